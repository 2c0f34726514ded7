"""Block ``tdi``: the optimized digital TDI accumulator (Qu et al. 2010; Tao et al. 2012).

Golden cases store the input *beats* (pixels, tuser, tlast and the run-time settings presented
with each beat) and the expected output beats from :func:`~tdicam.model.tdi.tdi_stream`, plus
the expected ``frame_errors`` count. Stimulus frames are generated per case:

* ``random``/``fullscale``/``stages``/``errors`` — small (64 x 4) cases, per-beat and fast.
* ``mixed_256x32`` — m = 32 with a full-scale column band (sums reach 32 x 4095 exactly),
  then a reverse-scan run at m = 8, then m = 1. Fast only.
* ``texture_1280x96`` — the paper's sensor (1280 wide, 96 stages): 98 frames, the fewest that
  give several output lines (96 to fill + 2). Every row is the same random 12-bit line rotated
  by a random amount, so each row is distinct (a wrong frame, row or column changes the sums)
  while the deflate-compressed file stays small. Fast only.
"""

from dataclasses import dataclass

import numpy as np

from collections import deque

from tdicam.beats import PPC_CHOICES, Beats, BeatStream, mark_resets
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.tdi import TdiAccumulator
from tdicam.model.cds import pixel_dtype
from tdicam.model.tdi import PIXEL_BITS, check_params, full_bits, out_width, tdi, tdi_stream
from tdicam.blocks import Bench, Stalls, StreamWork, Suite, SynthRef
from tdicam.blocks._bench import TDI, TDI_QUICK
from tdicam.blocks import (Block, Case, KeyDoc, Memory, Options, Param, SceneSim, SideInput,
                           Streams, Use, frame_stack)
from tdicam.blocks import _sim
from tdicam.blocks._pipeline import lane_stage
from tdicam.blocks.steps import Frames, RunView, Sim, Step
from tdicam.errors import TdicamError

__all__ = ["BLOCK", "PARAMS", "TdiOptions", "TDI_MEMORY", "pack_ctrl", "stream_arrays", "to_beats", "streamed_case", "SCENE",
           "case_makers"]

# ---- top
CTRL_PORTS = ("stages_active", "direction")   # Beats.ctrl order: first port in the MSBs


def _top(*, width, stages, pixel_bits, out_bits, ppc, bram="generic"):
    return AxisTop(TdiAccumulator(width=width, stages=stages, pixel_bits=pixel_bits,
                                  out_bits=out_bits, ppc=ppc, bram=bram))


def _ecp5_top(**params):
    """The ECP5 synthesis top: DP16KD banks with their output register (``bram="ecp5"``)."""
    return _top(**params, bram="ecp5")


def _check(p):
    check_params(width=p["width"], stages=p["stages"], pixel_bits=p["pixel_bits"],
                 out_bits=p["out_bits"], ppc=p["ppc"])


# ---- cases
def pack_ctrl(stages_active, direction):
    """``Beats.ctrl`` of the block's run-time ports: ``{stages_active, direction}``."""
    return (np.asarray(stages_active, np.uint64) << np.uint64(1)) \
        | np.asarray(direction, np.uint64)


def stream_arrays(frames, settings, params):
    """Input beat arrays for a list of frames (m_t, W) with per-frame (m, direction)."""
    ppc, W = params["ppc"], params["width"]
    dt = pixel_dtype(params["pixel_bits"])
    wb = W // ppc
    pix, first, last, sa, dr = [], [], [], [], []
    for fr, (m, d) in zip(frames, settings):
        fr = np.asarray(fr)
        n = fr.shape[0] * wb
        pix.append(fr.astype(dt, copy=False).reshape(n, ppc))
        f = np.zeros(n, bool)
        f[0] = True
        first.append(f)
        last.append(np.arange(n) % wb == wb - 1)
        sa.append(np.full(n, m, np.uint8))
        dr.append(np.full(n, d, np.uint8))
    return {"pixels": np.concatenate(pix), "first": np.concatenate(first),
            "last": np.concatenate(last), "stages_active": np.concatenate(sa),
            "direction": np.concatenate(dr)}


def _expect(arrays, params, lo=0, hi=None):
    sl = slice(lo, hi)
    res = tdi_stream(arrays["pixels"][sl], arrays["first"][sl], arrays["last"][sl],
                     arrays["stages_active"][sl], arrays["direction"][sl],
                     width=params["width"], stages=params["stages"],
                     pixel_bits=params["pixel_bits"], out_bits=params["out_bits"],
                     ppc=params["ppc"])
    return res


