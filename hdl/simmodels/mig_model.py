"""Simulation-only DDR3 controller + memory behind a MIG native UI, and the wrapper that
puts a DDR user and the model together as one stream component for the fast co-simulation.

* :class:`MigModel` — same behaviour and the same per-cycle stall pattern as
  :class:`tdicam.model.dram.MigSim`.
* :class:`SimTop` — a user component with a :class:`MigModel` behind its MIG ports (DRAM
  timing on by default).
"""

from amaranth.hdl import Array, Module, Mux, Signal, unsigned
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_range
from tdicam.model.ddr import ADDR_BITS, WORD_BITS
from tdicam.model.dram import BANKS, DramTiming, _check_stalls
from tdicam.hdl.interfaces.mig import MIG_PORT_NAMES, connect_mig, mig_model_ports
from tdicam.hdl.util import equals, quiet_reject

__all__ = ["MigModel", "SimTop"]


def _xorshift(s):
    a = s ^ (s << 13)[:32]
    b = a ^ (a >> 17)
    return (b ^ (b << 5)[:32])[:32]


class MigModel(wiring.Component):
    """Simulation-only model of a DDR3 controller behind a MIG native UI (not synthesizable
    into anything useful: the memory is an array of ``depth_words`` 256-bit words).

    Same behaviour and the same per-cycle stall pattern as
    :class:`tdicam.model.dram.MigSim` (xorshift32 state seeded with ``seed``, 1..2**32-1, stepping
    every cycle): ``app_rdy`` low in the first ``refresh_cycles`` of every
    ``refresh_period`` after the first, when ``state[7:0] < drop`` or when the return
    queue is nearly full;
    ``app_wdf_rdy`` low when ``state[15:8] < drop`` or the 16-word write-data FIFO is full;
    reads return in order ``lat_lo + (state[31:16] * (lat_hi - lat_lo + 1) >> 16)`` cycles
    after the command (at least one cycle after the previous read's data).

    With ``dram`` (a :class:`tdicam.model.dram.DramTiming`) it also charges, as
    :class:`~tdicam.model.dram.MigSim` with the same ``dram`` does and cycle for cycle with it,
    what the order of accesses costs on DDR3: after each accepted command ``app_rdy`` stays
    low for :meth:`DramTiming.cost <tdicam.model.dram.DramTiming.cost>` cycles (the queue
    drain on a bank change, the read/write turnaround, opening a row in the command's bank:
    row-bank-column mapping, word address bits [7:10] the bank, the bits above the row; 8
    open-row registers, cleared by a refresh). Use it with
    :data:`~tdicam.model.dram.DRAM_STALLS` (44-cycle refresh).

    ``error`` is sticky: an address outside ``depth_words * 8`` or not a multiple of 8, a
    write command with no write data accepted before it, ``app_wdf_end`` low on a data
    beat, or an ``app_cmd`` other than 0/1. The offending command is ignored.

    With ``count_stalls``, ``stalls`` (Out(32)) counts the cycles the user waited on the
    controller: a command (``app_en``) or write data (``app_wdf_wren``) presented and not
    taken (refresh, a dropped ready, the DRAM timing, a full queue).
    """

    WDF_DEPTH = 16
    RET_DEPTH = 128

    @quiet_reject
    def __init__(self, *, depth_words, addr_bits=ADDR_BITS, lat_lo=20, lat_hi=60,
                 refresh_period=780, refresh_cycles=44, drop=16, seed=1, dram=None,
                 count_stalls=False):
        _check_stalls(lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed)
        self._dram = dram
        check_range("depth_words", depth_words, 1, 1 << (addr_bits - 3))
        self._depth = depth_words
        self._aw = addr_bits
        self._p = (lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed)
        self.memory = None
        self._count = bool(count_stalls)
        super().__init__({**mig_model_ports(addr_bits), "error": Out(1),
                          "writes": Out(32), "reads": Out(32),
                          **({"stalls": Out(32)} if count_stalls else {})})

    depth_words = property(lambda self: self._depth)
    dram = property(lambda self: self._dram)

    def with_depth(self, depth_words):
        """The same model (stalls, timing, counters) holding ``depth_words`` words."""
        lo, hi, period, rcyc, drop, seed = self._p
        return MigModel(depth_words=depth_words, addr_bits=self._aw, lat_lo=lo, lat_hi=hi,
                        refresh_period=period, refresh_cycles=rcyc, drop=drop, seed=seed,
                        dram=self._dram, count_stalls=self._count)

    def elaborate(self, platform):
        m = Module()
        lo, hi, period, rcyc, drop, seed = self._p
        D, WB = self._depth, WORD_BITS
        s = Signal(32, init=seed)
        m.d.sync += s.eq(_xorshift(s))
        t = Signal(32)
        m.d.sync += t.eq(t + 1)
        rc = Signal(range(period))
        m.d.sync += rc.eq(Mux(rc == period - 1, 0, rc + 1))
        refresh = Signal()
        started = Signal()                  # the first refresh period is over
        with m.If(rc == period - 1):
            m.d.sync += started.eq(1)
        m.d.comb += refresh.eq(started & (rc < rcyc)) if rcyc else refresh.eq(0)

        mem = Memory(shape=unsigned(WB), depth=D, init=[])
        m.submodules.mem = self.memory = mem
        wp = mem.write_port()
        rp = mem.read_port()

        # write-data FIFO: registers + async head (data accepted at edge t is usable at t+1)
        wdf = Memory(shape=unsigned(WB), depth=self.WDF_DEPTH, init=[])
        m.submodules.wdf = wdf
        wdf_w = wdf.write_port()
        wdf_r = wdf.read_port(domain="comb")
        wdf_wp = Signal(range(self.WDF_DEPTH))
        wdf_rp = Signal(range(self.WDF_DEPTH))
        wdf_n = Signal(range(self.WDF_DEPTH + 1))

        # return queue: (data, due), written one cycle after the command (sync mem read)
        rq = Memory(shape=unsigned(WB), depth=self.RET_DEPTH, init=[])
        rqd = Memory(shape=unsigned(32), depth=self.RET_DEPTH, init=[])
        m.submodules.rq, m.submodules.rqd = rq, rqd
        rq_w, rqd_w = rq.write_port(), rqd.write_port()
        rq_r, rqd_r = rq.read_port(domain="comb"), rqd.read_port(domain="comb")
        rq_wp = Signal(range(self.RET_DEPTH))
        rq_rp = Signal(range(self.RET_DEPTH))
        rq_n = Signal(range(self.RET_DEPTH + 1))     # entries in the queue
        ret_n = Signal(range(self.RET_DEPTH + 1))    # reads accepted, data not yet returned
        last_due = Signal(32)
        pend = Signal()
        pend_due = Signal(32)

        free = ~self._dram_timing(m, refresh) if self._dram is not None else 1
        m.d.comb += [
            self.app_rdy.eq(~refresh & (s[0:8] >= drop) & (ret_n < self.RET_DEPTH - 2)
                            & free),
            self.app_wdf_rdy.eq((s[8:16] >= drop) & (wdf_n < self.WDF_DEPTH)),
        ]
        accept = Signal()
        wacc = Signal()
        m.d.comb += [accept.eq(self.app_en & self.app_rdy),
                     wacc.eq(self.app_wdf_wren & self.app_wdf_rdy)]
        addr = self.app_addr
        in_range = Signal()
        m.d.comb += in_range.eq(~addr[0:3].any() & (addr[3:] < D))
        is_wr = Signal()
        is_rd = Signal()
        m.d.comb += [is_wr.eq(accept & ~self.app_cmd.any()),
                     is_rd.eq(accept & (self.app_cmd == 1))]
        err = Signal()
        m.d.comb += self.error.eq(err)
        bad = (accept & (self.app_cmd[1:].any() | ~in_range)) | (is_wr & ~wdf_n.any()) \
            | (wacc & ~self.app_wdf_end)
        with m.If(bad):
            m.d.sync += err.eq(1)
        do_wr = Signal()
        do_rd = Signal()
        m.d.comb += [do_wr.eq(is_wr & in_range & wdf_n.any()), do_rd.eq(is_rd & in_range)]

        # write data FIFO
        m.d.comb += [wdf_w.addr.eq(wdf_wp), wdf_w.data.eq(self.app_wdf_data),
                     wdf_w.en.eq(wacc), wdf_r.addr.eq(wdf_rp)]
        with m.If(wacc):
            m.d.sync += wdf_wp.eq(wdf_wp + 1)
        with m.If(do_wr):
            m.d.sync += wdf_rp.eq(wdf_rp + 1)
        m.d.sync += wdf_n.eq(wdf_n + wacc - do_wr)

        # memory
        m.d.comb += [wp.addr.eq(addr[3:]), wp.data.eq(wdf_r.data), wp.en.eq(do_wr),
                     rp.addr.eq(addr[3:]), rp.en.eq(do_rd)]
        span = hi - lo + 1
        lat = Signal(32)
        m.d.comb += lat.eq(lo + ((s[16:32] * span) >> 16))
        due = Signal(32)
        m.d.comb += due.eq(Mux(t + lat > last_due, t + lat, last_due + 1))
        with m.If(do_rd):
            m.d.sync += [last_due.eq(due), pend_due.eq(due)]
        m.d.sync += pend.eq(do_rd)
        m.d.comb += [rq_w.addr.eq(rq_wp), rq_w.data.eq(rp.data), rq_w.en.eq(pend),
                     rqd_w.addr.eq(rq_wp), rqd_w.data.eq(pend_due), rqd_w.en.eq(pend),
                     rq_r.addr.eq(rq_rp), rqd_r.addr.eq(rq_rp)]
        with m.If(pend):
            m.d.sync += rq_wp.eq(rq_wp + 1)
        ret = Signal()
        m.d.comb += [ret.eq(rq_n.any() & (rqd_r.data <= t)),
                     self.app_rd_data_valid.eq(ret),
                     self.app_rd_data.eq(Mux(ret, rq_r.data, 0))]
        with m.If(ret):
            m.d.sync += rq_rp.eq(rq_rp + 1)
        m.d.sync += [rq_n.eq(rq_n + pend - ret), ret_n.eq(ret_n + do_rd - ret)]
        wr_count, rd_count = Signal(32), Signal(32)
        m.d.sync += [wr_count.eq(wr_count + do_wr), rd_count.eq(rd_count + do_rd)]
        m.d.comb += [self.writes.eq(wr_count), self.reads.eq(rd_count)]
        if self._count:
            waits = Signal(32)
            with m.If((self.app_en & ~self.app_rdy) | (self.app_wdf_wren & ~self.app_wdf_rdy)):
                m.d.sync += waits.eq(waits + 1)
            m.d.comb += self.stalls.eq(waits)
        return m

    def _dram_timing(self, m, refresh):
        """The DRAM cost of each accepted command (:meth:`DramTiming.cost
        <tdicam.model.dram.DramTiming.cost>`); returns the signal that holds ``app_rdy``
        low."""
        d = self._dram
        word = self.app_addr[3:]
        bank, row = word[7:10], word[10:]
        top = (d.first + d.bank + max(d.rd_to_wr, d.wr_to_rd) + 3 + d.activate + d.precharge
               + d.write_recovery)
        busy = Signal(range(top + 1))
        last_valid, last_rd = Signal(), Signal()
        last_bank = Signal(3)
        # one register per bank, written under an explicit compare (no partial case
        # statements or truncating shifts in the Verilog: lint-clean)
        open_valid = Array(Signal(name=f"open_valid{b}") for b in range(BANKS))
        open_rows = Array(Signal(len(row), name=f"open_row{b}") for b in range(BANKS))
        is_rd = self.app_cmd[0]
        vis, turn, act, cost = (Signal(range(top + 1), name=n)
                                for n in ("vis", "turn", "act", "cost"))
        was_rd, hit, conflict, wr_conflict = Signal(), Signal(), Signal(), Signal()
        m.d.comb += [
            vis.eq(Mux(last_valid, Mux(bank != last_bank, d.bank, 0), d.first)),
            was_rd.eq(~last_valid | last_rd),
            turn.eq(Mux(is_rd == was_rd, vis,
                        Mux(is_rd, Mux(vis + 3 > d.wr_to_rd, vis + 3, d.wr_to_rd),
                            vis + d.rd_to_wr))),
            hit.eq(open_valid[bank] & (open_rows[bank] == row)),
            conflict.eq(open_valid[bank] & (open_rows[bank] != row)),
            act.eq(Mux(hit, 0, d.activate) + Mux(conflict, d.precharge, 0)),
            wr_conflict.eq(conflict & last_valid & (bank == last_bank) & ~last_rd),
            # tWR runs during the turnaround
            cost.eq(Mux(wr_conflict & (turn < d.write_recovery), d.write_recovery, turn)
                    + act),
        ]
        with m.If(self.app_en & self.app_rdy):
            m.d.sync += [busy.eq(cost), last_valid.eq(1), last_rd.eq(is_rd),
                         last_bank.eq(bank)]
            for b in range(BANKS):
                with m.If(equals(bank, b)):
                    m.d.sync += [open_rows[b].eq(row), open_valid[b].eq(1)]
        with m.Elif(busy.any()):
            m.d.sync += busy.eq(busy - 1)
        with m.If(refresh):                 # a refresh precharges every bank
            m.d.sync += [open_valid[b].eq(0) for b in range(BANKS)]
        return busy.any()


