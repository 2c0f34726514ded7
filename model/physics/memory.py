"""Line-buffer memory of the TDI accumulator and the DDR bandwidth of spilled partial sums.

Qu et al. 2010 (Qu Hongsong, Zhang Ye, Jin Guang, "Improving the function of area-array CMOS image
sensors with a digital-domain TDI algorithm", Optics and Precision Engineering 18(8), 2010)
section 3.2 for the basic and optimized accumulator structures; Ning et al. 2019 (Ning Yonghui et
al., "Design of a large-array high-frame-rate CMOS imaging electronics system", Optics and
Precision Engineering 27(5), 2019) section 4.2 for the DDR3 MIG user interface. The partial-
sum width and the line counts are the golden model's own (:func:`tdicam.model.tdi.full_bits`,
:func:`tdicam.model.tdi.basic_line_buffers`, :func:`tdicam.model.tdi.optimized_line_buffers`);
this module checks the arguments and adds the bit and bandwidth arithmetic. Memory sizes are
exact Python integers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError

from tdicam.model import tdi as _tdi
from tdicam.model._args import count, real

__all__ = [
    "DDR_WORD_BITS",
    "DDR_USER_CLOCK_HZ",
    "DDR_EFFICIENCY",
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
]

#: DDR3 MIG user-interface data width of Ning et al. 2019 (bits per word).
DDR_WORD_BITS = 256
#: MIG user-interface clock of Ning et al. 2019 (100 MHz).
DDR_USER_CLOCK_HZ = 100e6
#: Interface efficiency Ning et al. 2019 reached (> 80 %).
DDR_EFFICIENCY = 0.8

_STRUCTURES = ("optimized", "basic")


def _structure(structure):
    if structure not in _STRUCTURES:
        raise TdicamError(f"structure = {structure!r} is not valid; valid: "
                          + ", ".join(_STRUCTURES))
    return structure


# --------------------------------------------------------------------------------------
# line-buffer memory and DDR bandwidth (Qu et al. 2010 section 3.2, Ning et al. 2019 section 4.2)
# --------------------------------------------------------------------------------------


def tdi_line_buffer_lines(stages, structure="optimized"):
    """Line buffers a TDI accumulator of ``stages`` stages needs, Qu et al. 2010 section 3.2.

    The basic structure (Qu et al. 2010 Fig. 7) delays row k by ``m - k`` lines before one adder:
    ``m (m - 1) / 2`` lines of raw pixels. The optimized structure (Fig. 8; Yuan et al. 2013 Table 2)
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
    m = count("stages", stages, lo=1)
    if _structure(structure) == "basic":
        return _tdi.basic_line_buffers(m)
    return _tdi.optimized_line_buffers(m)


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
    m = count("stages", stages, lo=1)
    return _tdi.basic_line_buffers(m) - _tdi.optimized_line_buffers(m)


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
    b = count("pixel_bits", pixel_bits, lo=1, hi=64)
    m = count("stages", stages, lo=1)
    return _tdi.full_bits(b, m)


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
    w = count("width", width, lo=1)
    lines = tdi_line_buffer_lines(stages, structure)
    if structure == "basic":
        return lines * w * count("pixel_bits", pixel_bits, lo=1, hi=64)
    return lines * w * partial_sum_bits(pixel_bits, stages)


def _ddr_line_bits(width, sum_bits, word_bits):
    per_word = word_bits // sum_bits
    if per_word < 1:
        raise TdicamError(f"word_bits = {word_bits} is out of range; valid: {sum_bits}..inf "
                          "(one partial sum per DDR word)")
    return -(-width // per_word) * word_bits


def ddr_bandwidth_needed(width, stages, pixel_bits, line_period_s, *, word_bits=DDR_WORD_BITS):
    """DDR bandwidth when the ``m - 1`` partial-sum lines live in external DDR.

    Every line period the optimized accumulator reads the ``m - 1`` stored partial sums,
    adds the new window, and writes ``m - 1`` updated sums back (the oldest leaves as the
    output line, the newest is the window's last row): ``2 (m - 1)`` lines per line period,
    reads and writes sharing one interface. Sums are packed whole into interface words,
    ``floor(word_bits / partial_sum_bits)`` per word (like Ning et al. 2019 Table 2, which packs 24
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
    w = count("width", width, lo=1)
    m = count("stages", stages, lo=1)
    wb = count("word_bits", word_bits, lo=1)
    t = real("line_period_s", line_period_s, lo=0.0, lo_open=True)
    line_bits = _ddr_line_bits(w, partial_sum_bits(pixel_bits, m), wb)
    return np.float64(2 * (m - 1) * line_bits) / t


def ddr_bandwidth_available(word_bits=DDR_WORD_BITS, user_clock_hz=DDR_USER_CLOCK_HZ,
                            efficiency=DDR_EFFICIENCY):
    """Sustained bandwidth of a MIG-style DDR user interface: ``word_bits * f * efficiency``.

    Ning et al. 2019: a 256-bit user interface at 100 MHz reached > 80 % efficiency (20.48 Gbit/s,
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
    wb = count("word_bits", word_bits, lo=1)
    f = real("user_clock_hz", user_clock_hz, lo=0.0, lo_open=True)
    eff = real("efficiency", efficiency, lo=0.0, hi=1.0, lo_open=True)
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
        partial sums go to DDR (``tdicam.hdl.tdi_ddr.TdiDdr``), :attr:`TdiMemory.ddr_ok`
        whether the interface sustains them.

    Returns
    -------
    TdiMemory
    """
    if onchip_budget_bits is None and device is not None:
        onchip_budget_bits = onchip_budget(device)
    budget = None if onchip_budget_bits is None else count(
        "onchip_budget_bits", onchip_budget_bits, lo=0)
    m = count("stages", stages, lo=1)
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
