"""Block ``hdr``: high/low-gain HDR merge with a frame-to-frame junction (Ning et al. 2019 §4.4.2)."""

from dataclasses import dataclass

import numpy as np

from tdicam.beats import PPC_CHOICES, frames_to_beats, mark_resets
from tdicam.hdl.hdr import Hdr
from tdicam.model.cds import pixel_dtype
from tdicam.model.hdr import ANCHORS, DEFAULT_GAINS, hdr, hdr_config
from tdicam.errors import TdicamError
from tdicam.blocks import Bench, Stalls, StreamWork, Suite, SynthRef
from tdicam.blocks._bench import PX, PX_QUICK
from tdicam.blocks import (PPC_PARAM, Block, Case, KeyDoc, Options, Param, SceneSim, SideInput,
                           Streams, Use, check_width as _check_width, frame_stack)
from tdicam.blocks import _sim
from tdicam.blocks._dsp import model_params, tops
from tdicam.blocks._pipeline import lane_stage
from tdicam.blocks.steps import Frames, RunView, Sim, Step

__all__ = ["BLOCK", "HdrOptions", "ramp_frame", "scene_frames"]


# ---- top
_top, _ecp5_top = tops(Hdr)


def _check(params):
    hdr_config(**model_params(params))


# ---- cases
def _frame_start_stalls(arrays, params):
    """Cycles ``hdr`` holds its input at the frame starts after a measured band (the
    junction's divisions, :attr:`tdicam.hdl.hdr.Hdr.frame_start_cycles` each)."""
    return (len(arrays["hg"]) - 1) * Hdr(**params).frame_start_cycles


def _ratio(cfg, sel):
    return cfg.slopes[sel] / (1 << cfg.slope_frac_bits)


def ramp_frame(cfg, sel=0):
    """Every LG code once, HG = round(LG * ratio) clamped at full scale; shape (rows, 64)."""
    full = (1 << cfg.pixel_bits) - 1
    lg = np.arange(full + 1, dtype=np.int64)
    hg = np.minimum(np.floor(lg * _ratio(cfg, sel) + 0.5), full).astype(np.int64)
    return hg.reshape(-1, 64), lg.reshape(-1, 64)


def scene_frames(cfg, rng, frames, rows, cols, sels=None, noise=2.0, span=None):
    """A noisy scene: light level ramps across the frame, LG is the light in LG codes,
    HG = LG * ratio of the frame's gain pair, both with Gaussian noise, quantized and
    clipped. ``span = (lo, hi)`` is the light range in units of the threshold's light level
    (default: dark to twice HG full scale)."""
    full = (1 << cfg.pixel_bits) - 1
    sels = np.zeros(frames, np.int64) if sels is None else np.asarray(sels)
    hg = np.empty((frames, rows, cols), np.int64)
    lg = np.empty_like(hg)
    for k in range(frames):
        r = _ratio(cfg, int(sels[k]))
        lo, hi = (0.0, 2.0 * full / cfg.threshold) if span is None else span
        light = np.linspace(lo * cfg.threshold / r, hi * cfg.threshold / r,
                            rows * cols).reshape(rows, cols)
        light = light * rng.uniform(0.8, 1.2) + rng.normal(0, noise, (rows, cols))
        lg[k] = np.clip(np.floor(light + rng.normal(0, noise, light.shape) + 0.5), 0, full)
        hg[k] = np.clip(np.floor(light * r + rng.normal(0, noise * 2, light.shape) + 0.5),
                        0, full)
    return hg, lg



def _pack(params, hg, lg, sels, reset_frame=None, cut=None):
    """Arrays of a case; with a reset the frames after ``reset_frame`` restart from reset."""
    hg = np.asarray(hg, np.uint16)
    lg = np.asarray(lg, np.uint16)
    sels = np.asarray(sels, np.int64)
    if reset_frame is None:
        out = hdr(hg, lg, gain_sel=sels, **model_params(params))
    else:
        r = reset_frame
        out = np.concatenate([hdr(hg[:r + 1], lg[:r + 1], gain_sel=sels[:r + 1], **model_params(params)),
                              hdr(hg[r + 1:], lg[r + 1:], gain_sel=sels[r + 1:], **model_params(params))])
    arrays = {"hg": hg, "lg": lg, "gain_sel": sels, "out": out}
    if reset_frame is not None:
        arrays["reset_frame"] = np.array([reset_frame], np.int64)
        arrays["reset_before"] = np.array([cut], np.int64)
    return arrays


