"""Frame control of the digital TDI accumulator, shared by its memory back-ends.

:class:`TdiFrameControl` turns the input beats (m rows of W pixels per frame, tuser/tlast)
and the run-time settings into *decoded beats*: for each beat the partial-sum address it
reads and writes, whether the stored sum is used, whether the updated sum is written back or
output, and the output beat's markers. The on-chip accumulator
(:class:`tdicam.hdl.tdi.TdiAccumulator`) and the DDR one (``TdiDdr``) differ only in where
the partial sums live. The beat-level contract is :func:`tdicam.model.tdi.tdi_stream`.
"""

from amaranth.hdl import Array, Cat, Const, Module, Mux, Signal, Value, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out
from amaranth.utils import bits_for

from tdicam.model.tdi import check_params
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import saturating_increment

__all__ = ["TdiFrameControl", "beat_layout", "tdi_ports"]


def tdi_ports(pixel_bits, out_bits, stages, ppc):
    """The ports every TDI accumulator has, whatever holds its partial sums: ``ppc`` pixels
    in and out per beat, the run-time ``stages_active`` / ``direction`` and the
    ``frame_errors`` counter (a signature dict for ``wiring.Component.__init__``)."""
    return {
        "i_stream": In(pixel_signature(channels_shape(pixel_bits, ppc))),
        "o_stream": Out(pixel_signature(channels_shape(out_bits, ppc))),
        "stages_active": In(unsigned(bits_for(stages))),
        "direction": In(unsigned(1)),
        "frame_errors": Out(unsigned(16)),
    }

_WAIT, _RUN, _DROP, _PAD = range(4)   # frame states, each a flag register (one-hot)
_SLOTS = 3                            # pixel slots at ppc >= 2: the skid's, A's and B's beats


def _next_slot(k):
    return Mux(k == _SLOTS - 1, 0, k + 1)


def beat_layout(*, ppc, pixel_bits, addr_bits):
    """Layout of a decoded beat: ``data`` (``ppc`` pixels), ``addr`` (partial-sum address of
    the beat: line start + beat in row for ``stride = W/ppc``, the line for ``stride = 1``),
    ``use`` (add the stored sum), ``wr`` (write the new sum back), ``out`` (an output beat),
    ``first``/``last`` (first/last beat of its row), ``zero`` (padding: output zeros, touch
    no memory)."""
    return data.StructLayout({"data": unsigned(ppc * pixel_bits), "addr": unsigned(addr_bits),
                              "use": 1, "wr": 1, "out": 1, "first": 1, "last": 1, "zero": 1})


