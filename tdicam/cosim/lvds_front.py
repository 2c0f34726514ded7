"""Simulation of the camera's front end (:class:`tdicam.hdl.lvds_front.LvdsFront`) against
its golden model (:mod:`tdicam.model.lvds_front`) and the link model
(:mod:`tdicam.model.lvds`), with two clocks.

:class:`FrontCase` is one scenario: frames per gain channel, the lanes' analogue parameters,
the sensor's schedule (training, then whole frames; a retrain segment where asked), the
two clock periods. :func:`raw_table` evaluates the link model once for every tap and
cycle, so a testbench only looks words up: the word the DUT gets at word clock ``k`` is
``raw(k)`` sampled with the tap loaded (``lane_ld``) two word clocks earlier.
:func:`run_amaranth` runs a case in Amaranth's simulator and returns the output frames and
the status; :func:`frames_of` cuts output beats into frames. :data:`SCENARIOS` are the
must-show cases (the crossing at the worst rate ratios, a narrow eye, a lane dying mid-run
and the retrain), shared by the Amaranth tests and the cocotb co-simulation: :func:`scenario`
builds one, :func:`check` judges a run of it.
"""

from dataclasses import dataclass, field

import numpy as np

from tdicam.hdl.lvds import EYE_STATUS, RUN_BITS, SLIP_BITS, TAP_BITS
from tdicam.model import lvds
from tdicam.model import lvds_front

__all__ = ["FrontCase", "raw_table", "STEADY_ENTRIES", "driver_tables", "STATUS", "EYE_PORTS",
           "WordDriver", "run_amaranth", "frames_of", "GEOMETRY", "GOOD_LANES", "CLOCKS", "SCENARIOS", "scenario_frames", "cds_kinds",
           "scenario_lanes", "scenario", "check", "run_cocotb", "plan_case", "lane_eyes"]


@dataclass
class FrontCase:
    """A front-end scenario.

    ``frames``: one ``(F, R, C)`` stack per gain channel; ``lanes``: one
    :class:`tdicam.model.lvds.Lane` per lane (high-gain lanes first); ``segments``: frames
    per data segment (each ends with a blank line; a training segment before each, the
    retrain request at its first word); ``word_ns``/``proc_ns``: the two clock
    periods; ``ready``: probability that the processing side takes a beat; ``kinds``: each
    frame's kind (1 a reset frame, 0 a signal frame; None: signal frames), sent in its row
    headers; ``lead``: word clocks of training past the receiver's training time before the
    first frame (a camera whose start-up holds frames longer, e.g. the calibration load,
    starts the sensor later); ``walk``: the receiver has the eye status
    (:func:`tdicam.hdl.lvds.eye_ports`) and the sensor sends one round of the walking-1/0
    patterns (:func:`tdicam.model.lvds.walk_words`, ``2 W`` words) just before each data
    segment, after the lanes have locked; ``track``: the receiver tracks the eyes with that
    margin (:mod:`tdicam.model.lvds_track`).
    """

    frames: list
    lanes: list
    lanes_per_gain: int
    word_bits: int = 12
    bits: int = 12
    ppc: int = 1
    segments: tuple | None = None
    n_check: int = 4
    settle: int = 4
    word_ns: float = 10.0
    proc_ns: float = 10.0
    ready: float = 1.0
    seed: int = 1
    tail: int = 200
    kinds: tuple | None = None
    lead: int = 40
    walk: bool = False
    track: int = 0
    retrains: tuple = field(default=(), init=False)
    link: object = field(default=None, init=False)
    cycles: int = field(default=0, init=False)

    def __post_init__(self):
        L, w = self.lanes_per_gain, self.word_bits
        nf, nr, nc = np.asarray(self.frames[0]).shape
        self.columns = nc
        lw = lvds_front.line_words(nc, L)
        self.p = lw - 2
        tw = lvds.training_words(w, self.n_check, self.settle)
        segs = self.segments or (nf,)
        if sum(segs) != nf:
            raise ValueError("segments must add up to the frames")
        if self.walk and self.lead < 2 * w + 4:
            raise ValueError(f"lead = {self.lead}: the walking patterns need >= {2 * w + 4}")
        sched, k, retrains, parts, f0 = [], tw + self.lead, [], [], 0
        for i, f in enumerate(segs):
            if i:
                retrains.append(k)
                sched.append((k, "train"))
                k += 1 + tw + 40
            if self.walk:
                sched.append((k - 2 * w, "walk"))
            sched.append((k, "data"))
            k += (f * nr + 1) * lw
            parts.append([np.asarray(a)[f0:f0 + f] for a in self.frames])
            f0 += f
        self.retrains = tuple(retrains)
        self.link = lvds.Link(self.lanes, word_bits=w, line_words=lw, schedule=tuple(sched),
                              payload=lvds_front.segment_payload(parts, L, w, self.kinds))
        self.cycles = k + self.tail
        self.segment_starts = [s for s, mode in sched if mode == "data"]

    @property
    def fifo_depth(self):
        return lvds_front.fifo_depth(self.lanes_per_gain, self.ppc, self.columns,
                                     1e3 / self.word_ns, 1e3 / self.proc_ns)

    def golden_run(self):
        return lvds.run(self.link, cycles=self.cycles, retrains=self.retrains,
                        n_check=self.n_check, settle=self.settle, eye=self.walk,
                        track=self.track)


