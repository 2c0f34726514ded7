"""LVDS receiver with IDELAY bit training, bitslip word alignment and lane deskew.

Ning et al. 2019 §4.1. The golden model and the exact timing contract are in
:mod:`tdicam.model.lvds` (module docstring); this module implements it:

* :class:`LaneTrainer` — per lane: the fabric bitslip gearbox and the training controller
  (drives the delay tap with its load strobe and the bitslip, checks the training word over
  ``n_check`` words per tap, finds the widest run, samples at its ``pick``-th tap, aligns the
  word, locks, then keeps checking the lane and reports a lane that dies).
* :class:`Deskew` — per-lane FIFOs in dual-port RAM, written from each lane's first sync word
  and read in lockstep once every trained lane has seen its sync word.
* :class:`LvdsRx` — N lanes + deskew + status (the simulated and generated top ``lvds``).
* :class:`LvdsXilinx` — the same core behind 7-series IBUFDS/IDELAYE2/ISERDESE2 instances
  (simulated from serial bits with the primitive models: :mod:`tdicam.cosim.lvds_pins`).

Everything runs in one clock domain, the *word clock*: one word per lane per cycle.

One module (~600 lines) on purpose: the lane trainer, the deskew and the two receiver tops
share the lane status layout and the settings checks, and are verified together.
"""

from amaranth.hdl import Cat, ClockDomain, ClockSignal, Const, Instance, Module, \
    Mux, ResetSignal, Signal
from amaranth.lib import memory, wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError, check_choice, check_range
from tdicam.model.lvds import LINK_LATENCY, N_TAPS, VERDICT_WORDS
from tdicam.model.lvds_track import COUNT_BITS
from tdicam.hdl.util import quiet_reject

__all__ = ["LaneTrainer", "Deskew", "LvdsRx", "LvdsXilinx", "TAP_BITS", "SLIP_BITS",
           "RUN_BITS", "forward_core", "settings_registers", "rx_ports", "lane_ports", "eye_ports", "EYE_STATUS"]

TAP_BITS = 5
SLIP_BITS = 4
RUN_BITS = 6
# state codes start at 1: yosys writes "x == 0" as "!x", which lints as WIDTHTRUNC
_SCAN, _DECIDE, _SLIP, _LOCKED, _ERROR = range(1, 6)


def _settings_shapes(w, settle):
    """{name: shape} of a lane's registered settings (:func:`settings_registers`)."""
    top = settle + 255 + VERDICT_WORDS - 1
    return {"train_word": w, "sync_word": w, "line_words": 16, "chk_end": range(top + 1),
            "last_at": range(top + 1)}


def settings_registers(m, settle, train_word, sync_word, n_check, line_words):
    """The lanes' quasi-static settings registered (one cycle after they change; a lane
    first uses them >= ``settle`` cycles into a step): ``(train_word, sync_word,
    line_words, chk_end, last_at)``, the last two the step's check end ``settle +
    max(n_check, 1)`` and verdict cycle (:data:`VERDICT_WORDS` - 1 after it). Made by each
    :class:`LaneTrainer` for itself, or once for all the lanes of :class:`LvdsRx`."""
    shapes = _settings_shapes(len(train_word), settle)
    top = shapes["last_at"].stop - 1
    regs = {name: Signal(shape, reset_less=True, name=f"reg_{name}",
                         init={"chk_end": settle + 1, "last_at": top}.get(name, 0))
            for name, shape in shapes.items()}
    n_eff = Mux(n_check.any(), n_check, 1)
    m.d.sync += [regs["chk_end"].eq(settle + n_eff),
                 regs["last_at"].eq(settle + n_eff + (VERDICT_WORDS - 1)),
                 regs["train_word"].eq(train_word), regs["sync_word"].eq(sync_word),
                 regs["line_words"].eq(line_words)]
    return tuple(regs[name] for name in shapes)


def _check_common(word_bits, settle, min_run, pick):
    check_choice("word_bits", word_bits, (10, 12))
    check_range("settle", settle, LINK_LATENCY + 2, 64)
    check_range("min_run", min_run, 1, N_TAPS)
    check_range("pick", pick, 1, N_TAPS)
    if pick > min_run:
        raise TdicamError(f"pick = {pick} must not exceed min_run = {min_run} (the sample "
                          f"tap must lie inside the accepted run)")


