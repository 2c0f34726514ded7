"""Pin-level simulation of the output links (:class:`tdicam.hdl.tlk2711.Tlk2711` with
``pins``, and ``crossing``: the processing clock and the links' reference clock), against
the golden model :mod:`tdicam.model.tlk2711`.

A :class:`PinsCase` is frames through the block with random idle input cycles, the two
clock periods and, optionally, a reset of both domains mid-frame (the golden case form of
:mod:`tdicam.blocks.tlk2711`: ``keep``/``reset_after``). The source offers the stimulus
beats on the processing clock; the sink samples every link's ``TXD``/``TKLSB``/``TKMSB`` on
every link clock. :func:`check` judges a capture the way a receiver sees the links: with the
IDLEs dropped each segment's words must be the golden words (a segment cut by a reset: a
prefix of them), every SOF and SOL must follow at least two IDLEs (the receiver's commas),
the links must be idle together (they run in lockstep), and :func:`~tdicam.model.tlk2711.
decode` of a capture without a reset must give the frames back.

:func:`run_amaranth` runs a case in Amaranth's simulator (two clock domains),
:func:`run_cocotb` the generated Verilog on Icarus or Verilator
(:mod:`tdicam.simtb.tlk2711_tb`), several cases of one parameter set in one run.
"""

import json
import os
import shutil
import time
from dataclasses import dataclass, field

import numpy as np

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.model import tlk2711

__all__ = ["PinsCase", "PARAMS", "SCENARIOS", "scenario", "PinSink", "run_amaranth",
           "run_cocotb", "check", "RST_CYCLES"]

#: Cycles of the slower clock both resets are held (at the start and mid-stream).
RST_CYCLES = 4


@dataclass
class PinsCase:
    """A pin-level scenario.

    ``frames``: 2-D frames of one width; ``params``: the block's (``pins`` set here);
    ``proc_ns``, ``link_ns``: the clock periods (equal without ``crossing``); ``idle``:
    probability of an idle input cycle; ``keep``, ``reset_after``: as in a golden case (a
    reset of both domains after frame ``f`` when ``reset_after[f]``, the frame cut after
    ``keep[f]`` pixels)."""

    name: str
    frames: list
    params: dict
    proc_ns: float = 10.0
    link_ns: float = 10.0
    idle: float = 0.2
    seed: int = 1
    keep: list | None = None
    reset_after: list | None = None
    stim: object = field(default=None, init=False)
    exp: object = field(default=None, init=False)

    def __post_init__(self):
        blk = blocks.get("tlk2711")
        self.params = blk.resolve({**self.params, "pins": True})
        if not self.params["crossing"] and self.proc_ns != self.link_ns:
            raise TdicamError(f"{self.name}: two clock periods need crossing")
        from tdicam.blocks.tlk2711 import case_beats, stream_case
        arrays = stream_case([np.asarray(f) for f in self.frames], self.params,
                             keep=self.keep, reset_after=self.reset_after)
        self.stim, self.exp = case_beats(arrays, {**self.params, "pins": False})

    @property
    def links(self):
        return self.params["links"]

    def segments(self):
        """The golden words of each segment (between resets), ``(links, n)`` each."""
        return [self.exp.data[self.exp.seg == s].T for s in range(int(self.exp.seg.max()) + 1)]

    def last_words(self):
        """Non-IDLE words a link sends in the last segment (the sink's stop count)."""
        return int((self.segments()[-1][0] != tlk2711.IDLE).sum())


def _frames(rng, bits, heights, width):
    full = (1 << bits) - 1
    out = [rng.integers(0, full + 1, (h, width)) for h in heights]
    out[0][0] = full                         # a full-scale row and a zero row
    out[-1][-1] = 0
    return out


def scenario(name):
    """The :class:`PinsCase` called ``name`` (:data:`SCENARIOS`)."""
    if name not in SCENARIOS:
        raise TdicamError(f"unknown tlk2711 pins scenario {name!r}; valid: "
                          f"{', '.join(SCENARIOS)}")
    kw = dict(SCENARIOS[name])
    rng = np.random.default_rng(kw.pop("seed", 1))
    p = PARAMS[kw.pop("params")]
    heights, width = kw.pop("heights"), kw.pop("width")
    return PinsCase(name, _frames(rng, p["pixel_bits"], heights, width), p, **kw)


