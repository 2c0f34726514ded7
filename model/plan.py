"""Planning physics of a digital-TDI push-broom camera (SPEC section 2).

Every function here is a closed-form equation from one of the seed papers, evaluated in
float64 numpy. Scalars in give a numpy scalar out; arrays broadcast (useful for sweeps and
plots). Memory sizes are exact Python integers. Units are SI unless a parameter name says
otherwise (``_m``, ``_s``, ``_hz``, ``_bits``...). Spatial frequencies are in **cycles per
pixel** (``f * p``), so the Nyquist frequency is :data:`NYQUIST` = 0.5 for every pitch.

Bad input (a non-positive GSD, a negative altitude, stages < 1, a zero velocity...) raises
:class:`~tdicam.errors.TdicamError` with a one-line message that names the parameter and its
valid range.

Sources
-------
* seed 000 (Qu 2010): ground-track speed, line period, frame rate, line-buffer structures.
* seed 001 (Yuan 2013): MTF factors and the velocity-mismatch model.
* seed 002 (Ning 2019): DDR3 MIG user interface (256 bit, 100 MHz, > 80 % efficiency).
* seed 003 (Tao 2012): rolling-shutter timing, SNR gain of digital TDI.
* seed 004 (Zhou 2008): charge-domain TDI for comparison.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError

__all__ = [
    "EARTH_RADIUS_M",
    "EARTH_MU_M3_S2",
    "NYQUIST",
    "DDR_WORD_BITS",
    "DDR_USER_CLOCK_HZ",
    "DDR_EFFICIENCY",
    "ground_speed",
    "line_period",
    "orbit_line_period",
    "turntable_line_period",
    "required_frame_rate",
    "row_time",
    "row_time_from_frame_rate",
    "RollingTiming",
    "rolling_timing",
    "tdi_line_buffer_lines",
    "line_buffer_saving_lines",
    "partial_sum_bits",
    "tdi_line_buffer_bits",
    "ddr_bandwidth_needed",
    "ONCHIP_RAM_BITS",
    "onchip_budget",
    "ddr_bandwidth_available",
    "TdiMemory",
    "tdi_memory",
    "quantization_noise",
    "temporal_noise",
    "snr_gain_digital",
    "quantization_correlated_fraction",
    "snr_gain_digital_predicted",
    "snr_gain_charge",
    "gain_db",
    "snr_db",
    "mtf_aperture",
    "mtf_temporal",
    "mtf_velocity_mismatch",
    "mtf_system",
]

#: Equatorial Earth radius R of seed 000 Table 1 (6378.137 km), in metres.
EARTH_RADIUS_M = 6378137.0
#: Earth's gravitational parameter mu of seed 000 Table 1 (3.98600436e5 km^3/s^2), in m^3/s^2.
EARTH_MU_M3_S2 = 3.98600436e14
#: Nyquist frequency in cycles per pixel, ``1/(2p)`` times the pitch ``p``.
NYQUIST = 0.5
#: DDR3 MIG user-interface data width of seed 002 (bits per word).
DDR_WORD_BITS = 256
#: MIG user-interface clock of seed 002 (100 MHz).
DDR_USER_CLOCK_HZ = 100e6
#: Interface efficiency seed 002 reached (> 80 %).
DDR_EFFICIENCY = 0.8

_STRUCTURES = ("optimized", "basic")


# --------------------------------------------------------------------------------------
# input checking
# --------------------------------------------------------------------------------------


def _fmt(value) -> str:
    if isinstance(value, (float, np.floating)) and float(value).is_integer():
        return str(int(value)) if abs(value) < 1e16 else repr(float(value))
    if isinstance(value, (np.generic,)):
        return repr(value.item())
    return repr(value) if isinstance(value, str) else str(value)


def _real(name, value, *, lo=None, hi=None, lo_open=False, hi_open=False):
    """Return ``value`` as float64 (scalar or array) after a range check on every element."""
    if isinstance(value, (bool, np.bool_)):
        raise TdicamError(f"{name} must be a number, got {value!r}")
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TdicamError(f"{name} must be a number, got {value!r}") from None
    if arr.size == 0:
        raise TdicamError(f"{name} must not be empty")
    bad = ~np.isfinite(arr)
    if lo is not None:
        bad |= (arr <= lo) if lo_open else (arr < lo)
    if hi is not None:
        bad |= (arr >= hi) if hi_open else (arr > hi)
    if np.any(bad):
        first = arr[bad].flat[0] if arr.ndim else arr.item()
        raise TdicamError(f"{name} = {_fmt(float(first))} is out of range; valid: "
                          f"{_range_text(lo, hi, lo_open, hi_open)}")
    return arr[()] if arr.ndim == 0 else arr


def _range_text(lo, hi, lo_open, hi_open) -> str:
    if lo is not None and hi is not None:
        return (f"{'(' if lo_open else '['}{_fmt(lo)}, {_fmt(hi)}{')' if hi_open else ']'}")
    if lo is not None:
        return f"{'>' if lo_open else '>='} {_fmt(lo)}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {_fmt(hi)}"
    return "any finite number"


def _count(name, value, *, lo=1, hi=None):
    """Return an integer count (Python int, or an int64 array) checked against ``lo..hi``."""
    if isinstance(value, (bool, np.bool_)):
        raise TdicamError(f"{name} must be an integer, got {value!r}")
    arr = np.asarray(value)
    if arr.size == 0:
        raise TdicamError(f"{name} must not be empty")
    if arr.dtype.kind not in "iu":
        try:
            farr = arr.astype(np.float64)
        except (TypeError, ValueError):
            raise TdicamError(f"{name} must be an integer, got {value!r}") from None
        if not np.all(np.isfinite(farr)) or np.any(farr != np.round(farr)):
            raise TdicamError(f"{name} must be an integer, got {value!r}")
        arr = farr.astype(np.int64)
    bad = arr < lo
    if hi is not None:
        bad |= arr > hi
    if np.any(bad):
        first = int(arr[bad].flat[0]) if arr.ndim else int(arr)
        hi_s = "inf" if hi is None else hi
        raise TdicamError(f"{name} = {first} is out of range; valid: {lo}..{hi_s}")
    return int(arr) if arr.ndim == 0 else arr.astype(np.int64)


def _structure(structure):
    if structure not in _STRUCTURES:
        raise TdicamError(f"structure = {structure!r} is not valid; valid: "
                          + ", ".join(_STRUCTURES))
    return structure


# --------------------------------------------------------------------------------------
# orbit, line rate, frame rate (seed 000 eqs 4-9)
# --------------------------------------------------------------------------------------


def ground_speed(altitude_m, *, radius_m=EARTH_RADIUS_M, mu_m3_s2=EARTH_MU_M3_S2):
    """Ground-track (sub-satellite point) speed of a circular orbit, seed 000 eq 4.

    ``v_g = R / (R + H) * sqrt(mu / (R + H))``

    Parameters
    ----------
    altitude_m : float or array_like
        Orbit altitude H above the sphere of radius ``radius_m``, metres, >= 0.
    radius_m : float, optional
        Earth radius R, metres, > 0 (default 6378.137 km, seed 000 Table 1).
    mu_m3_s2 : float, optional
        Gravitational parameter mu, m^3/s^2, > 0 (default 3.98600436e14).

    Returns
    -------
    numpy.float64 or numpy.ndarray
        Ground-track speed in m/s (6908.0 m/s at 600 km).
    """
    h = _real("altitude_m", altitude_m, lo=0.0)
    r = _real("radius_m", radius_m, lo=0.0, lo_open=True)
    mu = _real("mu_m3_s2", mu_m3_s2, lo=0.0, lo_open=True)
    return r / (r + h) * np.sqrt(mu / (r + h))


def line_period(gsd_m, ground_speed_m_s):
    """Line period that matches image motion to the line rate, seed 000 eq 5.

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
    gsd = _real("gsd_m", gsd_m, lo=0.0, lo_open=True)
    v = _real("ground_speed_m_s", ground_speed_m_s, lo=0.0, lo_open=True)
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
    """Line period of a turntable push-broom rig, seed 003 eq 5.

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
    a = _real("pitch_m", pitch_m, lo=0.0, lo_open=True)
    w = _real("angular_speed_rad_s", angular_speed_rad_s, lo=0.0, lo_open=True)
    d = _real("distance_m", distance_m, lo=0.0, lo_open=True)
    return a / (w * d)


def required_frame_rate(stages, rows, line_period_s):
    """Full-frame rate a c x r sensor needs to read an m-row window every line period.

    Seed 000 eqs 6-9: reading ``c*m`` pixels at pixel rate ``F_r = c*r*F_f`` takes
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
    r = _count("rows", rows, lo=1)
    m = _count("stages", stages, lo=1, hi=r)
    t1 = _real("line_period_s", line_period_s, lo=0.0, lo_open=True)
    return np.asarray(m, dtype=np.float64) / (r * t1)


