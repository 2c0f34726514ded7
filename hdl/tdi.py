"""Optimized digital TDI accumulator (SPEC 3.1; seeds 000 §3.2 Fig. 8, 001 §3.1, 003 §2.2).

Golden model: :mod:`tdicam.model.tdi` (:func:`~tdicam.model.tdi.tdi_stream` is the beat-level
contract this component implements bit for bit).
"""

from amaranth.asserts import AnySeq
from amaranth.hdl import Assert, Assume, Cat, Const, Elaboratable, Module, Mux, Signal, Value, unsigned
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out
from amaranth.utils import bits_for

from tdicam.model.tdi import check_params, full_bits, out_width
from .stream import channels_shape, pixel_signature

__all__ = ["TdiAccumulator", "TdiNoWrapProof"]

_WAIT, _RUN, _DROP, _PAD = range(4)   # (x == 0 written ~x.any(): yosys prints x == 0 as !x)
# DP16KD data widths (x18, x9: 18,432 bits; x4, x2, x1: 16,384) and depth per block RAM
_RAM_DEPTH = {18: 1024, 9: 2048, 4: 4096, 2: 8192, 1: 16384}
_GROUP = 16       # block RAMs per first-level read mux
_SUM_AT = 4       # cycles from a beat's read issue to its partial-sum add (output FIFO write)
_WRITE_AT = 5     # ... to its write back


def _split(bits):
    """Partial-sum bit widths, each a DP16KD data width, largest first (19 -> 18 + 1)."""
    parts = []
    while bits:
        parts.append(next(w for w in _RAM_DEPTH if w <= bits))
        bits -= parts[-1]
    return parts


def _eq(value, c):
    """value == c, spelled ~value.any() for 0 (yosys writes x == 0 as !x: a lint warning)."""
    return ~value.any() if c == 0 else value == c


