"""The camera's output end: the frame selector and the TLK2711 links as one component, the
end of a pipeline top whose ``[pipeline].output`` is ``"links"``
(:class:`tdicam.hdl.chain_top.Pipeline` with ``links``).

Structure::

    i_stream (the last block's output, processing clock)
      -> FrameSelect: one image of ``image_rows`` rows in ``keep``
         (:mod:`tdicam.hdl.frame_select`; golden :mod:`tdicam.model.frame_select`)
      -> Tlk2711 (pins, crossing): the framers in the link clock's domain (ports
         ``link_clk``/``link_rst``), link{L}_txd / _tklsb / _tkmsb
         (:mod:`tdicam.hdl.tlk2711`; golden :mod:`tdicam.model.tlk2711`)
"""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError
from tdicam.hdl.frame_select import FrameSelect
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.tlk2711 import Tlk2711, pin_names

__all__ = ["OutputLinks", "LINKS_FRAME"]

#: The status port high on the cycle an image's first beat enters the links (the control
#: bus counts them as ``frame_count``).
LINKS_FRAME = "links_frame"


class OutputLinks(wiring.Component):
    """The frame selector and the links for a :class:`~tdicam.blocks.steps.LinkPlan`.

    Parameters
    ----------
    plan : :class:`~tdicam.blocks.steps.LinkPlan`
    bits, count : int
        The last block's pixel width (at most ``plan.pixel_bits``) and pixels a beat.

    Attributes
    ----------
    i_stream : In(pixel stream of ``count`` x ``plan.pixel_bits``)
        Frames of ``plan.frame_rows`` rows (``first`` on each frame's first beat), the
        last block's pixels zero-extended.
    link{L}_txd, link{L}_tklsb, link{L}_tkmsb : Out(16), Out(1), Out(1)
        Link ``L``'s TLK2711 parallel port (:func:`~tdicam.hdl.tlk2711.pin_names`), in the
        link clock's domain.
    links_frame : Out(1)
        :data:`LINKS_FRAME`.

    Raises
    ------
    TdicamError
        Pixels wider than ``plan.pixel_bits``, an image not a whole number of the input's
        frames (one line; :func:`tdicam.chain.design.link_plan` refuses the first for a
        scene, naming its keys).
    """

    def __init__(self, plan, *, bits, count):
        if bits > plan.pixel_bits:
            raise TdicamError(f"output links: {bits}-bit pixels do not fit the links' "
                              f"{plan.pixel_bits}")
        if plan.image_rows % plan.frame_rows:
            raise TdicamError(f"pipeline: an image of {plan.image_rows} rows for the links "
                              f"is not a whole number of the chain's {plan.frame_rows}-row "
                              f"frames")
        self._plan = plan
        self._select = FrameSelect(bits=plan.pixel_bits, count=count, keep=plan.keep,
                                   image_frames=plan.image_rows // plan.frame_rows)
        self._tlk = Tlk2711(pixel_bits=plan.pixel_bits, ppc=count, links=plan.links,
                            pins=True, crossing=True)
        mem = self._tlk.signature.members
        super().__init__({"i_stream": In(pixel_signature(channels_shape(plan.pixel_bits,
                                                                        count))),
                          LINKS_FRAME: Out(1)}
                         | {n: mem[n] for k in range(plan.links) for n in pin_names(k)})

    plan = property(lambda self: self._plan)
    port_domains = property(lambda self: self._tlk.port_domains,
                            doc="{pin: the link clock's domain} of the links' pins.")

    def elaborate(self, platform):
        m = Module()
        m.submodules.frame_select = sel = self._select
        m.submodules.links = tlk = self._tlk
        wiring.connect(m, wiring.flipped(self.i_stream), sel.i_stream)
        wiring.connect(m, sel.o_stream, tlk.i_stream)
        o = sel.o_stream
        m.d.comb += getattr(self, LINKS_FRAME).eq(o.valid & o.ready & o.payload.first)
        for k in range(self._plan.links):
            for n in pin_names(k):
                m.d.comb += getattr(self, n).eq(getattr(tlk, n))
        return m