#: Parameter sets of the scenarios (a simulator build each): one clock at 1 pixel a clock
#: into two links (the pairing); the crossing at 2 pixels a clock with a 4-entry FIFO; 8
#: pixels a clock of 16 bits into two links.
PARAMS = {
    "one_clock": {"pixel_bits": 12, "ppc": 1, "links": 2},
    "crossing": {"pixel_bits": 12, "ppc": 2, "links": 2, "crossing": True, "fifo_depth": 4},
    "ppc8": {"pixel_bits": 16, "ppc": 8, "links": 2, "crossing": True},
}

#: The must-show scenarios: one clock (the pins and their IDLE fill); the crossing with the
#: link clock faster than the processing clock (133 vs 100 MHz: the input's rate limits),
#: slower (80 vs 150 MHz: the links limit, backpressure through the FIFO), a reset of both
#: domains mid-frame with entries in the FIFO; 8 pixels a clock into 2 links (the links
#: limit).
SCENARIOS = {
    "one_clock": dict(params="one_clock", heights=(3, 2), width=10, idle=0.3),
    "link_faster": dict(params="crossing", heights=(3, 1, 2), width=12, proc_ns=10.0,
                        link_ns=7.5, idle=0.2, seed=2),
    "link_slower": dict(params="crossing", heights=(2, 3), width=16, proc_ns=6.666,
                        link_ns=12.5, idle=0.1, seed=3),
    "reset_mid_frame": dict(params="crossing", heights=(4, 2), width=20, proc_ns=9.0,
                            link_ns=11.0, idle=0.1, seed=5, keep=[50, 40],
                            reset_after=[1, 0]),
    "ppc8_two_links": dict(params="ppc8", heights=(2, 2), width=32, proc_ns=8.0,
                           link_ns=10.0, idle=0.0, seed=4),
}


class PinSink:
    """The link side of a pins testbench, simulator-neutral: :meth:`sample` takes each link
    clock's words (one a link) and the links' reset as sampled with them, and says when to
    stop. Segments are told apart by the reset: a reset seen on two samples in a row starts
    the next segment (the first sample may still show the words sent before the reset took
    effect; the second and later are the reset's IDLEs)."""

    def __init__(self, case, *, drain=40, in_reset=False):
        self.n_last, self.last_seg = case.last_words(), int(case.stim.seg.max())
        self.drain, self.quiet, self.seen = drain, 0, 0
        self.segment, self.prev, self.counted = 0, in_reset, in_reset
        self.words, self.seg = [], []

    def sample(self, words, rst):
        """Record one link clock; True when the last segment is all out and the links have
        been idle for ``drain`` clocks since."""
        if rst and self.prev and not self.counted:
            self.segment, self.counted = self.segment + 1, True
        self.counted &= bool(rst)
        self.prev = bool(rst)
        self.words.append([int(w) for w in words])
        self.seg.append(self.segment)
        if words[0] != tlk2711.IDLE:
            self.seen += self.segment == self.last_seg
            self.quiet = 0
        else:
            self.quiet += 1
        return self.seen >= self.n_last and self.quiet >= self.drain

    def capture(self):
        """What :func:`check` takes."""
        return {"words": self.words, "seg": self.seg, "cycles": len(self.words)}


def _idle(link, w):
    return w[link] == tlk2711.IDLE


def _frame_line(want, k, link):
    """`` frame F line L`` of golden non-IDLE word ``k`` (from the SOF and SOL markers
    before it), or ``""`` before the first frame."""
    sof = np.flatnonzero(want[:k + 1] == tlk2711.marker(tlk2711.K27_7, link))
    if not len(sof):
        return ""
    rows = int((want[sof[-1]:k + 1] == tlk2711.marker(tlk2711.K28_0, link)).sum())
    return f" frame {len(sof) - 1}" + (f" line {rows - 1}" if rows else "")