def raw_table(link, cycles):
    """``raw[lane, tap, k]``: the raw word of every lane at every tap and word clock."""
    k = np.broadcast_to(np.arange(cycles, dtype=np.int64), (lvds.N_TAPS, cycles))
    taps = np.arange(lvds.N_TAPS, dtype=np.int64)[:, None]
    return np.stack([lvds.raw_words(link, i, taps, k)
                     for i in range(len(link.lanes))])


#: Entries (lanes x taps x word clocks) above which :func:`driver_tables` gives a steady
#: table: 2**24 (64 MiB of int32; the whole camera's 80 lanes over its start-up are 170 M).
STEADY_ENTRIES = 1 << 24


def driver_tables(case, *, steady_above=STEADY_ENTRIES, margin=8):
    """What a testbench's :class:`WordDriver` looks the lanes' raw words up in: ``(raw,
    steady)``.

    ``raw`` is :func:`raw_table` of the first ``k0`` word clocks and ``steady`` None
    (``k0`` = the whole run) or ``(k0, taps, words)``: from word clock ``k0`` on, each
    lane's raw words at ``taps[lane]`` only (``words[lane, k - k0]``), the tap the golden
    receiver (:meth:`FrontCase.golden_run`) trained the lane to. A steady table is made
    when the whole table would exceed ``steady_above`` entries and the run keeps every
    lane on its trained tap: every lane locks (no error) by ``k0`` (its last lock ``+
    margin`` word clocks), no retrain, no tracking, no lane that changes or drifts. The
    driver then refuses (``res["steady_miss"]``) a lane sampled at another tap after ``k0``.
    """
    n = len(case.lanes)
    if n * lvds.N_TAPS * case.cycles <= steady_above or case.retrains or case.track or any(
            ln.change_at is not None or ln.drift_taps for ln in case.lanes):
        return raw_table(case.link, case.cycles), None
    runs = case.golden_run().trainings[-1]
    if not all(r.events and r.events[-1][1] == 1 and r.events[-1][2] == 0 for r in runs):
        return raw_table(case.link, case.cycles), None
    k0 = min(case.cycles, max(r.events[-1][0] for r in runs) + margin)
    taps = [int(r.tap) for r in runs]
    ks = np.arange(k0, case.cycles, dtype=np.int64)
    words = np.stack([lvds.raw_words(case.link, i, t, ks) for i, t in enumerate(taps)])
    return raw_table(case.link, k0), (k0, taps, words)


def frames_of(beats, rows, columns, ppc, gains):
    """Output beats ``(first, last, data elements)`` -> frames ``(G, F, R, C)``: a frame
    starts at a ``first`` beat; beats before the first ``first`` are an error."""
    out, cur = [], None
    for first, _last, elems in beats:
        if first:
            cur = []
            out.append(cur)
        if cur is None:
            raise AssertionError("beats before the first start of frame")
        cur.append(elems)
    frames = []
    for f in out:
        a = np.array(f, np.int64).reshape(-1, ppc, gains)
        if a.shape[0] * ppc != rows * columns:
            raise AssertionError(f"a frame of {a.shape[0] * ppc} pixels, not {rows * columns}")
        frames.append(a.reshape(rows, columns, gains).transpose(2, 0, 1))
    if not frames:
        return np.zeros((gains, 0, rows, columns), np.int64)
    return np.stack(frames, axis=1)


