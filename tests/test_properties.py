"""Gateware equals golden over the legal parameter space: one hypothesis property per
stream block of the registry.

Each property draws a legal parameter set from the block's own :class:`~tdicam.blocks.Param`
ranges and checks (:meth:`~tdicam.blocks.Block.resolve`; a set it refuses is not drawn
again), at every ppc, biased toward the ends of each range (the widths where sums get
narrow or saturate), small frames of random, zero, full-scale and constant pixels, random
idle cycles and backpressure, and compares the Verilog top in Amaranth's simulator
(:func:`tdicam.cosim.run_scene`, the :mod:`tdicam.cosim.streamsim` loop) bit for bit with
the golden model. Short form (CI): a few examples a block and ppc; ``TDICAM_FULL=1``: many
more. ``tlk2711``'s property is in tests/test_tlk2711.py (it needs its own framing checks).
"""


import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from tdicam import blocks
from tdicam.beats import PPC_CHOICES
from tdicam.cosim import run_scene
from tdicam.cosim.testing import FULL
from tdicam.errors import TdicamError
from tdicam.model.hdr import MAX_PAIRS, MAX_RATIO
from tdicam.model.tdi import settings_valid

#: Examples a block and ppc in the short form (by the cost of one: the DDR model and
#: median3's line buffers are slow in Amaranth's simulator); ``TDICAM_FULL=1``: this many
#: times :data:`FULL_FACTOR`.
EXAMPLES = {"nuc": 100, "cds": 10, "hdr": 10, "tdi": 8, "secded_enc": 10, "secded_dec": 10,
            "median3": 3, "cds_ddr": 3, "nuc_ddr": 3}
FULL_FACTOR = 10

#: Stream blocks whose property lives elsewhere or that this module cannot run, and why.
ELSEWHERE = {
    "tlk2711": "tests/test_tlk2711.py test_gateware_equals_golden_property",
    "calib": "coefficient words, not frames: tests/test_calib.py",
    "nand_store": "a flash part model: tests/test_nand_store.py",
    "ddr": "DDR buffer: tests/test_ddr.py",
    "tdi_ddr": "DDR partial sums: tests/test_tdi.py, tests/test_ddr.py",
}


def _ints(p, hi=None, corners=False):
    """Integers of ``p``'s range (``hi`` caps it for the simulation's cost), two draws in
    three at its ends: the narrowest or widest formats, where sums and clamps break;
    ``corners``: only its two ends."""
    lo, top = p.lo, p.hi if hi is None else min(p.hi, hi)
    if corners:
        return st.sampled_from(sorted({lo, top}))
    edges = sorted({lo, min(lo + 1, top), max(top - 1, lo), top})
    return st.one_of(st.sampled_from(sorted({lo, top})), st.sampled_from(edges),
                     st.integers(lo, top))


def _param(p, caps, corners):
    if p.choices is not None:
        return st.sampled_from(p.choices)
    if p.type is bool:
        return st.booleans()
    s = _ints(p, caps.get(p.name), corners)
    # (an optional parameter, derived when not given: given in three draws in four)
    return st.one_of(s, s, s, st.none()) if p.default is None else s


def _legal(draw, blk, fixed, caps=None, skip=()):
    """A parameter set of ``blk``: ``fixed`` as given, the rest drawn from their ranges
    (in half of the sets every integer at one end of its range: a corner of the space)."""
    corners = draw(st.booleans(), "corners")
    given_ = {p.name: draw(_param(p, caps or {}, corners), p.name) for p in blk.params
              if p.name not in fixed and p.name not in skip and p.type is not str}
    given_ = {k: v for k, v in given_.items() if v is not None}
    try:
        return blk.resolve({**given_, **fixed})
    except TdicamError:
        assume(False)


def _frames(draw, rng, n, shape, full, dtype=np.uint16):
    """``n`` frames of ``shape``: random, zeros, full scale or a constant, by a draw each."""
    out = []
    for _ in range(n):
        kind = draw(st.sampled_from(["random", "random", "zeros", "full", "const"]))
        out.append({"random": lambda: rng.integers(0, full + 1, shape),
                    "zeros": lambda: np.zeros(shape, np.int64),
                    "full": lambda: np.full(shape, full),
                    "const": lambda: np.full(shape, rng.integers(0, full + 1))}[kind]())
    return np.stack(out).astype(dtype)


