"""Block ``nand_store``: the calibration store in NAND flash (Ning et al. 2019 §4.3).

(Not ``nand``: the Verilog top is named after the block, and ``nand`` is a Verilog gate
primitive.)

``hdl/nand.py`` (:class:`~tdicam.hdl.nand_store.NandCalibTop`: the store, with the simulation
model of the part attached when ``--device 1``), ``model/nand.py`` (device, stored image,
golden model :func:`~tdicam.model.nand_store.store_stream`), ``cocotb_tests/test_nand_store.py``,
``golden/nand_store/``. The stimulus loads the part's contents into the simulation model
(:func:`load_beats`) and ends with the start beat; the output is the coefficient stream
of :class:`~tdicam.hdl.calib.CalibReader` (plus, with ``--debug 1``, its counters and
flags and the bad-block count).
"""

import numpy as np

from tdicam.beats import Beats
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.nand_store import (LOAD_GO, LOAD_MARKER, LOAD_PAGE, LOAD_SLOT, MAX_SLOTS,
                                   NandCalibTop)
from tdicam.model import calib, nand_store
from tdicam.model.nuc import NucFormat
from tdicam.errors import TdicamError
from tdicam.blocks import SynthRef
from tdicam.blocks import Block, Case, Param, Streams, Suite
from tdicam.blocks.calib import BLOCK as CALIB, code_maps, random_codes

__all__ = ["BLOCK", "load_beats", "store_beats", "geometry_of", "TEST_PART"]

# ---- top
_FMT_KEYS = ("gain_int_bits", "gain_frac_bits", "offset_bits", "offset_frac_bits")
_OUT_FIELDS = ("gain", "offset", "corrected", "uncorrectable", "defaulted", "header_error",
               "first", "last")


def _fmt(params):
    return NucFormat(*(params[k] for k in _FMT_KEYS))


def geometry_of(params):
    """The :class:`~tdicam.model.nand_store.Geometry` of a parameter dict."""
    return nand_store.Geometry(page_bytes=params["page_bytes"],
                               pages_per_block=params["pages_per_block"], blocks=params["blocks"])


def _check(params):
    _fmt(params)._check_slots()
    g = geometry_of(params)
    if params["device"]:       # the simulation model holds the image's programmed pages
        need = nand_store.programmed_pages(
            calib.HEADER_WORDS + calib.payload_words(params["rows"], params["cols"]), g)
        if need > params["slots"]:
            raise TdicamError(f"slots = {params['slots']}: the {params['rows']} x "
                              f"{params['cols']} image and its block map program {need} pages "
                              f"of {params['page_bytes']} bytes; give slots >= {need}")


def _top(**params):
    return AxisTop(NandCalibTop(**params))


# ---- cases
def load_beats(device, slots):
    """Loader words (uint64 array) putting ``device``'s contents into the simulation model:
    one slot per page with data, the data bytes that are not ``0xFF``, the markers that are
    not ``0xFF``. Raises when the part holds more pages than ``slots``."""
    g = device.geometry
    rows = [r for r in sorted(device.pages) if (device.pages[r][:g.page_bytes] != 0xFF).any()]
    if len(rows) > slots:
        raise TdicamError(f"nand: the image holds {len(rows)} programmed pages, the simulation "
                          f"model {slots} slots")
    out = []
    for k, r in enumerate(rows):
        data = device.pages[r][:g.page_bytes]
        col = np.nonzero(data != 0xFF)[0]
        out.append((LOAD_SLOT << 30) | (r << 8) | (k + 1))
        out.extend(((LOAD_PAGE << 30) | ((k * g.page_bytes + col) << 8) | data[col]).tolist())
    for b in device.bad_blocks():
        out.append((LOAD_MARKER << 30) | (b << 8) | device.marker(b))
    return np.array(out, np.uint64)


