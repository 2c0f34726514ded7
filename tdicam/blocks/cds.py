"""Block ``cds``: digital correlated double sampling."""

from dataclasses import dataclass

import numpy as np

from tdicam.beats import frames_to_beats, mark_resets
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.cds import Cds
from tdicam.model.cds import cds, pixel_dtype
from tdicam.blocks import Block, Case, KeyDoc, Options, Param, SideInput, Use
from tdicam.blocks._pipeline import lane_stage
from tdicam.blocks.steps import Step

__all__ = ["BLOCK", "CdsOptions"]


def _top(*, pixel_bits):
    return AxisTop(Cds(pixel_bits=pixel_bits))


def _random(frames, rows, cols):
    def make(params, rng):
        b = params["pixel_bits"]
        dt = pixel_dtype(b)
        sig = rng.integers(0, 1 << b, (frames, rows, cols)).astype(dt)
        rst = rng.integers(0, 1 << b, (frames, rows, cols)).astype(dt)
        return {"signal": sig, "reset": rst, "out": cds(sig, rst, pixel_bits=b)}
    return make


def _hard(params, rng):
    """Zeros, full scale, reset > signal, reset == signal, signal full and reset 0."""
    b = params["pixel_bits"]
    full = (1 << b) - 1
    dt = pixel_dtype(b)
    shape = (8, 12)
    pairs = [(0, 0), (full, full), (full, 0), (0, full), (5, 6), (6, 5)]
    sig = np.stack([np.full(shape, s, dt) for s, _ in pairs])
    rst = np.stack([np.full(shape, r, dt) for _, r in pairs])
    # one frame of random values where reset is always 1 above signal (clamp every pixel)
    r = rng.integers(1, full + 1, shape).astype(dt)
    sig = np.concatenate([sig, (r - 1)[None]])
    rst = np.concatenate([rst, r[None]])
    return {"signal": sig, "reset": rst, "out": cds(sig, rst, pixel_bits=b)}


def _reset_mid_frame(params, rng):
    """Frame 0 is cut by a reset after ``cut`` pixels; frame 1 follows clean."""
    out = _random(2, 10, 16)(params, rng)
    out["reset_before"] = np.array([77], np.int64)
    return out


def _golden(arrays, params):
    return {"out": cds(arrays["signal"], arrays["reset"], pixel_bits=params["pixel_bits"])}


def _example(rng, n, shape, params):
    hi = 1 << params["pixel_bits"]
    return {k: rng.integers(0, hi, (n, *shape), dtype=pixel_dtype(params["pixel_bits"]))
            for k in ("signal", "reset")}


def _to_beats(arrays, params):
    stim = frames_to_beats(np.stack([arrays["signal"], arrays["reset"]], axis=-1), channels=2)
    exp = frames_to_beats(arrays["out"])
    mark_resets(stim, exp, arrays.get("reset_before"))
    return stim, exp



@dataclass(frozen=True)
class CdsOptions:
    """``[pipeline.cds]``: mean reset level present in both images, DN."""

    reset_level_dn: float = 0.0


def _read_options(sec, sensor):
    full = sensor.full_scale_dn
    return CdsOptions(reset_level_dn=sec.number("reset_level_dn", 0.0, lo=0.0,
                                                hi=float(full + 1), hi_open=True))


OPTIONS = Options(
    CdsOptions, _read_options,
    "Digital correlated double sampling: signal frame minus reset frame.",
    {"reset_level_dn": KeyDoc("DN", "mean reset level present in both frames",
                              range="[0, 2**bits)")})


def _pipeline_step(ctx):
    return Step("cds", {"pixel_bits": ctx.bits}), ctx.bits


BLOCK = Block(
    name="cds",
    summary="digital CDS: signal - reset per pixel, clamped at 0 (Ning et al. 2019 §4.4.1)",
    params=(Param("pixel_bits", 12, "signal, reset and output pixel width", lo=8, hi=16),),
    top=_top,
    cases=lambda: [
        Case("random_8b", {"pixel_bits": 8}, _random(3, 16, 24), seed=1),
        Case("random_12b", {"pixel_bits": 12}, _random(3, 16, 24), seed=2),
        Case("random_16b", {"pixel_bits": 16}, _random(3, 16, 24), seed=3),
        Case("hard_12b", {"pixel_bits": 12}, _hard, seed=4, tags=("fullscale", "zeros")),
        Case("hard_16b", {"pixel_bits": 16}, _hard, seed=5, tags=("fullscale", "zeros")),
        Case("reset_mid_frame_12b", {"pixel_bits": 12}, _reset_mid_frame, seed=6,
             tags=("reset",)),
    ],
    model_version="cds-1",
    to_beats=_to_beats,
    stream="signal",
    side_inputs=(SideInput("reset", "pixel", "the pixel's reset sample (CDS reset frame), "
                           "element 1 of each input beat"),),
    golden=_golden,
    example=_example,
    pipeline=Use(_pipeline_step, lane_stage(elems=2), elems=2, per_frame=True, rank=1,
                 scratch_bytes=14.0,
                 options=OPTIONS),
)
