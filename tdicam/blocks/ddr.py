"""Blocks ``ddr``, ``cds_ddr``, ``tdi_ddr``: DDR line/frame buffers and their users
(SPEC 3.8; :mod:`tdicam.hdl.ddr`, :mod:`tdicam.model.ddr`).

Each Verilog top is the user logic with the simulation-only controller model
:class:`~tdicam.hdl.mig_model.MigModel` behind it (:class:`~tdicam.hdl.mig_model.SimTop`), so the fast
co-simulation runs the whole round trip in the simulator; the stall pattern is a parameter
set (default :data:`tdicam.model.ddr.DEFAULT_STALLS`: latency 20..60, refresh 26 of every 780
cycles, each ready dropped with probability 16/256). ``ddr_error`` (the model's sticky
error) blocks the input, so a bad access shows as a stalled run.

* ``ddr`` — :class:`~tdicam.hdl.ddr.DdrFrameBuffer`: output = input after DDR.
* ``cds_ddr`` — :class:`~tdicam.hdl.cds_ddr.CdsDdr`: reset frames stored, signal frames
  subtracted (``frame_kind`` rides with each beat).
* ``tdi_ddr`` — :class:`~tdicam.hdl.tdi_ddr.TdiDdr`: the ``tdi`` block with its partial sums
  in DDR; golden vectors from the same :func:`~tdicam.model.tdi.tdi_stream`.
"""

import numpy as np

from ..cosim.codec import Beats, frames_to_beats, mark_resets
from ..errors import TdicamError
from ..hdl.axis import AxisTop
from ..model.cds import pixel_dtype
from ..model.ddr import (ADDR_PER_WORD, DEFAULT_STALLS, LineLayout, _check_stalls,
                         cds_ddr_frames, check_capacity, tdi_ddr_check)
from ..model.tdi import check_params as tdi_check_params
from . import Block, Case, Param
from . import tdi as _tdi_block    # the tdi block's stimulus generators (looked up lazily)

__all__ = ["BLOCKS", "STALL_PARAMS", "stalls_of"]

STALL_PARAMS = (
    Param("lat_lo", DEFAULT_STALLS["lat_lo"], "model: shortest read latency, cycles", lo=2,
          hi=1000),
    Param("lat_hi", DEFAULT_STALLS["lat_hi"], "model: longest read latency, cycles", lo=2,
          hi=1000),
    Param("refresh_period", DEFAULT_STALLS["refresh_period"],
          "model: cycles between refresh starts", lo=1, hi=1 << 20),
    Param("refresh_cycles", DEFAULT_STALLS["refresh_cycles"],
          "model: cycles of each refresh (app_rdy low)", lo=0, hi=1 << 20),
    Param("drop", DEFAULT_STALLS["drop"],
          "model: each ready dropped with probability drop/256 per cycle", lo=0, hi=255),
    Param("seed", DEFAULT_STALLS["seed"], "model: stall pattern seed", lo=0,
          hi=0xFFFFFFFF),
)
_STALL_NAMES = tuple(p.name for p in STALL_PARAMS)


def stalls_of(p):
    """The stall-pattern parameters of a resolved parameter dict."""
    return {k: p[k] for k in _STALL_NAMES}


def _sim_top(core, words):
    from ..hdl.mig_model import SimTop
    return SimTop(core, depth_words=max(1, words), **core._stalls)


# ---------------------------------------------------------------------------------------
# ddr: frame buffer round trip
# ---------------------------------------------------------------------------------------

def _ddr_layout(p):
    return LineLayout(width=p["width"], channels=p["channels"], pixel_bits=p["pixel_bits"],
                      pixels_per_word=p["pixels_per_word"], line_stride=p["line_stride"],
                      base=p["base"])


def _ddr_check(p):
    _check_stalls(*(p[k] for k in _STALL_NAMES))
    lay = _ddr_layout(p)
    e = p["ppc"] * p["channels"]
    if p["width"] % p["ppc"]:
        raise TdicamError(f"width = {p['width']} is not a multiple of ppc = {p['ppc']}")
    ppw = p["pixels_per_word"]
    if ppw % e and e % ppw:
        raise TdicamError(f"ppc x channels = {e} values per beat and pixels_per_word = {ppw}:"
                          " one must divide the other")
    check_capacity(lay, p["rows"], p["capacity_mib"] << 20, "frame buffer")
    end = lay.end_addr(p["rows"])
    if end // ADDR_PER_WORD > 1 << 22:
        raise TdicamError(f"the simulation model holds at most {1 << 22} words (128 MiB); "
                          f"this buffer needs {end // ADDR_PER_WORD}")


