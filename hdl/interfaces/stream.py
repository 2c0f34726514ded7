"""The pixel stream shared by every video block.

Pixels travel in raster order on an :class:`amaranth.lib.stream.Signature` whose payload is
:func:`pixel_layout`: ``data`` (one pixel, or an array of pixels or channels), ``first``
(start of frame, on the first pixel of a frame) and ``last`` (end of line, on the last pixel
of each row). A transfer happens on a clock edge where ``valid & ready``; a producer holds
``valid`` and ``payload`` until accepted. AXI4-Stream names appear only in
:mod:`tdicam.hdl.interfaces.axis`.
"""

from amaranth.hdl import Module, Shape, unsigned
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
    """A pipeline register on a stream: ``valid`` and ``payload`` registered, ``ready``
    passed through (``i_stream.ready = ~o_stream.valid | o_stream.ready``).

    Full throughput (a beat per clock while the sink is ready), no beat lost or duplicated
    under any ``ready`` pattern; :attr:`latency` 1 cycle. Cuts a combinational path from
    the producer's data and valid to the consumer's registers.

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
        m.d.comb += i.ready.eq(~o.valid | o.ready)
        with m.If(i.ready):
            m.d.sync += [o.valid.eq(i.valid), o.payload.eq(i.payload)]
        return m