class LaneTrainer(wiring.Component):
    """Bit training, word alignment and supervision of one lane.

    Parameters
    ----------
    word_bits : 10 or 12
    settle : int, 4..64
        Word clocks ignored after a tap load or bitslip change (covers the delay line, the
        deserializer and the gearbox; the simulated link needs >= 3).
    min_run, pick : int
        Accept a run of at least ``min_run`` passing taps; sample at its ``pick``-th tap.

    Attributes
    ----------
    raw : In(word_bits)
        Deserializer word, first received bit in the MSB.
    train_word, sync_word : In(word_bits)
        Run-time registers (the training word must differ from all its rotations).
    n_check : In(8)
        Words checked per tap and per bitslip (0 counts as 1).
    line_words : In(16)
        Sync word period in data mode (>= 2).
    restart : In(1)
        Restart training next cycle (retrain request).
    reg_train_word, reg_sync_word, reg_line_words, reg_chk_end, reg_last_at : In, with
    ``shared=True`` only
        In place of the four settings above: their registers made once for all lanes by
        :func:`settings_registers` (what a lane makes for itself without ``shared``), so N
        lanes hold one copy; the same cycles.
    hold : In(1), with ``hold=True`` only
        The delay line is still moving to the step's tap (a delay stepped one count at a
        time, the ECP5 DELAYF): the step's word counter stays at 0 while it is high, so the
        ``settle`` words start once the delay has arrived. Without it every step has the
        fixed length of :meth:`step_words`.
    slip_pass, walk : Out(word_bits), Out(2*word_bits), with ``eye=True`` only
        The eye status (:mod:`tdicam.model.lvds`): bit ``s`` of ``slip_pass`` = slip ``s``
        locked (the slips before it failed); ``walk``: the walking-1/0 patterns received
        after lock and before the first sync word (bit ``j``: only bit ``j`` set, bit
        ``W + j``: only bit ``j`` clear; all ones = every bit seen as 1 and 0). With ``eye``
        the locked lane accepts those patterns before its first sync word.
    up, down : In(1), with ``track=True`` only
        While locked: step the tap up / down by one (a tracker's correction,
        :class:`tdicam.hdl.lvds_track.LaneTracker`), with the load strobe; a lane error
        takes precedence.
    tap, ld : Out(5), Out(1)
        Delay tap and its load strobe (high in the first cycle of every step).
    slip : Out(4)
        Gearbox bitslip 0..W-1.
    locked, error : Out(1)
        Status; never both. ``error`` = no run of ``min_run`` taps, no bitslip matched, or the
        lane broke the training/sync rules after lock.
    run : Out(6)
        Length of the widest run found. ``scan`` : Out(32): taps that passed.
    word, word_sync : Out(word_bits), Out(1)
        The aligned word (2 cycles after its raw word) and whether it is the sync word.

    Notes
    -----
    Step timing (see :mod:`tdicam.model.lvds`): a step lasts
    :meth:`step_words` ``= settle + max(n_check, 1) + 3``; 32 scan steps, 1 decide cycle,
    up to W slip steps. Error after lock shows 3 cycles after the offending raw word.
    ``train_word``, ``sync_word``, ``n_check`` and ``line_words`` are registered in the lane
    (timing): a change takes effect one cycle later; hold them while training.
    """

    @quiet_reject
    def __init__(self, *, word_bits=10, settle=8, min_run=9, pick=5, hold=False, eye=False,
                 track=False, shared=False):
        _check_common(word_bits, settle, min_run, pick)
        self._w, self._settle, self._min_run, self._pick = word_bits, settle, min_run, pick
        self._hold, self._eye, self._track = bool(hold), bool(eye), bool(track)
        self._shared = bool(shared)
        w = word_bits
        settings = ({f"reg_{name}": In(shape) for name, shape in
                     _settings_shapes(w, settle).items()} if shared else
                    {"train_word": In(w), "sync_word": In(w), "n_check": In(8),
                     "line_words": In(16)})
        ports = {
            "raw": In(w), **settings, "restart": In(1),
            "tap": Out(TAP_BITS), "ld": Out(1, init=1), "slip": Out(SLIP_BITS),
            "locked": Out(1), "error": Out(1), "run": Out(RUN_BITS), "scan": Out(N_TAPS),
            "word": Out(w), "word_sync": Out(1),
        }
        if hold:
            ports["hold"] = In(1)
        if eye:
            ports.update({"slip_pass": Out(w), "walk": Out(2 * w)})
        if track:
            ports.update({"up": In(1), "down": In(1)})
        super().__init__(ports)

    @property
    def word_bits(self):
        return self._w

    @property
    def settle(self):
        return self._settle

    @property
    def latency(self):
        """Cycles from a raw word to its aligned ``word`` output."""
        return 2

    def step_words(self, n_check):
        return self._settle + max(int(n_check), 1) + VERDICT_WORDS

    def elaborate(self, platform):
        m = Module()
        w, settle = self._w, self._settle
        state = Signal(3, init=_SCAN)
        cnt = Signal(range(settle + 256 + VERDICT_WORDS))
        if self._shared:
            train_word, sync_word, line_words, chk_end, last_at = (
                getattr(self, f"reg_{name}") for name in _settings_shapes(w, settle))
        else:
            train_word, sync_word, line_words, chk_end, last_at = settings_registers(
                m, settle, self.train_word, self.sync_word, self.n_check, self.line_words)
        last = cnt == last_at
        in_step = (state == _SCAN) | (state == _SLIP)

        # gearbox: word = samples (k-1)*W + slip .. of {previous raw, raw}
        prev = Signal(w)
        m.d.sync += prev.eq(self.raw)
        both = Cat(self.raw, prev)
        # as a shifter: (both << slip)[W:2W] = both[W-slip:2W-slip] (slip 0..W-1; a
        # 16-entry case on the slip maps to about twice the LUTs)
        g = (both << self.slip)[w:2 * w]

        # stage A: aligned word and what to do with it (decided at port time)
        w_a, chk_a, first_a, mon_a, scan_a = (Signal(w), Signal(), Signal(), Signal(),
                                              Signal())
        m.d.sync += [
            w_a.eq(g),
            chk_a.eq(in_step & (cnt >= settle) & (cnt < chk_end)),
            first_a.eq(cnt == settle),
            mon_a.eq(state == _LOCKED),
            scan_a.eq(state == _SCAN),
        ]
        # stage B: comparisons
        rots = [Cat(train_word[w - r:], train_word[:w - r]) if r else train_word
                for r in range(w)]
        w_b, chk_b, first_b, mon_b, scan_b = (Signal(w), Signal(), Signal(), Signal(),
                                              Signal())
        eq_rot, eq_train, eq_sync = Signal(w), Signal(), Signal()
        if self._eye:
            eq_walk = Signal(2 * w)
            full = (1 << w) - 1
            m.d.sync += eq_walk.eq(Cat(*(w_a == (1 << j) for j in range(w)),
                                       *(w_a == (full ^ (1 << j)) for j in range(w))))
        m.d.sync += [
            w_b.eq(w_a), chk_b.eq(chk_a), first_b.eq(first_a), mon_b.eq(mon_a),
            scan_b.eq(scan_a),
            eq_rot.eq(Cat(w_a == r for r in rots)),
            eq_train.eq(w_a == train_word),
            eq_sync.eq(w_a == sync_word),
        ]
        m.d.comb += [self.word.eq(w_b), self.word_sync.eq(eq_sync)]

        # stage C: verdict accumulation
        ok, ref, cur_word = Signal(), Signal(w), Signal(w)
        same = Signal()  # ref == cur_word, written with ref
        with m.If(chk_b):
            with m.If(first_b):
                m.d.sync += [ok.eq(Mux(scan_b, eq_rot.any(), eq_train)), ref.eq(w_b),
                             same.eq(w_b == cur_word)]
            with m.Else():
                m.d.sync += ok.eq(ok & Mux(scan_b, w_b == ref, eq_train))

        # run tracking
        prev_pass = Signal()
        cur_start, cur_len = Signal(TAP_BITS), Signal(RUN_BITS)
        best_start, best_len = Signal(TAP_BITS), Signal(RUN_BITS)
        # comparisons precomputed from registers that only change at a step's end
        len_inc, inc_gt, one_gt = Signal(RUN_BITS), Signal(), Signal()
        tap_hot = Signal(N_TAPS)
        m.d.sync += [len_inc.eq(cur_len + 1), inc_gt.eq(cur_len + 1 > best_len),
                     one_gt.eq(~best_len.any()), tap_hot.eq(1 << self.tap)]
        extend = ok & prev_pass & same
        new_len = Mux(ok, Mux(extend, len_inc, 1), 0)
        new_start = Mux(extend, cur_start, self.tap)
        better = ok & Mux(extend, inc_gt, one_gt)
        m.d.comb += [self.run.eq(best_len)]

        # locked-lane supervision
        mphase = Signal()
        lpos = Signal(16)
        lpos_next = lpos + 1
        go_error_mon = Signal()
        with m.If(mon_b & (state == _LOCKED)):
            with m.If(~mphase):
                with m.If(eq_sync):
                    m.d.sync += [mphase.eq(1), lpos.eq(Mux(lpos_next >= line_words,
                                                           0, lpos_next))]
                with m.Elif(~eq_train & ~eq_walk.any() if self._eye else ~eq_train):
                    m.d.comb += go_error_mon.eq(1)
                if self._eye:
                    m.d.sync += self.walk.eq(self.walk | eq_walk)
            with m.Else():
                with m.If(eq_sync == lpos.any()):
                    m.d.comb += go_error_mon.eq(1)
                m.d.sync += lpos.eq(Mux(lpos_next >= line_words, 0, lpos_next))

        m.d.sync += self.ld.eq(0)
        with m.If(state == _SCAN):
            m.d.sync += cnt.eq(cnt + 1)
            with m.If(last):
                m.d.sync += [
                    cnt.eq(0),
                    prev_pass.eq(ok), cur_word.eq(ref), cur_len.eq(new_len),
                    cur_start.eq(new_start),
                    self.scan.eq(self.scan | Mux(ok, tap_hot, 0)),
                ]
                with m.If(better):
                    m.d.sync += [best_len.eq(new_len), best_start.eq(new_start)]
                with m.If(self.tap == N_TAPS - 1):
                    m.d.sync += state.eq(_DECIDE)
                with m.Else():
                    m.d.sync += [self.tap.eq(self.tap + 1), self.ld.eq(1)]
            if self._hold:
                with m.If(self.hold):
                    m.d.sync += cnt.eq(0)
        with m.Elif(state == _DECIDE):
            m.d.sync += [cnt.eq(0), self.slip.eq(0), self.ld.eq(1)]
            with m.If(best_len >= self._min_run):
                m.d.sync += [state.eq(_SLIP), self.tap.eq(best_start + (self._pick - 1))]
            with m.Else():
                m.d.sync += [state.eq(_ERROR), self.error.eq(1), self.tap.eq(0)]
        with m.Elif(state == _SLIP):
            m.d.sync += cnt.eq(cnt + 1)
            with m.If(last):
                m.d.sync += cnt.eq(0)
                with m.If(ok):
                    m.d.sync += [state.eq(_LOCKED), self.locked.eq(1)]
                    if self._eye:
                        m.d.sync += self.slip_pass.eq(1 << self.slip)
                with m.Elif(self.slip == w - 1):
                    m.d.sync += [state.eq(_ERROR), self.error.eq(1), self.tap.eq(0),
                                 self.slip.eq(0), self.ld.eq(1)]
                with m.Else():
                    m.d.sync += [self.slip.eq(self.slip + 1), self.ld.eq(1)]
            if self._hold:
                with m.If(self.hold):
                    m.d.sync += cnt.eq(0)
        with m.Elif(state == _LOCKED):
            with m.If(go_error_mon):
                m.d.sync += [state.eq(_ERROR), self.locked.eq(0), self.error.eq(1)]
            if self._track:
                with m.Elif(self.up):
                    m.d.sync += [self.tap.eq(self.tap + 1), self.ld.eq(1)]
                with m.Elif(self.down):
                    m.d.sync += [self.tap.eq(self.tap - 1), self.ld.eq(1)]

        with m.If(self.restart):
            m.d.sync += [
                state.eq(_SCAN), cnt.eq(0), self.tap.eq(0), self.slip.eq(0), self.ld.eq(1),
                self.locked.eq(0), self.error.eq(0), self.scan.eq(0),
                prev_pass.eq(0), cur_len.eq(0), cur_start.eq(0), best_len.eq(0),
                best_start.eq(0), mphase.eq(0), lpos.eq(0),
                chk_a.eq(0), mon_a.eq(0), chk_b.eq(0), mon_b.eq(0),
            ]
            if self._eye:
                m.d.sync += [self.slip_pass.eq(0), self.walk.eq(0)]
        return m