#: The front's status ports a run reports at its end.
STATUS = ("lane_locked", "lane_error", "frame_invalid", "trained", "releasing",
          "need_retrain", "frames_out", "frames_dropped", "frames_affected", "lane_errors",
          "fifo_overflow")
#: The status ports of a front with the eye status a run reports too.
EYE_PORTS = ("lane_scan", "lane_run", "lane_slip") + EYE_STATUS


class WordDriver:
    """The word-clock side of a front testbench, simulator-neutral: the lanes' raw words
    from ``raw`` (:func:`raw_table`) for the tap each lane loaded (``lane_ld``) two word
    clocks earlier, the retrain pulses, and the log of lane status changes and frame
    status into ``res`` (:func:`run_amaranth`'s ``events`` and ``frame_status``).

    Per word clock ``k``: :meth:`inputs` (``lane_raw``, ``retrain`` to drive), then
    :meth:`observe` with the status ports read in that cycle.
    """

    def __init__(self, raw, word_bits, retrains, res, steady=None):
        self.raw, self.w, self.retrains, self.res = raw, word_bits, set(retrains), res
        self.n = raw.shape[0]
        # a steady table (driver_tables): from k0 on, every lane's word packed per clock
        self.k0, self.steady = raw.shape[2], None
        if steady is not None:
            k0, taps, words = steady
            bits = (np.asarray(words, np.int64).T[:, :, None] >> np.arange(word_bits)) & 1
            packed = np.packbits(bits.reshape(len(bits), -1).astype(np.uint8), axis=1,
                                 bitorder="little")
            self.k0, self.steady = int(k0), ([int(t) for t in taps], packed)
        self.tapq, self.tap2 = [0] * self.n, [0] * self.n
        self.mq, self.m2 = [0] * self.n, [0] * self.n
        self.prev, self.out_seen, self.seen = [(0, 0)] * self.n, 0, (0, 0)
        self.last_tap = [None] * self.n

    def inputs(self, k):
        if k >= self.k0:
            taps, packed = self.steady
            if self.tap2 != taps and "steady_miss" not in self.res:
                i = next(i for i in range(self.n) if self.tap2[i] != taps[i])
                self.res["steady_miss"] = [k, i, self.tap2[i], taps[i]]
            return int.from_bytes(packed[k - self.k0].tobytes(), "little"), \
                int(k in self.retrains)
        raw = sum(int(self.raw[i, self.tap2[i], k]) << (i * self.w) for i in range(self.n))
        return raw, int(k in self.retrains)

    def mon_inputs(self, k):
        """The monitor samplers' words (a receiver with tracking: ``lane_mon_raw``)."""
        return sum(int(self.raw[i, self.m2[i], k]) << (i * self.w) for i in range(self.n))

    def mon_observe(self, ld, tap):
        """The monitor samplers' tap loads (``lane_mon_ld``, ``lane_mon_tap``) of the cycle
        (call before :meth:`observe`)."""
        for i in range(self.n):
            self.m2[i] = self.mq[i]
            if (ld >> i) & 1:
                self.mq[i] = (tap >> TAP_BITS * i) & ((1 << TAP_BITS) - 1)

    def observe(self, k, ld, tap, locked, error, frames_out, frame_invalid):
        """``frame_invalid``: a callable reading the port (read only when a frame ends).
        With ``res["corrections"]`` a list, every tap change of a locked lane is logged
        there as ``(effect word, lane, new tap)`` (the first raw word sampled with it)."""
        log = self.res.get("corrections")
        for i in range(self.n):
            cur = (tap >> TAP_BITS * i) & ((1 << TAP_BITS) - 1)
            if log is not None and (locked >> i) & 1 and self.prev[i][0] \
                    and cur != self.last_tap[i]:
                log.append((k + lvds.LINK_LATENCY, i, cur))
            self.last_tap[i] = cur
        if (locked, error) != self.seen:         # a lane's status changed (rare)
            self.seen = (locked, error)
            for i in range(self.n):
                st = ((locked >> i) & 1, (error >> i) & 1)
                if st != self.prev[i]:
                    self.res["events"].append((k, i) + st)
                    self.prev[i] = st
        if frames_out != self.out_seen:
            self.res["frame_status"].append(frame_invalid())
            self.out_seen = frames_out
        self.tap2 = list(self.tapq)      # the tap reaches the sampler 2 words after its load
        for i in range(self.n) if ld else ():
            if (ld >> i) & 1:
                self.tapq[i] = (tap >> TAP_BITS * i) & ((1 << TAP_BITS) - 1)


