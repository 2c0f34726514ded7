"""Digital CDS with the reset frame stored in DDR (Ning et al. 2019, section 4.4.1).

:class:`CdsDdr` — :class:`tdicam.hdl.cds.Cds` with the reset frame written to DDR through a
:class:`~tdicam.hdl.ddr.LineWriter` and read back line by line through a
:class:`~tdicam.hdl.ddr.LineReader` while the signal frame streams in.
"""

from amaranth.hdl import Module, Mux, Signal, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_range
from tdicam.model.ddr import ADDR_BITS, CAPACITY_BYTES, WORD_BITS, check_capacity
from tdicam.hdl.ddr import LineReader, LineWriter, _layout
from tdicam.hdl.interfaces.mig import MigPort, connect_mig, mig_user_ports
from tdicam.hdl.interfaces.stream import pixel_signature
from tdicam.hdl.util import quiet_reject

__all__ = ["CdsDdr"]


class CdsDdr(wiring.Component):
    """Digital CDS with the reset frame stored in DDR (Ning et al. 2019, section 4.4.1).

    Golden model: :func:`tdicam.model.ddr.cds_ddr_frames`.

    Parameters
    ----------
    width, rows : int
        Frame size (pixels per line, lines). Frames must be exactly ``rows`` x ``width``.
    pixel_bits : int
        8..16 (the :class:`~tdicam.hdl.cds.Cds` core's range).
    pixels_per_word : int or None
        Reset values per 256-bit word; default 24 for 10-bit pixels (Ning et al. 2019, Table 2),
        else ``256 // pixel_bits``.
    line_stride, base, capacity_bytes
        Where the reset frame lives (:class:`~tdicam.model.ddr.LineLayout`).

    Attributes
    ----------
    i_stream : In(pixel stream, ``pixel_bits``)
        Frames, one pixel per beat; ``frame_kind`` presented with a frame's tuser beat
        says what it is.
    frame_kind : In(1)
        1: a reset frame — written to DDR, no output; 0: a signal frame — each pixel paired
        with the stored reset pixel (read back line by line while the signal streams in)
        and output as ``max(signal - reset, 0)``. Before any reset frame the reset is 0.
    o_stream : Out(pixel stream, ``pixel_bits``)
        One frame per signal frame, ``first``/``last`` as on the input.

    Notes
    -----
    The reads of a signal frame start when its tuser beat is presented (not yet accepted)
    and the reset frame's last word has been queued; a signal beat is accepted only with its
    reset pixel in hand, so a following reset frame can never overwrite a line still to be
    read. Throughput 1 pixel/clock once the first line's reads have returned; one DDR read
    per ``pixels_per_word`` pixels.
    """

    @quiet_reject
    def __init__(self, *, width, rows, pixel_bits=12, pixels_per_word=None, line_stride=None,
                 base=0, capacity_bytes=CAPACITY_BYTES):
        check_range("pixel_bits", pixel_bits, 8, 16)
        if pixels_per_word is None:
            pixels_per_word = 24 if pixel_bits == 10 else WORD_BITS // pixel_bits
        self.layout = _layout(width, 1, pixel_bits, pixels_per_word, line_stride, base)
        check_range("rows", rows, 1, 1 << 16)
        check_capacity(self.layout, rows, capacity_bytes, "reset frame")
        self._rows = rows
        super().__init__({
            "i_stream": In(pixel_signature(unsigned(pixel_bits))),
            "o_stream": Out(pixel_signature(unsigned(pixel_bits))),
            "frame_kind": In(1), "line_errors": Out(16), **mig_user_ports()})

    rows = property(lambda self: self._rows)
    pixel_bits = property(lambda self: self.layout.pixel_bits)

    def elaborate(self, platform):
        from tdicam.hdl.cds import Cds
        m = Module()
        lay = self.layout
        m.submodules.port = port = MigPort()
        m.submodules.writer = wr = LineWriter(layout=lay, elements=1, rows=self._rows)
        m.submodules.reader = rd = LineReader(
            layout=lay, elements=1, max_lines=port.rd_depth // lay.words_per_line + 3)
        m.submodules.cds = cds = Cds(pixel_bits=lay.pixel_bits)
        connect_mig(m, port, self)
        wiring.connect(m, cds.o_stream, wiring.flipped(self.o_stream))
        m.d.comb += [self.line_errors.eq(wr.line_errors), wr.line_ok.eq(1),
                     port.wr_valid.eq(wr.wr_valid), wr.wr_ready.eq(port.wr_ready),
                     port.wr_addr.eq(wr.wr_addr), port.wr_data.eq(wr.wr_data),
                     port.rd_valid.eq(rd.rd_valid), rd.rd_ready.eq(port.rd_ready),
                     port.rd_addr.eq(rd.rd_addr),
                     rd.rdata_valid.eq(port.rdata_valid), port.rdata_ready.eq(rd.rdata_ready),
                     rd.rdata.eq(port.rdata)]
        i = self.i_stream
        kind = Signal()
        cur_kind = Mux(i.payload.first, self.frame_kind, kind)
        have_reset = Signal()
        launched = Signal()
        left = Signal(range(self._rows + 1))
        req_addr = Signal(ADDR_BITS)
        req_first = Signal()
        m.d.comb += [rd.req_valid.eq(left.any()), rd.req_addr.eq(req_addr),
                     rd.req_first.eq(req_first)]
        with m.If(rd.req_valid & rd.req_ready):
            m.d.sync += [left.eq(left - 1), req_addr.eq(req_addr + lay.line_stride),
                         req_first.eq(0)]
        launch = i.valid & i.payload.first & ~self.frame_kind & have_reset & ~launched \
            & ~left.any() & ~wr.busy
        with m.If(launch):
            m.d.sync += [launched.eq(1), left.eq(self._rows), req_addr.eq(lay.base),
                         req_first.eq(1)]
        rs = rd.o_stream
        sig_ok = cds.i_stream.ready & (~have_reset | (rs.valid & (~i.payload.first | launched)))
        m.d.comb += [
            wr.i_stream.valid.eq(i.valid & cur_kind),
            wr.i_stream.payload.eq(i.payload),
            cds.i_stream.valid.eq(i.valid & ~cur_kind & (~have_reset | (
                rs.valid & (~i.payload.first | launched)))),
            cds.i_stream.payload.data[0].eq(i.payload.data),
            cds.i_stream.payload.data[1].eq(Mux(have_reset, rs.payload.data, 0)),
            cds.i_stream.payload.first.eq(i.payload.first),
            cds.i_stream.payload.last.eq(i.payload.last),
            i.ready.eq(Mux(cur_kind, wr.i_stream.ready, sig_ok)),
            rs.ready.eq(i.valid & ~cur_kind & have_reset & sig_ok),
        ]
        fire = i.valid & i.ready
        with m.If(fire):
            m.d.sync += kind.eq(cur_kind)
            with m.If(cur_kind & i.payload.first):
                m.d.sync += have_reset.eq(1)
            with m.If(~cur_kind & i.payload.first):
                m.d.sync += launched.eq(0)
        return m
