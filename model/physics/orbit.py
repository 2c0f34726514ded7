"""Orbit, line rate, frame rate and rolling-shutter timing of a push-broom TDI camera.

Closed-form equations of Qu Hongsong, Zhang Ye, Jin Guang, "Improving the function of
area-array CMOS image sensors with a digital-domain TDI algorithm" (Optics and Precision
Engineering 18(8), 2010; "Qu et al. 2010" below) and Tao Shuping et al., "Design and analysis of a
digital-domain TDI CMOS camera for high-resolution space imaging" (2012; "Tao et al. 2012"), in
float64 numpy: scalars give numpy scalars, arrays broadcast. SI units unless a name says
otherwise. Bad input raises :class:`~tdicam.errors.TdicamError` naming the parameter and its
valid range (:mod:`tdicam.model._args`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tdicam.model._args import count, real

__all__ = [
    "EARTH_RADIUS_M",
    "EARTH_MU_M3_S2",
    "MAX_ALTITUDE_M",
    "ground_speed",
    "line_period",
    "orbit_line_period",
    "turntable_line_period",
    "required_frame_rate",
    "row_time",
    "row_time_from_frame_rate",
    "RollingTiming",
    "rolling_timing",
]

#: Equatorial Earth radius R of Qu et al. 2010 Table 1 (6378.137 km), in metres.
EARTH_RADIUS_M = 6378137.0
#: Earth's gravitational parameter mu of Qu et al. 2010 Table 1 (3.98600436e5 km^3/s^2), in m^3/s^2.
EARTH_MU_M3_S2 = 3.98600436e14
#: Highest orbit altitude accepted, metres (100,000 km: 2.8 x geostationary; beyond it an
#: Earth-observing push-broom camera makes no sense and the arithmetic is garbage).
MAX_ALTITUDE_M = 1e8


# --------------------------------------------------------------------------------------
# orbit, line rate, frame rate (Qu et al. 2010 eqs 4-9)
# --------------------------------------------------------------------------------------


def ground_speed(altitude_m, *, radius_m=EARTH_RADIUS_M, mu_m3_s2=EARTH_MU_M3_S2):
    """Ground-track (sub-satellite point) speed of a circular orbit, Qu et al. 2010 eq 4.

    ``v_g = R / (R + H) * sqrt(mu / (R + H))``

    Parameters
    ----------
    altitude_m : float or array_like
        Orbit altitude H above the sphere of radius ``radius_m``, metres,
        0..:data:`MAX_ALTITUDE_M`.
    radius_m : float, optional
        Earth radius R, metres, > 0 (default 6378.137 km, Qu et al. 2010 Table 1).
    mu_m3_s2 : float, optional
        Gravitational parameter mu, m^3/s^2, > 0 (default 3.98600436e14).

    Returns
    -------
    numpy.float64 or numpy.ndarray
        Ground-track speed in m/s (6908.0 m/s at 600 km).
    """
    h = real("altitude_m", altitude_m, lo=0, hi=MAX_ALTITUDE_M)
    r = real("radius_m", radius_m, lo=0.0, lo_open=True)
    mu = real("mu_m3_s2", mu_m3_s2, lo=0.0, lo_open=True)
    return r / (r + h) * np.sqrt(mu / (r + h))


def line_period(gsd_m, ground_speed_m_s):
    """Line period that matches image motion to the line rate, Qu et al. 2010 eq 5.

    ``T1 = GSD / v_g``

    Parameters
    ----------
    gsd_m : float or array_like
        Ground sample distance, metres, > 0.
    ground_speed_m_s : float or array_like
        Ground-track speed, m/s, > 0 (a zero velocity has no line period).

    Returns
    -------
    numpy.float64 or numpy.ndarray
        Line period in seconds.
    """
    gsd = real("gsd_m", gsd_m, lo=0.0, lo_open=True)
    v = real("ground_speed_m_s", ground_speed_m_s, lo=0.0, lo_open=True)
    return gsd / v


def orbit_line_period(altitude_m, gsd_m):
    """Line period for a circular orbit: :func:`line_period` of :func:`ground_speed`.

    Parameters
    ----------
    altitude_m : float or array_like
        Orbit altitude, metres, >= 0.
    gsd_m : float or array_like
        Ground sample distance, metres, > 0.

    Returns
    -------
    numpy.float64 or numpy.ndarray
        Line period in seconds (0.14476 ms for 600 km and 1 m).
    """
    return line_period(gsd_m, ground_speed(altitude_m))


def turntable_line_period(pitch_m, angular_speed_rad_s, distance_m):
    """Line period of a turntable push-broom rig, Tao et al. 2012 eq 5.

    ``T_line = a / (omega * l)`` with ``a`` the sensor pixel size, ``omega`` the turntable's
    angular speed and ``l`` the distance between the sensor and the turntable axis (the
    image moves over the focal plane at ``omega * l``; drift angle 0).

    Parameters
    ----------
    pitch_m : float or array_like
        Pixel size a, metres, > 0.
    angular_speed_rad_s : float or array_like
        Angular speed omega, rad/s, > 0.
    distance_m : float or array_like
        Distance l, metres, > 0.

    Returns
    -------
    numpy.float64 or numpy.ndarray
        Line period in seconds.
    """
    a = real("pitch_m", pitch_m, lo=0.0, lo_open=True)
    w = real("angular_speed_rad_s", angular_speed_rad_s, lo=0.0, lo_open=True)
    d = real("distance_m", distance_m, lo=0.0, lo_open=True)
    return a / (w * d)


def required_frame_rate(stages, rows, line_period_s):
    """Full-frame rate a c x r sensor needs to read an m-row window every line period.

    Qu et al. 2010 eqs 6-9: reading ``c*m`` pixels at pixel rate ``F_r = c*r*F_f`` takes
    ``m / (r*F_f)``, which must not exceed ``T1``, so ``F_f >= m / (r * T1)``. (The paper
    prints ``<`` in eq 9; its text and Table 2 mean ``>=``.)

    Parameters
    ----------
    stages : int or array_like of int
        TDI stages m (window rows), 1..rows.
    rows : int
        Sensor rows r, >= 1.
    line_period_s : float or array_like
        Line period T1, seconds, > 0.

    Returns
    -------
    numpy.float64 or numpy.ndarray
        Minimum full-frame rate in frames per second (647.6 for 1 m GSD, 96 stages, r=1024
        at 600 km).
    """
    r = count("rows", rows, lo=1)
    m = count("stages", stages, lo=1, hi=r)
    t1 = real("line_period_s", line_period_s, lo=0.0, lo_open=True)
    return np.asarray(m, dtype=np.float64) / (r * t1)


# --------------------------------------------------------------------------------------
# rolling-shutter timing (Tao et al. 2012 eqs 1-9, 13)
# --------------------------------------------------------------------------------------


def row_time(row_blanking_s, pixels_per_row, pixel_clock_hz):
    """Time to read one row, Tao et al. 2012 eq 4: ``T_row = t_rb + n_pixels / f_s``.

    Parameters
    ----------
    row_blanking_s : float
        Row blanking t_rb, seconds, >= 0 (Tao et al. 2012: typically 3.5 us, used for the
        sensor's column CDS).
    pixels_per_row : int
        Pixels read per row n_pixels (the window width), >= 1.
    pixel_clock_hz : float
        Pixel rate f_s, pixels per second over all output channels together, > 0.

    Returns
    -------
    numpy.float64
        Row time in seconds.
    """
    trb = real("row_blanking_s", row_blanking_s, lo=0.0)
    n = count("pixels_per_row", pixels_per_row, lo=1)
    fs = real("pixel_clock_hz", pixel_clock_hz, lo=0.0, lo_open=True)
    return trb + n / fs


def row_time_from_frame_rate(frame_rate_hz, rows):
    """Row time implied by a datasheet full-frame rate: ``T_row = 1 / (r * F_f)``.

    This is Qu et al. 2010 eq 7 read backwards; with it, :func:`rolling_timing` gives the same
    stage limit as the frame-rate condition of :func:`required_frame_rate`.

    Parameters
    ----------
    frame_rate_hz : float
        Full-frame (all ``rows``) rate, frames per second, > 0.
    rows : int
        Sensor rows r, >= 1.

    Returns
    -------
    numpy.float64
        Row time in seconds.
    """
    f = real("frame_rate_hz", frame_rate_hz, lo=0.0, lo_open=True)
    r = count("rows", rows, lo=1)
    return 1.0 / (r * f)


@dataclass(frozen=True)
class RollingTiming:
    """Rolling-shutter TDI timing of one line period (Tao et al. 2012 eqs 6-9, 13).

    Attributes
    ----------
    line_period_s : float
        TDI line period ``T_line`` set by the image motion.
    row_time_s : float
        Row read time ``T_row``.
    n_lines : int
        Window rows read per line period, ``floor(T_line / T_row)`` (capped at the sensor
        rows when ``rows`` was given; ``capped`` says so).
    back_porch_s : float
        Idle time ``T_back = T_line - n_lines * T_row``; ``0 <= T_back < T_row`` unless
        ``capped``.
    m0 : int
        Largest usable stage count, ``M0 = n_lines`` (eq 13). 0 means the line period is
        shorter than one row time: no TDI is possible.
    capped : bool
        True when the sensor has fewer rows than would fit in the line period.
    """

    line_period_s: float
    row_time_s: float
    n_lines: int
    back_porch_s: float
    m0: int
    capped: bool

    @property
    def available_frame_rate_hz(self) -> float:
        """Frame rate of ``n_lines`` rows: ``1 / (n_lines * T_row)`` (inf if n_lines = 0)."""
        return math.inf if self.n_lines == 0 else 1.0 / (self.n_lines * self.row_time_s)


def rolling_timing(line_period_s, row_time_s, rows=None):
    """Window rows, back-porch time and largest stage count for one line period.

    Tao et al. 2012 eqs 6-9 and 13: ``n_lines = floor(T_line / T_row)``,
    ``T_back = T_line - n_lines * T_row`` (so ``0 <= T_back < T_row``), ``M0 = n_lines``;
    stages are adjustable at run time in ``[1, M0]``. The floor is taken with a relative
    tolerance of 1e-12 so that an exact multiple (``T_line = 3 * T_row``) gives 3 rows and
    ``T_back = 0`` despite float rounding. The same bound applies to a global-shutter sensor
    read in pipelined mode (integrating while the previous window is read out).

    Parameters
    ----------
    line_period_s : float
        Line period ``T_line``, seconds, > 0.
    row_time_s : float
        Row time ``T_row`` (:func:`row_time`), seconds, > 0.
    rows : int, optional
        Sensor rows, >= 1; when given, the window is capped at ``rows``.

    Returns
    -------
    RollingTiming
    """
    t_line = float(real("line_period_s", line_period_s, lo=0.0, lo_open=True))
    t_row = float(real("row_time_s", row_time_s, lo=0.0, lo_open=True))
    n = int(math.floor(t_line / t_row * (1.0 + 1e-12)))
    capped = False
    if rows is not None:
        r = count("rows", rows, lo=1)
        if n > r:
            n, capped = r, True
    back = max(0.0, t_line - n * t_row)
    return RollingTiming(line_period_s=t_line, row_time_s=t_row, n_lines=n,
                         back_porch_s=back, m0=n, capped=capped)
