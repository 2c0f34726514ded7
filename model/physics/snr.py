"""SNR of digital (and, for comparison, charge-domain) TDI.

Tao et al. 2012 (Tao Shuping, Jin Guang, Qu Hongsong, He Xiaojun, Yang Xiubin, "Design and analysis
of a digital-domain TDI CMOS camera for high-resolution space imaging", 2012) eqs 14-29, and
Zhou et al. 2008 (Zhou Huaide et al., "TDI operation of interline-transfer area CCDs", Optics and
Precision Engineering 16(9), 2008) for charge-domain TDI; plus the planning model that splits
quantization noise into its independent and shared parts. float64 numpy, scalars or arrays.
"""

from __future__ import annotations

import numpy as np
from scipy.special import erfc

from tdicam.errors import TdicamError

from tdicam.model._args import count, real

__all__ = [
    "quantization_noise",
    "temporal_noise",
    "snr_gain_digital",
    "quantization_correlated_fraction",
    "snr_gain_digital_predicted",
    "snr_gain_charge",
    "gain_db",
    "snr_tdi_db",
]


# --------------------------------------------------------------------------------------
# SNR (Tao et al. 2012 eqs 14-29; Zhou et al. 2008 for charge-domain TDI)
# --------------------------------------------------------------------------------------


def quantization_noise(e_per_dn):
    """RMS quantization noise of one conversion: ``q / sqrt(12)`` for a step of q.

    Tao et al. 2012 eq 14 writes the quantization term with the full well over ``2**N`` levels;
    here it is the standard deviation of a uniform error of one step, in the units of the
    step (electrons when ``e_per_dn`` is in e-/DN).

    Parameters
    ----------
    e_per_dn : float or array_like
        Quantization step, >= 0 (e.g. full well / 2**bits).

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    return real("e_per_dn", e_per_dn, lo=0.0) / np.sqrt(12.0)


def temporal_noise(signal_e, read_noise_e=0.0, dark_e=0.0):
    """Temporal noise of one exposure in electrons: ``sqrt(S + D + read**2)``.

    Photon shot noise of the signal ``S``, shot noise of the dark charge ``D`` and read noise
    add in quadrature (Tao et al. 2012 eq 25, expressed in electrons). This is ``sigma_CMOS``.

    Parameters
    ----------
    signal_e : float or array_like
        Signal electrons per exposure, >= 0.
    read_noise_e : float or array_like, optional
        RMS read noise, electrons, >= 0.
    dark_e : float or array_like, optional
        Dark electrons per exposure, >= 0.

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    s = real("signal_e", signal_e, lo=0.0)
    r = real("read_noise_e", read_noise_e, lo=0.0)
    d = real("dark_e", dark_e, lo=0.0)
    return np.sqrt(s + d + r * r)