def check(case, capture):
    """Judge a capture (``{"words": [[w per link] per link clock], "seg": [segment per
    link clock]}``) of ``case``; raises AssertionError naming the scenario, the link and
    the word."""
    words = np.array(capture["words"], np.int64).reshape(-1, case.links)
    seg = np.array(capture["seg"], np.int64)
    idle = words == tlk2711.IDLE
    both = idle.all(axis=1) | (~idle).all(axis=1)
    if not both.all():
        k = int(np.argmin(both))
        raise AssertionError(f"{case.name}: link clock {k}: one link idle, the other not "
                             f"({[hex(int(x)) for x in words[k]]}): the links must run in "
                             f"lockstep")
    gold = case.segments()
    for s, g in enumerate(gold):
        for link in range(case.links):
            got = words[(seg == s) & ~idle[:, link], link]
            want = g[link][g[link] != tlk2711.IDLE].astype(np.int64)
            last = s == len(gold) - 1
            n = min(len(got), len(want))
            bad = np.flatnonzero(got[:n] != want[:n])
            if len(bad) or len(got) > len(want) or (last and len(got) != len(want)):
                k = int(bad[0]) if len(bad) else n
                clocks = np.flatnonzero((seg == s) & ~idle[:, link])
                at = f" at link clock {int(clocks[k])}" if k < len(clocks) else ""
                raise AssertionError(
                    f"{case.name}: segment {s} link {link}{_frame_line(want, k, link)}: "
                    f"non-IDLE word {k}{at} "
                    f"{'0x%05x' % got[k] if k < len(got) else 'missing'}, expected "
                    f"{'0x%05x' % want[k] if k < len(want) else 'nothing'} ({len(got)} "
                    f"words captured, {len(want)} golden)")
        for link in range(case.links):
            w = words[seg == s, link]
            marks = np.flatnonzero(np.isin(w, [tlk2711.marker(tlk2711.K27_7, link),
                                               tlk2711.marker(tlk2711.K28_0, link)]))
            short = [int(k) for k in marks if k < 2 or not (w[k - 2:k] == tlk2711.IDLE).all()]
            if short:
                raise AssertionError(f"{case.name}: segment {s} link {link}: the marker at "
                                     f"link clock {short[0]} follows fewer than 2 IDLEs")
    if len(gold) == 1:
        got = tlk2711.decode(words.T, width=case.frames[0].shape[1],
                           pixel_bits=case.params["pixel_bits"], links=case.links)
        for f, (a, b) in enumerate(zip(got.frames, case.frames)):
            if a.shape != b.shape or (a != b).any():
                raise AssertionError(f"{case.name}: frame {f} decoded from the pins differs "
                                     f"from the frame sent")
        if len(got.frames) != len(case.frames):
            raise AssertionError(f"{case.name}: {len(got.frames)} frames decoded, "
                                 f"{len(case.frames)} sent")


