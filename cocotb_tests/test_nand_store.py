"""Co-simulation of the generated ``nand`` store Verilog (with the simulation model of the
part attached) against its golden model.

Every golden case runs in fast mode on Verilator (clean part; 1, 10 and 100 random bad
blocks; a grown bad block after a program failure; one flipped bit in every word of every
page; double flips defaulting exactly 4 coefficients; more bad blocks than the stream's
blocks -> ``error``; the production build). Short forms: Icarus fast mode on the clean,
100-bad-block, grown, double-flip and out-of-blocks cases; per-beat mode on the clean,
double-flip and 100-bad-block cases on Verilator, clean and double on Icarus; every case on
both with ``TDICAM_FULL=1``. Besides the
golden cases, a round trip checks the outputs against the original maps, not only the
model.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import os

import numpy as np

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.blocks.nand_store import load_beats, store_beats
from tdicam.cosim.testing import check_beats
from tdicam.model import calib, nand_store
from tdicam.model.nuc import DEFAULT_FORMAT as FMT

FULL = os.environ.get("TDICAM_FULL") == "1"


def test_cases_exercise_what_they_claim():
    """The golden cases really hold what their names say (a case that cannot fail is a
    defect): bad-block counts, the grown block, every word corrected, doubles defaulted."""
    arr = {c.name: golden.load("nand_store", c.name)[0] for c in blocks.get("nand_store").cases()}
    assert [int(arr[c]["bad_blocks"]) for c in ("clean", "bad1", "bad10", "bad100")] == \
        [0, 1, 10, 100]
    assert arr["bad1"]["l2p"][0] != 1 or arr["bad1"]["l2p"][1] != 2  # skipped a data block
    assert arr["grown"]["bad"][1] and arr["grown"]["l2p"][0] == 2
    n = calib.HEADER_WORDS + calib.payload_words(30, 40)
    assert int(arr["single_every_word"]["out_corrected"][-1]) == n
    assert not arr["single_every_word"]["out_defaulted"].any()
    d = arr["double"]
    k = d["flips"]
    assert (k == 2).sum() > 20 and int(d["out_uncorrectable"][-1]) == (k == 2).sum()
    assert d["out_defaulted"].sum() == 2 * (k == 2).sum()  # 2 pixels = 4 coefficients each
    assert not arr["out_of_blocks"]["complete"] and len(arr["out_of_blocks"]["out_gain"]) \
        == 2 * (nand_store.Geometry(pages_per_block=2, blocks=128).words_per_block
                - calib.HEADER_WORDS)


def test_round_trip_against_maps(sim):
    """Maps -> image with doubles and bad blocks -> NAND -> store Verilog -> the maps back:
    exact where the word was clean or corrected, gain 1.0 / offset 0 for exactly the two
    pixels of each uncorrectable word."""
    params = blocks.get("nand_store").resolve(blocks.get("nand_store").cases()[0].params)
    rng = np.random.default_rng(31)
    g_val = 1 + 0.1 * rng.standard_normal((30, 40))
    o_val = 50 * rng.standard_normal((30, 40))
    g, o = calib.codes_from_values(g_val, o_val, FMT)
    words, k = calib.inject_flips(rng, calib.encode_image(g, o, FMT), p_single=0.3,
                                  p_double=0.1)
    geo = nand_store.Geometry(pages_per_block=2, blocks=128)
    dev = nand_store.write_store(words, geo, bad_blocks=rng.choice(np.arange(1, 128), 30,
                                                                   replace=False))
    out, sr, _ = nand_store.store_stream(dev, rows=30, cols=40, fmt=FMT)
    exp = {f: getattr(out, f) for f in ("gain", "offset", "corrected", "uncorrectable",
                                        "defaulted", "header_error", "first", "last")}
    exp["bad_blocks"] = sr.bad_count
    stim, want = store_beats(load_beats(dev, params["slots"]), exp, params)
    res = check_beats("nand_store", params, stim, want, sim=sim, mode="fast", idle=0.2,
                      backpressure=0.2, seed=3)
    got = res.out.data.astype(np.int64)
    bad = np.repeat(k[calib.HEADER_WORDS:] == 2, 2)[:1200]
    assert bad.sum() >= 100
    np.testing.assert_array_equal(got[~bad, 0], g.ravel()[~bad])
    np.testing.assert_array_equal(got[~bad, 1], (o.ravel() & 0xFFFF)[~bad])
    assert (got[bad, 0] == FMT.gain_one).all() and (got[bad, 1] == 0).all()
    assert (got[:, 5] == 30).all()
