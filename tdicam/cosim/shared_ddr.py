"""The camera's DDR users on one arbiter: the command order the controller sees.

Ning et al. 2019 §4.2 puts every DDR consumer of the camera on the MIG user interface of its
DDR part. :func:`record_shared` runs DDR users (:class:`~tdicam.hdl.nuc_ddr.NucDdr`,
:class:`~tdicam.hdl.cds_ddr.CdsDdr`, :class:`~tdicam.hdl.ddr.DdrFrameBuffer`, ...) in
Amaranth's simulator, each through its own port of one
:class:`~tdicam.hdl.ddr_arbiter.DdrArbiter` onto one
:class:`~tdicam.hdl.simmodels.mig_model.MigModel` (DRAM timing on), each input always valid
(data always available) and each output always ready unless the user is given a
:class:`Pace`, and records each command the model accepts: a one-port
:class:`~tdicam.model.ddr_traces.Trace` (word addresses), the arbiter's real access order,
which :func:`tdicam.model.ddr_traces.replay_model` and :func:`tdicam.cosim.litedram.replay`
replay back to back. :func:`camera_trace` is the camera's, as the whole camera's top has it
on each gain channel's interface: the NUC coefficient read and the CDS reset frame's write
and read (saturated), and the output links' frame buffer writing the kept lines and reading
them back at the links' pace (:data:`FB_WRITE_SHARE`, :data:`FB_READ_SHARE`).
"""

from dataclasses import dataclass

from amaranth.hdl import Elaboratable, Module

from tdicam.errors import TdicamError
from tdicam.model.ddr import ADDR_PER_WORD
from tdicam.model.ddr_traces import Trace
from tdicam.model.dram import DEFAULT_STALLS, DramTiming, window_words

__all__ = ["SharedDdr", "Pace", "record_shared", "camera_trace", "CAMERA_TRACE",
           "FB_WRITE_SHARE", "FB_READ_SHARE", "FB_OFFER"]

#: the name of :func:`camera_trace`'s order (the benchmark's row, the fixture's key)
CAMERA_TRACE = "cds_nuc_fb_arbiter"
#: the frame buffer's written words per word of the coefficient reads and the reset frame's
#: writes and reads, as the camera plan budgets one interface
#: (``tdicam plan --scene scenes/ning2019_gmax0504_full.toml``: image write 3.92 Gbit/s
#: against coefficients 15.64, reset write 5.23 and read 5.23)
FB_WRITE_SHARE = 3.92 / (15.64 + 5.23 + 5.23)
#: the frame buffer's read words per written word (the plan's image read 1.60 Gbit/s
#: against its write 3.92: the links drain the kept images slower than the chain makes them)
FB_READ_SHARE = 1.60 / 3.92
#: the probability a cycle offers the frame buffer an input beat in :func:`camera_trace`
#: (8 pixels, half a 16-pixel word): set so its written words come to
#: :data:`FB_WRITE_SHARE` of the saturated users' words as recorded (the note of the trace
#: and tests/test_ddr_arbiter.py check the shares)
FB_OFFER = 0.168


@dataclass(frozen=True)
class Pace:
    """A DDR user's pace in :func:`record_shared`: each cycle with its input idle offers the
    next input beat with probability ``offer`` (the beat then held valid until taken),
    and ``o_stream.ready`` is high in a cycle with probability ``ready``, both drawn from a
    generator seeded by the recording's ``seed`` and the user's port (deterministic).
    ``offer = ready = 1``: always valid, always ready (the saturated user)."""

    offer: float = 1.0
    ready: float = 1.0

    def __post_init__(self):
        for n in ("offer", "ready"):
            v = getattr(self, n)
            if not 0 < v <= 1:
                raise TdicamError(f"Pace.{n} = {v}: give a probability in (0, 1]")


