"""Block ``cds``: digital correlated double sampling."""

from dataclasses import dataclass

import numpy as np

from tdicam.beats import PPC_CHOICES, frames_to_beats, mark_resets
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.cds import Cds
from tdicam.model.cds import cds, pixel_dtype
from tdicam.blocks import Bench, Stalls, StreamWork, Suite, SynthRef
from tdicam.blocks._bench import PX, PX_QUICK
from tdicam.blocks import (PPC_PARAM, Block, Case, KeyDoc, Memory, Options, Param, SceneSim,
                           SideInput, Streams, Use, check_width as _check_width)
from tdicam.blocks import _sim
from tdicam.blocks._pipeline import lane_stage
from tdicam.blocks.steps import Frames, RunView, Sim, Step

__all__ = ["BLOCK", "CdsOptions"]


# ---- top
def _top(*, pixel_bits, ppc):
    return AxisTop(Cds(pixel_bits=pixel_bits, ppc=ppc))


# ---- cases
def _random(frames, rows, cols):
    def make(params, rng):
        b = params["pixel_bits"]
        dt = pixel_dtype(b)
        sig = rng.integers(0, 1 << b, (frames, rows, cols)).astype(dt)
        rst = rng.integers(0, 1 << b, (frames, rows, cols)).astype(dt)
        return {"signal": sig, "reset": rst, "out": cds(sig, rst, pixel_bits=b)}
    return make


def _hard(params, rng, shape=(8, 12)):
    """Zeros, full scale, reset > signal, reset == signal, signal full and reset 0."""
    b = params["pixel_bits"]
    full = (1 << b) - 1
    dt = pixel_dtype(b)
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


def _hard_wide(params, rng):
    """:func:`_hard` on 8 x 16 frames (a width every ``ppc`` divides)."""
    return _hard(params, rng, shape=(8, 16))


