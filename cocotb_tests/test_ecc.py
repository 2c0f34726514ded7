"""Co-simulation of the generated SECDED encoder/decoder Verilog against the golden model.

The exhaustive sweep runs through the decoder's stream wrapper (``--stream 1``) in fast
mode: every sweep word error-free, with each of its 72 single flips and each of its 2,556
double flips (64 words = 168,256 code words; 256 with ``TDICAM_FULL=1``).

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import os

import numpy as np
import pytest

from tdicam import blocks
from tdicam.blocks.secded_dec import dec_beats, sweep_codes
from tdicam.blocks.secded_enc import enc_beats
from tdicam.cosim.testing import check_beats
from tdicam.model import ecc

FULL = os.environ.get("TDICAM_FULL") == "1"


def _params(block, registered, pipelined=False):
    given = {"stream": True, "registered": registered}
    if pipelined:
        given["pipelined"] = True
    return blocks.get(block).resolve(given)


@pytest.mark.parametrize("registered,pipelined", [(False, False), (True, False), (True, True)])
def test_exhaustive_sweep(sim, registered, pipelined):
    """All single and double flips of >= 64 words: singles corrected with the flag, doubles
    flagged uncorrectable and never 'corrected', error-free words untouched."""
    n_words = 256 if FULL else 64
    words = ecc.sweep_words(n_words)
    d, c, n_flips = sweep_codes(words)
    stim, exp = dec_beats(d, c)
    res = check_beats("secded_dec", _params("secded_dec", registered, pipelined), stim, exp,
                      sim=sim, mode="fast", idle=0.1, backpressure=0.1, seed=5 + registered)
    # the simulator's own output against the claim (not only against the model)
    out = res.out.data.astype(np.uint64)
    data = np.zeros(len(out), np.uint64)
    for k in range(8):
        data |= out[:, k] << np.uint64(8 * k)
    corrected, uncorrectable = (out[:, 9] & 1) == 1, (out[:, 9] & 2) == 2
    orig = np.repeat(words, 2629)
    ok = n_flips <= 1
    assert len(out) == n_words * 2629
    np.testing.assert_array_equal(data[ok], orig[ok])
    assert not corrected[n_flips == 0].any() and not uncorrectable[n_flips == 0].any()
    assert (out[n_flips == 0, 8] == 0).all()
    assert corrected[n_flips == 1].all() and not uncorrectable[n_flips == 1].any()
    assert uncorrectable[n_flips == 2].all() and not corrected[n_flips == 2].any()
    assert (n_flips == 2).sum() == 2556 * n_words


@pytest.mark.parametrize("registered", [False, True])
def test_encoder_sweep(sim, registered):
    rng = np.random.default_rng(3)
    data = np.concatenate([ecc.sweep_words(256), rng.integers(0, 1 << 64, 20000,
                                                              dtype=np.uint64)])
    stim, exp = enc_beats(data)
    check_beats("secded_enc", _params("secded_enc", registered), stim, exp, sim=sim,
                mode="fast", idle=0.2, backpressure=0.2, seed=9)


@pytest.mark.parametrize("idle,bp", [(0.0, 0.0), (0.0, 0.9), (0.9, 0.0)])
def test_extreme_stalls(sim, idle, bp):
    d, c, _ = sweep_codes(ecc.sweep_words(2))
    stim, exp = dec_beats(d, c)
    res = check_beats("secded_dec", _params("secded_dec", True), stim, exp, sim=sim,
                      mode="fast", idle=idle, backpressure=bp, seed=3)
    if idle == bp == 0.0:
        # one code word per clock: n transfers + latency 2 + the 2000-cycle drain window
        assert res.cycles <= len(stim) + 2 + 2000 + 2