def snr_gain_digital(stages, sigma_ad, sigma_cmos):
    """Linear SNR gain of m-stage digital TDI over one exposure, Tao et al. 2012 eq 28.

    ``G(m) = m (s_AD + s_CMOS) / (m s_AD + sqrt(m) s_CMOS)``: the signal grows as m, the
    temporal noise ``s_CMOS`` as ``sqrt(m)`` and, because every exposure is quantized, the
    quantization noise ``s_AD`` as m (Tao et al. 2012 eq 27 adds the two standard deviations
    linearly; this follows the paper). ``G(1) = 1`` exactly; ``G -> sqrt(m)`` when
    ``s_AD = 0``; ``G -> 1`` when quantization dominates. In decibels the gain is
    ``20 log10 G`` *added* to the single-exposure SNR (Tao et al. 2012 eq 29).

    Parameters
    ----------
    stages : int or array_like of int
        TDI stages m, >= 1.
    sigma_ad : float
        Quantization noise of one exposure, >= 0 (:func:`quantization_noise`).
    sigma_cmos : float
        Temporal noise of one exposure, >= 0, same units (:func:`temporal_noise`);
        ``sigma_ad + sigma_cmos`` must be > 0.

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    m, a, c = _digital_args(stages, sigma_ad, sigma_cmos)
    return m * (a + c) / (m * a + np.sqrt(m) * c)


def _digital_args(stages, sigma_ad, sigma_cmos):
    m = np.asarray(count("stages", stages, lo=1), dtype=np.float64)
    a = real("sigma_ad", sigma_ad, lo=0.0)
    c = real("sigma_cmos", sigma_cmos, lo=0.0)
    if np.any(a + c <= 0):
        raise TdicamError("sigma_ad + sigma_cmos = 0 is out of range; valid: 0..inf, "
                          "excluding 0 "
                          "(a noiseless exposure has no SNR)")
    return m, a, c


def quantization_correlated_fraction(sigma_dn):
    """Fraction of the quantization-error variance that the m exposures of one point share.

    An ADC of step 1 (DN) adds the error ``e(x) = round(x) - x`` to ``x = mu + n``, ``n`` the
    noise in front of it (Gaussian, RMS ``sigma_dn``). Split ``e`` into its conditional mean
    ``b(mu) = E[e | mu] = sum_k (-1)^k / (pi k) exp(-2 pi^2 k^2 s^2) sin(2 pi k mu)`` and the
    rest. The rest is independent from exposure to exposure (the noise is), so it adds in
    quadrature like the temporal noise; ``b(mu)`` is the same for every exposure that sees the
    same level ``mu`` and adds linearly, growing as m. Over a scene whose levels spread over
    many steps its share of the uniform ``1/12`` variance is
    ``rho = (6 / pi^2) sum_k exp(-4 pi^2 k^2 s^2) / k^2``: 1 without noise (Tao et al. 2012 eq 28's
    case: every error is shared), ``6/pi^2 exp(-4 pi^2 s^2)`` < 3e-5 from ``s = 0.5`` on.

    Parameters
    ----------
    sigma_dn : float or array_like
        RMS noise in front of the ADC in steps (DN), >= 0. Noise that differs between the
        exposures of one point but is fixed in time (PRNU/DSNU of different window rows)
        decorrelates ``b`` as well and may be included.

    Returns
    -------
    numpy.float64 or numpy.ndarray
        ``rho`` in [0, 1].
    """
    s = np.asarray(real("sigma_dn", sigma_dn, lo=0.0), np.float64)
    k = np.arange(1, 257, dtype=np.float64).reshape((-1,) + (1,) * s.ndim)
    c = 4.0 * np.pi ** 2 * (s * s)
    # terms k <= 256, then the tail k >= 257 as the integral from 256.5 of exp(-c x^2) / x^2,
    # exp(-c a^2) / a - sqrt(pi c) erfc(a sqrt(c)) (midpoint rule: error ~ 1/(12 a^3) = 5e-9)
    a = 256.5
    tail = np.exp(-c * a * a) / a - np.sqrt(np.pi * c) * erfc(a * np.sqrt(c))
    rho = (6.0 / np.pi ** 2) * (np.sum(np.exp(-c * k * k) / (k * k), axis=0) + tail)
    return np.clip(rho, 0.0, 1.0)[()]


def snr_gain_digital_predicted(stages, sigma_ad, sigma_cmos, correlated=0.0):
    """Linear SNR gain of m-stage digital TDI with quantization split as it really adds.

    ``G(m) = m sqrt(a^2 + c^2) / sqrt(m (c^2 + (1 - rho) a^2) + m^2 rho a^2)``: the temporal
    (and row-to-row fixed-pattern) noise ``c`` and the independent part ``(1 - rho) a^2`` of
    the quantization variance grow as ``sqrt(m)``; only the shared part ``rho a^2``
    (:func:`quantization_correlated_fraction`) grows as m. ``rho = 0`` gives ``sqrt(m)``;
    ``rho = 1`` with ``c = 0`` gives 1, the limit of Tao et al. 2012 eq 28
    (:func:`snr_gain_digital`), which lets all of ``a`` grow as m (and adds it linearly to
    ``c``): the paper's worst case, ``G_eq28 <= sqrt(m)``, right only when the noise does not
    dither the ADC and the scene has detail.

    A flat field has one level: ``b(mu)`` is then the same for every pixel, a bias of the
    mean and no noise at all, so its measured gain has ``rho = 0`` whatever the noise; a
    scene with detail has ``rho = quantization_correlated_fraction(sigma_DN)``.

    Parameters
    ----------
    stages : int or array_like of int
        TDI stages m, >= 1.
    sigma_ad : float
        Quantization noise of one exposure, >= 0 (:func:`quantization_noise`).
    sigma_cmos : float
        Noise of one exposure that is independent between exposures (temporal, and fixed
        pattern of different window rows), >= 0, same units.
    correlated : float, optional
        ``rho`` in [0, 1] (default 0).

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    m, a, c = _digital_args(stages, sigma_ad, sigma_cmos)
    rho = real("correlated", correlated, lo=0.0, hi=1.0)
    a2, c2 = a * a, c * c
    return m * np.sqrt(a2 + c2) / np.sqrt(m * (c2 + (1.0 - rho) * a2) + m * m * rho * a2)


