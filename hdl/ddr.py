"""DDR line/frame buffers behind a MIG-style user interface (SPEC 3.8, seed 002 §4.2).

Golden models, packing, addresses and the Python controller model: :mod:`tdicam.model.ddr`
(read its module docstring first: ``app_addr`` counts 32-bit columns, a 256-bit word is 8
address steps; values packed 24 x 10 bit per word as seed 002 Table 2, first value in the
most significant used bits).

Components
----------
* :class:`MigPort` — one user port on the controller: writes and reads enter one in-order
  command queue (so a read issued after a write to the same address sees the new data),
  write data goes to ``app_wdf_*`` ahead of its command (MIG allows data first), read
  data lands in a FIFO whose space is reserved when the read is queued (``app_rd_data``
  has no backpressure).
* :class:`LineWriter` — pixel stream -> packed 256-bit words at ``base + slot * line_stride``.
* :class:`LineReader` — line requests -> read commands -> unpacked pixel stream.
* :class:`DdrFrameBuffer` — writer + reader through one port: a frame buffer of ``rows``
  lines, the output is the input after a trip through DDR.
* :class:`CdsDdr` — digital CDS (:class:`tdicam.hdl.cds.Cds`) with the reset frame stored
  in DDR and read back line by line while the signal frame streams in.
* :class:`TdiDdr` — the TDI accumulator of :mod:`tdicam.hdl.tdi` with its ``m_max - 1``
  partial-sum lines in DDR.
* :class:`MigModel` — simulation-only controller + memory (same stall pattern as
  :class:`tdicam.model.ddr.MigSim`), and :class:`SimTop` putting a user and a model together
  as one stream component for the fast co-simulation.
"""

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, unsigned
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out
from amaranth.utils import bits_for

from tdicam.errors import TdicamError, check_range
from tdicam.model.ddr import (ADDR_BITS, ADDR_PER_WORD, CAPACITY_BYTES, WORD_BITS, LineLayout,
                              check_capacity, _check_stalls)
from .stream import channels_shape, pixel_signature

__all__ = ["mig_user_ports", "mig_model_ports", "MigModel", "MigPort", "LineWriter",
           "LineReader", "DdrFrameBuffer", "CdsDdr", "TdiDdr", "SimTop", "connect_mig",
           "MIG_PORT_NAMES"]

MIG_PORT_NAMES = ("app_addr", "app_cmd", "app_en", "app_rdy", "app_wdf_data", "app_wdf_wren",
                  "app_wdf_end", "app_wdf_rdy", "app_rd_data", "app_rd_data_valid")
_TO_MEM = ("app_addr", "app_cmd", "app_en", "app_wdf_data", "app_wdf_wren", "app_wdf_end")


def mig_user_ports(addr_bits=ADDR_BITS):
    """Signature members of the user (FPGA logic) side of a MIG native UI."""
    shapes = {"app_addr": addr_bits, "app_cmd": 3, "app_en": 1, "app_rdy": 1,
              "app_wdf_data": WORD_BITS, "app_wdf_wren": 1, "app_wdf_end": 1,
              "app_wdf_rdy": 1, "app_rd_data": WORD_BITS, "app_rd_data_valid": 1}
    return {n: (Out if n in _TO_MEM else In)(unsigned(shapes[n])) for n in MIG_PORT_NAMES}


def mig_model_ports(addr_bits=ADDR_BITS):
    """Members of the controller side (the flip of :func:`mig_user_ports`)."""
    return {n: (In if n in _TO_MEM else Out)(m.shape)
            for n, m in mig_user_ports(addr_bits).items()}


def connect_mig(m, user, ctrl):
    """Wire a user's UI ports to a controller's (both objects with the MIG port names)."""
    for n in MIG_PORT_NAMES:
        if n in _TO_MEM:
            m.d.comb += getattr(ctrl, n).eq(getattr(user, n))
        else:
            m.d.comb += getattr(user, n).eq(getattr(ctrl, n))


def _eq(sig, k):
    """``sig == k``, written ``~sig.any()`` for 0 (yosys prints x == 0 as !x: lint)."""
    return ~sig.any() if k == 0 else sig == k


def _sel(options, index):
    """``options[index]`` as a mux chain (a variable shift would be 2**n words wide)."""
    v = options[0]
    for k in range(1, len(options)):
        v = Mux(index == k, options[k], v)
    return v


