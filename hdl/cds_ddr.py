"""Digital CDS with the reset frame stored in DDR (Ning et al. 2019, section 4.4.1).

:class:`CdsDdr` — :class:`tdicam.hdl.cds.Cds` with the reset frame written to DDR through a
:class:`~tdicam.hdl.ddr.LineWriter` and read back line by line through a
:class:`~tdicam.hdl.ddr.LineReader` while the signal frame streams in.
"""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError, check_choice, check_multiple, check_range
from tdicam.beats import PPC_CHOICES
from tdicam.model.ddr import ADDR_BITS, CAPACITY_BYTES, WORD_BITS, check_capacity
from tdicam.hdl.ddr import LineReader, LineWriter, _layout
from tdicam.hdl.interfaces.mig import MigPort, connect_mig, mig_user_ports
from tdicam.hdl.interfaces.stream import (PairBuffer, StreamRegister, channels_shape,
                                          pixel_signature)
from tdicam.hdl.util import quiet_reject

__all__ = ["CdsDdr", "default_pixels_per_word", "port_wiring", "frame_requests", "track_kinds"]


class CdsDdr(wiring.Component):
    """Digital CDS with the reset frame stored in DDR (Ning et al. 2019, section 4.4.1).

    Golden model: :func:`tdicam.model.cds_ddr.cds_ddr_frames`.

    Parameters
    ----------
    width, rows : int
        Frame size (pixels per line, lines). Frames must be exactly ``rows`` x ``width``.
    pixel_bits : int
        8..16 (the :class:`~tdicam.hdl.cds.Cds` core's range).
    pixels_per_word : int or None
        Reset values per 256-bit word; default 24 for 10-bit pixels (Ning et al. 2019, Table 2),
        else ``256 // pixel_bits``, rounded down to a multiple of ``ppc`` (12-bit: 21 at
        ppc 1, 20 at ppc 2 and 4, 16 at ppc 8). A given value and ``ppc`` must divide one
        another.
    line_stride, base, capacity_bytes
        Where the reset frame lives (:class:`~tdicam.model.ddr.LineLayout`).
    ppc : int
        Pixels per clock (per beat): 1, 2, 4 or 8; ``width`` must be a multiple of it.

    Attributes
    ----------
    i_stream : In(pixel stream of ``ppc`` x ``pixel_bits``)
        Frames, ``ppc`` pixels per beat (element 0 the leftmost, in the least significant
        bits; a row is ``width / ppc`` beats); ``frame_kind`` presented with a frame's tuser
        beat says what it is.
    frame_kind : In(1)
        1: a reset frame — written to DDR, no output; 0: a signal frame — each pixel paired
        with the stored reset pixel (read back line by line while the signal streams in)
        and output as ``max(signal - reset, 0)``. Before any reset frame the reset is 0.
    o_stream : Out(pixel stream of ``ppc`` x ``pixel_bits``)
        One frame per signal frame, ``first``/``last`` as on the input.

    Notes
    -----
    The reads of a signal frame start when its tuser beat is presented (not yet accepted)
    and the reset frame's last word has been queued; a signal beat is accepted only with its
    reset pixel in hand, so a following reset frame can never overwrite a line still to be
    read. Throughput ``ppc`` pixels/clock once the first line's reads have returned (while
    the DDR model delivers a word per ``pixels_per_word / ppc`` clocks); one DDR read per
    ``pixels_per_word`` pixels. :attr:`latency` (the CDS core's register) is 1 cycle from an
    accepted signal beat to its output beat, at every ``ppc``.

    Raises
    ------
    TdicamError
        A parameter out of range, ``width`` not a multiple of ``ppc``, ``pixels_per_word``
        and ``ppc`` that do not divide one another, a reset frame beyond the capacity
        (one line each).
    """

    @quiet_reject
    def __init__(self, *, width, rows, pixel_bits=12, pixels_per_word=None, line_stride=None,
                 base=0, capacity_bytes=CAPACITY_BYTES, ppc=1):
        check_range("pixel_bits", pixel_bits, 8, 16)
        self._ppc = check_choice("ppc", ppc, PPC_CHOICES)
        check_multiple(width, ppc)
        pixels_per_word = default_pixels_per_word(pixel_bits, ppc, pixels_per_word)
        self.layout = _layout(width, 1, pixel_bits, pixels_per_word, line_stride, base)
        check_range("rows", rows, 1, 1 << 16)
        check_capacity(self.layout, rows, capacity_bytes, "reset frame")
        self._rows = rows
        shape = channels_shape(pixel_bits, ppc)
        super().__init__({
            "i_stream": In(pixel_signature(shape)),
            "o_stream": Out(pixel_signature(shape)),
            "frame_kind": In(1), "line_errors": Out(16), **mig_user_ports()})

    rows = property(lambda self: self._rows)
    pixel_bits = property(lambda self: self.layout.pixel_bits)
    ppc = property(lambda self: self._ppc, doc="Pixels per clock (per beat).")
    latency = property(lambda self: 1, doc="Cycles from an accepted signal beat to its "
                                           "output beat being valid (1 at every ppc).")

    def elaborate(self, platform):
        from tdicam.hdl.cds import Cds
        m = Module()
        lay = self.layout
        ppc = self._ppc
        m.submodules.port = port = MigPort(early_count=ppc > 1)
        m.submodules.writer = wr = LineWriter(layout=lay, elements=ppc, rows=self._rows,
                                               early_sums=ppc > 1)
        m.submodules.reader = rd = LineReader(
            layout=lay, elements=ppc, max_lines=port.rd_depth // lay.words_per_line + 3,
            early_last=ppc > 1)
        m.submodules.cds = cds = Cds(pixel_bits=lay.pixel_bits, ppc=ppc)
        connect_mig(m, port, self)
        wiring.connect(m, cds.o_stream, wiring.flipped(self.o_stream))
        m.d.comb += [self.line_errors.eq(wr.line_errors), wr.line_ok.eq(1),
                     *port_wiring(port, wr, rd)]
        i = self.i_stream
        kind = Signal()
        cur_kind = Mux(i.payload.first, self.frame_kind, kind)
        have_reset = Signal()
        launched = Signal()
        left, start = frame_requests(m, rd, lay, self._rows)
        launch = i.valid & i.payload.first & ~self.frame_kind & have_reset & ~launched \
            & ~left.any() & ~wr.busy
        with m.If(launch):
            m.d.sync += [launched.eq(1), *start]
        # the reset pixels through a register slice: the reader's word-to-value select and
        # the subtraction in one cycle, and the ready chain back into the MIG port, held the
        # block near 100 MHz on the ECP5; at ppc >= 2 a PairBuffer (the beat's kind and the
        # core's ready reach its read pointer, not the reset pixels' enable)
        slice_kind = PairBuffer if ppc > 1 else StreamRegister
        m.submodules.reset_reg = reg = slice_kind(rd.o_stream.payload.shape())
        wiring.connect(m, rd.o_stream, reg.i_stream)
        rs = reg.o_stream
        sig_ok = cds.i_stream.ready & (~have_reset | (rs.valid & (~i.payload.first | launched)))
        m.d.comb += [
            wr.i_stream.valid.eq(i.valid & cur_kind),
            wr.i_stream.payload.eq(i.payload),
            cds.i_stream.valid.eq(i.valid & ~cur_kind & (~have_reset | (
                rs.valid & (~i.payload.first | launched)))),
            *(cds.i_stream.payload.data[2 * k].eq(_elem(i.payload.data, k, ppc))
              for k in range(ppc)),
            *(cds.i_stream.payload.data[2 * k + 1].eq(
                Mux(have_reset, _elem(rs.payload.data, k, ppc), 0)) for k in range(ppc)),
            cds.i_stream.payload.first.eq(i.payload.first),
            cds.i_stream.payload.last.eq(i.payload.last),
            i.ready.eq(Mux(cur_kind, wr.i_stream.ready, sig_ok)),
            rs.ready.eq(i.valid & ~cur_kind & have_reset & sig_ok),
        ]
        track_kinds(m, i, kind, cur_kind, have_reset, launched)
        return m