def snr_gain_charge(stages, sigma_ad, sigma_shot, sigma_read=0.0):
    """Linear SNR gain of m-stage charge-domain TDI (TDI-CCD, Zhou et al. 2008) for comparison.

    Charge is summed before one readout and one conversion, so read noise and quantization
    are added once while shot noise grows as ``sqrt(m)``. Using the same convention as
    :func:`snr_gain_digital` (quantization added linearly to the temporal noise):

    ``G_c(m) = m (s_AD + sqrt(s_shot**2 + s_read**2)) / (s_AD + sqrt(m s_shot**2 + s_read**2))``

    A read-noise-limited scene gains m (4 stages: +12.0 dB; Zhou et al. 2008 measured 22.13 ->
    33.62 dB, +11.5 dB) where digital TDI gains ``sqrt(m)`` (+6.0 dB); a shot-noise-limited
    scene gains ``sqrt(m)`` in both domains. ``G_c(1) = 1`` exactly.

    Parameters
    ----------
    stages : int or array_like of int
        TDI stages m, >= 1.
    sigma_ad : float
        Quantization noise of one conversion, >= 0.
    sigma_shot : float
        Shot noise (signal + dark) of one exposure, >= 0.
    sigma_read : float, optional
        Read noise of one readout, >= 0. The three must not all be 0.

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    m = np.asarray(count("stages", stages, lo=1), dtype=np.float64)
    a = real("sigma_ad", sigma_ad, lo=0.0)
    s = real("sigma_shot", sigma_shot, lo=0.0)
    r = real("sigma_read", sigma_read, lo=0.0)
    if np.any(a + s + r <= 0):
        raise TdicamError("sigma_ad + sigma_shot + sigma_read = 0 is out of range; valid: 0..inf, "
                          "excluding 0 "
                          "(a noiseless exposure has no SNR)")
    return m * (a + np.sqrt(s * s + r * r)) / (a + np.sqrt(m * s * s + r * r))


def gain_db(gain):
    """A linear amplitude ratio in decibels, ``20 log10(gain)``.

    Parameters
    ----------
    gain : float or array_like
        Linear ratio, > 0.

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    return 20.0 * np.log10(real("gain", gain, lo=0.0, lo_open=True))


def snr_tdi_db(signal, sigma_ad, sigma_cmos, stages=1):
    """SNR in dB of m-stage digital TDI, Tao et al. 2012 eqs 28-29.

    ``20 log10( m S / (m s_AD + sqrt(m) s_CMOS) )`` — the single-exposure SNR
    ``20 log10(S / (s_AD + s_CMOS))`` plus ``20 log10 G(m)``.

    Parameters
    ----------
    signal : float or array_like
        Signal of one exposure S, > 0, in the units of the noises.
    sigma_ad, sigma_cmos : float
        As :func:`snr_gain_digital`.
    stages : int or array_like of int, optional
        TDI stages m, >= 1 (default 1: single exposure).

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    s = real("signal", signal, lo=0.0, lo_open=True)
    g = snr_gain_digital(stages, sigma_ad, sigma_cmos)
    return 20.0 * np.log10(s / (sigma_ad + sigma_cmos)) + gain_db(g)