class Deskew(wiring.Component):
    """Lane-to-lane word alignment through per-lane FIFOs in dual-port RAM.

    Parameters
    ----------
    lanes : int
    word_bits : 10 or 12
    depth : 8, 16 or 32
        FIFO words per lane; lanes may arrive up to ``depth - 2`` words apart.

    Attributes
    ----------
    words, syncs : In(lanes*word_bits), In(lanes)
        Each lane's aligned word every cycle and whether it is the sync word.
    mask : In(lanes)
        Lanes taking part (the locked lanes).
    arm : In(1)
        Training finished on every lane: start waiting for sync words.
    restart : In(1)
        Drop everything (retrain).
    o_valid, o_sync, o_data : Out(1), Out(1), Out(lanes*word_bits)
        One aligned word per lane per cycle while aligned, lane 0 in the LSBs; lanes outside
        the mask read 0. The first valid cycle carries every lane's first sync word.
    aligned, error : Out(1)
        Lanes released together / a FIFO overflowed (skew > depth - 2) or the sync words
        left aligned (sticky until restart; the stage re-arms on the next sync word).

    Notes
    -----
    Each masked lane writes from its first sync word on; when every masked lane has written
    its sync word the FIFOs are read in lockstep, one word per cycle, so nothing is lost or
    duplicated. :attr:`latency`: cycles from the last lane's sync word at this stage's
    input to ``o_valid``.
    """

    @quiet_reject
    def __init__(self, *, lanes, word_bits=10, depth=8):
        self._n = check_range("lanes", lanes, 1, 256)
        self._w = check_choice("word_bits", word_bits, (10, 12))
        self._depth = check_choice("deskew_depth", depth, (8, 16, 32))
        super().__init__({
            "words": In(lanes * word_bits), "syncs": In(lanes), "mask": In(lanes),
            "arm": In(1), "restart": In(1),
            "o_valid": Out(1), "o_sync": Out(1), "o_data": Out(lanes * word_bits),
            "aligned": Out(1), "error": Out(1),
        })

    @property
    def latency(self):
        return 2

    def elaborate(self, platform):
        m = Module()
        n, w, depth = self._n, self._w, self._depth
        idle, wait, running = 1, 2, 3
        state = Signal(2, init=idle)
        started = Signal(n)
        rptr = Signal(range(depth))
        valid = Signal()
        st_now = Signal(n)
        flags = Signal(n)
        rdata = []
        for i in range(n):
            mem = memory.Memory(shape=w + 1, depth=depth, init=[])
            m.submodules[f"fifo{i}"] = mem
            wp = mem.write_port()
            rp = mem.read_port()
            wptr = Signal(range(depth), name=f"wptr{i}")
            word = self.words[i * w:(i + 1) * w]
            m.d.comb += st_now[i].eq((state == wait) & self.mask[i] & ~started[i]
                                     & self.syncs[i])
            wen = ((state == wait) & (started[i] | st_now[i])) | \
                  ((state == running) & started[i])
            m.d.comb += [
                wp.addr.eq(Mux(started[i], wptr, 0)), wp.data.eq(Cat(word, self.syncs[i])),
                wp.en.eq(wen), rp.addr.eq(rptr), flags[i].eq(rp.data[w]),
            ]
            with m.If(wen):
                m.d.sync += wptr.eq(Mux(started[i], wptr + 1, 1))
            m.d.comb += self.o_data[i * w:(i + 1) * w].eq(Mux(self.mask[i], rp.data[:w], 0))
            rdata.append(rp)
            if i == 0:
                overflow = started[i] & (wptr == depth - 1)
            else:
                overflow = overflow | (started[i] & (wptr == depth - 1))
        any_mask = self.mask.any()
        all_go = ((~self.mask) | started | st_now).all() & any_mask
        sync_any = (self.mask & flags).any()
        sync_all = ((~self.mask) | flags).all()
        misalign = valid & sync_any & ~sync_all
        m.d.comb += [
            self.o_valid.eq(valid), self.o_sync.eq(valid & sync_any & sync_all),
            self.aligned.eq(state == running),
        ]
        m.d.sync += valid.eq(0)
        with m.If(state == idle):
            with m.If(self.arm):
                m.d.sync += [state.eq(wait), started.eq(0)]
        with m.Elif(state == wait):
            with m.If(overflow):
                m.d.sync += [self.error.eq(1), started.eq(0)]
            with m.Else():
                m.d.sync += started.eq(started | st_now)
                with m.If(all_go):
                    m.d.sync += [state.eq(running), rptr.eq(0)]
        with m.Elif(state == running):
            m.d.sync += rptr.eq(rptr + 1)
            with m.If(~any_mask):
                m.d.sync += state.eq(idle)
            with m.Elif(misalign):
                m.d.sync += [self.error.eq(1), state.eq(wait), started.eq(0)]
            with m.Else():
                m.d.sync += valid.eq(1)
        with m.If(self.restart):
            m.d.sync += [state.eq(idle), started.eq(0), valid.eq(0), self.error.eq(0)]
        return m


