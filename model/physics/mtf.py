"""Along-track MTF of a digital-TDI camera: one exposure and smear model, and Yuan et al. 2013's.

One model serves ``tdicam plan``, the run report and the scene simulator
(:class:`tdicam.model.physics.optics.Geometry` evaluates its footprint with :func:`transfer_along`).
Frequencies ``f`` are in cycles per pixel pitch (Nyquist :data:`NYQUIST` = 0.5); lengths in
pitches, times in line periods ``T``.

The camera model (:func:`camera_mtf`)
-------------------------------------
Each of the M exposures of a ground line integrates for ``x T`` (``x`` = ``exposure``, the
integration time over the line period: 1, the full line period, unless the sensor integrates
for less) while the image moves along track at its actual speed ``v = 1 - dV/V`` pitches per
line period (a positive mismatch is an image slower than the TDI clock). Rolling-shutter row
``k`` of the window is read ``k T_row`` after row 0, so successive stages are
``T (1 - e)`` apart with the skew ``e = +T_row/T`` (forward scan), ``-T_row/T`` (reverse) or
0 (global shutter) (:func:`rolling_skew`). Each stage then lags the previous one by
``Delta = 1 - v (1 - e)`` pitches (:func:`stage_lag`). The transfer function is the product

``H(f) = sinc(f q/p) * sinc(f v x) * exp(-2 pi^2 sigma^2 f^2) * D_M(f Delta)``

— pixel aperture (active width ``q/p``), smear during one exposure, optics PSF (Gaussian,
``sigma`` pitches) and the M-stage misregistration, with the discrete-stage kernel
``D_M(u) = sin(pi M u) / (M sin(pi u))`` (:func:`dirichlet`, ``-> sinc(M u)`` for small
``u``). The MTF is its modulus ``|H|``; ``H < 0`` is contrast reversal (bars print with
bright and dark swapped), reported separately by :attr:`CameraMtf.reversed`, never as a
negative MTF.

The paper's model (:func:`mtf_system`)
--------------------------------------
Yuan Gaobin, Li Binqiao, Xu Jiangtao, Nie Kaiming, "MTF velocity-mismatch model of TDI
area-array CMOS image sensors" (2013), eqs 2-8: ``sinc(f q/p) * sinc(f M/(M+1)) *
sinc(f M dV/V)`` — each exposure taken as ``M/(M+1)`` of a line period, the smear at the
nominal speed and the mismatch as a continuous line spread of ``M dV/V`` pitches, no
rolling-shutter skew. It is printed beside the camera model as "paper's model": its
mismatch factor gives 0.637 at ``M dV/V = 1`` and 0 at ``M dV/V = 2`` at Nyquist. At
``dV/V = 0`` it is higher than the camera by 0.168 / 0.044 / 0.012 / 0.004 for
M = 1 / 8 / 32 / 96 (the exposure it assumes is shorter than the line period).

Every function returns a modulus unless ``signed=True`` is asked for. A velocity mismatch
must lie in (-1, 1): at ``dV/V = 1`` the image stands still and there is no line period
(:func:`check_dv_over_v`; the paper's formulas alone take any finite value).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tdicam.model._args import count, real

__all__ = [
    "NYQUIST",
    "check_dv_over_v",
    "rolling_skew",
    "stage_lag",
    "dirichlet",
    "transfer_along",
    "camera_mtf",
    "CameraMtf",
    "camera_mtf_terms",
    "mtf_aperture",
    "mtf_temporal",
    "mtf_velocity_mismatch",
    "mtf_system",
]

#: Nyquist frequency in cycles per pixel, ``1/(2p)`` times the pitch ``p``.
NYQUIST = 0.5


def check_dv_over_v(dv_over_v, name="dv_over_v"):
    """Return ``dv_over_v`` (float64) if every value lies in the open interval (-1, 1).

    Raises :class:`~tdicam.errors.TdicamError` ``NAME = V is out of range; valid: -1..1,
    excluding -1 and 1`` otherwise (at 1 the image is at rest; beyond it moves backwards).
    """
    return real(name, dv_over_v, lo=-1.0, hi=1.0, lo_open=True, hi_open=True)


def rolling_skew(row_time_s, line_period_s, *, shutter="rolling", direction="forward"):
    """Rolling-shutter skew per stage ``e``, in line periods.

    ``+T_row/T`` for a forward scan, ``-T_row/T`` for a reverse scan, 0 for a global shutter
    or when the row time is unknown (None).

    Parameters
    ----------
    row_time_s : float or None
        Row read time ``T_row``, seconds, > 0 (None: unknown).
    line_period_s : float
        Line period ``T``, seconds, > 0.
    shutter : {"rolling", "global"}
    direction : {"forward", "reverse"}

    Returns
    -------
    float
    """
    if shutter == "global" or row_time_s is None:
        return 0.0
    t_row = float(real("row_time_s", row_time_s, lo=0.0, lo_open=True))
    t = float(real("line_period_s", line_period_s, lo=0.0, lo_open=True))
    return (t_row / t) * (1.0 if direction == "forward" else -1.0)


def stage_lag(dv_over_v, skew=0.0):
    """Along-track lag of one stage behind the previous, ``Delta = 1 - (1 - dV/V)(1 - e)``.

    Pitches; ``M Delta`` is the total misregistration over M stages (``M dV/V`` without skew).
    """
    dv = check_dv_over_v(dv_over_v)
    e = real("skew", skew, lo=-1.0, hi=1.0, lo_open=True, hi_open=True)
    return 1.0 - (1.0 - dv) * (1.0 - e)


def dirichlet(u, m):
    """Normalised discrete-stage kernel ``sin(pi m u) / (m sin(pi u))`` (1 at ``u = 0``), signed."""
    u = np.asarray(u, np.float64)
    m = np.asarray(m, np.float64)
    den = m * np.sin(np.pi * u)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(np.abs(den) < 1e-300, 1.0,
                       np.sin(np.pi * m * u) / np.where(den == 0, 1.0, den))
    return out[()] if out.ndim == 0 else out


def transfer_along(f, stages, dv_over_v=0.0, skew=0.0, q_over_p=1.0, exposure=1.0,
                   psf_sigma_px=0.0, *, include_stages=True):
    """Signed along-track transfer ``H(f)`` of the camera model (module docstring).

    Parameters
    ----------
    f : float or array_like
        Spatial frequency, cycles per pitch, >= 0.
    stages : int or array_like of int
        TDI stages M, >= 1.
    dv_over_v : float or array_like
        Velocity mismatch, in (-1, 1).
    skew : float
        Rolling-shutter skew per stage (:func:`rolling_skew`), in (-1, 1).
    q_over_p : float
        Active width over pitch, in (0, 1].
    exposure : float
        Integration time over the line period, in (0, 1] (1: the full line period).
    psf_sigma_px : float
        Gaussian optics PSF standard deviation, pitches, >= 0.
    include_stages : bool
        False: the footprint of one exposure only (no ``D_M`` factor).

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    f = real("f", f, lo=0.0)
    m = np.asarray(count("stages", stages, lo=1), dtype=np.float64)
    q = real("q_over_p", q_over_p, lo=0.0, hi=1.0, lo_open=True)
    x = real("exposure", exposure, lo=0.0, hi=1.0, lo_open=True)
    sig = real("psf_sigma_px", psf_sigma_px, lo=0.0)
    v = 1.0 - check_dv_over_v(dv_over_v)
    h = np.sinc(f * q) * np.sinc(f * v * x) * np.exp(-2.0 * np.pi ** 2 * sig * sig * f * f)
    if include_stages:
        h = h * dirichlet(f * stage_lag(dv_over_v, skew), m)
    return h