# -------------------------------------------------- one input strategy per block


def _param_of(blk, name):
    return next(p for p in blk.params if p.name == name)


def _cds(draw, blk, ppc, rng):
    p = _legal(draw, blk, {"ppc": ppc})
    shape = (draw(st.integers(1, 3)), ppc * draw(st.integers(1, 3)))
    n, full = draw(st.integers(1, 3)), (1 << p["pixel_bits"]) - 1
    return p, {"signal": _frames(draw, rng, n, shape, full),
               "reset": _frames(draw, rng, n, shape, full)}


def _nuc(draw, blk, ppc, rng):
    from tdicam.blocks.nuc import _fmt
    fixed = {"ppc": ppc}
    if draw(st.sampled_from([False, False, False, True]), "narrow sum, widest output"):
        # the narrowest pixel and gain integer part into the widest output
        fixed.update({k: _param_of(blk, k).lo for k in ("pixel_bits", "gain_int_bits")},
                     out_bits=_param_of(blk, "out_bits").hi)
    p = _legal(draw, blk, fixed)
    fmt = _fmt(p)
    shape = (n := draw(st.integers(1, 2)), draw(st.integers(1, 3)), ppc * draw(st.integers(1, 3)))
    full = (1 << p["pixel_bits"]) - 1
    x = _frames(draw, rng, n, shape[1:], full)
    gain, off = _coeffs(draw, rng, fmt, shape)
    return p, {"x": x, "gain": gain.astype(np.uint32), "offset": off.astype(np.int32)}


def _coeffs(draw, rng, fmt, shape):
    """(gain, offset) codes of ``shape``: random, extreme or unity, by a draw."""
    kind = draw(st.sampled_from(["random", "extreme", "unity"]))
    if kind == "unity":
        return np.full(shape, fmt.gain_one), np.zeros(shape, np.int64)
    g = [0, 1, fmt.gain_one, fmt.gain_max] if kind == "extreme" else None
    o = [fmt.offset_min, -1, 0, 1, fmt.offset_max] if kind == "extreme" else None
    gain = rng.choice(g, shape) if g else rng.integers(0, fmt.gain_max + 1, shape)
    off = rng.choice(o, shape) if o else rng.integers(fmt.offset_min,
                                                      fmt.offset_max + 1, shape)
    return gain, off


def _hdr(draw, blk, ppc, rng):
    pairs = draw(st.lists(st.tuples(st.integers(1, 64), st.integers(1, 64)),
                          min_size=1, max_size=MAX_PAIRS), "gain pairs")
    pairs = [(max(a, b), min(a, b)) for a, b in pairs if max(a, b) / min(a, b) < MAX_RATIO]
    assume(pairs)
    fixed = {"ppc": ppc, "gain_pairs": ",".join(f"{a}:{b}" for a, b in pairs),
             "anchor": draw(st.sampled_from(_param_of(blk, "anchor").choices), "anchor")}
    p = _legal(draw, blk, fixed, skip=("threshold", "band"))
    full = (1 << p["pixel_bits"]) - 1
    if draw(st.booleans(), "threshold given"):
        t = draw(st.one_of(st.sampled_from([1, full]), st.integers(1, full)), "threshold")
        b = draw(st.one_of(st.sampled_from([1, t]), st.integers(1, t)), "band")
        p = _legal(draw, blk, {**p, "threshold": t, "band": b})
    shape = (draw(st.integers(1, 3)), ppc * draw(st.integers(1, 3)))
    n = draw(st.integers(1, 4))
    sel = rng.integers(0, 1 << (len(pairs) - 1).bit_length(), n)
    return p, {"hg": _frames(draw, rng, n, shape, full), "lg": _frames(draw, rng, n, shape, full),
               "gain_sel": sel}


def _median3(draw, blk, ppc, rng):
    w = max(ppc * draw(st.integers(1, 4)), _param_of(blk, "width").lo)
    p = _legal(draw, blk, {"ppc": ppc, "width": w, "enhance": draw(st.booleans(), "enhance")})
    full = (1 << p["pixel_bits"]) - 1
    rows = draw(st.integers(1, 6))
    return p, {"frames": _frames(draw, rng, draw(st.integers(1, 2)), (rows, w), full)}