def run_amaranth(case, *, dut=None, hook=None, prefix="", settings=None, elems=None,
                 steady=None):
    """Run ``case`` on :class:`~tdicam.hdl.lvds_front.LvdsFront` in Amaranth's simulator.

    Returns a dict: ``beats`` (first, last, elements) in order, ``kinds`` (``frame_kind`` at
    every ``first`` beat), ``status`` (the word-domain
    status ports at the end), ``frame_status`` (``frame_invalid`` at every ``frames_out``
    step, in order), ``events`` (cycle, lane, locked, error) lane status changes.
    ``hook(ctx, dut, k)``, when given, runs every word clock (fault injection).

    ``dut`` may be a pipeline (:class:`tdicam.hdl.chain_top.Pipeline`) whose source is the
    front: ``prefix`` is its ports' prefix (``"lvds_"``), ``settings`` the values of its
    other input ports, ``elems`` the output elements per beat (default ``ppc * gains``).
    ``steady``: the driver's tables (:func:`driver_tables`); None: :func:`raw_table` of the
    whole run.
    """
    from amaranth.sim import Simulator

    from tdicam.hdl.lvds_front import WORD_DOMAIN, LvdsFront
    L, g = case.lanes_per_gain, len(case.frames)
    n, w, bits, ppc = L * g, case.word_bits, case.bits, case.ppc
    nr = np.asarray(case.frames[0]).shape[1]
    if dut is None:
        dut = LvdsFront(lanes_per_gain=L, gains=g, word_bits=w, bits=bits,
                        columns=case.columns, ppc=ppc, fifo_depth=case.fifo_depth,
                        settle=case.settle, eye=case.walk, track=case.track)
    n_out = ppc * g if elems is None else elems

    def port(name):
        return getattr(dut, prefix + name)
    kind_port = getattr(dut, "frame_kind", None)
    raw, steady = (raw_table(case.link, case.cycles), None) if steady is None else steady
    res = {"beats": [], "kinds": [], "frame_status": [], "events": [], "status": {}}
    if case.track:
        res["corrections"] = []
    done = [False]

    async def word_side(ctx):
        for name, v in (("train_word", case.link.train_word),
                        ("sync_word", case.link.sync_word), ("n_check", case.n_check),
                        ("frame_rows", nr)):
            ctx.set(port(name), v)
        for name, v in (settings or {}).items():
            ctx.set(getattr(dut, name), v)
        drv = WordDriver(raw, w, case.retrains, res, steady)
        for k in range(case.cycles):
            lane_raw, retrain = drv.inputs(k)
            ctx.set(port("lane_raw"), lane_raw)
            ctx.set(port("retrain"), retrain)
            if case.track:
                ctx.set(port("lane_mon_raw"), drv.mon_inputs(k))
                drv.mon_observe(ctx.get(port("lane_mon_ld")), ctx.get(port("lane_mon_tap")))
            if hook is not None:
                hook(ctx, dut, k)
            drv.observe(k, *(ctx.get(port(x)) for x in ("lane_ld", "lane_tap", "lane_locked",
                                                        "lane_error", "frames_out")),
                        lambda: ctx.get(port("frame_invalid")))
            await ctx.tick(WORD_DOMAIN)
        eye = EYE_PORTS if hasattr(dut, prefix + "lane_walk") else ()
        for name in STATUS + eye:
            res["status"][name] = ctx.get(port(name))
        done[0] = True

    async def proc_side(ctx):
        rng = np.random.default_rng(case.seed)
        o = dut.o_stream
        while not done[0]:
            rdy = int(rng.random() < case.ready)
            ctx.set(o.ready, rdy)
            if rdy and ctx.get(o.valid):
                d = ctx.get(o.payload.data)
                elems = [int(d[i]) for i in range(n_out)] if n_out > 1 else [int(d)]
                res["beats"].append((ctx.get(o.payload.first), ctx.get(o.payload.last),
                                     elems))
                if ctx.get(o.payload.first) and kind_port is not None:
                    res["kinds"].append(ctx.get(kind_port))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(case.word_ns * 1e-9, domain=WORD_DOMAIN)
    sim.add_clock(case.proc_ns * 1e-9)
    sim.add_testbench(word_side)
    sim.add_testbench(proc_side, background=True)
    sim.run()
    return res