def _ramp(params, rng):
    """The full LG sweep twice (reset junction, then the one measured on the sweep), then a
    frame starting with threshold edges: HG at T-band-1, T-band, T-1, T, T+1 with LG below,
    at and above the junction (the rest of that frame is the sweep again)."""
    cfg = hdr_config(**model_params(params))
    hg, lg = ramp_frame(cfg)
    t, b, full = cfg.threshold, cfg.band, (1 << cfg.pixel_bits) - 1
    hgs = np.clip([t - b - 1, t - b, t - 1, t, t + 1], 0, full)
    lgs = np.clip(np.round(t / _ratio(cfg, 0)) + np.arange(-6, 7) * 3, 0, full)
    edge = np.array(np.meshgrid(hgs, lgs, indexing="ij")).reshape(2, -1)  # 65 pixels
    eh, el = hg.copy(), lg.copy()
    eh.flat[:edge.shape[1]] = edge[0]
    el.flat[:edge.shape[1]] = edge[1]
    return _pack(params, np.stack([hg, hg, eh]), np.stack([lg, lg, el]), np.zeros(3, np.int64))


def _scene(frames, rows, cols, sels=None, span=None):
    def make(params, rng):
        cfg = hdr_config(**model_params(params))
        s = np.zeros(frames, np.int64) if sels is None else np.asarray(sels)
        hg, lg = scene_frames(cfg, rng, frames, rows, cols, s, span=span)
        return _pack(params, hg, lg, s)
    return make


def _empty_band(cols):
    """Four 12 x ``cols`` frames: frame 0 fills the band; frames 1 and 2 have none (L_T kept,
    no division by zero); frame 3 has band pixels again."""
    def make(params, rng):
        cfg = hdr_config(**model_params(params))
        hg, lg = scene_frames(cfg, rng, 4, 12, cols)
        t, b = cfg.threshold, cfg.band
        for k in (1, 2):
            inside = (hg[k] >= t - b) & (hg[k] < t)
            hg[k][inside] = np.where(rng.random(int(inside.sum())) < 0.5, t - b - 1, t)
        return _pack(params, hg, lg, np.zeros(4, np.int64))
    return make


def _extremes(params, rng):
    """Constant frames: zeros, full scale on both, HG full with LG 0, HG 0 with LG full,
    then a frame of random codes."""
    full = (1 << params["pixel_bits"]) - 1
    pairs = [(0, 0), (full, full), (full, 0), (0, full), (full, full)]
    hg = np.stack([np.full((6, 10), h) for h, _ in pairs] + [rng.integers(0, full + 1, (6, 10))])
    lg = np.stack([np.full((6, 10), v) for _, v in pairs] + [rng.integers(0, full + 1, (6, 10))])
    return _pack(params, hg, lg, np.zeros(len(hg), np.int64))


def _reset_mid_frame(sels):
    """Frames 0-1 build up a measured junction (and gain pair), a reset cuts frame 1, then
    frames 2-3 start clean from the reset state."""
    def make(params, rng):
        cfg = hdr_config(**model_params(params))
        s = np.asarray(sels, np.int64)
        hg, lg = scene_frames(cfg, rng, 4, 10, 16, s)
        return _pack(params, hg, lg, s, reset_frame=1, cut=93)
    return make


def _extremes_wide(params, rng):
    """:func:`_extremes` on 6 x 16 frames (a width every ``ppc`` divides)."""
    full = (1 << params["pixel_bits"]) - 1
    pairs = [(0, 0), (full, full), (full, 0), (0, full), (full, full)]
    shape = (6, 16)
    hg = np.stack([np.full(shape, h) for h, _ in pairs] + [rng.integers(0, full + 1, shape)])
    lg = np.stack([np.full(shape, v) for _, v in pairs] + [rng.integers(0, full + 1, shape)])
    return _pack(params, hg, lg, np.zeros(len(hg), np.int64))


