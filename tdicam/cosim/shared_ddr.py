"""The camera's DDR users on one arbiter: the command order the controller sees.

Ning et al. 2019 §4.2 puts every DDR consumer of the camera on the MIG user interface of its
DDR part. :func:`record_shared` runs DDR users (:class:`~tdicam.hdl.nuc_ddr.NucDdr`,
:class:`~tdicam.hdl.cds_ddr.CdsDdr`, ...) in Amaranth's simulator, each through its own
port of one :class:`~tdicam.hdl.ddr_arbiter.DdrArbiter` onto one
:class:`~tdicam.hdl.simmodels.mig_model.MigModel` (DRAM timing on), every input always valid
(data always available) and every output always ready, and records each command the model
accepts: a one-port :class:`~tdicam.model.ddr_traces.Trace` (word addresses), the arbiter's real
access order, which :func:`tdicam.model.ddr_traces.replay_model` and
:func:`tdicam.cosim.litedram.replay` replay back to back. :func:`camera_trace` is the
camera's: the NUC coefficient read beside the CDS reset frame's write and read.
"""

from amaranth.hdl import Elaboratable, Module

from tdicam.errors import TdicamError
from tdicam.model.ddr import ADDR_PER_WORD
from tdicam.model.ddr_traces import Trace
from tdicam.model.dram import DEFAULT_STALLS, DramTiming, window_words

__all__ = ["SharedDdr", "record_shared", "camera_trace", "CAMERA_TRACE"]

#: the name of :func:`camera_trace`'s order (the benchmark's row, the fixture's key)
CAMERA_TRACE = "nuc_cds_arbiter"


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


def record_shared(users, stims, *, sides=None, burst=64, stalls=None, name="shared",
                  max_cycles=200000):
    """The controller-side command order of ``users`` (DDR user components with
    ``i_stream``/``o_stream`` and MIG ports) behind one arbiter.

    ``stims[k]``: user ``k``'s input :class:`~tdicam.beats.Beats`, presented back to back;
    ``sides[k]``: its level inputs per beat (``{"frame_kind": array}``). Returns a one-port
    :class:`~tdicam.model.ddr_traces.Trace`, ``note`` giving the cycles and each user's commands
    taken; raises :class:`TdicamError` on a controller-model error or when the inputs are
    not all taken in ``max_cycles``."""
    import numpy as np
    from amaranth.lib.data import ArrayLayout
    from amaranth.sim import Simulator

    top = SharedDdr(users, burst=burst, **(stalls or DEFAULT_STALLS))
    mdl, arb = top.model, top.arb
    sides = sides or [{} for _ in users]
    cmds, per_port = [], [0] * len(users)
    state = {"t": 0, "error": False, "done": False}

    def feeder(u, stim, side):
        data = np.asarray(stim.data, np.uint64)
        array = isinstance(u.i_stream.payload.data.shape(), ArrayLayout)

        async def bench(ctx):
            ctx.set(u.o_stream.ready, 1)
            for k in range(len(stim)):
                if array:
                    for e in range(data.shape[1]):
                        ctx.set(u.i_stream.payload.data[e], int(data[k, e]))
                else:
                    ctx.set(u.i_stream.payload.data, int(data[k, 0]))
                ctx.set(u.i_stream.payload.first, bool(stim.first[k]))
                ctx.set(u.i_stream.payload.last, bool(stim.last[k]))
                for s, v in side.items():
                    ctx.set(getattr(u, s), int(v[k]))
                ctx.set(u.i_stream.valid, 1)
                await ctx.tick().until(u.i_stream.ready)
            ctx.set(u.i_stream.valid, 0)
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
            if tk:
                per_port[g] += 1
            if en and rdy:
                cmds.append((int(cmd), int(addr) // ADDR_PER_WORD))
                quiet = 0
            else:
                quiet += 1
            if quiet > 2000 or state["t"] > max_cycles:
                return

    sim = Simulator(top)
    sim.add_clock(1e-8)
    for u, stim, side in zip(users, stims, sides):
        sim.add_testbench(feeder(u, stim, side), background=True)
    sim.add_testbench(monitor)
    sim.run()
    if state["error"]:
        raise TdicamError(f"recording {name}: the controller model flagged a bad access")
    return Trace(name, [cmds], note=f"{state['t']} cycles; commands taken per port: "
                                    f"{per_port}")


def camera_trace(*, width=512, rows=16, ppc=8, seed=1):
    """The camera's shared DDR order (:data:`CAMERA_TRACE`): port 0 a
    :class:`~tdicam.hdl.nuc_ddr.NucDdr` (its coefficient frame loaded, then pixel frames: a
    coefficient line of ``width / 8`` words read per row), port 1 a
    :class:`~tdicam.hdl.cds_ddr.CdsDdr` (10-bit reset frame then signal frame, in turn: a
    reset line of ``width / 24`` words written, read back), both at ``ppc`` pixels a clock
    on frames of ``rows`` x ``width``, the CDS reset frame at address 0, the coefficients
    above it; the arbiter's burst a coefficient line. The commands from the end of the
    coefficient load on (the steady state), as many as cover the steady-state window
    (:func:`tdicam.model.dram.window_words`)."""
    import numpy as np

    from tdicam.beats import frames_to_beats
    from tdicam.hdl.cds_ddr import CdsDdr
    from tdicam.hdl.nuc_ddr import NucDdr
    from tdicam.model.nuc_ddr import coeff_layout

    rng = np.random.default_rng(seed)
    cds = CdsDdr(width=width, rows=rows, pixel_bits=10, ppc=ppc)
    nuc_base = -(-cds.layout.end_addr(rows) // 4096) * 4096
    nuc = NucDdr(width=width, rows=rows, pixel_bits=10, ppc=ppc, base=nuc_base)
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
    tr = record_shared([nuc, cds], [nuc_stim, cds_stim],
                       sides=[{"frame_kind": kinds_n}, {"frame_kind": kinds_c}], burst=wpl,
                       name=CAMERA_TRACE)
    cmds = tr.ports[0]
    nuc_lo = nuc_base // ADDR_PER_WORD
    load_end = max(i for i, (rd, a) in enumerate(cmds) if not rd and a >= nuc_lo) + 1
    tr.ports[0] = cmds[load_end:]
    if len(tr.ports[0]) < need:
        raise TdicamError(f"trace {CAMERA_TRACE}: {len(tr.ports[0])} commands after the "
                          f"coefficient load, fewer than the window's {need}")
    return tr