# ---------------------------------------------------------------- shared scenarios
#: The scenarios' geometry: 4 lanes a gain, 2 gains, 16 columns (P = 4 words a line), 3 rows.
GEOMETRY = {"lanes_per_gain": 4, "gains": 2, "columns": 16, "rows": 3}
#: Eye centre, width (taps) and whole-word delay of the 8 lanes: every lane trains.
GOOD_LANES = ((10, 14, 0), (12, 16, 1), (8, 12, 0), (20, 15, 2), (14, 18, 0), (9, 13, 1),
              (16, 20, 0), (11, 14, 1))
#: Scenario -> (word clock ns, processing clock ns, ready probability) at ppc 2: the word
#: clock faster than the processing side's share at the bound r = P / (P + 2) (12 / 9 ns),
#: slower (r = 5.6, with backpressure), and the fault scenarios at r = 2.
CLOCKS = {"cdc_fast": (12.0, 9.0, 1.0), "cdc_slow": (100.0, 9.0, 0.5),
          "narrow_eye": (40.0, 10.0, 0.9), "lane_dies": (40.0, 10.0, 1.0)}
SCENARIOS = tuple(CLOCKS)
NARROW_LANE, DYING_LANE = 5, 2


def scenario_frames(nf, seed, bits=12, columns=None):
    """``nf`` random frames per gain (``columns`` wide, None: :data:`GEOMETRY`'s); the first
    pixel at full scale (sent as one less)."""
    rng = np.random.default_rng(seed)
    g = GEOMETRY
    c = g["columns"] if columns is None else int(columns)
    fr = [rng.integers(0, 1 << bits, (nf, g["rows"], c)) for _ in range(g["gains"])]
    fr[0][0, 0, 0] = (1 << bits) - 1
    return fr


def scenario_lanes(spec=GOOD_LANES, over=None):
    """:func:`tdicam.model.lvds_front.eye_lane` of each (centre, width, word delay);
    ``over``: lane -> extra keywords (``change_at``, ``after``)."""
    return [lvds_front.eye_lane(c, w, word_delay=d, seed=i, **(over or {}).get(i, {}))
            for i, (c, w, d) in enumerate(spec)]


def cds_kinds(nf):
    """The kinds of ``nf`` frames of a sensor read for CDS: a reset frame (1) before each
    signal frame (0)."""
    return tuple(int(f % 2 == 0) for f in range(nf))


def scenario(name, *, ppc=2, columns=None):
    """The :class:`FrontCase` of scenario ``name`` (:data:`SCENARIOS`); at ``ppc`` other
    than 2 the word clock period scales by ``2 / ppc`` (the same rate ratio ``r``). The
    sensor sends reset and signal frames in turn (:func:`cds_kinds`). ``columns``: the
    frames' width (None: :data:`GEOMETRY`'s; one the lanes do not divide pads the last word
    clock of each line)."""
    word_ns, proc_ns, ready = CLOCKS[name]
    kw = dict(ppc=ppc, word_ns=word_ns * 2 / ppc, proc_ns=proc_ns, ready=ready)
    kw["kinds"] = cds_kinds(8 if name == "lane_dies" else 5 if name.startswith("cdc") else 4)
    L = GEOMETRY["lanes_per_gain"]
    if name.startswith("cdc"):
        return FrontCase(scenario_frames(5, 3, columns=columns), scenario_lanes(), L, **kw)
    if name == "narrow_eye":
        spec = list(GOOD_LANES)
        spec[NARROW_LANE] = (12, 6, 0)            # 6 taps: no run of 9, cannot train
        return FrontCase(scenario_frames(4, 4, columns=columns), scenario_lanes(spec), L, **kw)
    # lane_dies: the lane dies in the middle of frame 2 of a first segment of 5 frames; the
    # sensor controller retrains after it, 3 frames follow
    frames = scenario_frames(8, 5, columns=columns)
    probe = FrontCase(frames, scenario_lanes(), L, segments=(5, 3))
    lw = probe.p + 2
    die_at = probe.segment_starts[0] + int(2.5 * GEOMETRY["rows"] * lw)
    lanes = scenario_lanes(over={DYING_LANE: {
        "change_at": die_at, "after": lvds.Lane(skew_ps=0.0, eye_ps=0.0)}})
    return FrontCase(frames, lanes, L, segments=(5, 3), **kw)


