"""Optimized digital TDI accumulator (SPEC 3.1; seeds 000 §3.2 Fig. 8, 001 §3.1, 003 §2.2).

Golden model: :mod:`tdicam.model.tdi` (:func:`~tdicam.model.tdi.tdi_stream` is the beat-level
contract this component implements bit for bit).
"""

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, unsigned
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out
from amaranth.utils import bits_for

from tdicam.model.tdi import check_params, full_bits, out_width
from .stream import channels_shape, pixel_signature

__all__ = ["TdiAccumulator"]

_WAIT, _RUN, _DROP, _PAD = range(4)   # (x == 0 written ~x.any(): yosys prints x == 0 as !x)


class TdiAccumulator(wiring.Component):
    """Digital TDI: each output line is the sum of m rows from m consecutive frames.

    Parameters
    ----------
    width : int
        Pixels per line W, 2*ppc..8192, a multiple of ``ppc``.
    stages : int
        m_max, the largest stage count, 1..128. Sizes the partial-sum memory.
    pixel_bits : int
        Input pixel width, 8..14.
    out_bits : int or None
        Saturate the output at ``2**out_bits - 1`` (``pixel_bits .. full width``); None: full
        width ``pixel_bits + ceil(log2(stages))``, never saturates, never wraps.
    ppc : int
        Pixels per clock (per beat): 1, 2, 4 or 8.

    Attributes
    ----------
    i_stream : In(pixel stream of ``ppc`` x ``pixel_bits``)
        One frame per line period: m rows (readout order 1..m) of W pixels; ``first`` (tuser)
        on the frame's first beat, ``last`` (tlast) on the last beat of every row.
    o_stream : Out(pixel stream of ``ppc`` x :attr:`out_bits`)
        One line of W pixels per frame once m frames have been seen; ``first`` on its first
        beat, ``last`` on its last.
    stages_active : In(unsigned(bits_for(stages)))
        m, sampled with the tuser beat of each frame. Valid: 1..stages (reverse direction:
        1..stages-1, or 1; see :func:`~tdicam.model.tdi.settings_valid`).
    direction : In(1)
        0: ground line seen first by row m (seed 000 eq 3); 1: reverse scan, rows mirrored.
        Sampled with the tuser beat.
    frame_errors : Out(16)
        Saturating count of malformed frames and invalid settings (each also restarts the
        fill), see :func:`~tdicam.model.tdi.tdi_stream`.

    Notes
    -----
    *Structure.* On-chip memory of exactly ``stages - 1`` partial-sum lines of W words of
    :attr:`psum_bits`: ``ppc`` banks (one per pixel lane, ``(stages-1) * W/ppc`` words
    each), each with one synchronous read port and one write port sharing the address
    (``lib.memory``; word width stays :attr:`psum_bits` whatever ``ppc``). Every input row
    reads one line and writes its update back to the same address one cycle later
    (read-modify-write: one read and one write per bank per beat, never to the same address
    in the same cycle since a row is at least 2 beats); which line a row uses rotates by one
    per frame (a base pointer), so partial sums are never copied. Row r of a frame has age a
    (``m-1-r`` forward, ``r`` reverse): age 0 starts a sum (the memory read is ignored), age
    m-1 completes it (the output row, nothing written), the others add. A stored sum is only
    used if its ground line was first seen after the last (re)start, so stale memory never
    reaches the output and the memory needs no clearing.

    *Settings.* ``stages_active`` and ``direction`` are latched with each frame's tuser beat;
    a change restarts the fill: the next m frames produce no output, no line mixes two
    settings. Malformed frames are handled as documented in
    :func:`~tdicam.model.tdi.tdi_stream` (dropped, counted in :attr:`frame_errors`, fill
    restarted, a started output line completed with zeros).

    *Reverse scan* needs m partial-sum lines for m stages (see
    :func:`~tdicam.model.tdi.slots_needed`), so with ``stages - 1`` lines it runs up to
    ``stages - 1`` stages; ``direction = 1`` with ``stages_active = stages`` is an invalid
    setting (frame dropped and counted).

    *Throughput and latency.* ``ppc`` pixels per clock sustained while ``o_stream.ready`` is
    high: a 3-stage pipeline (input register, memory read, output register with a skid
    buffer). Input rows that produce no output (all but one per frame) flow at full rate even
    while the output is stalled. ``i_stream.ready`` depends only on registers (no
    combinational path from ``o_stream.ready``). No beat is lost or duplicated whatever
    ``ready`` does. :attr:`latency` = 3 cycles from an output-row input beat's transfer to its
    output beat being valid.

    Raises
    ------
    TdicamError
        On bad parameters (one line, before elaboration).
    """

    def __init__(self, *, width, stages, pixel_bits=12, out_bits=None, ppc=1, _psum_bits=None):
        check_params(width=width, stages=stages, pixel_bits=pixel_bits, out_bits=out_bits,
                     ppc=ppc)
        self._width = width
        self._stages = stages
        self._pixel_bits = pixel_bits
        self._ppc = ppc
        self._out_bits = out_width(pixel_bits, stages, out_bits)
        self._saturate = out_bits is not None
        # _psum_bits: test hook only (a deliberately too narrow, wrapping mutant)
        self._psum_bits = full_bits(pixel_bits, stages) if _psum_bits is None else _psum_bits
        self.memories = []
        self.probe = {}
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, ppc))),
            "o_stream": Out(pixel_signature(channels_shape(self._out_bits, ppc))),
            "stages_active": In(unsigned(bits_for(stages))),
            "direction": In(unsigned(1)),
            "frame_errors": Out(unsigned(16)),
        })

    width = property(lambda self: self._width, doc="Pixels per line W.")
    stages = property(lambda self: self._stages, doc="m_max.")
    pixel_bits = property(lambda self: self._pixel_bits)
    ppc = property(lambda self: self._ppc, doc="Pixels per clock.")
    out_bits = property(lambda self: self._out_bits, doc="Output pixel width.")
    saturating = property(lambda self: self._saturate,
                          doc="True when the output saturates at 2**out_bits - 1.")
    psum_bits = property(lambda self: self._psum_bits, doc="Partial-sum word width.")

    @property
    def latency(self):
        """Cycles from an input beat's transfer to the matching output beat being valid."""
        return 3

    @property
    def memory_lines(self):
        """Partial-sum lines held on chip: ``stages - 1``."""
        return self._stages - 1

    @property
    def memory_shape(self):
        """(banks, depth, word bits) of the partial-sum memory: ``ppc`` banks of
        ``(stages-1) * W/ppc`` words of :attr:`psum_bits` (bank k holds pixel lane k)."""
        return (self._ppc, self.memory_lines * (self._width // self._ppc), self._psum_bits)

    def elaborate(self, platform):
        m = Module()
        W, M, PB, PPC = self._width, self._stages, self._pixel_bits, self._ppc
        WB = W // PPC
        PS, OB = self._psum_bits, self._out_bits
        depth = (M - 1) * WB
        aw = max(1, bits_for(max(depth - 1, 0)))
        mb = bits_for(M)
        i, o = self.i_stream, self.o_stream

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

        # ---- control state
        state = Signal(2, init=_WAIT)
        m_reg = Signal(mb)
        dir_reg = Signal()
        run = Signal(mb)          # well-formed frames in the current run (saturates at M)
        f = Signal(mb)            # run at the start of the current frame
        row = Signal(mb)
        col = Signal(range(WB))
        base = Signal(aw)         # first address of the line row 0 uses this frame
        row_addr = Signal(aw)     # first address of the current row's line
        lim = Signal(bits_for(depth))  # lines in use x WB
        pad_col = Signal(range(WB))
        errors = Signal(16)
        m.d.comb += self.frame_errors.eq(errors)

        # ---- stage B: memory read data + beat; output skid buffer
        b_valid, b_use, b_wr, b_out, b_first, b_last, b_zero = (Signal() for _ in range(7))
        b_data = Signal(PPC * PB)
        b_addr = Signal(aw)
        sk_valid = Signal()
        def wire(name, value, shape=1):
            w = Signal(shape, name=name)
            m.d.comb += w.eq(value)
            return w

        b_adv = wire("b_adv", b_valid & (~b_out | ~sk_valid))
        b_can = wire("b_can", ~b_valid | b_adv)

        # ---- decode A's beat
        start = a_first
        new_ok = a_m.any()
        if M < (1 << len(a_m)) - 1:
            new_ok &= a_m <= M
        if M >= 2:
            new_ok &= ~(a_dir & (a_m == M))
        new_ok = wire("new_ok", new_ok)
        same = wire("same", (a_m == m_reg) & (a_dir == dir_reg) & run.any())
        base_step = wire("base_step", base + WB, aw + 1)
        base_next = wire("base_next", Mux(same & (base_step < lim), base_step, 0), aw)
        e_m = wire("e_m", Mux(start, a_m, m_reg), mb)
        e_dir = wire("e_dir", Mux(start, a_dir, dir_reg))
        e_f = wire("e_f", Mux(start, Mux(same, run, 0), f), mb)
        e_row = wire("e_row", Mux(start, 0, row), mb)
        e_col = wire("e_col", Mux(start, 0, col), range(WB))
        e_rowaddr = wire("e_rowaddr", Mux(start, base_next, row_addr), aw)
        age = wire("age", Mux(e_dir, e_row, e_m - 1 - e_row), mb)
        out_row = wire("out_row", age == e_m - 1)
        out_en = wire("out_en", e_f >= e_m - 1)
        use_mem = wire("use_mem", age.any() & (age <= e_f))
        last_col = wire("last_col", e_col == WB - 1)
        tlast_ok = wire("tlast_ok", a_last == last_col)
        frame_end = wire("frame_end", last_col & (e_row == e_m - 1))
        # the current frame's output line has started (only meaningful in _RUN)
        line_open = wire("line_open", (Mux(dir_reg, row, m_reg - 1 - row) == m_reg - 1)
                         & (f >= m_reg - 1) & col.any())

        busy = wire("busy", a_valid & (state != _PAD))
        proc = wire("proc", busy & Mux(start, (state != _RUN) & new_ok, state == _RUN))
        cut = wire("cut", busy & start & (state == _RUN))
        invalid = wire("invalid", busy & start & (state != _RUN) & ~new_ok)
        stray = wire("stray", busy & ~start & (state != _RUN))
        anomaly = wire("anomaly", proc & ~tlast_ok)
        step = wire("step", proc & tlast_ok & b_can)
        pad_now = wire("pad_now", (state == _PAD) & b_can)
        error = wire("error", cut | invalid | anomaly | (stray & ~state.any()))  # _WAIT == 0

        with m.If(error):
            m.d.sync += run.eq(0)
            with m.If(errors != 0xFFFF):
                m.d.sync += errors.eq(errors + 1)
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
        nxt_fwd = wire("nxt_fwd", Mux(e_rowaddr + WB < lim, e_rowaddr + WB, 0), aw)
        nxt_rev = wire("nxt_rev", Mux(e_rowaddr.any(), e_rowaddr - WB,
                                      Mux(lim.any(), lim - WB, 0)), aw)
        with m.If(step):
            with m.If(start):
                m.d.sync += [m_reg.eq(a_m), dir_reg.eq(a_dir), f.eq(e_f), base.eq(base_next),
                             lim.eq(n_new * WB)]
            with m.If(last_col):
                m.d.sync += [col.eq(0), row.eq(e_row + 1),
                             row_addr.eq(Mux(e_dir, nxt_rev, nxt_fwd))]
            with m.Else():
                m.d.sync += [col.eq(e_col + 1), row.eq(e_row), row_addr.eq(e_rowaddr)]
            with m.If(frame_end):
                m.d.sync += [state.eq(_WAIT), run.eq(Mux(e_f == M, M, e_f + 1))]
            with m.Else():
                m.d.sync += state.eq(_RUN)
        with m.If(pad_now):
            m.d.sync += pad_col.eq(pad_col + 1)
            with m.If(pad_col == WB - 1):
                m.d.sync += state.eq(_DROP)

        # ---- memory: exactly (M-1) lines x W words of PS bits, one bank per pixel lane
        # (bank k holds pixels k, k+PPC, ...; all banks share the address)
        self.memories = []
        if depth:
            addr = wire("addr", e_rowaddr + e_col, aw)
            rds, wrs = [], []
            for k in range(PPC):
                mem = Memory(shape=unsigned(PS), depth=depth, init=[])
                m.submodules[f"psum{k}"] = mem
                self.memories.append(mem)
                rd, wr = mem.read_port(), mem.write_port()
                m.d.comb += [rd.addr.eq(addr), rd.en.eq(step)]
                rds.append(rd)
                wrs.append(wr)
            mem_word = Cat(*(rd.data for rd in rds))
        else:
            mem_word = Const(0, PPC * PS)

        with m.If(step):
            m.d.sync += [b_valid.eq(1), b_data.eq(a_data), b_addr.eq(e_rowaddr + e_col),
                         b_use.eq(use_mem), b_wr.eq(~out_row), b_out.eq(out_row & out_en),
                         b_first.eq(~e_col.any()), b_last.eq(last_col), b_zero.eq(0)]
        with m.Elif(pad_now):
            m.d.sync += [b_valid.eq(1), b_use.eq(0), b_wr.eq(0), b_out.eq(1), b_first.eq(0),
                         b_last.eq(pad_col == WB - 1), b_zero.eq(1)]
        with m.Elif(b_adv):
            m.d.sync += b_valid.eq(0)

        sums, outs, wraps = [], [], []
        for k in range(PPC):
            px = b_data[k * PB:(k + 1) * PB]
            ps = mem_word[k * PS:(k + 1) * PS]
            s = Signal(PS + 1, name=f"sum{k}")
            m.d.comb += s.eq(Mux(b_use, ps, 0) + px)
            sums.append(s[:PS])
            wraps.append(s[PS])
            if self._saturate and OB < PS + 1:
                v = Mux(s > (1 << OB) - 1, (1 << OB) - 1, s[:OB])
            else:
                v = s[:OB]
            outs.append(Mux(b_zero, 0, v))
        for wr, lane in zip(wrs if depth else [], sums):
            m.d.comb += [wr.addr.eq(b_addr), wr.data.eq(lane),
                         wr.en.eq(b_valid & b_wr & ~b_zero)]

        # ---- output register + skid buffer
        new_word = Cat(*outs)
        o_valid, o_first, o_last = Signal(), Signal(), Signal()
        o_data = Signal(PPC * OB)
        sk_data = Signal(PPC * OB)
        sk_first, sk_last = Signal(), Signal()
        m.d.comb += [o.valid.eq(o_valid), Value.cast(o.payload.data).eq(o_data),
                     o.payload.first.eq(o_first), o.payload.last.eq(o_last)]
        push = b_valid & b_out & ~sk_valid
        pop = o_valid & o.ready
        with m.If(sk_valid):
            with m.If(pop):
                m.d.sync += [o_data.eq(sk_data), o_first.eq(sk_first), o_last.eq(sk_last),
                             sk_valid.eq(0)]
        with m.Elif(push):
            with m.If(~o_valid | pop):
                m.d.sync += [o_data.eq(new_word), o_first.eq(b_first & ~b_zero),
                             o_last.eq(b_last), o_valid.eq(1)]
            with m.Else():
                m.d.sync += [sk_data.eq(new_word), sk_first.eq(b_first & ~b_zero),
                             sk_last.eq(b_last), sk_valid.eq(1)]
        with m.Elif(pop):
            m.d.sync += o_valid.eq(0)

        self.probe = {"wrap": Cat(*wraps), "b_valid": b_valid, "b_use": b_use, "b_wr": b_wr,
                      "sums": Cat(*sums), "state": state, "run": run}
        return m