def _tdi(draw, blk, ppc, rng):
    w = ppc * draw(st.integers(2, 3))
    p = _legal(draw, blk, {"ppc": ppc, "width": w}, caps={"stages": 128 if FULL else 9})
    m = draw(st.integers(1, p["stages"]), "stages_active")
    d = draw(st.sampled_from([0, 1]), "direction")
    assume(settings_valid(m, d, p["stages"]))
    full = (1 << p["pixel_bits"]) - 1
    n = draw(st.integers(1, 4))
    return p, {"frames": _frames(draw, rng, n, (m, w), full), "stages": m, "direction": d}


def _secded_enc(draw, blk, ppc, rng):
    p = _legal(draw, blk, {"stream": True})
    n = draw(st.integers(1, 20))
    data = rng.integers(0, 1 << 64, n, dtype=np.uint64)
    data[:: 3] = draw(st.sampled_from([0, (1 << 64) - 1]))
    return p, {"data": data}


def _secded_dec(draw, blk, ppc, rng):
    from tdicam.model import ecc
    p = _legal(draw, blk, {"stream": True})
    n = draw(st.integers(1, 20))
    data = rng.integers(0, 1 << 64, n, dtype=np.uint64)
    data[:: 3] = draw(st.sampled_from([0, (1 << 64) - 1]))
    k = rng.integers(0, 4, n)                   # 0..3 flipped bits
    pos = np.stack([np.where(k > j, rng.permutation(72)[:n] if n <= 72 else
                             rng.integers(0, 72, n), -1) for j in range(3)], axis=1)
    pos[:, 1] = np.where(pos[:, 1] == pos[:, 0], -1, pos[:, 1])
    pos[:, 2] = np.where((pos[:, 2] == pos[:, 0]) | (pos[:, 2] == pos[:, 1]), -1, pos[:, 2])
    d, c = ecc.flip(data, ecc.encode(data), pos)
    return p, {"data_in": d, "check_in": c}


#: the MIG model's stall settings a DDR block's property draws within (short latencies and
#: refresh periods: stalls every few lines of a small frame)
_DDR_CAPS = {"lat_lo": 30, "lat_hi": 30, "refresh_period": 200, "refresh_cycles": 30,
             "base": 1 << 16, "line_stride": 1 << 12}


def _ddr_frames(draw, blk, ppc, first_kinds):
    """A DDR block's parameters (small frames, the MIG model's stalls within
    :data:`_DDR_CAPS`), its frame shape and count, full scale and the frames' kinds (the
    first drawn from ``first_kinds``, then a stored frame in three)."""
    w = ppc * draw(st.integers(1, 3))
    rows = draw(st.integers(1, 3))
    p = _legal(draw, blk, {"ppc": ppc, "width": w, "rows": rows}, caps=_DDR_CAPS,
               skip=("seed",))
    n, full = draw(st.integers(2, 4)), (1 << p["pixel_bits"]) - 1
    kinds = np.array([draw(st.sampled_from(first_kinds))] +
                     [draw(st.sampled_from([0, 0, 1])) for _ in range(n - 1)], np.int64)
    return p, (n, rows, w), full, kinds


def _cds_ddr(draw, blk, ppc, rng):
    p, (n, rows, w), full, kinds = _ddr_frames(draw, blk, ppc, [1])
    return p, {"frames": _frames(draw, rng, n, (rows, w), full), "kinds": kinds}


def _nuc_ddr(draw, blk, ppc, rng):
    from tdicam.blocks.nuc_ddr import _fmt
    p, (n, rows, w), full, kinds = _ddr_frames(draw, blk, ppc, [0, 1, 1])
    gain, off = _coeffs(draw, rng, _fmt(p), (n, rows, w))
    return p, {"x": _frames(draw, rng, n, (rows, w), full), "gain": gain, "offset": off,
               "kinds": kinds}


STRATEGIES = {"cds": _cds, "nuc": _nuc, "hdr": _hdr, "median3": _median3, "tdi": _tdi,
              "secded_enc": _secded_enc, "secded_dec": _secded_dec, "cds_ddr": _cds_ddr,
              "nuc_ddr": _nuc_ddr}
#: Blocks without a ppc parameter run once (ppc 1 only).
ONE_PPC = {"secded_enc", "secded_dec"}
CASES = [(name, ppc) for name in sorted(STRATEGIES) for ppc in PPC_CHOICES
         if ppc == 1 or name not in ONE_PPC]