def _checked(init):
    """Constructor wrapper: a rejected component is never elaborated, so it must not warn
    as an unused elaboratable."""
    def wrapper(self, *args, **kwargs):
        try:
            init(self, *args, **kwargs)
        except TdicamError:
            self._MustUse__silence = True
            raise
    wrapper.__doc__ = init.__doc__
    return wrapper


def _xorshift(s):
    a = s ^ (s << 13)[:32]
    b = a ^ (a >> 17)
    return (b ^ (b << 5)[:32])[:32]


class MigModel(wiring.Component):
    """Simulation-only model of a DDR3 controller behind a MIG native UI (not synthesizable
    into anything useful: the memory is an array of ``depth_words`` 256-bit words).

    Same behaviour and the same per-cycle stall pattern as
    :class:`tdicam.model.ddr.MigSim` (xorshift32 state seeded with ``seed | 1``, stepping
    every cycle): ``app_rdy`` low in the last ``refresh_cycles`` of every
    ``refresh_period``, when ``state[7:0] < drop`` or when the return queue is nearly full;
    ``app_wdf_rdy`` low when ``state[15:8] < drop`` or the 16-word write-data FIFO is full;
    reads return in order ``lat_lo + (state[31:16] * (lat_hi - lat_lo + 1) >> 16)`` cycles
    after the command (at least one cycle after the previous read's data).

    ``error`` is sticky: an address outside ``depth_words * 8`` or not a multiple of 8, a
    write command with no write data accepted before it, ``app_wdf_end`` low on a data
    beat, or an ``app_cmd`` other than 0/1. The offending command is ignored.
    """

    WDF_DEPTH = 16
    RET_DEPTH = 128

    @_checked
    def __init__(self, *, depth_words, addr_bits=ADDR_BITS, lat_lo=20, lat_hi=60,
                 refresh_period=780, refresh_cycles=26, drop=16, seed=1):
        _check_stalls(lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed)
        check_range("depth_words", depth_words, 1, 1 << (addr_bits - 3))
        self._depth = depth_words
        self._aw = addr_bits
        self._p = (lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed)
        self.memory = None
        super().__init__({**mig_model_ports(addr_bits), "error": Out(1),
                          "writes": Out(32), "reads": Out(32)})

    depth_words = property(lambda self: self._depth)

    def elaborate(self, platform):
        m = Module()
        lo, hi, period, rcyc, drop, seed = self._p
        D, WB = self._depth, WORD_BITS
        s = Signal(32, init=(seed | 1) & 0xFFFFFFFF)
        m.d.sync += s.eq(_xorshift(s))
        t = Signal(32)
        m.d.sync += t.eq(t + 1)
        rc = Signal(range(period))
        m.d.sync += rc.eq(Mux(rc == period - 1, 0, rc + 1))
        refresh = Signal()
        m.d.comb += refresh.eq(rc >= period - rcyc) if rcyc else refresh.eq(0)

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

        m.d.comb += [
            self.app_rdy.eq(~refresh & (s[0:8] >= drop) & (ret_n < self.RET_DEPTH - 2)),
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
        return m


class MigPort(wiring.Component):
    """One in-order user port on a MIG native UI.

    ``wr_*`` (address + 256-bit word) and ``rd_*`` (address) requests enter one command
    queue in the order accepted (a write offered in the same cycle as a read goes first),
    so every read sees every write queued before it. Write data is sent on ``app_wdf_*``
    as soon as the controller takes it and its command follows once the data was
    accepted in an earlier cycle. A read is queued only while the read-data FIFO has room
    for it (``rd_depth`` words reserved from queueing until the word is taken from
    ``rdata``), because ``app_rd_data_valid`` cannot be stalled. Commands, data and read
    data each move one per cycle: ``app_en`` and ``app_wdf_wren`` never depend on the
    ready signals.
    """

    def __init__(self, *, addr_bits=ADDR_BITS, cmd_depth=16, wdata_depth=16, rd_depth=64):
        self._aw, self._cq, self._wq, self._rd = addr_bits, cmd_depth, wdata_depth, rd_depth
        super().__init__({
            "wr_valid": In(1), "wr_ready": Out(1), "wr_addr": In(addr_bits),
            "wr_data": In(WORD_BITS),
            "rd_valid": In(1), "rd_ready": Out(1), "rd_addr": In(addr_bits),
            "rdata_valid": Out(1), "rdata_ready": In(1), "rdata": Out(WORD_BITS),
            "idle": Out(1),
            **mig_user_ports(addr_bits)})

    rd_depth = property(lambda self: self._rd)

    def elaborate(self, platform):
        m = Module()
        AW = self._aw
        m.submodules.cmdq = cmdq = SyncFIFOBuffered(width=AW + 1, depth=self._cq)
        m.submodules.wq = wq = SyncFIFOBuffered(width=WORD_BITS, depth=self._wq)
        m.submodules.rq = rq = SyncFIFOBuffered(width=WORD_BITS, depth=self._rd)
        out_n = Signal(range(self._rd + 1))
        m.d.comb += [
            self.wr_ready.eq(cmdq.w_rdy & wq.w_rdy),
            self.rd_ready.eq(cmdq.w_rdy & ~self.wr_valid & (out_n < self._rd)),
        ]
        push_w = self.wr_valid & self.wr_ready
        push_r = self.rd_valid & self.rd_ready
        m.d.comb += [
            cmdq.w_en.eq(push_w | push_r),
            cmdq.w_data.eq(Cat(Mux(push_w, self.wr_addr, self.rd_addr), ~push_w)),
            wq.w_en.eq(push_w), wq.w_data.eq(self.wr_data),
        ]
        ahead = Signal(range(self._wq + 2))
        head_read = cmdq.r_data[AW]
        m.d.comb += [
            self.app_wdf_data.eq(wq.r_data), self.app_wdf_wren.eq(wq.r_rdy),
            self.app_wdf_end.eq(wq.r_rdy), wq.r_en.eq(self.app_wdf_rdy),
            self.app_en.eq(cmdq.r_rdy & (head_read | ahead.any())),
            self.app_cmd.eq(head_read), self.app_addr.eq(cmdq.r_data[:AW]),
            cmdq.r_en.eq(self.app_en & self.app_rdy),
        ]
        dfire = wq.r_rdy & self.app_wdf_rdy
        wcfire = self.app_en & self.app_rdy & ~head_read
        m.d.sync += ahead.eq(ahead + dfire - wcfire)
        m.d.comb += [rq.w_en.eq(self.app_rd_data_valid), rq.w_data.eq(self.app_rd_data),
                     self.rdata.eq(rq.r_data), self.rdata_valid.eq(rq.r_rdy),
                     rq.r_en.eq(self.rdata_ready)]
        m.d.sync += out_n.eq(out_n + push_r - (rq.r_rdy & self.rdata_ready))
        m.d.comb += self.idle.eq(~cmdq.r_rdy & ~cmdq.level.any() & ~wq.r_rdy)
        return m


def _gear(elements, ppw):
    if ppw % elements == 0:
        return ppw // elements, 1
    if elements % ppw == 0:
        return 1, elements // ppw
    raise TdicamError(f"elements = {elements} per beat and pixels_per_word = {ppw}: one "
                      "must divide the other")


def _word_slices(ppw, bits):
    """(lo, hi) bit range of value j in a word (first value most significant)."""
    return [((ppw - 1 - j) * bits, (ppw - j) * bits) for j in range(ppw)]


class LineWriter(wiring.Component):
    """Pixel stream -> packed 256-bit words, one line every ``width`` beats.

    Line k of the stream goes to slot ``k mod rows`` at ``base + slot * line_stride`` (a
    beat with ``first`` at the start of a line restarts at slot 0). Beats carry
    ``elements`` values, in the layout's (pixel, channel) order. ``wr_eol`` marks a line's
    last word, ``wr_first`` its frame-start flag (``first`` on the line's first beat).
    ``line_ok`` low holds the first beat of a new line (the user's line-lead limit).
    Lines are cut by count; a ``last`` that disagrees counts in ``line_errors``.
    """

    @_checked
    def __init__(self, *, layout, elements, rows, addr_bits=ADDR_BITS):
        self._lay, self._e, self._rows, self._aw = layout, elements, rows, addr_bits
        if layout.values_per_line % elements:
            raise TdicamError(f"a line of {layout.values_per_line} values is not a whole "
                              f"number of {elements}-value beats")
        self._g, self._r = _gear(elements, layout.pixels_per_word)
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(layout.pixel_bits, elements))),
            "wr_valid": Out(1), "wr_ready": In(1), "wr_addr": Out(addr_bits),
            "wr_data": Out(WORD_BITS), "wr_eol": Out(1), "wr_first": Out(1),
            "line_ok": In(1), "line_start": Out(1), "busy": Out(1),
            "line_errors": Out(16)})

    def elaborate(self, platform):
        m = Module()
        lay, E, G, R = self._lay, self._e, self._g, self._r
        P, B = lay.pixels_per_word, lay.pixel_bits
        W = lay.values_per_line // E           # beats per line
        i = self.i_stream
        col = Signal(range(W))
        line_base = Signal(self._aw, init=lay.base)
        waddr = Signal(self._aw, init=lay.base)
        first_flag = Signal()
        errs = Signal(16)
        m.d.comb += self.line_errors.eq(errs)
        last_col = col == W - 1
        restart = i.payload.first & ~col.any()
        line_start = ~col.any()
        fire = Signal()
        m.d.comb += [fire.eq(i.valid & i.ready), self.line_start.eq(fire & line_start)]
        beat = [i.payload.data[k] if E > 1 else i.payload.data for k in range(E)]
        end_base = lay.base + (self._rows - 1) * lay.line_stride
        next_base = Mux(restart, Const(lay.base, self._aw), line_base)
        next_line = Mux(next_base == end_base, lay.base, next_base + lay.line_stride)

        with m.If(fire):
            with m.If(i.payload.last != last_col):
                with m.If(errs != 0xFFFF):
                    m.d.sync += errs.eq(errs + 1)
            with m.If(line_start):
                m.d.sync += first_flag.eq(i.payload.first)

        o_valid = Signal()
        o_data = Signal(WORD_BITS)
        o_addr = Signal(self._aw)
        o_eol, o_first = Signal(), Signal()
        m.d.comb += [self.wr_valid.eq(o_valid), self.wr_data.eq(o_data),
                     self.wr_addr.eq(o_addr), self.wr_eol.eq(o_eol),
                     self.wr_first.eq(o_first)]
        ofire = o_valid & self.wr_ready
        cur_addr = Mux(line_start, next_base, waddr)
        cur_first = Mux(line_start, i.payload.first, first_flag)
        if R == 1:
            k = Signal(range(max(G, 2)))
            vals = [Signal(B, name=f"v{j}") for j in range(P)]
            completes = (k == G - 1) | last_col
            m.d.comb += [
                i.ready.eq(~(completes & o_valid & ~self.wr_ready) & (~line_start | self.line_ok)),
                self.busy.eq(o_valid | k.any()),
            ]
            new_vals = []
            for j in range(P):
                g, e = divmod(j, E)
                nv = Mux(_eq(k, g), beat[e], Mux(~k.any(), 0, vals[j])) if G > 1 else beat[e]
                new_vals.append(nv)
            word = Cat(*[new_vals[j] for j in reversed(range(P))], Const(0, WORD_BITS - P * B))
            with m.If(fire):
                m.d.sync += [v.eq(nv) for v, nv in zip(vals, new_vals)]
                with m.If(completes):
                    m.d.sync += [o_valid.eq(1), o_data.eq(word), o_addr.eq(cur_addr),
                                 o_eol.eq(last_col), o_first.eq(cur_first), k.eq(0)]
                    with m.If(last_col):
                        m.d.sync += [col.eq(0), line_base.eq(next_line), waddr.eq(next_line)]
                    with m.Else():
                        m.d.sync += [col.eq(col + 1), waddr.eq(cur_addr + ADDR_PER_WORD)]
                        with m.If(line_start):
                            m.d.sync += line_base.eq(next_base)
                with m.Else():
                    m.d.sync += [k.eq(k + 1), col.eq(col + 1), waddr.eq(cur_addr)]
                    with m.If(line_start):
                        m.d.sync += line_base.eq(next_base)
                with m.If(ofire & ~completes):
                    m.d.sync += o_valid.eq(0)
            with m.Elif(ofire):
                m.d.sync += o_valid.eq(0)
        else:
            # one beat -> R words, sent one per cycle from the held beat
            r = Signal(range(R))
            held = Signal(E * B)
            h_eol, h_first = Signal(), Signal()
            m.d.comb += self.busy.eq(o_valid)
            last_sub = r == R - 1
            m.d.comb += i.ready.eq((~o_valid | (self.wr_ready & last_sub))
                                   & (~line_start | self.line_ok))
            words = []
            for w in range(R):
                vals = [held[(w * P + j) * B:(w * P + j + 1) * B] for j in range(P)]
                words.append(Cat(*[vals[j] for j in reversed(range(P))],
                                 Const(0, WORD_BITS - P * B)))
            m.d.comb += [self.wr_data.eq(_sel(words, r)),
                         self.wr_eol.eq(h_eol & last_sub), self.wr_first.eq(h_first)]
            with m.If(fire):
                m.d.sync += [o_valid.eq(1), held.eq(Cat(*beat)), r.eq(0),
                             o_addr.eq(cur_addr), h_eol.eq(last_col), h_first.eq(cur_first)]
                with m.If(last_col):
                    m.d.sync += [col.eq(0), line_base.eq(next_line), waddr.eq(next_line)]
                with m.Else():
                    m.d.sync += [col.eq(col + 1), waddr.eq(cur_addr + R * ADDR_PER_WORD)]
                    with m.If(line_start):
                        m.d.sync += line_base.eq(next_base)
            with m.Elif(ofire):
                with m.If(last_sub):
                    m.d.sync += o_valid.eq(0)
                with m.Else():
                    m.d.sync += [r.eq(r + 1), o_addr.eq(o_addr + ADDR_PER_WORD)]
        return m


