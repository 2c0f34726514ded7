"""The camera's front end: the sensor's LVDS lanes in, the pipeline's pixel stream out.

Ning et al. 2019 §4.1 (the GMAX0504: 40 lanes per gain channel, 12-bit words, 300 Mbit/s).
The lane format and the lane-to-column convention (lane ``g*L + k`` carries columns ``k,
k+L, ...`` of gain channel ``g``; lines ``[sync, row header, P pixel words]``, the header's
top bit the frame's kind: 1 a reset frame, 0 a signal frame) are
:mod:`tdicam.model.lvds_front`'s, which is also the golden model. The kind rides with every
output beat (``frame_kind``), for the CDS stage that keeps the reset frame.

Clock domains and start-up::

    word clock (domain "word", one word per lane per clock)           | processing clock ("sync")
                                                                      |
    lane_raw --> LvdsRx: train (IDELAY taps) -> bitslip -> deskew     |
                 |  lane_locked / lane_error                          |
                 v                                                    |
              framer: HOLD until every lane has trained (locked or  <=sync== release
                      error), the deskew is aligned and ``release``   |
                      is high, then RUN from the next line whose      |
                      header is row 0 (with ``pairs`` a reset         |
                      frame's; frames seen while held: dropped,       |
                      counted); a lane lost mid-frame: FILL the frame |
                      with invalid words (affected, counted), HOLD    |
                      until ``retrain``                               |
                 |  one entry = one word of every lane (L columns a   |
                 |  channel) + first/last + the frame's kind          |
                 v                                                    |
              AsyncFIFO write ================ crossing ==============> AsyncFIFO read
                                                                      |   -> L/ppc beats of ppc
                                                                      |      pixels x G channels
                                                                      |   -> o_stream, frame_kind

At ``ppc >= 2`` the crossing is a
:class:`~tdicam.hdl.interfaces.crossing.RegisteredAsyncFIFO` (its read address a choice of
two registers, ``r_rdy`` a register) and the read side registers the FIFO's head (an entry
register) and its beats (a :class:`~tdicam.hdl.interfaces.stream.PairBuffer`): the block
RAM's read data reaches no read address and ``o_stream.ready`` neither the FIFO nor the
entry; at ``ppc = 1`` an :class:`amaranth.lib.fifo.AsyncFIFO` and the beats straight off its
read data.

Status outputs are in the word-clock domain (quasi-static registers and counters, for a
processor to read through its own synchronizer); the run-time inputs too (``train_word``,
``sync_word``, ``n_check``, ``frame_rows``, ``retrain``).
"""

from amaranth.hdl import Array, Cat, Const, DomainRenamer, Module, Mux, Signal
from amaranth.lib import fifo, wiring
from amaranth.lib.data import StructLayout
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from tdicam.beats import PPC_CHOICES
from tdicam.errors import TdicamError, check_choice, check_range
from tdicam.hdl.interfaces.stream import PairBuffer, channels_shape, pixel_signature
from tdicam.hdl.interfaces.crossing import RegisteredAsyncFIFO
from tdicam.hdl.lvds import eye_ports, lane_ports, rx_ports
from tdicam.model.lvds_front import last_word_columns, line_words
from tdicam.model.lvds_track import COUNT_BITS
from tdicam.hdl.util import quiet_reject

__all__ = ["LvdsFront", "WORD_DOMAIN"]

#: The clock domain of the lanes' words (ports ``word_clk``/``word_rst`` of a top).
WORD_DOMAIN = "word"

_HOLD, _RUN, _FILL = 1, 2, 3


#: The receiver's training status a front with ``eye`` publishes besides the eye ports
#: (:func:`tdicam.hdl.lvds.eye_ports`).
_EYE_RX = ("lane_scan", "lane_run", "lane_slip")


