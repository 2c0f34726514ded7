"""Block ``median3``: 3x3 median filter, replicated borders, optional edge enhancement.

Golden cases hold a stream of frames of possibly different heights (the block's run-time
``height`` port): ``frames`` (all rows, concatenated), ``heights`` (rows per frame),
``keep`` (pixels of each frame actually sent: fewer means the frame is cut by a reset; at
``ppc`` > 1 rounded up to whole beats),
``reset_after`` (1 = reset the block before the next frame) and ``out`` (golden output of
every frame, whole).
"""

from dataclasses import dataclass

import numpy as np

from tdicam.beats import PPC_CHOICES, Beats, cut_frames_beats
from tdicam.errors import TdicamError
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.median3 import Median3, check_geometry
from tdicam.model.cds import pixel_dtype
from tdicam.model.median3 import MAX_GAIN, MAX_SHIFT, MAX_WIDTH, median3
from tdicam.blocks import (PPC_PARAM, Bench, Block, Case, KeyDoc, Options, Param, SceneSim,
                           StreamWork, Streams, Suite, SynthRef, Use, frame_stack)
from tdicam.blocks import _sim
from tdicam.blocks._pipeline import lane_stage
from tdicam.blocks.steps import Frames, RunView, Sim, Step

__all__ = ["BLOCK", "Median3Options", "BUILDS", "FULL_ONLY_BUILDS", "stream_case", "case_beats",
           "MAX_PIXEL_BITS", "check_after_tdi"]


# ---- top
def _check(params):
    check_geometry(params["width"], params["ppc"])
    if not params["enhance"] and (params["enhance_gain"] != 1
                                  or params["enhance_shift"] is not None):
        raise TdicamError("--enhance-gain and --enhance-shift need --enhance true")



def _top(**params):
    return AxisTop(Median3(**params))


def _ecp5_top(**params):
    """The ECP5 synthesis top: line buffers as DP16KD whose output register is the line
    buffers' own (``bram="ecp5"``), the enhancement's products in MULT18X18D output
    registers (``dsp="ecp5"``); the same latency and cycles as :func:`_top`."""
    return AxisTop(Median3(**params, bram="ecp5", dsp="ecp5"))


# ---- cases
def _model_kw(params):
    return {k: params[k] for k in ("pixel_bits", "enhance", "enhance_gain", "enhance_shift")}


def stream_case(frames, params, *, keep=None, reset_after=None):
    """Arrays of a case from a list of 2-D frames (same width, any heights)."""
    w = params["width"]
    for f in frames:
        if f.ndim != 2 or f.shape[1] != w:
            raise TdicamError(f"every frame must be 2-D and {w} wide, got {f.shape}")
    dt = pixel_dtype(params["pixel_bits"])
    out = [median3(f, **_model_kw(params)) for f in frames]
    n = len(frames)
    heights = np.array([f.shape[0] for f in frames], np.int64)
    keep = heights * w if keep is None else np.asarray(keep, np.int64)
    reset_after = np.zeros(n, np.uint8) if reset_after is None else \
        np.asarray(reset_after, np.uint8)
    return {"frames": np.concatenate(frames).astype(dt), "heights": heights,
            "keep": keep, "reset_after": reset_after, "out": np.concatenate(out)}


def case_beats(arrays, params):
    """(stimulus, expected) Beats of a case; ``height`` rides in ``ctrl`` with every beat.
    A beat carries ``ppc`` pixels of a row (element 0 the leftmost)."""
    w, ppc = params["width"], params.get("ppc", 1)
    check_geometry(w, ppc)
    out, n_row = arrays["out"], w // ppc

    def expected(f, row, h):
        idx = np.arange(h * n_row)
        return Beats(out[row:row + h].reshape(h * n_row, ppc), idx == 0,
                     idx % n_row == n_row - 1)
    return cut_frames_beats(arrays["frames"], arrays["heights"].tolist(), arrays["keep"],
                            arrays["reset_after"], ppc=ppc, expected=expected,
                            ctrl=lambda f, h: h)


