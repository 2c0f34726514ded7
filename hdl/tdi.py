"""Optimized digital TDI accumulator (SPEC 3.1; seeds 000 §3.2 Fig. 8, 001 §3.1, 003 §2.2).

Golden model: :mod:`tdicam.model.tdi` (:func:`~tdicam.model.tdi.tdi_stream` is the beat-level
contract this component implements bit for bit). The frame control is
:class:`tdicam.hdl.tdi_control.TdiFrameControl` (shared with the DDR accumulator); this module
is the on-chip partial-sum memory and its read pipeline.
"""

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, unsigned
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.memory import Memory

from tdicam.errors import TdicamError
from tdicam.model.tdi import check_params, full_bits, out_width
from tdicam.hdl.vendor import ecp5_bram
from tdicam.hdl.util import NO_INIT, NO_RW_CHECK
from tdicam.hdl.tdi_control import TdiFrameControl, tdi_ports

__all__ = ["TdiAccumulator", "BRAMS"]

# DP16KD data widths and the bank depth used for each: one block RAM (x9 .. x1: 2048 x 9,
# 4096 x 4, 8192 x 2, 16384 x 1) or, for x18, two 2048 x 9 blocks side by side (no read mux)
_BANK_DEPTH = {18: 2048, 9: 2048, 4: 4096, 2: 8192, 1: 16384}
_GROUP = 8        # banks per first-level OR; block RAMs per replicated address register
_REPLICA = {"attrs": {"keep": 1}, "reset_less": True}   # Signal() of a replicated register
_READ_STAGES = 5  # issue (C), block RAM data, three registers (banks: per bank, OR of 8, OR)


def _split(bits):
    """Partial-sum bit widths, each a DP16KD data width, largest first (19 -> 18 + 1)."""
    parts = []
    while bits:
        parts.append(next(w for w in _BANK_DEPTH if w <= bits))
        bits -= parts[-1]
    return parts


def _onehot(addr, lg, n):
    """``n`` bank enables, bit c set when ``addr >> lg == c`` (a decoder: one shift)."""
    if n == 1:
        return Const(1, 1)
    return (Const(1, 1) << addr[lg:lg + (n - 1).bit_length()])[:n]


def _or(items):
    """OR of items, as a balanced tree."""
    while len(items) > 1:
        items = [items[j] | items[j + 1] if j + 1 < len(items) else items[j]
                 for j in range(0, len(items), 2)]
    return items[0]


def _flat(acc, m, p, do_write, sum_word, ports):
    """``generic``: one ``lib.memory`` memory ``psum`` of ``(stages-1) W/ppc`` words of
    ``ppc`` x psum bits, one synchronous read port (read enable) and one write port, then
    three registers (the last one masked to zero when the stored sum is not used), the
    same stages as the banks' per-bank register and two OR levels. Returns the per-lane
    stored sums."""
    PPC, PS = acc._ppc, acc._psum_bits
    ps_ = p[acc._read_stages]
    depth = acc.memory_shape[1]
    if not depth:
        return [Const(0, PS)] * PPC
    mem = Memory(shape=unsigned(PPC * PS), depth=depth, init=[],
                 attrs={NO_RW_CHECK: 1, NO_INIT: 1})
    m.submodules.psum = mem
    acc.memories.append(mem)
    rd, wr = mem.read_port(), mem.write_port()
    aw = len(p[0]["addr"])
    ra, wa = Signal(aw, name="ra"), Signal(aw, name="wa")
    re, we, wd = Signal(name="re"), Signal(name="we"), Signal(PPC * PS, name="wd")
    # issue: address and enable registered (C); write-back registered, written a cycle later
    m.d.sync += [ra.eq(p[0]["addr"]), re.eq(p[0]["valid"]),
                 wa.eq(ps_["addr"]), we.eq(do_write), wd.eq(sum_word)]
    m.d.comb += [rd.addr.eq(ra), rd.en.eq(re), wr.addr.eq(wa), wr.data.eq(wd),
                 wr.en.eq(we)]
    ports.append((rd.en, rd.addr, wr.en, wr.addr))
    q, use = rd.data, p[acc._read_stages - 1]["use"]
    for s in range(3):
        r = Signal(PPC * PS, name=f"q{s}")
        m.d.sync += r.eq(Mux(use, q, 0) if s == 2 else q)
        q = r
    return [q[k * PS:(k + 1) * PS] for k in range(PPC)]