def _reset_beats(params, rng):
    """Frame 0 (10 x 16) is cut by a reset in the middle of a row, after beat
    ``cut`` = 9 rows and a half of ``16 / ppc`` beats (rounded up); frame 1 follows clean."""
    out = _random(2, 10, 16)(params, rng)
    wb = 16 // params["ppc"]
    out["reset_before"] = np.array([9 * wb + (wb + 1) // 2], np.int64)
    return out


def _golden(arrays, params):
    return {"out": cds(arrays["signal"], arrays["reset"], pixel_bits=params["pixel_bits"])}


def _example(rng, n, shape, params):
    hi = 1 << params["pixel_bits"]
    return {k: rng.integers(0, hi, (n, *shape), dtype=pixel_dtype(params["pixel_bits"]))
            for k in ("signal", "reset")}


def _to_beats(arrays, params):
    """``ppc`` pixels per beat, pixel-major (signal, reset) pairs: p0.signal p0.reset
    p1.signal ...; ``reset_before`` counts stimulus beats. The frame width must be a
    multiple of ``ppc``."""
    ppc = params["ppc"]
    frames = np.stack([arrays["signal"], arrays["reset"]], axis=-1)
    _check_width(frames.shape[-2], ppc)
    stim = frames_to_beats(frames, ppc=ppc, channels=2)
    exp = frames_to_beats(arrays["out"], ppc=ppc)
    mark_resets(stim, exp, arrays.get("reset_before"))
    return stim, exp


def _ppc_cases():
    """The cases at ppc 2, 4 and 8: random, hard values (16-bit at ppc 8), a reset mid-row,
    the smallest width (one beat per row) and 8-bit pixels at ppc 8."""
    out = []
    for k, ppc in enumerate(PPC_CHOICES[1:]):
        p = {"pixel_bits": 12, "ppc": ppc}
        bits = 16 if ppc == 8 else 12      # (one parameter set, one build, at ppc 2 and 4)
        out += [
            Case(f"random_12b_p{ppc}", p, _random(3, 16, 24), seed=20 + k),
            Case(f"hard_{bits}b_p{ppc}", {"pixel_bits": bits, "ppc": ppc}, _hard_wide,
                 seed=30 + k, tags=("fullscale", "zeros")),
            Case(f"reset_mid_frame_12b_p{ppc}", p, _reset_beats, seed=40 + k,
                 tags=("reset",)),
            Case(f"narrow_12b_p{ppc}", p, _random(3, 6, ppc), seed=50 + k,
                 tags=("narrow",)),
        ]
    out.append(Case("random_8b_p8", {"pixel_bits": 8, "ppc": 8}, _random(2, 8, 32),
                    seed=60))
    return out



# ---- scene
#: ``[pipeline.cds].memory``: where the reset frame is kept.
CDS_MEMORY = ("chip", "ddr")


@dataclass(frozen=True)
class CdsOptions:
    """``[pipeline.cds]``: mean reset level present in both images, DN; where the gateware
    keeps the reset frame (``memory``)."""

    reset_level_dn: float = 0.0
    memory: str = "chip"


def _read_options(sec, sensor):
    full = sensor.full_scale_dn
    return CdsOptions(reset_level_dn=sec.number("reset_level_dn", 0.0, lo=0.0,
                                                hi=float(full + 1), hi_open=True),
                      memory=sec.choice("memory", "chip", CDS_MEMORY))


OPTIONS = Options(
    CdsOptions, _read_options,
    "Digital correlated double sampling: signal frame minus reset frame.",
    {"reset_level_dn": KeyDoc("DN", "mean reset level present in both frames",
                              range="[0, 2**bits)"),
     "memory": KeyDoc("", "chip: the reset frame arrives beside each signal pixel; ddr: "
                          "the sensor's reset frame arrives as a frame of its own before its "
                          "signal frame, is written to the DDR of [ddr] and read back line by "
                          "line (block cds_ddr, Ning et al. 2019 §4.4.1, §4.2)")})


# ---- chain
def _pipeline_step(ctx):
    return Step("cds", {"pixel_bits": ctx.bits}), ctx.bits


# ---- simulator
def _sim_step(c: RunView, fr: Frames):
    """Digital CDS of every channel: signal minus reset frame."""
    bits = c.sensor.bits
    for ch, x in enumerate(fr.channels):
        p = _sim.step(c, BLOCK, bits, x.shape[-1]).params
        y = _sim.golden(BLOCK, {"signal": x, "reset": fr.resets[ch]}, p)
        if fr.keep is not None and ch == 0:
            fr.crop[BLOCK.name] = {"signal": fr.keep(x), "reset": fr.keep(fr.resets[ch]),
                                   "out": fr.keep(y), "params": p}
        fr.channels[ch] = y


def _subtract_reset(signal, reset, bits):
    """The golden model on one frame and its reset frame."""
    return _sim.golden(BLOCK, {"signal": signal, "reset": reset}, {"pixel_bits": bits})


#: The block in the scene simulator.
SIM = SceneSim((Sim("block cds (golden model)", _sim_step, aggregated=True,
                    subtract=_subtract_reset,
                    pedestal=lambda scene: scene.pipeline.cds.reset_level_dn),),
               scratch_bytes=14.0)


# ---- entry
BLOCK = Block(
    name="cds",
    summary="digital CDS: signal - reset per pixel, clamped at 0 (Ning et al. 2019 §4.4.1)",
    params=(Param("pixel_bits", 12, "signal, reset and output pixel width", lo=8, hi=16),
            PPC_PARAM),
    top=_top,
    cases=lambda: [
        Case("random_8b", {"pixel_bits": 8}, _random(3, 16, 24), seed=1),
        Case("random_12b", {"pixel_bits": 12}, _random(3, 16, 24), seed=2),
        Case("random_16b", {"pixel_bits": 16}, _random(3, 16, 24), seed=3),
        Case("hard_12b", {"pixel_bits": 12}, _hard, seed=4, tags=("fullscale", "zeros")),
        Case("hard_16b", {"pixel_bits": 16}, _hard, seed=5, tags=("fullscale", "zeros")),
        Case("reset_mid_frame_12b", {"pixel_bits": 12}, _reset_mid_frame, seed=6,
             tags=("reset",)),
        *_ppc_cases(),
    ],
    model_version="cds-1",
    streams=Streams(
        to_beats=_to_beats,
        stream="signal",
        side_inputs=(SideInput("reset", "pixel", "the pixel's reset sample (CDS reset frame), "
                               "element 2k + 1 of each input beat (pixel k's signal: 2k)"),),
        golden=_golden,
        example=_example,
        small=((4, 40), {}),
    ),
    pipeline=Use(_pipeline_step, lane_stage(elems=2), elems=2, per_frame=True, rank=1,
                 memory=Memory(holds="reset frames",
                               placement=lambda scene: scene.pipeline.cds.memory,
                               spill="cds_ddr", caller_places=False),
                 options=OPTIONS,
                 sim=SIM),
    order=10,
    bench=Bench("cds", StreamWork("cds", "cds", {"pixel_bits": 12}, "pixel",
                                  "frames of 1280 x 4, 12-bit", (4, 1280), PX, PX_QUICK)),
    synth=(SynthRef("cds", {"pixel_bits": 12}),),
    suite=Suite(stalls=Stalls("random_12b", full_rate=("random_12b_p2", "random_12b_p4",
                                                      "random_12b_p8"))),
)
