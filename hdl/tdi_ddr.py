"""The TDI accumulator with its partial-sum lines in DDR (SPEC 3.4 + 3.8).

:class:`TdiDdr` — :class:`tdicam.hdl.tdi.TdiAccumulator`'s behaviour with the ``stages - 1``
partial-sum lines in DDR behind one :class:`~tdicam.hdl.interfaces.mig.MigPort`.
"""

from amaranth.hdl import Cat, Module, Mux, Signal, Value, signed
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.utils import bits_for

from tdicam.model.ddr import (ADDR_BITS, ADDR_PER_WORD, CAPACITY_BYTES, WORD_BITS, LineLayout,
                              check_capacity)
from tdicam.hdl.interfaces.mig import MigPort, connect_mig, mig_user_ports
from tdicam.hdl.tdi_control import TdiFrameControl, tdi_ports
from tdicam.hdl.util import equals, mux_select, quiet_reject

__all__ = ["TdiDdr"]

class TdiDdr(wiring.Component):
    """The optimized TDI accumulator with its ``stages - 1`` partial-sum lines in DDR.

    Same parameters, ports, settings, error handling and output, beat for beat, as
    :class:`tdicam.hdl.tdi.TdiAccumulator` (golden model :func:`tdicam.model.tdi.tdi_stream`;
    the frame control is that block's, :class:`~tdicam.hdl.tdi_control.TdiFrameControl`,
    with addresses counted in lines), plus the MIG
    user-interface ports. Refuses (one-line :class:`TdicamError`) configurations checked by
    :func:`tdicam.model.tdi_ddr.tdi_ddr_check` (rows shorter than the read look-ahead; with
    ``line_period_s``, DDR bandwidth or clock short for ``stages``).

    Partial sums in DDR: :func:`tdicam.model.ddr.psums_per_word` sums of :attr:`psum_bits`
    per 256-bit word (sum j of a word at bits ``[j*psum_bits +: psum_bits]``), line ``s`` at
    ``base + s * words_per_line * 8``.

    DRAM order (:data:`tdicam.model.ddr_efficiency.TDI_SPILL_PATTERN`): reads and writes go to DDR in
    blocks of a line, not interleaved word by word (a read/write turnaround costs a DDR3
    controller 6-13 cycles). A row that adds stored sums has its whole line read as one
    block of :attr:`words_per_line` reads once the add stage has started the row before it
    and every write of older rows has been queued (a row that reads the line the row before
    it writes, ``stages_active`` = 2 forward, waits until that row is finished, which costs
    about the DDR read latency per row); no write is queued during a block. The new sums
    wait meanwhile in a write-behind FIFO and are written back, in order, between the
    blocks. Efficiency of the interface on the recorded order, over a steady-state window of
    4 refresh intervals (3128 cycles; :data:`tdicam.model.ddr_efficiency.MEASURED_EFFICIENCY`, the
    memory model): 83.3 % at W = 1280 (m = 16, 12-bit), 86.9 % at W = 4096 (m = 32,
    ppc 4), against 12.5 % for a read and a write per word; LiteDRAM over the same window:
    82.1 % and 86.3 % (the DDR table of docs/guide/benchmarks.md; ``bench/bench_ddr.py
    --litedram`` prints them).

    On-chip buffers (block RAM): the read-ahead, :class:`~tdicam.hdl.interfaces.mig.MigPort`'s read-data
    FIFO of ``2 * words_per_line`` x 256 bit (the row being added and the next row's
    block); the write-behind FIFO of ``max(16, words_per_line)`` x (256 + 28) bit; the
    decoded-beat FIFO of :attr:`LOOKAHEAD` x (``ppc * pixel_bits`` + 37..41) bit.
    :attr:`buffer_bits` sums them: 283 kbit at W = 4096, m = 32, ppc = 4, 12-bit pixels
    (the partial sums there take 2.7 Mbit of DDR words), 70 kbit at W = 1280, m = 16.

    Pipeline: the frame control (input register, decoded-beat register) -> the decoded-beat
    FIFO (a row descriptor to the read engine with each row's first beat) -> add (stored
    sum + pixels, write-back into the write-behind FIFO, output register). Rows must be
    longer than the look-ahead (the check). Sustained rate: ``ppc`` pixels per clock while
    the DDR interface keeps up (``2 * words_per_line`` words per row that adds), lower
    under DDR stalls; latency variable (>= the DDR read latency on rows that read).
    """

    LOOKAHEAD = 128

    @quiet_reject
    def __init__(self, *, width, stages, pixel_bits=12, out_bits=None, ppc=1, base=0,
                 line_period_s=None, clock_hz=100e6, capacity_bytes=CAPACITY_BYTES):
        from tdicam.model.ddr import psums_per_word
        from tdicam.model.tdi_ddr import tdi_ddr_check
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
        self._wb = max(16, self._wpl)
        self._beat_bits = ppc * pixel_bits + 7 + bits_for(max(self._j, 2) - 1) + ADDR_BITS
        self.layout = LineLayout(width=self._wpl * self._k, pixel_bits=self._psum_bits,
                                 pixels_per_word=self._k, base=base,
                                 line_stride=self._wpl * ADDR_PER_WORD)
        check_capacity(self.layout, max(stages - 1, 0), capacity_bytes, "partial-sum lines")
        super().__init__({**tdi_ports(pixel_bits, self._out_bits, stages, ppc),
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
    def buffer_bits(self):
        """Block RAM bits of the on-chip buffers (read-ahead, write-behind, decoded beats)."""
        return (2 * self._wpl * WORD_BITS + self._wb * (WORD_BITS + ADDR_BITS)
                + self.LOOKAHEAD * self._beat_bits)

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
        m.submodules.port = port = MigPort(rd_depth=2 * WPL)
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
        line_addr = wire("line_addr", self.layout.base + b.addr * (WPL * ADDR_PER_WORD), AW)
        word_addr = wire("word_addr", line_addr + e_wcol * ADDR_PER_WORD, AW)
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

        # a row descriptor (line address, use, hazard) with each decoded row-start beat;
        # hazard: the row reads the line the row before it writes
        m.submodules.rows = dq = SyncFIFOBuffered(width=AW + 2, depth=4)
        prev_line = Signal(AW)
        prev_wr = Signal()
        m.d.comb += [ctl.o_stream.ready.eq(bq.w_rdy & (~b.first | dq.w_rdy)),
                     bq.w_en.eq(ctl.o_stream.valid & ctl.o_stream.ready),
                     dq.w_en.eq(bq.w_en & b.first),
                     dq.w_data.eq(Cat(line_addr, b.use,
                                      b.use & prev_wr & (line_addr == prev_line)))]
        with m.If(dq.w_en):
            m.d.sync += [prev_line.eq(line_addr), prev_wr.eq(b.wr)]
        with m.If(bq.w_en):
            with m.If(e_wpos == J - 1):
                m.d.sync += [wpos.eq(0), wcol.eq(e_wcol + 1)]
            with m.Else():
                m.d.sync += [wpos.eq(e_wpos + 1), wcol.eq(e_wcol)]

        # ---- read engine: a row's words read as one block of words_per_line reads, once
        # the add stage has started the row before it (every write of older rows produced)
        # and the write-behind FIFO is empty (all of them queued), and with a hazard once
        # the add stage has finished the row before; no write is queued during the block
        d_line, d_use, d_haz = dq.r_data[:AW], dq.r_data[AW], dq.r_data[AW + 1]
        ahead = Signal(signed(16))      # rows popped here - rows started by the add stage
        in_row = Signal()               # the add stage is inside a row
        blk = Signal()
        blk_addr = Signal(AW)
        blk_left = Signal(range(WPL + 1))
        m.submodules.wbehind = wf = SyncFIFOBuffered(width=AW + WORD_BITS, depth=self._wb)
        may = wire("may", dq.r_rdy & ~blk & ~wf.level.any() & (ahead <= 0)
                   & (~d_haz | ~in_row))
        pop = wire("pop", dq.r_rdy & ~blk & (~d_use | may))
        m.d.comb += dq.r_en.eq(pop)
        with m.If(pop & d_use):
            m.d.sync += [blk.eq(1), blk_addr.eq(d_line), blk_left.eq(WPL)]
        m.d.comb += [port.rd_valid.eq(blk), port.rd_addr.eq(blk_addr)]
        with m.If(blk & port.rd_ready):
            m.d.sync += [blk_addr.eq(blk_addr + ADDR_PER_WORD), blk_left.eq(blk_left - 1)]
            with m.If(blk_left == 1):
                m.d.sync += blk.eq(0)
        m.d.comb += [port.wr_valid.eq(wf.r_rdy & ~blk), port.wr_addr.eq(wf.r_data[:AW]),
                     port.wr_data.eq(wf.r_data[AW:]), wf.r_en.eq(port.wr_valid & port.wr_ready)]

        # ---- add stage: head of the beat FIFO + its stored sums
        h_rd = wire("h_rd", q["use"] & ~q["wpos"].any())
        rword = Signal(WORD_BITS)
        psword = wire("psword", Mux(h_rd, port.rdata, rword), WORD_BITS)
        o_valid, o_first, o_last = Signal(), Signal(), Signal()
        o_data = Signal(PPC * OB)
        m.d.comb += [o.valid.eq(o_valid), Value.cast(o.payload.data).eq(o_data),
                     o.payload.first.eq(o_first), o.payload.last.eq(o_last)]
        # words a row's read block brought that its beats have not used (a row cut short by
        # a malformed frame): dropped before the next row starts
        rd_left = Signal(range(WPL + 1))
        drain = wire("drain", bq.r_rdy & q["first"] & rd_left.any())
        rd_ok = wire("rd_ok", ~h_rd | port.rdata_valid)
        out_ok = wire("out_ok", ~q["out"] | ~o_valid | o.ready)
        w_need = wire("w_need", q["wr"] & q["wend"])
        go = wire("go", bq.r_rdy & ~drain & rd_ok & out_ok & (~w_need | wf.w_rdy))
        m.d.comb += [bq.r_en.eq(go),
                     port.rdata_ready.eq((go & h_rd) | (drain & port.rdata_valid))]
        with m.If(drain & port.rdata_valid):
            m.d.sync += rd_left.eq(rd_left - 1)
        with m.Elif(go & h_rd):
            m.d.sync += rd_left.eq(Mux(q["first"], WPL - 1, rd_left - 1))
        started = wire("started", go & q["first"])
        m.d.sync += ahead.eq(ahead + pop - started)
        with m.If(go & q["last"]):
            m.d.sync += in_row.eq(0)
        with m.Elif(started):
            m.d.sync += in_row.eq(1)
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
        m.d.comb += [wf.w_en.eq(go & w_need), wf.w_data.eq(Cat(q["addr"], new_word))]
        with m.If(go & q["out"]):
            m.d.sync += [o_valid.eq(1), o_data.eq(Cat(*outs)),
                         o_first.eq(q["first"] & ~q["zero"]), o_last.eq(q["last"])]
        with m.Elif(o.ready):
            m.d.sync += o_valid.eq(0)
        return m