def _or(items):
    """OR of items, as a balanced tree."""
    while len(items) > 1:
        items = [items[j] | items[j + 1] if j + 1 < len(items) else items[j]
                 for j in range(0, len(items), 2)]
    return items[0]


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
    each; word width stays :attr:`psum_bits` whatever ``ppc``). Every input row reads one
    line and writes its update back to the same address a few cycles later
    (read-modify-write: one read and one write per bank per beat); which line a row uses
    rotates by one per frame (a base pointer), so partial sums are never copied. Row r of a
    frame has age a (``m-1-r`` forward, ``r`` reverse): age 0 starts a sum (the memory read
    is ignored), age m-1 completes it (the output row, nothing written), the others add. A
    stored sum is only used if its ground line was first seen after the last (re)start, so
    stale memory never reaches the output and the memory needs no clearing.

    *Memory split.* Each bank is split by bits into parts of a block RAM data width (18, 9,
    4, 2, 1 bits, largest first: 19 = 18 + 1) and each part by address into
    ``lib.memory`` memories of at most one ECP5 DP16KD (1024 x 18, 2048 x 9, 4096 x 4,
    8192 x 2, 16384 x 1), each with one synchronous read port and one write port: every
    bit is stored once, ``(stages-1) * W/ppc * psum_bits`` bits per lane, and a 19-bit
    bank does not waste a 20th bit (4096 x 4 shapes). At 1280 x 96 stages x 12 bits that is
    127 block RAMs (ppc 1) / 128 (ppc 4), the floor being 126. Each memory's read data is
    registered (zero unless it is the one addressed), then ORed in two registered levels
    (16 memories, then the rest).

    *Pipeline.* A: input register; the row/column/line decode computes the beat's
    address from registers (a per-beat address counter, the next row's and next frame's
    first addresses precomputed), registered in B. B issues the read; from there a beat
    moves one stage per cycle with no stall: read data (p1), registered per memory (p2),
    first mux level (p3), partial sum (p4: add, saturate, into the output FIFO), write
    back (p5, registered address, data and enables). A line's address is read again at
    the earliest ``W/ppc`` beats after its write (the next frame's neighbouring row); for
    rows of fewer than 6 beats, B leaves ``6 - W/ppc`` idle cycles after each row so the
    read never overtakes the write. No multiplier: lines x W/ppc is a sum of shifts.

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
    high (rows of at least 6 beats, see above). An output beat issues from B only with a
    credit: the output FIFO (6 entries, ``amaranth.lib.fifo.SyncFIFO``) has room for every
    output beat in flight, so the read pipeline never stalls and no beat is lost or
    duplicated whatever ``ready`` does. Input rows that produce no output (all but one per
    frame) flow at full rate even while the output is stalled. ``i_stream.ready`` depends
    only on registers (no combinational path from ``o_stream.ready``). :attr:`latency` = 7
    cycles from an output-row input beat's transfer to its output beat being valid (input
    register, issue register, 4 read-pipeline stages, FIFO).

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
        """Cycles from an input beat's transfer to the matching output beat being valid: 7
        (input register, issue register, 4 read-pipeline stages, output FIFO)."""
        return 3 + _SUM_AT

    @property
    def row_cycles(self):
        """Cycles per input row at full rate: ``W/ppc`` beats, at least 6 (see *Pipeline*)."""
        return max(self._width // self._ppc, _WRITE_AT + 1)

    @property
    def memory_lines(self):
        """Partial-sum lines held on chip: ``stages - 1``."""
        return self._stages - 1

    @property
    def memory_shape(self):
        """(banks, depth, word bits) of the partial-sum memory: ``ppc`` banks of
        ``(stages-1) * W/ppc`` words of :attr:`psum_bits` (bank k holds pixel lane k)."""
        return (self._ppc, self.memory_lines * (self._width // self._ppc), self._psum_bits)

    @property
    def memory_parts(self):
        """Bit widths a bank's words are split into, each a block RAM data width, largest
        first (19 bits: ``(18, 1)``); see *Memory split*."""
        return tuple(_split(self._psum_bits))

    def elaborate(self, platform):
        m = Module()
        W, M, PB, PPC = self._width, self._stages, self._pixel_bits, self._ppc
        WB = W // PPC
        PS, OB = self._psum_bits, self._out_bits
        depth = (M - 1) * WB
        aw = max(1, bits_for(max(depth - 1, 0)))
        mb = bits_for(M)
        i, o = self.i_stream, self.o_stream

        # ---- stage A: input register (beat + the settings presented with it, predecoded)
        a_valid = Signal()
        a_data = Signal(PPC * PB)
        a_first, a_last, a_dir = Signal(), Signal(), Signal()
        a_m = Signal(len(self.stages_active))
        a_m1 = Signal(mb)         # m - 1
        a_ok = Signal()           # the settings are valid
        a_lines = Signal(mb)      # partial-sum lines the settings use (m-1 forward, m reverse)
        a_take = Signal()
        m.d.comb += i.ready.eq(~a_valid | a_take)
        with m.If(i.valid & i.ready):
            sa, sd = self.stages_active, self.direction
            ok = sa.any()
            if M < (1 << len(sa)) - 1:
                ok &= sa <= M
            if M >= 2:
                ok &= ~(sd & (sa == M))
            m.d.sync += [a_valid.eq(1), a_data.eq(Value.cast(i.payload.data)),
                         a_first.eq(i.payload.first), a_last.eq(i.payload.last),
                         a_m.eq(sa), a_dir.eq(sd), a_m1.eq(sa - 1), a_ok.eq(ok),
                         a_lines.eq(Mux(sa == 1, 0, sa - 1 + sd))]
        with m.Elif(a_take):
            m.d.sync += a_valid.eq(0)

        # ---- control state
        state = Signal(2, init=_WAIT)
        m_reg = Signal(mb)
        m1_reg = Signal(mb)       # m_reg - 1
        dir_reg = Signal()
        run = Signal(mb)          # well-formed frames in the current run (saturates at M)
        f = Signal(mb)            # run at the start of the current frame
        col = Signal(range(WB))
        col_last = Signal()       # col == WB - 1
        # the current row: its age (m-1-r forward, r reverse), whether it is the output row,
        # uses the stored sum, is the frame's last row; whether this frame outputs
        age = Signal(mb)
        r_out, r_use, r_last, out_en = Signal(), Signal(), Signal(), Signal()
        base = Signal(aw)         # first address of the line row 0 uses this frame
        bnext = Signal(aw)        # base's successor (registered: base changes >= 2 cycles apart)
        bnext1 = Signal(aw)       # bnext + 1
        row_addr = Signal(aw)     # first address of the current row's line
        cur = Signal(aw)          # address of the current row's next beat
        lim = Signal(bits_for(depth))  # lines in use x WB
        pad_col = Signal(range(WB))
        errors = Signal(16)
        m.d.comb += self.frame_errors.eq(errors)

        # ---- stage B: the decoded beat, issued into the read pipeline
        b_valid, b_use, b_wr, b_out, b_first, b_last, b_zero = (Signal() for _ in range(7))
        b_data = Signal(PPC * PB)
        b_addr = Signal(aw)
        room = Signal(init=1)     # the output FIFO has a free credit
        gap_cycles = max(0, _WRITE_AT + 1 - WB)
        gap = Signal(range(gap_cycles + 1)) if gap_cycles else Const(0, 1)

        def wire(name, value, shape=1):
            w = Signal(shape, name=name)
            m.d.comb += w.eq(value)
            return w

        b_adv = wire("b_adv", b_valid & (~b_out | room) & ~gap.any())
        b_can = wire("b_can", ~b_valid | b_adv)

        # ---- decode A's beat: a frame's first beat from A's predecoded settings, the
        # others from the current row's registers
        start = a_first
        same = wire("same", (a_m == m_reg) & (a_dir == dir_reg) & run.any())
        base_step = wire("base_step", base + WB, aw + 1)
        m.d.sync += [bnext.eq(Mux(base_step < lim, base_step, 0)),
                     bnext1.eq(Mux(base_step < lim, base_step, 0) + 1)]
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
        tlast_ok = wire("tlast_ok", a_last == last_col)
        frame_end = wire("frame_end", last_col & r_last)
        # the current frame's output line has started (only meaningful in _RUN)
        line_open = wire("line_open", r_out & out_en & col.any())

        busy = wire("busy", a_valid & (state != _PAD))
        proc = wire("proc", busy & Mux(start, (state != _RUN) & a_ok, state == _RUN))
        cut = wire("cut", busy & start & (state == _RUN))
        invalid = wire("invalid", busy & start & (state != _RUN) & ~a_ok)
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

        # the next row, from registers (a row's last beat is never a frame's first)
        fwd = wire("fwd", row_addr + WB, aw + 1)
        nxt_fwd = wire("nxt_fwd", Mux(fwd < lim, fwd, 0), aw)
        nxt_rev = wire("nxt_rev", Mux(row_addr.any(), row_addr - WB,
                                      Mux(lim.any(), lim - WB, 0)), aw)
        row_next = wire("row_next", Mux(dir_reg, nxt_rev, nxt_fwd), aw)
        age_next = wire("age_next", Mux(dir_reg, age + 1, age - 1), mb)
        # lines x WB without a multiplier: WB is a constant, a sum of shifted copies
        lim_new = sum((a_lines << k for k in range(WB.bit_length()) if WB >> k & 1), Const(0))
        with m.If(step):
            with m.If(start):
                m.d.sync += [m_reg.eq(a_m), m1_reg.eq(a_m1), dir_reg.eq(a_dir), f.eq(s_f),
                             base.eq(base_next), lim.eq(lim_new), age.eq(Mux(a_dir, 0, a_m1)),
                             r_out.eq(s_out), r_use.eq(s_use), r_last.eq(m1_zero),
                             out_en.eq(s_out_en), col.eq(1), col_last.eq(WB == 2),
                             row_addr.eq(base_next), cur.eq(Mux(same, bnext1, 1))]
            with m.Elif(last_col):
                m.d.sync += [col.eq(0), col_last.eq(0), row_addr.eq(row_next),
                             cur.eq(row_next), age.eq(age_next),
                             r_out.eq(age_next == m1_reg),
                             r_use.eq(age_next.any() & (age_next <= f)),
                             r_last.eq(Mux(dir_reg, age_next == m1_reg, ~age_next.any()))]
            with m.Else():
                m.d.sync += [col.eq(col + 1), col_last.eq(col == WB - 2), cur.eq(cur + 1)]
            with m.If(frame_end):
                m.d.sync += [state.eq(_WAIT), run.eq(Mux(f == M, M, f + 1))]
            with m.Else():
                m.d.sync += state.eq(_RUN)
        with m.If(pad_now):
            m.d.sync += pad_col.eq(pad_col + 1)
            with m.If(pad_col == WB - 1):
                m.d.sync += state.eq(_DROP)

        with m.If(step):
            m.d.sync += [b_valid.eq(1), b_data.eq(a_data), b_addr.eq(e_addr),
                         b_use.eq(e_use), b_wr.eq(~e_out), b_out.eq(e_out & e_out_en),
                         b_first.eq(start | ~col.any()), b_last.eq(last_col), b_zero.eq(0)]
        with m.Elif(pad_now):
            m.d.sync += [b_valid.eq(1), b_use.eq(0), b_wr.eq(0), b_out.eq(1), b_first.eq(0),
                         b_last.eq(pad_col == WB - 1), b_zero.eq(1)]
        with m.Elif(b_adv):
            m.d.sync += b_valid.eq(0)
        if gap_cycles:
            # rows narrower than the read-to-write distance: idle cycles after each row, so
            # a line is never read before the write of its previous update has landed
            with m.If(b_adv & b_last):
                m.d.sync += gap.eq(gap_cycles)
            with m.Elif(gap.any()):
                m.d.sync += gap.eq(gap - 1)

        # ---- read pipeline: from B's issue every beat moves one stage per cycle, no stall
        # p1: block RAM read data; p2: registered per RAM (zero unless addressed); p3: OR of
        # 16 RAMs registered; p4: partial sum (OR of the rest) registered -> add, output
        # FIFO; p5: write back (registered address, data, per-RAM enables)
        fields = {"valid": 1, "data": PPC * PB, "use": 1, "wr": 1, "out": 1, "first": 1,
                  "last": 1, "zero": 1, "addr": aw}
        p = [{"valid": b_adv, "data": b_data, "use": b_use, "wr": b_wr, "out": b_out,
              "first": b_first, "last": b_last, "zero": b_zero, "addr": b_addr}]
        for s in range(1, _SUM_AT + 1):
            regs = {n: Signal(w, name=f"p{s}_{n}") for n, w in fields.items()}
            m.d.sync += [regs[n].eq(p[-1][n]) for n in fields]
            p.append(regs)
        p4 = p[_SUM_AT]
        w_addr = Signal(aw)
        w_data = Signal(PPC * PS)
        we, rh = {}, {}           # (part width, RAM index) -> registered write enable, read hit
        do_write = p4["valid"] & p4["wr"] & ~p4["zero"]
        m.d.sync += w_addr.eq(p4["addr"])

        self.memories = []
        lanes = []
        for k in range(PPC):
            pieces, lo = [], 0
            for pw in (_split(PS) if depth else []):
                rd_depth = _RAM_DEPTH[pw]
                lg = rd_depth.bit_length() - 1
                n_ram = -(-depth // rd_depth)
                q = []
                for c in range(n_ram):
                    mem = Memory(shape=unsigned(pw), depth=min(rd_depth, depth - c * rd_depth),
                                 init=[])
                    m.submodules[f"psum{k}_b{lo}_{c}"] = mem
                    self.memories.append(mem)
                    rd, wr = mem.read_port(), mem.write_port()
                    if (pw, c) not in we:
                        we[pw, c] = Signal(name=f"we_{pw}b_{c}")
                        rh[pw, c] = Signal(name=f"rh_{pw}b_{c}")
                        whit = _eq(p4["addr"] >> lg, c) if n_ram > 1 else 1
                        rhit = _eq(b_addr >> lg, c) if n_ram > 1 else 1
                        m.d.sync += [we[pw, c].eq(do_write & whit), rh[pw, c].eq(rhit)]
                    qr = Signal(pw, name=f"q{k}_b{lo}_{c}")
                    m.d.comb += [rd.addr.eq(b_addr[:len(rd.addr)]),
                                 wr.addr.eq(w_addr[:len(wr.addr)]),
                                 wr.data.eq(w_data[k * PS + lo:k * PS + lo + pw]),
                                 wr.en.eq(we[pw, c])]
                    # zero unless addressed (a flip-flop synchronous reset, no LUT): the
                    # read mux is then an OR tree
                    m.d.sync += qr.eq(Mux(rh[pw, c], rd.data, 0))
                    q.append(qr)
                groups = []
                for j in range(0, n_ram, _GROUP):
                    g = Signal(pw, name=f"g{k}_b{lo}_{j // _GROUP}")
                    m.d.sync += g.eq(_or(q[j:j + _GROUP]))
                    groups.append(g)
                piece = Signal(pw, name=f"ps{k}_b{lo}")
                m.d.sync += piece.eq(_or(groups))
                pieces.append(piece)
                lo += pw
            lanes.append(Cat(*pieces) if pieces else Const(0, PS))

        sums, outs, wraps = [], [], []
        for k in range(PPC):
            px = p4["data"][k * PB:(k + 1) * PB]
            s = Signal(PS + 1, name=f"sum{k}")
            m.d.comb += s.eq(Mux(p4["use"], lanes[k], 0) + px)
            sums.append(s[:PS])
            wraps.append(s[PS])
            if self._saturate and OB < PS + 1:
                v = Mux(s > (1 << OB) - 1, (1 << OB) - 1, s[:OB])
            else:
                v = s[:OB]
            outs.append(Mux(p4["zero"], 0, v))
        m.d.sync += w_data.eq(Cat(*sums))

        # ---- output FIFO; credits: an output beat issues only with room reserved for it
        n_fifo = _SUM_AT + 2
        m.submodules.out_fifo = fifo = SyncFIFO(width=PPC * OB + 2, depth=n_fifo)
        m.d.comb += [fifo.w_data.eq(Cat(*outs, p4["first"] & ~p4["zero"], p4["last"])),
                     fifo.w_en.eq(p4["valid"] & p4["out"]),
                     o.valid.eq(fifo.r_rdy), fifo.r_en.eq(o.ready),
                     Value.cast(o.payload.data).eq(fifo.r_data[:PPC * OB]),
                     o.payload.first.eq(fifo.r_data[PPC * OB]),
                     o.payload.last.eq(fifo.r_data[PPC * OB + 1])]
        pend = Signal(range(n_fifo + 1))   # output beats issued and not yet taken
        pend_next = wire("pend_next", pend + (b_adv & b_out) - (o.valid & o.ready),
                         range(n_fifo + 2))
        m.d.sync += [pend.eq(pend_next), room.eq(pend_next < n_fifo)]

        self.probe = {"wrap": Cat(*wraps), "b_valid": p4["valid"], "b_use": p4["use"],
                      "b_wr": p4["wr"], "sums": Cat(*sums), "state": state, "run": run}
        return m


class TdiNoWrapProof(Elaboratable):
    """Formal harness: the partial-sum adders never carry out of the partial-sum width.

    Inputs (pixels, tuser, tlast, valid, ``stages_active``, ``direction``, the sink's
    ``ready``, the synchronous reset) are free on every cycle. Asserted on every cycle: the
    sum a pipeline beat writes back or outputs (stored partial sum + pixel, per lane) fits
    :attr:`TdiAccumulator.psum_bits`, and every partial sum written is at most
    ``(stages - 1) * (2**pixel_bits - 1)``. Meant for a bounded model check from the initial
    state (:func:`tdicam.formal.prove` ``mode="bmc"``, :meth:`depth` cycles: ``stages + 1``
    whole frames plus the pipeline), which covers every stage count, direction, setting
    change, reset and malformed-frame path reachable in that many cycles.

    ``full_scale`` assumes every pixel is ``2**pixel_bits - 1``: sound for this property,
    because no control decision depends on pixel values and every sum is a sum of pixels,
    so the largest sum of any control trace is the one with full-scale pixels; it makes the
    check several times faster. ``valid_settings`` assumes ``1 <= stages_active <= stages``
    (an invalid setting only drops its frame and restarts the fill, like a change of
    setting). ``psum_bits`` overrides the partial-sum width: a deliberately too narrow,
    wrapping mutant must fail.
    """

    def __init__(self, *, width=2, stages=3, pixel_bits=8, ppc=1, psum_bits=None,
                 full_scale=False, valid_settings=False):
        self.dut = TdiAccumulator(width=width, stages=stages, pixel_bits=pixel_bits, ppc=ppc,
                                  _psum_bits=psum_bits)
        self.dut._MustUse__silence = True   # elaborated by hand in elaborate()
        self.full_scale = full_scale
        self.valid_settings = valid_settings

    def depth(self, frames=None):
        """BMC depth covering ``frames`` whole frames (default ``stages + 1``) + pipeline."""
        d = self.dut
        frames = d.stages + 1 if frames is None else frames
        return frames * d.stages * d.row_cycles + d.latency + 2

    def elaborate(self, platform):
        m = Module()
        dut = self.dut
        m.submodules.dut = dut.elaborate(platform)   # by hand, to reach its probes
        i, o = dut.i_stream, dut.o_stream
        m.d.comb += [
            i.valid.eq(AnySeq(1)),
            Value.cast(i.payload).eq(AnySeq(len(Value.cast(i.payload)))),
            dut.stages_active.eq(AnySeq(len(dut.stages_active))),
            dut.direction.eq(AnySeq(1)),
            o.ready.eq(AnySeq(1)),
        ]
        if self.full_scale:
            pmax = (1 << dut.pixel_bits) - 1
            m.d.comb += Assume(Value.cast(i.payload.data) == Cat(*([Const(pmax, dut.pixel_bits)] * dut.ppc)))
        if self.valid_settings:
            m.d.comb += Assume((dut.stages_active >= 1) & (dut.stages_active <= dut.stages))
        p = dut.probe
        m.d.comb += Assert(~(p["b_valid"] & p["wrap"].any()))
        bound = (dut.stages - 1) * ((1 << dut.pixel_bits) - 1)
        ps = dut.psum_bits
        for k in range(dut.ppc):
            lane = p["sums"][k * ps:(k + 1) * ps]
            m.d.comb += Assert(~(p["b_valid"] & p["b_wr"]) | (lane <= bound))
        return m