class LineReader(wiring.Component):
    """Line requests (first address, frame-start flag) -> unpacked pixel stream.

    Each request reads the layout's words of one line through ``rd_*`` and emits its
    ``width * channels / elements`` beats on ``o_stream``, ``first`` on beat 0 when the
    request's flag is set, ``last`` on the final beat. ``line_issued`` pulses when a line's
    last read was queued.
    """

    @_checked
    def __init__(self, *, layout, elements, addr_bits=ADDR_BITS, max_lines=66):
        self._lay, self._e, self._aw, self._fl = layout, elements, addr_bits, max_lines
        self._g, self._r = _gear(elements, layout.pixels_per_word)
        super().__init__({
            "req_valid": In(1), "req_ready": Out(1), "req_addr": In(addr_bits),
            "req_first": In(1),
            "rd_valid": Out(1), "rd_ready": In(1), "rd_addr": Out(addr_bits),
            "rdata_valid": In(1), "rdata_ready": Out(1), "rdata": In(WORD_BITS),
            "line_issued": Out(1),
            "o_stream": Out(pixel_signature(channels_shape(layout.pixel_bits, elements)))})

    def elaborate(self, platform):
        m = Module()
        lay, E, G, R = self._lay, self._e, self._g, self._r
        P, B = lay.pixels_per_word, lay.pixel_bits
        W = lay.values_per_line // E
        WPL = lay.words_per_line
        m.submodules.flight = flight = SyncFIFOBuffered(width=1, depth=self._fl)
        cur_valid = Signal()
        cur_addr = Signal(self._aw)
        w = Signal(range(WPL))
        m.d.comb += [self.req_ready.eq(~cur_valid & flight.w_rdy),
                     flight.w_en.eq(self.req_valid & self.req_ready),
                     flight.w_data.eq(self.req_first),
                     self.rd_valid.eq(cur_valid), self.rd_addr.eq(cur_addr)]
        rfire = cur_valid & self.rd_ready
        m.d.comb += self.line_issued.eq(rfire & (w == WPL - 1))
        with m.If(self.req_valid & self.req_ready):
            m.d.sync += [cur_valid.eq(1), cur_addr.eq(self.req_addr), w.eq(0)]
        with m.Elif(rfire):
            m.d.sync += [cur_addr.eq(cur_addr + ADDR_PER_WORD), w.eq(w + 1)]
            with m.If(w == WPL - 1):
                m.d.sync += cur_valid.eq(0)

        o = self.o_stream
        col = Signal(range(W))
        last_col = col == W - 1
        ofire = o.valid & o.ready
        m.d.comb += [o.payload.first.eq(flight.r_data & ~col.any()),
                     o.payload.last.eq(last_col),
                     flight.r_en.eq(ofire & last_col)]
        with m.If(ofire):
            m.d.sync += col.eq(Mux(last_col, 0, col + 1))
        sl = _word_slices(P, B)
        if R == 1:
            k = Signal(range(max(G, 2)))
            wv = Signal()
            word = Signal(WORD_BITS)
            done = (k == G - 1) | last_col
            m.d.comb += [o.valid.eq(wv),
                         self.rdata_ready.eq(~wv | (ofire & done))]
            vals = [word[lo:hi] for lo, hi in sl]
            for e in range(E):
                opts = [vals[g * E + e] for g in range(G)]
                v = opts[0] if G == 1 else _sel(opts, k)
                m.d.comb += (o.payload.data[e] if E > 1 else o.payload.data).eq(v)
            with m.If(ofire):
                m.d.sync += k.eq(Mux(done, 0, k + 1))
                with m.If(done):
                    m.d.sync += wv.eq(0)
            with m.If(self.rdata_valid & self.rdata_ready):
                m.d.sync += [wv.eq(1), word.eq(self.rdata)]
        else:
            r = Signal(range(R))
            buf = [Signal(WORD_BITS, name=f"buf{x}") for x in range(R - 1)]
            bv = Signal()
            beat = Signal(E * B)
            m.d.comb += [o.valid.eq(bv), Value.cast(o.payload.data).eq(beat),
                         self.rdata_ready.eq((r != R - 1) | ~bv | o.ready)]
            words = buf + [self.rdata]
            new_beat = Cat(*[words[x][sl[j][0]:sl[j][1]] for x in range(R) for j in range(P)])
            rdfire = self.rdata_valid & self.rdata_ready
            with m.If(rdfire):
                with m.If(r == R - 1):
                    m.d.sync += [beat.eq(new_beat), bv.eq(1), r.eq(0)]
                with m.Else():
                    m.d.sync += r.eq(r + 1)
                    for x in range(R - 1):
                        with m.If(_eq(r, x)):
                            m.d.sync += buf[x].eq(self.rdata)
            with m.If(ofire & ~(rdfire & (r == R - 1))):
                m.d.sync += bv.eq(0)
        return m