def store_beats(loader, exp, params):
    """(stimulus, expected) Beats: the loader words and the start beat; the coefficient
    stream ``exp`` (dict of :class:`~tdicam.model.calib.ReaderOutput` fields and
    ``bad_blocks``)."""
    words = np.concatenate([np.asarray(loader, np.uint64), [np.uint64(LOAD_GO << 30)]])
    n = len(words)
    as_bytes = (words[:, None] >> (np.arange(4, dtype=np.uint64) * np.uint64(8))) & np.uint64(0xFF)
    stim = Beats(as_bytes, np.arange(n) == 0, np.arange(n) == n - 1)
    cols = [exp["gain"], exp["offset"]]
    if params["debug"]:
        flags = exp["defaulted"].astype(np.uint64) | (exp["header_error"].astype(np.uint64) << 1)
        cols += [exp["corrected"], exp["uncorrectable"], flags,
                 np.full(len(flags), int(exp["bad_blocks"]))]
    return stim, Beats(np.stack([np.asarray(c, np.uint64) for c in cols], axis=1),
                       exp["first"], exp["last"])


def _beats(arrays, params):
    exp = {f: arrays[f"out_{f}"] for f in _OUT_FIELDS}
    exp["bad_blocks"] = arrays["bad_blocks"]
    return store_beats(arrays["loader"], exp, params)


def _case(build):
    """``build(params, rng, words)`` -> NandDevice holding the stream ``words``."""
    def make(params, rng):
        fmt = _fmt(params)
        g, o = random_codes(rng, params["rows"], params["cols"], fmt)
        words = calib.encode_image(g, o, fmt)
        dev, flips = build(params, rng, words)
        out, sr, complete = nand_store.store_stream(dev, rows=params["rows"], cols=params["cols"],
                                                    fmt=fmt, count_bits=params["count_bits"])
        arrays = {"gain_map": g, "offset_map": o, "flips": np.asarray(flips, np.uint8),
                  "loader": load_beats(dev, params["slots"]),
                  "bad": sr.bad, "l2p": sr.l2p, "bad_blocks": np.int64(sr.bad_count),
                  "complete": np.bool_(complete)}
        arrays.update({f"out_{f}": getattr(out, f) for f in _OUT_FIELDS})
        return arrays
    return make


def _bad(n, first_blocks=None):
    """``n`` random factory bad blocks (in 1..first_blocks when given, else anywhere)."""
    def build(params, rng, words):
        top = first_blocks or params["blocks"] - 1
        bad = rng.choice(np.arange(1, top + 1), n, replace=False)
        return nand_store.write_store(words, geometry_of(params), bad_blocks=bad), \
            np.zeros(len(words))
    return build


def _grown(params, rng, words):
    """Block 1 fails program (marked bad by the writer), block 3 factory bad."""
    dev = nand_store.write_store(words, geometry_of(params), bad_blocks=[3], fail_program=[1])
    assert dev.grown == [1]
    return dev, np.zeros(len(words))


def _flips(p_single, p_double, every=False):
    def build(params, rng, words):
        if every:  # one flipped bit in every word of every page, header included
            pos = rng.integers(0, 72, len(words))
            words, k = calib.flip_image_bits(words, pos[:, None]), np.ones(len(words))
        else:
            words, k = calib.inject_flips(rng, words, p_single=p_single, p_double=p_double)
        return nand_store.write_store(words, geometry_of(params), bad_blocks=[2]), k
    return build


def _out_of_blocks(params, rng, words):
    """Written on a clean part, then every block after the first data block went bad: the
    store reads one logical block and stops with ``error``."""
    g = geometry_of(params)
    dev = nand_store.write_store(words, g)
    for b in range(2, g.blocks):
        dev.mark_bad(b)
    return dev, np.zeros(len(words))


def _to_case(arrays, params):
    """Scene arrays ``{"words": one flash image}`` -> case arrays: the image written on a
    clean part of the block's geometry, the loader words and the store's golden output."""
    words = np.asarray(arrays["words"], np.uint64)
    dev = nand_store.write_store(words, geometry_of(params))
    out, sr, complete = nand_store.store_stream(dev, rows=params["rows"], cols=params["cols"],
                                                fmt=_fmt(params), count_bits=params["count_bits"])
    case = {"words": words, "loader": load_beats(dev, params["slots"]),
            "bad_blocks": np.int64(sr.bad_count), "complete": np.bool_(complete)}
    case.update({f"out_{f}": getattr(out, f) for f in _OUT_FIELDS})
    return case