def run_amaranth(case, *, drain=40, max_link_cycles=None):
    """Simulate ``case`` on :class:`~tdicam.hdl.tlk2711.Tlk2711` in Amaranth's simulator
    (with ``crossing``: the ``sync`` and ``link`` domains on their own clocks). Returns the
    capture :func:`check` takes, with ``cycles`` (link clocks) and ``wall`` (s)."""
    from amaranth.hdl import ClockDomain, Module
    from amaranth.sim import Simulator
    from tdicam.hdl.tlk2711 import LINK_DOMAIN, Tlk2711, pin_names
    p = case.params
    dut = Tlk2711(**{k: p[k] for k in ("pixel_bits", "ppc", "links", "pins", "crossing",
                                       "fifo_depth")})
    m = Module()
    m.domains.sync = sync = ClockDomain("sync")
    m.submodules.dut = dut
    link_cd = sync
    if p["crossing"]:
        m.domains.link = link_cd = ClockDomain(LINK_DOMAIN)
    stim = case.stim
    rng = np.random.default_rng(case.seed)
    state = {"done": False}
    out = PinSink(case, drain=drain, in_reset=True)
    pins = [[getattr(dut, n) for n in pin_names(k)] for k in range(case.links)]
    slow = max(case.proc_ns, case.link_ns)
    hold = int(np.ceil(RST_CYCLES * slow / case.proc_ns))
    limit = max_link_cycles or 50 * len(stim) + 2000
    i = dut.i_stream

    async def reset(ctx):
        """Both domains' resets for ``hold`` processing clocks."""
        ctx.set(i.valid, 0)
        for level in (1, 0):
            for cd in {sync, link_cd}:
                ctx.set(cd.rst, level)
            for _ in range(hold * level):
                await ctx.tick("sync")

    async def source(ctx):
        k = 0
        await reset(ctx)
        while k < len(stim) and not state["done"]:
            if stim.rst[k] and state.get("served") != k:
                state["served"] = k
                await reset(ctx)
            offer = rng.random() >= case.idle
            ctx.set(i.valid, offer)
            if offer:
                d = stim.data[k]
                if p["ppc"] == 1:
                    ctx.set(i.payload.data, int(d[0]))
                else:
                    for e in range(p["ppc"]):
                        ctx.set(i.payload.data[e], int(d[e]))
                ctx.set(i.payload.first, bool(stim.first[k]))
                ctx.set(i.payload.last, bool(stim.last[k]))
                took = ctx.get(i.ready)
            else:
                took = False
            await ctx.tick("sync")
            k += bool(took)
        ctx.set(i.valid, 0)

    async def sink(ctx):
        for _ in range(limit):
            await ctx.tick(LINK_DOMAIN if link_cd is not sync else "sync")
            w = [ctx.get(t) | ctx.get(lo) << 16 | ctx.get(hi) << 17 for t, lo, hi in pins]
            if out.sample(w, ctx.get(link_cd.rst)):
                break
        state["done"] = True

    sim = Simulator(m)
    sim.add_clock(case.proc_ns * 1e-9, domain="sync")
    if link_cd is not sync:
        sim.add_clock(case.link_ns * 1e-9, domain=LINK_DOMAIN)
    sim.add_testbench(source)
    sim.add_testbench(sink)
    t0 = time.perf_counter()
    sim.run()
    return {**out.capture(), "wall": time.perf_counter() - t0}


def run_cocotb(names, sim, *, keep=False):
    """Co-simulate scenarios ``names`` (one parameter set: they must share it) on the
    generated top (``tdicam verilog tlk2711 --pins ...``) with cocotb
    (:mod:`tdicam.simtb.tlk2711_tb`), every scenario in one simulator run. Returns
    ``(cases, captures, wall seconds, build seconds)``."""
    from tdicam.cosim.build import build_sources, run_cocotb as _run
    from tdicam.hw.verilog import generate
    cases = [scenario(n) for n in names]
    params = cases[0].params
    if any(c.params != params for c in cases):
        raise TdicamError("run_cocotb: the scenarios of one run share one parameter set")
    text = generate("tlk2711", params)
    bdir, build_s = build_sources("tlk2711_pins", params, sim, {"tlk2711.v": text},
                                  top="tlk2711")
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    job = {"scenarios": []}
    for k, c in enumerate(cases):
        stim = c.stim
        np.save(rundir / f"stim_{k}.npy", np.column_stack(
            [stim.data.astype(np.int64), stim.first, stim.last, stim.rst]))
        job["scenarios"].append({
            "name": c.name, "ppc": params["ppc"], "bits": params["pixel_bits"],
            "links": c.links, "crossing": params["crossing"],
            "proc_ps": 2 * round(c.proc_ns * 500), "link_ps": 2 * round(c.link_ns * 500),
            "idle": c.idle, "seed": c.seed, "rst_cycles": RST_CYCLES,
            "max_link_cycles": 50 * len(stim) + 2000})
    (rundir / "job.json").write_text(json.dumps(job))
    ok, wall = _run(bdir, sim, "tlk2711_tb", rundir, [], top="tlk2711")
    caps = []
    for k in range(len(cases)):
        f = rundir / f"capture_{k}.json"
        if not ok or not f.exists():
            raise TdicamError(f"{sim} simulation of tlk2711 --pins failed; see "
                              f"{rundir / 'sim.log'}")
        caps.append(json.loads(f.read_text()))
    if not keep:
        shutil.rmtree(rundir, ignore_errors=True)
    return cases, caps, wall, build_s
