"""Scene simulator: runs only the effects a scene calls for, in a fixed physical order (SPEC 4).

:func:`simulate` turns a validated :class:`~tdicam.scene.Scene` into the camera's images —
the ideal target, one raw exposure of every ground line, and the TDI output — plus an
effects table and measured-vs-predicted image quality. Each effect in :data:`EFFECTS`
declares when a scene needs it; the engine runs only those and records for each: ran or
skipped and why, wall time, the fidelity used and its stated error bound, and its impact on
the output (PSNR and RMS change of the output against the output without that effect, on a
crop, with the same random numbers for every other effect).

Physical order (:data:`EFFECTS`)
--------------------------------
optics (Gaussian PSF) -> aperture (pixel active area and the image motion during one
exposure) -> smear (stage misregistration from velocity mismatch and drift) -> rolling_skew
(row read-time offsets of a rolling shutter) -> prnu -> dark_current -> dsnu -> shot_noise
-> full_well -> reset_frames (for CDS) -> read_noise -> dual_gain (HG/LG channels) ->
quantization (ADC per exposure) -> cds -> nuc -> hdr -> median3 (before TDI) -> tdi ->
median3 (after TDI). Physics lives in :mod:`tdicam.model.optics` (where each exposure looks)
and :mod:`tdicam.model.sensor` (charge, noise, ADC); the hardware blocks run through their
golden models ``tdicam.model.<block>`` via thin adapters; a block whose golden model cannot
be imported is reported ``skipped: golden model not available``.

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
    and variance when the temporal noise dithers the ADC. The stated bound is the Widrow
    dependence ``exp(-2 pi^2 sigma_DN^2)`` at the darkest level of the scene; where it
    exceeds :data:`MOMENTS_BELOW_DITHER` the sum is drawn instead as integers with the exact
    mean and variance of every rounding (:func:`tdicam.model.sensor.quantized_moments`,
    Gaussian noise in front of the ADC), so the undithered rounding bias is kept; per-exposure
    clipping (full well, ADC range, CDS clamp) is not reproduced, with its probability as the
    bound. A Poisson sum of mean >= ``1 / (4 tolerance^2)`` (Berry-Esseen distance <
    tolerance) is drawn as a Normal of the same mean and variance. Blocks that act on single
    exposures and are not linear (nuc, hdr, median3 before TDI) cannot be aggregated: fast
    then falls back to exact, and the report says so.
``auto``
    per effect: fast where its bound is below ``[run].tolerance``, exact otherwise.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import os
import time
from dataclasses import dataclass, field

import numpy as np

from tdicam.errors import TdicamError
from tdicam.model import optics as _optics
from tdicam.model import sensor as _sensor
from tdicam.model import targets as _targets

__all__ = ["EFFECTS", "EFFECT_LABELS", "EffectRecord", "SimResult", "simulate", "tdi_sum",
           "golden_available"]

#: Effects in the fixed physical order.
EFFECTS = ("optics", "aperture", "smear", "rolling_skew", "prnu", "dark_current", "dsnu",
           "shot_noise", "full_well", "reset_frames", "read_noise", "dual_gain",
           "quantization", "cds", "nuc", "hdr", "median3_pre", "tdi", "median3_post")
EFFECT_LABELS = {
    "optics": "optics PSF (Gaussian)",
    "aperture": "pixel aperture + exposure motion",
    "smear": "motion smear (dV/V, drift)",
    "rolling_skew": "rolling-shutter row skew",
    "prnu": "PRNU",
    "dark_current": "dark current",
    "dsnu": "DSNU",
    "shot_noise": "photon/dark shot noise",
    "full_well": "full-well clipping",
    "reset_frames": "reset frames for CDS",
    "read_noise": "read noise",
    "dual_gain": "dual-gain channels (HG/LG)",
    "quantization": "ADC quantization per exposure",
    "cds": "block cds (golden model)",
    "nuc": "block nuc (golden model)",
    "hdr": "block hdr (golden model)",
    "median3_pre": "block median3 before TDI (golden)",
    "tdi": "TDI accumulation",
    "median3_post": "block median3 after TDI (golden)",
}
_BLOCK_OF = {"cds": "cds", "nuc": "nuc", "hdr": "hdr", "median3_pre": "median3",
             "median3_post": "median3", "tdi": "tdi"}
#: Effects that can be forced on at zero strength (to check that skipping them is exact).
FORCIBLE = ("optics", "smear", "rolling_skew", "prnu", "dark_current", "dsnu", "full_well",
            "read_noise")
# fixed RNG stream per effect: disabling one never changes another's random numbers
_STREAM = {"fpn_prnu": 1, "fpn_dsnu": 2, "shot": 3, "read": 4, "read_reset": 5, "quant": 6,
           "read_lg": 7, "read_reset_lg": 8}
_IMPACT_LINES = 32
#: In fast fidelity the raw single exposure covers at most this many ground lines.
RAW_LINES = 256
_IMPACT_COLS = 256
#: Fast fidelity sums exact per-rounding moments where the Widrow defect exceeds this.
MOMENTS_BELOW_DITHER = 1e-4


def golden_available(block):
    """True when ``tdicam.model.<block>`` imports (the golden model has landed)."""
    try:
        importlib.import_module(f"tdicam.model.{block}")
    except ImportError:
        return False
    return True


@dataclass
class EffectRecord:
    """One row of the effects table."""

    name: str
    label: str
    ran: bool
    why: str
    fidelity: str = "-"
    seconds: float = 0.0
    bound: float | None = None
    impact: dict | None = None

    def to_dict(self):
        return dataclasses.asdict(self)


@dataclass
class SimResult:
    """Everything one simulation produced (images as numpy arrays)."""

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

    @property
    def lines_per_s(self):
        return self.output.shape[0] / self.seconds if self.seconds > 0 else float("inf")

    @property
    def exposure_pixels_per_s(self):
        return self.exposure_pixels / self.seconds if self.seconds > 0 else float("inf")


# --------------------------------------------------------------------------------------
# golden-model adapters
# --------------------------------------------------------------------------------------


def tdi_sum(frames, *, stages, direction=0, out_bits=None):
    """Vectorized digital TDI of a frame stack: ``O(t) = sum_k P_k(t - k + 1)`` (SPEC 3.1).

    Bit-exact with :func:`tdicam.model.tdi.tdi` for integer frames (tested): line ``i`` is
    ``sum_j frames[i + m - 1 - j, row(j)]`` with ``row(j) = j`` forward and ``m - 1 - j``
    reverse, summed in int64, saturated at ``2**out_bits - 1`` when ``out_bits`` is given.
    """
    f = np.asarray(frames)
    n, m, w = f.shape[0] - stages + 1, stages, f.shape[2]
    if n <= 0:
        return np.zeros((0, w), np.int64)
    acc = np.zeros((n, w), np.int64)
    for j in range(m):
        row = j if direction == 0 else m - 1 - j
        acc += f[m - 1 - j:m - 1 - j + n, row, :]
    if out_bits is not None:
        np.minimum(acc, (1 << out_bits) - 1, out=acc)
    return acc


def _bits_of(maxval):
    return max(1, int(maxval).bit_length())


# --------------------------------------------------------------------------------------
# configuration of one run
# --------------------------------------------------------------------------------------


@dataclass
class _Cfg:
    scene: object
    m: int
    dv: float
    fidelity: str            # requested: exact | fast | auto
    on: set                  # effects that run
    forced: set
    fast: bool               # aggregate the exposures
    records: dict
    skew: float
    dark_e: float
    gains: tuple
    n_reads: int             # conversions per exposure (2 with CDS)
    offset_dn: float
    notes: list
    fast_fpn_mean: bool = False
    quant_moments: bool = False      # fast: exact moments of every rounding (noise < ~0.7 DN)


def _seq(seed, name):
    return np.random.default_rng(np.random.SeedSequence([int(seed), _STREAM[name]]))


def _decide(scene, m, dv, force, disable):
    """Which effects the scene needs, and why (before fidelity)."""
    sen, tdi, pipe = scene.sensor, scene.tdi, scene.pipeline
    drift = scene.motion.drift_deg
    t_line = scene.line_period_s
    t_row = sen.row_time_s
    S = scene.target.signal_e
    dark_e = sen.dark_current_e_per_s * t_line
    rec = {}

    def put(name, need, why):
        if name in disable:
            need, why = False, f"disabled by request ({why})"
        elif name in force and not need:
            if name not in FORCIBLE:
                raise TdicamError(f"--force {name}: only {', '.join(FORCIBLE)} can be forced on")
            need, why = True, f"forced on at zero strength ({why})"
        rec[name] = EffectRecord(name, EFFECT_LABELS[name], bool(need), why)

    sig = scene.optics.psf_sigma_px
    put("optics", sig > 0, f"Gaussian PSF sigma {sig:g} px" if sig > 0
        else "[optics].psf_sigma_px = 0: perfect lens")
    put("aperture", True, f"every pixel integrates its active area (q/p = {sen.q_over_p:.3g}) "
                          f"while the image moves {1 - dv:.4g} px in the line period")
    if m == 1:
        put("smear", False, "1 stage: nothing to misregister")
    elif dv == 0 and drift == 0:
        put("smear", False, "dV/V = 0 and no drift")
    else:
        put("smear", True, f"dV/V = {dv:g}, drift {drift:g} deg: M dV/V = {m * dv:.3g} px "
                           f"along, M tan(drift) = {m * math.tan(math.radians(drift)):.3g} px "
                           f"across")
    skew = 0.0
    if sen.shutter == "global":
        put("rolling_skew", False, "global shutter: all rows expose together")
    elif m == 1:
        put("rolling_skew", False, "1 stage: no stage-to-stage skew")
    elif t_row is None:
        put("rolling_skew", False, "rolling shutter but no row time ([sensor].pixel_clock_mhz "
                                   "or max_frame_rate_hz): skew unknown")
    else:
        skew = (t_row / t_line) * (1.0 if tdi.direction == "forward" else -1.0)
        put("rolling_skew", True, f"T_row/T_line = {t_row / t_line:.4g} per stage, "
                                  f"{m * t_row / t_line:.3g} px over {m} stages "
                                  f"({tdi.direction} scan)")
    put("prnu", sen.prnu > 0, f"PRNU {100 * sen.prnu:g} % RMS" if sen.prnu > 0 else "PRNU = 0")
    put("dark_current", sen.dark_current_e_per_s > 0,
        f"{sen.dark_current_e_per_s:g} e-/s x {t_line * 1e6:.4g} us = {dark_e:.3g} e- per "
        f"exposure" if sen.dark_current_e_per_s > 0 else "dark current = 0")
    put("dsnu", sen.dsnu_e > 0, f"DSNU {sen.dsnu_e:g} e- RMS" if sen.dsnu_e > 0 else "DSNU = 0")
    lit = S > 0 or dark_e > 0
    put("shot_noise", lit, "charge is Poisson" if lit else "no light and no dark current")
    # full well: can an exposure (or the charge sum) come near it?
    peak = S * (1 + 4 * sen.prnu) + dark_e + 4 * sen.dsnu_e
    if tdi.domain == "charge":
        peak *= m
    reach = peak + 5 * math.sqrt(max(peak, 0.0))
    need_fw = reach >= sen.full_well_e
    put("full_well", need_fw,
        f"{'charge sum' if tdi.domain == 'charge' else 'brightest exposure'} reaches "
        f"{reach:.4g} e- (mean + 5 sigma) "
        f"{'>=' if need_fw else '<'} full well {sen.full_well_e:g} e-")
    cds_on = "cds" in pipe.blocks
    put("reset_frames", cds_on, "the cds block subtracts a reset frame" if cds_on
        else "no cds block in the pipeline")
    put("read_noise", sen.read_noise_e > 0, f"{sen.read_noise_e:g} e- RMS per sample"
        if sen.read_noise_e > 0 else "read noise = 0")
    two = len(sen.gains) == 2
    put("dual_gain", two, f"gains HG x{sen.gains[0]:g} / LG x{sen.gains[1]:g}" if two
        else "one-gain sensor")
    put("quantization", True, f"{sen.bits}-bit ADC, {sen.conversion_gain_e_per_dn:.4g} e-/DN "
                              f"at gain 1")
    for name in ("cds", "nuc", "hdr", "median3_pre", "tdi", "median3_post"):
        block = _BLOCK_OF[name]
        listed = block in pipe.blocks
        if name.startswith("median3") and listed:
            listed = (name == "median3_post") == bool(pipe.median_after_tdi)
        if name == "tdi" and tdi.domain == "charge":
            put(name, True, f"charge domain: {m} stages summed as charge before one readout "
                            f"(seed 004); the FPGA accumulator is not used")
            continue
        if not listed:
            where = "" if not name.startswith("median3") or block not in pipe.blocks else \
                (" here (it runs " + ("after" if pipe.median_after_tdi else "before") + " TDI)")
            put(name, False, f"not in [pipeline].blocks{where}")
        elif name == "hdr" and not two:
            put(name, False, "one-gain sensor: nothing to merge")
        elif not golden_available(block):
            put(name, False, f"golden model not available (tdicam.model.{block})")
        else:
            put(name, True, f"in [pipeline].blocks, golden model tdicam.model.{block}")
    return rec, skew, dark_e


def _fast_bounds(scene, m, rec, dark_e, tolerance):
    """Stated error bounds of the fast aggregate per effect; None where fast is exact."""
    sen = scene.sensor
    S = scene.target.signal_e
    conv = sen.conversion_gain_e_per_dn / sen.gains[0]
    n_reads = 2 if rec["reset_frames"].ran else 1
    # darkest level of the scene: chart dark level or 0 for pictures
    dark_rel = 0.0
    kind = scene.target.kind
    if kind == "flat":
        dark_rel = 1.0
    elif kind in ("bars", "edge", "siemens"):
        c = scene.target.contrast
        dark_rel = (1 - c) / (1 + c)
    var_e = (S * dark_rel if rec["shot_noise"].ran else 0.0) \
        + (dark_e if rec["shot_noise"].ran else 0.0) \
        + (sen.read_noise_e ** 2 if rec["read_noise"].ran else 0.0)
    sigma_dn = math.sqrt(var_e) / conv
    bounds = {"quantization": float(_sensor.dither_defect(sigma_dn))}
    # per-exposure clipping the aggregate cannot reproduce
    full = sen.full_scale_dn
    lo_level = (S * dark_rel + dark_e) / conv + scene.sensor.black_level_dn
    hi_level = (S + dark_e) / conv + scene.sensor.black_level_dn
    sd = max(sigma_dn, 1e-9)
    p_lo = 0.5 * math.erfc(lo_level / sd / math.sqrt(2)) if n_reads == 1 else \
        0.5 * math.erfc((S * dark_rel + dark_e) / conv / (sd * math.sqrt(2)) / math.sqrt(2))
    p_hi = 0.5 * math.erfc((full - hi_level) / sd / math.sqrt(2))
    bounds["clipping"] = min(1.0, p_lo + p_hi)
    if rec["full_well"].ran:
        bounds["full_well"] = 1.0      # clipping of single exposures: cannot aggregate
    moving = m > 1 and (rec["smear"].ran or rec["rolling_skew"].ran)
    if moving and rec["prnu"].ran:
        # sum_s rel_s w_s taken as mean(rel) sum(w): error std prnu sqrt(m) std_s(rel) S,
        # std_s(rel) <= (1 - dark)/2, relative to the bright level m S
        bounds["prnu_smear"] = sen.prnu * (1.0 - dark_rel) / 2.0 / math.sqrt(m)
    return bounds


def _configure(scene, m, dv, fidelity, force, disable):
    rec, skew, dark_e = _decide(scene, m, dv, set(force), set(disable))
    notes = []
    tol = scene.run.tolerance
    bounds = _fast_bounds(scene, m, rec, dark_e, tol)
    per_exposure = [n for n in ("nuc", "hdr", "median3_pre") if rec[n].ran]
    if scene.tdi.domain == "charge":
        per_exposure = []        # charge sum happens before any block
    fast = fidelity == "fast"
    if fidelity == "auto":
        worst = max(bounds.values())
        fast = worst <= tol and not per_exposure
        notes.append(f"auto: {'fast' if fast else 'exact'} (largest fast-aggregate bound "
                     f"{worst:.3g} vs tolerance {tol:g}"
                     + (f"; per-exposure blocks {', '.join(per_exposure)}" if per_exposure
                        else "") + ")")
    if fast and per_exposure:
        notes.append(f"fast aggregate not applicable: {', '.join(per_exposure)} act on single "
                     f"exposures and are not linear; ran exact")
        fast = False
    mode = "fast" if fast else "exact"
    for name, r in rec.items():
        if r.ran and name in ("shot_noise", "read_noise", "quantization", "full_well",
                              "prnu", "dsnu", "dark_current", "smear", "rolling_skew", "tdi",
                              "cds"):
            r.fidelity = mode
    moments = fast and bounds["quantization"] > MOMENTS_BELOW_DITHER
    if moments:
        rec["quantization"].bound = bounds["quantization"]
        rec["quantization"].why += (f"; fast: the noise does not dither the ADC (Widrow "
                                    f"defect {bounds['quantization']:.2g}): the sum of the "
                                    f"roundings drawn as a Normal with the exact mean and "
                                    f"variance of each rounding (shape not reproduced), "
                                    f"clipping probability {bounds['clipping']:.2g}")
    elif fast:
        rec["quantization"].bound = bounds["quantization"]
        rec["quantization"].why += (f"; fast: m roundings -> 1 rounding + Normal((n-1)/12) "
                                    f"DN, Widrow bound {bounds['quantization']:.2g}, "
                                    f"clipping probability {bounds['clipping']:.2g}")
        if rec["full_well"].ran:
            rec["full_well"].bound = 1.0
            rec["full_well"].why += "; fast: clipped on the mean per exposure (approximate)"
        if "prnu_smear" in bounds:
            rec["prnu"].bound = bounds["prnu_smear"]
            rec["prnu"].why += (f"; fast: moving stages weighted by the mean row gain, "
                                f"error <= {bounds['prnu_smear']:.2g} of the bright level")
    sen = scene.sensor
    gains = sen.gains if rec["dual_gain"].ran else sen.gains[:1]
    n_reads = 2 if rec["reset_frames"].ran else 1
    offset = sen.black_level_dn + (scene.pipeline.cds.reset_level_dn if rec["reset_frames"].ran
                                   else 0.0)
    if len(sen.gains) == 2 and not rec["hdr"].ran:
        notes.append("two gains but no hdr merge: the HG channel feeds the chain")
    return _Cfg(scene, m, dv, fidelity, {n for n, r in rec.items() if r.ran}, set(force),
                fast, rec, skew, dark_e, gains, n_reads, offset, notes,
                fast_fpn_mean=fast and "prnu_smear" in bounds, quant_moments=moments)


# --------------------------------------------------------------------------------------
# the core: one pass over a crop of lines x columns with a given set of effects
# --------------------------------------------------------------------------------------


class _Timer:
    def __init__(self):
        self.t = {}

    def add(self, name, dt):
        self.t[name] = self.t.get(name, 0.0) + dt


def _geometry(cfg, on):
    sc = cfg.scene
    return _optics.Geometry(
        stages=cfg.m,
        dv_over_v=cfg.dv if "smear" in on else 0.0,
        drift_deg=sc.motion.drift_deg if "smear" in on else 0.0,
        skew=cfg.skew if "rolling_skew" in on else 0.0,
        q_over_p=sc.sensor.q_over_p,
        psf_sigma_px=sc.optics.psf_sigma_px if "optics" in on else 0.0)


def _stage_row(s, m, direction):
    """0-based window row that makes stage s (first exposure s = 0) of a ground line."""
    return m - 1 - s if direction == "forward" else s


def _core(cfg, on, lines, col0, ncols, timer, progress=None, keep_frames=None):
    """Simulate ``lines`` output lines of columns ``col0..col0+ncols-1`` with effects ``on``.

    Returns (target, raw, single, output, pedestal_single, pedestal_output, full_scale,
    exposure_pixels, crop_arrays).
    """
    sc, m = cfg.scene, cfg.m
    sen = sc.sensor
    seed = sc.run.seed
    t0 = time.perf_counter()
    geom = _geometry(cfg, on)
    tgt = _targets.make_target(sc.target, columns=sen.columns, lines=lines)
    rend = _optics.Renderer(tgt, geom, ncols, col0=col0, optics="optics" in on,
                            aperture="aperture" in on)
    timer.add("render", time.perf_counter() - t0)
    S = sc.target.signal_e
    # fixed pattern of the window rows (first m rows of the sensor), whole width then cropped
    t0 = time.perf_counter()
    rows_fp = max(sc.tdi.stages)
    gain_map = np.ones((rows_fp, sen.columns))
    dark_map = np.full((rows_fp, sen.columns), cfg.dark_e if "dark_current" in on else 0.0)
    if "prnu" in on:
        gain_map = np.maximum(1.0 + sen.prnu * _seq(seed, "fpn_prnu").standard_normal(
            (rows_fp, sen.columns)), 0.0)
    if "dsnu" in on:
        dark_map = np.maximum(dark_map + sen.dsnu_e * _seq(seed, "fpn_dsnu").standard_normal(
            (rows_fp, sen.columns)), 0.0)
    gain_map = gain_map[:m, col0:col0 + ncols]
    dark_map = dark_map[:m, col0:col0 + ncols]
    timer.add("prnu", time.perf_counter() - t0)

    def render_grid(lo, hi):
        t = time.perf_counter()
        grid = rend.grid(lo, hi)
        timer.add("render", time.perf_counter() - t)
        return rend, grid

    rng_shot = _seq(seed, "shot")
    rng_read = [_seq(seed, "read"), _seq(seed, "read_lg")]
    rng_reset = [_seq(seed, "read_reset"), _seq(seed, "read_reset_lg")]
    conv = sen.conversion_gain_e_per_dn
    fw = sen.full_well_e
    r_e = sen.read_noise_e if "read_noise" in on else 0.0
    bits = sen.bits
    gains = cfg.gains
    digital = sc.tdi.domain == "digital"
    t0 = time.perf_counter()
    target_img = rend.ideal(np.arange(lines))
    timer.add("render", time.perf_counter() - t0)

    def expose(lam, shape):
        """Charge of one exposure set: Poisson (or mean), full-well clip."""
        t = time.perf_counter()
        lam = np.broadcast_to(lam, shape)
        e = rng_shot.poisson(lam).astype(np.float64) if "shot_noise" in on else lam.copy()
        timer.add("shot_noise", time.perf_counter() - t)
        if "full_well" in on:
            t = time.perf_counter()
            np.minimum(e, fw, out=e)
            timer.add("full_well", time.perf_counter() - t)
        return e

    def convert(e, ch):
        """Read noise + ADC of charge ``e`` on channel ``ch``; with CDS also the reset."""
        t = time.perf_counter()
        v = e + r_e * rng_read[ch].standard_normal(e.shape) if r_e > 0 else e
        timer.add("read_noise", time.perf_counter() - t)
        t = time.perf_counter()
        dn = _sensor.adc(v, e_per_dn=conv, gain=gains[ch], bits=bits,
                         black_level_dn=cfg.offset_dn)
        timer.add("quantization", time.perf_counter() - t)
        rst = None
        if "reset_frames" in on:
            t = time.perf_counter()
            vr = r_e * rng_reset[ch].standard_normal(e.shape) if r_e > 0 else np.zeros(e.shape)
            rst = _sensor.adc(vr, e_per_dn=conv, gain=gains[ch], bits=bits,
                              black_level_dn=cfg.offset_dn)
            timer.add("reset_frames", time.perf_counter() - t)
        return dn, rst

    exposures = 0
    crop_arrays = {}
    if cfg.fast:
        out, raw, single, ped1, pedm, fs, exposures = _fast_path(
            cfg, on, lines, ncols, gain_map, dark_map, S, timer, rend, progress)
    elif digital:
        out, raw, single, ped1, pedm, fs, exposures, crop_arrays = _exact_digital(
            cfg, on, lines, ncols, gain_map, dark_map, S, timer, expose, convert, render_grid,
            progress, keep_frames)
    else:
        out, raw, single, ped1, pedm, fs, exposures, crop_arrays = _exact_charge(
            cfg, on, lines, ncols, gain_map, dark_map, S, timer, expose, convert, render_grid,
            progress, keep_frames)
    return target_img, raw, single, out, ped1, pedm, fs, exposures, crop_arrays


def _pre_tdi_blocks(cfg, on, frames_ch, resets_ch, timer, crop_arrays, keep):
    """cds -> nuc -> hdr -> median3 (before TDI) on frame stacks (one per channel)."""
    sc = cfg.scene
    bits = sc.sensor.bits
    pb = bits
    out = []
    for ch, fr in enumerate(frames_ch):
        x = fr
        if "cds" in on:
            from tdicam.model.cds import cds
            t = time.perf_counter()
            y = cds(x, resets_ch[ch], pixel_bits=bits)
            if keep is not None and ch == 0:
                crop_arrays["cds"] = {"signal": keep(x), "reset": keep(resets_ch[ch]),
                                      "out": keep(y), "params": {"pixel_bits": bits}}
            x = y
            timer.add("cds", time.perf_counter() - t)
        if "nuc" in on:
            t = time.perf_counter()
            x = _nuc_adapter(cfg, x, ch, crop_arrays if ch == 0 else None, keep)
            timer.add("nuc", time.perf_counter() - t)
        out.append(x)
    if "hdr" in on and len(out) == 2:
        from tdicam.model.hdr import hdr
        t = time.perf_counter()
        h = sc.pipeline.hdr
        g = sc.sensor.gains
        params = dict(pixel_bits=pb, threshold=h.threshold_dn, band=h.band_dn,
                      gain_pairs=f"{g[0]}:{g[1]}", slope_frac_bits=h.slope_frac_bits)
        merged = hdr(out[0], out[1], **params)
        if keep is not None:
            crop_arrays["hdr"] = {"hg": keep(out[0]), "lg": keep(out[1]), "out": keep(merged),
                                  "params": params}
        from tdicam.model.hdr import hdr_config
        pb = hdr_config(**params).out_bits
        out = [merged]
        timer.add("hdr", time.perf_counter() - t)
    x = out[0]
    if "median3_pre" in on:
        from tdicam.model.median3 import median3
        t = time.perf_counter()
        _check_bits("median3", pb, 8, 16, "[sensor].bits")
        y = median3(x, pixel_bits=pb, enhance=sc.pipeline.median3.edge_enhance)
        if keep is not None:
            crop_arrays["median3"] = {"frames": keep(x), "out": None, "params": {
                "pixel_bits": pb, "enhance": bool(sc.pipeline.median3.edge_enhance)}}
        x = y
        timer.add("median3_pre", time.perf_counter() - t)
    return x, pb


def _check_bits(block, bits, lo, hi, key):
    if not lo <= bits <= hi:
        raise TdicamError(f"{key}: the {block} golden model takes {lo}..{hi}-bit pixels, "
                          f"this chain gives it {bits}-bit pixels")


def _nuc_adapter(cfg, x, ch, crop_arrays, keep):
    """Ideal least-squares NUC coefficients from the known fixed pattern, then golden nuc."""
    from tdicam.model.nuc import NucFormat, nuc
    sc = cfg.scene
    opt = sc.pipeline.nuc
    fmt = NucFormat(gain_int_bits=2, gain_frac_bits=opt.gain_frac_bits, offset_bits=16,
                    offset_frac_bits=0)
    coeff = cfg._nuc_coeffs[ch]
    gain_c, off_c = coeff
    if opt.ecc:
        gain_c, off_c = _ecc_roundtrip(fmt, gain_c, off_c)
    shape = x.shape
    g = np.broadcast_to(gain_c, shape)
    o = np.broadcast_to(off_c, shape)
    y = nuc(x, g, o, pixel_bits=sc.sensor.bits, **fmt.params())
    if crop_arrays is not None and keep is not None:
        crop_arrays["nuc"] = {"x": keep(x), "gain": keep(np.ascontiguousarray(g)),
                              "offset": keep(np.ascontiguousarray(o)), "out": keep(y),
                              "params": dict(pixel_bits=sc.sensor.bits, **fmt.params())}
    return y


def _ecc_roundtrip(fmt, gain, offset):
    """Store the coefficients as 64/72 SECDED words and read them back (no flips injected)."""
    try:
        from tdicam.model import ecc
    except ImportError:
        return gain, offset
    data = np.asarray(fmt.pack_words(gain, offset), np.uint64)
    dec = ecc.decode(data, ecc.encode(data))
    if np.any(dec.uncorrectable):
        raise TdicamError("nuc coefficients: ECC round trip reported an uncorrectable word")
    g, o = fmt.unpack_words(np.asarray(dec.data, np.uint64))
    n = np.size(gain)
    return g[:n].reshape(np.shape(gain)), o[:n].reshape(np.shape(offset))


def _nuc_coeffs(cfg, on, gain_map, dark_map):
    """Per-pixel (gain, offset) codes that map each pixel onto the mean response.

    Pixel response (DN, before quantization): ``y = a/c (S (1+P) + d) + B``; the corrected
    target is ``a/c (S + mean d) + B``. Least squares over signal levels gives exactly
    ``gain = 1/(1+P)`` and ``offset = B + a/c mean(d) - gain (B + a/c d)``.
    """
    from tdicam.model.nuc import NucFormat
    sc = cfg.scene
    fmt = NucFormat(gain_int_bits=2, gain_frac_bits=sc.pipeline.nuc.gain_frac_bits,
                    offset_bits=16, offset_frac_bits=0)
    out = []
    cds = "cds" in on
    base = 0.0 if cds else cfg.offset_dn
    for ch in range(len(cfg.gains)):
        k = cfg.gains[ch] / sc.sensor.conversion_gain_e_per_dn
        gr = 1.0 / np.maximum(gain_map, 1e-6)
        off = base + k * dark_map.mean() - gr * (base + k * dark_map)
        out.append((fmt.gain_code(gr), fmt.offset_code(off)))
    return out


def threads():
    """Worker threads of the exact exposure loop: ``TDICAM_THREADS`` or the CPU count (<= 4).

    The result never depends on it: every block of rows draws from its own generator."""
    v = os.environ.get("TDICAM_THREADS")
    if v:
        try:
            return max(1, int(v))
        except ValueError:
            raise TdicamError(f"TDICAM_THREADS = {v!r}: must be an integer >= 1") from None
    return max(1, min(os.cpu_count() or 1, 4))


#: Rows per random-number block of the exact loop: ~64 k pixels, fixed by the width only.
_BLOCK_PIXELS = 1 << 16


def _block_rng(seed, name, stage, block):
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(
        [int(seed), _STREAM[name], int(stage), int(block)])))


def _expose_frames(cfg, on, frames, resets, rend_x, grid, gain_map, dark_map, S, moving,
                   timer, progress):
    """Every exposure of every frame row: Poisson charge, full-well clip, read noise, ADC.

    Rows are cut in blocks of ``_BLOCK_PIXELS``; block ``j`` of stage ``s`` draws its shot,
    read and reset noise from generators seeded ``(seed, stream, s, j)``, so the frames are
    the same whatever the thread count and timing. numpy's Generator releases the GIL while
    it fills an array, so the blocks run on :func:`threads` threads.
    """
    sc, m = cfg.scene, cfg.m
    sen = sc.sensor
    n_f, ncols = frames[0].shape[0], frames[0].shape[2]
    seed = sc.run.seed
    rows = max(1, _BLOCK_PIXELS // max(ncols, 1))
    blocks = [(j, a, min(n_f, a + rows)) for j, a in enumerate(range(0, n_f, rows))]
    shot = "shot_noise" in on
    fw = sen.full_well_e if "full_well" in on else None
    r_e = sen.read_noise_e if "read_noise" in on else 0.0
    top = float(sen.full_scale_dn)
    scale = [g / sen.conversion_gain_e_per_dn for g in cfg.gains]
    add = cfg.offset_dn + 0.5
    rst_read = ("read_reset", "read_reset_lg")
    sig_read = ("read", "read_lg")

    def task(s, j, a, b):
        dt = {}
        r = _stage_row(s, m, sc.tdi.direction)
        t = time.perf_counter()
        # frame tau, stage s sees ground line tau - s
        rel = rend_x.sample(grid, np.arange(a, b) - s, s if moving else None)
        lam = np.multiply(S * rel, gain_map[r])
        lam += dark_map[r]
        lam = np.broadcast_to(lam, (b - a, ncols))
        dt["render"] = time.perf_counter() - t
        t = time.perf_counter()
        e = _block_rng(seed, "shot", s, j).poisson(lam).astype(np.float64) if shot \
            else np.array(lam, np.float64)
        if fw is not None:
            np.minimum(e, fw, out=e)
        dt["shot_noise"] = time.perf_counter() - t
        for ch, k in enumerate(scale):
            times = _read_convert(e.copy() if ch + 1 < len(scale) else e, k, r_e, add, top,
                                  _block_rng(seed, sig_read[ch], s, j), frames[ch][a:b, r, :],
                                  _block_rng(seed, rst_read[ch], s, j),
                                  None if resets is None else resets[ch][a:b, r, :])
            for name, v in times.items():
                dt[name] = dt.get(name, 0.0) + v
        return dt

    _run_blocks(task, [(s, j, a, b) for s in range(m) for j, a, b in blocks], timer,
                progress, lambda s, j, a, b: (b - a) * ncols)


def _read_convert(x, k, r_e, add, top, rng_read, dst, rng_reset=None, dst_reset=None):
    """Read noise (float32 Normal, in place on the charge ``x``) and the ADC
    ``clamp(floor(v k + add), 0, top)`` into ``dst``; with ``dst_reset`` also the reset
    sample (read noise alone) into it. Returns ``{effect: seconds}``."""
    t0 = time.perf_counter()
    if r_e > 0:
        z = rng_read.standard_normal(x.shape, np.float32)
        z *= np.float32(r_e)
        x += z
    t1 = time.perf_counter()
    _adc_into(x, k, add, top, dst)
    t2 = time.perf_counter()
    dt = {"read_noise": t1 - t0, "quantization": t2 - t1}
    if dst_reset is not None:
        if r_e > 0:
            v = rng_reset.standard_normal(x.shape, np.float32).astype(np.float64)
            v *= r_e
        else:
            v = np.zeros(x.shape)
        _adc_into(v, k, add, top, dst_reset)
        dt["reset_frames"] = time.perf_counter() - t2
    return dt


def _adc_into(x, k, add, top, dst):
    x *= k
    x += add
    np.floor(x, out=x)
    np.clip(x, 0.0, top, out=x)
    dst[...] = x


def _run_blocks(fn, args, timer, progress, work_of):
    """``fn(*a)`` for every ``a`` in ``args`` on :func:`threads` threads; each returns
    ``{effect: seconds}``. Timings and progress are collected in order, here."""
    from concurrent.futures import ThreadPoolExecutor
    n_thr = min(threads(), len(args))
    pool = ThreadPoolExecutor(n_thr) if n_thr > 1 else None
    try:
        done = pool.map(lambda a: fn(*a), args) if pool is not None \
            else (fn(*a) for a in args)
        for a, dt in zip(args, done):
            for name, v in dt.items():
                timer.add(name, v)
            if progress is not None:
                progress(work_of(*a))
    finally:
        if pool is not None:
            pool.shutdown()


def _exact_digital(cfg, on, lines, ncols, gain_map, dark_map, S, timer, expose, convert,
                   render_grid, progress, keep_frames):
    sc, m = cfg.scene, cfg.m
    n_f = lines + m - 1
    geom_moving = _geometry(cfg, on).moving
    rend_x, grid = render_grid(-(m - 1), n_f - 1)
    n_ch = len(cfg.gains)
    bits = sc.sensor.bits
    dt = np.uint16 if bits <= 16 else np.uint32
    frames = [np.empty((n_f, m, ncols), dt) for _ in range(n_ch)]
    resets = [np.empty((n_f, m, ncols), dt) for _ in range(n_ch)] if "reset_frames" in on \
        else None
    _expose_frames(cfg, on, frames, resets, rend_x, grid, gain_map, dark_map, S, geom_moving,
                   timer, progress)
    r0 = _stage_row(0, m, sc.tdi.direction)
    raw = frames[0][:lines, r0, :].astype(np.int64)
    crop_arrays = {}
    keep = None
    if keep_frames is not None:
        y0, h, x0, w = keep_frames

        def keep(a):
            a = np.asarray(a)
            return a[y0:y0 + h + m - 1, :, x0:x0 + w].copy()
    cfg._nuc_coeffs = _nuc_coeffs(cfg, on, gain_map, dark_map) if "nuc" in on else None
    x, pb = _pre_tdi_blocks(cfg, on, frames, resets, timer, crop_arrays, keep)
    single = x[:lines, r0, :].astype(np.int64)
    # TDI through the golden model
    t = time.perf_counter()
    tdi_cfg = sc.tdi
    out_bits = tdi_cfg.output_bits if tdi_cfg.output == "saturate" else None
    from tdicam.model import tdi as tdi_model
    _check_bits("tdi", pb, *tdi_model.PIXEL_BITS,
                "[sensor].bits" if pb == bits else "[pipeline].blocks (hdr output)")
    if out_bits is not None and out_bits >= tdi_model.full_bits(pb, m):
        out_bits = None          # saturating at or above the full width never saturates
    if out_bits is not None and not pb <= out_bits <= tdi_model.full_bits(pb, m):
        raise TdicamError(f"[tdi].output_bits: must be in {pb}..{tdi_model.full_bits(pb, m)} "
                          f"for {pb}-bit pixels and {m} stages, got {out_bits}")
    out = tdi_model.tdi(x, stages=m, pixel_bits=pb, out_bits=out_bits,
                        direction=0 if tdi_cfg.direction == "forward" else 1).astype(np.int64)
    if keep is not None:
        crop_arrays["tdi"] = {"frames": keep(x), "params": dict(
            width=None, stages=m, pixel_bits=pb, out_bits=out_bits,
            direction=0 if tdi_cfg.direction == "forward" else 1),
            "out": out[keep_frames[0]:keep_frames[0] + keep_frames[1],
                       keep_frames[2]:keep_frames[2] + keep_frames[3]].copy()}
    timer.add("tdi", time.perf_counter() - t)
    fs = (1 << (out_bits if out_bits is not None else tdi_model.full_bits(pb, m))) - 1
    ped1 = 0.0 if "cds" in on else cfg.offset_dn
    out, fs = _post_tdi(cfg, on, out, fs, timer, crop_arrays, keep_frames)
    return out, raw, single, ped1, m * ped1, fs, n_f * m * ncols * n_ch, crop_arrays


def _post_tdi(cfg, on, out, fs, timer, crop_arrays, keep_frames):
    if "median3_post" in on:
        from tdicam.model.median3 import median3
        t = time.perf_counter()
        pb = _bits_of(fs)
        if pb > 16:
            raise TdicamError(f"[tdi].output: median3 after TDI takes at most 16-bit pixels; "
                              f"the TDI output is {pb} bits: set output = 'saturate' with "
                              f"output_bits <= 16")
        pb = max(pb, 8)
        y = median3(out, pixel_bits=pb,
                    enhance=cfg.scene.pipeline.median3.edge_enhance).astype(np.int64)
        if keep_frames is not None:
            y0, h, x0, w = keep_frames
            crop_arrays["median3"] = {"frames": out[y0:y0 + h, x0:x0 + w].copy(),
                                      "out": None, "params": {
                                          "pixel_bits": pb,
                                          "enhance": bool(cfg.scene.pipeline.median3
                                                          .edge_enhance)}}
        out = y
        timer.add("median3_post", time.perf_counter() - t)
    return out, fs


def _exact_charge(cfg, on, lines, ncols, gain_map, dark_map, S, timer, expose, convert,
                  render_grid, progress, keep_frames):
    """Charge-domain TDI: sum charge of m exposures, one readout, one conversion."""
    sc, m = cfg.scene, cfg.m
    moving = _geometry(cfg, on).moving
    rend_x, grid = render_grid(0, lines - 1)
    acc = np.zeros((lines, ncols))
    first = None
    g_lines = np.arange(lines)
    for s in range(m):
        r = _stage_row(s, m, sc.tdi.direction)
        t = time.perf_counter()
        rel = rend_x.sample(grid, g_lines, s if moving else None)
        lam = (S * rel) * gain_map[r] + dark_map[r]
        timer.add("render", time.perf_counter() - t)
        e = expose(lam, (lines, ncols))
        if s == 0:
            first = e.copy()
        t = time.perf_counter()
        acc += e
        timer.add("tdi", time.perf_counter() - t)
        if progress is not None:
            progress(lines * ncols)
    if "full_well" in on:
        np.minimum(acc, sc.sensor.full_well_e, out=acc)
    outs, singles = [], []
    crop_arrays = {}
    for ch in range(len(cfg.gains)):
        dn, rst = convert(acc, ch)
        d1, r1 = convert(first, ch)
        outs.append((dn, rst))
        singles.append((d1, r1))
    raw = singles[0][0].astype(np.int64)
    keep = None
    if keep_frames is not None:
        y0, h, x0, w = keep_frames

        def keep(a):
            a = np.asarray(a)
            return a[..., y0:y0 + h, x0:x0 + w].copy()
    cfg._nuc_coeffs = None
    if "nuc" in on:
        # charge TDI: each output pixel's response is the column mean of the window's gains
        gm = gain_map.mean(axis=0, keepdims=True)
        dm = dark_map.sum(axis=0, keepdims=True)
        cfg._nuc_coeffs = _nuc_coeffs(cfg, on, gm, dm)
    x, pb = _pre_tdi_blocks(cfg, on, [o[0][None] for o in outs],
                            [o[1][None] for o in outs] if "reset_frames" in on else None,
                            timer, crop_arrays, keep)
    if "nuc" in on:
        cfg._nuc_coeffs = _nuc_coeffs(cfg, on, gain_map[:1], dark_map[:1])
    crop_single = {}
    x1, _ = _pre_tdi_blocks(cfg, on, [o[0][None] for o in singles],
                            [o[1][None] for o in singles] if "reset_frames" in on else None,
                            timer, crop_single, None)
    out = x[0].astype(np.int64)
    single = x1[0].astype(np.int64)
    fs = (1 << pb) - 1
    ped = 0.0 if "cds" in on else cfg.offset_dn
    out, fs = _post_tdi(cfg, on, out, fs, timer, crop_arrays, keep_frames)
    return out, raw, single, ped, ped, fs, lines * m * ncols, crop_arrays


def _fast_path(cfg, on, lines, ncols, gain_map, dark_map, S, timer, rend, progress):
    """Aggregate the m exposures of each ground line (see the module docstring)."""
    sc, m = cfg.scene, cfg.m
    sen = sc.sensor
    moving = _geometry(cfg, on).moving
    digital = sc.tdi.domain == "digital"
    conv = sen.conversion_gain_e_per_dn
    k = cfg.gains[0] / conv
    r_e = sen.read_noise_e if "read_noise" in on else 0.0
    n_conv = cfg.n_reads * (m if digital else 1)        # conversions summed per output pixel
    var_read = (cfg.n_reads * (m if digital else 1)) * r_e * r_e
    gauss_min = 1.0 / (4.0 * sc.run.tolerance ** 2)
    r_rows = [_stage_row(s, m, sc.tdi.direction) for s in range(m)]
    gsum = gain_map[r_rows].sum(axis=0) if not moving else None
    dsum = dark_map.sum(axis=0)
    out = np.empty((lines, ncols), np.int64)
    n_raw = min(lines, RAW_LINES)
    raw = np.empty((n_raw, ncols), np.int64)
    single = np.empty((n_raw, ncols), np.int64)
    chunk = max(1, min(lines, _BLOCK_PIXELS // max(ncols, 1)))
    ped = cfg.offset_dn if "reset_frames" not in on else 0.0
    pedm = ped * (m if digital else 1)
    fw = sen.full_well_e
    r0 = r_rows[0]
    top = (1 << (_tdi_bits(cfg, sen.bits, m) if digital else sen.bits)) - 1
    var_dn = var_read * k * k + (n_conv - 1) / 12.0
    gmat = gain_map[r_rows] if moving else None        # (m, W): row weight of each stage
    gsum_all = gain_map[r_rows].sum(axis=0)
    seed = sc.run.seed
    add1 = cfg.offset_dn + 0.5
    top1 = float(sen.full_scale_dn)

    def work(ci, lo, hi):
        """Output lines lo..hi-1 (and their raw exposure) from the generators of chunk ci."""
        dt = {}
        rng_q = _block_rng(seed, "quant", 0, ci)
        rng_shot = _block_rng(seed, "shot", 0, ci)
        g_lines = np.arange(lo, hi)
        t = time.perf_counter()
        rend_x, grid = rend, rend.grid(lo, hi - 1)
        if moving and cfg.fast_fpn_mean and "full_well" not in on:
            # sum_s rel_s w_s ~ mean_s(rel_s) sum_s w_s: error prnu std_s(rel)/sqrt(m)
            first = rend_x.sample(grid, g_lines, 0)
            mu = (S * rend_x.stage_mean(grid, g_lines)) * gsum_all
        elif moving:
            rels = [rend_x.sample(grid, g_lines, s) for s in range(m)]
            first = rels[0]
            if "full_well" in on:
                mu = sum(np.minimum((S * rels[s]) * gmat[s] + dark_map[r_rows[s]], fw)
                         - dark_map[r_rows[s]] for s in range(m))
            elif rels[0].shape[1] == 1:
                # target constant across track: sum_s rel_s(g) w_s(x) is a matrix product
                mu = S * (np.concatenate(rels, axis=1) @ gmat)
            else:
                mu = np.zeros((hi - lo, ncols))
                for s in range(m):
                    mu += (S * rels[s]) * gmat[s]
        else:
            rel = rend_x.sample(grid, g_lines, None)
            first = rel
            if "full_well" in on:
                mu = sum(np.minimum((S * rel) * gain_map[rr] + dark_map[rr], fw)
                         - dark_map[rr] for rr in r_rows)
            else:
                mu = (S * rel) * gsum
        lam = mu + dsum
        if lam.shape != (hi - lo, ncols):
            lam = np.broadcast_to(lam, (hi - lo, ncols)).copy()
        dt["render"] = time.perf_counter() - t
        t = time.perf_counter()
        if cfg.quant_moments and n_conv > 1:
            # noise too small to dither the ADC: sum the exact mean and variance of every
            # rounding (model.sensor.quantized_moments) instead of m roundings -> 1 + (n-1)/12
            # (one conversion is drawn exactly below: Poisson, Normal read noise, 1 rounding)
            if moving:
                rel_s = [rend_x.sample(grid, g_lines, s) for s in range(m)]
            else:
                rel_s = [rel] * m
            x = _moment_sum(cfg, on, S, rel_s, gain_map, dark_map, r_rows, k, r_e,
                            (hi - lo, ncols), rng_q)
            np.clip(x, 0.0, top + 0.5, out=x)
            out[lo:hi] = x
            dt["quantization"] = time.perf_counter() - t
        else:
            _fast_draw(cfg, on, lam, k, var_dn, gauss_min, pedm, top, fw, digital, rng_q,
                       rng_shot, out[lo:hi])
            dt["shot_noise"] = time.perf_counter() - t
        # the raw exposure of the first RAW_LINES ground lines: stage 0 alone, exact
        if lo >= n_raw:
            return dt
        t = time.perf_counter()
        hi = min(hi, n_raw)
        first = first[:hi - lo]
        lam1 = np.broadcast_to((S * first) * gain_map[r0] + dark_map[r0], (hi - lo, ncols))
        e1 = rng_shot.poisson(lam1).astype(np.float64) if "shot_noise" in on \
            else np.array(lam1, np.float64)
        if "full_well" in on:
            np.minimum(e1, fw, out=e1)
        rst1 = np.empty((hi - lo, ncols), np.int64) if "reset_frames" in on else None
        _read_convert(e1, k, r_e, add1, top1, _block_rng(seed, "read", 0, ci), raw[lo:hi],
                      _block_rng(seed, "read_reset", 0, ci), rst1)
        if rst1 is not None:
            from tdicam.model.cds import cds
            single[lo:hi] = cds(raw[lo:hi], rst1, pixel_bits=sen.bits)
        else:
            single[lo:hi] = raw[lo:hi]
        dt["raw_exposure"] = time.perf_counter() - t
        return dt

    _run_blocks(work, [(ci, lo, min(lines, lo + chunk))
                       for ci, lo in enumerate(range(0, lines, chunk))],
                timer, progress, lambda ci, lo, hi: (hi - lo) * ncols * m)
    fs = top
    if digital and sc.tdi.output == "saturate":
        np.minimum(out, (1 << sc.tdi.output_bits) - 1, out=out)
        fs = (1 << sc.tdi.output_bits) - 1
    crop = {}
    out, fs = _post_tdi(cfg, on, out, fs, timer, crop, None)
    return out, raw, single, ped, pedm, fs, lines * m * ncols


def _fast_draw(cfg, on, lam, k, var_dn, gauss_min, pedm, top, fw, digital, rng_q, rng_shot,
               out):
    """Shot noise (Normal where the summed mean is large, Poisson elsewhere), read noise and
    the n roundings, drawn as one Normal of the summed variance in DN, rounded into ``out``."""
    z = rng_q.standard_normal(lam.shape, dtype=np.float32)
    small = None
    if "shot_noise" in on:
        small = np.flatnonzero(lam < gauss_min)
        sd = lam * (k * k)
        if small.size:
            sd.flat[small] = 0.0
    else:
        sd = np.zeros(lam.shape)
    sd += var_dn
    np.sqrt(sd, out=sd)
    sd *= z
    x = lam * k
    if small is not None and small.size:
        x.flat[small] = rng_shot.poisson(lam.flat[small]) * k
    if "full_well" in on and not digital and small is not None:
        np.minimum(x, fw * k, out=x)
    x += sd
    x += pedm + 0.5
    np.clip(x, 0.0, top + 0.5, out=x)
    out[...] = x                        # truncation of x >= 0: round half up


def _moment_sum(cfg, on, S, rel_s, gain_map, dark_map, r_rows, k, r_e, shape, rng_q):
    """Sum of the m (digital) or 1 (charge) conversions of each output pixel, drawn as a
    Normal with the exact mean and variance of every rounding, plus 1/2 (for truncation)."""
    sc = cfg.scene
    fw = sc.sensor.full_well_e
    digital = sc.tdi.domain == "digital"
    shot = "shot_noise" in on
    mean = np.zeros((1, 1))
    var = np.zeros((1, 1))
    lam_all = 0.0

    def flat(rel):
        # a target constant along the lines: one row of moments serves every line
        return rel[:1] if rel.shape[0] > 1 and np.all(rel == rel[:1]) else rel
    for s, rr in enumerate(r_rows):
        lam = (S * flat(rel_s[s])) * gain_map[rr] + dark_map[rr]
        if "full_well" in on:
            lam = np.minimum(lam, fw)
        if not digital:
            lam_all = lam_all + lam
            continue
        mu_s, v_s = _sensor.quantized_moments(
            lam * k + cfg.offset_dn, k * np.sqrt((lam if shot else 0.0) + r_e * r_e))
        mean = mean + mu_s
        var = var + v_s
    if not digital:
        if "full_well" in on:
            lam_all = np.minimum(lam_all, fw)
        mean, var = _sensor.quantized_moments(lam_all * k + cfg.offset_dn,
                                              k * np.sqrt((lam_all if shot else 0.0)
                                                          + r_e * r_e))
    n_sig = len(r_rows) if digital else 1
    if "reset_frames" in on:
        mu_r, v_r = _sensor.quantized_moments(cfg.offset_dn, k * r_e)
        mean = mean - n_sig * mu_r
        var = var + n_sig * v_r
    return _integer_draw(np.broadcast_to(mean, shape), np.broadcast_to(var, shape), rng_q)


def _integer_draw(mean, var, rng):
    """Integers with exactly the given mean and variance (plus 1/2, for truncation).

    Variance <= 3/4: ``F + Y``, ``F = round(mean)``, ``Y`` in {-1, 0, 1} with
    ``P(+-1) = (var + d^2 +- d) / 2``, ``d = mean - F`` (valid for every integer variable's
    moments). Above: ``round(Normal(mean, var - 1/12))``, whose rounding the Normal dithers
    (Widrow defect < 2e-6).
    """
    f = np.floor(mean + 0.5)
    d = mean - f
    u = rng.random(mean.shape)
    p_dn = np.clip((var + d * d - d) * 0.5, 0.0, 1.0)
    p_up = np.clip((var + d * d + d) * 0.5, 0.0, 1.0)
    small = f + (u < p_up) - ((u >= p_up) & (u < p_up + p_dn))
    z = rng.standard_normal(mean.shape)
    big = mean + np.sqrt(np.maximum(var - 1.0 / 12.0, 0.0)) * z
    return np.where(var <= 0.75, small, big) + 0.5


def _tdi_bits(cfg, bits, m):
    return bits + (int(m) - 1).bit_length()


# --------------------------------------------------------------------------------------
# public entry point
# --------------------------------------------------------------------------------------


def simulate(scene, *, stages=None, dv_over_v=None, fidelity=None, force=(), disable=(),
             lines=None, impact=True, progress=None, keep_crop=None):
    """Simulate one configuration of ``scene``.

    Parameters
    ----------
    scene : tdicam.scene.Scene
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
        Effects to leave out (for impact studies).
    lines : int, optional
        Output lines (default ``[run].lines``).
    impact : bool
        Measure each effect's impact on a crop (one extra crop simulation per effect).
    progress : callable(n) or None
        Called with the number of exposure-pixels done, as the work advances.
    keep_crop : (y0, h, x0, w) or None
        Keep the golden blocks' inputs/outputs on this output crop (for RTL co-simulation).

    Returns
    -------
    SimResult
    """
    m = int(scene.tdi.stages[0] if stages is None else stages)
    dv = float(scene.motion.dv_over_v[0] if dv_over_v is None else dv_over_v)
    fid = scene.run.fidelity if fidelity is None else fidelity
    if fid not in ("exact", "fast", "auto"):
        raise TdicamError(f"fidelity = {fid!r} is not valid; valid: exact, fast, auto")
    for name in list(force) + list(disable):
        if name not in EFFECTS:
            raise TdicamError(f"unknown effect {name!r}; valid: {', '.join(EFFECTS)}")
    if m > scene.sensor.rows:
        raise TdicamError(f"[tdi].stages: must be <= {scene.sensor.rows} (the sensor rows), "
                          f"got {m}")
    n_lines = int(scene.run.lines if lines is None else lines)
    cfg = _configure(scene, m, dv, fid, force, disable)
    timer = _Timer()
    t0, c0 = time.perf_counter(), time.process_time()
    target, raw, single, out, ped1, pedm, fs, expo, crop_arrays = _core(
        cfg, cfg.on, n_lines, 0, scene.sensor.columns, timer, progress, keep_crop)
    seconds = time.perf_counter() - t0
    cpu_seconds = time.process_time() - c0
    records = [cfg.records[n] for n in EFFECTS]
    for r in records:
        if r.ran:
            r.seconds = timer.t.get(r.name, 0.0)
    render = timer.t.get("render", 0.0)
    for r in records:
        if r.name == "aperture":
            r.seconds = render
    notes = list(cfg.notes)
    notes.append(f"rendering (target through aperture, optics and smear) took {render:.3g} s; "
                 f"its time is listed on the aperture row")
    if "raw_exposure" in timer.t:
        notes.append(f"the raw single exposure (exact, stage 0 of every line) took "
                     f"{timer.t['raw_exposure']:.3g} s of the fast run")
    res = SimResult(m, dv, "fast" if cfg.fast else "exact", target, raw, single, out, records,
                    ped1, pedm, fs, seconds, expo, _geometry(cfg, cfg.on), notes, crop_arrays,
                    cpu_seconds)
    if impact:
        _impacts(cfg, res)
    return res


def _impacts(cfg, res):
    """PSNR of the output with vs without each effect that ran, on a crop, same RNG."""
    sc = cfg.scene
    lines = min(res.output.shape[0], _IMPACT_LINES)
    ncols = min(sc.sensor.columns, _IMPACT_COLS)
    col0 = (sc.sensor.columns - ncols) // 2
    base = _core(cfg, cfg.on, lines, col0, ncols, _Timer())[3].astype(np.float64)
    peak = float(res.output_full_scale)
    skip = {"tdi"}
    for r in res.effects:
        if not r.ran or r.name in skip:
            continue
        if r.name in cfg.forced and r.name in FORCIBLE and "forced" in r.why:
            pass
        on = set(cfg.on) - {r.name}
        if r.name == "dual_gain":
            on -= {"hdr"}
        if r.name == "reset_frames":
            on -= {"cds"}          # no reset frame: no CDS
        if r.name == "cds":
            on -= {"reset_frames"}
        if r.name == "quantization":
            r.impact = {"note": "the ADC cannot be removed; see the fast-vs-exact error"}
            continue
        try:
            c2 = dataclasses.replace(cfg, gains=cfg.gains[:1]) if r.name == "dual_gain" \
                else cfg
            other = _core(c2, on, lines, col0, ncols, _Timer())[3].astype(np.float64)
        except TdicamError as exc:
            r.impact = {"note": f"not measurable: {exc}"}
            continue
        if other.shape != base.shape:
            r.impact = {"note": "output shape changes"}
            continue
        diff = base - other
        mse = float(np.mean(diff * diff))
        r.impact = {
            "psnr_db": (float("inf") if mse == 0 else 10 * math.log10(peak * peak / mse)),
            "rms_dn": math.sqrt(mse),
            "mean_dn": float(diff.mean()),
            "crop": [0, col0, lines, ncols],
        }
