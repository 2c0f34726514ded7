"""Sensor physics of one exposure and the flat-field SNR models the scene simulator checks.

Signal chain of one exposure of one pixel (electrons unless stated):

1. photo-electrons expected ``mu = S * rel * (1 + P)``: ``S`` the scene light level
   (``[target].signal_e``), ``rel`` the rendered relative radiance, ``P`` the pixel's PRNU
   (Gaussian, RMS ``prnu``);
2. dark electrons expected ``d = I_dark * T_line + D``: ``D`` the pixel's DSNU (Gaussian, RMS
   ``dsnu_e``); ``d`` is clipped at 0 (no negative charge);
3. shot noise: the collected charge is ``Poisson(mu + d)``;
4. full-well clipping: ``min(charge, full_well_e)``;
5. read noise: ``+ Normal(0, read_noise_e**2)`` per sample (a digital-CDS pair has two);
6. ADC, channel gain ``a``: ``DN = clamp(floor(v a / c + B + 1/2), 0, 2**bits - 1)`` with
   ``c`` = ``conversion_gain_e_per_dn`` (e-/DN at gain 1) and ``B`` = ``black_level_dn``
   (round half up, saturate, never wrap).

Flat-field SNR of m-stage TDI
-----------------------------
Tao et al. 2012 eq 28 adds the quantization noise ``s_AD`` *linearly* to the temporal noise
``s_CMOS`` and lets it grow as ``m``: ``G(m) = m (s_AD + s_CMOS) / (m s_AD + sqrt(m) s_CMOS)``
(:func:`tdicam.model.physics.plan.snr_gain_digital`). That is the worst case of fully correlated
quantization errors. When the temporal noise in front of the ADC is at least about half a
step (``sigma_DN >~ 0.5``; the usual case), each exposure's quantization error is uniform and
independent of the others (Widrow's quantization theorem: the dependence is of order
``exp(-2 pi^2 sigma_DN^2)``, :func:`dither_defect`), so all noise terms — shot, dark, read,
quantization, and the column-wise fixed pattern of PRNU/DSNU summed over m rows — add in
quadrature and grow as ``sqrt(m)``: the measured digital gain is ``sqrt(m)``
(:func:`snr_gain_digital_quadrature`). Eq 28 then agrees with the measurement within
``20 log10((1 + r sqrt(m)) / (1 + r))`` dB, ``r = s_AD / s_CMOS``: under 0.5 dB at m = 96
only when ``r < 0.0068``. :func:`eq28_validity_db` gives that difference. Below about half a
step of noise the rounding error has a signal-dependent mean ``b(mu)`` that the m exposures of
one level share and that grows as m; on a flat field it is a bias, not noise, and in a scene
with detail its variance is the fraction ``rho`` of :func:`tdicam.model.physics.plan.
quantization_correlated_fraction`; :func:`tdicam.model.physics.plan.snr_gain_digital_predicted`
is the planning model that accounts for both parts, :func:`quantized_moments` the exact
moments of one rounding.

Charge-domain TDI (Zhou et al. 2008) sums charge before one read and one conversion:
:func:`snr_gain_charge_quadrature`.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["fixed_pattern", "adc", "dither_defect", "snr_gain_digital_quadrature",
           "snr_gain_charge_quadrature", "eq28_validity_db", "quantization_sigma_e",
           "quantized_moments"]


def fixed_pattern(rng, shape, *, prnu, dsnu_e, dark_e):
    """Per-pixel gain ``1 + P`` and dark electrons per exposure ``max(dark_e + D, 0)``.

    Parameters
    ----------
    rng : numpy.random.Generator
    shape : tuple
        ``(rows, columns)`` of the sensor window.
    prnu : float
        RMS of ``P`` (0 gives exactly 1).
    dsnu_e : float
        RMS of ``D``, electrons (0 gives exactly ``dark_e``).
    dark_e : float
        Mean dark electrons per exposure (dark current times line period).

    Returns
    -------
    (gain, dark) : float64 arrays of ``shape``
    """
    gain = np.ones(shape)
    dark = np.full(shape, float(dark_e))
    if prnu > 0:
        gain = 1.0 + prnu * rng.standard_normal(shape)
        np.maximum(gain, 0.0, out=gain)
    if dsnu_e > 0:
        dark = np.maximum(dark_e + dsnu_e * rng.standard_normal(shape), 0.0)
    return gain, dark


def adc(volts_e, *, e_per_dn, gain=1.0, bits=12, black_level_dn=0.0, out=None):
    """Convert electrons (float array) to DN: round half up, saturate to ``0..2**bits-1``.

    ``DN = clamp(floor(v * gain / e_per_dn + black_level_dn + 0.5), 0, 2**bits - 1)``;
    the result is int64 (or written into ``out``).
    """
    x = np.asarray(volts_e, np.float64) * (gain / e_per_dn)
    if black_level_dn:
        x = x + (black_level_dn + 0.5)
    else:
        x = x + 0.5
    np.floor(x, out=x)
    np.clip(x, 0, (1 << bits) - 1, out=x)
    if out is not None:
        out[...] = x
        return out
    return x.astype(np.int64)


def quantization_sigma_e(e_per_dn, gain=1.0):
    """RMS quantization noise of one conversion in input electrons, ``c / (a sqrt(12))``."""
    return e_per_dn / gain / math.sqrt(12.0)


def dither_defect(sigma_dn):
    """Widrow dependence of the quantization error on the signal, ``exp(-2 pi^2 s^2)``.

    ``s`` is the RMS temporal noise in front of the ADC in DN. The first Fourier term of the
    rounding error's mean and correlation is bounded by this; below ~1e-3 (``s >= 0.6``)
    successive exposures' quantization errors are independent and uniform to that accuracy.
    """
    s = np.asarray(sigma_dn, np.float64)
    return np.exp(-2.0 * np.pi ** 2 * s * s)


def quantized_moments(mu_dn, sigma_dn):
    """Mean and variance of ``floor(mu + sigma z + 1/2)``, ``z`` standard normal (no clipping).

    Exact for Gaussian noise in front of a round-half-up ADC in any regime: from the
    probabilities ``P(Q = f + d) = Phi((d + 1/2 - u) / s) - Phi((d - 1/2 - u) / s)``
    (``f = floor(mu)``, ``u = mu - f``) over ``|d| <= 6 s + 2``. Where the noise dithers the
    ADC (``s >= 1.5``: Widrow defect < 1e-19) it is ``(mu, s^2 + 1/12)``.

    Parameters
    ----------
    mu_dn, sigma_dn : array_like (broadcast)
        Mean and RMS of the value in front of the ADC, DN; ``sigma_dn >= 0``.

    Returns
    -------
    (mean, var) : float64 arrays of the broadcast shape
    """
    from scipy.special import ndtr
    mu, s = np.broadcast_arrays(np.asarray(mu_dn, np.float64), np.asarray(sigma_dn, np.float64))
    mean = np.array(mu, np.float64)
    var = np.array(s * s + 1.0 / 12.0, np.float64)
    low = s < 1.5
    if not np.any(low):
        return mean, var
    m, sl = mu[low], s[low]
    f = np.floor(m)
    u = m - f
    n = int(math.ceil(6.0 * float(sl.max()))) + 2
    d = np.arange(-n, n + 1, dtype=np.float64)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (d + 0.5 - u) / sl
    z = np.where(sl > 0, z, np.where(d + 0.5 - u > 0, np.inf, -np.inf))
    cdf = ndtr(z)                                  # P(Q <= f + d)
    p = np.diff(cdf, axis=0, prepend=0.0)
    p[0] = cdf[0]
    e1 = (d * p).sum(axis=0)
    e2 = (d * d * p).sum(axis=0)
    mean[low] = f + e1
    var[low] = np.maximum(e2 - e1 * e1, 0.0)
    return mean, var


def snr_gain_digital_quadrature(stages):
    """Flat-field SNR gain of m-stage digital TDI when all noise adds in quadrature:
    ``sqrt(m)`` (see the module docstring)."""
    return np.sqrt(np.asarray(stages, np.float64))


def snr_gain_charge_quadrature(stages, *, signal_e, shot_var_e2, read_var_e2, quant_var_e2,
                               fpn_var_e2=0.0):
    """Flat-field SNR gain of m-stage charge-domain TDI, noise in quadrature.

    One exposure: ``S / sqrt(shot + fpn + read + quant)``; m stages sum charge (signal m S,
    shot and fixed-pattern variance times m) and read and convert once:
    ``G = m S / sqrt(m (shot + fpn) + read + quant) / (S / sqrt(shot + fpn + read + quant))``.
    """
    m = np.asarray(stages, np.float64)
    one = shot_var_e2 + fpn_var_e2 + read_var_e2 + quant_var_e2
    many = m * (shot_var_e2 + fpn_var_e2) + read_var_e2 + quant_var_e2
    return m * np.sqrt(one) / np.sqrt(many)


def eq28_validity_db(stages, sigma_ad, sigma_cmos):
    """How far Tao et al. 2012 eq 28 sits below ``sqrt(m)``, dB: ``20 log10(sqrt(m) / G(m))``."""
    m = np.asarray(stages, np.float64)
    g = m * (sigma_ad + sigma_cmos) / (m * sigma_ad + np.sqrt(m) * sigma_cmos)
    return 20.0 * np.log10(np.sqrt(m) / g)
