"""Image-quality metrics measured on images (Ning et al. 2019 eqs 1-3).

Ning Yonghui, Liu Hui, Zhao Qinglei, Guo Hanzhou, "Design of a large-array high-frame-rate
CMOS imaging electronics system", Optics and Precision Engineering 27(5), 2019 ("Ning et al. 2019").
:func:`snr_db` here measures an image region; the planned SNR of m-stage TDI is
:func:`tdicam.model.physics.snr.snr_tdi_db`.

These are the measurements Ning et al. 2019 Table 3 reports (PRNU 1.5 %, SNR 45 dB, MTF 0.08) and
that the scene simulator applies to its output: SNR = mean/std of a uniform region, PRNU =
std/mean of a flat field, and MTF estimated from the contrast transfer function (CTF) of a
bar target, ``MTF ~ (pi/4) CTF`` (the first harmonic of a square wave has amplitude 4/pi).

All statistics use float64 and the population standard deviation (divide by n, as Ning et al. 2019
eqs 1-2 write). Bad input raises :class:`~tdicam.errors.TdicamError`.
"""

from __future__ import annotations

import numpy as np

from tdicam.errors import TdicamError

from tdicam.model._args import real

__all__ = ["snr", "snr_db", "prnu", "ctf", "mtf_from_ctf", "bar_ctf", "bar_mtf"]


def _region(name, values):
    """``values`` as a float64 array: non-empty, all finite (the planning models' check)."""
    return np.asarray(real(name, values), dtype=np.float64)


def snr(region):
    """Linear SNR of a uniform region, Ning et al. 2019 eq 1: ``mean / std``.

    Parameters
    ----------
    region : array_like
        Pixel values of a region of uniform scene radiance, non-empty, finite.

    Returns
    -------
    float
        ``mean / std`` (population std); ``inf`` for a noiseless region with a non-zero
        mean. Raises when both mean and std are 0.
    """
    arr = _region("region", region)
    mean, std = float(arr.mean()), float(arr.std())
    if std == 0.0:
        if mean == 0.0:
            raise TdicamError("region has mean 0 and std 0; SNR is undefined")
        return float(np.inf)
    return mean / std


def snr_db(region):
    """SNR of a uniform region in decibels, ``20 log10(mean / std)`` (Ning et al. 2019 eq 1).

    Parameters
    ----------
    region : array_like
        As :func:`snr`; the mean must be > 0.

    Returns
    -------
    float
        Decibels (``inf`` for a noiseless region).
    """
    value = snr(region)
    if value <= 0:
        raise TdicamError(f"region mean must be > 0 for an SNR in dB, got SNR {value:.6g}")
    return float(20.0 * np.log10(value))


def prnu(flat):
    """Photo-response non-uniformity of a flat field, Ning et al. 2019 eq 2: ``std / mean``.

    Pass a temporally averaged flat (or a noiseless one) to measure the fixed pattern only;
    temporal noise in ``flat`` is counted as non-uniformity.

    Parameters
    ----------
    flat : array_like
        Flat-field pixel values (dark-subtracted), non-empty, finite, mean > 0.

    Returns
    -------
    float
        A fraction (0.015 is 1.5 %).
    """
    arr = _region("flat", flat)
    mean = float(arr.mean())
    if mean <= 0:
        raise TdicamError(f"flat mean = {mean:.6g} is out of range; valid: > 0")
    return float(arr.std()) / mean


def ctf(i_max, i_min):
    """Contrast transfer function (Michelson contrast), Ning et al. 2019 eq 3.

    ``CTF = (I_max - I_min) / (I_max + I_min)``

    Parameters
    ----------
    i_max, i_min : float or array_like
        Bright-bar and dark-bar levels, >= 0, with ``i_max + i_min > 0``.

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    hi = _region("i_max", i_max)
    lo = _region("i_min", i_min)
    if np.any(hi < 0) or np.any(lo < 0):
        raise TdicamError("i_max and i_min must be >= 0")
    if np.any(hi + lo <= 0):
        raise TdicamError("i_max + i_min = 0 is out of range; valid: > 0")
    out = (hi - lo) / (hi + lo)
    return out[()] if out.ndim == 0 else out


def mtf_from_ctf(ctf_value):
    """MTF estimate from a square-wave CTF, Ning et al. 2019 eq 3: ``(pi/4) * CTF``.

    Parameters
    ----------
    ctf_value : float or array_like
        CTF in [-1, 1].

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    c = _region("ctf_value", ctf_value)
    if np.any(np.abs(c) > 1):
        raise TdicamError("ctf_value is out of range; valid: [-1, 1]")
    out = np.pi / 4.0 * c
    return out[()] if out.ndim == 0 else out


def bar_ctf(image, axis=0):
    """CTF of a bar-target image whose bars run along ``axis``.

    The image is averaged along ``axis`` (along the bars, which removes most temporal noise)
    to a 1-D profile across the bars; ``I_max``/``I_min`` are that profile's maximum and
    minimum. Crop the image to whole bars of one period before calling.

    Parameters
    ----------
    image : array_like
        2-D bar-target image, finite, non-negative, with at least one non-zero pixel.
    axis : {0, 1}
        Axis along which the bars run (0: bars are vertical stripes, the profile varies
        along the columns).

    Returns
    -------
    float
    """
    arr = _region("image", image)
    if arr.ndim != 2:
        raise TdicamError(f"image must be 2-D, got {arr.ndim}-D")
    if axis not in (0, 1):
        raise TdicamError(f"axis = {axis!r} is not valid; valid: 0, 1")
    profile = arr.mean(axis=axis)
    return float(ctf(profile.max(), profile.min()))


def bar_mtf(image, axis=0):
    """MTF estimate of a bar-target image: ``mtf_from_ctf(bar_ctf(image, axis))``.

    Parameters
    ----------
    image : array_like
        As :func:`bar_ctf`.
    axis : {0, 1}
        As :func:`bar_ctf`.

    Returns
    -------
    float
    """
    return float(mtf_from_ctf(bar_ctf(image, axis)))
