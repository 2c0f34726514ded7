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
from .util import equals, mux_select, quiet_reject, saturating_increment

__all__ = ["TdiDdr"]

_WAIT, _RUN, _DROP, _PAD = range(4)


class TdiDdr(wiring.Component):
    """The optimized TDI accumulator with its ``stages - 1`` partial-sum lines in DDR.

    Same parameters, ports, settings, error handling and output, beat for beat, as
    :class:`tdicam.hdl.tdi.TdiAccumulator` (golden model :func:`tdicam.model.tdi.tdi_stream`;
    the frame control below is that block's, with addresses counted in lines), plus the MIG
    user-interface ports. Refuses (one-line :class:`TdicamError`) configurations checked by
    :func:`tdicam.model.ddr.tdi_ddr_check` (rows shorter than the read look-ahead; with
    ``line_period_s``, DDR bandwidth or clock short for ``stages``).

    Partial sums in DDR: :func:`tdicam.model.ddr.psums_per_word` sums of :attr:`psum_bits`
    per 256-bit word (sum j of a word at bits ``[j*psum_bits +: psum_bits]``), line ``s`` at
    ``base + s * words_per_line * 8``. Per word of a row: one read (queued when the row's
    beat that starts the word is decoded, only for rows that add a stored sum) and one write
    (when its last beat has been added, except on the output row).

    Pipeline: stage A (input register) -> decode (the frame control) -> a FIFO of
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
        WB = W // PPC
        PS, OB, J, WPL = self._psum_bits, self._out_bits, self._j, self._wpl
        AW = ADDR_BITS
        mb = bits_for(M)
        i, o = self.i_stream, self.o_stream
        m.submodules.port = port = MigPort()
        connect_mig(m, port, self)

        def wire(name, value, shape=1):
            w = Signal(shape, name=name)
            m.d.comb += w.eq(value)
            return w

        # ---- stage A: input register (beat + the settings presented with it)
        a_valid = Signal()
        a_data = Signal(PPC * PB)
        a_first, a_last, a_dir = Signal(), Signal(), Signal()
        a_m = Signal(len(self.stages_active))
        a_take = Signal()
        m.d.comb += i.ready.eq(~a_valid | a_take)
        with m.If(i.valid & i.ready):
            m.d.sync += [a_valid.eq(1), a_data.eq(Value.cast(i.payload.data)),
                         a_first.eq(i.payload.first), a_last.eq(i.payload.last),
                         a_m.eq(self.stages_active), a_dir.eq(self.direction)]
        with m.Elif(a_take):
            m.d.sync += a_valid.eq(0)

        # ---- control state (TdiAccumulator's, addresses in lines)
        state = Signal(2, init=_WAIT)
        m_reg = Signal(mb)
        dir_reg = Signal()
        run = Signal(mb)
        f = Signal(mb)
        row = Signal(mb)
        col = Signal(range(WB))
        wcol = Signal(range(WPL))
        wpos = Signal(range(max(J, 2)))
        base = Signal(mb)          # line row 0 uses this frame
        row_line = Signal(mb)      # line of the current row
        lim = Signal(mb)           # lines in use
        pad_col = Signal(range(WB))
        errors = Signal(16)
        m.d.comb += self.frame_errors.eq(errors)

        # decoded-beat FIFO: data, use, wr, out, first, last, zero, wpos, wend, word addr
        fields = [("data", PPC * PB), ("use", 1), ("wr", 1), ("out", 1), ("first", 1),
                  ("last", 1), ("zero", 1), ("wpos", len(wpos)), ("wend", 1), ("addr", AW)]
        fw = sum(w for _, w in fields)
        m.submodules.beats = bq = SyncFIFOBuffered(width=fw, depth=self.LOOKAHEAD)
        q_in = {n: Signal(w, name=f"q_{n}") for n, w in fields}
        m.d.comb += bq.w_data.eq(Cat(*(q_in[n] for n, _ in fields)))
        q = {}
        off = 0
        for n, w in fields:
            q[n] = bq.r_data[off:off + w]
            off += w

        # ---- decode A's beat
        start = a_first
        new_ok = a_m.any()
        if M < (1 << len(a_m)) - 1:
            new_ok &= a_m <= M
        if M >= 2:
            new_ok &= ~(a_dir & (a_m == M))
        new_ok = wire("new_ok", new_ok)
        same = wire("same", (a_m == m_reg) & (a_dir == dir_reg) & run.any())
        base_step = wire("base_step", base + 1, mb + 1)
        base_next = wire("base_next", Mux(same & (base_step < lim), base_step, 0), mb)
        e_m = wire("e_m", Mux(start, a_m, m_reg), mb)
        e_dir = wire("e_dir", Mux(start, a_dir, dir_reg))
        e_f = wire("e_f", Mux(start, Mux(same, run, 0), f), mb)
        e_row = wire("e_row", Mux(start, 0, row), mb)
        e_col = wire("e_col", Mux(start, 0, col), range(WB))
        e_wcol = wire("e_wcol", Mux(start, 0, wcol), range(WPL))
        e_wpos = wire("e_wpos", Mux(start, 0, wpos), len(wpos))
        e_line = wire("e_line", Mux(start, base_next, row_line), mb)
        age = wire("age", Mux(e_dir, e_row, e_m - 1 - e_row), mb)
        out_row = wire("out_row", age == e_m - 1)
        out_en = wire("out_en", e_f >= e_m - 1)
        use_mem = wire("use_mem", age.any() & (age <= e_f))
        last_col = wire("last_col", e_col == WB - 1)
        tlast_ok = wire("tlast_ok", a_last == last_col)
        frame_end = wire("frame_end", last_col & (e_row == e_m - 1))
        line_open = wire("line_open", (Mux(dir_reg, row, m_reg - 1 - row) == m_reg - 1)
                         & (f >= m_reg - 1) & col.any())
        need_rd = wire("need_rd", use_mem & ~e_wpos.any())
        word_addr = wire("word_addr", self.layout.base
                         + (e_line * WPL + e_wcol) * ADDR_PER_WORD, AW)
        b_can = wire("b_can", bq.w_rdy & (~need_rd | port.rd_ready))

        busy = wire("busy", a_valid & (state != _PAD))
        proc = wire("proc", busy & Mux(start, (state != _RUN) & new_ok, state == _RUN))
        cut = wire("cut", busy & start & (state == _RUN))
        invalid = wire("invalid", busy & start & (state != _RUN) & ~new_ok)
        stray = wire("stray", busy & ~start & (state != _RUN))
        anomaly = wire("anomaly", proc & ~tlast_ok)
        step = wire("step", proc & tlast_ok & b_can)
        pad_now = wire("pad_now", (state == _PAD) & bq.w_rdy)
        error = wire("error", cut | invalid | anomaly | (stray & ~state.any()))

        with m.If(error):
            m.d.sync += run.eq(0)
            saturating_increment(m, errors)
        with m.If(cut | (anomaly & ~start)):
            with m.If(line_open):
                m.d.sync += [state.eq(_PAD), pad_col.eq(col)]
            with m.Else():
                m.d.sync += state.eq(_DROP)
        with m.If(anomaly & start):
            m.d.sync += state.eq(_DROP)
        with m.If(invalid | stray):
            m.d.sync += state.eq(_DROP)
        m.d.comb += a_take.eq(step | invalid | stray | (anomaly & (start | ~line_open)))

        n_new = Mux(a_m == 1, 0, a_m - 1 + a_dir)
        nxt_fwd = wire("nxt_fwd", Mux(e_line + 1 < lim, e_line + 1, 0), mb)
        nxt_rev = wire("nxt_rev", Mux(e_line.any(), e_line - 1, Mux(lim.any(), lim - 1, 0)), mb)
        wend = wire("wend", (e_wpos == J - 1) | last_col)
        with m.If(step):
            with m.If(start):
                m.d.sync += [m_reg.eq(a_m), dir_reg.eq(a_dir), f.eq(e_f), base.eq(base_next),
                             lim.eq(n_new)]
            with m.If(last_col):
                m.d.sync += [col.eq(0), wcol.eq(0), wpos.eq(0), row.eq(e_row + 1),
                             row_line.eq(Mux(e_dir, nxt_rev, nxt_fwd))]
            with m.Else():
                m.d.sync += [col.eq(e_col + 1), row.eq(e_row), row_line.eq(e_line)]
                with m.If(e_wpos == J - 1):
                    m.d.sync += [wpos.eq(0), wcol.eq(e_wcol + 1)]
                with m.Else():
                    m.d.sync += [wpos.eq(e_wpos + 1), wcol.eq(e_wcol)]
            with m.If(frame_end):
                m.d.sync += [state.eq(_WAIT), run.eq(Mux(e_f == M, M, e_f + 1))]
            with m.Else():
                m.d.sync += state.eq(_RUN)
        with m.If(pad_now):
            m.d.sync += pad_col.eq(pad_col + 1)
            with m.If(pad_col == WB - 1):
                m.d.sync += state.eq(_DROP)

        # read request with the decoded beat that starts a word of a row that adds
        m.d.comb += [port.rd_valid.eq(proc & tlast_ok & bq.w_rdy & need_rd),
                     port.rd_addr.eq(word_addr)]
        m.d.comb += [
            bq.w_en.eq(step | pad_now),
            q_in["data"].eq(a_data), q_in["use"].eq(step & use_mem),
            q_in["wr"].eq(step & ~out_row), q_in["out"].eq(Mux(step, out_row & out_en, 1)),
            q_in["first"].eq(step & ~e_col.any()),
            q_in["last"].eq(Mux(step, last_col, pad_col == WB - 1)),
            q_in["zero"].eq(~step), q_in["wpos"].eq(e_wpos), q_in["wend"].eq(wend),
            q_in["addr"].eq(word_addr),
        ]

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
