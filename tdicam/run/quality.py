"""The imaging questions every ``tdicam run`` report answers, whatever the target.

:func:`quality` returns, for one sweep point (a :class:`~tdicam.engine.SceneResult`):

* ``"clipping"`` — per cent of pixels at full scale (and at code 0) in the raw exposure
  (full scale ``2**bits - 1`` DN) and in the output (:func:`output_full_scale`), and
  ``saturated``: the stages where more than :data:`SATURATED_PERCENT` per cent sit at full
  scale (their SNR and MTF measure the clipping, not the camera);
* ``"region_snr"`` (every target but ``flat``, whose SNR :func:`tdicam.run.measure.measure`
  measures on the whole image) — the SNR of the output and of one exposure (the TDI input,
  as for a flat target) on a region the target makes flat: :func:`flat_region`. Signal =
  the mean above the zero-light pedestal times the light's share ``S / (S + D)`` (``S`` the
  region's photo-electrons, ``D`` the mean dark charge), noise = the standard deviation of
  the region's pixels about a least-squares ``a + b * target`` fit (what is left of the
  target's own variation inside the region is not counted as noise); ``20 log10``, dB, and
  the gain, output minus one exposure;
* ``"vs_target"`` (``image`` targets) — PSNR and SSIM of the output and of one exposure
  against the ideal target (:func:`fidelity`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

__all__ = ["quality", "flat_region", "fidelity", "clipping", "output_full_scale",
           "to_target_scale", "relative", "SATURATED_PERCENT",
           "FLAT_TOLERANCE", "MIN_REGION_PIXELS"]

#: A stage is *saturated* (a warning line on the console) when more than this per cent of
#: its pixels are at full scale.
SATURATED_PERCENT = 1.0

#: A target pixel is *flat* when its 3 x 3 neighbourhood varies by at most this fraction of
#: the target's range; the region is the flat pixels within it of the brightest flat level.
FLAT_TOLERANCE = 0.01

#: Fewest pixels an SNR is measured on.
MIN_REGION_PIXELS = 32


def _trimmed(a, trim):
    a = np.asarray(a, np.float64)
    if trim and min(a.shape) > 2 * trim + 2:
        a = a[trim:-trim, trim:-trim]
    return a


def flat_region(target, tol=FLAT_TOLERANCE):
    """``(mask, how)``: the pixels of the ideal ``target`` (relative radiance) an SNR is
    measured on, and the words saying which.

    The first of these with at least :data:`MIN_REGION_PIXELS` pixels: the flat pixels (3 x 3
    neighbourhood within ``tol`` of the target's range) within ``tol`` of the brightest
    flat level (bars, edges); every flat pixel (a picture's smooth areas, at several
    levels: the fit of :func:`region_snr` takes the levels out); every pixel within ``tol``
    of the target's brightest level (bars two pixels wide have no flat 3 x 3
    neighbourhood). A mask of fewer pixels: no such region.
    """
    t = np.asarray(target, np.float64)
    span = float(t.max() - t.min())
    band = tol * span if span > 0 else 0.0
    flat = ndimage.maximum_filter(t, 3, mode="nearest") \
        - ndimage.minimum_filter(t, 3, mode="nearest") <= band
    if flat.sum() >= MIN_REGION_PIXELS:
        top = float(t[flat].max())
        mask = flat & (t >= top - band)
        if mask.sum() >= MIN_REGION_PIXELS:
            return mask, f"flat 3 x 3 pixels at the brightest flat level ({top:.3g})"
        return flat, "flat 3 x 3 pixels of the target, every level"
    top = float(t.max())
    return t >= top - band, f"pixels at the target's brightest level ({top:.3g})"


def _region_db(img, target, mask, pedestal, light):
    """SNR (dB) of ``img`` on ``mask``: light share of the mean above ``pedestal`` over the
    deviation about the affine fit to ``target``; None without signal or noise."""
    v = np.asarray(img, np.float64)[mask]
    t = np.asarray(target, np.float64)[mask]
    if np.ptp(t) > 0:
        coef = np.polyfit(t, v, 1)
        resid = v - np.polyval(coef, t)
    else:
        resid = v - v.mean()
    mean = (v.mean() - pedestal) * light
    std = float(np.sqrt(np.mean(resid ** 2)))
    if std == 0 or mean <= 0:
        return None
    return 20.0 * math.log10(mean / std)


def region_snr(scene, res, trim, dark_e):
    """The ``"region_snr"`` entry of :func:`quality` (module docstring)."""
    tgt = _trimmed(res.target, trim)
    mask, how = flat_region(tgt)
    n = int(mask.sum())
    none = {"output_db": None, "single_db": None, "gain_db": None, "pixels": n, "region": how}
    if n < MIN_REGION_PIXELS:
        return {**none, "note": f"no flat region of the target to measure an SNR on (at "
                                f"least {MIN_REGION_PIXELS} pixels)"}
    clipped = [name for name, img, fs in
               (("raw exposure", res.raw, 2 ** scene.sensor.bits - 1),
                ("output", res.output, output_full_scale(scene, res)))
               if 100.0 * np.mean(_trimmed(img, trim)[mask] >= fs) > SATURATED_PERCENT]
    if clipped:
        return {**none, "note": f"saturated: more than {SATURATED_PERCENT:g} % of the region's "
                                f"{' and '.join(clipped)} pixels are "
                                f"at full scale, so its SNR measures the clipping"}
    s_e = scene.target.signal_e * float(tgt[mask].mean())
    light = s_e / (s_e + dark_e) if s_e + dark_e > 0 else 0.0
    out = _region_db(_trimmed(res.output, trim), tgt, mask, res.pedestal_output, light)
    one = _region_db(_trimmed(res.single, trim), tgt, mask, res.pedestal_single, light)
    entry = {"output_db": out, "single_db": one,
             "gain_db": None if out is None or one is None else out - one,
             "pixels": n, "region": how, "signal_e": s_e}
    if out is None or one is None:
        which = " and ".join(k for k, v in (("output", out), ("one read", one)) if v is None)
        entry["note"] = (f"no SNR for the {which}: no signal above the zero-light pedestal "
                         f"or no noise in the region")
    return entry


def to_target_scale(target, img, pedestal):
    """``img`` on the ideal ``target``'s scale (relative radiance): ``img`` minus its
    zero-light ``pedestal`` and the offset ``a`` of the least-squares ``a + b * target`` fit,
    over its gain ``b`` (gain, offset and dark level removed). None when the target is
    constant or the fit has no positive gain."""
    t = np.asarray(target, np.float64)
    v = np.asarray(img, np.float64) - pedestal
    if np.ptp(t) == 0:
        return None
    b, a = np.polyfit(t.ravel(), v.ravel(), 1)
    return None if b <= 0 else (v - a) / b


def relative(img, pedestal):
    """``img`` above its zero-light ``pedestal`` over its mean above it: 1 is the mean
    signal, so images of different gain (one read, m stages) share one scale."""
    v = np.asarray(img, np.float64) - pedestal
    mean = float(v.mean())
    return v / mean if mean > 0 else v


def fidelity(target, img, pedestal):
    """PSNR (dB) and SSIM of ``img`` against the ideal ``target``.

    Alignment: none — the simulator renders the ideal target at the output pixels, so
    ``target[i, j]`` is the radiance output pixel ``(i, j)`` sees. Scaling: ``img`` is mapped
    onto the target's scale by :func:`to_target_scale` (least-squares gain and offset), then
    compared with ``skimage.metrics.peak_signal_noise_ratio`` and ``structural_similarity``
    at ``data_range = 1`` (the target's relative radiance, 0 to 1). None when the target is
    constant or the fit has no gain.
    """
    from skimage.metrics import peak_signal_noise_ratio, structural_similarity
    t = np.asarray(target, np.float64)
    scaled = to_target_scale(t, img, pedestal)
    if scaled is None:
        return {"psnr_db": None, "ssim": None}
    win = min(7, *t.shape)
    win -= 1 - win % 2                       # odd, at most the image's side
    return {"psnr_db": float(peak_signal_noise_ratio(t, scaled, data_range=1.0)),
            "ssim": float(structural_similarity(t, scaled, data_range=1.0, win_size=win))
            if win >= 3 else None}


def output_full_scale(scene, res):
    """The largest value the output reaches, DN: the output word's full scale, and for
    digital TDI at most ``stages`` times the ADC's (m reads at full scale summed: 16,380 DN
    for 4 stages of 12 bits in a 16,383 DN word)."""
    fs = int(res.output_full_scale)
    if scene.tdi.domain == "digital":
        fs = min(fs, res.stages * (2 ** scene.sensor.bits - 1))
    return fs


def clipping(scene, res):
    """The ``"clipping"`` entry of :func:`quality` (module docstring)."""
    raw_fs = 2 ** scene.sensor.bits - 1
    out_fs = output_full_scale(scene, res)
    entry = {}
    for key, img, fs in (("raw", res.raw, raw_fs), ("output", res.output, out_fs)):
        a = np.asarray(img)
        entry[key] = {"full_scale_dn": fs,
                      "at_full_scale_percent": 100.0 * float(np.mean(a >= fs)),
                      "at_zero_percent": 100.0 * float(np.mean(a <= 0))}
    entry["saturated"] = [k for k in ("raw", "output")
                          if entry[k]["at_full_scale_percent"] > SATURATED_PERCENT]
    return entry


def quality(scene, res, trim, dark_e):
    """The imaging-question entries of one sweep point's measurements (module docstring)."""
    out = {"clipping": clipping(scene, res)}
    kind = scene.target.kind
    if kind != "flat":
        out["region_snr"] = region_snr(scene, res, trim, dark_e)
    if kind == "image":
        t = _trimmed(res.target, trim)
        out["vs_target"] = {
            "output": fidelity(t, _trimmed(res.output, trim), res.pedestal_output),
            "single": fidelity(t, _trimmed(res.single, trim), res.pedestal_single),
            "data_range": 1.0,
            "method": "against the ideal target at the output pixels (no shift); each image "
                      "minus its zero-light pedestal mapped onto the target's 0..1 scale by "
                      "a least-squares gain and offset; skimage.metrics PSNR and SSIM at "
                      "data_range = 1"}
    return out