def lane_ports(phy, n, w, track=False):
    """The lane-side ports of a receiver top with PHY ``phy`` ({name: member}): the
    deserializers' words and the delay taps (``none``: :class:`LvdsRx`; with ``track`` the
    monitor samplers' too), or the pins and clocks (``xilinx7``: :class:`LvdsXilinx`;
    ``ecp5``: :class:`tdicam.hdl.lvds_phy.LvdsEcp5`).
    """
    if phy == "none":
        ports = {"lane_raw": In(n * w), "lane_tap": Out(n * TAP_BITS), "lane_ld": Out(n)}
        if track:
            ports.update({"lane_mon_raw": In(n * w), "lane_mon_tap": Out(n * TAP_BITS),
                          "lane_mon_ld": Out(n)})
        return ports
    if phy == "ecp5":
        return {"lane_p": In(n), "clk_eclk": In(1)}
    ports = {"lane_p": In(n), "lane_n": In(n), "clk_bit": In(1), "clk_ref": In(1),
             "idelay_rdy": Out(1)}
    if w == 12:
        ports["clk_div"] = In(1)
    return ports


#: The eye status of a receiver with ``eye=True`` besides :func:`rx_ports`' (per lane).
EYE_STATUS = ("lane_chosen_tap", "lane_slip_pass", "lane_walk", "lane_walk_ok")


