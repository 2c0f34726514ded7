"""Image-quality measurements of a simulated run next to the planning model's predictions.

``measure(scene, result)`` returns a dict for the report (with, for every target, the
clipping, region SNR and PSNR / SSIM entries of :func:`tdicam.run.quality.quality`):

* flat targets — SNR of the TDI output and of a single exposure, one definition for the
  measurement and the prediction: signal = the mean photo-electron charge (the light only,
  dark charge excluded), noise = the standard deviation of everything (shot noise of light
  and dark, read noise, quantization, fixed pattern). Measured: the mean above the known
  zero-light pedestal times ``S / (S + D)`` — the light's share of it, ``S`` the signal and
  ``D`` the mean dark charge per exposure (:func:`mean_dark_e`) — over the standard
  deviation (Ning et al. 2019 eq 1 with the dark level removed); their difference (the measured
  TDI gain in dB), and the predictions (:func:`tdicam.planning.predict.snr_prediction`): the planning model's
  ``G(m)`` (:func:`tdicam.model.physics.plan.snr_gain_digital_predicted`, quantization split into
  its independent and shared parts) and, next to it, Tao et al. 2012 eq 28
  (:func:`tdicam.model.physics.plan.snr_gain_digital`, the paper's worst case) or their
  charge-domain forms;
* bar targets — the MTF at the bar frequency from a least-squares sinusoid fit to the
  profile across the bars (amplitude over the pedestal-free mean, divided by the input
  modulation of the fundamental: ``c`` for a sine grating, ``4c/pi`` for square bars), the
  Ning et al. 2019 estimate ``(pi/4) CTF`` for square bars, and the predictions, all moduli (an MTF
  is never negative; ``planned_reversed`` flags contrast reversal): ``planned`` — the planning
  model :func:`tdicam.planning.predict.mtf_prediction` (full-line-period exposure, smear at the image
  speed ``1 - dV/V``, rolling-shutter skew, the M-stage term, optics; along track), the
  exact footprint model of :class:`tdicam.model.physics.optics.Geometry` the simulator renders
  (``footprint_model``, either axis), and ``yuan2013_model`` — the paper's model, Yuan et al.,
  "MTF velocity-mismatch model of TDI area-array CMOS image sensors" (2013):
  ``aperture x temporal x mismatch`` with the plain velocity mismatch dV/V (no skew, no
  image speed; ``mtf_prediction(...)["paper"]["system"]``).
  Where the fitted amplitude is below :data:`MIN_MODULATION_SNR` standard deviations of its
  estimate, the mean is not above the pedestal, or the bright bars saturate (``saturated``:
  ``signal_e`` plus dark charge per exposure reaches :func:`saturation_e`, so the clipped
  output has less modulation than the camera's MTF) both measured values are None and
  ``note`` says why.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from tdicam import blocks
from tdicam.planning.predict import mtf_left_out, mtf_prediction, snr_prediction
from tdicam.run.quality import quality

__all__ = ["measure", "saturation_e", "fit_modulation", "mean_dark_e",
           "MIN_MODULATION_SNR", "SNR_DEFINITION"]


def mean_dark_e(scene):
    """Mean dark charge of one exposure, electrons: the dark current over a line period,
    with the DSNU (Normal, clipped at 0 charge) adding ``E[max(D + s Z, 0)] - D``."""
    d = scene.sensor.dark_current_e_per_s * scene.line_period_s
    s = scene.sensor.dsnu_e
    if s <= 0:
        return d
    u = d / s
    return d * 0.5 * math.erfc(-u / math.sqrt(2)) + s * math.exp(-u * u / 2) \
        / math.sqrt(2 * math.pi)


def saturation_e(scene, stages):
    """Charge per exposure (electrons, dark included) at which a flat output saturates:
    the full well or the ADC full scale (``2**bits - 1`` DN less the black level, at the
    lowest gain: the channel that holds the most), whichever is lower; in the charge domain
    the well and the one conversion hold the sum of ``stages`` exposures, so the
    per-exposure level is 1/stages of it."""
    sen = scene.sensor
    adc_e = ((2 ** sen.bits - 1) - sen.black_level_dn) * sen.conversion_gain_e_per_dn \
        / min(sen.gains)
    share = stages if scene.tdi.domain == "charge" else 1
    return min(sen.full_well_e, adc_e) / share


def _snr_db(img, pedestal, trim, light=1.0):
    """SNR (dB) of a flat image: ``light * (mean - pedestal) / std`` (``light``: the share
    of the mean that is signal), None when there is no signal or no noise."""
    a = np.asarray(img, np.float64)
    if trim and min(a.shape) > 2 * trim + 2:
        a = a[trim:-trim, trim:-trim]
    mean = (a.mean() - pedestal) * light
    std = a.std()
    if std == 0 or mean <= 0:
        return None
    return 20.0 * math.log10(mean / std)


#: What report.json's SNR values mean (measured and predicted alike).
SNR_DEFINITION = ("signal = mean photo-electrons (dark charge excluded: measured as the mean "
                  "above the zero-light pedestal times S / (S + dark)); noise = the standard "
                  "deviation of everything, dark shot noise and fixed pattern included")

#: A modulation is measurable when its fitted amplitude is at least this many standard
#: deviations of the amplitude estimate (from the fit residual) above zero.
MIN_MODULATION_SNR = 5.0


def _fit(profile, freq):
    """Least-squares ``(amplitude, mean, amplitude standard deviation)`` of a sinusoid at
    ``freq`` cycles/sample; the deviation is ``rms residual * sqrt(2 / n)``."""
    p = np.asarray(profile, np.float64)
    u = np.arange(len(p), dtype=np.float64)
    ph = 2 * np.pi * freq * u
    a = np.stack([np.cos(ph), np.sin(ph), np.ones_like(u)], axis=1)
    coef, *_ = np.linalg.lstsq(a, p, rcond=1e-9)
    resid = p - a @ coef
    dof = max(len(p) - 3, 1)
    sd = math.sqrt(float(resid @ resid) / dof) * math.sqrt(2.0 / max(len(p), 1))
    return float(math.hypot(coef[0], coef[1])), float(coef[2]), sd


def fit_modulation(profile, freq, pedestal=0.0):
    """Amplitude / (mean - pedestal) of ``profile`` at ``freq`` cycles/sample (least squares).

    Returns None when the mean is not above the pedestal.
    """
    amp, mean, _ = _fit(profile, freq)
    mean -= pedestal
    if mean <= 0:
        return None
    return float(amp / mean)


def measure(scene, res):
    """Measured image quality of a :class:`~tdicam.engine.SceneResult` and its predictions."""
    out = {"stages": res.stages, "dv_over_v": res.dv_over_v}
    tgt = scene.target
    m = res.stages
    trim = max((blocks.get(b).pipeline.sim.trim for b in scene.pipeline.blocks), default=0)
    cds = any(e.name == "reset_frames" and e.ran for e in res.effects)
    if tgt.kind == "flat":
        S, dark = tgt.signal_e, mean_dark_e(scene)
        light = S / (S + dark) if S + dark > 0 else 0.0
        s_out = _snr_db(res.output, res.pedestal_output, trim, light)
        s_one = _snr_db(res.single, res.pedestal_single, trim, light)
        cap = saturation_e(scene, m)
        saturated = S + dark >= cap
        if saturated:       # a flat output at full scale: its "SNR" measures nothing
            s_out = s_one = None
            scene = dataclasses.replace(scene, target=dataclasses.replace(
                tgt, signal_e=max(cap - dark, 0.0)))
        pred = snr_prediction(scene, m, cds=cds)
        out["snr"] = {
            "output_db": s_out, "single_db": s_one,
            "gain_db": None if s_out is None or s_one is None else s_out - s_one,
            "signal_definition": SNR_DEFINITION, "dark_e": dark,
            "saturated": saturated, "saturation_e": cap,
            **pred,
        }
        if saturated:
            out["snr"]["note"] = (
                f"saturated: signal {S:g} e- + dark {dark:.3g} e- per exposure reaches "
                f"{cap:.6g} e- (full well or ADC full scale), so the output is clipped flat "
                f"and has no SNR to measure; the predictions are for a signal at that level")
    if tgt.kind == "bars":
        g = res.geometry
        period = tgt.period_px
        f = 1.0 / period                                  # cycles per pitch
        c = tgt.contrast
        along = tgt.direction == "along_track"
        img = np.asarray(res.output, np.float64)
        if along:
            prof = img.mean(axis=1)
            f_out = f * g.speed                               # cycles per output line
        else:
            prof = img.mean(axis=0)
            f_out = f
        if trim:
            prof = prof[trim:-trim]
        mod_in = c * (4 / math.pi if tgt.profile != "sine" else 1.0)
        amp, mean, amp_sd = _fit(prof, f_out)
        mean -= res.pedestal_output
        mtf_fit = ctf_mtf = note = None
        dark, cap = mean_dark_e(scene), saturation_e(scene, m)
        saturated = tgt.signal_e + dark >= cap
        if saturated:       # clipped bars: less modulation than optics and motion give
            note = (f"not measurable: saturated: the bright bars' signal {tgt.signal_e:g} e- + "
                    f"dark {dark:.3g} e- per exposure reaches {cap:.6g} e- (full well or ADC "
                    f"full scale), so the output is clipped and its modulation is not the "
                    f"MTF's")
        elif mean <= 0:
            note = "not measurable: the mean output is not above the zero-light pedestal"
        elif amp < MIN_MODULATION_SNR * amp_sd:
            note = (f"not measurable: the modulation at the bar frequency ({amp:.3g} DN) is "
                    f"below {MIN_MODULATION_SNR:g}x its noise ({amp_sd:.3g} DN RMS)")
        else:
            mtf_fit = amp / mean / mod_in
        ctf_note = None
        if note is None and tgt.profile != "sine":
            # min and max of n single samples: their noise is the per-sample noise times
            # ~sqrt(2 ln n) (the extreme of n Normal draws), not the fitted amplitude's
            n_prof = max(len(prof), 2)
            sd_sample = amp_sd * math.sqrt(n_prof / 2.0) * math.sqrt(2.0 * math.log(n_prof))
            lo, hi = float(prof.min()) - res.pedestal_output, float(prof.max()) \
                - res.pedestal_output
            if amp < MIN_MODULATION_SNR * sd_sample:
                ctf_note = (f"(pi/4) CTF not measurable: the modulation at the bar frequency "
                            f"({amp:.3g} DN) is below {MIN_MODULATION_SNR:g}x the noise of "
                            f"the minimum and maximum of the {n_prof} profile samples it "
                            f"takes ({sd_sample:.3g} DN)")
            elif hi + lo > 0 and lo >= 0:
                ctf_mtf = (math.pi / 4) * ((hi - lo) / (hi + lo)) / c
        above = _above_one(scene, mtf_fit, amp_sd / mean / mod_in if mean > 0 else 0.0,
                           ctf_mtf)
        plan = mtf_prediction(scene, m, res.dv_over_v, f) if along else None
        exact = float(abs(g.mtf_along(f) if along else g.mtf_cross(f)))
        out["mtf"] = {
            "frequency_cyc_per_px": f, "axis": "along" if along else "cross",
            "measured": mtf_fit, "measured_ctf": ctf_mtf,
            "planned": plan["system"] if along else None,
            "planned_reversed": plan["reversed"] if along else None,
            "yuan2013_model": plan["paper"]["system"] if along else None,
            "footprint_model": exact,
            "m_dv_over_v": m * res.dv_over_v, "m_delta_effective": m * g.stage_lag,
            "saturated": saturated, "saturation_e": cap,
        }
        left = mtf_left_out(scene)
        out["mtf"]["planned_before"] = left[0] if left else None
        left_note = None if not left else (
            f"planned is the camera before {left[0]} (the planning model leaves it out: a "
            f"median is not linear); measured is after it: the two do not compare")
        notes = [n for n in (note, ctf_note, above, left_note) if n is not None]
        if notes:
            out["mtf"]["note"] = "; ".join(notes)
    out.update(quality(scene, res, trim, mean_dark_e(scene)))
    return out


def _above_one(scene, mtf_fit, mtf_sd, ctf):
    """Why a measured MTF or (pi/4) CTF above 1 is one, or None when neither is: within
    the noise of the measurement, or the median3 block's edge enhancement (a sharpening
    filter); the (pi/4) CTF equals the MTF only for a square-wave response whose harmonics
    the system passes in the ratio of the fundamental."""
    why = []
    sharp = [b for b in scene.pipeline.blocks if blocks.get(b).pipeline.sim.sharpens
             and blocks.get(b).pipeline.sim.sharpens(getattr(scene.pipeline, b))]
    if mtf_fit is not None and mtf_fit > 1.0:
        if mtf_fit - 1.0 <= MIN_MODULATION_SNR * mtf_sd:
            why.append(f"measured MTF {mtf_fit:.3f} > 1 is within the noise of the fit "
                       f"({MIN_MODULATION_SNR:g} x {mtf_sd:.3g})")
        elif sharp:
            why.append(f"measured MTF {mtf_fit:.3f} > 1: the {sharp[0]} block's edge "
                       f"enhancement sharpens the bars")
        else:
            why.append(f"measured MTF {mtf_fit:.3f} > 1 by more than the noise of the fit "
                       f"({mtf_sd:.3g}): a pipeline block amplifies the bar frequency")
    if ctf is not None and ctf > 1.0:
        why.append(f"(pi/4) CTF {ctf:.3f} > 1: the min/max estimate assumes the square "
                   f"wave's harmonics pass like its fundamental; the fitted MTF is the "
                   f"measurement")
    return "; ".join(why) or None
