"""The pixel stream shared by every video block.

Pixels travel in raster order on an :class:`amaranth.lib.stream.Signature` whose payload is
:func:`pixel_layout`: ``data`` (one pixel, or an array of pixels or channels), ``first``
(start of frame, on the first pixel of a frame) and ``last`` (end of line, on the last pixel
of each row). A transfer happens on a clock edge where ``valid & ready``; a producer holds
``valid`` and ``payload`` until accepted. AXI4-Stream names appear only in
:mod:`tdicam.hdl.interfaces.axis`.
"""

from amaranth.hdl import Module, Shape, Signal, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

__all__ = ["pixel_layout", "pixel_signature", "channels_shape", "StreamRegister"]


def pixel_layout(data_shape):
    """Struct layout ``{data: data_shape, first: 1, last: 1}``."""
    return data.StructLayout({"data": data_shape, "first": 1, "last": 1})


def pixel_signature(data_shape):
    """Stream signature carrying :func:`pixel_layout` of ``data_shape``."""
    return stream.Signature(pixel_layout(data_shape))


def channels_shape(bits, count):
    """``count`` unsigned ``bits``-wide elements: several pixels per clock or several channels
    of one pixel (element 0 in the least significant bits). ``count == 1`` gives a plain
    ``unsigned(bits)``."""
    if count == 1:
        return unsigned(bits)
    return data.ArrayLayout(unsigned(bits), count)


def element_bits(data_shape):
    """(element width, element count) of a pixel ``data`` shape."""
    if isinstance(data_shape, data.ArrayLayout):
        return Shape.cast(data_shape.elem_shape).width, data_shape.length
    return Shape.cast(data_shape).width, 1


class StreamRegister(wiring.Component):
    """A register slice on a stream (a skid buffer): ``valid``, ``payload`` and the
    upstream ``ready`` all come from registers.

    Full throughput (a beat per clock while the sink is ready), no beat lost or duplicated
    under any ``ready`` pattern; :attr:`latency` 1 cycle. Cuts every combinational path
    through it: the producer's data and valid to the consumer's registers, and the
    consumer's ready back to the producer (a beat accepted while the sink stalls waits in
    the second register).

    Parameters
    ----------
    payload_shape : shape-like
        The stream's payload (e.g. :func:`pixel_layout` of a data shape).
    """

    def __init__(self, payload_shape):
        super().__init__({"i_stream": In(stream.Signature(payload_shape)),
                          "o_stream": Out(stream.Signature(payload_shape))})

    latency = property(lambda self: 1, doc="Cycles from an accepted input beat to its "
                                           "output beat being valid.")

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        skid = Signal.like(i.payload)
        skid_valid = Signal()
        m.d.comb += i.ready.eq(~skid_valid)
        with m.If(~o.valid | o.ready):
            with m.If(skid_valid):
                m.d.sync += [o.valid.eq(1), o.payload.eq(skid), skid_valid.eq(0)]
            with m.Else():
                m.d.sync += [o.valid.eq(i.valid), o.payload.eq(i.payload)]
        with m.Elif(i.valid & ~skid_valid):
            m.d.sync += [skid.eq(i.payload), skid_valid.eq(1)]
        return m