def port_wiring(port, wr, rd):
    """A :class:`~tdicam.hdl.ddr.LineWriter` and a :class:`~tdicam.hdl.ddr.LineReader` on
    one :class:`~tdicam.hdl.interfaces.mig.MigPort`, straight (the statements)."""
    return [port.wr_valid.eq(wr.wr_valid), wr.wr_ready.eq(port.wr_ready),
            port.wr_addr.eq(wr.wr_addr), port.wr_data.eq(wr.wr_data),
            port.rd_valid.eq(rd.rd_valid), rd.rd_ready.eq(port.rd_ready),
            port.rd_addr.eq(rd.rd_addr),
            rd.rdata_valid.eq(port.rdata_valid), port.rdata_ready.eq(rd.rdata_ready),
            rd.rdata.eq(port.rdata)]


def frame_requests(m, rd, lay, rows, base=None):
    """The reader's requests for a stored frame: ``rows`` lines of ``lay`` from its base
    (``base``: a signal holding the first line's address instead), one a request. Returns
    ``(left, start)``: the lines still to request and the statements that start a frame's
    requests (``m.d.sync``, when ``left`` is 0)."""
    left = Signal(range(rows + 1))
    req_addr = Signal(ADDR_BITS)
    req_first = Signal()
    m.d.comb += [rd.req_valid.eq(left.any()), rd.req_addr.eq(req_addr),
                 rd.req_first.eq(req_first)]
    with m.If(rd.req_valid & rd.req_ready):
        m.d.sync += [left.eq(left - 1), req_addr.eq(req_addr + lay.line_stride),
                     req_first.eq(0)]
    return left, [left.eq(rows), req_addr.eq(lay.base if base is None else base),
                  req_first.eq(1)]


def track_kinds(m, i, kind, cur_kind, have, launched):
    """On each accepted beat of ``i``: ``kind`` holds the frame's kind (``cur_kind``, 1 a
    stored frame), ``have`` goes high at a stored frame's first beat, ``launched`` low at
    another frame's first beat (its reads to be started again)."""
    with m.If(i.valid & i.ready):
        m.d.sync += kind.eq(cur_kind)
        with m.If(cur_kind & i.payload.first):
            m.d.sync += have.eq(1)
        with m.If(~cur_kind & i.payload.first):
            m.d.sync += launched.eq(0)


def _elem(data, k, ppc):
    """Pixel ``k`` of a beat's ``data`` (the whole value at ppc 1)."""
    return data[k] if ppc > 1 else data


def default_pixels_per_word(pixel_bits, ppc, given=None):
    """Values per 256-bit word of the reset frame: ``given``, else 24 for 10-bit pixels
    (Ning et al. 2019, Table 2) or ``256 // pixel_bits``, rounded down to a multiple of
    ``ppc``; a ``given`` value and ``ppc`` must divide one another (one line naming both)."""
    if given is None:
        ppw = 24 if pixel_bits == 10 else WORD_BITS // pixel_bits
        return ppw - ppw % ppc
    if given % ppc and ppc % given:
        raise TdicamError(f"pixels_per_word = {given} and ppc = {ppc}: one must divide the "
                          f"other")
    return given