def _kinds_problems(res, want):
    """The frames' kinds as the run saw them (``frame_kind`` at each first beat) against
    ``want``."""
    got = [int(k) for k in res["kinds"]]
    return [] if got == [int(k) for k in want] else [f"frame kinds: got {got}, expected "
                                                     f"{[int(k) for k in want]}"]


def check(name, case, res):
    """Problems (strings; none = pass) of a run of scenario ``name`` against the golden
    model: the released frames bit for bit, the frame status, the counters.

    * every scenario: each frame's kind (reset or signal) as its headers say;
    * ``cdc_*``: every frame out exactly, nothing dropped, no overflow;
    * ``narrow_eye``: lane 5 reported (error), every frame's status says lane 5, the frames
      equal the golden front on the lanes' words
      (:func:`tdicam.model.lvds_front.frames_from_lanes`) with lane 5 invalid (columns 0);
    * ``lane_dies``: frames 0, 1 exact; frame 2 cut by the death, filled and flagged
      (status all lanes); frames 3, 4 held and counted dropped; after the retrain (lane 2
      found dead) frames 5..7 exact with lane 2 invalid; two lane errors counted.
    """
    g = GEOMETRY
    G, L, C, R = g["gains"], g["lanes_per_gain"], case.columns, g["rows"]
    n = G * L
    st, out = res["status"], []
    try:
        got = frames_of(res["beats"], R, C, case.ppc, G)
    except AssertionError as exc:
        return [f"output stream: {exc}"]

    def same(what, a, b):
        if not (np.shape(a) == np.shape(b) and np.array_equal(a, b)):
            out.append(f"{what}: got {np.shape(a)} {np.asarray(a).ravel()[:6]}..., expected "
                       f"{np.shape(b)} {np.asarray(b).ravel()[:6]}...")

    def counters(*want):
        names = ("frames_out", "frames_dropped", "frames_affected", "lane_errors",
                 "fifo_overflow", "need_retrain")
        got_c = tuple(st[k] for k in names)
        if got_c != want:
            out.append(f"counters {names}: got {got_c}, expected {want}")
    nf = len(case.frames[0])
    lane_words = [lvds_front.data_words(case.link, i) for i in range(n)]

    def expected(bad):      # the golden front on the lanes' words
        return lvds_front.frames_from_lanes(lane_words, L, R, case.word_bits, bad, C)[0]
    kinds = lvds_front.frames_from_lanes(lane_words, L, R, case.word_bits)[2]
    if name.startswith("cdc"):
        same("frames", got, expected([]))
        out += _kinds_problems(res, kinds)
        counters(nf, 0, 0, 0, 0, 0)
        same("frame status", res["frame_status"], [0] * nf)
    elif name == "narrow_eye":
        bad = [i for i, f in enumerate(case.golden_run().final) if f["error"]]
        same("golden untrained lanes", bad, [NARROW_LANE])
        same("lane_error", st["lane_error"], 1 << NARROW_LANE)
        same("frame status", res["frame_status"], [1 << NARROW_LANE] * nf)
        same("frames", got, expected([NARROW_LANE]))
        out += _kinds_problems(res, kinds)
        counters(nf, 0, nf, 1, 0, 0)
    else:
        full = (1 << n) - 1
        dead = 1 << DYING_LANE
        same("frame status", res["frame_status"], [0, 0, full, dead, dead, dead])
        out += _kinds_problems(res, kinds[[0, 1, 2, 5, 6, 7]])
        counters(6, 2, 4, 2, 0, 0)
        if not any(ev[1] == DYING_LANE and ev[3] == 1 and ev[0] < case.retrains[0]
                   for ev in res["events"]):
            out.append(f"lane {DYING_LANE}'s death was not reported before the retrain")
        exp = expected([])
        if got.shape[1] != 6:
            return out + [f"{got.shape[1]} frames out, expected 6"]
        same("frames 0-1", got[:, :2], exp[:, :2])
        same("frames 5-7", got[:, 3:], expected([DYING_LANE])[:, 5:])
        keep = ~lvds_front.invalid_columns([DYING_LANE], C, L, G)
        same("frame 2 row 0", got[:, 2, 0][keep], exp[:, 2, 0][keep])
    return out


