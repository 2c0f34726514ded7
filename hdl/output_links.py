"""The camera's output end: the frame selector and the TLK2711 links as one component, the
end of a pipeline top whose ``[pipeline].output`` is ``"links"``
(:class:`tdicam.hdl.chain_top.Pipeline` with ``links``).

Structure::

    i_stream (the last block's output, processing clock)
      -> FrameSelect: one image of ``image_rows`` rows in ``keep``
         (:mod:`tdicam.hdl.frame_select`; golden :mod:`tdicam.model.frame_select`)
      -> DdrFrameBuffer, when ``buffer_rows``: the kept images written to DDR as they
         come and read at the links' pace (:mod:`tdicam.hdl.ddr`; its MIG user interface
         the ports ``frame_buffer_app_*``; output = input)
      -> Tlk2711 (pins, crossing): the framers in the link clock's domain (ports
         ``link_clk``/``link_rst``), link{L}_txd / _tklsb / _tkmsb
         (:mod:`tdicam.hdl.tlk2711`; golden :mod:`tdicam.model.tlk2711`)
"""

from types import SimpleNamespace

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError
from tdicam.hdl.frame_select import FrameSelect
from tdicam.hdl.interfaces.mig import MIG_PORT_NAMES, connect_mig
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.tlk2711 import Tlk2711, pin_names

__all__ = ["OutputLinks", "LINKS_FRAME", "FRAME_BUFFER", "buffer_packing"]

#: The status port high on the cycle an image's first beat enters the links (the control
#: bus counts them as ``frame_count``).
LINKS_FRAME = "links_frame"

#: The prefix of the frame buffer's MIG user interface ports (``frame_buffer_app_addr``, ...)
#: and of its MIG model's status in a co-simulation board (``frame_buffer_ddr_error``).
FRAME_BUFFER = "frame_buffer"


def buffer_packing(pixel_bits, count):
    """Pixels a 256-bit word of the frame buffer: the most of
    ``min(256 // pixel_bits, 24)`` (the plan's, Ning et al. 2019 Table 2's 24 at 10 bit)
    that is a multiple of ``count`` pixels a beat, or divides it (16 for 16-bit pixels at
    any ppc; 16 for 12-bit ones at ppc 8, not 21)."""
    from tdicam.model.ddr import PIXELS_PER_WORD, WORD_BITS
    top = min(WORD_BITS // pixel_bits, PIXELS_PER_WORD)
    return max(n for n in range(1, top + 1) if n % count == 0 or count % n == 0)


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
    frame_buffer_app_* : the MIG user interface (with ``plan.buffer_rows``)
        The frame buffer's DDR (:func:`~tdicam.hdl.interfaces.mig.mig_user_ports`): an
        interface of its own. Lines of ``ceil(width / buffer_packing)`` 256-bit words at
        ``base + row * line_stride`` (:class:`~tdicam.hdl.ddr.DdrFrameBuffer`: the writer
        never more than ``buffer_rows`` rows ahead of the reads, so a kept image the
        links are slow to send stalls the chain only when it is more than the buffer
        holds).

    Raises
    ------
    TdicamError
        Pixels wider than ``plan.pixel_bits``, an image not a whole number of the input's
        frames (one line; :func:`tdicam.chain.design.link_plan` refuses the first for a
        scene, naming its keys).
    """

    def __init__(self, plan, *, bits, count, width=None):
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
        self._buffer = None
        if plan.buffer_rows:
            from tdicam.hdl.ddr import DdrFrameBuffer
            if width is None:
                raise TdicamError("output links: a frame buffer needs the image's width")
            self._buffer = DdrFrameBuffer(
                width=width, rows=plan.buffer_rows, channels=1, elements=count,
                pixel_bits=plan.pixel_bits,
                pixels_per_word=buffer_packing(plan.pixel_bits, count), early=True,
                paced=True)
            # (made here for its checks and ports; a top made for its ports only leaves it)
            self._buffer._MustUse__silence = True
        mem = self._tlk.signature.members
        fb = {} if self._buffer is None else {
            f"{FRAME_BUFFER}_{n}": self._buffer.signature.members[n] for n in MIG_PORT_NAMES}
        super().__init__({"i_stream": In(pixel_signature(channels_shape(plan.pixel_bits,
                                                                        count))),
                          LINKS_FRAME: Out(1)}
                         | {n: mem[n] for k in range(plan.links) for n in pin_names(k)}
                         | fb)

    plan = property(lambda self: self._plan)
    port_domains = property(lambda self: self._tlk.port_domains,
                            doc="{pin: the link clock's domain} of the links' pins.")
    frame_buffer = property(lambda self: self._buffer,
                            doc="The :class:`~tdicam.hdl.ddr.DdrFrameBuffer`, or None.")

    def elaborate(self, platform):
        m = Module()
        m.submodules.frame_select = sel = self._select
        m.submodules.links = tlk = self._tlk
        wiring.connect(m, wiring.flipped(self.i_stream), sel.i_stream)
        if self._buffer is None:
            wiring.connect(m, sel.o_stream, tlk.i_stream)
        else:
            m.submodules.frame_buffer = fb = self._buffer
            wiring.connect(m, sel.o_stream, fb.i_stream)
            wiring.connect(m, fb.o_stream, tlk.i_stream)
            connect_mig(m, fb, SimpleNamespace(**{
                n: getattr(self, f"{FRAME_BUFFER}_{n}") for n in MIG_PORT_NAMES}))
        o = sel.o_stream
        m.d.comb += getattr(self, LINKS_FRAME).eq(o.valid & o.ready & o.payload.first)
        for k in range(self._plan.links):
            for n in pin_names(k):
                m.d.comb += getattr(self, n).eq(getattr(tlk, n))
        return m
