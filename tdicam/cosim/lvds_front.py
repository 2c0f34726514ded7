"""Simulation of the camera's front end (:class:`tdicam.hdl.lvds_front.LvdsFront`) against
its golden model (:mod:`tdicam.model.lvds_front`) and the link model
(:mod:`tdicam.model.lvds`), with two clocks.

:class:`FrontCase` is one scenario: frames per gain channel, the lanes' analogue parameters,
the sensor's schedule (training, then whole frames; a retrain segment where asked), the
two clock periods. :func:`raw_table` evaluates the link model once for every tap and
cycle, so a testbench only looks words up: the word the DUT gets at word clock ``k`` is
``raw(k)`` sampled with the tap loaded (``lane_ld``) two word clocks earlier.
:func:`run_amaranth` runs a case in Amaranth's simulator and returns the output frames and
the status; :func:`frames_of` cuts output beats into frames.
"""

from dataclasses import dataclass, field

import numpy as np

from tdicam.hdl.lvds import TAP_BITS
from tdicam.model import lvds as model
from tdicam.model import lvds_front as front

__all__ = ["FrontCase", "raw_table", "run_amaranth", "frames_of"]


@dataclass
class FrontCase:
    """A front-end scenario.

    ``frames``: one ``(F, R, C)`` stack per gain channel; ``lanes``: one
    :class:`tdicam.model.lvds.Lane` per lane (high-gain lanes first); ``segments``: frames
    per data segment (each ends with a blank line; a training segment before each, the
    retrain request at its first word); ``word_ns``/``proc_ns``: the two clock
    periods; ``ready``: probability that the processing side takes a beat.
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
    retrains: tuple = field(default=(), init=False)
    link: object = field(default=None, init=False)
    cycles: int = field(default=0, init=False)

    def __post_init__(self):
        L, w = self.lanes_per_gain, self.word_bits
        nf, nr, nc = np.asarray(self.frames[0]).shape
        self.p = nc // L
        lw = self.p + 2
        tw = model.training_words(w, self.n_check, self.settle)
        segs = self.segments or (nf,)
        if sum(segs) != nf:
            raise ValueError("segments must add up to the frames")
        sched, k, retrains, parts, f0 = [], tw + 40, [], [], 0
        for i, f in enumerate(segs):
            if i:
                retrains.append(k)
                sched.append((k, "train"))
                k += 1 + tw + 40
            sched.append((k, "data"))
            k += (f * nr + 1) * lw
            parts.append([np.asarray(a)[f0:f0 + f] for a in self.frames])
            f0 += f
        self.retrains = tuple(retrains)
        self.link = model.Link(self.lanes, word_bits=w, line_words=lw, schedule=tuple(sched),
                               payload=front.segment_payload(parts, L, w))
        self.cycles = k + self.tail
        self.segment_starts = [s for s, mode in sched if mode == "data"]

    @property
    def fifo_depth(self):
        return front.fifo_depth(self.lanes_per_gain, self.ppc, self.p * self.lanes_per_gain,
                                1e3 / self.word_ns, 1e3 / self.proc_ns)

    def golden_run(self):
        return model.run(self.link, cycles=self.cycles, retrains=self.retrains,
                         n_check=self.n_check, settle=self.settle)


def raw_table(link, cycles):
    """``raw[lane, tap, k]``: the raw word of every lane at every tap and word clock."""
    k = np.broadcast_to(np.arange(cycles, dtype=np.int64), (model.N_TAPS, cycles))
    taps = np.arange(model.N_TAPS, dtype=np.int64)[:, None]
    return np.stack([model.raw_words(link, i, taps, k)
                     for i in range(len(link.lanes))])


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


def run_amaranth(case, *, dut=None, hook=None):
    """Run ``case`` on :class:`~tdicam.hdl.lvds_front.LvdsFront` in Amaranth's simulator.

    Returns a dict: ``beats`` (first, last, elements) in order, ``status`` (the word-domain
    status ports at the end), ``frame_status`` (``frame_invalid`` at every ``frames_out``
    step, in order), ``events`` (cycle, lane, locked, error) lane status changes.
    ``hook(ctx, dut, k)``, when given, runs every word clock (fault injection).
    """
    from amaranth.sim import Simulator

    from tdicam.hdl.lvds_front import WORD_DOMAIN, LvdsFront
    L, g = case.lanes_per_gain, len(case.frames)
    n, w, bits, ppc = L * g, case.word_bits, case.bits, case.ppc
    nr = np.asarray(case.frames[0]).shape[1]
    if dut is None:
        dut = LvdsFront(lanes_per_gain=L, gains=g, word_bits=w, bits=bits,
                        columns=case.p * L, ppc=ppc, fifo_depth=case.fifo_depth,
                        settle=case.settle)
    raw = raw_table(case.link, case.cycles)
    res = {"beats": [], "frame_status": [], "events": [], "status": {}}
    done = [False]
    tmask = (1 << TAP_BITS) - 1

    async def word_side(ctx):
        for port, v in (("train_word", case.link.train_word),
                        ("sync_word", case.link.sync_word), ("n_check", case.n_check),
                        ("frame_rows", nr)):
            ctx.set(getattr(dut, port), v)
        tapq, tap2 = [0] * n, [0] * n
        prev, out_seen = [(0, 0)] * n, 0
        for k in range(case.cycles):
            ctx.set(dut.lane_raw, sum(int(raw[i, tap2[i], k]) << (i * w) for i in range(n)))
            ctx.set(dut.retrain, int(k in case.retrains))
            if hook is not None:
                hook(ctx, dut, k)
            ld, tap = ctx.get(dut.lane_ld), ctx.get(dut.lane_tap)
            lk, er = ctx.get(dut.lane_locked), ctx.get(dut.lane_error)
            for i in range(n):
                st = ((lk >> i) & 1, (er >> i) & 1)
                if st != prev[i]:
                    res["events"].append((k, i) + st)
                    prev[i] = st
            fo = ctx.get(dut.frames_out)
            if fo != out_seen:
                res["frame_status"].append(ctx.get(dut.frame_invalid))
                out_seen = fo
            await ctx.tick(WORD_DOMAIN)
            for i in range(n):
                tap2[i] = tapq[i]
                if (ld >> i) & 1:
                    tapq[i] = (tap >> TAP_BITS * i) & tmask
        for name in ("lane_locked", "lane_error", "frame_invalid", "trained", "releasing",
                     "need_retrain", "frames_out", "frames_dropped", "frames_affected",
                     "lane_errors", "fifo_overflow"):
            res["status"][name] = ctx.get(getattr(dut, name))
        done[0] = True

    async def proc_side(ctx):
        rng = np.random.default_rng(case.seed)
        o = dut.o_stream
        while not done[0]:
            rdy = int(rng.random() < case.ready)
            ctx.set(o.ready, rdy)
            if rdy and ctx.get(o.valid):
                d = ctx.get(o.payload.data)
                elems = [int(d[i]) for i in range(ppc * g)] if ppc * g > 1 else [int(d)]
                res["beats"].append((ctx.get(o.payload.first), ctx.get(o.payload.last),
                                     elems))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(case.word_ns * 1e-9, domain=WORD_DOMAIN)
    sim.add_clock(case.proc_ns * 1e-9)
    sim.add_testbench(word_side)
    sim.add_testbench(proc_side, background=True)
    sim.run()
    return res