def camera_mtf(f, stages, dv_over_v=0.0, skew=0.0, q_over_p=1.0, exposure=1.0,
               psf_sigma_px=0.0):
    """Along-track MTF of the camera model, ``|transfer_along(...)|`` (same parameters)."""
    return np.abs(transfer_along(f, stages, dv_over_v, skew, q_over_p, exposure,
                                 psf_sigma_px))


@dataclass(frozen=True)
class CameraMtf:
    """The camera model's MTF at one frequency, factor by factor (all moduli, in [0, 1]).

    Attributes
    ----------
    f : float
        Cycles per pitch.
    aperture, smear, optics, stages : float
        ``|sinc(f q/p)|``, ``|sinc(f v x)|``, the PSF factor and ``|D_M(f Delta)|``.
    system : float
        Their product, the MTF.
    reversed : bool
        True when the transfer is negative: contrast reversal (an odd number of negative
        factors).
    m_delta : float
        Total misregistration over the stages, ``M Delta`` pitches.
    skew_px : float
        The rolling-shutter part of it, ``M e`` pitches (0 for a global shutter).
    exposure : float
        Integration time over the line period used.
    """

    f: float
    aperture: float
    smear: float
    optics: float
    stages: float
    system: float
    reversed: bool
    m_delta: float
    skew_px: float
    exposure: float