def eye_ports(lanes, w):
    """The eye-status ports of a receiver with ``eye=True`` ({name: member}, per lane, lane 0
    in the LSBs): the trainer's tap (the chosen one once locked: ``lane_tap`` of the core,
    inside a PHY), the slip that locked as a mask, the walking-1/0 patterns received and
    whether all were (:class:`LaneTrainer` ``slip_pass``, ``walk``)."""
    return {"lane_chosen_tap": Out(lanes * TAP_BITS), "lane_slip_pass": Out(lanes * w),
            "lane_walk": Out(lanes * 2 * w), "lane_walk_ok": Out(lanes)}


def forward_core(m, outer, core):
    """Connect the register and status ports of a PHY wrapper ``outer`` to its
    :class:`LvdsRx` ``core`` (settings in, status out; the eye status when the core has
    it)."""
    names = list(rx_ports(core.lanes, core.word_bits))
    if core.eye:
        names += list(eye_ports(core.lanes, core.word_bits))
    if core.track:
        names.append("lane_corrections")
    for name in names:
        port, inner = getattr(outer, name), getattr(core, name)
        if name in ("train_word", "sync_word", "n_check", "line_words", "retrain"):
            m.d.comb += inner.eq(port)
        else:
            m.d.comb += port.eq(inner)


def rx_ports(lanes, w):
    """The register and status ports every receiver top has ({name: member})."""
    return {
        "train_word": In(w), "sync_word": In(w), "n_check": In(8), "line_words": In(16),
        "retrain": In(1),
        "lane_slip": Out(lanes * SLIP_BITS), "lane_locked": Out(lanes),
        "lane_error": Out(lanes), "lane_run": Out(lanes * RUN_BITS),
        "lane_scan": Out(lanes * N_TAPS), "lane_mask": Out(lanes), "all_locked": Out(1),
        "trained": Out(1),
        "o_valid": Out(1), "o_sync": Out(1), "o_data": Out(lanes * w), "aligned": Out(1),
        "deskew_error": Out(1),
    }


