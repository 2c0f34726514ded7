"""The frame selector before the camera's output links: the chain's frames gathered into
images, one image in ``keep`` passed (:mod:`tdicam.model.frame_select`, bit-exact).

A combinational pass-through with two counters: no latency, no buffer. A beat with
``first`` starts frame ``f`` (from 0 after reset), of image ``f // image_frames``; the
counters hold the next frame's ``f mod image_frames`` and its image's index mod ``keep``. The beats of a kept image pass with ``first`` only on the
image's first frame start; the beats of a dropped image are taken and dropped (``ready``
high, no ``valid``), whatever the sink does.
"""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_range
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import quiet_reject
from tdicam.model.frame_select import MAX_IMAGE_FRAMES, MAX_KEEP_EVERY

__all__ = ["FrameSelect"]


class FrameSelect(wiring.Component):
    """One image in ``keep`` of the chain's frames, ``image_frames`` frames an image.

    Parameters
    ----------
    bits : int
        Bits of a stream element.
    count : int
        Elements a beat (pixels per clock).
    keep : int
        ``K``: images counted for each image passed (1: all), 1..65535.
    image_frames : int
        Frames of the input an image (the image's rows over the input frame's), 1..65535.

    Attributes
    ----------
    i_stream : In(pixel stream of ``count`` x ``bits``)
        ``first`` on each frame's first beat.
    o_stream : Out(the same)
        The kept images' beats as they come (:attr:`latency` 0), ``first`` on each image's
        first beat, ``last`` as the input's.
    """

    @quiet_reject
    def __init__(self, *, bits, count=1, keep=1, image_frames=1):
        self._keep = check_range("keep", keep, 1, MAX_KEEP_EVERY)
        self._g = check_range("image_frames", image_frames, 1, MAX_IMAGE_FRAMES)
        shape = channels_shape(bits, count)
        super().__init__({"i_stream": In(pixel_signature(shape)),
                          "o_stream": Out(pixel_signature(shape))})

    keep = property(lambda self: self._keep)
    image_frames = property(lambda self: self._g)
    latency = property(lambda self: 0, doc="Cycles from an input beat to its output: 0.")

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        g = Signal(range(self._g), name="frame_in_image")       # the next frame's
        k = Signal(range(self._keep), name="image_in_keep")     # the next image's
        kept = Signal(name="kept")                              # the current frame's
        starts_image = g == 0
        now = Mux(i.payload.first, k == 0, kept)
        m.d.comb += [
            o.valid.eq(i.valid & now), i.ready.eq(o.ready | ~now),
            o.payload.data.eq(i.payload.data), o.payload.last.eq(i.payload.last),
            o.payload.first.eq(i.payload.first & starts_image),
        ]
        with m.If(i.valid & i.ready & i.payload.first):
            m.d.sync += kept.eq(k == 0)
            with m.If(g == self._g - 1):
                m.d.sync += [g.eq(0), k.eq(Mux(k == self._keep - 1, 0, k + 1))]
            with m.Else():
                m.d.sync += g.eq(g + 1)
        return m