def camera_mtf_terms(f, stages, dv_over_v=0.0, skew=0.0, q_over_p=1.0, exposure=1.0,
                     psf_sigma_px=0.0) -> CameraMtf:
    """:func:`camera_mtf` at one frequency (scalars), factor by factor, with reversal.

    This is the function a report calls to print the planned MTF (``tdicam plan`` does).
    """
    h = float(transfer_along(f, stages, dv_over_v, skew, q_over_p, exposure, psf_sigma_px))
    f = float(f)
    m = int(stages)
    v = 1.0 - float(dv_over_v)
    lag = float(stage_lag(dv_over_v, skew))
    d = float(dirichlet(f * lag, m))
    return CameraMtf(
        f=f, aperture=float(abs(np.sinc(f * q_over_p))),
        smear=float(abs(np.sinc(f * v * exposure))),
        optics=float(np.exp(-2.0 * np.pi ** 2 * psf_sigma_px ** 2 * f * f)),
        stages=abs(d), system=abs(h), reversed=h < 0, m_delta=m * lag,
        skew_px=m * float(skew), exposure=float(exposure))


# --------------------------------------------------------------------------------------
# the paper's model: Yuan et al. 2013, eqs 2-8
# --------------------------------------------------------------------------------------


def _out(h, signed):
    return h if signed else np.abs(h)


def mtf_aperture(f, q_over_p=1.0, *, signed=False):
    """Detector-aperture MTF (Yuan et al. 2013 eq 3): ``|sinc(f q/p)|``.

    At Nyquist and a full aperture (q = p) it is ``2/pi = 0.637``.

    Parameters
    ----------
    f : float or array_like
        Spatial frequency, cycles per pitch, >= 0.
    q_over_p : float, optional
        Active width over pitch, in (0, 1] (the square root of an area fill factor).
    signed : bool
        Return the signed transfer instead of the modulus.
    """
    f = real("f", f, lo=0.0)
    k = real("q_over_p", q_over_p, lo=0.0, hi=1.0, lo_open=True)
    return _out(np.sinc(f * k), signed)


def mtf_temporal(f, stages, *, signed=False):
    """Temporal-sampling MTF of M-stage TDI as Yuan et al. 2013 eq 3 writes it: ``|sinc(f M/(M+1))|``.

    The paper takes each exposure as ``T_int/T_L = M/(M+1)`` of a line period; the camera
    model (:func:`camera_mtf`) exposes for the sensor's integration time at the actual image
    speed instead.
    """
    f = real("f", f, lo=0.0)
    m = np.asarray(count("stages", stages, lo=1), dtype=np.float64)
    return _out(np.sinc(f * m / (m + 1.0)), signed)


def mtf_velocity_mismatch(f, stages, dv_over_v, *, signed=False):
    """Velocity-mismatch MTF, Yuan et al. 2013 eq 8: ``|sinc(f M dV/V)|``.

    At Nyquist: ``M dV/V = 1`` gives ``2/pi = 0.637``, ``M dV/V = 2`` gives 0 (the TDI-CCD
    tolerance), ``dV/V = 0`` gives exactly 1. Even in dV/V. The paper's formula is a
    function of ``M dV/V`` and is evaluated for any finite ``dv_over_v`` (curves drawn past a
    scene's own range); the camera model and ``tdicam plan`` accept only (-1, 1).
    """
    f = real("f", f, lo=0.0)
    m = np.asarray(count("stages", stages, lo=1), dtype=np.float64)
    dv = real("dv_over_v", dv_over_v)
    return _out(np.sinc(f * m * dv), signed)


def mtf_system(f, stages, dv_over_v=0.0, q_over_p=1.0, *, signed=False):
    """The paper's model: aperture x temporal x velocity mismatch (Yuan et al. 2013 eq 2).

    Optics and readout-circuit MTFs of eq 2 are taken as 1. A modulus unless ``signed``.
    """
    h = (mtf_aperture(f, q_over_p, signed=True) * mtf_temporal(f, stages, signed=True)
         * mtf_velocity_mismatch(f, stages, dv_over_v, signed=True))
    return _out(h, signed)