class LvdsRx(wiring.Component):
    """N-lane LVDS receiver core: per-lane training, deskew, status (Verilog top ``lvds``).

    Parameters
    ----------
    lanes : int, 1..128
        80 for the GMAX0504 (lanes 0..39 high gain, 40..79 low gain).
    word_bits : 10 or 12
    settle, min_run, pick : see :class:`LaneTrainer`
    deskew_depth : 8, 16 or 32
    hold : bool
        Add ``lane_hold`` (:class:`LaneTrainer`'s ``hold`` of every lane).
    eye : bool
        Add the eye status (:func:`eye_ports`; opt-in: without it the Verilog is that of
        before).
    track : int
        > 0: track each locked lane's eye with a monitor sampler probing ``track`` taps
        either side (:class:`tdicam.hdl.lvds_track.LaneTracker`; ports ``lane_mon_raw``
        in, the monitor deserializers' words; ``lane_mon_tap``/``lane_mon_ld`` out, their
        delay taps; ``lane_corrections`` out, 8 bits a lane). 0: none (the Verilog of before).

    Attributes
    ----------
    lane_raw : In(lanes*word_bits)
        Deserializer words, lane 0 in the LSBs.
    lane_tap, lane_ld : Out(lanes*5), Out(lanes)
        Delay taps and load strobes (IDELAYE2 ``CNTVALUEIN``/``LD`` in ``VAR_LOAD`` mode).
    train_word, sync_word, n_check, line_words : In
        Run-time registers shared by all lanes; change them only together with ``retrain``.
    retrain : In(1)
        Retrain request: every lane restarts training the next cycle (put the sensor in
        training mode at the same time).
    lane_slip, lane_locked, lane_error, lane_run, lane_scan : Out
        Per-lane status (bitslip, locked, error, widest run, passing taps).
    lane_mask, all_locked, trained : Out
        Locked lanes (they take part in the deskew); every lane locked; every lane finished
        training (locked or error). ``all_locked``/``trained`` lag lane status by one cycle.
    o_valid, o_sync, o_data, aligned, deskew_error : Out
        The deskewed words (see :class:`Deskew`).

    Notes
    -----
    :attr:`latency` = 4: from the raw word that is the last lane's first sync word to
    ``o_valid``. There is no backpressure: the sensor cannot be stalled.
    """

    @quiet_reject
    def __init__(self, *, lanes=8, word_bits=10, settle=8, min_run=9, pick=5,
                 deskew_depth=8, hold=False, eye=False, track=0):
        _check_common(word_bits, settle, min_run, pick)
        self._track = check_range("track", track, 0, 15)
        self._n = check_range("lanes", lanes, 1, 128)
        self._w = word_bits
        self._kw = dict(word_bits=word_bits, settle=settle, min_run=min_run, pick=pick,
                        hold=bool(hold), eye=bool(eye))
        self._depth = check_choice("deskew_depth", deskew_depth, (8, 16, 32))
        ports = lane_ports("none", lanes, word_bits, bool(self._track))
        if hold:
            ports["lane_hold"] = In(lanes)
        ports.update(rx_ports(lanes, word_bits))
        if eye:
            ports.update(eye_ports(lanes, word_bits))
        if self._track:
            ports["lane_corrections"] = Out(lanes * COUNT_BITS)
        super().__init__(ports)

    @property
    def track(self):
        return self._track

    @property
    def lanes(self):
        return self._n

    @property
    def eye(self):
        return self._kw["eye"]

    @property
    def word_bits(self):
        return self._w

    @property
    def settle(self):
        return self._kw["settle"]

    @property
    def latency(self):
        return 2 + 2

    def step_words(self, n_check):
        return self._kw["settle"] + max(int(n_check), 1) + VERDICT_WORDS

    def elaborate(self, platform):
        m = Module()
        n, w = self._n, self._w
        m.submodules.deskew = dsk = Deskew(lanes=n, word_bits=w, depth=self._depth)
        done = []
        # the settings registered once for every lane (not a copy in each)
        shared = dict(zip((f"reg_{name}" for name in _settings_shapes(w, self._kw["settle"])),
                          settings_registers(m, self._kw["settle"], self.train_word,
                                             self.sync_word, self.n_check, self.line_words)))
        for i in range(n):
            t = LaneTrainer(**self._kw, track=bool(self._track), shared=True)
            m.submodules[f"lane{i}"] = t
            if self._track:
                from tdicam.hdl.lvds_track import LaneTracker
                tr = LaneTracker(word_bits=w, settle=self._kw["settle"], margin=self._track)
                m.submodules[f"track{i}"] = tr
                m.d.comb += [
                    tr.locked.eq(t.locked), tr.tap.eq(t.tap), tr.slip.eq(t.slip),
                    tr.word.eq(t.word), tr.mon_raw.eq(self.lane_mon_raw[i * w:(i + 1) * w]),
                    tr.n_check.eq(self.n_check), t.up.eq(tr.up), t.down.eq(tr.down),
                    self.lane_mon_tap[i * TAP_BITS:(i + 1) * TAP_BITS].eq(tr.mon_tap),
                    self.lane_mon_ld[i].eq(tr.mon_ld),
                    self.lane_corrections[i * COUNT_BITS:(i + 1) * COUNT_BITS].eq(tr.count),
                ]
            m.d.comb += [
                t.raw.eq(self.lane_raw[i * w:(i + 1) * w]),
                *(getattr(t, name).eq(reg) for name, reg in shared.items()),
                t.restart.eq(self.retrain),
                self.lane_tap[i * TAP_BITS:(i + 1) * TAP_BITS].eq(t.tap),
                self.lane_ld[i].eq(t.ld),
                self.lane_slip[i * SLIP_BITS:(i + 1) * SLIP_BITS].eq(t.slip),
                self.lane_locked[i].eq(t.locked), self.lane_error[i].eq(t.error),
                self.lane_run[i * RUN_BITS:(i + 1) * RUN_BITS].eq(t.run),
                self.lane_scan[i * N_TAPS:(i + 1) * N_TAPS].eq(t.scan),
                dsk.words[i * w:(i + 1) * w].eq(t.word), dsk.syncs[i].eq(t.word_sync),
            ]
            if self._kw["hold"]:
                m.d.comb += t.hold.eq(self.lane_hold[i])
            if self._kw["eye"]:
                m.d.comb += [
                    self.lane_chosen_tap[i * TAP_BITS:(i + 1) * TAP_BITS].eq(t.tap),
                    self.lane_slip_pass[i * w:(i + 1) * w].eq(t.slip_pass),
                    self.lane_walk[2 * i * w:2 * (i + 1) * w].eq(t.walk),
                    self.lane_walk_ok[i].eq(t.walk.all()),
                ]
            done.append(t.locked | t.error)
        m.d.comb += self.lane_mask.eq(self.lane_locked)
        m.d.sync += [self.all_locked.eq(self.lane_locked.all() & ~self.retrain),
                     self.trained.eq(Cat(done).all() & ~self.retrain)]
        m.d.comb += [
            dsk.mask.eq(self.lane_locked), dsk.arm.eq(self.trained), dsk.restart.eq(self.retrain),
            self.o_valid.eq(dsk.o_valid), self.o_sync.eq(dsk.o_sync),
            self.o_data.eq(dsk.o_data), self.aligned.eq(dsk.aligned),
            self.deskew_error.eq(dsk.error),
        ]
        return m