def _status_ports(n, w, eye=False, track=0):
    extra = {}
    if eye:
        extra = {name: mem for name, mem in rx_ports(n, w).items() if name in _EYE_RX}
        extra.update(eye_ports(n, w))
    if track:
        extra["lane_corrections"] = Out(n * COUNT_BITS)
    return {**extra,
        "train_word": In(w), "sync_word": In(w), "n_check": In(8), "frame_rows": In(16),
        "retrain": In(1),
        "lane_locked": Out(n), "lane_error": Out(n), "lanes_bad": Out(n),
        "frame_invalid": Out(n), "trained": Out(1), "releasing": Out(1),
        "need_retrain": Out(1), "frames_out": Out(16), "frames_dropped": Out(16),
        "frames_affected": Out(16), "lane_errors": Out(16), "fifo_overflow": Out(1),
    }


class _WordSide(wiring.Component):
    """Receiver and framer, written in ``sync`` (renamed to the word domain by
    :class:`LvdsFront`); ``w_*`` drive the crossing FIFO's write port."""

    def __init__(self, *, n, w, bits, p, rx, phy, pairs=False, eye=False, track=0):
        self._n, self._w, self._bits, self._p, self._rx = n, w, bits, p, rx
        self._pairs = pairs
        self._lane_ports = lane_ports(phy, n, w, bool(track))
        ports = {**self._lane_ports,
                 "w_data": Out(n * bits + 3), "w_en": Out(1), "w_rdy": In(1),
                 "released": In(1)}
        ports.update(_status_ports(n, w, eye, track))
        self._eye, self._track = eye, track
        super().__init__(ports)

    def elaborate(self, platform):
        m = Module()
        n, w, bits, p = self._n, self._w, self._bits, self._p
        m.submodules.rx = rx = self._rx
        for name, member in self._lane_ports.items():
            if member.flow == wiring.In:
                m.d.comb += getattr(rx, name).eq(getattr(self, name))
            else:
                m.d.comb += getattr(self, name).eq(getattr(rx, name))
        m.d.comb += [
            rx.train_word.eq(self.train_word),
            rx.sync_word.eq(self.sync_word), rx.n_check.eq(self.n_check),
            rx.line_words.eq(p + 2), rx.retrain.eq(self.retrain),
            self.lane_locked.eq(rx.lane_locked), self.lane_error.eq(rx.lane_error),
            self.trained.eq(rx.trained),
        ]
        if self._eye:
            m.d.comb += [getattr(self, name).eq(getattr(rx, name))
                         for name in (*_EYE_RX, *eye_ports(n, w))]
        if self._track:
            m.d.comb += self.lane_corrections.eq(rx.lane_corrections)
        locked = rx.lane_locked
        bad_now = ~locked
        m.d.comb += self.lanes_bad.eq(bad_now)
        # a locked lane that drops out (not by a retrain) or a deskew fault: retrain needed
        locked_q, retrain_q, err_q = Signal(n), Signal(), Signal(n)
        m.d.sync += [locked_q.eq(locked), retrain_q.eq(self.retrain), err_q.eq(rx.lane_error)]
        lost = (locked_q & ~locked).any() & ~retrain_q
        with m.If((rx.lane_error & ~err_q).any()):
            m.d.sync += self.lane_errors.eq(self.lane_errors + 1)

        # the aligned words: position in the line, the header (OR of the lanes: masked
        # lanes read 0, the others all carry the row)
        words = [rx.o_data[i * w:(i + 1) * w] for i in range(n)]
        header = Signal(w)
        acc_h = Const(0, w)
        for wd in words:
            acc_h = acc_h | wd
        m.d.comb += header.eq(acc_h)
        # the header's top bit: the frame's kind (1 reset, 0 signal); the row below it
        h_row, h_kind = header[:w - 1], header[w - 1]
        pos = Signal(range(p + 2))
        with m.If(rx.o_valid):
            m.d.sync += pos.eq(Mux(pos == p + 1, 0, pos + 1))
            with m.If(rx.o_sync):
                m.d.sync += pos.eq(1)
        at_sync = rx.o_valid & rx.o_sync
        at_header = rx.o_valid & (pos == 1)
        at_pixel = rx.o_valid & (pos >= 2)

        state = Signal(2, init=_HOLD)
        row = Signal(16)
        kind = Signal()          # the kind of the frame being written
        acc = Signal(n)          # lanes bad during the frame being written
        pend, pend_acc = Signal(), Signal(n)  # a finished frame waiting for the next sync
        fill_col = Signal(range(p + 1))
        rows_m1 = self.frame_rows - 1
        pixels = Cat(*(wd[:bits] for wd in words))
        m.d.comb += self.releasing.eq(state == _RUN)

        def publish(m, mask):
            m.d.sync += [self.frame_invalid.eq(mask), self.frames_out.eq(self.frames_out + 1),
                         pend.eq(0)]
            with m.If(mask.any()):
                m.d.sync += self.frames_affected.eq(self.frames_affected + 1)

        write = Signal()
        m.d.comb += [self.w_en.eq(write), self.w_data.eq(0)]
        with m.If(write & ~self.w_rdy):
            m.d.sync += self.fifo_overflow.eq(1)

        fault = lost | self.retrain | rx.deskew_error | ~rx.aligned
        with m.If(lost | rx.deskew_error):
            m.d.sync += self.need_retrain.eq(1)
        with m.If(self.retrain):
            m.d.sync += self.need_retrain.eq(0)
        # a finished frame is judged once the next line's sync has passed the lane monitor
        with m.If(pend & (at_sync | fault)):
            publish(m, pend_acc | bad_now)

        ok = rx.trained & rx.aligned & locked.any() & ~self.need_retrain & ~lost & \
            ~self.retrain & ~rx.deskew_error
        with m.Switch(state):
            with m.Case(_HOLD):
                # a run starts at a frame's first line (with ``pairs``: a reset frame's, so
                # the CDS stage never pairs a signal frame with a reset frame it missed)
                start = at_header & (h_row == 0)
                with m.If(start & ok & self.released & (h_kind if self._pairs else 1)):
                    m.d.sync += [state.eq(_RUN), row.eq(0), acc.eq(0), kind.eq(h_kind)]
                with m.Elif(start & ((self.need_retrain & rx.aligned) | ok)):
                    # held: a lane lost (until ``retrain``), the top not ready yet (its
                    # start-up: the calibration load), or the signal frame of a pair
                    # whose reset frame was not taken
                    m.d.sync += self.frames_dropped.eq(self.frames_dropped + 1)
            with m.Case(_RUN):
                in_frame = (row != 0) | (pos >= 2)
                # a frame's first line may be of either kind; its other lines of its kind
                with m.If(at_header & (row == 0)):
                    m.d.sync += kind.eq(h_kind)
                with m.If(fault | (at_header & ((h_row != row) |
                                                ((row != 0) & (h_kind != kind))))):
                    # pixel words of this row already written: pos - 2 (none before pos 2)
                    with m.If(in_frame):
                        m.d.sync += [state.eq(_FILL), fill_col.eq(Mux(pos >= 2, pos - 2, 0))]
                    with m.Else():
                        m.d.sync += state.eq(_HOLD)
                with m.Elif(at_pixel):
                    m.d.comb += [write.eq(1), self.w_data.eq(Cat(
                        pixels, (row == 0) & (pos == 2), pos == p + 1, kind))]
                    m.d.sync += acc.eq(acc | bad_now)
                    with m.If(pos == p + 1):
                        with m.If(row == rows_m1):
                            m.d.sync += [row.eq(0), pend.eq(1), pend_acc.eq(acc | bad_now)]
                            with m.If(self.need_retrain):
                                m.d.sync += state.eq(_HOLD)
                        with m.Else():
                            m.d.sync += row.eq(row + 1)
            with m.Case(_FILL):
                # the rest of the frame as invalid words (all lanes flagged), one a clock
                m.d.comb += [write.eq(1), self.w_data.eq(Cat(
                    Const(0, n * bits), (row == 0) & (fill_col == 0), fill_col == p - 1,
                    kind))]
                m.d.sync += fill_col.eq(fill_col + 1)
                with m.If(fill_col == p - 1):
                    m.d.sync += [fill_col.eq(0), row.eq(row + 1)]
                    with m.If(row == rows_m1):
                        m.d.sync += [state.eq(_HOLD), row.eq(0)]
                        publish(m, Const((1 << n) - 1, n))
        return m


