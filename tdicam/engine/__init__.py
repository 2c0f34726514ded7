"""Scene simulator: runs only the effects a scene calls for, in a fixed physical order.

:func:`simulate` turns a validated :class:`~tdicam.scene.loader.Scene` into the camera's images —
the ideal target, one raw exposure of every ground line, and the TDI output — plus an
effects table and measured-vs-predicted image quality. The table of effects
(:data:`~tdicam.engine.effects.EFFECTS`) says for each effect when a scene needs it and why,
its error bound in the fast aggregate and its exact and fast implementations; the engine
runs only the effects that are needed and records for each: ran or skipped and why, wall
time, the fidelity used and its stated error bound, and its impact on the output (PSNR and
RMS change of the output against the output without that effect, on a crop, with the same
random numbers for every other effect).

Package layout: :mod:`~tdicam.engine.effects` (the table), :mod:`~tdicam.engine.context`
(the :class:`RunContext` of one run and its configuration), :mod:`~tdicam.engine.exact` and
:mod:`~tdicam.engine.fast` (the two fidelities), :mod:`~tdicam.engine.block_rows` (the
pipeline blocks' rows of the table, generated from the registry: what each block does to the
frame stacks is its entry's :attr:`tdicam.blocks.Use.sim`), :mod:`~tdicam.engine.streams`
(random numbers, threads, timing), this module (the entry point and the impact study).

Physical order
--------------
optics (Gaussian PSF) -> aperture (pixel active area and the image motion during one
exposure) -> smear (stage misregistration from velocity mismatch and drift) -> rolling_skew
(row read-time offsets of a rolling shutter) -> prnu -> dark_current -> dsnu -> shot_noise
-> full_well -> reset_frames (for CDS) -> read_noise -> dual_gain (HG/LG channels) ->
quantization (ADC per exposure) -> the pipeline blocks of the registry in their
``[pipeline].blocks`` rank (cds -> nuc -> hdr -> median3 before TDI), the line-making block
(tdi) and the blocks on its output (median3 after TDI). Physics lives in :mod:`tdicam.model.physics.optics` (where each exposure looks)
and :mod:`tdicam.model.physics.sensor` (charge, noise, ADC); the hardware blocks run through their
golden models ``tdicam.model.<block>``.

Fidelity
--------
``exact``
    every exposure of every pixel is generated (Poisson charge, full-well clip, read noise)
    and quantized; the per-exposure blocks run on every frame and the frames go through the
    golden TDI accumulator.
``fast``
    the m exposures of a ground line are aggregated where that is exact in distribution —
    the sum of Poisson charges is Poisson of the summed mean (so PRNU, DSNU, dark current and
    smear enter exactly through the mean), read noise sums to ``Normal(0, m r^2)`` — and
    approximated where it is not: the m roundings of the ADC become one rounding of the
    summed value plus ``Normal(0, (n - 1)/12)`` DN (``n`` conversions), which is exact in mean
    and variance when the temporal noise dithers the ADC. The stated bound is the rounding
    defect at the darkest level of the scene
    (:func:`~tdicam.engine.effects.rounding_defect`: the Poisson charge lattice and the
    Gaussian read noise at every harmonic of the DN grid, and with CDS the reset sample's
    read noise alone — Widrow's ``exp(-2 pi^2 sigma_DN^2)`` is its first Gaussian term); where
    it exceeds :data:`MOMENTS_BELOW_DITHER` the sum is drawn instead as integers with the exact
    mean and variance of every rounding (:func:`tdicam.model.physics.sensor.quantized_moments`,
    Gaussian noise in front of the ADC), so the undithered rounding bias is kept; per-exposure
    clipping (full well, ADC range, CDS clamp) is not reproduced, with its probability as the
    bound. A Poisson sum of mean >= ``1 / (4 tolerance^2)`` (Berry-Esseen distance <
    tolerance) is drawn as a Normal of the same mean and variance. Blocks that act on single
    exposures and are not linear (nuc, hdr, median3 before TDI) cannot be aggregated: fast
    then falls back to exact, and the report says so.
``auto``
    per effect: fast where its bound is below ``[run].tolerance``, exact otherwise.

Layer: above :mod:`tdicam.scene` and the tools; below :mod:`tdicam.chain` and the services.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from tdicam.errors import TdicamError
from tdicam.model.physics import optics as _optics, targets as _targets
from tdicam.scene.loader import digital_tdi_limits_error
from tdicam.scene.schema import FIDELITIES

from tdicam.engine import exact as _exact, fast as _fast
from tdicam.engine.block_rows import LINES, ROWS
from tdicam.engine.context import RunContext, EffectRecord, decide
from tdicam.engine.effects import EFFECT_NAMES, EFFECTS, FORCIBLE, MOMENTS_BELOW_DITHER, FixedPattern
from tdicam.engine.streams import Timer, threads

__all__ = ["EFFECTS", "EFFECT_NAMES", "EFFECT_LABELS", "FORCIBLE", "EffectRecord",
           "SceneResult", "RunContext", "simulate", "check_point", "threads",
           "MOMENTS_BELOW_DITHER"]

EFFECT_LABELS = {e.name: e.label for e in EFFECTS}
_IMPACT_LINES = 32
#: Largest optics PSF the renderer takes: its MTF exp(-2 pi^2 sigma^2 f^2) is below 1e-3
#: at 0.03 cycles/px already, and the kernel's cost grows as sigma^2 (sigma 160 px: seconds
#: per 64 lines; 1e6 px: hours).
MAX_PSF_SIGMA_PX = 64.0
#: Largest cross-track image motion per line period (``(1 - dV/V) tan(drift)``, pixels) on a
#: target that varies across track: the motion kernel and the render grid grow with it
#: (drift 89.99 degrees, 5,730 px per line: hours for 16 lines of 32 columns).
MAX_CROSS_MOTION_PX = 64.0
_IMPACT_COLS = 256


@dataclass
class SceneResult:
    """Everything one simulation of a scene produced (images as numpy arrays)."""

    stages: int
    dv_over_v: float
    fidelity: str
    target: np.ndarray           # ideal relative radiance at the output pixels (float)
    raw: np.ndarray              # one exposure of each ground line, sensor DN (HG channel)
    single: np.ndarray           # that exposure after the pre-TDI blocks (TDI's input)
    output: np.ndarray           # the camera output (after TDI and post-TDI blocks)
    effects: list
    pedestal_single: float       # DN level of zero light in ``single``
    pedestal_output: float       # DN level of zero light in ``output``
    output_full_scale: int
    seconds: float
    exposure_pixels: int
    geometry: _optics.Geometry
    notes: list = field(default_factory=list)
    frames_crop: dict | None = None   # per-block golden inputs/outputs on the RTL crop
    cpu_seconds: float = 0.0          # process CPU time (all threads) of the simulation
    flash: list | None = None         # NAND store counters per channel (flash = "nand")
    raw_data: dict | None = None      # with keep_raw: the frames entering the blocks

    @property
    def lines_per_s(self):
        return self.output.shape[0] / self.seconds if self.seconds > 0 else float("inf")

    @property
    def exposure_pixels_per_s(self):
        return self.exposure_pixels / self.seconds if self.seconds > 0 else float("inf")


@dataclass
class _PassResult:
    target: np.ndarray
    raw: np.ndarray
    single: np.ndarray
    output: np.ndarray
    pedestal_single: float
    pedestal_output: float
    full_scale: int
    exposure_pixels: int
    crop: dict


class Pass:
    """One pass over ``lines`` output lines of columns ``col0 .. col0 + ncols - 1``: the
    geometry and renderer of the running render effects, the fixed pattern of the window
    rows, the timer, progress and the RTL crop to keep."""

    def __init__(self, c, lines, col0, ncols, timer, progress=None, keep_crop=None):
        sc, sen = c.scene, c.sensor
        self.lines, self.col0, self.ncols = lines, col0, ncols
        self.timer, self.progress, self.keep_crop = timer, progress, keep_crop
        t0 = time.perf_counter()
        self.geometry, flags = geometry(c)
        tgt = _targets.make_target(sc.target, columns=sen.columns, lines=lines)
        self.renderer = _optics.Renderer(tgt, self.geometry, ncols, col0=col0, **flags)
        timer.add("render", time.perf_counter() - t0)
        # fixed pattern of the window rows (first rows of the sensor), whole width, cropped;
        # drawn for the largest window of the sweep (or of this run) so that every stage
        # count of a sweep sees the same pattern
        t0 = time.perf_counter()
        # (an area camera's, c.frame_rows: the frame's first `lines` rows, one an output line)
        rows_fp = lines if c.frame_rows else max(max(sc.tdi.stages), c.m)
        fp = FixedPattern(np.ones((rows_fp, sen.columns)), np.zeros((rows_fp, sen.columns)))
        for step in c.steps("pattern"):
            step(c, fp)
        keep = lines if c.frame_rows else c.m
        fp.gain = fp.gain[:keep, col0:col0 + ncols]
        fp.dark = fp.dark[:keep, col0:col0 + ncols]
        self.pattern = fp
        timer.add("prnu", time.perf_counter() - t0)
        t0 = time.perf_counter()
        self.target = self.renderer.ideal(np.arange(lines))
        timer.add("render", time.perf_counter() - t0)

    def render_grid(self, lo, hi):
        t = time.perf_counter()
        grid = self.renderer.grid(lo, hi)
        self.timer.add("render", time.perf_counter() - t)
        return self.renderer, grid

    def result(self, out, raw, single, ped1, pedm, full_scale, exposures, crop):
        return _PassResult(self.target, raw, single, out, ped1, pedm, full_scale, exposures,
                           crop)


def geometry(c):
    """Geometry and renderer switches of the running render effects of context ``c``."""
    kw = {"stages": c.m, "dv_over_v": 0.0, "drift_deg": 0.0, "skew": 0.0,
          "q_over_p": c.sensor.q_over_p, "psf_sigma_px": 0.0, "optics": False,
          "aperture": False}
    for step in c.steps("render"):
        step(c, kw)
    flags = {"optics": kw.pop("optics"), "aperture": kw.pop("aperture")}
    return _optics.Geometry(**kw), flags


def _run_pass(c, lines, col0, ncols, timer, progress=None, keep_crop=None):
    p = Pass(c, lines, col0, ncols, timer, progress, keep_crop)
    if c.fast:
        return _fast.path(c, p)
    return _exact.digital(c, p) if c.digital else _exact.charge(c, p)


def check_point(scene, m, dv, fid, force=(), disable=()):
    """Refuse, in one line, a sweep point the simulator cannot run: an unknown fidelity or
    effect, more stages than sensor rows or than the digital TDI takes, a PSF wider than
    :data:`MAX_PSF_SIGMA_PX`, more cross-track motion than :data:`MAX_CROSS_MOTION_PX`. Cheap: :func:`tdicam.run.runner.run_scene` checks every point
    before any work."""
    if fid not in FIDELITIES:
        raise TdicamError(f"fidelity = {fid!r} is not valid; valid: {', '.join(FIDELITIES)}")
    for name in list(force) + list(disable):
        if name not in EFFECT_NAMES:
            raise TdicamError(f"unknown effect {name!r}; valid: {', '.join(EFFECT_NAMES)}")
    if LINES in disable:
        raise TdicamError(f"disable {LINES}: the TDI sum is what the camera outputs; it "
                          f"cannot be left out")
    if m > scene.sensor.rows:
        raise TdicamError(f"[tdi].stages: must be <= {scene.sensor.rows} (the sensor rows), "
                          f"got {m}")
    why = digital_tdi_limits_error(scene, m)
    if why is not None:
        raise TdicamError(f"[tdi].{why}" if why.startswith("stages") else f"[sensor].{why}")
    cross = abs((1.0 - dv) * math.tan(math.radians(scene.motion.drift_deg)))
    if cross > MAX_CROSS_MOTION_PX and "x" in _targets.make_target(
            scene.target, columns=scene.sensor.columns, lines=1).axes:
        raise TdicamError(f"[motion].drift_deg = {scene.motion.drift_deg:g} moves the image "
                          f"{cross:.4g} px across track per line; the scene simulator renders "
                          f"at most {MAX_CROSS_MOTION_PX:g} px (drift up to "
                          f"{math.degrees(math.atan(MAX_CROSS_MOTION_PX / (1.0 - dv))):.4g} "
                          f"degrees at dV/V = {dv:g}) on a target that varies across track")
    sigma = scene.optics.psf_sigma_px
    if sigma > MAX_PSF_SIGMA_PX:
        raise TdicamError(f"[optics].psf_sigma_px: must be <= {MAX_PSF_SIGMA_PX:g} px for "
                          f"the scene simulator (its Gaussian kernel spans 8 sigma on a grid "
                          f"of up to 16 samples per pixel), got {sigma:g}")


def simulate(scene, *, stages=None, dv_over_v=None, fidelity=None, force=(), disable=(),
             lines=None, impact=True, progress=None, keep_crop=None, keep_raw=False):
    """Simulate one configuration of ``scene``.

    Parameters
    ----------
    scene : tdicam.scene.loader.Scene
    stages : int, optional
        Stage count (default: the first of ``[tdi].stages``).
    dv_over_v : float, optional
        Velocity mismatch (default: the first of ``[motion].dv_over_v``).
    fidelity : {"exact", "fast", "auto"}, optional
        Default ``[run].fidelity``.
    force : iterable of str
        Effects (from :data:`FORCIBLE`) to run even where the scene does not need them, at
        zero strength; the output must then equal the output with them skipped.
    disable : iterable of str
        Effects to leave out (for impact studies); ``tdi`` cannot be left out.
    lines : int, optional
        Output lines (default ``[run].lines``).
    impact : bool
        Measure each effect's impact on a crop (one extra crop simulation per effect).
    progress : callable(n) or None
        Called with the number of exposure-pixels done, as the work advances.
    keep_crop : (y0, h, x0, w) or None
        Keep the golden blocks' inputs/outputs on this output crop (for RTL co-simulation).
    keep_raw : bool
        Exact digital TDI only: hand out, as ``raw_data`` of the result, the raw frames of
        every channel (and the reset frames with CDS) as they enter the pipeline blocks, and
        the NUC coefficient codes (the input of the camera pipeline's RTL co-simulation).

    Returns
    -------
    SceneResult
    """
    m = int(scene.tdi.stages[0] if stages is None else stages)
    dv = float(scene.motion.dv_over_v[0] if dv_over_v is None else dv_over_v)
    fid = scene.run.fidelity if fidelity is None else fidelity
    check_point(scene, m, dv, fid, force, disable)
    n_lines = int(scene.run.lines if lines is None else lines)
    c = decide(scene, m, dv, fid, force, disable)
    c.keep_raw = bool(keep_raw)
    timer = Timer()
    t0, c0 = time.perf_counter(), time.process_time()
    r = _run_pass(c, n_lines, 0, scene.sensor.columns, timer, progress, keep_crop)
    seconds = time.perf_counter() - t0
    cpu_seconds = time.process_time() - c0
    records = [c.records[n] for n in EFFECT_NAMES]
    render = timer.t.get("render", 0.0)
    for rec in records:
        if rec.ran:
            rec.seconds = render if rec.name == "aperture" else timer.t.get(rec.name, 0.0)
    notes = list(c.notes)
    notes.append(f"rendering (target through aperture, optics and smear) took {render:.3g} s; "
                 f"its time is listed on the aperture row")
    if "raw_exposure" in timer.t:
        notes.append(f"the raw single exposure (exact, stage 0 of every line) took "
                     f"{timer.t['raw_exposure']:.3g} s of the fast run")
    res = SceneResult(m, dv, "fast" if c.fast else "exact", r.target, r.raw, r.single,
                      r.output, records, r.pedestal_single, r.pedestal_output, r.full_scale,
                      seconds, r.exposure_pixels, geometry(c)[0], notes, r.crop, cpu_seconds,
                      [c.flash[k] for k in sorted(c.flash)] or None, c.raw_data)
    for row in ROWS:
        if row.sim.notes is not None:
            notes.extend(row.sim.notes(c))
    if impact:
        _impacts(c, res)
    return res


_RESET_TAKERS = {r.name for r in ROWS if r.block.pipeline.elems == 2}
#: Effects that cannot be removed alone: removing the key removes the values too (the
#: gain merge without a second gain channel, a block that takes reset frames without them).
_REMOVED_WITH = {"dual_gain": {r.name for r in ROWS if r.block.pipeline.merge},
                 "reset_frames": _RESET_TAKERS, **{b: {"reset_frames"} for b in _RESET_TAKERS}}


def _impacts(c, res):
    """PSNR of the output with vs without each effect that ran, on a crop, same RNG."""
    sc = c.scene
    lines = min(res.output.shape[0], _IMPACT_LINES)
    ncols = min(sc.sensor.columns, _IMPACT_COLS)
    col0 = (sc.sensor.columns - ncols) // 2
    base = _run_pass(c.with_effects(c.on), lines, col0, ncols, Timer()).output \
        .astype(np.float64)
    peak = float(res.output_full_scale)
    for r in res.effects:
        if not r.ran or r.name == LINES:    # the TDI sum itself: no impact of its own
            continue
        if r.name == "quantization":
            r.impact = {"note": "the ADC cannot be removed; see the fast-vs-exact error"}
            continue
        on = set(c.on) - {r.name} - _REMOVED_WITH.get(r.name, set())
        try:
            other = _run_pass(c.with_effects(on), lines, col0, ncols, Timer()).output \
                .astype(np.float64)
        except TdicamError as exc:
            r.impact = {"note": f"not measurable: {exc}"}
            continue
        if other.shape != base.shape:
            r.impact = {"note": "output shape changes"}
            continue
        diff = base - other
        mse = float(np.mean(diff * diff))
        r.impact = {
            "psnr_db": None if mse == 0 else 10 * math.log10(peak * peak / mse),
            "rms_dn": math.sqrt(mse),
            "mean_dn": float(diff.mean()),
            "crop": [0, col0, lines, ncols],
        }
        if mse == 0:
            r.impact["note"] = "no change on the crop (PSNR infinite)"
