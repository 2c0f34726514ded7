"""The TDI accumulator with its partial-sum lines in DDR (SPEC 3.4 + 3.8).

:class:`TdiDdr` — :class:`tdicam.hdl.tdi.TdiAccumulator`'s behaviour with the ``stages - 1``
partial-sum lines in DDR behind one :class:`~tdicam.hdl.mig.MigPort`.
"""

from amaranth.hdl import Cat, Module, Mux, Signal, Value, unsigned
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.wiring import In, Out
from amaranth.utils import bits_for

from tdicam.model.ddr import ADDR_BITS, ADDR_PER_WORD, CAPACITY_BYTES, WORD_BITS, LineLayout, \
    check_capacity
from .mig import MigPort, connect_mig, mig_user_ports
from .stream import channels_shape, pixel_signature
from .tdi_control import TdiFrameControl
from .util import equals, mux_select, quiet_reject

__all__ = ["TdiDdr"]

class TdiDdr(wiring.Component):
    """The optimized TDI accumulator with its ``stages - 1`` partial-sum lines in DDR.

    Same parameters, ports, settings, error handling and output, beat for beat, as
    :class:`tdicam.hdl.tdi.TdiAccumulator` (golden model :func:`tdicam.model.tdi.tdi_stream`;
    the frame control is that block's, :class:`~tdicam.hdl.tdi_control.TdiFrameControl`,
    with addresses counted in lines), plus the MIG
    user-interface ports. Refuses (one-line :class:`TdicamError`) configurations checked by
    :func:`tdicam.model.ddr.tdi_ddr_check` (rows shorter than the read look-ahead; with
    ``line_period_s``, DDR bandwidth or clock short for ``stages``).

    Partial sums in DDR: :func:`tdicam.model.ddr.psums_per_word` sums of :attr:`psum_bits`
    per 256-bit word (sum j of a word at bits ``[j*psum_bits +: psum_bits]``), line ``s`` at
    ``base + s * words_per_line * 8``. Per word of a row: one read (queued when the row's
    beat that starts the word is decoded, only for rows that add a stored sum) and one write
    (when its last beat has been added, except on the output row).

    Pipeline: the frame control (input register, decoded-beat register) -> a FIFO of
    ``lookahead`` decoded beats, which lets reads run ahead of the additions by up to
    ``lookahead`` beats and 64 words -> add (stored sum + pixels, write-back, output
    register). A stored sum is read one row after it was written at the earliest, so rows
    must be longer than the look-ahead (the check). The DDR port keeps reads and writes in
    one order, so no read overtakes the write it depends on. Sustained rate: ``ppc`` pixels
    per clock while the DDR interface keeps up (two commands per word of
    ``psums_per_word`` sums), lower under DDR stalls; latency variable (>= the DDR read
    latency on rows that read).
    """

    LOOKAHEAD = 128

    @quiet_reject
    def __init__(self, *, width, stages, pixel_bits=12, out_bits=None, ppc=1, base=0,
                 line_period_s=None, clock_hz=100e6, capacity_bytes=CAPACITY_BYTES):
        from tdicam.model.ddr import psums_per_word, tdi_ddr_check
        from tdicam.model.tdi import check_params, full_bits, out_width
        check_params(width=width, stages=stages, pixel_bits=pixel_bits, out_bits=out_bits,
                     ppc=ppc)
        self.info = tdi_ddr_check(width=width, stages=stages, pixel_bits=pixel_bits, ppc=ppc,
                                  line_period_s=line_period_s, clock_hz=clock_hz,
                                  lookahead=self.LOOKAHEAD + 4)
        self._width, self._stages, self._pixel_bits, self._ppc = width, stages, pixel_bits, ppc
        self._out_bits = out_width(pixel_bits, stages, out_bits)
        self._saturate = out_bits is not None
        self._psum_bits = full_bits(pixel_bits, stages)
        self._k = psums_per_word(self._psum_bits, ppc)
        self._j = self._k // ppc
        self._wpl = -(-(width // ppc) // self._j)
        self.layout = LineLayout(width=self._wpl * self._k, pixel_bits=self._psum_bits,
                                 pixels_per_word=self._k, base=base,
                                 line_stride=self._wpl * ADDR_PER_WORD)
        check_capacity(self.layout, max(stages - 1, 0), capacity_bytes, "partial-sum lines")
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, ppc))),
            "o_stream": Out(pixel_signature(channels_shape(self._out_bits, ppc))),
            "stages_active": In(unsigned(bits_for(stages))),
            "direction": In(unsigned(1)),
            "frame_errors": Out(unsigned(16)),
            **mig_user_ports()})

    width = property(lambda self: self._width)
    stages = property(lambda self: self._stages)
    pixel_bits = property(lambda self: self._pixel_bits)
    ppc = property(lambda self: self._ppc)
    out_bits = property(lambda self: self._out_bits)
    psum_bits = property(lambda self: self._psum_bits)
    psums_per_word = property(lambda self: self._k)
    words_per_line = property(lambda self: self._wpl)

    @property
    def ddr_words(self):
        """DDR words holding the partial sums: ``(stages - 1) * words_per_line``."""
        return max(self._stages - 1, 0) * self._wpl

    def elaborate(self, platform):
        m = Module()
        W, M, PB, PPC = self._width, self._stages, self._pixel_bits, self._ppc
        PS, OB, J, WPL = self._psum_bits, self._out_bits, self._j, self._wpl
        AW = ADDR_BITS
        o = self.o_stream
        m.submodules.port = port = MigPort()
        connect_mig(m, port, self)

        def wire(name, value, shape=1):
            w = Signal(shape, name=name)
            m.d.comb += w.eq(value)
            return w

        # ---- frame control (shared with TdiAccumulator), addresses counted in lines
        m.submodules.control = ctl = TdiFrameControl(width=W, stages=M, pixel_bits=PB,
                                                     ppc=PPC, stride=1)
        wiring.connect(m, wiring.flipped(self.i_stream), ctl.i_stream)
        m.d.comb += [ctl.stages_active.eq(self.stages_active),
                     ctl.direction.eq(self.direction), self.frame_errors.eq(ctl.frame_errors)]
        b = ctl.o_stream.payload

        # the decoded beat's word within its row: (word column, position in the word)
        wcol = Signal(range(WPL))
        wpos = Signal(range(max(J, 2)))
        e_wcol = wire("e_wcol", Mux(b.first, 0, wcol), range(WPL))
        e_wpos = wire("e_wpos", Mux(b.first, 0, wpos), len(wpos))
        need_rd = wire("need_rd", b.use & ~e_wpos.any())
        word_addr = wire("word_addr", self.layout.base
                         + (b.addr * WPL + e_wcol) * ADDR_PER_WORD, AW)
        wend = wire("wend", (e_wpos == J - 1) | b.last)

        # decoded-beat FIFO: data, use, wr, out, first, last, zero, wpos, wend, word addr
        fields = [("data", PPC * PB), ("use", 1), ("wr", 1), ("out", 1), ("first", 1),
                  ("last", 1), ("zero", 1), ("wpos", len(wpos)), ("wend", 1), ("addr", AW)]
        m.submodules.beats = bq = SyncFIFOBuffered(width=sum(w for _, w in fields),
                                                   depth=self.LOOKAHEAD)
        q_in = {"data": b.data, "use": b.use, "wr": b.wr, "out": b.out, "first": b.first,
                "last": b.last, "zero": b.zero, "wpos": e_wpos, "wend": wend,
                "addr": word_addr}
        m.d.comb += bq.w_data.eq(Cat(*(q_in[n] for n, _ in fields)))
        q = {}
        off = 0
        for n, w in fields:
            q[n] = bq.r_data[off:off + w]
            off += w

        # read request with the decoded beat that starts a word of a row that adds
        m.d.comb += [ctl.o_stream.ready.eq(bq.w_rdy & (~need_rd | port.rd_ready)),
                     port.rd_valid.eq(ctl.o_stream.valid & bq.w_rdy & need_rd),
                     port.rd_addr.eq(word_addr),
                     bq.w_en.eq(ctl.o_stream.valid & ctl.o_stream.ready)]
        with m.If(bq.w_en):
            with m.If(e_wpos == J - 1):
                m.d.sync += [wpos.eq(0), wcol.eq(e_wcol + 1)]
            with m.Else():
                m.d.sync += [wpos.eq(e_wpos + 1), wcol.eq(e_wcol)]

        # ---- add stage: head of the beat FIFO + its stored sums
        h_rd = wire("h_rd", q["use"] & ~q["wpos"].any())
        rword = Signal(WORD_BITS)
        psword = wire("psword", Mux(h_rd, port.rdata, rword), WORD_BITS)
        o_valid, o_first, o_last = Signal(), Signal(), Signal()
        o_data = Signal(PPC * OB)
        m.d.comb += [o.valid.eq(o_valid), Value.cast(o.payload.data).eq(o_data),
                     o.payload.first.eq(o_first), o.payload.last.eq(o_last)]
        rd_ok = wire("rd_ok", ~h_rd | port.rdata_valid)
        out_ok = wire("out_ok", ~q["out"] | ~o_valid | o.ready)
        w_need = wire("w_need", q["wr"] & q["wend"])
        ready_but_wr = wire("ready_but_wr", bq.r_rdy & rd_ok & out_ok)
        go = wire("go", ready_but_wr & (~w_need | port.wr_ready))
        m.d.comb += [bq.r_en.eq(go), port.rdata_ready.eq(go & h_rd)]
        with m.If(go & h_rd):
            m.d.sync += rword.eq(port.rdata)
        chunks = [psword[p * PPC * PS:(p + 1) * PPC * PS] for p in range(J)]
        chunk = mux_select(chunks, q["wpos"]) if J > 1 else chunks[0]
        sums, outs = [], []
        for k in range(PPC):
            px = q["data"][k * PB:(k + 1) * PB]
            ps = chunk[k * PS:(k + 1) * PS]
            s = Signal(PS + 1, name=f"sum{k}")
            m.d.comb += s.eq(Mux(q["use"], ps, 0) + px)
            sums.append(s[:PS])
            if self._saturate and OB < PS + 1:
                v = Mux(s > (1 << OB) - 1, (1 << OB) - 1, s[:OB])
            else:
                v = s[:OB]
            outs.append(Mux(q["zero"], 0, v))
        wword = Signal(WORD_BITS)
        new_chunks = []
        for p in range(J):
            old = wword[p * PPC * PS:(p + 1) * PPC * PS]
            new_chunks.append(Mux(equals(q["wpos"], p), Cat(*sums), Mux(~q["wpos"].any(), 0, old)))
        new_word = wire("new_word", Cat(*new_chunks), WORD_BITS)
        with m.If(go & q["wr"]):
            m.d.sync += wword.eq(new_word)
        m.d.comb += [port.wr_valid.eq(ready_but_wr & w_need), port.wr_addr.eq(q["addr"]),
                     port.wr_data.eq(new_word)]
        with m.If(go & q["out"]):
            m.d.sync += [o_valid.eq(1), o_data.eq(Cat(*outs)),
                         o_first.eq(q["first"] & ~q["zero"]), o_last.eq(q["last"])]
        with m.Elif(o.ready):
            m.d.sync += o_valid.eq(0)
        return m
