"""The configuration check of ``tdi_ddr``, TDI with its partial sums in DDR (the gateware is
:class:`tdicam.hdl.tdi_ddr.TdiDdr`): its output is the on-chip accumulator's
(:func:`tdicam.model.tdi.tdi_stream`), so its golden model is :mod:`tdicam.model.tdi`; what
is its own is whether a configuration can keep its partial sums in DDR."""

from tdicam.errors import TdicamError
from tdicam.model.ddr import WORD_BITS, psums_per_word
from tdicam.model.ddr_efficiency import tdi_spill_efficiency
from tdicam.model.tdi import full_bits

__all__ = ["tdi_ddr_check"]


def tdi_ddr_check(*, width, stages, pixel_bits, ppc, line_period_s=None,
                  clock_hz=100e6, efficiency=None, lookahead=128):
    """Check a TDI configuration for partial sums in DDR; returns a dict of its figures.

    Refuses (one-line :class:`TdicamError`) when a row is shorter than the read look-ahead
    (``width / ppc`` beats must exceed ``lookahead`` + one word: a partial sum is read again
    one row after it is written back), and, with ``line_period_s`` given, when the DDR
    interface cannot move the ``2 (m_max - 1)`` partial-sum lines per line period at
    ``clock_hz * efficiency`` words per second (default efficiency: the planner's figure
    for TdiDdr's access pattern, :func:`tdi_spill_efficiency`), or the clock cannot take
    the ``m_max * width / ppc`` input beats of a line period.
    """
    ps = full_bits(pixel_bits, stages)
    k = psums_per_word(ps, ppc)
    wb = width // ppc
    j = k // ppc
    wpl = -(-wb // j)
    if stages > 1 and wb <= lookahead + j:
        raise TdicamError(f"width = {width} with ppc = {ppc} is {wb} beats per row: DDR "
                          f"partial sums need more than {lookahead + j} (the read look-ahead "
                          f"plus one word); use the on-chip accumulator")
    words = 2 * (stages - 1) * wpl
    info = {"psum_bits": ps, "psums_per_word": k, "words_per_line": wpl,
            "words_per_line_period": words, "beats_per_line_period": stages * wb}
    if line_period_s is not None:
        if efficiency is None:
            info["pattern"], efficiency = tdi_spill_efficiency(width, stages, pixel_bits, ppc)
        info["efficiency"] = efficiency
        avail = line_period_s * clock_hz * efficiency
        if words > avail:
            raise TdicamError(
                f"DDR bandwidth short: {stages - 1} partial-sum lines read and written per "
                f"line period = {words} words ({words * WORD_BITS * 1e-9 / line_period_s:.2f}"
                f" Gbit/s), the interface moves {avail:.0f} words "
                f"({WORD_BITS * clock_hz * efficiency * 1e-9:.2f} Gbit/s at "
                f"{clock_hz / 1e6:g} MHz x {efficiency * 100:.1f} %)")
        cyc = line_period_s * clock_hz
        if stages * wb > cyc:
            raise TdicamError(f"clock too slow: {stages * wb} input beats per line period, "
                              f"{cyc:.0f} cycles at {clock_hz / 1e6:g} MHz")
        info["ddr_load"] = words / avail
    return info