def _golden(arrays, params):
    """The store's (gain, offset) code maps after power-up from a clean part: uint64
    ``(1, rows, cols)`` each (offset as its ``offset_bits`` two's-complement code)."""
    case = _to_case(arrays, params)
    return code_maps(case["out_gain"], case["out_offset"], params)


def _example(rng, n, shape, params):
    """One clean flash image of random codes for the block's rows x cols (the part holds
    one calibration image: ``n`` and ``shape`` are ignored)."""
    fmt = _fmt(params)
    return {"words": calib.encode_image(*random_codes(rng, params["rows"], params["cols"],
                                                      fmt), fmt)}


#: the test part: 2,048 + 64-byte pages as the real part, 2 pages per block, 128 blocks
TEST_PART = {"page_bytes": 2048, "pages_per_block": 2, "blocks": 128}
_DBG = {"rows": 30, "cols": 40, "debug": True, "device": True, **TEST_PART}
_PLAIN = {"rows": 30, "cols": 40, "device": True, **TEST_PART}


def _cases():
    return [
        Case("clean", _DBG, _case(_bad(0)), seed=1),
        Case("bad1", _DBG, _case(_bad(1, first_blocks=2)), seed=2, tags=("bad",)),
        Case("bad10", _DBG, _case(_bad(10)), seed=3, tags=("bad",)),
        Case("bad100", _DBG, _case(_bad(100)), seed=4, tags=("bad",)),
        Case("grown", _DBG, _case(_grown), seed=5, tags=("bad", "grown")),
        Case("single_every_word", _DBG, _case(_flips(0, 0, every=True)), seed=6,
             tags=("single",)),
        Case("double", _DBG, _case(_flips(0.2, 0.2)), seed=7, tags=("single", "double")),
        Case("out_of_blocks", _DBG, _case(_out_of_blocks), seed=8, tags=("error",)),
        Case("clean_plain", _PLAIN, _case(_bad(3)), seed=9),
    ]


#: The short form of the standard co-simulation suite (every case with TDICAM_FULL=1):
#: the cases Icarus runs in fast mode, and each simulator's per-beat cases.
ICARUS_FAST = ("clean", "bad100", "grown", "double", "out_of_blocks")
PER_BEAT = {"icarus": ("clean", "double"), "verilator": ("clean", "double", "bad100")}


def _full_only(case, sim, mode):
    if mode == "beat":
        return case.name not in PER_BEAT[sim]
    return sim == "icarus" and case.name not in ICARUS_FAST


# ---- entry
BLOCK = Block(
    name="nand_store",
    summary="calibration store in NAND flash: power-up bad-block scan, block map, pages "
            "through SECDED into the nuc coefficient stream (Ning et al. 2019 §4.4.4, §4.3)",
    params=(
        *(p for p in CALIB.params if p.name != "debug"),  # the reader's, as block calib
        Param("debug", False, "carry counters, flags and the bad-block count on every pixel",
              type=bool),
        Param("page_bytes", 2048, "data bytes per page (power of two)", lo=512, hi=16384),
        Param("pages_per_block", 64, "pages per block (power of two)", lo=1, hi=256),
        Param("blocks", 4096, "blocks of the part", lo=2, hi=65536),
        Param("device", False, "attach the simulation model of the part (co-simulation); "
                               "else the bus is ports", type=bool),
        Param("slots", 8, "programmed pages the simulation model holds", lo=1, hi=MAX_SLOTS),
        Param("busy_cycles", 16, "simulation model: R/B# low time after 30h/FFh (t_R)",
              lo=3, hi=65535),
    ),
    top=_top,
    cases=_cases,
    streams=Streams(
        to_beats=_beats,
        stream="words",
        golden=_golden,
        to_case=_to_case,
        unstream=CALIB.streams.unstream,
        example=_example,
        frame_beats=lambda p: calib.HEADER_WORDS + calib.payload_words(p["rows"], p["cols"]),
        small=((), {"rows": 3, "cols": 5, "device": True, "page_bytes": 2048,
                      "pages_per_block": 2, "blocks": 16}),
        reset_clears_state=False,  # the part's simulation model keeps its pages across reset,
    ),
    check=_check,
    model_version="nand-1",
    order=91,
    synth=(SynthRef("nand_store", note="3800 x 5144 from 4 Gb NAND, bus as ports"),),
    suite=Suite(full_only=_full_only),
)