def _layout(width, channels, pixel_bits, pixels_per_word, line_stride, base):
    return LineLayout(width=width, channels=channels, pixel_bits=pixel_bits,
                      pixels_per_word=pixels_per_word, line_stride=line_stride, base=base)


class DdrFrameBuffer(wiring.Component):
    """A frame buffer in DDR: every line written, read back, and streamed out unchanged.

    Parameters
    ----------
    width : int
        Pixels per line.
    rows : int
        Lines the buffer holds (a frame's height): line y of a frame is stored at
        ``base + y * line_stride``; the writer never gets more than ``rows`` lines ahead of
        the reads, so no line is overwritten before it was read.
    channels : int
        Values per pixel (72 in seed 002).
    elements : int
        Values per beat (divides or is a multiple of ``pixels_per_word``; default
        ``channels``).
    pixel_bits, pixels_per_word, line_stride, base
        The packing and addresses (:class:`tdicam.model.ddr.LineLayout`).
    capacity_bytes : int
        DDR size for the address check.

    Attributes
    ----------
    i_stream, o_stream : pixel streams of ``elements`` x ``pixel_bits``
        Output = input (values, ``first``, ``last`` on every ``width * channels / elements``
        beats), after the round trip.
    hold_reads : In(1)
        While high no read is queued (to measure writes alone).
    line_errors : Out(16)
        Input lines whose ``last`` was misplaced (lines are cut by count).

    Notes
    -----
    Latency: at least one line plus the DDR read latency. Throughput: one word per
    cycle each way at best, shared by reads and writes (writes first).
    """

    @_checked
    def __init__(self, *, width, rows, channels=1, elements=None, pixel_bits=10,
                 pixels_per_word=24, line_stride=None, base=0, capacity_bytes=CAPACITY_BYTES,
                 rd_depth=64):
        self.layout = _layout(width, channels, pixel_bits, pixels_per_word, line_stride, base)
        check_range("rows", rows, 1, 1 << 16)
        self._e = channels if elements is None else elements
        _gear(self._e, pixels_per_word)
        check_capacity(self.layout, rows, capacity_bytes, "frame buffer")
        self._rows, self._rd = rows, rd_depth
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, self._e))),
            "o_stream": Out(pixel_signature(channels_shape(pixel_bits, self._e))),
            "hold_reads": In(1), "line_errors": Out(16), **mig_user_ports()})

    elements = property(lambda self: self._e)
    rows = property(lambda self: self._rows)

    def elaborate(self, platform):
        m = Module()
        lay = self.layout
        m.submodules.port = port = MigPort(rd_depth=self._rd)
        m.submodules.writer = wr = LineWriter(layout=lay, elements=self._e, rows=self._rows)
        fl = self._rd // lay.words_per_line + 3
        m.submodules.reader = rd = LineReader(layout=lay, elements=self._e, max_lines=fl)
        m.submodules.desc = desc = SyncFIFOBuffered(width=ADDR_BITS + 1, depth=self._rows + 1)
        wiring.connect(m, wiring.flipped(self.i_stream), wr.i_stream)
        wiring.connect(m, rd.o_stream, wiring.flipped(self.o_stream))
        connect_mig(m, port, self)
        m.d.comb += self.line_errors.eq(wr.line_errors)
        # writer -> port (+ a line descriptor with each line's last word)
        m.d.comb += [port.wr_valid.eq(wr.wr_valid & (~wr.wr_eol | desc.w_rdy)),
                     wr.wr_ready.eq(port.wr_ready & (~wr.wr_eol | desc.w_rdy)),
                     port.wr_addr.eq(wr.wr_addr), port.wr_data.eq(wr.wr_data),
                     desc.w_en.eq(wr.wr_valid & wr.wr_eol & port.wr_ready & desc.w_rdy),
                     desc.w_data.eq(Cat((wr.wr_addr - (lay.words_per_line - 1) * ADDR_PER_WORD)[:ADDR_BITS],
                                        wr.wr_first))]
        # descriptors -> reader -> port
        m.d.comb += [rd.req_valid.eq(desc.r_rdy & ~self.hold_reads),
                     desc.r_en.eq(rd.req_ready & ~self.hold_reads),
                     rd.req_addr.eq(desc.r_data[:ADDR_BITS]),
                     rd.req_first.eq(desc.r_data[ADDR_BITS]),
                     port.rd_valid.eq(rd.rd_valid), rd.rd_ready.eq(port.rd_ready),
                     port.rd_addr.eq(rd.rd_addr),
                     rd.rdata_valid.eq(port.rdata_valid), port.rdata_ready.eq(rd.rdata_ready),
                     rd.rdata.eq(port.rdata)]
        # line lead: lines started by the writer minus lines fully queued by the reader
        lead = Signal(range(self._rows + 2))
        m.d.sync += lead.eq(lead + wr.line_start - rd.line_issued)
        m.d.comb += wr.line_ok.eq(lead < self._rows)
        return m