def _finish(arrays, params):
    res = _expect(arrays, params)
    arrays.update({"out": res.data, "out_first": res.first, "out_last": res.last,
                   "frame_errors": np.array(res.frame_errors, np.int64)})
    return arrays


def _rand_frames(rng, params, settings):
    b = params["pixel_bits"]
    return [rng.integers(0, 1 << b, (m, params["width"])) for m, _ in settings]


def _random(n, m=None, direction=0):
    def make(params, rng):
        mm = params["stages"] if m is None else m
        settings = [(mm, direction)] * n
        return _finish(stream_arrays(_rand_frames(rng, params, settings), settings, params),
                       params)
    return make


def _fullscale(params, rng):
    """All-full-scale frames at m_max, then zeros, then full scale again, then random."""
    mm, full = params["stages"], (1 << params["pixel_bits"]) - 1
    W = params["width"]
    frames = [np.full((mm, W), full)] * (mm + 2) + [np.zeros((mm, W), int)] * 2 \
        + [np.full((mm, W), full)] * (mm + 1)
    settings = [(mm, 0)] * len(frames)
    return _finish(stream_arrays(frames, settings, params), params)


def _stages(seq):
    """Stage count and direction changing mid-stream: ``seq`` = [(m, direction, frames)]."""
    def make(params, rng):
        settings = [(m, d) for m, d, n in seq for _ in range(n)]
        return _finish(stream_arrays(_rand_frames(rng, params, settings), settings, params),
                       params)
    return make