class SharedDdr(Elaboratable):
    """Simulation only: ``users`` (components with MIG user ports) on the ports of one
    :class:`~tdicam.hdl.ddr_arbiter.DdrArbiter` (``arb``, ``burst``) onto one
    :class:`~tdicam.hdl.simmodels.mig_model.MigModel` (``model``: ``depth_words``, DRAM
    timing, the stall pattern ``stalls``)."""

    def __init__(self, users, *, burst, depth_words=1 << 20, **stalls):
        from tdicam.hdl.ddr_arbiter import DdrArbiter
        from tdicam.hdl.simmodels.mig_model import MigModel
        self.users = users
        self.arb = DdrArbiter(n_ports=len(users), burst=burst)
        self.model = MigModel(depth_words=depth_words, dram=DramTiming(), **stalls)

    def elaborate(self, platform):
        from tdicam.hdl.interfaces.mig import connect_mig
        m = Module()
        m.submodules.arb, m.submodules.model = self.arb, self.model
        for k, u in enumerate(self.users):
            m.submodules[f"user{k}"] = u
            connect_mig(m, u, self.arb.port(k))
        connect_mig(m, self.arb, self.model)
        return m


def record_shared(users, stims, *, sides=None, pacing=None, seed=1, burst=64, stalls=None,
                  name="shared", max_cycles=200000, quiet_cycles=2000):
    """The controller-side command order of DDR users behind one arbiter.

    Parameters
    ----------
    users : list of components
        DDR users with ``i_stream``/``o_stream`` and MIG user ports; user ``k`` on the
        arbiter's port ``k``.
    stims : list of :class:`~tdicam.beats.Beats`
        ``stims[k]``: user ``k``'s input beats, in order.
    sides : list of dict, optional
        ``sides[k]``: user ``k``'s level inputs per beat (``{"frame_kind": array}``).
    pacing : list of :class:`Pace` or None, optional
        ``pacing[k]``: user ``k``'s input offer and output ready probabilities; None (or
        ``pacing`` None): saturated, every input beat valid back to back and the output
        always ready.
    seed : int
        Seeds the paced users' draws (user ``k``'s generator: ``(seed, k)``).
    burst, stalls
        The arbiter's commands a grant; the controller model's stall pattern (default
        :data:`tdicam.model.dram.DEFAULT_STALLS`).
    name : str
        The trace's name.
    max_cycles, quiet_cycles : int
        The recording stops when the saturated users (every user, when all are paced) have
        had no command taken for ``quiet_cycles`` cycles, or after ``max_cycles``.

    Returns
    -------
    :class:`~tdicam.model.ddr_traces.Trace`
        One port: every command the controller model accepted, ``(is_read, word address)``
        in its order; ``note`` gives the cycles, each port's commands taken and each user's
        input beats taken.

    Raises
    ------
    TdicamError
        The controller model flagged a bad access; or a paced user's input ran out before
        the recording stopped (its share would not hold to the end: give it more beats).
    """
    import numpy as np
    from amaranth.lib.data import ArrayLayout
    from amaranth.sim import Simulator

    top = SharedDdr(users, burst=burst, **(stalls or DEFAULT_STALLS))
    mdl, arb = top.model, top.arb
    sides = sides or [{} for _ in users]
    pacing = list(pacing or [None] * len(users))
    saturated = [k for k, p in enumerate(pacing) if p is None] or list(range(len(users)))
    cmds, per_port, taken = [], [0] * len(users), [0] * len(users)
    state = {"t": 0, "error": False}

    def feeder(k, u, stim, side, pace):
        data = np.asarray(stim.data, np.uint64)
        array = isinstance(u.i_stream.payload.data.shape(), ArrayLayout)
        rng = np.random.default_rng([seed, k])

        async def bench(ctx):
            if pace is None:
                ctx.set(u.o_stream.ready, 1)
            for i in range(len(stim)):
                if pace is not None:
                    while rng.random() >= pace.offer:
                        await ctx.tick()
                if array:
                    for e in range(data.shape[1]):
                        ctx.set(u.i_stream.payload.data[e], int(data[i, e]))
                else:
                    ctx.set(u.i_stream.payload.data, int(data[i, 0]))
                ctx.set(u.i_stream.payload.first, bool(stim.first[i]))
                ctx.set(u.i_stream.payload.last, bool(stim.last[i]))
                for s, v in side.items():
                    ctx.set(getattr(u, s), int(v[i]))
                ctx.set(u.i_stream.valid, 1)
                while not (await ctx.tick().sample(u.i_stream.ready))[-1]:
                    pass        # (not tick().until: a paced feeder is left waiting at the end)
                taken[k] += 1
                if pace is not None:
                    ctx.set(u.i_stream.valid, 0)
            ctx.set(u.i_stream.valid, 0)
        return bench

    def sink(k, u, pace):
        rng = np.random.default_rng([seed, k, 1])

        async def bench(ctx):
            while True:
                ctx.set(u.o_stream.ready, int(rng.random() < pace.ready))
                await ctx.tick()
        return bench

    async def monitor(ctx):
        quiet = 0
        async for _, _, en, rdy, cmd, addr, g, tk, err in ctx.tick().sample(
                mdl.app_en, mdl.app_rdy, mdl.app_cmd, mdl.app_addr, arb.grant, arb.take,
                mdl.error):
            state["t"] += 1
            if err:
                state["error"] = True
                return
            if en and rdy:
                cmds.append((int(cmd), int(addr) // ADDR_PER_WORD))
            quiet += 1
            if tk:
                per_port[g] += 1
                if g in saturated:
                    quiet = 0
            if quiet > quiet_cycles or state["t"] > max_cycles:
                return

    sim = Simulator(top)
    sim.add_clock(1e-8)
    for k, (u, stim, side, pace) in enumerate(zip(users, stims, sides, pacing)):
        sim.add_testbench(feeder(k, u, stim, side, pace), background=True)
        if pace is not None:
            sim.add_testbench(sink(k, u, pace), background=True)
    sim.add_testbench(monitor)
    sim.run()
    if state["error"]:
        raise TdicamError(f"recording {name}: the controller model flagged a bad access")
    short = [k for k, p in enumerate(pacing) if p is not None and taken[k] == len(stims[k])]
    if short:
        raise TdicamError(f"recording {name}: paced user {short[0]}'s {len(stims[short[0]])} "
                          f"input beats ran out before the recording stopped; give it more")
    return Trace(name, [cmds], note=f"{state['t']} cycles; commands taken per port: "
                                    f"{per_port}; input beats taken per user: {taken}")


def camera_trace(*, width=512, rows=16, ppc=8, seed=1):
    """The camera's shared DDR order (:data:`CAMERA_TRACE`), as the whole camera's top has
    it on a gain channel's interface.

    The ports in the top's order (:class:`~tdicam.hdl.chain_top.Pipeline`: the DDR blocks
    in stream order, the frame buffer last): port 0 a :class:`~tdicam.hdl.cds_ddr.CdsDdr`
    (10-bit reset frame then signal frame, in turn: a reset line of ``width / 24`` words
    written, read back), port 1 a :class:`~tdicam.hdl.nuc_ddr.NucDdr` (its coefficient frame
    loaded, then pixel frames: a coefficient line of ``width / 8`` words read per row), both
    saturated (inputs always
    valid, outputs always ready) at ``ppc`` pixels a clock on frames of ``rows`` x
    ``width``; port 2 (last) the output links' :class:`~tdicam.hdl.ddr.DdrFrameBuffer`
    (16-bit pixels, 16 a word, ``ppc`` a beat, early, paced) of as many lines as it is fed,
    so its lead limit never holds it, its input offered with probability :data:`FB_OFFER`
    a cycle and its output ready with :data:`FB_READ_SHARE` of that (:class:`Pace`): its
    writes about :data:`FB_WRITE_SHARE` of the other two users' words, its reads
    :data:`FB_READ_SHARE` of its writes. The CDS reset frame at address 0, the coefficients
    above it, the frame buffer above them (each from the next multiple of 4096); the
    arbiter's burst a coefficient line. The commands from the end of the coefficient load
    to the saturated users' last (the steady state), at least the steady-state window's
    (:func:`tdicam.model.dram.window_words`); ``note`` adds the frame buffer's shares in
    them."""
    import numpy as np

    from tdicam.beats import frames_to_beats
    from tdicam.hdl.cds_ddr import CdsDdr
    from tdicam.hdl.ddr import DdrFrameBuffer
    from tdicam.hdl.nuc_ddr import NucDdr
    from tdicam.model.nuc_ddr import coeff_layout

    def above(end):
        return -(-end // 4096) * 4096

    rng = np.random.default_rng(seed)
    cds = CdsDdr(width=width, rows=rows, pixel_bits=10, ppc=ppc)
    nuc_base = above(cds.layout.end_addr(rows))
    nuc = NucDdr(width=width, rows=rows, pixel_bits=10, ppc=ppc, base=nuc_base)
    fb_base = above(nuc.layout.end_addr(rows))
    wpl = coeff_layout(width).words_per_line
    need = window_words()
    frames = -(-need // (rows * (wpl + 2 * cds.layout.words_per_line))) + 2
    g = rng.integers(1 << 13, 1 << 15, (1, rows, width))
    o = rng.integers(-64, 64, (1, rows, width)) & 0xFFFF
    coeffs = np.stack([g[0], o[0]], axis=-1)[None]
    px = rng.integers(0, 1 << 10, (frames, rows, width))
    nuc_in = np.concatenate([coeffs, np.stack([px, np.zeros_like(px)], axis=-1)])
    per = rows * width // ppc
    nuc_stim = frames_to_beats(nuc_in, ppc=ppc, channels=2)
    cds_stim = frames_to_beats(rng.integers(0, 1 << 10, (2 * frames, rows, width)), ppc=ppc)
    kinds_n = np.repeat(np.r_[1, np.zeros(frames, int)], per)
    kinds_c = np.repeat(np.tile([1, 0], frames), per)
    # the frame buffer's lines: enough for the recording were the saturated users' words to
    # go at 0.4 a cycle (they go at about 0.6)
    saturated_words = (frames + 1) * rows * wpl + 2 * frames * rows * cds.layout.words_per_line
    fb_lines = -(-int(FB_OFFER * saturated_words / 0.4) // (width // ppc)) + 1
    fb = DdrFrameBuffer(width=width, rows=fb_lines, channels=1, elements=ppc, pixel_bits=16,
                        pixels_per_word=16, early=True, paced=True, base=fb_base)
    fb_stim = frames_to_beats(rng.integers(0, 1 << 16, (1, fb_lines, width)), ppc=ppc)
    tr = record_shared([cds, nuc, fb], [cds_stim, nuc_stim, fb_stim],
                       sides=[{"frame_kind": kinds_c}, {"frame_kind": kinds_n}, {}],
                       pacing=[None, None, Pace(offer=FB_OFFER, ready=FB_OFFER * FB_READ_SHARE)],
                       seed=seed, burst=wpl, name=CAMERA_TRACE)
    cmds = tr.ports[0]
    nuc_lo, fb_lo = nuc_base // ADDR_PER_WORD, fb_base // ADDR_PER_WORD
    load_end = max(i for i, (rd, a) in enumerate(cmds) if not rd and nuc_lo <= a < fb_lo) + 1
    end = max(i for i, (rd, a) in enumerate(cmds) if a < fb_lo) + 1
    tr.ports[0] = cmds = cmds[load_end:end]
    if len(cmds) < need:
        raise TdicamError(f"trace {CAMERA_TRACE}: {len(cmds)} commands after the "
                          f"coefficient load, fewer than the window's {need}")
    fw = sum(1 for rd, a in cmds if not rd and a >= fb_lo)
    fr = sum(1 for rd, a in cmds if rd and a >= fb_lo)
    tr.note += (f"; frame buffer writes {fw / (len(cmds) - fw - fr):.3f} of the others' words "
                f"(plan {FB_WRITE_SHARE:.3f}), reads {fr / max(fw, 1):.3f} of its writes "
                f"(plan {FB_READ_SHARE:.3f})")
    return tr
