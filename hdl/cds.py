"""Digital correlated double sampling (Ning et al. 2019 §4.4.1)."""

from amaranth.hdl import Module, Mux, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_range
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import quiet_reject

__all__ = ["Cds"]


class Cds(wiring.Component):
    """Subtract the reset level from the signal level of every pixel.

    Parameters
    ----------
    pixel_bits : int
        Width of the signal, reset and output pixels, 8..16.

    Attributes
    ----------
    i_stream : In(pixel stream)
        ``data[0]`` is the signal level, ``data[1]`` the reset level of the same pixel.
    o_stream : Out(pixel stream)
        ``data = signal - reset`` when ``signal >= reset``, else 0 (the paper's "numerical
        protection"); ``pixel_bits`` wide, never wraps. ``first``/``last`` pass through.

    Notes
    -----
    One register stage: :attr:`latency` = 1 cycle from an accepted input to a valid
    output. Full throughput (1 pixel/clock) while ``o_stream.ready`` is high; ``i_stream.ready``
    is low only when the output register holds a pixel that is not being taken, so no pixel is
    lost or duplicated whatever ``ready`` does.
    """

    @quiet_reject
    def __init__(self, *, pixel_bits=12):
        self._pixel_bits = check_range("pixel_bits", pixel_bits, 8, 16)
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, 2))),
            "o_stream": Out(pixel_signature(unsigned(pixel_bits))),
        })

    @property
    def pixel_bits(self):
        return self._pixel_bits

    @property
    def latency(self):
        """Cycles from an input transfer to the corresponding output being valid."""
        return 1

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        sig, rst = i.payload.data[0], i.payload.data[1]
        m.d.comb += i.ready.eq(~o.valid | o.ready)
        with m.If(i.valid & i.ready):
            m.d.sync += [
                o.valid.eq(1),
                o.payload.data.eq(Mux(sig >= rst, sig - rst, 0)),
                o.payload.first.eq(i.payload.first),
                o.payload.last.eq(i.payload.last),
            ]
        with m.Elif(o.ready):
            m.d.sync += o.valid.eq(0)
        return m