def _ddr_top(*, width, rows, channels, ppc, pixel_bits, pixels_per_word, line_stride, base,
             capacity_mib, **stalls):
    from ..hdl.ddr import DdrFrameBuffer
    core = DdrFrameBuffer(width=width, rows=rows, channels=channels, elements=ppc * channels,
                          pixel_bits=pixel_bits, pixels_per_word=pixels_per_word,
                          line_stride=line_stride, base=base,
                          capacity_bytes=capacity_mib << 20)
    core._stalls = stalls
    return AxisTop(_sim_top(core, core.layout.end_addr(rows) // ADDR_PER_WORD))


def ddr_frames(rng, params, n, kind="random"):
    """(n, rows, width, channels) frames for the ``ddr`` block."""
    b = params["pixel_bits"]
    shape = (n, params["rows"], params["width"], params["channels"])
    if kind == "random":
        return rng.integers(0, 1 << b, shape).astype(pixel_dtype(b))
    full = (1 << b) - 1
    f = np.zeros(shape, pixel_dtype(b))
    f[1::2] = full
    return f


def _ddr_random(n, kind="random"):
    def make(params, rng):
        return {"frames": ddr_frames(rng, params, n, kind)}
    return make


def _ddr_reset(params, rng):
    """Reset at a line boundary in the middle of frame 1: the buffer passes every beat."""
    out = {"frames": ddr_frames(rng, params, 3)}
    line = params["width"] // params["ppc"]
    per = params["rows"] * line
    out["reset_before"] = np.array([per + (params["rows"] // 2) * line], np.int64)
    return out


def ddr_to_beats(arrays, params):
    fr = arrays["frames"]
    stim = frames_to_beats(fr, ppc=params["ppc"], channels=params["channels"])
    exp = frames_to_beats(fr, ppc=params["ppc"], channels=params["channels"])
    mark_resets(stim, exp, arrays.get("reset_before"))
    return stim, exp


def _ddr_p(width, rows, channels=1, ppc=1, pixel_bits=10, ppw=24, stride=None, **kw):
    return {"width": width, "rows": rows, "channels": channels, "ppc": ppc,
            "pixel_bits": pixel_bits, "pixels_per_word": ppw, "line_stride": stride,
            "base": kw.get("base", 0), "capacity_mib": kw.get("capacity_mib", 1024),
            **{k: kw.get(k, v) for k, v in DEFAULT_STALLS.items()}}


def _ddr_cases():
    return [
        Case("paper_72ch_4x6", _ddr_p(4, 6, channels=72), _ddr_random(3), seed=1,
             tags=("layout",)),
        Case("paper_72ch_table2", _ddr_p(170, 2, channels=72, stride=4096, base=8192),
             _ddr_random(2), seed=2, tags=("layout", "table2")),
        Case("mono_48x6_p8", _ddr_p(48, 6, ppc=8), _ddr_random(3), seed=3),
        Case("mono_50x4_p1", _ddr_p(50, 4), _ddr_random(3), seed=4, tags=("partial-word",)),
        Case("mono_96x4_p24", _ddr_p(96, 4, ppc=24), _ddr_random(3), seed=5),
        Case("fullscale_48x4_p2_12b", _ddr_p(48, 4, ppc=2, pixel_bits=12, ppw=20),
             _ddr_random(4, "fullscale"), seed=6, tags=("fullscale", "zeros")),
        Case("reset_mid_frame_48x6_p8", _ddr_p(48, 6, ppc=8), _ddr_reset, seed=8,
             tags=("reset",)),
        Case("mono_12x3_p2_nostall",
             _ddr_p(12, 3, ppc=2, drop=0, refresh_cycles=0, lat_lo=2, lat_hi=2),
             _ddr_random(3), seed=7),
    ]


# ---------------------------------------------------------------------------------------
# cds_ddr
# ---------------------------------------------------------------------------------------

def _cds_layout(p):
    ppw = p["pixels_per_word"]
    if ppw is None:
        ppw = 24 if p["pixel_bits"] == 10 else 256 // p["pixel_bits"]
    return LineLayout(width=p["width"], pixel_bits=p["pixel_bits"], pixels_per_word=ppw,
                      line_stride=p["line_stride"], base=p["base"])


def _cds_check(p):
    _check_stalls(*(p[k] for k in _STALL_NAMES))
    check_capacity(_cds_layout(p), p["rows"], p["capacity_mib"] << 20, "reset frame")


def _cds_top(*, width, rows, pixel_bits, pixels_per_word, line_stride, base, capacity_mib,
             **stalls):
    from ..hdl.cds_ddr import CdsDdr
    core = CdsDdr(width=width, rows=rows, pixel_bits=pixel_bits,
                  pixels_per_word=pixels_per_word, line_stride=line_stride, base=base,
                  capacity_bytes=capacity_mib << 20)
    core._stalls = stalls
    return AxisTop(_sim_top(core, core.layout.end_addr(rows) // ADDR_PER_WORD))


def cds_arrays(frames, kinds, params):
    frames = np.asarray(frames)
    kinds = np.asarray(kinds, np.int64)
    return {"frames": frames, "kinds": kinds,
            "out": cds_ddr_frames(frames, kinds, pixel_bits=params["pixel_bits"])}


def _cds_random(kinds):
    def make(params, rng):
        b = params["pixel_bits"]
        fr = rng.integers(0, 1 << b, (len(kinds), params["rows"], params["width"]))
        return cds_arrays(fr.astype(pixel_dtype(b)), kinds, params)
    return make


def _cds_hard(params, rng):
    """Zeros, full scale, reset > signal everywhere, reset == signal, then a random reset."""
    b = params["pixel_bits"]
    full = (1 << b) - 1
    shape = (params["rows"], params["width"])
    r = rng.integers(1, full + 1, shape)
    seq = [(np.zeros(shape), 1), (np.full(shape, full), 0), (np.full(shape, full), 1),
           (np.zeros(shape), 0), (np.full(shape, full), 0), (r, 1), (r - 1, 0), (r, 0),
           (np.zeros(shape), 1), (np.zeros(shape), 0)]
    fr = np.stack([s for s, _ in seq]).astype(pixel_dtype(b))
    return cds_arrays(fr, [k for _, k in seq], params)


def _cds_reset(params, rng):
    out = _cds_random([1, 0, 0, 1, 0])(params, rng)
    per = params["rows"] * params["width"]
    out["reset_before"] = np.array([2 * per + per // 2], np.int64)   # inside signal frame 2
    return out


def cds_to_beats(arrays, params):
    fr, kinds = arrays["frames"], arrays["kinds"]
    stim = frames_to_beats(fr)
    per = fr.shape[1] * fr.shape[2]
    stim.ctrl = np.repeat(kinds.astype(np.uint64), per)
    if "reset_before" not in arrays:
        return stim, frames_to_beats(arrays["out"])
    # a reset forgets the stored reset frame: recompute the golden after it
    k = int(arrays["reset_before"][0])
    fi = k // per
    nxt = fi + 1
    before = cds_ddr_frames(fr[:nxt], kinds[:nxt], pixel_bits=params["pixel_bits"])
    after = cds_ddr_frames(fr[nxt:], kinds[nxt:], pixel_bits=params["pixel_bits"])
    exp0 = frames_to_beats(before) if len(before) else Beats(np.zeros((0, 1)), [], [])
    exp1 = frames_to_beats(after)
    exp = Beats.concat([exp0, exp1])
    # the cut frame's tail (no tuser) is dropped by the stream contract: feed it with rst
    keep = np.ones(len(stim), bool)
    keep[k:nxt * per] = False
    stim = stim.select(keep)
    mark_resets(stim, exp, [k], [len(exp0)])
    return stim, exp


def _cds_p(width, rows, pixel_bits=12, ppw=None, stride=None, **kw):
    return {"width": width, "rows": rows, "pixel_bits": pixel_bits, "pixels_per_word": ppw,
            "line_stride": stride, "base": kw.get("base", 0),
            "capacity_mib": kw.get("capacity_mib", 1024),
            **{k: kw.get(k, v) for k, v in DEFAULT_STALLS.items()}}


def _cds_cases():
    return [
        Case("random_24x4_12b", _cds_p(24, 4), _cds_random([1, 0, 0, 1, 0]), seed=1),
        Case("no_reset_first_24x4_12b", _cds_p(24, 4), _cds_random([0, 1, 0, 0]), seed=2),
        Case("hard_30x3_12b", _cds_p(30, 3), _cds_hard, seed=3, tags=("fullscale", "zeros")),
        Case("paper_10b_50x4", _cds_p(50, 4, pixel_bits=10, stride=4096, base=4096),
             _cds_random([1, 0, 1, 0]), seed=4, tags=("layout",)),
        Case("hard_16x2_16b", _cds_p(16, 2, pixel_bits=16), _cds_hard, seed=5,
             tags=("fullscale",)),
        Case("reset_mid_frame_24x4_12b", _cds_p(24, 4), _cds_reset, seed=6, tags=("reset",)),
        Case("random_512x16_10b", _cds_p(512, 16, pixel_bits=10), _cds_random([1, 0, 0]),
             seed=7, tags=("fast-only",)),
    ]


# ---------------------------------------------------------------------------------------
# tdi_ddr
# ---------------------------------------------------------------------------------------

def _gen(name, *args):
    """One of the ``tdi`` block's case generators, looked up when the case is made (a
    rename there then breaks these cases, not the block registry)."""
    def make(params, rng):
        g = getattr(_tdi_block, name)
        return g(*args)(params, rng) if args else g(params, rng)
    return make


def _tdi_to_beats(arrays, params):
    return _tdi_block._to_beats(arrays, params)


def _tdi_check(p):
    tdi_check_params(width=p["width"], stages=p["stages"], pixel_bits=p["pixel_bits"],
                     out_bits=p["out_bits"], ppc=p["ppc"])
    _check_stalls(*(p[k] for k in _STALL_NAMES))
    from ..hdl.tdi_ddr import TdiDdr
    lp = None if p["line_period_ns"] is None else p["line_period_ns"] * 1e-9
    tdi_ddr_check(width=p["width"], stages=p["stages"], pixel_bits=p["pixel_bits"],
                  ppc=p["ppc"], line_period_s=lp, clock_hz=p["clock_mhz"] * 1e6,
                  lookahead=TdiDdr.LOOKAHEAD + 4)


def _tdi_top(*, width, stages, pixel_bits, out_bits, ppc, base, line_period_ns, clock_mhz,
             **stalls):
    from ..hdl.tdi_ddr import TdiDdr
    core = TdiDdr(width=width, stages=stages, pixel_bits=pixel_bits, out_bits=out_bits,
                  ppc=ppc, base=base,
                  line_period_s=None if line_period_ns is None else line_period_ns * 1e-9,
                  clock_hz=clock_mhz * 1e6)
    core._stalls = stalls
    return AxisTop(_sim_top(core, base // ADDR_PER_WORD + core.ddr_words))


def _tdi_p(width, stages, ppc=1, out_bits=None, pixel_bits=12, **kw):
    return {"width": width, "stages": stages, "pixel_bits": pixel_bits, "out_bits": out_bits,
            "ppc": ppc, "base": kw.get("base", 0), "line_period_ns": None, "clock_mhz": 100,
            **{k: kw.get(k, v) for k, v in DEFAULT_STALLS.items()}}


_A = _tdi_p(256, 4, base=1 << 16)
_B = _tdi_p(320, 5, ppc=2, out_bits=14)
_C = _tdi_p(512, 16)
_D = _tdi_p(1024, 8, ppc=4, pixel_bits=10)
_CHANGES = [(4, 0, 6), (2, 0, 4), (3, 1, 5), (1, 0, 2), (1, 1, 2), (2, 1, 3), (4, 0, 5),
            (3, 1, 4)]


def _tdi_cases():
    return [
        Case("random_256x4_p1", _A, _gen("_random", 8), seed=1),
        Case("stages_256x4_p1", _A, _gen("_stages", _CHANGES), seed=2,
             tags=("stages", "direction")),
        Case("errors_256x4_p1", _A, _gen("_errors"), seed=3, tags=("errors", "direction")),
        Case("reset_256x4_p1", _A, _gen("_reset"), seed=4, tags=("reset",)),
        Case("fullscale_320x5_p2_sat", _B, _gen("_fullscale"), seed=5,
             tags=("fullscale", "saturate", "fast-only")),
        Case("stages_320x5_p2_sat", _B,
             _gen("_stages", [(5, 0, 7), (2, 1, 4), (4, 1, 6), (3, 0, 4)]),
             seed=6, tags=("stages", "direction", "saturate", "fast-only")),
        Case("random_512x16_p1", _C, _gen("_random", 18), seed=7, tags=("fast-only", "paper")),
        Case("stages_512x16_p1", _C, _gen("_stages", [(16, 0, 17), (9, 1, 11), (16, 0, 17)]),
             seed=8, tags=("fast-only", "paper", "stages", "direction")),
        Case("mixed_1024x8_p4_10b", _D, _gen("_stages", [(8, 0, 10), (7, 1, 9), (1, 0, 2)]),
             seed=9, tags=("fast-only", "stages", "direction")),
    ]


_TDI_PARAMS = (
    Param("width", 512, "pixels per line W (a multiple of ppc; W/ppc above the read "
                        "look-ahead)", lo=2, hi=8192),
    Param("stages", 16, "m_max; sizes the (stages-1) partial-sum lines in DDR", lo=1, hi=128),
    Param("pixel_bits", 12, "input pixel width", lo=8, hi=14),
    Param("out_bits", None, "saturate the output at 2^N-1; default full width", lo=8, hi=21),
    Param("ppc", 1, "pixels per clock", choices=(1, 2, 4, 8)),
    Param("base", 0, "DDR address of partial-sum line 0 (a multiple of 8)", lo=0,
          hi=(1 << 28) - 8),
    Param("line_period_ns", None, "line period the design must sustain (checks the DDR "
                                  "bandwidth and the clock); default: not checked",
          lo=1, hi=10 ** 9),
    Param("clock_mhz", 100, "user-interface clock for the bandwidth check, MHz", lo=1, hi=1000),
) + STALL_PARAMS


BLOCKS = [
    Block(
        name="ddr",
        summary="DDR frame buffer round trip: line writer -> MIG UI -> line reader "
                "(SPEC 3.8, seed 002 Table 2 packing)",
        params=(
            Param("width", 1280, "pixels per line", lo=1, hi=1 << 16),
            Param("rows", 16, "lines in the buffer (a frame's height)", lo=1, hi=1 << 16),
            Param("channels", 1, "values per pixel (72 in seed 002)", lo=1, hi=256),
            Param("ppc", 8, "pixels per beat (ppc x channels divides or is a multiple of "
                            "pixels_per_word)", lo=1, hi=256),
            Param("pixel_bits", 10, "bits per value", lo=1, hi=32),
            Param("pixels_per_word", 24, "values per 256-bit word", lo=1, hi=256),
            Param("line_stride", None, "address units between lines (8 per word); default "
                                       "the line rounded up to a power of two", lo=8,
                  hi=1 << 28),
            Param("base", 0, "address of line 0 (a multiple of 8)", lo=0, hi=(1 << 28) - 8),
            Param("capacity_mib", 1024, "DDR size for the address check, MiB", lo=1,
                  hi=1024),
        ) + STALL_PARAMS,
        top=_ddr_top,
        cases=_ddr_cases,
        to_beats=ddr_to_beats,
        check=_ddr_check,
        model_version="ddr-1",
    ),
    Block(
        name="cds_ddr",
        summary="digital CDS with the reset frame in DDR (SPEC 3.2 + 3.8)",
        params=(
            Param("width", 512, "pixels per line", lo=1, hi=1 << 16),
            Param("rows", 16, "lines per frame", lo=1, hi=1 << 16),
            Param("pixel_bits", 12, "pixel width", lo=8, hi=16),
            Param("pixels_per_word", None, "values per 256-bit word; default 24 for 10 bit, "
                                           "else 256 // pixel_bits", lo=1, hi=32),
            Param("line_stride", None, "address units between lines (8 per word)", lo=8,
                  hi=1 << 28),
            Param("base", 0, "address of the reset frame's line 0", lo=0, hi=(1 << 28) - 8),
            Param("capacity_mib", 1024, "DDR size for the address check, MiB", lo=1,
                  hi=1024),
        ) + STALL_PARAMS,
        top=_cds_top,
        cases=_cds_cases,
        to_beats=cds_to_beats,
        check=_cds_check,
        model_version="cds_ddr-1",
    ),
    Block(
        name="tdi_ddr",
        summary="TDI accumulator with its m_max-1 partial-sum lines in DDR (SPEC 3.1 + 3.8)",
        params=_TDI_PARAMS,
        top=_tdi_top,
        cases=_tdi_cases,
        to_beats=_tdi_to_beats,
        check=_tdi_check,
        model_version="tdi_ddr-1",
    ),
]


# ---------------------------------------------------------------------------------------
# co-simulation of the bare user interface against the Python controller model
# ---------------------------------------------------------------------------------------

def run_ui_cosim(*, width, rows, channels=1, ppc=1, pixel_bits=10, pixels_per_word=24,
                 line_stride=None, base=0, capacity_mib=1024, sim="verilator", seed=1,
                 backpressure=0.0, frame=None, stalls=None, max_cycles=None):
    """Run one frame through :class:`~tdicam.hdl.ddr.DdrFrameBuffer` with its MIG ports
    driven by :class:`~tdicam.model.ddr.MigSim` in cocotb (``cocotb_tests/ddr_tb.py``).

    Writes alone, then reads (``hold_reads``). Returns the tb's result dict: ``data_ok``,
    ``flags_ok`` (output = input), ``mem_mismatches`` (memory vs
    :func:`~tdicam.model.ddr.pack_lines`, word for word), ``error`` (a model error),
    ``write_cycles``/``read_cycles`` and ``words`` per phase, plus ``write_eff`` and
    ``read_eff`` = words / cycles of the phase, ``wall`` and ``build_time``.
    """
    import json
    import os
    import shutil
    import time

    from ..cosim import REPO, build_sources, run_cocotb
    from ..hdl.ddr import DdrFrameBuffer
    from ..verilog import convert
    stalls = dict(DEFAULT_STALLS if stalls is None else stalls)
    core = DdrFrameBuffer(width=width, rows=rows, channels=channels, elements=ppc * channels,
                          pixel_bits=pixel_bits, pixels_per_word=pixels_per_word,
                          line_stride=line_stride, base=base,
                          capacity_bytes=capacity_mib << 20)
    lay = core.layout
    top = AxisTop(core)
    key = {"width": width, "rows": rows, "channels": channels, "ppc": ppc,
           "pixel_bits": pixel_bits, "ppw": pixels_per_word, "stride": lay.line_stride,
           "base": base}
    bdir, build_time = build_sources("ddr_ui", key, sim, {"ddr_ui.v": convert(top, "ddr_ui")},
                                     top="ddr_ui")
    if frame is None:
        rng = np.random.default_rng(seed)
        frame = rng.integers(0, 1 << pixel_bits, (rows, width, channels))
    beats = np.asarray(frame).reshape(-1, ppc * channels)
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    np.savez(rundir / "stim.npz", beats=beats)
    words = rows * lay.words_per_line
    job = {"beats_per_line": width // ppc, "rows": rows, "padded": top._in[2],
           "layout": {"width": width, "channels": channels, "pixel_bits": pixel_bits,
                      "pixels_per_word": pixels_per_word, "line_stride": lay.line_stride,
                      "base": base},
           "capacity_bytes": capacity_mib << 20, "stalls": stalls, "seed": seed,
           "backpressure": backpressure,
           "max_cycles": max_cycles or 20 * (words + len(beats)) + 5000}
    (rundir / "job.json").write_text(json.dumps(job))
    env_pp = os.environ.get("PYTHONPATH", "")
    os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env_pp]))
    try:
        ok, wall = run_cocotb(bdir, sim, "ddr_tb", rundir, [], top="ddr_ui")
    finally:
        os.environ["PYTHONPATH"] = env_pp
    res_path = rundir / "result.json"
    if not ok or not res_path.exists():
        raise TdicamError(f"{sim} UI co-simulation of ddr failed; see {rundir / 'sim.log'}")
    res = json.loads(res_path.read_text())
    shutil.rmtree(rundir, ignore_errors=True)
    res["write_eff"] = res["words"] / res["write_cycles"] if res["write_cycles"] else 0.0
    res["read_eff"] = res["words"] / res["read_cycles"] if res["read_cycles"] else 0.0
    res.update(wall=wall, build_time=build_time, sim=sim)
    return res