def _reset_beats(sels):
    """:func:`_reset_mid_frame` with the reset in the middle of row 5 of frame 1, after
    ``5 * 16 / ppc + 16 / ppc / 2`` beats (rounded up)."""
    def make(params, rng):
        cfg = hdr_config(**model_params(params))
        s = np.asarray(sels, np.int64)
        hg, lg = scene_frames(cfg, rng, 4, 10, 16, s)
        wb = 16 // params["ppc"]
        return _pack(params, hg, lg, s, reset_frame=1, cut=5 * wb + (wb + 1) // 2)
    return make


def _golden(arrays, params):
    """hdr on (..., rows, cols) stacks; ``gain_sel`` one value per frame."""
    hg = np.asarray(arrays["hg"])
    sels = np.asarray(arrays["gain_sel"], np.int64).ravel()
    out = hdr(frame_stack(hg), frame_stack(arrays["lg"]), gain_sel=sels, **model_params(params))
    return {"out": out.reshape(hg.shape[:-2] + out.shape[-2:])}


def _zeros_per_frame(hg):
    return np.zeros(frame_stack(hg).shape[0], np.int64)


def _unstream(out, arrays, params):
    bits = hdr_config(**model_params(params)).out_bits
    return {"out": out.data.reshape(np.shape(arrays["hg"])).astype(pixel_dtype(bits))}


def _example(rng, n, shape, params):
    """A light ramp across each frame, HG/LG with noise (:func:`scene_frames`)."""
    hg, lg = scene_frames(hdr_config(**model_params(params)), rng, n, *shape)
    dt = pixel_dtype(params["pixel_bits"])
    return {"hg": hg.astype(dt), "lg": lg.astype(dt)}


def _to_beats(arrays, params):
    """``ppc`` pixels per beat, pixel-major (HG, LG) pairs; ``gain_sel`` on the ctrl of a
    frame's first beat; ``reset_before`` counts beats of frame ``reset_frame``. The frame
    width must be a multiple of ``ppc``."""
    cfg = hdr_config(**model_params(params))
    ppc = params["ppc"]
    hg, lg, sels = arrays["hg"], arrays["lg"], arrays["gain_sel"]
    _check_width(np.shape(hg)[-1], ppc)
    stim = frames_to_beats(np.stack([hg, lg], axis=-1), ppc=ppc, channels=2)
    exp = frames_to_beats(arrays["out"], ppc=ppc)
    per = hg[0].size // ppc
    frame_of = np.arange(len(stim)) // per
    if cfg.sel_bits:
        # only the value presented with a frame's first pixel counts: every other beat
        # carries a random gain_sel that the block must ignore
        noise = np.random.default_rng(12345).integers(0, 1 << cfg.sel_bits, len(stim))
        stim.ctrl = np.where(stim.first, sels[frame_of], noise).astype(np.uint64)
    if "reset_frame" in arrays:
        r, cut = int(arrays["reset_frame"][0]), int(arrays["reset_before"][0])
        keep = np.ones(len(stim), bool)
        keep[r * per + cut:(r + 1) * per] = False
        stim, exp = stim.select(keep), exp.select(keep)
        mark_resets(stim, exp, [r * per + cut])
    return stim, exp


def _ppc_cases():
    """At ppc 2, 4 and 8: a scene, a reset mid-row, the count saturating inside a beat
    (``ramp_multi``: 15 band pixels at most) and the smallest width (one beat per row); at
    ppc 8 also the LG sweep, constant extremes, empty bands, gain changes and the coarse
    16-bit format."""
    out = []
    for k, ppc in enumerate(PPC_CHOICES[1:]):
        p, pm = {"ppc": ppc}, {**MULTI, "ppc": ppc}
        out += [
            Case(f"scene_12b_p{ppc}", p, _scene(3, 16, 32), seed=20 + k),
            Case(f"reset_mid_frame_multi_p{ppc}", pm, _reset_beats([2, 2, 1, 0]),
                 seed=30 + k, tags=("reset", "runtime")),
            Case(f"ramp_multi_p{ppc}", pm, _ramp, seed=40 + k,
                 tags=("monotonic", "count-saturation")),
            Case(f"narrow_12b_p{ppc}", p, _scene(3, 8, ppc, span=(0.8, 1.2)), seed=50 + k,
                 tags=("narrow",)),
        ]
    p8 = {"ppc": 8}
    out += [
        Case("ramp_12b_p8", p8, _ramp, seed=60, tags=("monotonic", "threshold", "fullscale")),
        Case("extremes_12b_p8", p8, _extremes_wide, seed=61, tags=("fullscale", "zeros")),
        Case("empty_band_12b_p8", p8, _empty_band(24), seed=62, tags=("empty-band",)),
        Case("gain_change_multi_p8", {**MULTI, "ppc": 8},
             _scene(8, 8, 24, [0, 0, 1, 1, 2, 3, 3, 0], span=(0.8, 1.2)), seed=63,
             tags=("runtime", "count-saturation")),
        Case("scene_coarse_16b_p8", {**COARSE, "ppc": 8}, _scene(3, 12, 24), seed=64,
             tags=("clamp",)),
        Case("extremes_coarse_16b_p8", {**COARSE, "ppc": 8}, _extremes_wide, seed=65,
             tags=("fullscale", "zeros")),
    ]
    return out


# ---- scene
MULTI = {"gain_pairs": "4.9:0.8,4.9:1.6,2.45:0.8", "count_bits": 4}
COARSE = {"pixel_bits": 16, "anchor": "threshold", "slope_frac_bits": 0, "lgt_frac_bits": 0,
          "out_bits": 16, "band": 64}


@dataclass(frozen=True)
class HdrOptions:
    """``[pipeline.hdr]``: HG threshold, width of the band below it, slope fraction bits."""

    threshold_dn: int
    band_dn: int = 64
    slope_frac_bits: int = 8


def _read_options(sec, sensor):
    full = sensor.full_scale_dn
    threshold = sec.integer("threshold_dn", 3 * (full + 1) // 4 if full > 1 else 1, lo=1,
                            hi=max(1, full - 1))
    return HdrOptions(threshold_dn=threshold,
                      band_dn=sec.integer("band_dn", min(64, threshold), lo=1, hi=threshold),
                      slope_frac_bits=sec.integer("slope_frac_bits", 8, lo=0, hi=16))


OPTIONS = Options(
    HdrOptions, _read_options,
    "High/low-gain merge of the two channels of a dual-gain sensor ([sensor].gains with two "
    "entries).",
    {"threshold_dn": KeyDoc("DN", "high-gain level above which the low-gain channel is used",
                            default="3/4 of full scale", range="1..2**bits - 2"),
     "band_dn": KeyDoc("DN", "width of the blending band below threshold_dn",
                       default="min(64, threshold_dn)", range="1..threshold_dn"),
     "slope_frac_bits": KeyDoc("bit", "fractional bits of the measured gain ratio")})


# ---- chain
def _pipeline_hw(step, data, *, ecp5=False):
    """The merge stage; at ``ppc`` >= 2 a register slice follows it (``out_slice``):
    without it TDI's input ready reached hdr's clock enables in one cycle (the Ning et al.
    2019 chain at ppc 8: 94.1 MHz, that path 10.6 ns); at ppc 1 the top is as it was."""
    cut = step.params.get("ppc", 1) > 1
    return lane_stage("merge", out_slice=cut)(step, data, ecp5=ecp5)


def _pipeline_step(ctx):
    h, g = ctx.scene.pipeline.hdr, ctx.scene.sensor.gains
    if len(g) != 2:
        raise TdicamError(f"pipeline: hdr merges two gain channels; [sensor].gains has "
                          f"{len(g)}")
    p = {"pixel_bits": ctx.bits, "threshold": h.threshold_dn, "band": h.band_dn,
         "gain_pairs": f"{g[0]}:{g[1]}", "slope_frac_bits": h.slope_frac_bits}
    return Step("hdr", p), hdr_config(**p).out_bits


# ---- simulator
def _sim_step(c: RunView, fr: Frames):
    """Golden HDR merge of the HG and LG channels into one."""
    if len(fr.channels) != 2:
        return
    p = _sim.step(c, BLOCK, fr.bits, fr.channels[0].shape[-1]).params
    merged = _sim.golden(BLOCK, {"hg": fr.channels[0], "lg": fr.channels[1]}, p)
    if fr.keep is not None:
        fr.crop[BLOCK.name] = {"hg": fr.keep(fr.channels[0]), "lg": fr.keep(fr.channels[1]),
                               "out": fr.keep(merged), "params": p}
    fr.bits = hdr_config(**p).out_bits
    fr.channels = [merged]


#: The block in the scene simulator.
SIM = SceneSim((Sim("block hdr (golden model)", _sim_step, per_exposure=True),),
               scratch_bytes=22.0)


# ---- entry
BLOCK = Block(
    name="hdr",
    summary="HG/LG dual-gain merge, junction measured on the previous frame (Ning et al. 2019 §4.4.2)",
    params=(
        Param("pixel_bits", 12, "HG and LG pixel width", lo=8, hi=16),
        Param("threshold", None, "threshold T on HG (default 3/4 of full scale)", lo=1,
              hi=65535),
        Param("band", None, "band [T - band, T) of the junction statistics (default "
              "2**(pixel_bits-5))", lo=1, hi=65535),
        Param("gain_pairs", DEFAULT_GAINS, "slope table: programmed gain pairs 'hg:lg,...' "
              "selected by the gain_sel port", type=str),
        Param("slope_frac_bits", 8, "fraction bits of the slope", lo=0, hi=12),
        Param("lgt_frac_bits", 4, "fraction bits of L_T and H_T", lo=0, hi=8),
        Param("anchor", "band", "HG level of the junction: band mean or threshold T",
              choices=ANCHORS, type=str),
        Param("count_bits", 24, "band pixel counter width (saturating)", lo=4, hi=32),
        Param("out_bits", None, "output width (default: enough for the largest slope)",
              lo=8, hi=24),
        PPC_PARAM,
    ),
    top=_top,
    ecp5_top=_ecp5_top,
    cases=lambda: [
        Case("ramp_12b", {}, _ramp, seed=1, tags=("monotonic", "threshold", "fullscale")),
        Case("scene_12b", {}, _scene(3, 16, 32), seed=2),
        Case("empty_band_12b", {}, _empty_band(20), seed=3, tags=("empty-band",)),
        Case("extremes_12b", {}, _extremes, seed=4, tags=("fullscale", "zeros")),
        Case("reset_mid_frame_12b", {}, _reset_mid_frame([0, 0, 0, 0]), seed=5,
             tags=("reset",)),
        Case("gain_change_multi", MULTI,
             _scene(8, 8, 24, [0, 0, 1, 1, 2, 3, 3, 0], span=(0.8, 1.2)), seed=6,
             tags=("runtime", "count-saturation")),
        Case("ramp_multi", MULTI, _ramp, seed=7, tags=("monotonic", "count-saturation")),
        Case("reset_mid_frame_multi", MULTI, _reset_mid_frame([2, 2, 1, 0]), seed=8,
             tags=("reset", "runtime")),
        Case("scene_coarse_16b", COARSE, _scene(3, 12, 24), seed=9, tags=("clamp",)),
        Case("extremes_coarse_16b", COARSE, _extremes, seed=10, tags=("fullscale", "zeros")),
        *_ppc_cases(),
    ],
    check=_check,
    model_version="hdr-1",
    streams=Streams(
        to_beats=_to_beats,
        stream="hg",
        side_inputs=(
            SideInput("lg", "pixel", "the low-gain channel of the same pixel, element 2k + 1 "
                      "of each input beat for its pixel k (the high-gain channel, the stream: 2k)"),
            SideInput("gain_sel", "frame", "index of the frame's programmed gain pair "
                      "(--gain-pairs), on the gain_sel port with the frame's first pixel",
                      default=_zeros_per_frame),
        ),
        golden=_golden,
        unstream=_unstream,
        example=_example,
        small=((4, 64), {}),
    ),
    pipeline=Use(_pipeline_step, _pipeline_hw, merge=True, per_frame=True, rank=3,
                 options=OPTIONS,
                 sim=SIM),
    order=40,
    bench=Bench("hdr", StreamWork("hdr", "hdr", {}, "pixel",
                                  "frames of 1280 x 4, 12-bit HG/LG light ramp", (4, 1280), PX,
                                  PX_QUICK)),
    synth=(SynthRef("hdr", {"pixel_bits": 12}, note="12-bit HG + LG"),),
    suite=Suite(stalls=Stalls("scene_12b", extra_cycles=_frame_start_stalls,
                              full_rate=("scene_12b_p2", "scene_12b_p4", "scene_12b_p8"))),
)
