"""The camera's output end: the frame selector and the TLK2711 links as one component, the
end of a pipeline top whose ``[pipeline].output`` is ``"links"``
(:class:`tdicam.hdl.chain_top.Pipeline` with ``links``).

Structure::

    i_stream (the last block's output, processing clock)
      -> FrameSelect: one image of ``image_rows`` rows in ``keep``
         (:mod:`tdicam.hdl.frame_select`; golden :mod:`tdicam.model.frame_select`)
      -> DdrFrameBuffer(s), when ``buffer_rows``: the kept images written to DDR as they
         come and read at the links' pace (:mod:`tdicam.hdl.ddr`; output = input); with
         ``buffers`` = n, line y of an image to buffer ``y mod n`` and back in the same
         order (one a DDR interface; buffer j's MIG user interface the ports
         ``frame_buffer_app_*_j``, ``_0`` left out)
      -> Tlk2711 (pins, crossing): the framers in the link clock's domain (ports
         ``link_clk``/``link_rst``), link{L}_txd / _tklsb / _tkmsb
         (:mod:`tdicam.hdl.tlk2711`; golden :mod:`tdicam.model.tlk2711`)
"""

from types import SimpleNamespace

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError, check_range
from tdicam.hdl.util import quiet_reject
from tdicam.hdl.frame_select import FrameSelect
from tdicam.hdl.interfaces.mig import MIG_PORT_NAMES, connect_mig
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.tlk2711 import Tlk2711, pin_names