class SimTop(wiring.Component):
    """A DDR user with a :class:`MigModel` behind it, as one component for co-simulation.

    Exposes the user's streams and its other non-MIG ports unchanged, plus ``ddr_error``
    (the model's sticky error). While ``ddr_error`` is high the input is never accepted,
    so a co-simulation with an out-of-range access fails visibly. Input ports named in
    ``tie_low`` are not exposed (held at 0): level controls such as ``hold_reads``, which
    the stream testbench would drive from stale stimulus after the last beat.
    """

    def __init__(self, user, *, depth_words, tie_low=("hold_reads",), **stalls):
        self._user = user
        self._tie = tuple(tie_low)
        self._model = MigModel(depth_words=depth_words, **stalls)
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


class CdsDdr(wiring.Component):
    """Digital CDS with the reset frame stored in DDR (SPEC 3.2 + 3.8, seed 002 §4.4.1).

    Golden model: :func:`tdicam.model.ddr.cds_ddr_frames`.

    Parameters
    ----------
    width, rows : int
        Frame size (pixels per line, lines). Frames must be exactly ``rows`` x ``width``.
    pixel_bits : int
        8..16 (the :class:`~tdicam.hdl.cds.Cds` core's range).
    pixels_per_word : int or None
        Reset values per 256-bit word; default 24 for 10-bit pixels (seed 002 Table 2),
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

    @_checked
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
        from .cds import Cds
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

    @_checked
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
        chunk = _sel(chunks, q["wpos"]) if J > 1 else chunks[0]
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
            new_chunks.append(Mux(_eq(q["wpos"], p), Cat(*sums), Mux(~q["wpos"].any(), 0, old)))
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


_WAIT, _RUN, _DROP, _PAD = range(4)