class TdiFrameControl(wiring.Component):
    """Row/frame counters, settings latch, refill and malformed-frame handling of the TDI
    accumulator, as a stream of decoded beats.

    Parameters
    ----------
    width, stages, pixel_bits, ppc : int
        As :class:`tdicam.hdl.tdi.TdiAccumulator` (checked the same way).
    stride : int
        Address step per partial-sum line: ``width // ppc`` (addresses count beats) or 1
        (addresses count lines; the back-end tracks the beat within a row from ``first``).
    row_cycles : int
        Fewest cycles between the first beats of two consecutive rows (default 2, the
        shortest row): a back-end whose write-back lands ``row_cycles`` after the read of
        the same address asks for it, and rows of fewer beats get idle cycles after them.

    Attributes
    ----------
    i_stream : In(pixel stream of ``ppc`` x ``pixel_bits``)
    stages_active, direction : In
        Sampled with each frame's tuser beat (see ``TdiAccumulator``).
    o_stream : Out(stream of :func:`beat_layout`)
        Decoded beats, registered. ``ready`` may depend combinationally on ``valid`` and the
        payload. Every beat reaches ``o_stream`` in input order; malformed frames give no
        beats except the zero padding that completes an output line already started.
    frame_errors : Out(16)
        Saturating count of malformed frames and invalid settings (counted one cycle after
        the beat that shows the error is decoded).

    Notes
    -----
    Partial-sum lines: ``stages - 1`` of them (``lines x stride`` addresses). Which line a
    row uses rotates by one per frame (a base pointer), so partial sums are never copied.
    Row r of a frame has age a (``m-1-r`` forward, ``r`` reverse): age 0 starts a sum
    (``use`` = 0), age m-1 completes it (``out``, ``wr`` = 0), the others add. A stored sum
    is used only if its ground line was first seen after the last (re)start of the fill, so
    stale memory never reaches the output. A settings change restarts the fill; malformed
    frames are dropped, counted, restart the fill, and an output line already started is
    completed with ``zero`` beats (:func:`tdicam.model.tdi.tdi_stream`). The decode of each
    beat uses only registers (per-row flags and address counters precomputed); a beat
    spends one cycle in the input register and one in the output register.
    ``i_stream.ready`` does not depend combinationally on ``o_stream.ready``; at ppc >= 2
    it is a register (a skid register beside the input register holds a beat accepted
    while the input register is held: the same beats and latency, ``ready`` low only while
    the skid is full).
    """

    def __init__(self, *, width, stages, pixel_bits=12, ppc=1, stride=None, row_cycles=2):
        check_params(width=width, stages=stages, pixel_bits=pixel_bits, ppc=ppc)
        self._width, self._stages, self._pixel_bits, self._ppc = width, stages, pixel_bits, ppc
        self._stride = width // ppc if stride is None else stride
        self._wide = ppc >= 2      # stage A of _wide_input
        self._row_cycles = row_cycles
        self._addr_bits = max(1, bits_for(max((stages - 1) * self._stride - 1, 0)))
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, ppc))),
            "stages_active": In(unsigned(bits_for(stages))),
            "direction": In(unsigned(1)),
            "o_stream": Out(stream.Signature(beat_layout(ppc=ppc, pixel_bits=pixel_bits,
                                                         addr_bits=self._addr_bits))),
            "frame_errors": Out(unsigned(16)),
        })

    stride = property(lambda self: self._stride, doc="Address step per partial-sum line.")
    addr_bits = property(lambda self: self._addr_bits, doc="Width of the beats' ``addr``.")
    row_cycles = property(lambda self: self._row_cycles,
                          doc="Fewest cycles from a row's first beat to the next row's.")

    def _settings(self, regs, first, last, sa, sd):
        """Stage A's loads of a beat's markers and its settings, predecoded."""
        M = self._stages
        ok = sa.any()
        if M < (1 << len(sa)) - 1:
            ok &= sa <= M
        if M >= 2:
            ok &= ~(sd & (sa == M))
        a_first, a_last, a_m, a_dir, a_m1, a_ok, a_lines = regs
        return [a_first.eq(first), a_last.eq(last), a_m.eq(sa), a_dir.eq(sd),
                a_m1.eq(sa - 1), a_ok.eq(ok), a_lines.eq(Mux(sa == 1, 0, sa - 1 + sd))]

    def _wide_input(self, m, wire, a_take, a_valid, regs):
        """Stage A at ppc >= 2: ``i_stream.ready`` a register, and the pixels on no decoded
        clock enable. A skid register holds the markers and settings of a beat accepted
        while A is held (``ready`` is low only while it is full); the pixels go into one of
        three slots on acceptance, in turn, and stay there until the beat leaves B (the
        skid's, A's and B's beats never share one). Returns A's slot."""
        i = self.i_stream
        beat = [i.payload.first, i.payload.last, self.stages_active, self.direction]
        skid = [Signal.like(v, name=f"skid_{k}") for k, v in enumerate(beat)]
        skid_valid = Signal()
        a_free = wire("a_free", ~a_valid | a_take)
        accept = wire("accept", i.valid & ~skid_valid)
        m.d.comb += i.ready.eq(~skid_valid)
        with m.If(a_free):
            m.d.sync += skid_valid.eq(0)
        with m.Elif(accept):
            m.d.sync += skid_valid.eq(1)
        with m.If(accept):      # (unused unless skid_valid is set with it)
            m.d.sync += [r.eq(v) for r, v in zip(skid, beat)]
        pixels = Value.cast(i.payload.data)
        self._slots = [Signal(len(pixels), name=f"a_slot{k}") for k in range(_SLOTS)]
        w_slot, a_slot = Signal(range(_SLOTS)), Signal(range(_SLOTS), init=_SLOTS - 1)
        with m.If(a_free & (skid_valid | i.valid)):
            m.d.sync += [a_valid.eq(1), a_slot.eq(_next_slot(a_slot)),
                         *self._settings(regs, *(Mux(skid_valid, r, v)
                                                 for r, v in zip(skid, beat)))]
        with m.Elif(a_take):
            m.d.sync += a_valid.eq(0)
        with m.If(accept):
            m.d.sync += w_slot.eq(_next_slot(w_slot))
            for k, slot in enumerate(self._slots):
                with m.If(w_slot == k):
                    m.d.sync += slot.eq(pixels)
        return a_slot

    def elaborate(self, platform):
        m = Module()
        M, PB, PPC = self._stages, self._pixel_bits, self._ppc
        WB = self._width // PPC
        S = self._stride
        aw = self._addr_bits
        mb = bits_for(M)
        i, o = self.i_stream, self.o_stream

        def wire(name, value, shape=1):
            w = Signal(shape, name=name)
            m.d.comb += w.eq(value)
            return w

        # ---- stage A: input register (beat + the settings presented with it, predecoded)
        a_valid = Signal()
        a_first, a_last, a_dir = Signal(), Signal(), Signal()
        a_m = Signal(len(self.stages_active))
        a_m1 = Signal(mb)         # m - 1
        a_ok = Signal()           # the settings are valid
        a_lines = Signal(mb)      # partial-sum lines the settings use (m-1 forward, m reverse)
        a_take = Signal()
        if self._wide:
            a_slot = self._wide_input(m, wire, a_take, a_valid,
                                      [a_first, a_last, a_m, a_dir, a_m1, a_ok, a_lines])
        else:
            a_data = Signal(PPC * PB)
            m.d.comb += i.ready.eq(~a_valid | a_take)
            with m.If(i.valid & i.ready):
                m.d.sync += [a_valid.eq(1), a_data.eq(Value.cast(i.payload.data)),
                             *self._settings([a_first, a_last, a_m, a_dir, a_m1, a_ok, a_lines],
                                             i.payload.first, i.payload.last,
                                             self.stages_active, self.direction)]
            with m.Elif(a_take):
                m.d.sync += a_valid.eq(0)

        # ---- control state: one flag per state, and idle (_WAIT or _DROP)
        st = [Signal(init=k == _WAIT, name=f"st_{n}")
              for k, n in enumerate(("wait", "run", "drop", "pad"))]
        st_idle = Signal(init=1)

        def goto(k):
            return [*(f.eq(j == k) for j, f in enumerate(st)),
                    st_idle.eq(k in (_WAIT, _DROP))]
        m_reg = Signal(mb)
        m1_reg = Signal(mb)       # m_reg - 1
        dir_reg = Signal()
        run = Signal(mb)          # well-formed frames in the current run (saturates at M)
        f = Signal(mb)            # run at the start of the current frame
        col = Signal(range(WB))
        col_last = Signal()       # col == WB - 1
        col_zero = Signal(init=1)  # col == 0
        line_open = Signal()      # r_out & out_en & (col != 0): the current frame's output
                                  # line has started (meaningful in _RUN)
        # the current row (of age m-1-r forward, r reverse; the next row's age is age_next,
        # below): whether it is the output row, uses the stored sum, is the frame's last row;
        # whether this frame outputs
        r_out, r_use, r_last, out_en = Signal(), Signal(), Signal(), Signal()
        base = Signal(aw)         # first address of the line row 0 uses this frame
        bnext = Signal(aw)        # base's successor (registered: base changes >= 2 cycles apart)
        row_addr = Signal(aw)     # first address of the current row's line
        cur = Signal(aw)          # address of the current row's next beat
        # the last line's first address, (lines in use - 1) x stride (0 when none is in
        # use): x + S < lines x stride is x < lim_s, no adder before the compare
        lim_s = Signal(bits_for((M - 1) * S))
        pad_col = Signal(range(WB))
        errors = Signal(16)
        m.d.comb += self.frame_errors.eq(errors)

        # ---- stage B: the decoded beat (o_stream)
        b_valid, b_use, b_wr, b_out, b_first, b_last, b_zero = (Signal() for _ in range(7))
        if self._wide:            # B's pixels: its beat's slot
            b_slot = Signal(range(_SLOTS))
            b_data = wire("b_data", Array(self._slots)[b_slot], PPC * PB)
        else:
            b_data = Signal(PPC * PB)
        b_addr = Signal(aw)
        gap_cycles = max(0, self._row_cycles - WB)
        gap = Signal(range(gap_cycles + 1)) if gap_cycles else Const(0, 1)
        p = o.payload
        m.d.comb += [o.valid.eq(b_valid & ~gap.any()), p.data.eq(b_data), p.addr.eq(b_addr),
                     p.use.eq(b_use), p.wr.eq(b_wr), p.out.eq(b_out), p.first.eq(b_first),
                     p.last.eq(b_last), p.zero.eq(b_zero)]
        b_adv = wire("b_adv", o.valid & o.ready)
        b_can = wire("b_can", ~b_valid | b_adv)

        # ---- decode A's beat: a frame's first beat from A's predecoded settings, the
        # others from the current row's registers
        start = a_first
        same = wire("same", (a_m == m_reg) & (a_dir == dir_reg) & run.any())
        base_step = wire("base_step", base + S, aw + 1)
        step_in_row = 1 if S > 1 else 0      # addresses count beats, or lines
        # bnext + step_in_row, registered with it: a new frame's second beat's address
        bnext_cur = Signal(aw)
        m.d.sync += [bnext.eq(Mux(base < lim_s, base_step, 0)),
                     bnext_cur.eq(Mux(base < lim_s, base + (S + step_in_row), step_in_row))]
        base_next = wire("base_next", Mux(same, bnext, 0), aw)
        s_f = wire("s_f", Mux(same, run, 0), mb)            # f of a new frame
        m1_zero = wire("m1_zero", ~a_m1.any())
        fill = wire("fill", a_m1 <= run)
        # row 0: age m-1 forward (the output row), 0 reverse
        s_out = wire("s_out", ~a_dir | m1_zero)
        s_out_en = wire("s_out_en", Mux(same, fill, m1_zero))
        s_use = wire("s_use", ~a_dir & same & ~m1_zero & fill)
        e_out = wire("e_out", Mux(start, s_out, r_out))
        e_use = wire("e_use", Mux(start, s_use, r_use))
        e_out_en = wire("e_out_en", Mux(start, s_out_en, out_en))
        e_addr = wire("e_addr", Mux(start, base_next, cur), aw)
        last_col = wire("last_col", ~start & col_last)     # a row has >= 2 beats
        frame_end = wire("frame_end", last_col & r_last)
        s_run, s_pad = st[_RUN], st[_PAD]

        # A's beat: the frame's first, with valid settings, no tlast (a_go) or not (a_bad),
        # or its row's next (tlast where col_last says, or an anomaly)
        a_go = wire("a_go", a_first & a_ok & ~a_last)
        a_bad = wire("a_bad", a_first & ~(a_ok & ~a_last))
        a_tl = wire("a_tl", a_last == col_last)
        step = wire("step", a_valid & b_can & ((st_idle & a_go) | (s_run & ~a_first & a_tl)))
        cut = wire("cut", a_valid & a_first & s_run)
        invalid = wire("invalid", a_valid & st_idle & a_first & ~a_ok)
        stray = wire("stray", a_valid & st_idle & ~a_first)
        anomaly = wire("anomaly", a_valid & ((st_idle & a_bad & a_ok) | (s_run & ~a_first & ~a_tl)))
        pad_now = wire("pad_now", s_pad & b_can)
        error = wire("error", cut | invalid | anomaly | (stray & st[_WAIT]))

        counted = Signal()        # error, registered: the count follows one cycle later
        m.d.sync += counted.eq(error)
        with m.If(error):
            m.d.sync += run.eq(0)
        with m.If(counted):
            saturating_increment(m, errors)
        with m.If(cut | (anomaly & ~start)):
            with m.If(line_open):
                m.d.sync += [*goto(_PAD), pad_col.eq(col)]
            with m.Else():
                m.d.sync += goto(_DROP)
        with m.If((anomaly & start) | invalid | stray):
            m.d.sync += goto(_DROP)
        m.d.comb += a_take.eq(a_valid & (
            (st_idle & (~a_first | a_bad | (a_go & b_can))) |
            (s_run & ~a_first & Mux(a_tl, b_can, ~line_open))))

        # the next row, from registers (a row's last beat is never a frame's first)
        fwd = wire("fwd", row_addr + S, aw + 1)
        nxt_fwd = wire("nxt_fwd", Mux(row_addr < lim_s, fwd, 0), aw)
        nxt_rev = wire("nxt_rev", Mux(row_addr.any(), row_addr - S, lim_s), aw)
        row_next = wire("row_next", Mux(dir_reg, nxt_rev, nxt_fwd), aw)
        # the next row's age, a register kept one row ahead (no adder before the compares
        # of r_out / r_use / r_last): set at a frame's first beat, stepped at a row's end
        age_next = Signal(mb, init=(1 << mb) - 1, name="age_next")
        # lines x stride without a multiplier: a sum of shifted copies
        lim_new = sum((a_lines << k for k in range(S.bit_length()) if S >> k & 1), Const(0))
        with m.If(step):
            with m.If(start):
                m.d.sync += [m_reg.eq(a_m), m1_reg.eq(a_m1), dir_reg.eq(a_dir), f.eq(s_f),
                             base.eq(base_next), lim_s.eq(Mux(a_lines.any(), lim_new - S, 0)),
                             age_next.eq(Mux(a_dir, 1, a_m1 - 1)),
                             r_out.eq(s_out), r_use.eq(s_use), r_last.eq(m1_zero),
                             out_en.eq(s_out_en), col.eq(1), col_last.eq(WB == 2),
                             col_zero.eq(0), line_open.eq(s_out & s_out_en),
                             row_addr.eq(base_next),
                             cur.eq(Mux(same, bnext_cur, step_in_row))]
            with m.Elif(last_col):
                m.d.sync += [col.eq(0), col_last.eq(0), col_zero.eq(1), line_open.eq(0),
                             row_addr.eq(row_next),
                             cur.eq(row_next),
                             age_next.eq(Mux(dir_reg, age_next + 1, age_next - 1)),
                             r_out.eq(age_next == m1_reg),
                             r_use.eq(age_next.any() & (age_next <= f)),
                             r_last.eq(Mux(dir_reg, age_next == m1_reg, ~age_next.any()))]
            with m.Else():
                m.d.sync += [col.eq(col + 1), col_last.eq(col == WB - 2), col_zero.eq(0),
                             line_open.eq(r_out & out_en),
                             cur.eq(cur + step_in_row)]
            with m.If(frame_end):
                m.d.sync += [*goto(_WAIT), run.eq(Mux(f == M, M, f + 1))]
            with m.Else():
                m.d.sync += goto(_RUN)
        with m.If(pad_now):
            m.d.sync += pad_col.eq(pad_col + 1)
            with m.If(pad_col == WB - 1):
                m.d.sync += goto(_DROP)

        with m.If(step):
            m.d.sync += [b_valid.eq(1),
                         b_slot.eq(a_slot) if self._wide else b_data.eq(a_data),
                         b_addr.eq(e_addr),
                         b_use.eq(e_use), b_wr.eq(~e_out), b_out.eq(e_out & e_out_en),
                         b_first.eq(start | col_zero), b_last.eq(last_col), b_zero.eq(0)]
        with m.Elif(pad_now):
            m.d.sync += [b_valid.eq(1), b_use.eq(0), b_wr.eq(0), b_out.eq(1), b_first.eq(0),
                         b_last.eq(pad_col == WB - 1), b_zero.eq(1)]
        with m.Elif(b_adv):
            m.d.sync += b_valid.eq(0)
        if gap_cycles:
            # rows shorter than row_cycles: idle cycles after each row
            with m.If(b_adv & b_last):
                m.d.sync += gap.eq(gap_cycles)
            with m.Elif(gap.any()):
                m.d.sync += gap.eq(gap - 1)

        self.probe = {"state": Cat(*st), "run": run}
        return m