class LvdsFront(wiring.Component):
    """Sensor lanes (word clock) to the pipeline's pixel stream (processing clock).

    Parameters
    ----------
    lanes_per_gain : int, 1..64
        ``L``; the receiver has ``gains * L`` lanes, high-gain lanes first.
    gains : 1 or 2
        Gain channels; the output beat carries, for each of its ``ppc`` pixels, the high-
        then the low-gain value (the two channel lanes of the pipeline, as ``hdr`` takes
        them).
    word_bits : 10 or 12
    bits : int
        Pixel bits (<= ``word_bits``; the low bits of each word).
    columns : int
        Frame width, >= ``L``: ``P = ceil(columns / L)`` pixel words a line; the last word
        clock of a line carries ``R = columns - (P - 1) L`` columns (lanes ``0 .. R - 1``;
        the lanes above send padded slots, dropped: that entry gives ``R / ppc`` beats).
    ppc : int
        Pixels per output beat; must divide ``L`` and ``R``.
    fifo_depth : int
        Entries of the crossing FIFO (power of two), from the two clock rates:
        :func:`tdicam.model.lvds_front.fifo_depth`,
        ``2**ceil(log2(ceil(P * max(0, 1 - f_p ppc / (L f_w))) + 8))``.
    settle, min_run, pick, deskew_depth
        :class:`tdicam.hdl.lvds.LvdsRx`'s.
    phy : {"none", "xilinx7", "ecp5"}
        ``none``: the generic simulated PHY (the deserializers' words in, the delay taps
        out); ``ecp5``: :class:`~tdicam.hdl.lvds_phy.LvdsEcp5` (pins ``lane_p``, the edge
        clock ``clk_eclk``); ``xilinx7``: the receiver behind 7-series IBUFDS/IDELAYE2/ISERDESE2
        (:class:`~tdicam.hdl.lvds.LvdsXilinx`: pins ``lane_p``/``lane_n``, ``clk_bit``,
        ``clk_ref``, ``idelay_rdy``, ``clk_div`` with 12-bit words; the word clock is its
        ``CLKDIV``).
    pairs : bool
        The sensor sends each reset frame before its signal frame (off-chip CDS): after any
        hold (start-up, ``release`` low, a retrain) frames are released from a reset frame
        on, so the CDS stage never pairs a signal frame with a reset frame it did not get.
    track : int
        > 0: track every locked lane's eye with that probe margin (taps;
        :class:`tdicam.hdl.lvds_track.LaneTracker`; the generic PHY only): ports
        ``lane_mon_raw`` in, ``lane_mon_tap``/``lane_mon_ld`` out (the monitor samplers),
        ``lane_corrections`` out (8 bits a lane).
    eye : bool
        Publish the lanes' training (word domain, opt-in): ``lane_scan`` (pass mask over
        the 32 taps), ``lane_run`` (the widest run: the eye width found, taps), ``lane_slip``
        and the eye status of :func:`tdicam.hdl.lvds.eye_ports` (chosen tap, slip mask,
        the walking-1/0 patterns received after lock: the sensor sends them before its
        first frame; :mod:`tdicam.model.lvds`).

    Attributes
    ----------
    lane_raw : In(gains*L*word_bits)
        Deserializer words (word domain), lane 0 in the LSBs (``phy = "none"``).
    lane_tap, lane_ld : Out
        Delay taps and load strobes (word domain; ``phy = "none"``).
    train_word, sync_word, n_check, frame_rows, retrain : In
        Word-domain settings: the training and sync words, words checked per tap, rows per
        frame (< 2**(word_bits - 1) - 2: the header's top bit is the frame kind), retrain request (the sensor trains from then on).
    o_stream : Out(pixel stream), processing domain
        ``ppc * gains`` elements of ``bits``, pixel-major; ``first`` on a frame's first beat,
        ``last`` on each line's last. No backpressure reaches the sensor: the processing side
        must take the rate (``fifo_overflow`` says when it did not).
    frame_kind : Out(1), processing domain
        The kind of the frame ``o_stream``'s beat belongs to (from its row header's top bit:
        1 a reset frame, 0 a signal frame), valid with every beat.
    release : In(1, init 1), processing domain
        The processing side is ready for frames (in a pipeline: its start-up is done, e.g.
        the NUC calibration loaded from NAND); registered, then synchronized into the word
        domain. Frames
        whose first line arrives while it is low are dropped whole and counted
        (``frames_dropped``); the first frame released is the first whole frame after it
        rises, so the sensor may start at power-up, before the calibration load.
    lane_locked, lane_error : Out(gains*L)
        Per-lane status (word domain); ``lanes_bad`` = not locked (their columns are invalid).
    frame_invalid : Out(gains*L)
        Lanes whose columns are invalid in the last finished frame (published at the next
        frame's first sync word, after the lane monitor has judged the frame's last line;
        all ones for a frame cut by a lane loss and filled).
    trained, releasing, need_retrain : Out(1)
        Every lane trained (locked or error); frames are being released; a lane was lost
        or the deskew failed after training (frames held until ``retrain``).
    frames_out, frames_dropped, frames_affected, lane_errors : Out(16)
        Frames finished (released); whole frames seen but not released (after a lane loss
        until ``retrain``, before ``release``, with ``pairs`` a signal frame whose reset
        frame was not released); released frames with an invalid lane; lane error events
        (cycles with a new lane error).
    fifo_overflow : Out(1)
        Sticky: an entry arrived with the FIFO full (pixels lost).
    """

    @quiet_reject
    def __init__(self, *, lanes_per_gain=4, gains=2, word_bits=12, bits=12, columns=32,
                 ppc=1, fifo_depth=16, settle=8, min_run=9, pick=5, deskew_depth=8,
                 phy="none", pairs=False, eye=False, track=0):
        L = check_range("lanes_per_gain", lanes_per_gain, 1, 64)
        self._g = check_choice("gains", gains, (1, 2))
        self._w = check_choice("word_bits", word_bits, (10, 12))
        self._bits = check_range("bits", bits, 1, word_bits)
        self._ppc = check_choice("ppc", ppc, PPC_CHOICES)
        if columns < L:
            raise TdicamError(f"lanes_per_gain = {L} is more lanes than columns = {columns}")
        p = line_words(columns, L) - 2
        self._rem = last_word_columns(columns, L)
        if L % ppc:
            raise TdicamError(f"ppc = {ppc} does not divide lanes_per_gain = {L}")
        if self._rem % ppc:
            raise TdicamError(f"ppc = {ppc} does not divide the {self._rem} columns of a "
                              f"line's last word clock (columns = {columns} on {L} lanes)")
        if fifo_depth < 4 or fifo_depth & (fifo_depth - 1):
            raise TdicamError(f"fifo_depth = {fifo_depth} must be a power of two >= 4")
        self._L, self._p, self._depth = L, p, fifo_depth
        from tdicam.hdl.lvds_phy import PHYS
        self._phy = check_choice("phy", phy, tuple(PHYS))
        self._pairs = bool(pairs)
        rx_cls = PHYS[phy]
        self._eye, self._track = bool(eye), int(track)
        if track and phy != "none":
            raise TdicamError(f"eye tracking (track = {track}) needs the generic PHY's monitor "
                              f"samplers (phy = 'none'), not phy = {phy!r}")
        trk = {"track": self._track} if track else {}
        self._rx = rx_cls(lanes=L * gains, word_bits=word_bits, settle=settle, eye=self._eye,
                          min_run=min_run, pick=pick, deskew_depth=deskew_depth, **trk)
        n = L * gains
        ports = {**lane_ports(phy, n, word_bits, bool(track)),
                 "o_stream": Out(pixel_signature(channels_shape(bits, ppc * gains))),
                 "frame_kind": Out(1), "release": In(1, init=1)}
        ports.update(_status_ports(n, word_bits, self._eye, self._track))
        super().__init__(ports)

    lanes = property(lambda self: self._L * self._g)
    latency = property(lambda self: None,
                       doc="None: the output's timing depends on the two clocks' phases")
    line_words = property(lambda self: self._p + 2)
    fifo_depth = property(lambda self: self._depth)

    @property
    def port_domains(self):
        """{port: clock domain} of the ports not in the processing clock (``sync``): the
        lanes' and the status and settings ports, in the word domain."""
        n = self._L * self._g
        return {name: WORD_DOMAIN for name in {
            **lane_ports(self._phy, n, self._w, bool(self._track)),
            **_status_ports(n, self._w, self._eye, self._track)}}

    @property
    def csr_ports(self):
        """{port: kind} (:data:`tdicam.hdl.csr_map.PORT_KINDS`) of the word-clock settings and
        status a control bus crosses into its register map: every status output, and the
        settings but ``retrain`` (a strobe timed with the sensor's own training: the
        controller that commands the sensor drives it). The lanes' per-lane masks are
        levels; ``lane_error`` is the fault (a lane failed to train or was lost)."""
        n = self._L * self._g
        kinds = {name: "status" for name, mem in
                 _status_ports(n, self._w, self._eye, self._track).items()
                 if mem.flow == wiring.Out}
        kinds.update({name: "mask" for name in ("lane_locked", "lanes_bad", "frame_invalid",
                                                 "lane_walk_ok") if name in kinds})
        kinds["lane_error"] = "fault_mask"
        kinds.update({name: "setting" for name in ("train_word", "sync_word", "n_check",
                                                    "frame_rows")})
        return kinds

    #: The status that must be low for the bus's word-clock settings to be applied
    #: (:attr:`csr_ports`): they reach the front while it holds its frames (start-up, a
    #: lane loss until the retrain), never in the middle of a released frame.
    csr_hold = "releasing"

    @property
    def pin_ports(self):
        """{port: I/O attributes} of the ports that are device pins (the ECP5 PHY's LVDS
        lanes and edge clock; :func:`tdicam.hdl.lvds_phy.pin_ports`)."""
        from tdicam.hdl.lvds_phy import pin_ports
        return pin_ports(self._phy)

    def elaborate(self, platform):
        m = Module()
        bits, n = self._bits, self._L * self._g
        ws = _WordSide(n=n, w=self._w, bits=bits, p=self._p, rx=self._rx, phy=self._phy,
                       pairs=self._pairs, eye=self._eye, track=self._track)
        m.submodules.word_side = DomainRenamer({"sync": WORD_DOMAIN})(ws)
        # registered before the crossing (the top's gate is an AND of its stages' status)
        release_q = Signal()
        m.d.sync += release_q.eq(self.release)
        m.submodules.release_sync = FFSynchronizer(release_q, ws.released,
                                                   o_domain=WORD_DOMAIN, init=0)
        # ppc >= 2: no adder or comparison before the wide FIFO's read address
        queue = fifo.AsyncFIFO if self._ppc == 1 else RegisteredAsyncFIFO
        m.submodules.cdc = cdc = queue(width=n * bits + 3, depth=self._depth,
                                       r_domain="sync", w_domain=WORD_DOMAIN)
        outer = {**lane_ports(self._phy, n, self._w, bool(self._track)),
                 **_status_ports(n, self._w, self._eye, self._track)}
        for name, member in outer.items():
            if member.flow == wiring.In:
                m.d.comb += getattr(ws, name).eq(getattr(self, name))
            else:
                m.d.comb += getattr(self, name).eq(getattr(ws, name))
        m.d.comb += [cdc.w_data.eq(ws.w_data), cdc.w_en.eq(ws.w_en), ws.w_rdy.eq(cdc.w_rdy)]

        # read side: one entry = L columns a channel -> L/ppc beats (a line's last entry
        # with padded slots: rem/ppc)
        if self._ppc == 1:
            self._read_direct(m, cdc)
        else:
            self._read_registered(m, cdc)
        return m

    def _beats(self, m, d, beat):
        """(the beats of entry ``d`` selected by ``beat``, first, last, kind, end: the
        beat is the entry's last)."""
        L, g, bits, ppc, n = self._L, self._g, self._bits, self._ppc, self._L * self._g
        k = L // ppc
        pix = [d[i * bits:(i + 1) * bits] for i in range(n)]
        first, last, kind = d[n * bits], d[n * bits + 1], d[n * bits + 2]
        beats = [Cat(*(pix[c * L + b * ppc + q] for q in range(ppc) for c in range(g)))
                 for b in range(k)]
        if self._rem == L:
            end = beat == k - 1
        else:
            end = Signal()
            m.d.comb += end.eq(beat == Mux(last, self._rem // ppc - 1, k - 1))
        data = Array(beats)[beat] if k > 1 else beats[0]
        return data, first & (beat == 0), last & end, kind, end

    def _read_direct(self, m, cdc):
        """ppc 1: the beats straight off the FIFO's read data; ``o_stream.ready`` moves the
        FIFO (its read address)."""
        beat = Signal(range(max(self._L // self._ppc, 2)))
        data, first, last, kind, end = self._beats(m, cdc.r_data, beat)
        o = self.o_stream
        m.d.comb += [
            o.valid.eq(cdc.r_rdy), o.payload.data.eq(data), o.payload.first.eq(first),
            o.payload.last.eq(last), self.frame_kind.eq(kind),
            cdc.r_en.eq(o.ready & end),
        ]
        with m.If(o.valid & o.ready):
            m.d.sync += beat.eq(Mux(end, 0, beat + 1))

    def _read_registered(self, m, cdc):
        """ppc >= 2: the FIFO's head taken into an entry register, its beats through a
        :class:`~tdicam.hdl.interfaces.stream.PairBuffer` (with the frame kind). No path
        from the block RAM's read data (its clock-to-out, ~4 ns on the ECP5) into the
        FIFO's read address (the whole camera's front at ppc 8: the entry's ``last`` bit
        -> the beat's end -> ``r_en`` -> the read pointer's adder -> the DP16KDs' address,
        10.7 ns), nor from ``o_stream.ready`` into the FIFO or the entry register (the
        output's registered ready). The same beats in the same order; an entry is taken
        as its predecessor's last beat goes out, so the rate is the direct read's."""
        beat = Signal(range(max(self._L // self._ppc, 2)))
        ent = Signal(len(cdc.r_data), reset_less=True)
        held = Signal()
        data, first, last, kind, end = self._beats(m, ent, beat)
        o = self.o_stream
        m.submodules.out = out = PairBuffer(_out_layout(o))
        emit = held & out.i_stream.ready
        take = cdc.r_rdy & (~held | (emit & end))
        m.d.comb += [
            out.i_stream.valid.eq(held),
            out.i_stream.payload.data.eq(data), out.i_stream.payload.first.eq(first),
            out.i_stream.payload.last.eq(last), out.i_stream.payload.kind.eq(kind),
            cdc.r_en.eq(take),
            o.valid.eq(out.o_stream.valid), o.payload.data.eq(out.o_stream.payload.data),
            o.payload.first.eq(out.o_stream.payload.first),
            o.payload.last.eq(out.o_stream.payload.last),
            self.frame_kind.eq(out.o_stream.payload.kind),
            out.o_stream.ready.eq(o.ready),
        ]
        with m.If(take):
            m.d.sync += [ent.eq(cdc.r_data), held.eq(1)]
        with m.Elif(emit & end):
            m.d.sync += held.eq(0)
        with m.If(emit):
            m.d.sync += beat.eq(Mux(end, 0, beat + 1))


def _out_layout(o):
    """The registered read side's beat: ``o``'s payload fields and the frame kind."""
    return StructLayout({"data": o.payload.shape()["data"].shape, "first": 1, "last": 1,
                         "kind": 1})