def run_cocotb(names, sim, *, ppc=2, columns=None, keep=False):
    """Co-simulate scenarios ``names`` on the generated front (module ``lvds_front``, one
    build per simulator, ``ppc`` and ``columns``, every scenario in one simulator run) with
    cocotb (:mod:`tdicam.simtb.lvds_front_tb`); ``columns``: the frames' width
    (:func:`scenario`). Returns ``(cases, results, wall seconds, build seconds)``, the
    results shaped like :func:`run_amaranth`'s."""
    import json
    import os
    import shutil
    import time

    from tdicam.cosim.build import build_sources, run_cocotb as _run
    from tdicam.errors import TdicamError
    from tdicam.hdl.lvds_front import LvdsFront
    from tdicam.hw.verilog import convert
    g = GEOMETRY
    params = dict(lanes_per_gain=g["lanes_per_gain"], gains=g["gains"], word_bits=12,
                  bits=12, columns=g["columns"] if columns is None else int(columns), ppc=ppc,
                  fifo_depth=16, settle=4)
    dut = convert(LvdsFront(**params), "lvds_front")
    bdir, build_s = build_sources("lvds_front", params, sim, {"lvds_front.v": dut},
                                  top="lvds_front")
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    cases, job = [], {"scenarios": []}
    for k, name in enumerate(names):
        case = scenario(name, ppc=ppc, columns=columns)
        cases.append(case)
        np.save(rundir / f"raw_{k}.npy", raw_table(case.link, case.cycles).astype(np.int32))
        job["scenarios"].append({
            "name": name, "lanes": len(case.lanes), "word_bits": case.word_bits,
            "bits": case.bits, "elems": ppc * g["gains"], "cycles": case.cycles,
            "retrains": list(case.retrains), "word_ps": int(case.word_ns * 1000),
            "proc_ps": int(case.proc_ns * 1000), "ready": case.ready, "seed": case.seed,
            "settings": {"train_word": case.link.train_word, "sync_word": case.link.sync_word,
                         "n_check": case.n_check, "frame_rows": g["rows"], "release": 1}})
    (rundir / "job.json").write_text(json.dumps(job))
    ok, wall = _run(bdir, sim, "lvds_front_tb", rundir, [], top="lvds_front")
    results = []
    for k in range(len(names)):
        f = rundir / f"result_{k}.json"
        if not ok or not f.exists():
            raise TdicamError(f"{sim} simulation of lvds_front failed; see {rundir / 'sim.log'}")
        results.append(json.loads(f.read_text()))
    if not keep:
        shutil.rmtree(rundir, ignore_errors=True)
    return cases, results, wall, build_s


def plan_case(p, data, lanes, **kw):
    """The :class:`FrontCase` of a pipeline plan ``p`` whose source is the front (a scene
    with ``[sensor.lvds]``) on scene data ``data``: each channel's frames as the chain takes
    them (:meth:`tdicam.blocks.steps.SceneData.lane_arrays`: with a first block that keeps
    the reset frames, each reset frame before its signal frame, their kinds in the row
    headers, :func:`cds_kinds`), the front's geometry and settle from its step, ``lanes``
    (one :class:`tdicam.model.lvds.Lane` per lane); ``kw``: the other :class:`FrontCase`
    fields (clocks, ``lead``, ``n_check``, ...)."""
    from tdicam import blocks
    prm = blocks.get("lvds").resolve(p.steps[0].params)
    frames = [lane[0] for lane in data.lane_arrays(p)]
    kinds = cds_kinds(len(frames[0])) if p.reset_frames else None
    return FrontCase(frames, lanes, prm["lanes_per_gain"], word_bits=prm["word_bits"],
                     bits=prm["bits"], ppc=p.ppc, settle=prm["settle"], kinds=kinds, **kw)