class LvdsXilinx(wiring.Component):
    """:class:`LvdsRx` behind 7-series input primitives (:mod:`tdicam.cosim.lvds_pins`).

    Per lane: ``IBUFDS`` -> ``IDELAYE2`` (``VAR_LOAD``, 32 taps, 78 ps at a 200 MHz
    ``IDELAYCTRL`` reference; ``CNTVALUEIN``/``LD`` from the trainer, clocked by the word
    clock) -> ``ISERDESE2`` in ``NETWORKING``/``DDR`` mode. 10-bit words: a master/slave
    pair with ``DATA_WIDTH = 10`` (``CLKDIV`` = the word clock ``clk`` = bit clock / 5);
    the earliest bit is slave ``Q4``, then slave ``Q3``, master ``Q8`` .. ``Q1`` (UG471).
    12-bit words (DDR has no 12-bit mode): a master with ``DATA_WIDTH = 6`` on ``clk_div``
    (bit clock / 3) and a 2:1 fabric gearbox into the word clock ``clk`` (= ``clk_div`` / 2,
    from the same MMCM). The ISERDESE2 ``BITSLIP`` is tied off: in DDR mode it alternates
    shifts of 1 and 3 bits, so word alignment uses the trainer's fabric gearbox instead.

    Ports: ``lane_p``/``lane_n`` (pins), ``clk_bit`` (ISERDESE2 ``CLK``, half the bit rate:
    150 MHz for 300 Mb/s; ``CLKB`` is its inverse), ``clk_ref`` (200 MHz), ``clk_div`` (12-bit
    words only), ``idelay_rdy``, and every register/status port of :class:`LvdsRx`.

    ``track`` > 0 (12-bit words only): the core tracks each lane's eye
    (:class:`tdicam.hdl.lvds_track.LaneTracker`, ``lane_corrections`` out) with a monitor
    sampler in the pair's N pin: ``IBUFDS_DIFF_OUT`` (instead of ``IBUFDS``) whose ``OB``
    feeds a second ``IDELAYE2`` (the monitor's tap and load) and a second ``ISERDESE2``
    (``DATA_WIDTH = 6``) with the data's 2:1 gearbox, its words inverted back (litevideo's
    ``S7DataCapture`` and AMD XAPP860 use the pair so). 10-bit words cannot: their
    master/slave ``ISERDESE2`` pair takes both IOLOGIC sites of the pin pair, and the
    N pin's input path is the only second sampler a lane has.
    """

    @quiet_reject
    def __init__(self, *, lanes=8, word_bits=10, settle=8, min_run=9, pick=5,
                 deskew_depth=8, eye=False, track=0):
        if track and word_bits != 12:
            raise TdicamError(f"--track = {track} with --phy xilinx7 needs --word-bits 12 "
                              f"(10-bit words take both ISERDESE2 of the pin pair; the "
                              f"monitor sampler needs the N pin's)")
        self._core = LvdsRx(lanes=lanes, word_bits=word_bits, settle=settle, min_run=min_run,
                            pick=pick, deskew_depth=deskew_depth, eye=eye, track=track)
        ports = lane_ports("xilinx7", lanes, word_bits)
        ports.update(rx_ports(lanes, word_bits))
        if eye:
            ports.update(eye_ports(lanes, word_bits))
        if track:
            ports["lane_corrections"] = Out(lanes * COUNT_BITS)
        super().__init__(ports)

    @property
    def core(self):
        return self._core

    def elaborate(self, platform):
        m = Module()
        core = self._core
        m.submodules.core = core
        n, w = core.lanes, core.word_bits
        forward_core(m, self, core)
        rst = ResetSignal("sync")
        m.submodules.idelayctrl = Instance(
            "IDELAYCTRL", a_IODELAY_GROUP="tdicam_lvds",
            i_REFCLK=self.clk_ref, i_RST=rst, o_RDY=self.idelay_rdy)
        if w == 12:
            m.domains.div = ClockDomain("div", reset_less=True, local=True)
            m.d.comb += ClockSignal("div").eq(self.clk_div)
        clk_div = ClockSignal("sync") if w == 10 else ClockSignal("div")
        track = core.track
        for i in range(n):
            pad, dly = Signal(name=f"pad{i}"), Signal(name=f"dly{i}")
            buf = dict(p_DIFF_TERM="TRUE", p_IBUF_LOW_PWR="FALSE", p_IOSTANDARD="LVDS_25",
                       i_I=self.lane_p[i], i_IB=self.lane_n[i], o_O=pad)
            if track:
                padb = Signal(name=f"padb{i}")
                m.submodules[f"ibufds{i}"] = Instance("IBUFDS_DIFF_OUT", o_OB=padb, **buf)
            else:
                m.submodules[f"ibufds{i}"] = Instance("IBUFDS", **buf)

            def idelay(name, src, out, ld, tap, cnt):
                m.submodules[name] = Instance(
                    "IDELAYE2", a_IODELAY_GROUP="tdicam_lvds",
                    p_IDELAY_TYPE="VAR_LOAD", p_DELAY_SRC="IDATAIN", p_IDELAY_VALUE=0,
                    p_HIGH_PERFORMANCE_MODE="TRUE", p_SIGNAL_PATTERN="DATA",
                    p_REFCLK_FREQUENCY=200.0, p_CINVCTRL_SEL="FALSE", p_PIPE_SEL="FALSE",
                    i_C=ClockSignal("sync"), i_REGRST=Const(0), i_LD=ld,
                    i_CE=Const(0), i_INC=Const(0), i_CINVCTRL=Const(0),
                    i_CNTVALUEIN=tap, i_IDATAIN=src, i_DATAIN=Const(0), i_LDPIPEEN=Const(0),
                    o_DATAOUT=out, o_CNTVALUEOUT=Signal(TAP_BITS, name=cnt))
            sl = slice(i * TAP_BITS, (i + 1) * TAP_BITS)
            idelay(f"idelay{i}", pad, dly, core.lane_ld[i], core.lane_tap[sl], f"cntvalueout{i}")
            q = [Signal(name=f"q{i}_{j}") for j in range(1, 9)]
            common = dict(
                p_DATA_RATE="DDR", p_INTERFACE_TYPE="NETWORKING", p_NUM_CE=2,
                p_OFB_USED="FALSE", p_DYN_CLKDIV_INV_EN="FALSE", p_DYN_CLK_INV_EN="FALSE",
                **{f"p_{init}_Q{j}": Const(0, 1) for init in ("INIT", "SRVAL")
                   for j in range(1, 5)},
                i_CLK=self.clk_bit, i_CLKB=~self.clk_bit, i_CLKDIV=clk_div,
                i_CLKDIVP=Const(0), i_OCLK=Const(0), i_OCLKB=Const(0), i_RST=rst,
                i_CE1=Const(1), i_CE2=Const(1), i_BITSLIP=Const(0), i_DYNCLKDIVSEL=Const(0),
                i_DYNCLKSEL=Const(0), i_OFB=Const(0), i_D=Const(0))
            # every output pin connected (unused ones to named, unloaded wires)
            unused = {f"o_{pin}": Signal(name=f"nc{i}_{pin.lower()}")
                      for pin in ("O", "SHIFTOUT1", "SHIFTOUT2")}
            if w == 10:
                so1, so2 = Signal(name=f"shift{i}_1"), Signal(name=f"shift{i}_2")
                sq = [Signal(name=f"sq{i}_{j}") for j in range(1, 9)]
                m.submodules[f"iserdes{i}"] = Instance(
                    "ISERDESE2", p_DATA_WIDTH=10, p_SERDES_MODE="MASTER", p_IOBDELAY="IFD",
                    i_DDLY=dly, i_SHIFTIN1=Const(0), i_SHIFTIN2=Const(0),
                    o_SHIFTOUT1=so1, o_SHIFTOUT2=so2, o_O=unused["o_O"],
                    **{f"o_Q{j}": q[j - 1] for j in range(1, 9)}, **common)
                m.submodules[f"iserdes{i}_slave"] = Instance(
                    "ISERDESE2", p_DATA_WIDTH=10, p_SERDES_MODE="SLAVE", p_IOBDELAY="NONE",
                    i_DDLY=Const(0), i_SHIFTIN1=so1, i_SHIFTIN2=so2,
                    o_O=Signal(name=f"nc{i}_slave_o"),
                    o_SHIFTOUT1=unused["o_SHIFTOUT1"], o_SHIFTOUT2=unused["o_SHIFTOUT2"],
                    **{f"o_Q{j}": sq[j - 1] for j in range(1, 9)}, **common)
                raw = Cat(*q, sq[2], sq[3])  # slave Q3, Q4 extend the master's 8 bits
            else:
                m.submodules[f"iserdes{i}"] = Instance(
                    "ISERDESE2", p_DATA_WIDTH=6, p_SERDES_MODE="MASTER", p_IOBDELAY="IFD",
                    i_DDLY=dly, i_SHIFTIN1=Const(0), i_SHIFTIN2=Const(0), **unused,
                    **{f"o_Q{j}": q[j - 1] for j in range(1, 9)}, **common)
                raw, phase = self._gearbox(m, q, f"{i}")
                if track:
                    # the monitor: the N pin's delay line and deserializer, inverted back
                    mdly, mq = Signal(name=f"mdly{i}"), [Signal(name=f"mq{i}_{j}")
                                                         for j in range(1, 9)]
                    idelay(f"idelay{i}_mon", padb, mdly, core.lane_mon_ld[i],
                           core.lane_mon_tap[sl], f"cntvalueout{i}_mon")
                    m.submodules[f"iserdes{i}_mon"] = Instance(
                        "ISERDESE2", p_DATA_WIDTH=6, p_SERDES_MODE="MASTER",
                        p_IOBDELAY="IFD", i_DDLY=mdly, i_SHIFTIN1=Const(0),
                        i_SHIFTIN2=Const(0),
                        **{f"o_{pin}": Signal(name=f"nc{i}_mon_{pin.lower()}")
                           for pin in ("O", "SHIFTOUT1", "SHIFTOUT2")},
                        **{f"o_Q{j}": mq[j - 1] for j in range(1, 9)}, **common)
                    m.d.comb += core.lane_mon_raw[i * w:(i + 1) * w].eq(
                        ~self._gearbox(m, mq, f"{i}_mon", phase)[0])
            m.d.comb += core.lane_raw[i * w:(i + 1) * w].eq(raw)
        return m

    @staticmethod
    def _gearbox(m, q, tag, phase=None):
        """The 2:1 gearbox of a ``DATA_WIDTH = 6`` ISERDESE2's ``q`` into 12-bit words of
        the word clock, pairing every other ``clk_div`` word at ``phase`` (None: a new
        free-running toggle). Returns (the words, the phase)."""
        half, hold, pair = (Signal(6, name=f"half{tag}"), Signal(6, name=f"hold{tag}"),
                            Signal(12, name=f"pair{tag}"))
        m.d.comb += half.eq(Cat(*q[:6]))
        if phase is None:
            phase = Signal(name=f"phase{tag}")
            m.d.div += [hold.eq(half), phase.eq(~phase)]
        else:
            m.d.div += hold.eq(half)
        with m.If(phase):
            m.d.div += pair.eq(Cat(half, hold))
        raw = Signal(12, name=f"raw{tag}")
        m.d.sync += raw.eq(pair)
        return raw, phase