def _golden(arrays, params):
    fr = np.asarray(arrays["frames"])
    out = [median3(f, **_model_kw(params)) for f in frame_stack(fr)]
    return {"out": np.stack(out).reshape(fr.shape) if out else fr.copy()}


def _to_case(arrays, params):
    return stream_case(list(frame_stack(arrays["frames"])), params)


def _example(rng, n, shape, params):
    b = params["pixel_bits"]
    return {"frames": rng.integers(0, 1 << b, (n, shape[0], params["width"]),
                                   dtype=pixel_dtype(b))}


def _rand(rng, bits, h, w):
    return rng.integers(0, 1 << bits, (h, w))


def _random(heights):
    def make(params, rng):
        b, w = params["pixel_bits"], params["width"]
        return stream_case([_rand(rng, b, h, w) for h in heights], params)
    return make


def _salt_pepper(heights, density=0.2):
    """Mid-grey texture with a fraction of pixels forced to 0 or full scale."""
    def make(params, rng):
        b, w = params["pixel_bits"], params["width"]
        full = (1 << b) - 1
        frames = []
        for h in heights:
            f = rng.integers(full // 3, 2 * full // 3, (h, w))
            hit = rng.random((h, w)) < density
            f[hit] = np.where(rng.random(hit.sum()) < 0.5, 0, full)
            frames.append(f)
        return stream_case(frames, params)
    return make


def _flat_and_full(params, rng):
    """Zeros, full scale, a constant, a 0/full checkerboard and random 0/full pixels."""
    b, w = params["pixel_bits"], params["width"]
    full = (1 << b) - 1
    yy, xx = np.mgrid[0:6, 0:w]
    frames = [np.zeros((5, w), np.int64), np.full((4, w), full), np.full((3, w), full // 3 + 1),
              ((yy + xx) % 2) * full, rng.integers(0, 2, (7, w)) * full,
              np.full((1, w), full)]
    return stream_case(frames, params)


def _edges(params, rng):
    """Step edges, thin lines and ramps plus noise: where the enhancement acts."""
    b, w = params["pixel_bits"], params["width"]
    full = (1 << b) - 1
    h = 12
    yy, xx = np.mgrid[0:h, 0:w]
    step = np.where(xx >= w // 2, full, full // 8)
    lines = np.where((xx % 5 == 2) | (yy % 4 == 1), 3 * full // 4, full // 4)
    ramp = (xx * full) // max(w - 1, 1)
    frames = []
    for base in (step, lines, ramp):
        noise = rng.integers(-(full // 32), full // 32 + 1, (h, w))
        frames.append(np.clip(base + noise, 0, full))
    frames.append(np.where((yy == h // 2) & (xx == w // 2), full, 0))   # one hot pixel
    return stream_case(frames, params)


def _reset_mid_frame(params, rng):
    """Frame 0 cut after 2.5 rows (rounded up to a whole beat) by a reset; frame 1 clean;
    frame 2 ends and a reset hits while its last row is still being produced (flush); frame
    3 clean."""
    b, w, ppc = params["pixel_bits"], params["width"], params.get("ppc", 1)
    frames = [_rand(rng, b, h, w) for h in (6, 5, 4, 3)]
    keep = [-(-(5 * w // 2) // ppc) * ppc, 5 * w, 4 * w, 3 * w]
    return stream_case(frames, params, keep=keep, reset_after=[1, 0, 1, 0])


def _top_params(**kw):
    base = {"width": 24, "pixel_bits": 12, "enhance": False, "enhance_gain": 1,
            "enhance_shift": None}
    base.update(kw)
    return base


#: Parameter sets of the golden cases (each one is a simulator build).
BUILDS = {
    "w3_16b": _top_params(width=3, pixel_bits=16),
    "w24_12b": _top_params(width=24, pixel_bits=12),
    "w8192_8b": _top_params(width=MAX_WIDTH, pixel_bits=8),
    "enh_w16_12b": _top_params(width=16, pixel_bits=12, enhance=True),
    "enh_w3_16b": _top_params(width=3, pixel_bits=16, enhance=True, enhance_gain=200,
                              enhance_shift=30),
}


def _wide(params, rng):
    """One frame of two rows at the widest line: random, then runs of 0 and full scale."""
    b, w = params["pixel_bits"], params["width"]
    full = (1 << b) - 1
    runs = (np.arange(w) // 7 % 2) * full
    return stream_case([np.stack([_rand(rng, b, 1, w)[0], runs])], params)


#: Parameter sets of the ppc 2, 4, 8 golden cases: the smallest width (3 beats) plain and
#: with enhancement at every ppc; at ppc 8 also the widest line and a second enhancement
#: setting (16-bit, gain 200, shift 30).
for _p in PPC_CHOICES[1:]:
    BUILDS[f"p{_p}_w{3 * _p}_12b"] = _top_params(width=3 * _p, ppc=_p)
    BUILDS[f"p{_p}_enh_w{4 * _p}_12b"] = _top_params(width=4 * _p, enhance=True, enhance_gain=9,
                                                     ppc=_p)
BUILDS["p8_w8192_8b"] = _top_params(width=MAX_WIDTH, pixel_bits=8, ppc=8)
BUILDS["p8_enh_w40_16b"] = _top_params(width=40, pixel_bits=16, enhance=True,
                                       enhance_gain=200, enhance_shift=30, ppc=8)


def _ppc_cases():
    """Golden cases at ppc 2, 4, 8: random frames of changing heights, 0 / full scale /
    constant frames, a reset mid-frame and mid-row, with and without enhancement, at the
    smallest width; the widest line and 16-bit enhancement at ppc 8."""
    b, out = BUILDS, []
    for k, p in enumerate(PPC_CHOICES[1:]):
        plain, enh, s = b[f"p{p}_w{3 * p}_12b"], b[f"p{p}_enh_w{4 * p}_12b"], 100 + 10 * k
        out += [
            Case(f"p{p}_random_12b", plain, _random([4, 1, 2, 3, 7]), seed=s,
                 tags=("smallest", "height-change")),
            Case(f"p{p}_flat_full_12b", plain, _flat_and_full, seed=s + 1,
                 tags=("smallest", "fullscale", "zeros")),
            Case(f"p{p}_reset_12b", plain, _reset_mid_frame, seed=s + 2, tags=("reset",)),
            Case(f"p{p}_enh_edges_12b", enh, _edges, seed=s + 3, tags=("enhance",)),
            Case(f"p{p}_enh_random_12b", enh, _random([5, 1, 2, 3]), seed=s + 4,
                 tags=("enhance", "height-change")),
            Case(f"p{p}_enh_reset_12b", enh, _reset_mid_frame, seed=s + 5,
                 tags=("enhance", "reset")),
        ]
    out += [
        Case("p8_w8192_8b", b["p8_w8192_8b"], _wide, seed=140, tags=("widest", "fullscale")),
        Case("p8_enh_flat_full_16b", b["p8_enh_w40_16b"], _flat_and_full, seed=141,
             tags=("enhance", "fullscale", "zeros")),
        Case("p8_enh_salt_pepper_16b", b["p8_enh_w40_16b"], _salt_pepper([6, 2]), seed=142,
             tags=("enhance",)),
    ]
    return out


def _cases():
    b = BUILDS
    return [
        Case("w3_3x3_and_tall", b["w3_16b"], _random([3, 1, 2, 3, 64]), seed=1,
             tags=("smallest", "height-change")),
        Case("w3_flat_full", b["w3_16b"], _flat_and_full, seed=2, tags=("fullscale", "zeros")),
        Case("w3_salt_pepper", b["w3_16b"], _salt_pepper([12, 5], 0.35), seed=3),
        Case("random_12b", b["w24_12b"], _random([16, 9, 1, 2, 3]), seed=4,
             tags=("height-change",)),
        Case("salt_pepper_12b", b["w24_12b"], _salt_pepper([20, 7]), seed=5),
        Case("flat_full_12b", b["w24_12b"], _flat_and_full, seed=6, tags=("fullscale", "zeros")),
        Case("reset_mid_frame_12b", b["w24_12b"], _reset_mid_frame, seed=7, tags=("reset",)),
        Case("w8192_8b", b["w8192_8b"], _wide, seed=8, tags=("widest", "fullscale")),
        Case("enh_edges_12b", b["enh_w16_12b"], _edges, seed=9, tags=("enhance",)),
        Case("enh_random_12b", b["enh_w16_12b"], _random([9, 1, 2, 3, 4, 6]), seed=10,
             tags=("enhance", "height-change")),
        Case("enh_salt_pepper_12b", b["enh_w16_12b"], _salt_pepper([10]), seed=11,
             tags=("enhance",)),
        Case("enh_flat_full_12b", b["enh_w16_12b"], _flat_and_full, seed=12,
             tags=("enhance", "fullscale", "zeros")),
        Case("enh_reset_12b", b["enh_w16_12b"], _reset_mid_frame, seed=13,
             tags=("enhance", "reset")),
        Case("enh_w3_edges_16b", b["enh_w3_16b"], _edges, seed=14,
             tags=("enhance", "smallest", "fullscale")),
        Case("enh_w3_random_16b", b["enh_w3_16b"], _random([6, 1, 2, 3, 4]), seed=15,
             tags=("enhance", "smallest")),
        Case("enh_w3_flat_full_16b", b["enh_w3_16b"], _flat_and_full, seed=16,
             tags=("enhance", "fullscale", "zeros")),
        *_ppc_cases(),
    ]


#: Parameter sets co-simulated only with TDICAM_FULL=1 (each is a Verilator build of its
#: own): enhancement at ppc 2 and 4 and the 16-bit enhanced frames at ppc 8. Every run keeps
#: at every ppc the smallest width, full scale and zeros, a reset mid-frame, and enhancement
#: at ppc 1 and 8.
FULL_ONLY_BUILDS = ("p2_enh_w8_12b", "p4_enh_w16_12b", "p8_enh_w40_16b")


def _full_only(case, sim, mode):
    return any(case.params == BUILDS[b] for b in FULL_ONLY_BUILDS)


# ---- scene
@dataclass(frozen=True)
class Median3Options:
    """``[pipeline.median3]``: add Ning et al. 2019's edge enhancement to the median output,
    with its mask gain."""

    edge_enhance: bool = False
    enhance_gain: int = 1


def _read_options(sec, sensor):
    enhance = sec.boolean("edge_enhance", False)
    if not enhance and sec.has("enhance_gain"):
        sec.fail("enhance_gain", "is the edge enhancement's gain: set edge_enhance = true to "
                                 "use it")
    return Median3Options(edge_enhance=enhance,
                          enhance_gain=sec.integer("enhance_gain", 1, lo=0, hi=MAX_GAIN))


OPTIONS = Options(
    Median3Options, _read_options,
    "3x3 median filter.",
    {"edge_enhance": KeyDoc("", "add the edge-enhancement detail to the median output "
                                "(Ning et al. 2019, section 4.4.3)"),
     "enhance_gain": KeyDoc("", "gain of the enhancement mask (the gateware's enhance_gain; "
                                "only with edge_enhance = true)")},
    probe={"edge_enhance": True})


# ---- chain
def _pipeline_step(ctx):
    """After a line-making block the frames are ``lines`` output lines (one median image);
    before it, each exposure frame of ``stages`` rows."""
    pb = max(ctx.bits, 8)
    opt = ctx.scene.pipeline.median3
    p = {"width": ctx.width, "pixel_bits": pb, "enhance": bool(opt.edge_enhance),
         "enhance_gain": opt.enhance_gain}
    if ctx.after_lines:
        return Step("median3", p, {"height": ctx.lines}, group=ctx.lines), pb
    return Step("median3", p, {"height": ctx.m}), pb


# ---- simulator
#: The widest pixels median3 takes (its ``pixel_bits`` parameter's range).
MAX_PIXEL_BITS = 16


def check_after_tdi(bits, after=None):
    """Refuse TDI output of ``bits`` bits into median3 (the scene loader, before any work,
    and the scene simulator): a one-line :class:`TdicamError` naming ``[tdi].output``.
    ``after``: the blocks after TDI (None: median3 is among them)."""
    if after is not None and BLOCK.name not in after:
        return
    if bits > MAX_PIXEL_BITS:
        raise TdicamError(f"[tdi].output: median3 after TDI takes at most {MAX_PIXEL_BITS}-bit "
                          f"pixels; the TDI output is {bits} bits: set output = 'saturate' "
                          f"with output_bits <= {MAX_PIXEL_BITS}")


def _sim_pre(c: RunView, fr: Frames):
    """Golden 3x3 median on single exposures (before TDI)."""
    x = fr.channels[0]
    _sim.check_bits(BLOCK, fr.bits, 8, 16, "[sensor].bits")
    p = _sim.step(c, BLOCK, fr.bits, x.shape[-1]).params
    y = _sim.golden(BLOCK, {"frames": x}, p)
    if fr.keep is not None:
        fr.crop[BLOCK.name] = {"frames": fr.keep(x), "out": None, "params": {
            k: v for k, v in p.items() if k != "width"}}
    fr.channels = [y]


def _sim_post(c: RunView, fr: Frames):
    """Golden 3x3 median on the TDI output."""
    pb = max(1, int(fr.full_scale).bit_length())
    check_after_tdi(pb)
    p = _sim.step(c, BLOCK, pb, fr.out.shape[-1], after_lines=True).params
    y = _sim.golden(BLOCK, {"frames": fr.out}, p).astype(np.int64)
    if fr.keep_out is not None:
        y0, h, x0, w = fr.keep_out
        fr.crop[BLOCK.name] = {"frames": fr.out[y0:y0 + h, x0:x0 + w].copy(), "out": None,
                               "params": {k: v for k, v in p.items() if k != "width"}}
    fr.out = y


#: The block in the scene simulator: on single exposures or on the TDI output, where
#: ``[pipeline].blocks`` puts it.
SIM = SceneSim((Sim("block median3 before TDI (golden)", _sim_pre, where="pre",
                    per_exposure=True),
                Sim("block median3 after TDI (golden)", _sim_post, stage="output",
                    where="post")),
               post_bytes=190.0, trim=2, sharpens=lambda opts: opts.edge_enhance)


# ---- entry
BLOCK = Block(
    name="median3",
    summary="3x3 median, replicated borders, 1-8 pixels/clock, optional edge enhancement "
            "(Ning et al. 2019 §4.4.3)",
    params=(
        Param("width", 1280, "pixels per line (sizes the line buffers; a multiple of ppc, "
              ">= 3*ppc)", lo=3, hi=MAX_WIDTH),
        Param("pixel_bits", 12, "input and output pixel width", lo=8, hi=MAX_PIXEL_BITS),
        Param("enhance", False, "add the Laplacian x smoothed-gradient detail", type=bool),
        Param("enhance_gain", 1, "mask gain (with --enhance)", lo=0, hi=MAX_GAIN),
        Param("enhance_shift", None, "mask right shift (with --enhance; default "
              "pixel_bits + 2)", lo=0, hi=MAX_SHIFT),
        PPC_PARAM,
    ),
    top=_top,
    ecp5_top=_ecp5_top,
    cases=_cases,
    check=_check,
    model_version="median3-1",
    streams=Streams(
        to_beats=case_beats,
        stream="frames",
        golden=_golden,
        to_case=_to_case,
        fit=lambda arrays: {"width": int(np.shape(arrays["frames"])[-1])},
        example=_example,
        small=((6, 0), {"width": 24}),
    ),
    pipeline=Use(_pipeline_step, lane_stage(), rank=5, options=OPTIONS, sim=SIM),
    order=50,
    bench=Bench("median3", StreamWork("median3", "median3", {"width": 1280, "pixel_bits": 12},
                                      "pixel", 
                                      "frames of 1280 x 8, 12-bit", (8, 1280),
                                      {"pysim": 1, "beat": 2, "fast": 32, "icarus fast": 8},
                                      {"pysim": 1, "beat": 1, "fast": 2})),
    synth=(SynthRef("median3", {"width": 1280, "pixel_bits": 12},
                    note="1280 wide, 12 bit, 1 pixel/clock"),),
    suite=Suite(fast=False, full_only=_full_only),  # fast mode: a build's cases as one stream
)