def lane_eyes(golden, status, word_bits, *, prefix="", tap_ps=None, eye_taps=None, min_run=9,
              trained=None):
    """Each lane's training as the receiver published it (its eye-status ports in
    ``status``, ``{prefix + port: value}``, :func:`tdicam.hdl.lvds.eye_ports` and the
    front's ``lane_scan``/``lane_run``/``lane_slip``) beside the golden model's prediction
    (``golden``: :func:`tdicam.model.lvds.run` ``final`` with ``eye``).

    Returns one dict a lane: ``lane``, ``mask`` (pass mask over the 32 taps, bit ``t`` =
    tap ``t``), ``taps`` (the mask as a list of 0/1, tap 0 first), ``tap`` (chosen), ``slip``,
    ``slip_mask``, ``eye_taps_found`` (the widest run) and ``eye_ps_found`` (x ``tap_ps``),
    ``eye_taps_given`` (the scene's, when known), ``walk`` (the walking-1/0 patterns
    received), ``walk_ok``, ``locked``, ``error``, ``golden`` (the same fields predicted),
    ``agree`` (every field equal) and ``text`` (one line; a lane with no eye says so);
    ``trained``: each lane's tap as training chose it (None: ``tap``), ``trained_tap`` (the
    receiver's ``tap`` is the one at the end: with tracking it has moved).
    """
    w = word_bits
    fields = {"mask": ("lane_scan", lvds.N_TAPS), "eye_taps_found": ("lane_run", RUN_BITS),
              "tap": ("lane_chosen_tap", TAP_BITS), "slip": ("lane_slip", SLIP_BITS),
              "slip_mask": ("lane_slip_pass", w), "walk": ("lane_walk", 2 * w),
              "locked": ("lane_locked", 1), "error": ("lane_error", 1)}
    gkeys = {"mask": "scan", "eye_taps_found": "run", "tap": "tap", "slip": "slip",
             "slip_mask": "slip_pass", "walk": "walk", "locked": "locked", "error": "error"}
    full = (1 << 2 * w) - 1
    out = []
    for i, g in enumerate(golden):
        e = {"lane": i}
        for key, (port, bits) in fields.items():
            e[key] = (int(status[prefix + port]) >> (i * bits)) & ((1 << bits) - 1)
        e["golden"] = {key: int(g[gkeys[key]]) for key in fields}
        e["agree"] = all(e[k] == e["golden"][k] for k in fields)
        e["taps"] = [(e["mask"] >> t) & 1 for t in range(lvds.N_TAPS)]
        e["walk_ok"] = e["walk"] == full
        e["eye_ps_found"] = None if tap_ps is None else e["eye_taps_found"] * tap_ps
        e["eye_taps_given"] = None if eye_taps is None else float(eye_taps[i])
        tt = None if trained is None else trained[i]
        e["trained_tap"] = e["tap"] if tt is None else int(tt)
        at = f"tap {e['trained_tap']}" + ("" if e["trained_tap"] == e["tap"] else
                                         f" ({e['tap']} at the end, tracked)")
        given = "" if eye_taps is None else f" (scene: {float(eye_taps[i]):g})"
        same = "as the golden model predicts" if e["agree"] else \
            f"the golden model predicts {e['golden']}"
        if e["locked"]:
            e["text"] = (f"lane {i}: eye {e['eye_taps_found']} taps{given}, {at}, slip "
                         f"{e['slip']}; walking 1/0: "
                         + ("every bit seen as 1 and 0" if e["walk_ok"] else
                            f"patterns {e['walk']:#x} of {full:#x}")
                         + f"; {same}")
        elif e["eye_taps_found"] < min_run:
            e["text"] = (f"lane {i}: error: no eye (widest run {e['eye_taps_found']} taps"
                         f"{given}, {min_run} needed); {same}")
        else:
            e["text"] = (f"lane {i}: error after training (eye {e['eye_taps_found']} taps"
                         f"{given}, slips {e['slip_mask']:#x}, walking 1/0 {e['walk']:#x}); "
                         f"{same}")
        out.append(e)
    return out