def _banks(acc, m, p, do_write, sum_word, ports):
    """``ecp5``: the partial sums in DP16KD banks (see *Memory*), each read into its
    block RAM output register and a fabric register, ORed in two registered levels (the
    last one masked to zero when the stored sum is not used). Returns the per-lane stored
    sums."""
    PPC, PS = acc._ppc, acc._psum_bits
    aw = len(p[0]["addr"])
    ps_ = p[acc._read_stages]
    lanes = [[] for _ in range(PPC)]
    lo = 0
    rep = max(1, _GROUP // PPC)   # banks per replicated address / write register set
    for pw, depths in acc.memory_banks:
        lg = _BANK_DEPTH[pw].bit_length() - 1
        n = len(depths)
        # bank enables, one bit per bank, decoded once for the part (one shift, not a
        # comparator per bank): read at the issue (re), its data arrives (rh), write back (we)
        re_v = Signal(n, name=f"re_b{lo}")
        rh_v = Signal(n, name=f"rh_b{lo}")
        we_v = Signal(n, name=f"we_b{lo}")
        m.d.sync += [re_v.eq(Mux(p[0]["valid"], _onehot(p[0]["addr"], lg, n), 0)),
                     rh_v.eq(re_v),
                     we_v.eq(Mux(do_write, _onehot(ps_["addr"], lg, n), 0))]
        q = []
        for c, bd in enumerate(depths):
            if c % rep == 0:
                # replicated issue and write-back address and data registers: ``keep``
                # (tdicam synth keeps the flip-flops of a keep wire, so yosys does not
                # merge the copies), no reset (the bank enables say when they count)
                g = c // rep
                ra = Signal(aw, name=f"ra_b{lo}_g{g}", **_REPLICA)
                wa = Signal(aw, name=f"wa_b{lo}_g{g}", **_REPLICA)
                wd = Signal(PPC * pw, name=f"wd_b{lo}_g{g}", **_REPLICA)
                m.d.sync += [ra.eq(p[0]["addr"]), wa.eq(ps_["addr"]),
                             wd.eq(Cat(*(sum_word[k * PS + lo:k * PS + lo + pw]
                                         for k in range(PPC))))]
            q.append(ecp5_bram.bank(m, f"b{lo}_{c}", depth=bd, bits=PPC * pw, ra=ra,
                                    re=re_v[c], rh=rh_v[c], wa=wa, wd=wd, we=we_v[c]))
        groups = []
        for j in range(0, len(q), _GROUP):
            gq = Signal(PPC * pw, name=f"g_b{lo}_{j // _GROUP}")
            m.d.sync += gq.eq(_or(q[j:j + _GROUP]))
            groups.append(gq)
        piece = Signal(PPC * pw, name=f"ps_b{lo}")
        # the stored sum is used or not: masked here, so the adder gets registers
        m.d.sync += piece.eq(Mux(p[acc._read_stages - 1]["use"], _or(groups), 0))
        for k in range(PPC):
            lanes[k].append(piece[k * pw:(k + 1) * pw])
        lo += pw
    return [Cat(*parts) if parts else Const(0, PS) for parts in lanes]


#: How the partial sums are stored (``bram=``): the read stages each description adds to
#: the generic one's and the function that makes it. ``generic``: one ``lib.memory``
#: memory (every tool and simulator; vendor tools split it into their block RAMs);
#: ``ecp5``: Lattice DP16KD banks at the packing limit with their output register in use and
#: a fabric register after it (:mod:`tdicam.hdl.vendor.ecp5_bram`; what ``tdicam synth`` places
#: on the ECP5).
BRAMS = {"generic": (0, _flat), "ecp5": (ecp5_bram.EXTRA_STAGES, _banks)}


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
    bram : {"generic", "ecp5"}
        How the partial sums are stored (:data:`BRAMS`): ``generic`` (default), one
        ``lib.memory`` memory and three registers after its read port (every tool and
        simulator; what ``tdicam verilog`` writes); ``ecp5``, DP16KD banks at the packing
        limit whose output register is the bank register (:func:`tdicam.hdl.vendor.ecp5_bram.bank`)
        followed by a fabric register and two OR levels: the same behaviour, one read stage
        more (:attr:`latency` 10, :attr:`row_cycles` at least 7).

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
    *Structure.* The frame control (:class:`~tdicam.hdl.tdi_control.TdiFrameControl`: row
    and frame counters, settings latched with each tuser beat, refill after a change,
    malformed frames dropped, counted and a started output line completed with zeros, as
    :func:`~tdicam.model.tdi.tdi_stream`) decodes each input beat into a partial-sum address
    and what to do with it. The memory holds exactly ``stages - 1`` partial-sum lines of W
    words of :attr:`psum_bits`: per pixel lane ``(stages-1) * W/ppc`` words (lane k holds
    pixels k, k+ppc, ...). Every input row reads one line and writes its update back to the
    same address; which line a row uses rotates by one per frame, so partial sums are never
    copied, and a stored sum predating the last restart is never used, so the memory needs
    no clearing.

    *Memory.* ``generic``: one memory of ``(stages-1) * W/ppc`` words of ``ppc`` x
    :attr:`psum_bits` (what one address reads: a word of every lane) with one synchronous
    read port, read only when a beat is issued (read enable), and one write port; vendor
    tools split it into their block RAMs, and a simulator evaluates one memory per clock
    (the fastest description to simulate). ``ecp5``, *memory banks* (:attr:`memory_banks`):
    a lane's words are split by bits into parts of a block RAM data width (18, 9, 4, 2, 1
    bits, largest first: 19 = 18 + 1) and each part by address into banks of 2048 words
    for 18 and 9 bits, one DP16KD's depth for narrower parts (16384 x 1); a bank holds its
    part of every lane, is read only on the cycle it is addressed and written only when
    addressed (one-hot enables decoded once per part from the address, registered). Every
    bit is stored once: at 1280 x 96 stages x 12 bits, 127 DP16KD (ppc 1) / 128 (ppc 4 and
    8), the packing floor being 126.

    *No read/write collisions used.* The memory (each bank) carries yosys' ``no_rw_check`` attribute
    (:data:`tdicam.hw.verilog.NO_RW_CHECK`: a read of the address written in the same cycle
    returns an undefined value, so yosys adds no collision-bypass logic behind the block
    RAM), and no initial value (:data:`tdicam.hw.verilog.NO_INIT`). Both are sound because a
    read whose data is used never meets the write of its address (see *Pipeline*: a line is
    read again at least :attr:`row_cycles` cycles after the read that precedes its write),
    and a stored sum is used only once written since the last restart. The formal harness
    :class:`tdicam.hw.proofs.tdi.TdiNoWrapProof` asserts the first on every cycle.

    *Pipeline.* From the frame control's decoded beat every beat moves one stage per cycle
    with no stall: C (read issue: address and read enable registered), block RAM data, three
    registers (``ecp5``: per-bank register next to its block RAM, zero when the bank was
    not read; OR of 8 banks; OR of the groups), the last one masked to zero when the stored
    sum is not used -> add, into the output register (the whole sums; saturation and the
    padding's zeros on the way from it into the output FIFO) and the write-back registers
    (address, data, write enable), which write one cycle later. A line's address is read
    again at the earliest one row after its write (the next frame's neighbouring row), and
    the write lands 6 cycles after the read was issued: rows of fewer than 6 beats get
    ``6 - W/ppc`` idle cycles after them (:attr:`row_cycles`), so no read sees a stale sum
    (no forwarding path is needed). ``bram="ecp5"`` adds a stage after the block RAM data
    (its output register, then the per-bank register): the write lands 7 cycles after the
    read, rows of at least 7 cycles.

    *Throughput and latency.* ``ppc`` pixels per clock sustained while ``o_stream.ready`` is
    high (rows of at least :attr:`row_cycles` beats). An output beat enters the read
    pipeline only with a credit: the output FIFO (``amaranth.lib.fifo.SyncFIFO``) has room
    for every output beat in flight, so the pipeline never stalls and no beat is lost or
    duplicated whatever ``ready`` does. Input rows that produce no output (all but one per
    frame) flow at full rate even while the output is stalled. ``i_stream.ready`` does not
    depend combinationally on ``o_stream.ready``. :attr:`latency` = 9 cycles (``ecp5``: 10)
    from an output-row input beat's transfer to its output beat being valid.

    Raises
    ------
    TdicamError
        On bad parameters (one line, before elaboration).
    """

    def __init__(self, *, width, stages, pixel_bits=12, out_bits=None, ppc=1, bram="generic",
                 _psum_bits=None, _row_cycles=None):
        check_params(width=width, stages=stages, pixel_bits=pixel_bits, out_bits=out_bits,
                     ppc=ppc)
        if bram not in BRAMS:
            raise TdicamError(f"bram = {bram!r} is not valid; valid: {', '.join(BRAMS)}")
        self._bram = bram
        extra, self._memory_maker = BRAMS[bram]
        self._read_stages = _READ_STAGES + extra
        self._width = width
        self._stages = stages
        self._pixel_bits = pixel_bits
        self._ppc = ppc
        self._out_bits = out_width(pixel_bits, stages, out_bits)
        self._saturate = out_bits is not None
        # _psum_bits: test hook only (a deliberately too narrow, wrapping mutant)
        self._psum_bits = full_bits(pixel_bits, stages) if _psum_bits is None else _psum_bits
        # _row_cycles: test hook only (too few: a mutant that reads a sum as it is written)
        # (default: read issue to the write-back landing, see *Pipeline*)
        self._min_row = self._read_stages + 1 if _row_cycles is None else _row_cycles
        self.memories = []
        self.probe = {}
        super().__init__(tdi_ports(pixel_bits, self._out_bits, stages, ppc))

    width = property(lambda self: self._width, doc="Pixels per line W.")
    stages = property(lambda self: self._stages, doc="m_max.")
    pixel_bits = property(lambda self: self._pixel_bits)
    ppc = property(lambda self: self._ppc, doc="Pixels per clock.")
    out_bits = property(lambda self: self._out_bits, doc="Output pixel width.")
    saturating = property(lambda self: self._saturate,
                          doc="True when the output saturates at 2**out_bits - 1.")
    psum_bits = property(lambda self: self._psum_bits, doc="Partial-sum word width.")
    bram = property(lambda self: self._bram, doc="Bank description, a key of :data:`BRAMS`.")

    @property
    def latency(self):
        """Cycles from an input beat's transfer to the matching output beat being valid: 9
        (input and decode registers of the frame control, 5 read-pipeline stages, output
        register, FIFO); 10 with ``bram="ecp5"`` (6 read-pipeline stages)."""
        return 2 + self._read_stages + 2

    @property
    def row_cycles(self):
        """Cycles per input row at full rate: ``W/ppc`` beats, at least 6 (``ecp5``: 7; see
        *Pipeline*)."""
        return max(self._width // self._ppc, self._min_row)

    @property
    def memory_lines(self):
        """Partial-sum lines held on chip: ``stages - 1``."""
        return self._stages - 1

    @property
    def memory_shape(self):
        """(lanes, depth, word bits) of the partial-sum memory: ``ppc`` lanes of
        ``(stages-1) * W/ppc`` words of :attr:`psum_bits` (lane k holds pixels k, k+ppc...)."""
        return (self._ppc, self.memory_lines * (self._width // self._ppc), self._psum_bits)

    @property
    def memory_parts(self):
        """Bit widths a lane's words are split into in the ECP5 banks, each a block RAM data
        width, largest first (19 bits: ``(18, 1)``); see *Memory*."""
        return tuple(_split(self._psum_bits))

    @property
    def memory_banks(self):
        """``[(part bits, [bank depths])]`` of ``bram="ecp5"``: each bank holds ``ppc`` x
        part bits per word (see *Memory*)."""
        depth = self.memory_shape[1]
        out = []
        for pw in (self.memory_parts if depth else ()):
            bd = _BANK_DEPTH[pw]
            out.append((pw, [min(bd, depth - c) for c in range(0, depth, bd)]))
        return out

    def elaborate(self, platform):
        m = Module()
        W, M, PB, PPC = self._width, self._stages, self._pixel_bits, self._ppc
        PS, OB = self._psum_bits, self._out_bits
        o = self.o_stream

        m.submodules.control = ctl = TdiFrameControl(
            width=W, stages=M, pixel_bits=PB, ppc=PPC, row_cycles=self._min_row)
        wiring.connect(m, wiring.flipped(self.i_stream), ctl.i_stream)
        m.d.comb += [ctl.stages_active.eq(self.stages_active),
                     ctl.direction.eq(self.direction), self.frame_errors.eq(ctl.frame_errors)]
        aw = ctl.addr_bits
        b = ctl.o_stream.payload
        room = Signal(init=1)     # the output FIFO has a free credit
        m.d.comb += ctl.o_stream.ready.eq(~b.out | room)
        b_adv = Signal()
        m.d.comb += b_adv.eq(ctl.o_stream.valid & ctl.o_stream.ready)

        # ---- read pipeline: from the issue (C) every beat moves one stage per cycle
        fields = {"valid": 1, "data": PPC * PB, "use": 1, "wr": 1, "out": 1, "first": 1,
                  "last": 1, "zero": 1, "addr": aw}
        p = [{"valid": b_adv, "data": b.data, "use": b.use, "wr": b.wr, "out": b.out,
              "first": b.first, "last": b.last, "zero": b.zero, "addr": b.addr}]
        for s in range(self._read_stages):
            regs = {n: Signal(w, name=f"p{s}_{n}") for n, w in fields.items()}
            m.d.sync += [regs[n].eq(p[-1][n]) for n in fields]
            p.append(regs)
        pc, ps_ = p[1], p[self._read_stages]  # issue stage, sum stage
        do_write = ps_["valid"] & ps_["wr"] & ~ps_["zero"]
        sum_word = Signal(PPC * PS)           # the new partial sums (written back next)

        self.memories, ports = [], []
        lanes = self._memory_maker(self, m, p, do_write, sum_word, ports)

        sums, full, wraps = [], [], []
        for k in range(PPC):
            px = ps_["data"][k * PB:(k + 1) * PB]
            s = Signal(PS + 1, name=f"sum{k}")
            m.d.comb += s.eq(lanes[k] + px)
            sums.append(s[:PS])
            wraps.append(s[PS])
            full.append(s)
        m.d.comb += sum_word.eq(Cat(*sums))

        # ---- output register (the whole sums: saturation and zero padding after it, so
        # the adders end in flip-flops), then the FIFO; credits: an output beat issues only
        # with room reserved for it
        o_en, o_zero, o_first, o_last = Signal(), Signal(), Signal(), Signal()
        o_sum = Signal(PPC * (PS + 1))
        m.d.sync += [o_en.eq(ps_["valid"] & ps_["out"]), o_sum.eq(Cat(*full)),
                     o_zero.eq(ps_["zero"]), o_first.eq(ps_["first"] & ~ps_["zero"]),
                     o_last.eq(ps_["last"])]
        outs = []
        for k in range(PPC):
            s = o_sum[k * (PS + 1):(k + 1) * (PS + 1)]
            if self._saturate and OB < PS + 1:
                v = Mux(s[OB:].any(), (1 << OB) - 1, s[:OB])
            else:
                v = s[:OB]
            outs.append(Mux(o_zero, 0, v))
        n_fifo = self._read_stages + 3
        m.submodules.out_fifo = fifo = SyncFIFO(width=PPC * OB + 2, depth=n_fifo)
        m.d.comb += [fifo.w_data.eq(Cat(*outs, o_first, o_last)), fifo.w_en.eq(o_en),
                     o.valid.eq(fifo.r_rdy), fifo.r_en.eq(o.ready),
                     Value.cast(o.payload.data).eq(fifo.r_data[:PPC * OB]),
                     o.payload.first.eq(fifo.r_data[PPC * OB]),
                     o.payload.last.eq(fifo.r_data[PPC * OB + 1])]
        pend = Signal(range(n_fifo + 1))   # output beats issued and not yet taken
        # the next count and credit of each move, from pend alone: the issue and the take
        # (late: the issue depends on room itself) only select (with the adder and the
        # compare after them, room -> issue -> room was the orbit chain's slowest path on a
        # seed, 6.9 ns)
        up, down = Signal(), Signal()
        m.d.comb += [up.eq(b_adv & b.out), down.eq(o.valid & o.ready)]
        inc, dec = pend + 1, pend - 1
        with m.If(up != down):
            m.d.sync += [pend.eq(Mux(up, inc, dec)),
                         room.eq(Mux(up, inc < n_fifo, dec < n_fifo))]

        self.probe = {"wrap": Cat(*wraps), "b_valid": ps_["valid"], "b_use": ps_["use"],
                      "b_wr": ps_["wr"], "sums": Cat(*sums), "issue_use": pc["use"],
                      "ports": ports}
        return m