def test_every_stream_block_has_a_property():
    """A block added to the registry with a stream co-simulation gets a property here (or
    a line in :data:`ELSEWHERE` saying where it has one)."""
    stream = {b.name for b in blocks.all_blocks() if b.streams.to_beats is not None}
    assert stream == set(STRATEGIES) | set(ELSEWHERE), stream ^ (set(STRATEGIES) | set(ELSEWHERE))


def _check(name, ppc, data):
    blk = blocks.get(name)
    seed = data.draw(st.integers(0, 2**16), "seed")
    params, arrays = STRATEGIES[name](data.draw, blk, ppc, np.random.default_rng(seed))
    idle = data.draw(st.sampled_from([0.0, 0.3, 0.7]), "idle")
    bp = data.draw(st.sampled_from([0.0, 0.3, 0.7]), "backpressure")
    run, _ = run_scene(blk, arrays, params, sim="amaranth", idle=idle, backpressure=bp,
                       seed=seed + 1)
    assert run.ok, f"{name} {params}: {run.message()}"


@pytest.mark.parametrize("name,ppc", CASES)
def test_gateware_equals_golden(name, ppc):
    n = EXAMPLES[name] * (FULL_FACTOR if FULL else 1)
    run = settings(max_examples=n, deadline=None, derandomize=not FULL, database=None,
                   print_blob=True,              # a FULL run's failure replays from its blob
                   suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])(
        given(data=st.data())(lambda data: _check(name, ppc, data)))
    run()


#: A narrow sum with a wide output at ppc 1 (the clamp's constant once truncated to the
#: sum's width: every pixel saturated).
NUC_NARROW = [{"pixel_bits": 8, "gain_int_bits": 1, "gain_frac_bits": 4, "offset_bits": 2,
               "offset_frac_bits": 0, "out_bits": 16},
              {"pixel_bits": 8, "gain_int_bits": 1, "gain_frac_bits": 4, "offset_bits": 9,
               "offset_frac_bits": 6, "out_bits": 20}]


@pytest.mark.parametrize("params", NUC_NARROW)
def test_nuc_narrow_sum_wide_output(params):
    """x = 121 at gain 2/16, offset 0: 15 (not full scale) in every pixel."""
    blk = blocks.get("nuc")
    shape = (1, 3, 8)
    arrays = {"x": np.full(shape, 121, np.uint16), "gain": np.full(shape, 2, np.uint32),
              "offset": np.zeros(shape, np.int32)}
    run, out = run_scene(blk, arrays, {**params, "ppc": 1}, sim="amaranth", idle=0.2,
                         backpressure=0.2)
    assert run.ok, run.message()
    assert (out["out"] == 15).all()


#: The slowest legal memory model (each ready granted with probability 1/256) with one
#: reset value a DDR word at ppc 8: eight words a beat (found by the TDICAM_FULL property).
SLOWEST_DDR = {"width": 8, "rows": 3, "pixel_bits": 8, "pixels_per_word": 1, "ppc": 8,
               "base": 0, "capacity_mib": 1, "lat_lo": 2, "lat_hi": 2, "refresh_period": 200,
               "refresh_cycles": 0, "drop": 255, "seed": 1}


def test_ddr_block_at_the_slowest_memory_finishes():
    """The run's cycle budget grows with the memory model's stalls (it used to stop at
    n_in * 20 + 10,000 cycles and report the missing output as mismatches)."""
    frames = np.random.default_rng(0).integers(0, 256, (2, 3, 8)).astype(np.uint16)
    arrays = {"frames": frames, "kinds": np.array([1, 0])}
    run, _ = run_scene(blocks.get("cds_ddr"), arrays, SLOWEST_DDR, sim="amaranth")
    assert run.ok, run.message()
    assert run.result.cycles > 10_120


def test_an_amaranth_run_out_of_cycles_says_timed_out():
    frames = np.random.default_rng(0).integers(0, 256, (2, 3, 8)).astype(np.uint16)
    run, _ = run_scene(blocks.get("cds_ddr"), {"frames": frames, "kinds": np.array([1, 0])},
                       SLOWEST_DDR, sim="amaranth", max_cycles=2000)
    assert not run.ok and run.result.timeout
    assert "timed out after 200" in run.message()