class SimTop(wiring.Component):
    """A DDR user with a :class:`MigModel` behind it, as one component for co-simulation.

    Exposes the user's streams and its other non-MIG ports unchanged, plus ``ddr_error``
    (the model's sticky error). While ``ddr_error`` is high the input is never accepted,
    so a co-simulation with an out-of-range access fails visibly. Input ports named in
    ``tie_low`` are not exposed (held at 0): level controls such as ``hold_reads``, which
    the stream testbench would drive from stale stimulus after the last beat.

    The model charges DRAM timing by default (``dram``: a
    :class:`~tdicam.model.dram.DramTiming`; None for the plain stall pattern), on top of the
    stall pattern ``stalls``, so a co-simulation is not optimistic about the order in which
    the user accesses DDR (with the default random stalls it is pessimistic).
    """

    def __init__(self, user, *, depth_words, tie_low=("hold_reads",), dram=DramTiming(),
                 **stalls):
        self._user = user
        self._tie = tuple(tie_low)
        self._model = MigModel(depth_words=depth_words, dram=dram, **stalls)
        members = {}
        for name, mem in user.signature.members.items():
            if name in MIG_PORT_NAMES or name in self._tie:
                continue
            members[name] = mem
        members["ddr_error"] = Out(1)
        super().__init__(members)

    user = property(lambda self: self._user)
    model = property(lambda self: self._model)

    @property
    def latency(self):
        return getattr(self._user, "latency", None)

    def elaborate(self, platform):
        m = Module()
        m.submodules.user = u = self._user
        m.submodules.model = mdl = self._model
        connect_mig(m, u, mdl)
        for name in self._tie:
            if name in u.signature.members:
                m.d.comb += getattr(u, name).eq(0)
        for name, mem in self.signature.members.items():
            if name in ("i_stream", "o_stream", "ddr_error"):
                continue
            if mem.flow == In:
                m.d.comb += getattr(u, name).eq(getattr(self, name))
            else:
                m.d.comb += getattr(self, name).eq(getattr(u, name))
        i, o = self.i_stream, self.o_stream
        m.d.comb += [u.i_stream.valid.eq(i.valid & ~mdl.error),
                     i.ready.eq(u.i_stream.ready & ~mdl.error),
                     u.i_stream.payload.eq(i.payload)]
        wiring.connect(m, u.o_stream, wiring.flipped(o))
        m.d.comb += self.ddr_error.eq(mdl.error)
        return m
