"""Digital correlated double sampling (Ning et al. 2019 §4.4.1)."""

from amaranth.hdl import Module, Mux
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_choice, check_range
from tdicam.beats import PPC_CHOICES
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import quiet_reject

__all__ = ["Cds"]


class Cds(wiring.Component):
    """Subtract the reset level from the signal level of every pixel, ``ppc`` pixels per clock.

    Parameters
    ----------
    pixel_bits : int
        Width of the signal, reset and output pixels, 8..16.
    ppc : int
        Pixels per clock (per beat): 1, 2, 4 or 8 (default 1).

    Attributes
    ----------
    i_stream : In(pixel stream of ``2 * ppc`` x ``pixel_bits``)
        Pixel-major pairs, as :func:`tdicam.beats.frames_to_beats` ``(ppc=, channels=2)``
        lays them out: ``data[2k]`` is the signal level and ``data[2k + 1]`` the reset level
        of pixel ``k`` of the beat (pixel 0 the leftmost, element 0 in the least significant
        bits: ``p0.signal p0.reset p1.signal p1.reset ...`` from tdata's LSB up).
    o_stream : Out(pixel stream of ``ppc`` x ``pixel_bits``)
        ``data[k] = signal - reset`` of pixel ``k`` when ``signal >= reset``, else 0 (the
        paper's "numerical protection"); ``pixel_bits`` wide, never wraps. ``first``/``last``
        pass through (start of frame on the frame's first beat, end of line on a row's last
        beat); a row is ``width / ppc`` beats.

    Notes
    -----
    One register stage at every ``ppc``: :attr:`latency` = 1 cycle from an accepted input
    beat to the corresponding output beat being valid (ppc 1, 2, 4, 8: 1, 1, 1, 1). Full
    throughput (``ppc`` pixels/clock) while ``o_stream.ready`` is high; ``i_stream.ready``
    is low only when the output register holds a beat that is not being taken, so no beat
    is lost or duplicated whatever ``ready`` does. The frame width is not a parameter: it
    must be a multiple of ``ppc`` (checked where frames become beats, e.g.
    :func:`~tdicam.beats.frames_to_beats`).

    Raises
    ------
    TdicamError
        ``pixel_bits`` out of range or ``ppc`` not one of 1, 2, 4, 8 (one line).
    """

    @quiet_reject
    def __init__(self, *, pixel_bits=12, ppc=1):
        self._pixel_bits = check_range("pixel_bits", pixel_bits, 8, 16)
        self._ppc = check_choice("ppc", ppc, PPC_CHOICES)
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, 2 * ppc))),
            "o_stream": Out(pixel_signature(channels_shape(pixel_bits, ppc))),
        })

    @property
    def pixel_bits(self):
        return self._pixel_bits

    @property
    def ppc(self):
        """Pixels per clock (per beat)."""
        return self._ppc

    @property
    def latency(self):
        """Cycles from an input transfer to the corresponding output being valid: 1 at
        every ``ppc``."""
        return 1

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        diffs = []
        for k in range(self._ppc):
            sig, rst = i.payload.data[2 * k], i.payload.data[2 * k + 1]
            diffs.append(Mux(sig >= rst, sig - rst, 0))
        if self._ppc == 1:
            out = [o.payload.data.eq(diffs[0])]
        else:
            out = [o.payload.data[k].eq(d) for k, d in enumerate(diffs)]
        m.d.comb += i.ready.eq(~o.valid | o.ready)
        with m.If(i.valid & i.ready):
            m.d.sync += [
                o.valid.eq(1),
                *out,
                o.payload.first.eq(i.payload.first),
                o.payload.last.eq(i.payload.last),
            ]
        with m.Elif(o.ready):
            m.d.sync += o.valid.eq(0)
        return m