def _errors(params, rng):
    """Malformed input: stray beats, cut frames, bad tlast, long frames, invalid settings."""
    mm, W, ppc = params["stages"], params["width"], params["ppc"]
    wb = W // ppc
    b = params["pixel_bits"]
    m = max(1, mm - 1) if mm > 2 else mm

    def frame(mv=m, d=0):
        return stream_arrays([rng.integers(0, 1 << b, (max(mv, 1), W))], [(mv, d)], params)

    def cat(parts):
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}

    def good(k, mv=m, d=0):
        return [frame(mv, d) for _ in range(k)]

    def cut(a, n):
        return {k: v[:n] for k, v in a.items()}

    parts = []
    stray = frame()
    parts.append(cut({**stray, "first": np.zeros_like(stray["first"])}, 3))  # no tuser
    parts += good(m + 1)
    parts.append(cut(frame(), wb // 2))           # cut inside the output row (forward)
    parts += good(m + 1)
    f = frame()
    f["last"][wb // 2] = True                     # early tlast in the output row
    parts.append(f)
    parts += good(m + 1)
    f = frame()
    f["last"][wb - 1] = False                     # missing tlast at the end of row 1
    parts.append(f)
    parts += good(m)
    f = frame()
    parts.append(f)                               # a good frame followed by extra beats
    parts.append(cut({**frame(), "first": np.zeros_like(f["first"])}, 2))
    parts += good(m)
    parts.append(frame(0))                        # invalid: stages_active = 0
    parts += good(m)
    parts.append(frame(mm + 1))                   # invalid: above m_max
    if mm >= 2:
        parts.append(frame(mm, 1))                # invalid: reverse at m_max
    parts += good(m + 1, m, 1 if m < mm else 0)
    last = frame(m, 1 if m < mm else 0)
    parts.append(cut(last, (m - 1) * wb + wb // 2))  # reverse: cut in the output row (m)
    parts += good(m + 1)
    arrays = cat(parts)
    return _finish(arrays, params)


def _reset(params, rng):
    """Reset mid-frame (inside an output row); the block refills from the frames after it."""
    mm = params["stages"]
    settings = [(mm, 0)] * (mm + 3) + [(mm, 0)] * (mm + 2)
    arrays = stream_arrays(_rand_frames(rng, params, settings), settings, params)
    wb = params["width"] // params["ppc"]
    per_frame = mm * wb
    cut = (mm + 2) * per_frame + wb // 2          # inside row 1 (the output row) of a frame
    before = _expect(arrays, params, 0, cut)
    after = _expect(arrays, params, cut)
    arrays.update({
        "out": np.concatenate([before.data, after.data]),
        "out_first": np.concatenate([before.first, after.first]),
        "out_last": np.concatenate([before.last, after.last]),
        "frame_errors": np.array(after.frame_errors, np.int64),
        "reset_before": np.array([cut], np.int64),
        "exp_before": np.array([len(before.first)], np.int64),
    })
    return arrays


def _texture_frames(rng, params, settings):
    """Frames whose rows are one random line rotated by random amounts (distinct rows that
    deflate well: see the module docstring)."""
    W, b = params["width"], params["pixel_bits"]
    tex = rng.integers(0, 1 << b, W).astype(pixel_dtype(b))
    windows = np.lib.stride_tricks.sliding_window_view(np.concatenate([tex, tex]), W)
    out = []
    for m, _ in settings:
        shifts = rng.integers(0, W, m)
        out.append(windows[(W - shifts) % W])   # row = tex rotated right by its shift
    return out


def _mixed(params, rng):
    """m_max with a full-scale column band, then reverse at m = 8, then m = 1."""
    mm, W, b = params["stages"], params["width"], params["pixel_bits"]
    full = (1 << b) - 1
    settings = [(mm, 0)] * (mm + 1) + [(8, 1)] * 10 + [(1, 0)] * 2
    frames = [fr.copy() for fr in _texture_frames(rng, params, settings)]
    band = W // 4
    for fr, (m, _) in zip(frames, settings):
        if m == mm:
            fr[:, :band] = full
    return _finish(stream_arrays(frames, settings, params), params)


def _texture(n_frames):
    def make(params, rng):
        settings = [(params["stages"], 0)] * n_frames
        return _finish(stream_arrays(_texture_frames(rng, params, settings), settings, params),
                       params)
    return make


def _scene_frames(arrays):
    """(frames (n, m, W), m, direction) of scene arrays."""
    fr = frame_stack(arrays["frames"])
    return fr, int(arrays["stages"]), int(arrays["direction"])


def _to_case(arrays, params):
    fr, m, d = _scene_frames(arrays)
    return _finish(stream_arrays(list(fr), [(m, d)] * len(fr), params), params)


def _golden(arrays, params):
    """One output line per frame after the pipeline filled: :func:`tdicam.model.tdi.tdi`, the
    whole-array model with one setting (equal to the cycle-level :func:`tdi_stream` that the
    golden cases hold, which runs mid-stream setting changes and resets; tests/test_tdi.py)."""
    fr, m, d = _scene_frames(arrays)
    out = tdi(fr, stages=params["stages"], pixel_bits=params["pixel_bits"],
              out_bits=params["out_bits"], stages_active=m, direction=d)
    return {"out": out}


def _unstream(out, arrays, params):
    bits = out_width(params["pixel_bits"], params["stages"], params["out_bits"])
    return {"out": out.data.reshape(-1, params["width"]).astype(pixel_dtype(bits))}


def _fit(arrays):
    return {"width": int(np.shape(arrays["frames"])[-1]), "stages": int(arrays["stages"])}


def _example(rng, n, shape, params):
    b = params["pixel_bits"]
    return {"frames": rng.integers(0, 1 << b, (n, params["stages"], params["width"]),
                                   dtype=pixel_dtype(b))}


#: The scene-array contract shared by ``tdi`` and ``tdi_ddr`` (same stream, same model).
SCENE = dict(
    stream="frames",
    side_inputs=(
        SideInput("stages", "run", "active stages m (1..stages), on the stages_active port "
                  "with every beat; each input frame holds m rows",
                  default=lambda fr: np.shape(fr)[-2]),
        SideInput("direction", "run", "scan direction (0 forward, 1 reverse), on the "
                  "direction port with every beat", default=0),
    ),
    golden=_golden,
    to_case=_to_case,
    fit=_fit,
    unstream=_unstream,
    example=_example,
)


def to_beats(arrays, params):
    """(stimulus, expected) Beats of case arrays (``pixels``, ``first``, ``last``,
    ``stages_active``, ``direction``, ``out*``; optional ``reset_before``/``exp_before``)."""
    return _to_beats(arrays, params)


def case_makers():
    """The case generators ``tdi_ddr`` reuses, by name."""
    return {"random": _random, "stages": _stages, "errors": _errors, "reset": _reset,
            "fullscale": _fullscale}


def _to_beats(arrays, params):
    stim = Beats(arrays["pixels"], arrays["first"], arrays["last"],
                 ctrl=pack_ctrl(arrays["stages_active"], arrays["direction"]))
    exp = Beats(arrays["out"], arrays["out_first"], arrays["out_last"])
    if "reset_before" in arrays:
        mark_resets(stim, exp, arrays["reset_before"], arrays["exp_before"])
    return stim, exp


def streamed_case(params, seed=1):
    """``tdicam export`` above its beat limit: m_max + 2 random frames at m = m_max, forward
    (three output lines), made one frame at a time; each expected line from the whole-array
    model :func:`~tdicam.model.tdi.tdi` over the m frames it sums (memory: m frames)."""
    mm, W, ppc = params["stages"], params["width"], params["ppc"]
    wb, n_frames = W // ppc, mm + 2
    dt = pixel_dtype(params["pixel_bits"])
    settings = [(mm, 0)]

    def pieces():
        rng = np.random.default_rng(seed)
        window = deque(maxlen=mm)
        for _ in range(n_frames):
            fr = rng.integers(0, 1 << params["pixel_bits"], (mm, W), dtype=dt)
            window.append(fr)
            a = stream_arrays([fr], settings, params)
            stim = Beats(a["pixels"], a["first"], a["last"],
                         ctrl=pack_ctrl(a["stages_active"], a["direction"]))
            if len(window) < mm:
                exp = Beats(np.zeros((0, ppc), np.uint64), np.zeros(0, bool), np.zeros(0, bool))
            else:
                line = tdi(np.stack(window), stages=mm, pixel_bits=params["pixel_bits"],
                           out_bits=params["out_bits"], stages_active=mm)[-1]
                edge = np.zeros(wb, bool)
                exp = Beats(line.reshape(wb, ppc), edge.copy(), edge)
                exp.first[0] = exp.last[-1] = True
            yield stim, exp

    return BeatStream(f"stream_{W}x{mm}_p{ppc}", n_in=n_frames * mm * wb,
                      n_out=(n_frames - mm + 1) * wb, pieces=pieces)


def _p(width, stages, ppc, out_bits=None, pixel_bits=12):
    return {"width": width, "stages": stages, "pixel_bits": pixel_bits, "out_bits": out_bits,
            "ppc": ppc}


_A = _p(64, 4, 1)                   # full width (14 bits)
_B = _p(64, 4, 4, out_bits=13)      # saturating at 8191
_C1, _C4 = _p(256, 32, 1), _p(256, 32, 4)
_D1, _D4 = _p(1280, 96, 1), _p(1280, 96, 4)
_E = _p(48, 5, 2, pixel_bits=14)    # 14-bit, 2 pixels per clock, full width 17
_F = _p(64, 3, 8, out_bits=9, pixel_bits=8)   # 8-bit, 8 pixels per clock, saturating

_CHANGES = [(4, 0, 6), (2, 0, 4), (3, 0, 5), (3, 1, 5), (1, 0, 2), (1, 1, 2), (2, 1, 3),
            (4, 0, 5), (3, 1, 4)]


def _cases():
    return [
        Case("random_64x4_p1", _A, _random(10), seed=1),
        Case("fullscale_64x4_p1", _A, _fullscale, seed=2, tags=("fullscale", "zeros")),
        Case("stages_64x4_p1", _A, _stages(_CHANGES), seed=3, tags=("stages", "direction")),
        Case("reset_64x4_p1", _A, _reset, seed=4, tags=("reset",)),
        Case("errors_64x4_p1", _A, _errors, seed=5, tags=("errors", "direction")),
        Case("random_64x4_p4_sat", _B, _random(10), seed=6, tags=("saturate",)),
        Case("fullscale_64x4_p4_sat", _B, _fullscale, seed=7,
             tags=("fullscale", "saturate")),
        Case("stages_64x4_p4_sat", _B, _stages(_CHANGES), seed=8,
             tags=("stages", "direction", "saturate")),
        Case("errors_64x4_p4_sat", _B, _errors, seed=9, tags=("errors",)),
        Case("mixed_256x32_p1", _C1, _mixed, seed=10,
             tags=("fast-only", "fullscale", "direction", "stages")),
        Case("mixed_256x32_p4", _C4, _mixed, seed=11,
             tags=("fast-only", "fullscale", "direction", "stages")),
        Case("texture_1280x96_p1", _D1, _texture(98), seed=12, tags=("fast-only", "big")),
        Case("texture_1280x96_p4", _D4, _texture(98), seed=13, tags=("fast-only", "big")),
        Case("mixed_48x5_p2_14b", _E, _stages([(5, 0, 7), (2, 1, 4), (4, 1, 6), (3, 0, 4)]),
             seed=14, tags=("stages", "direction")),
        Case("errors_48x5_p2_14b", _E, _errors, seed=15, tags=("errors",)),
        Case("mixed_64x3_p8_8b_sat", _F, _stages([(3, 0, 6), (2, 1, 4), (1, 0, 2), (3, 0, 4)]),
             seed=16, tags=("stages", "direction", "saturate")),
        Case("fullscale_64x3_p8_8b_sat", _F, _fullscale, seed=17,
             tags=("fullscale", "saturate")),
    ]



#: (width, stages) of the cases Verilator co-simulates in every run (each other pair is a
#: ~30 s build of its own: with TDICAM_FULL=1).
VERILATOR_SIZES = ((64, 4), (1280, 96))


def _full_only(case, sim, mode):
    return sim == "verilator" and (case.params["width"], case.params["stages"]) not in \
        VERILATOR_SIZES


# ---- scene
#: ``[pipeline.tdi].memory``: where the partial sums live.
TDI_MEMORY = ("auto", "chip", "ddr")


@dataclass(frozen=True)
class TdiOptions:
    """``[pipeline.tdi]``: where the gateware keeps the partial sums (:data:`TDI_MEMORY`)."""

    memory: str = "auto"


OPTIONS = Options(
    TdiOptions, lambda sec, sensor: TdiOptions(memory=sec.choice("memory", "auto", TDI_MEMORY)),
    "Where the gateware keeps TDI's partial sums (the golden model is the same either way).",
    {"memory": KeyDoc("", "chip: block RAM; ddr: the DDR of [ddr] (through tdi_ddr); auto: "
                          "DDR when the partial sums exceed the device's block RAM")})


# ---- chain
def _pipeline_step(ctx):
    """Stages and direction from ``[tdi]`` (run-time ports at their scene values), the
    output saturated per ``[tdi].output``; ``ctx.block`` is ``tdi`` or its DDR variant."""
    t = ctx.scene.tdi
    m, pb = ctx.m, ctx.bits
    out_bits = t.output_bits if t.output == "saturate" else None
    if out_bits is not None and out_bits >= full_bits(pb, m):
        out_bits = None
    d = 0 if t.direction == "forward" else 1
    # a reverse scan needs one partial-sum line more (tdicam.model.tdi.settings_valid): one
    # stage more built in, the output kept at m stages' full width
    m_max = m + 1 if d and m > 1 else m
    if m_max > m and out_bits is None:
        out_bits = full_bits(pb, m)
    step = Step(ctx.block, {"width": ctx.width, "stages": m_max, "pixel_bits": pb,
                            "out_bits": out_bits, "ppc": ctx.ppc},
                {"stages_active": m, "direction": d}, inputs={"stages": m, "direction": d})
    return step, out_width(pb, m_max, out_bits)


# ---- simulator
def _memory_bits(step):
    """The (stages - 1) partial-sum lines at full width."""
    from tdicam.model.tdi import full_bits
    p = step.params
    return (p["stages"] - 1) * p["width"] * full_bits(p["pixel_bits"], p["stages"])


#: ``tdi``'s parameters; ``tdi_ddr`` inherits them (with its own defaults) and adds its DDR's.
PARAMS = (
    Param("width", 1280, "pixels per line W (a multiple of ppc, >= 2*ppc)", lo=2,
          hi=8192),
    Param("stages", 96, "m_max, the largest stage count; sizes the (stages-1)-line "
                        "partial-sum memory", lo=1, hi=128),
    Param("pixel_bits", 12, "input pixel width", lo=8, hi=14),
    Param("out_bits", None, "saturate the output at 2^N-1 (pixel_bits..full width); "
                            "default: full width pixel_bits+ceil(log2(stages))",
          lo=8, hi=21),
    Param("ppc", 1, "pixels per clock", choices=PPC_CHOICES),
)


#: ``tdi``'s and ``tdi_ddr``'s pipeline entry; ``tdi`` spills to ``tdi_ddr``.
#: The accumulator's output beat is read from its output FIFO's memory: a register slice
#: follows it in a chain (the read into median3 was the Ning et al. 2019 chain's critical
#: path, 9.2 ns on the ECP5).
PIPELINE = dict(step=_pipeline_step, hw=lane_stage(out_slice=True), lines=True)


def _sim_step(c: RunView, fr: Frames):
    """Golden digital TDI of the frame stack (saturating when ``[tdi].output`` says so)."""
    m, pb, x = c.m, fr.bits, fr.channels[0]
    _sim.check_bits(BLOCK, pb, *PIXEL_BITS,
                    "[sensor].bits" if pb == c.sensor.bits else "[pipeline].blocks (hdr output)")
    full = full_bits(pb, m)
    step = _sim.step(c, BLOCK, pb, x.shape[-1])
    out_bits, direction = step.params["out_bits"], step.inputs["direction"]
    if out_bits is not None and not pb <= out_bits <= full:
        raise TdicamError(f"[tdi].output_bits: must be in {pb}..{full} for {pb}-bit pixels "
                          f"and {m} stages, got {out_bits}")
    # the golden model's own limits, not the gateware's (a scene may be wider than 8192)
    out = BLOCK.run_golden({"frames": x, **step.inputs}, step.params)["out"]
    out = out.astype(np.int64)
    if fr.keep is not None:
        y0, h, x0, w = fr.keep_out
        fr.crop[BLOCK.name] = {"frames": fr.keep(x), "params": dict(
            width=None, stages=m, pixel_bits=pb, out_bits=None if out_bits == full else out_bits,
            direction=direction), "out": out[y0:y0 + h, x0:x0 + w].copy()}
    fr.out = out
    fr.full_scale = (1 << (out_bits if out_bits is not None else full)) - 1


def _sim_fast(c: RunView, fr: Frames):
    """The fast aggregate is the TDI sum; saturate it where ``[tdi].output`` says so."""
    if c.digital and c.scene.tdi.output == "saturate":
        np.minimum(fr.out, (1 << c.scene.tdi.output_bits) - 1, out=fr.out)
        fr.full_scale = (1 << c.scene.tdi.output_bits) - 1


#: The block in the scene simulator (its spill variant computes the same).
SIM = SceneSim((Sim("TDI accumulation", _sim_step, stage="lines", fast=_sim_fast,
                    aggregated=True),),
               scratch_bytes=0.5)


# ---- entry
BLOCK = Block(
    name="tdi",
    summary="optimized digital TDI accumulator: m-1 partial-sum lines, run-time stages and "
            "direction (Qu et al. 2010; Tao et al. 2012)",
    params=PARAMS,
    top=_top,
    ecp5_top=_ecp5_top,
    cases=_cases,
    check=_check,
    model_version="tdi-1",
    streams=Streams(
        **SCENE,
        to_beats=_to_beats,
        frame_beats=lambda p: p["stages"] * p["width"] // p["ppc"],
        streamed_case=streamed_case,
        small=((), {"width": 64, "stages": 4}),
    ),
    pipeline=Use(**PIPELINE, rank=4,
                 memory=Memory(bits=_memory_bits, holds="partial sums",
                               placement=lambda scene: scene.pipeline.tdi.memory,
                               spill="tdi_ddr"),
                 options=OPTIONS,
                 sim=SIM),
    order=20,
    bench=Bench("tdi", StreamWork("tdi", "tdi",
                                  {"width": 256, "stages": 4, "pixel_bits": 12, "ppc": 1},
                                  "pixel",
                                  "frames of 256 x 4 stages, 12-bit (output from frame 4 on)",
                                  (4, 256), TDI, TDI_QUICK)),
    synth=(SynthRef("tdi ppc=1", {"width": 1280, "stages": 96, "pixel_bits": 12, "ppc": 1},
                   note="1280 x 96 stages x 12 bit, 19-bit partial sums"),
           SynthRef("tdi ppc=4", {"width": 1280, "stages": 96, "pixel_bits": 12, "ppc": 4},
                    note="1280 x 96 stages x 12 bit, 4 pixels/clock"),
           SynthRef("tdi ppc=8", {"width": 1280, "stages": 96, "pixel_bits": 12, "ppc": 8},
                    note="1280 x 96 stages x 12 bit, 8 pixels/clock")),
    suite=Suite(per_beat="all", not_per_beat=("fullscale_64x3_p8_8b_sat", "mixed_48x5_p2_14b"),
                full_only=_full_only,
                stalls=Stalls("stages_64x4_p1", seed=5,
                              pairs=((0.0, 0.0), (0.0, 0.9), (0.9, 0.0), (0.6, 0.6)))),
)