__all__ = ["OutputLinks", "LINKS_FRAME", "FRAME_BUFFER", "buffer_packing", "buffer_port",
           "buffer_share", "SpreadFrameBuffer"]

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
    width : int
        Pixels a row (needed with a frame buffer).
    buffers : int
        DDR interfaces the frame buffer is spread over (1 or more; with
        ``plan.buffer_rows``): line y of each image goes to buffer ``y mod buffers``, which
        holds that share of ``plan.buffer_rows`` (:func:`buffer_share`), and the lines
        come back out in their order. Lines are dealt by count (``width / count`` beats a
        line, ``plan.image_rows`` lines an image), as the buffers cut them.

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
    frame_buffer_app_*, frame_buffer_app_*_j : the MIG user interfaces (with ``plan.buffer_rows``)
        Buffer j's DDR (:func:`~tdicam.hdl.interfaces.mig.mig_user_ports`; buffer 0's
        without the suffix). Lines of ``ceil(width / buffer_packing)`` 256-bit words at
        ``plan.buffer_base + slot * line_stride`` (:class:`~tdicam.hdl.ddr.DdrFrameBuffer`:
        a writer never more than its rows ahead of its reads, so a kept image the links
        are slow to send stalls the chain only when it is more than the buffers hold).

    Raises
    ------
    TdicamError
        Pixels wider than ``plan.pixel_bits``, an image not a whole number of the input's
        frames, a frame buffer without ``width`` (one line;
        :func:`tdicam.chain.design.link_plan` refuses the first for a scene, naming its
        keys).
    """

    def __init__(self, plan, *, bits, count, width=None, buffers=1):
        if bits > plan.pixel_bits:
            raise TdicamError(f"output links: {bits}-bit pixels do not fit the links' "
                              f"{plan.pixel_bits}")
        if plan.image_rows % plan.frame_rows:
            raise TdicamError(f"pipeline: an image of {plan.image_rows} rows for the links "
                              f"is not a whole number of the chain's {plan.frame_rows}-row "
                              f"frames")
        self._plan, self._count, self._width = plan, count, width
        self._select = FrameSelect(bits=plan.pixel_bits, count=count, keep=plan.keep,
                                   image_frames=plan.image_rows // plan.frame_rows)
        self._tlk = Tlk2711(pixel_bits=plan.pixel_bits, ppc=count, links=plan.links,
                            pins=True, crossing=True)
        self._spread = None
        if plan.buffer_rows:
            if width is None:
                raise TdicamError("output links: a frame buffer needs the image's width")
            self._spread = SpreadFrameBuffer(plan, width=width, count=count, buffers=buffers)
            # (made here for its checks and ports; a top made for its ports only leaves it)
            self._spread._MustUse__silence = True
        mem = self._tlk.signature.members
        sp = self._spread
        fb = {} if sp is None else {
            f"{FRAME_BUFFER}_{n}": sp.signature.members[n] for n in sp.mig_ports}
        super().__init__({"i_stream": In(pixel_signature(channels_shape(plan.pixel_bits,
                                                                        count))),
                          LINKS_FRAME: Out(1)}
                         | {n: mem[n] for k in range(plan.links) for n in pin_names(k)}
                         | fb)

    plan = property(lambda self: self._plan)
    port_domains = property(lambda self: self._tlk.port_domains,
                            doc="{pin: the link clock's domain} of the links' pins.")
    frame_buffers = property(lambda self: [] if self._spread is None else
                             self._spread.buffers,
                             doc="The :class:`~tdicam.hdl.ddr.DdrFrameBuffer` s, buffer j "
                                 "taking lines ``y mod len`` = j ([] without one).")

    def elaborate(self, platform):
        m = Module()
        m.submodules.frame_select = sel = self._select
        m.submodules.links = tlk = self._tlk
        wiring.connect(m, wiring.flipped(self.i_stream), sel.i_stream)
        sp = self._spread
        if sp is None:
            wiring.connect(m, sel.o_stream, tlk.i_stream)
        else:
            m.submodules.frame_buffer = sp
            wiring.connect(m, sel.o_stream, sp.i_stream)
            wiring.connect(m, sp.o_stream, tlk.i_stream)
            for n in sp.mig_ports:
                if sp.signature.members[n].flow == wiring.Out:
                    m.d.comb += getattr(self, f"{FRAME_BUFFER}_{n}").eq(getattr(sp, n))
                else:
                    m.d.comb += getattr(sp, n).eq(getattr(self, f"{FRAME_BUFFER}_{n}"))
        o = sel.o_stream
        m.d.comb += getattr(self, LINKS_FRAME).eq(o.valid & o.ready & o.payload.first)
        for k in range(self._plan.links):
            for n in pin_names(k):
                m.d.comb += getattr(self, n).eq(getattr(tlk, n))
        return m


class SpreadFrameBuffer(wiring.Component):
    """The output links' DDR frame buffer over ``buffers`` DDR interfaces: line y of each
    image to :class:`~tdicam.hdl.ddr.DdrFrameBuffer` ``y mod buffers`` and the lines back
    out in their order.

    Parameters
    ----------
    plan : :class:`~tdicam.blocks.steps.LinkPlan`
        ``image_rows`` lines an image, ``buffer_rows`` rows in all (buffer j holding its
        share, :func:`buffer_share`), from DDR address ``buffer_base`` on each interface.
    width, count : int
        Pixels a line and a beat (``plan.pixel_bits`` each, :func:`buffer_packing` a word).
    buffers : int
        DDR interfaces (at least 1; more than ``image_rows`` leave the extra ones out).

    Attributes
    ----------
    i_stream, o_stream : pixel streams of ``count`` x ``plan.pixel_bits``
        Output = input (values, ``first``, ``last``), after the round trip. Lines are
        dealt by count (``width / count`` beats a line, ``image_rows`` lines an image), as
        the buffers cut them; a reset starts again at line 0 on buffer 0.
    app_*, app_*_j : the MIG user interfaces
        Buffer j's (:func:`~tdicam.hdl.interfaces.mig.mig_user_ports`; buffer 0's without
        the suffix: :func:`buffer_port`).

    Notes
    -----
    Latency and throughput: each buffer's (:class:`~tdicam.hdl.ddr.DdrFrameBuffer`,
    ``early`` and ``paced``); the deal and the take add no cycle (a register of the line's
    buffer each side, selecting the handshake and the payload).
    """

    @quiet_reject
    def __init__(self, plan, *, width, count, buffers=1):
        from tdicam.hdl.ddr import DdrFrameBuffer
        check_range("buffers", buffers, 1, 64)
        if width % count:
            raise TdicamError(f"frame buffer: a line of {width} pixels is not a whole number "
                              f"of {count}-pixel beats")
        self._plan, self._width, self._count = plan, width, count
        self._buffers = [DdrFrameBuffer(
            width=width, rows=rows, channels=1, elements=count, pixel_bits=plan.pixel_bits,
            base=plan.buffer_base, pixels_per_word=buffer_packing(plan.pixel_bits, count),
            early=True, paced=True) for rows in buffer_share(plan, buffers)]
        self._mig = tuple(lane_port(n, j) for j in range(len(self._buffers))
                          for n in MIG_PORT_NAMES)
        px = pixel_signature(channels_shape(plan.pixel_bits, count))
        super().__init__({"i_stream": In(px), "o_stream": Out(px)} | {
            lane_port(n, j): b.signature.members[n]
            for j, b in enumerate(self._buffers) for n in MIG_PORT_NAMES})

    buffers = property(lambda self: list(self._buffers),
                       doc="The :class:`~tdicam.hdl.ddr.DdrFrameBuffer` s, buffer j taking "
                           "lines ``y mod len`` = j.")
    mig_ports = property(lambda self: self._mig,
                         doc="The buffers' MIG user interface ports (``app_addr``, ...,"
                             " ``app_addr_1``, ...).")

    def elaborate(self, platform):
        m = Module()
        bufs = self._buffers
        for j, fb in enumerate(bufs):
            m.submodules[f"buffer{j}"] = fb
            connect_mig(m, fb, SimpleNamespace(**{
                n: getattr(self, lane_port(n, j)) for n in MIG_PORT_NAMES}))
        src, dst = self.i_stream, self.o_stream
        if len(bufs) == 1:
            wiring.connect(m, wiring.flipped(src), bufs[0].i_stream)
            wiring.connect(m, bufs[0].o_stream, wiring.flipped(dst))
            return m
        beats, lines, n = self._width // self._count, self._plan.image_rows, len(bufs)
        w = _dealer(m, src.valid & src.ready, beats, lines, n, "deal")
        r = _dealer(m, dst.valid & dst.ready, beats, lines, n, "take")
        for j, fb in enumerate(bufs):
            m.d.comb += [fb.i_stream.payload.eq(src.payload),
                         fb.i_stream.valid.eq(src.valid & (w == j))]
        with m.Switch(w):
            for j, fb in enumerate(bufs):
                with m.Case(j):
                    m.d.comb += src.ready.eq(fb.i_stream.ready)
        with m.Switch(r):
            for j, fb in enumerate(bufs):
                with m.Case(j):
                    m.d.comb += [dst.payload.eq(fb.o_stream.payload),
                                 dst.valid.eq(fb.o_stream.valid),
                                 fb.o_stream.ready.eq(dst.ready)]
        return m


def lane_port(name, j):
    """Port ``name`` of lane (buffer) ``j``: ``name``, ``name_1``, ... (the top's
    convention, :meth:`tdicam.hdl.chain_top.Pipeline._status`)."""
    return name + (f"_{j}" if j else "")


def buffer_port(name, j):
    """The :class:`OutputLinks` port of buffer ``j``'s MIG user interface pin ``name``
    (``frame_buffer_app_addr``, ``frame_buffer_app_addr_1``, ...)."""
    return f"{FRAME_BUFFER}_{lane_port(name, j)}"


def buffer_share(plan, buffers):
    """Rows each of ``buffers`` frame buffers holds for ``plan``: buffer j the lines
    ``y mod buffers = j`` of ``plan.buffer_rows // plan.image_rows`` images (buffers that
    would hold none are left out: an image of fewer rows than buffers)."""
    images = plan.buffer_rows // plan.image_rows
    n = max(1, min(int(buffers), plan.image_rows))
    return [images * len(range(j, plan.image_rows, n)) for j in range(n)]


def _dealer(m, fire, beats, lines, n, name):
    """The buffer (0 .. n-1) a stream's current beat belongs to, line y of each
    ``lines``-line image to ``y mod n``: ``fire`` counts ``beats`` a line (registers)."""
    col = Signal(range(beats), name=f"{name}_col")
    row = Signal(range(lines), name=f"{name}_row")
    sel = Signal(range(n), name=f"{name}_sel")
    with m.If(fire):
        m.d.sync += col.eq(Mux(col == beats - 1, 0, col + 1))
        with m.If(col == beats - 1):
            m.d.sync += [row.eq(Mux(row == lines - 1, 0, row + 1)),
                         sel.eq(Mux((row == lines - 1) | (sel == n - 1), 0, sel + 1))]
    return sel
