"""What the planning model predicts a run of a scene measures: the along-track MTF
(:func:`mtf_prediction`) and the SNR gain of TDI (:func:`snr_prediction`).

``tdicam plan`` prints them for a design; ``tdicam run`` prints them beside what it
measured on the simulated images (:mod:`tdicam.run.measure`).
"""

from __future__ import annotations

import math

from tdicam.model.physics import mtf as _mtf, plan as _plan, sensor as _sensor

__all__ = ["mtf_prediction", "snr_prediction", "MTF_LEAVES_OUT", "mtf_left_out"]


#: Pipeline blocks the MTF model leaves out: a 3x3 median is not linear (it has no MTF; on
#: a bar target near Nyquist it cancels the bars at some phases).
MTF_LEAVES_OUT = ("median3",)


def mtf_left_out(scene) -> tuple[str, ...]:
    """The blocks of ``scene``'s pipeline the planned MTF leaves out
    (:data:`MTF_LEAVES_OUT`): a planned MTF of such a scene is the camera's before them,
    and does not compare with a measurement after them."""
    return tuple(b for b in scene.pipeline.blocks if b in MTF_LEAVES_OUT)


def mtf_prediction(scene, stages, dv_over_v, f=_mtf.NYQUIST) -> dict:
    """Planned along-track MTF of ``scene`` at ``f`` cycles/pitch, with the paper's model.

    The camera model (:func:`tdicam.model.physics.mtf.camera_mtf_terms`): full-line-period exposure,
    smear at the image speed ``1 - dV/V``, rolling-shutter skew from the sensor's row time
    (forward/reverse scan; none for a global shutter, one stage or an unknown row time), the
    M-stage term and the optics PSF — the footprint the scene simulator renders. Beside it,
    ``paper``: Yuan et al. 2013's ``aperture x temporal x mismatch`` (moduli). All values are moduli;
    ``reversed`` says when the camera's contrast is reversed. This is what a report prints.
    """
    s = scene.sensor
    dv = float(_mtf.check_dv_over_v(dv_over_v, "dv_over_v"))
    skew = 0.0
    skew_note = ("global shutter" if s.shutter == "global" else "one stage" if stages == 1
                 else "row time unknown" if s.row_time_s is None
                 else "a row takes longer than the line period (M0 = 0)"
                 if s.row_time_s >= scene.line_period_s else None)
    if skew_note is None:
        skew = _mtf.rolling_skew(s.row_time_s, scene.line_period_s, shutter=s.shutter,
                                 direction=scene.tdi.direction)
    cam = _mtf.camera_mtf_terms(f, stages, dv, skew, s.q_over_p, 1.0,
                                scene.optics.psf_sigma_px)
    paper = {"aperture": float(_mtf.mtf_aperture(f, s.q_over_p)),
             "temporal": float(_mtf.mtf_temporal(f, stages)),
             "mismatch": float(_mtf.mtf_velocity_mismatch(f, stages, dv)),
             "system": float(_mtf.mtf_system(f, stages, dv, s.q_over_p))}
    return {"f_cyc_per_px": float(f), "dv_over_v": dv, "m_dv_over_v": stages * dv,
            "skew_px": cam.skew_px, "no_skew_because": skew_note, "m_delta": cam.m_delta, "exposure": cam.exposure,
            "aperture": cam.aperture, "smear": cam.smear, "optics": cam.optics,
            "stages": cam.stages, "system": cam.system, "reversed": bool(cam.reversed),
            "paper": paper}


def snr_prediction(scene, stages, *, cds=False):
    """Predicted flat-field SNR gain (dB) of ``stages`` over one exposure.

    Returns a dict:

    * ``predicted_db`` — the planning model: digital TDI
      :func:`tdicam.model.physics.plan.snr_gain_digital_predicted` (temporal noise, the row-to-row
      fixed pattern and the independent part of the quantization noise grow as ``sqrt(m)``,
      only the shared part ``rho`` as m), charge domain
      :func:`tdicam.model.physics.sensor.snr_gain_charge_quadrature`;
    * ``eq28_db`` — Tao et al. 2012 eq 28 (:func:`tdicam.model.physics.plan.snr_gain_digital`) or its
      charge-domain form, the paper's worst case (all quantization noise growing as m);
    * ``rho`` — the shared fraction of the quantization variance used (0 on a flat field:
      one level, so the signal-dependent rounding error is a bias of the mean, not noise) and
      ``rho_detail`` — what a scene with detail at this light level would have;
    * ``sigma_ad_e``, ``sigma_cmos_e`` (temporal), ``sigma_fpn_e`` (electrons) and
      ``snr1_db`` (single-exposure SNR: signal the photo-electrons ``S`` only, dark charge
      excluded, over the noise in quadrature — shot noise of light and dark, read,
      quantization, fixed pattern; the definition the measured SNR follows; None, with a
      ``note``, when ``signal_e = 0``).
    """
    sen = scene.sensor
    S = scene.target.signal_e
    n = 2 if cds else 1
    dark = sen.dark_current_e_per_s * scene.line_period_s
    step_e = sen.conversion_gain_e_per_dn / sen.gains[0]
    s_ad = _sensor.quantization_sigma_e(sen.conversion_gain_e_per_dn, sen.gains[0]) \
        * math.sqrt(n)
    read_var = n * sen.read_noise_e ** 2
    s_cmos = math.sqrt(S + dark + read_var)
    fpn_var = (S * sen.prnu) ** 2 + sen.dsnu_e ** 2
    s_ind = math.sqrt(S + dark + read_var + fpn_var)
    snr1 = S / math.sqrt(S + dark + read_var + s_ad ** 2 + fpn_var)
    # only the signal conversion sees the scene's levels (a CDS reset sample is one level)
    s_sig = math.sqrt(S + dark + sen.read_noise_e ** 2 + fpn_var)
    rho_detail = float(_plan.quantization_correlated_fraction(s_sig / step_e)) / n
    rho = 0.0 if scene.target.kind == "flat" else rho_detail
    m = stages
    if scene.tdi.domain == "charge":
        eq = float(_plan.snr_gain_charge(m, s_ad, math.sqrt(S + dark),
                                         math.sqrt(read_var)))
        pred = float(_sensor.snr_gain_charge_quadrature(
            m, signal_e=S, shot_var_e2=S + dark, read_var_e2=read_var,
            quant_var_e2=s_ad ** 2, fpn_var_e2=fpn_var))
    else:
        eq = float(_plan.snr_gain_digital(m, s_ad, s_cmos))
        pred = float(_plan.snr_gain_digital_predicted(m, s_ad, s_ind, rho))
    out = {"predicted_db": 20 * math.log10(pred), "eq28_db": 20 * math.log10(eq),
           "rho": rho, "rho_detail": rho_detail, "sigma_ad_e": s_ad, "sigma_cmos_e": s_cmos,
           "sigma_fpn_e": math.sqrt(fpn_var),
           "snr1_db": 20 * math.log10(snr1) if snr1 > 0 else None}
    if snr1 <= 0:
        out["note"] = "signal_e = 0: no signal, so no SNR (the gains are noise ratios)"
    return out