# --------------------------------------------------------------------------------------
# rolling-shutter timing (seed 003 eqs 1-9, 13)
# --------------------------------------------------------------------------------------


def row_time(row_blanking_s, pixels_per_row, pixel_clock_hz):
    """Time to read one row, seed 003 eq 4: ``T_row = t_rb + n_pixels / f_s``.

    Parameters
    ----------
    row_blanking_s : float
        Row blanking t_rb, seconds, >= 0 (seed 003: typically 3.5 us, used for the
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
    trb = _real("row_blanking_s", row_blanking_s, lo=0.0)
    n = _count("pixels_per_row", pixels_per_row, lo=1)
    fs = _real("pixel_clock_hz", pixel_clock_hz, lo=0.0, lo_open=True)
    return trb + n / fs


def row_time_from_frame_rate(frame_rate_hz, rows):
    """Row time implied by a datasheet full-frame rate: ``T_row = 1 / (r * F_f)``.

    This is seed 000 eq 7 read backwards; with it, :func:`rolling_timing` gives the same
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
    f = _real("frame_rate_hz", frame_rate_hz, lo=0.0, lo_open=True)
    r = _count("rows", rows, lo=1)
    return 1.0 / (r * f)


@dataclass(frozen=True)
class RollingTiming:
    """Rolling-shutter TDI timing of one line period (seed 003 eqs 6-9, 13).

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

    Seed 003 eqs 6-9 and 13: ``n_lines = floor(T_line / T_row)``,
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
    t_line = float(_real("line_period_s", line_period_s, lo=0.0, lo_open=True))
    t_row = float(_real("row_time_s", row_time_s, lo=0.0, lo_open=True))
    n = int(math.floor(t_line / t_row * (1.0 + 1e-12)))
    capped = False
    if rows is not None:
        r = _count("rows", rows, lo=1)
        if n > r:
            n, capped = r, True
    back = max(0.0, t_line - n * t_row)
    return RollingTiming(line_period_s=t_line, row_time_s=t_row, n_lines=n,
                         back_porch_s=back, m0=n, capped=capped)


# --------------------------------------------------------------------------------------
# line-buffer memory and DDR bandwidth (seed 000 section 3.2, seed 002 section 4.2)
# --------------------------------------------------------------------------------------


def tdi_line_buffer_lines(stages, structure="optimized"):
    """Line buffers a TDI accumulator of ``stages`` stages needs, seed 000 section 3.2.

    The basic structure (seed 000 Fig. 7) delays row k by ``m - k`` lines before one adder:
    ``m (m - 1) / 2`` lines of raw pixels. The optimized structure (Fig. 8; seed 001 Table 2)
    keeps ``m - 1`` running partial sums.

    Parameters
    ----------
    stages : int
        TDI stages m, >= 1.
    structure : {"optimized", "basic"}
        Accumulator structure.

    Returns
    -------
    int
        Number of W-pixel lines.
    """
    m = _count("stages", stages, lo=1)
    if _structure(structure) == "basic":
        return m * (m - 1) // 2
    return m - 1


def line_buffer_saving_lines(stages):
    """Lines the optimized structure saves over the basic one: ``(m - 1)(m - 2) / 2``.

    Parameters
    ----------
    stages : int
        TDI stages m, >= 1.

    Returns
    -------
    int
        ``tdi_line_buffer_lines(m, "basic") - tdi_line_buffer_lines(m, "optimized")``.
    """
    m = _count("stages", stages, lo=1)
    return (m - 1) * (m - 2) // 2


def partial_sum_bits(pixel_bits, stages):
    """Bit width of a TDI sum that can never wrap: ``pixel_bits + ceil(log2(m))``.

    Computed exactly in integers (``(m - 1).bit_length()`` is ``ceil(log2 m)``): 12-bit
    pixels and 96 stages need 19 bits; one stage needs no extra bit.

    Parameters
    ----------
    pixel_bits : int
        Bits per pixel, 1..64.
    stages : int
        TDI stages m (or the largest stage count the hardware supports), >= 1.

    Returns
    -------
    int
    """
    b = _count("pixel_bits", pixel_bits, lo=1, hi=64)
    m = _count("stages", stages, lo=1)
    return b + (m - 1).bit_length()


def tdi_line_buffer_bits(width, stages, pixel_bits, structure="optimized"):
    """On-chip bits of the TDI line buffers.

    * ``"basic"``: ``m (m - 1) / 2`` delay lines of raw ``pixel_bits`` pixels.
    * ``"optimized"``: ``m - 1`` partial-sum lines of :func:`partial_sum_bits` each (one
      uniform width, as the hardware stores them).

    In lines the optimized structure is never larger. In bits it is not larger exactly when
    ``ceil(log2 m) <= pixel_bits (m/2 - 1)``: always for ``m >= 3`` and pixels of 4 bits or
    more, never for ``m = 2`` (one partial-sum line is one bit wider than one delay line).

    Parameters
    ----------
    width : int
        Pixels per line W, >= 1.
    stages : int
        TDI stages m, >= 1.
    pixel_bits : int
        Bits per pixel, 1..64.
    structure : {"optimized", "basic"}

    Returns
    -------
    int
        Total bits.
    """
    w = _count("width", width, lo=1)
    lines = tdi_line_buffer_lines(stages, structure)
    if structure == "basic":
        return lines * w * _count("pixel_bits", pixel_bits, lo=1, hi=64)
    return lines * w * partial_sum_bits(pixel_bits, stages)


def _ddr_line_bits(width, sum_bits, word_bits):
    per_word = word_bits // sum_bits
    if per_word < 1:
        raise TdicamError(f"word_bits = {word_bits} is out of range; valid: >= {sum_bits} "
                          "(one partial sum per DDR word)")
    return -(-width // per_word) * word_bits


def ddr_bandwidth_needed(width, stages, pixel_bits, line_period_s, *, word_bits=DDR_WORD_BITS):
    """DDR bandwidth when the ``m - 1`` partial-sum lines live in external DDR.

    Every line period the optimized accumulator reads the ``m - 1`` stored partial sums,
    adds the new window, and writes ``m - 1`` updated sums back (the oldest leaves as the
    output line, the newest is the window's last row): ``2 (m - 1)`` lines per line period,
    reads and writes sharing one interface. Sums are packed whole into interface words,
    ``floor(word_bits / partial_sum_bits)`` per word (like seed 002 Table 2, which packs 24
    10-bit pixels per 256-bit word), and each line starts on a new word.

    Parameters
    ----------
    width : int
        Pixels per line W, >= 1.
    stages : int
        TDI stages m, >= 1 (m = 1 needs no DDR traffic).
    pixel_bits : int
        Bits per pixel, 1..64.
    line_period_s : float
        Line period, seconds, > 0.
    word_bits : int, optional
        Interface data width, >= the partial-sum width (default 256, the MIG UI).

    Returns
    -------
    numpy.float64
        Bits per second over the interface.
    """
    w = _count("width", width, lo=1)
    m = _count("stages", stages, lo=1)
    wb = _count("word_bits", word_bits, lo=1)
    t = _real("line_period_s", line_period_s, lo=0.0, lo_open=True)
    line_bits = _ddr_line_bits(w, partial_sum_bits(pixel_bits, m), wb)
    return np.float64(2 * (m - 1) * line_bits) / t


def ddr_bandwidth_available(word_bits=DDR_WORD_BITS, user_clock_hz=DDR_USER_CLOCK_HZ,
                            efficiency=DDR_EFFICIENCY):
    """Sustained bandwidth of a MIG-style DDR user interface: ``word_bits * f * efficiency``.

    Seed 002: a 256-bit user interface at 100 MHz reached > 80 % efficiency (20.48 Gbit/s,
    shared between reads and writes).

    Parameters
    ----------
    word_bits : int, optional
        User-interface data width, >= 1 (default 256).
    user_clock_hz : float, optional
        User-interface clock, Hz, > 0 (default 100 MHz).
    efficiency : float, optional
        Fraction of clock cycles that move data, in (0, 1] (default 0.8).

    Returns
    -------
    numpy.float64
        Bits per second.
    """
    wb = _count("word_bits", word_bits, lo=1)
    f = _real("user_clock_hz", user_clock_hz, lo=0.0, lo_open=True)
    eff = _real("efficiency", efficiency, lo=0.0, hi=1.0, lo_open=True)
    return wb * f * eff


#: Block RAM of FPGA parts, bits (the whole device: the partial sums may use all of it at
#: most). ECP5: 18 kbit EBRs (25F: 56, 45F: 108, 85F: 208); 7-series: 36 kbit blocks
#: (XC7A35T: 50, XC7A100T: 135, XC7A200T: 365, XC7K325T: 445).
ONCHIP_RAM_BITS = {
    "ecp5-25f": 56 * 18 * 1024,
    "ecp5-45f": 108 * 18 * 1024,
    "ecp5-85f": 208 * 18 * 1024,
    "xc7a35t": 50 * 36 * 1024,
    "xc7a100t": 135 * 36 * 1024,
    "xc7a200t": 365 * 36 * 1024,
    "xc7k325t": 445 * 36 * 1024,
}


def onchip_budget(device):
    """On-chip RAM bits of ``device`` (a key of :data:`ONCHIP_RAM_BITS`, case-insensitive)."""
    key = str(device).lower()
    if key not in ONCHIP_RAM_BITS:
        raise TdicamError(f"device = {device!r} is not known; valid: "
                          f"{', '.join(ONCHIP_RAM_BITS)}")
    return ONCHIP_RAM_BITS[key]


@dataclass(frozen=True)
class TdiMemory:
    """Memory and bandwidth summary of one TDI configuration (see :func:`tdi_memory`).

    Attributes
    ----------
    width, stages, pixel_bits : int
        The configuration.
    sum_bits : int
        Partial-sum width, :func:`partial_sum_bits`.
    basic_lines, optimized_lines, saving_lines : int
        Line buffers of each structure and the difference ``(m-1)(m-2)/2``.
    basic_bits, optimized_bits : int
        Bits of each structure, :func:`tdi_line_buffer_bits`.
    onchip_budget_bits : int or None
        On-chip memory available for the partial sums, if known.
    fits_onchip : bool or None
        ``optimized_bits <= onchip_budget_bits`` (None without a budget).
    ddr_needed_bps, ddr_available_bps : float
        :func:`ddr_bandwidth_needed` and :func:`ddr_bandwidth_available`.
    """

    width: int
    stages: int
    pixel_bits: int
    sum_bits: int
    basic_lines: int
    optimized_lines: int
    saving_lines: int
    basic_bits: int
    optimized_bits: int
    onchip_budget_bits: int | None
    fits_onchip: bool | None
    ddr_needed_bps: float
    ddr_available_bps: float
    device: str | None = None

    @property
    def must_spill(self) -> bool:
        """True when the optimized structure's partial sums exceed the on-chip budget, so
        they have to live in DDR (False without a budget)."""
        return self.fits_onchip is False

    @property
    def saving_bits(self) -> int:
        """``basic_bits - optimized_bits`` (negative for m = 2 and for very narrow pixels)."""
        return self.basic_bits - self.optimized_bits

    @property
    def ddr_ok(self) -> bool:
        """True when the DDR interface sustains the partial-sum traffic."""
        return self.ddr_needed_bps <= self.ddr_available_bps


def tdi_memory(width, stages, pixel_bits, line_period_s, *, onchip_budget_bits=None,
               word_bits=DDR_WORD_BITS, user_clock_hz=DDR_USER_CLOCK_HZ,
               efficiency=DDR_EFFICIENCY, device=None):
    """Line-buffer memory of both structures, on-chip fit and DDR bandwidth in one call.

    Parameters
    ----------
    width : int
        Pixels per line W, >= 1.
    stages : int
        TDI stages m, >= 1.
    pixel_bits : int
        Bits per pixel, 1..64.
    line_period_s : float
        Line period, seconds, > 0.
    onchip_budget_bits : int, optional
        On-chip RAM bits available for the partial sums, >= 0.
    word_bits, user_clock_hz, efficiency
        DDR interface, see :func:`ddr_bandwidth_available`.
    device : str, optional
        FPGA part (:data:`ONCHIP_RAM_BITS`): its block RAM is the budget when
        ``onchip_budget_bits`` is not given. :attr:`TdiMemory.must_spill` says whether the
        partial sums go to DDR (``tdicam.hdl.ddr.TdiDdr``), :attr:`TdiMemory.ddr_ok`
        whether the interface sustains them.

    Returns
    -------
    TdiMemory
    """
    if onchip_budget_bits is None and device is not None:
        onchip_budget_bits = onchip_budget(device)
    budget = None if onchip_budget_bits is None else _count(
        "onchip_budget_bits", onchip_budget_bits, lo=0)
    m = _count("stages", stages, lo=1)
    opt_bits = tdi_line_buffer_bits(width, m, pixel_bits, "optimized")
    return TdiMemory(
        width=int(width), stages=m, pixel_bits=int(pixel_bits),
        sum_bits=partial_sum_bits(pixel_bits, m),
        basic_lines=tdi_line_buffer_lines(m, "basic"),
        optimized_lines=tdi_line_buffer_lines(m, "optimized"),
        saving_lines=line_buffer_saving_lines(m),
        basic_bits=tdi_line_buffer_bits(width, m, pixel_bits, "basic"),
        optimized_bits=opt_bits,
        onchip_budget_bits=budget,
        fits_onchip=None if budget is None else opt_bits <= budget,
        ddr_needed_bps=float(ddr_bandwidth_needed(width, m, pixel_bits, line_period_s,
                                                  word_bits=word_bits)),
        ddr_available_bps=float(ddr_bandwidth_available(word_bits, user_clock_hz, efficiency)),
        device=None if device is None else str(device).lower(),
    )


# --------------------------------------------------------------------------------------
# SNR (seed 003 eqs 14-29; seed 004 for charge-domain TDI)
# --------------------------------------------------------------------------------------


def quantization_noise(e_per_dn):
    """RMS quantization noise of one conversion: ``q / sqrt(12)`` for a step of q.

    Seed 003 eq 14 writes the quantization term with the full well over ``2**N`` levels;
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
    return _real("e_per_dn", e_per_dn, lo=0.0) / np.sqrt(12.0)


def temporal_noise(signal_e, read_noise_e=0.0, dark_e=0.0):
    """Temporal noise of one exposure in electrons: ``sqrt(S + D + read**2)``.

    Photon shot noise of the signal ``S``, shot noise of the dark charge ``D`` and read noise
    add in quadrature (seed 003 eq 25, expressed in electrons). This is ``sigma_CMOS``.

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
    s = _real("signal_e", signal_e, lo=0.0)
    r = _real("read_noise_e", read_noise_e, lo=0.0)
    d = _real("dark_e", dark_e, lo=0.0)
    return np.sqrt(s + d + r * r)


def snr_gain_digital(stages, sigma_ad, sigma_cmos):
    """Linear SNR gain of m-stage digital TDI over one exposure, seed 003 eq 28.

    ``G(m) = m (s_AD + s_CMOS) / (m s_AD + sqrt(m) s_CMOS)``: the signal grows as m, the
    temporal noise ``s_CMOS`` as ``sqrt(m)`` and, because every exposure is quantized, the
    quantization noise ``s_AD`` as m (seed 003 eq 27 adds the two standard deviations
    linearly; this follows the paper). ``G(1) = 1`` exactly; ``G -> sqrt(m)`` when
    ``s_AD = 0``; ``G -> 1`` when quantization dominates. In decibels the gain is
    ``20 log10 G`` *added* to the single-exposure SNR (see SPEC section 2 on eq 28).

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
    m = np.asarray(_count("stages", stages, lo=1), dtype=np.float64)
    a = _real("sigma_ad", sigma_ad, lo=0.0)
    c = _real("sigma_cmos", sigma_cmos, lo=0.0)
    if np.any(a + c <= 0):
        raise TdicamError("sigma_ad + sigma_cmos = 0 is out of range; valid: > 0 "
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
    ``rho = (6 / pi^2) sum_k exp(-4 pi^2 k^2 s^2) / k^2``: 1 without noise (seed 003 eq 28's
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
    s = np.asarray(_real("sigma_dn", sigma_dn, lo=0.0), np.float64)
    k = np.arange(1, 257, dtype=np.float64).reshape((-1,) + (1,) * s.ndim)
    c = 4.0 * np.pi ** 2 * (s * s)
    # terms k <= 256, then the tail as an integral from 256.5 (error O(256^-3))
    tail = np.exp(-c * 256.5 ** 2) / 256.5
    rho = (6.0 / np.pi ** 2) * (np.sum(np.exp(-c * k * k) / (k * k), axis=0) + tail)
    return np.clip(rho, 0.0, 1.0)[()]


def snr_gain_digital_predicted(stages, sigma_ad, sigma_cmos, correlated=0.0):
    """Linear SNR gain of m-stage digital TDI with quantization split as it really adds.

    ``G(m) = m sqrt(a^2 + c^2) / sqrt(m (c^2 + (1 - rho) a^2) + m^2 rho a^2)``: the temporal
    (and row-to-row fixed-pattern) noise ``c`` and the independent part ``(1 - rho) a^2`` of
    the quantization variance grow as ``sqrt(m)``; only the shared part ``rho a^2``
    (:func:`quantization_correlated_fraction`) grows as m. ``rho = 0`` gives ``sqrt(m)``;
    ``rho = 1`` with ``c = 0`` gives 1, the limit of seed 003 eq 28
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
    rho = _real("correlated", correlated, lo=0.0, hi=1.0)
    a2, c2 = a * a, c * c
    return m * np.sqrt(a2 + c2) / np.sqrt(m * (c2 + (1.0 - rho) * a2) + m * m * rho * a2)


def snr_gain_charge(stages, sigma_ad, sigma_shot, sigma_read=0.0):
    """Linear SNR gain of m-stage charge-domain TDI (TDI-CCD, seed 004) for comparison.

    Charge is summed before one readout and one conversion, so read noise and quantization
    are added once while shot noise grows as ``sqrt(m)``. Using the same convention as
    :func:`snr_gain_digital` (quantization added linearly to the temporal noise):

    ``G_c(m) = m (s_AD + sqrt(s_shot**2 + s_read**2)) / (s_AD + sqrt(m s_shot**2 + s_read**2))``

    A read-noise-limited scene gains m (4 stages: +12.0 dB; seed 004 measured 22.13 ->
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
    m = np.asarray(_count("stages", stages, lo=1), dtype=np.float64)
    a = _real("sigma_ad", sigma_ad, lo=0.0)
    s = _real("sigma_shot", sigma_shot, lo=0.0)
    r = _real("sigma_read", sigma_read, lo=0.0)
    if np.any(a + s + r <= 0):
        raise TdicamError("sigma_ad + sigma_shot + sigma_read = 0 is out of range; valid: > 0 "
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
    return 20.0 * np.log10(_real("gain", gain, lo=0.0, lo_open=True))


def snr_db(signal, sigma_ad, sigma_cmos, stages=1):
    """SNR in dB of m-stage digital TDI, seed 003 eqs 28-29.

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
    s = _real("signal", signal, lo=0.0, lo_open=True)
    g = snr_gain_digital(stages, sigma_ad, sigma_cmos)
    return 20.0 * np.log10(s / (sigma_ad + sigma_cmos)) + gain_db(g)


# --------------------------------------------------------------------------------------
# MTF (seed 001 eqs 2-8); f in cycles per pixel, Nyquist = 0.5
# --------------------------------------------------------------------------------------


def mtf_aperture(f, q_over_p=1.0):
    """Detector-aperture MTF, seed 001 eq 3: ``sinc(f q)``.

    With f in cycles per pixel this is ``sinc(f * q/p)``; at Nyquist and a full aperture
    (q = p) it is ``2/pi = 0.637``. ``sinc(x) = sin(pi x)/(pi x)`` (``numpy.sinc``).

    Parameters
    ----------
    f : float or array_like
        Spatial frequency, cycles per pixel, >= 0.
    q_over_p : float, optional
        Active width over pitch, in (0, 1] (the square root of an area fill factor for a
        square active area).

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    f = _real("f", f, lo=0.0)
    k = _real("q_over_p", q_over_p, lo=0.0, hi=1.0, lo_open=True)
    return np.sinc(f * k)


def mtf_temporal(f, stages):
    """Temporal-sampling (discrete-time) MTF of M-stage TDI, seed 001 eq 3.

    ``sinc(f p T_int/T_L)`` with ``T_int/T_L = M/(M+1)`` (seed 001's ratio of integration
    time to transit time), f in cycles per pixel.

    Parameters
    ----------
    f : float or array_like
        Spatial frequency, cycles per pixel, >= 0.
    stages : int or array_like of int
        TDI stages M, >= 1.

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    f = _real("f", f, lo=0.0)
    m = np.asarray(_count("stages", stages, lo=1), dtype=np.float64)
    return np.sinc(f * m / (m + 1.0))


def mtf_velocity_mismatch(f, stages, dv_over_v):
    """Velocity-mismatch MTF, seed 001 eq 8: ``sinc(f p M dV/V)``.

    A relative mismatch dV/V smears each ground line over ``M dV/V`` pixels (seed 001
    eq 7). At Nyquist (f = 0.5 cycles/pixel): ``M dV/V = 1`` gives ``2/pi = 0.637``,
    ``M dV/V = 2`` gives 0 (the TDI-CCD tolerance), and ``dV/V = 0`` gives exactly 1.
    The sign of dV/V does not matter.

    Parameters
    ----------
    f : float or array_like
        Spatial frequency, cycles per pixel, >= 0.
    stages : int or array_like of int
        TDI stages M, >= 1.
    dv_over_v : float or array_like
        Relative velocity mismatch, finite.

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    f = _real("f", f, lo=0.0)
    m = np.asarray(_count("stages", stages, lo=1), dtype=np.float64)
    dv = _real("dv_over_v", dv_over_v)
    return np.sinc(f * m * dv)


def mtf_system(f, stages, dv_over_v=0.0, q_over_p=1.0):
    """Product of the aperture, temporal-sampling and velocity-mismatch MTFs (seed 001 eq 2).

    Optics and readout-circuit MTFs of eq 2 are taken as 1 (not modelled here).

    Parameters
    ----------
    f : float or array_like
        Spatial frequency, cycles per pixel, >= 0.
    stages : int or array_like of int
        TDI stages M, >= 1.
    dv_over_v : float or array_like, optional
        Relative velocity mismatch (default 0).
    q_over_p : float, optional
        Active width over pitch, in (0, 1] (default 1).

    Returns
    -------
    numpy.float64 or numpy.ndarray
    """
    return (mtf_aperture(f, q_over_p) * mtf_temporal(f, stages)
            * mtf_velocity_mismatch(f, stages, dv_over_v))
