"""Replay DDR command orders into LiteDRAM, an independent DDR3 controller model.

The project's memory model (:class:`tdicam.model.dram.MigSim`) is our own; this harness
checks its efficiency figures against LiteDRAM (Kermarrec et al., ``litedram`` 2024.12 on
PyPI, with ``litex`` and ``migen``; install the ``ddrref`` extra: ``pip install
'tdicam[ddrref]'``): ``LiteDRAMController`` + ``LiteDRAMCrossbar`` + ``SDRAMPHYModel``
with its DDR3 timing-violation checker on, a DDR3-800 MT41K256M16 x2 (32-bit bus) at a
100 MHz controller clock (1:4), so one 256-bit native-port word is one BL8 burst, and the
row-bank-column address mapping (8 banks, rows of 128 words). The module's timings are the
data sheet's; its rows are trimmed to :data:`SIM_ROWS` and the PHY model's memory holds the
rows of each bank that the trace uses, at most :data:`MEM_ROWS` (migen's simulator turns every
memory word into a signal), so a trace may address ``MEM_ROWS * 8 * 128`` words.

A trace is the order in which a user issues its commands: a list of ``(is_read,
word_address)`` per port (word addresses = ``app_addr / 8``). :func:`replay` issues them
back to back (data always available, read data always taken), writes a word derived from
the address and the write's index, checks that every read returns the last word written
to its address before it (0 when none), and reports the efficiency: words moved / cycles
from the first command to the last data beat, or (``steady=True``, every figure the project
quotes) words moved in a steady-state window of :data:`tdicam.model.dram.WINDOW_REFRESHES`
refresh intervals (:func:`tdicam.model.dram.window_efficiency`: 4 x 782 cycles after a
100-cycle start-up), the replay stopped when the window closes. With two ports, a read waits until every
write to its address that precedes it in :attr:`Trace.order` has moved its data (the
dependency the user's logic enforces).

Traces of the access patterns come from :func:`tdicam.model.ddr_traces.pattern_trace`; a DDR
block's own order from :func:`record` / :func:`block_traces` (the block in Amaranth's
simulator with its controller model, :class:`tdicam.hdl.simmodels.mig_model.MigModel`).
:func:`replay_hdl` runs a trace on that HDL model and on the Python model side by side and
checks that they agree cycle for cycle.

LiteDRAM's Python simulation is slow (about 10-15 controller cycles per CPU second plus ~10 s
to build, measured here): keep traces short.
"""

import contextlib
import io
import time
from dataclasses import dataclass, field

from tdicam.errors import TdicamError
from tdicam.model.dram import STARTUP, window_cycles, window_efficiency, window_words
from tdicam.model.ddr_traces import PATTERNS, Trace, pattern_trace

__all__ = ["Trace", "ReplayResult", "replay", "record", "pattern_trace", "PATTERNS",
           "SIM_ROWS", "MEM_ROWS", "ROW_WORDS", "BANKS", "available", "block_traces",
           "BLOCKS", "replay_hdl", "trace_runs", "trace_from_runs", "fixture"]

#: rows per bank in the simulated module (MT41K256M16 has 32768; 2048 keeps 11 address bits)
SIM_ROWS = 2048
#: rows per bank the simulated memory stores at most
MEM_ROWS = 32
from tdicam.model.dram import BANKS, ROW_WORDS  # noqa: E402  (the module's geometry)
CLOCK_HZ = 100e6


def available():
    """None when LiteDRAM can be imported, else the reason (a one-line string)."""
    try:
        import litedram  # noqa: F401
        import migen  # noqa: F401
    except ImportError as e:
        return f"LiteDRAM not installed ({e.name}): pip install 'tdicam[ddrref]'"
    return None


@dataclass
class ReplayResult:
    """One replay: ``words`` moved in ``cycles`` (first command offered to last data beat),
    ``efficiency = words / cycles``, read ``mismatches`` against the expected data, the
    timing checker's ``violations`` (lines of its log) and the ``wall`` time in seconds;
    ``steady``: ``words``/``cycles`` are those of the steady-state window."""

    name: str
    words: int
    cycles: int
    efficiency: float
    mismatches: int
    violations: list = field(default_factory=list)
    wall: float = 0.0
    steady: bool = False

    @property
    def ok(self):
        return not self.mismatches and not self.violations


def _data(addr, k):
    """The 256-bit word of write ``k`` (to word address ``addr``)."""
    x = (addr * 0x9E3779B97F4A7C15 + k * 0xD1B54A32D192ED03 + 1) & ((1 << 64) - 1)
    out = 0
    for _ in range(4):
        x ^= (x << 13) & ((1 << 64) - 1)
        x ^= x >> 7
        x ^= (x << 17) & ((1 << 64) - 1)
        out = (out << 64) | x
    return out


def _module():
    from litedram.modules import MT41K256M16

    class _Trimmed(MT41K256M16):
        nrows = SIM_ROWS
    return _Trimmed(CLOCK_HZ, "1:4", speedgrade="800")


def _build(nports, read_time, write_time, mem_rows):
    from litedram.core.controller import ControllerSettings, LiteDRAMController
    from litedram.core.crossbar import LiteDRAMCrossbar
    from litedram.phy.model import SDRAM_VERBOSE_STD, SDRAMPHYModel, get_sdram_phy_settings
    from migen import Module

    import litedram.phy.model as phy_model
    module = _module()
    bank_model = phy_model.BankModel

    def small_bank(data_width, nrows, *args, **kwargs):
        return bank_model(data_width, min(nrows, mem_rows), *args, **kwargs)
    phy_settings = get_sdram_phy_settings(memtype="DDR3", data_width=32, clk_freq=CLOCK_HZ)
    top = Module()
    phy_model.BankModel = small_bank
    try:
        top.submodules.phy = phy = SDRAMPHYModel(module, phy_settings, clk_freq=CLOCK_HZ,
                                                 address_mapping="ROW_BANK_COL",
                                                 verbosity=SDRAM_VERBOSE_STD)
    finally:
        phy_model.BankModel = bank_model
    cs = ControllerSettings(address_mapping="ROW_BANK_COL", read_time=read_time,
                            write_time=write_time)
    top.submodules.ctrl = ctrl = LiteDRAMController(phy_settings, module.geom_settings,
                                                    module.timing_settings, CLOCK_HZ,
                                                    controller_settings=cs)
    top.comb += ctrl.dfi.connect(phy.dfi)
    top.submodules.xbar = xbar = LiteDRAMCrossbar(ctrl.interface)
    ports = [xbar.get_port() for _ in range(nports)]
    assert ports[0].data_width == 256, ports[0].data_width
    return top, ports


class _WindowClosed(Exception):
    """Ends a steady-state replay when its window closes."""


def replay(trace, *, read_time=32, write_time=16, max_cycles=None, steady=False):
    """Replay ``trace`` into LiteDRAM; returns a :class:`ReplayResult`.

    ``read_time``/``write_time``: the controller's read and write windows (cycles;
    LiteDRAM's defaults 32/16). ``steady``: measure over the steady-state window
    (:func:`tdicam.model.dram.window_efficiency`) and stop when it closes. Raises
    :class:`TdicamError` when LiteDRAM is missing, a run does not finish in
    ``max_cycles`` or (``steady``) the trace ends before the window closes."""
    why = available()
    if why:
        raise TdicamError(why)
    top_addr = _check_addresses(trace)
    top, ports = _build(len(trace.ports), read_time, write_time,
                        max(2, top_addr // (BANKS * ROW_WORDS) + 1))
    wdata, expect, need = _plan(trace)
    state = {"first": None, "last": 0, "t": 0, "mismatch": 0, "beats": [],
             "wdone": [0] * len(ports), "rdone": [0] * len(ports)}
    gens = _generators(trace, ports, state, wdata, expect, need, steady=steady,
                       max_cycles=max_cycles or 60 * trace.words + 4000)
    wall, viol = _simulate(top, gens)
    if steady:
        words, cycles, eff = window_efficiency(state["beats"], state["first"], state["t"],
                                               name=trace.name)
    else:
        words, cycles = trace.words, state["last"] - state["first"] + 1
        eff = words / cycles
    return ReplayResult(trace.name, words, cycles, eff, state["mismatch"], viol, wall,
                        steady)


def _check_addresses(trace):
    """The trace's highest word address; refuses one outside the simulated memory."""
    cap = MEM_ROWS * BANKS * ROW_WORDS
    top_addr = max((a for p in trace.ports for _, a in p), default=0)
    if min((a for p in trace.ports for _, a in p), default=0) < 0 or top_addr >= cap:
        raise TdicamError(f"trace {trace.name}: word addresses must lie in 0..{cap - 1} "
                          f"(the simulated memory); the trace reaches {top_addr}")
    return top_addr


def _plan(trace):
    """Write data, expected read data and cross-port dependencies from the trace's global
    order: ``wdata`` and ``expect`` {(port, index): word}, ``need`` {(port, index) of a
    read: (port, write rank) of the other port's write it must follow}."""
    order = trace.order or [(0, k) for k in range(len(trace.ports[0]))]
    shadow, wdata, expect, need = {}, {}, {}, {}
    last_write = {}         # address -> (port, write rank)
    wrank = [0] * len(trace.ports)
    for n, (p, k) in enumerate(order):
        rd, a = trace.ports[p][k]
        if rd:
            expect[(p, k)] = shadow.get(a, 0)
            dep = last_write.get(a)
            if dep is not None and dep[0] != p:
                need[(p, k)] = dep
        else:
            d = _data(a, n)
            shadow[a] = d
            wdata[(p, k)] = d
            last_write[a] = (p, wrank[p])
            wrank[p] += 1
    return wdata, expect, need


def _generators(trace, ports, state, wdata, expect, need, *, steady, max_cycles):
    """The Migen generators of a replay: the cycle counter (passive: it ends the run when
    the steady window closes or ``max_cycles`` pass), and per port its commands, its write
    data (if it writes) and its read data checks (if it reads); they update ``state``."""
    from migen.sim import passive

    span = STARTUP + window_cycles()
    nreads = [sum(1 for rd, _ in p if rd) for p in trace.ports]
    nwrites = [len(p) - r for p, r in zip(trace.ports, nreads)]

    def clock():
        while True:
            yield
            state["t"] += 1
            if steady and state["first"] is not None and state["t"] > state["first"] + span:
                raise _WindowClosed
            if state["t"] > max_cycles:
                raise TdicamError(f"trace {trace.name}: LiteDRAM replay did not finish in "
                                  f"{max_cycles} cycles")

    def cmd_gen(p):
        port, cmds = ports[p], trace.ports[p]
        for k, (rd, a) in enumerate(cmds):
            dep = need.get((p, k))
            while dep is not None and state["wdone"][dep[0]] <= dep[1]:
                yield
            yield port.cmd.valid.eq(1)
            yield port.cmd.we.eq(0 if rd else 1)
            yield port.cmd.addr.eq(a)
            if state["first"] is None:
                state["first"] = state["t"]
            yield
            while not (yield port.cmd.ready):
                yield
        yield port.cmd.valid.eq(0)

    def wdata_gen(p):
        port = ports[p]
        seq = [wdata[(p, k)] for k, (rd, _) in enumerate(trace.ports[p]) if not rd]
        yield port.wdata.we.eq((1 << 32) - 1)
        for d in seq:
            yield port.wdata.valid.eq(1)
            yield port.wdata.data.eq(d)
            yield
            while not (yield port.wdata.ready):
                yield
            state["wdone"][p] += 1
            state["last"] = max(state["last"], state["t"])
            state["beats"].append(state["t"])
        yield port.wdata.valid.eq(0)

    def rdata_gen(p):
        port = ports[p]
        exp = [expect[(p, k)] for k, (rd, _) in enumerate(trace.ports[p]) if rd]
        yield port.rdata.ready.eq(1)
        for e in exp:
            yield
            while not (yield port.rdata.valid):
                yield
            if (yield port.rdata.data) != e:
                state["mismatch"] += 1
            state["rdone"][p] += 1
            state["last"] = max(state["last"], state["t"])
            state["beats"].append(state["t"])

    gens = [passive(clock)()]
    for p in range(len(ports)):
        gens.append(cmd_gen(p))
        if nwrites[p]:
            gens.append(wdata_gen(p))
        if nreads[p]:
            gens.append(rdata_gen(p))
    return gens


def _simulate(top, gens):
    """Run the Migen simulation (its printout captured); the wall time and LiteDRAM's
    timing-violation and late-refresh lines."""
    from migen.sim import run_simulation

    log = io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(log):
        try:
            run_simulation(top, gens)
        except _WindowClosed:
            pass
    wall = time.perf_counter() - t0
    viol = [ln.strip() for ln in log.getvalue().splitlines()
            if "violation" in ln or "Late refresh" in ln]
    return wall, viol


def replay_hdl(trace, dram=None, windows=None, **stalls):
    """Replay ``trace`` through the HDL controller model
    (:class:`tdicam.hdl.simmodels.mig_model.MigModel`, Amaranth's simulator) and the Python one
    (:class:`tdicam.model.dram.MigSim`) side by side, each driven by a
    :class:`~tdicam.model.ddr_traces.TraceDriver` as :func:`tdicam.model.ddr_traces.replay_model` does.
    Raises :class:`TdicamError` at the first cycle where their ``app_rdy``,
    ``app_wdf_rdy`` or ``app_rd_data_valid`` differ; returns the efficiency of the run."""
    from amaranth.sim import Simulator

    from tdicam.hdl.simmodels.mig_model import MigModel
    from tdicam.model.dram import DEFAULT_STALLS, DRAM_STALLS, MigSim
    from tdicam.model.ddr_traces import TraceDriver, merged_commands, trace_dram
    cmds = merged_commands(trace, dram, windows)
    dram = trace_dram(trace, dram)
    st = {**(DEFAULT_STALLS if dram is None else DRAM_STALLS), **stalls}
    top = max((a for _, a in cmds), default=0) + 1
    dut = MigModel(depth_words=top, dram=dram, **st)
    ref = MigSim(dram=dram, **st)
    drv = TraceDriver(cmds)
    names = ("app_rdy", "app_wdf_rdy", "app_rd_data_valid")

    async def bench(ctx):
        while not drv.done:
            ins = drv.drive()
            for k, v in ins.items():
                ctx.set(getattr(dut, k), v)
            ctx.set(dut.app_wdf_end, 1)
            got = tuple(int(ctx.get(getattr(dut, k))) for k in names)
            o = ref.outputs()
            want = tuple(int(o[k]) for k in names)
            if got != want or ctx.get(dut.error):
                raise TdicamError(f"trace {trace.name}: HDL and Python controller models "
                                  f"differ at cycle {drv.t}: {dict(zip(names, got))} vs "
                                  f"{dict(zip(names, want))}")
            ref.step(**ins)
            drv.update(*got)
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return drv.result[2]


# ---------------------------------------------------------------------------------------
# a DDR block's own command order
# ---------------------------------------------------------------------------------------

def record(core, stim, *, side=None, stalls=None, name=None, max_cycles=None):
    """The command order ``core`` (a DDR user with MIG ports) issues for ``stim``.

    ``core`` runs in Amaranth's simulator behind :class:`tdicam.hdl.simmodels.mig_model.MigModel`
    (DRAM timing on; stall pattern ``stalls``, default
    :data:`tdicam.model.dram.DEFAULT_STALLS`), its input always valid (data always
    available) and its output always ready; ``side`` maps the names of level inputs
    presented with each beat (``frame_kind``, ``stages_active``, ...) to per-beat arrays.
    Every command the model accepts is recorded in order. Returns a one-port
    :class:`Trace` (word addresses); its ``note`` says in how many cycles the input was
    taken (first beat to last)."""
    import numpy as np
    from amaranth.lib.data import ArrayLayout
    from amaranth.sim import Simulator

    from tdicam.hdl.simmodels.mig_model import SimTop
    from tdicam.model.ddr import ADDR_PER_WORD
    from tdicam.model.dram import DEFAULT_STALLS

    top = SimTop(core, depth_words=1 << 20, **(stalls or DEFAULT_STALLS))
    mdl = top.model
    data = np.asarray(stim.data, np.uint64)
    side = {k: np.asarray(v) for k, v in (side or {}).items()}
    n = len(stim)
    cmds = []
    max_cycles = max_cycles or 40 * n + 20000
    state = {"out": 0, "error": False, "t": 0, "t0": 0, "t1": 0}
    array = isinstance(top.i_stream.payload.data.shape(), ArrayLayout)

    async def bench(ctx):
        ctx.set(top.o_stream.ready, 1)
        k = quiet = 0
        for _ in range(max_cycles):
            if k < n:
                if array:
                    for e in range(data.shape[1]):
                        ctx.set(top.i_stream.payload.data[e], int(data[k, e]))
                else:
                    ctx.set(top.i_stream.payload.data, int(data[k, 0]))
                ctx.set(top.i_stream.payload.first, bool(stim.first[k]))
                ctx.set(top.i_stream.payload.last, bool(stim.last[k]))
                for s, v in side.items():
                    ctx.set(getattr(top, s), int(v[k]))
            ctx.set(top.i_stream.valid, k < n)
            quiet = quiet + 1 if k >= n else 0
            if ctx.get(mdl.app_en) and ctx.get(mdl.app_rdy):
                cmds.append((int(ctx.get(mdl.app_cmd)), int(ctx.get(mdl.app_addr))
                             // ADDR_PER_WORD))
                quiet = 0
            if ctx.get(top.o_stream.valid):
                state["out"] += 1
            if k < n and ctx.get(top.i_stream.ready):
                state["t0" if k == 0 else "t1"] = state["t"]
                k += 1
            state["t"] += 1
            if ctx.get(top.ddr_error):
                state["error"] = True
                return
            if quiet > 400:
                return
            await ctx.tick()

    sim = Simulator(top)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    if state["error"]:
        raise TdicamError(f"recording {name or type(core).__name__}: the controller model "
                          "flagged a bad access")
    return Trace(name or type(core).__name__, [cmds],
                 note=f"{n} input beats in {state['t1'] - state['t0'] + 1} cycles")


def _units(words_per_unit):
    """Units (lines, rows) of ``words_per_unit`` commands a trace needs to cover the
    start-up and the steady-state window (:func:`tdicam.model.dram.window_words`)."""
    return -(-window_words() // int(words_per_unit)) + 1


def _tdi_trace(name, *, width, stages, ppc, active, rng):
    """TdiDdr's order in steady state: frames of ``active`` rows (stages ``active`` of a
    ``stages``-stage design, forward), the commands of the last rows (the fill over), as
    many as cover the steady-state window."""
    import numpy as np

    from tdicam.cosim.codec import frames_to_beats
    from tdicam.hdl.tdi_ddr import TdiDdr
    from tdicam.model.ddr_efficiency import tdi_spill_efficiency
    tdi = TdiDdr(width=width, stages=stages, pixel_bits=12, ppc=ppc)
    rows = _units(2 * tdi.words_per_line)
    fr = rng.integers(0, 1 << 12, (-(-rows // active) + 2, active, width))
    n = fr.size // ppc
    tr = record(tdi, frames_to_beats(fr, ppc=ppc), name=name,
                side={"stages_active": np.full(n, active), "direction": np.zeros(n, int)})
    tr.ports[0] = tr.ports[0][-2 * rows * tdi.words_per_line:]
    tr.planned = tdi_spill_efficiency(width, stages, 12, ppc)[1]
    return tr


def block_traces(*, width=1280, seed=1, wide=4096):
    """Recorded command orders of the DDR blocks (``name -> Trace``, ``planned`` set to what
    the planner counts on: :func:`tdicam.model.ddr_efficiency.tdi_spill_efficiency` for the TDI spill,
    :data:`tdicam.model.physics.memory.DDR_EFFICIENCY` for the others), each long enough to
    cover the start-up and the steady-state window of
    :data:`tdicam.model.dram.WINDOW_REFRESHES` refresh intervals, on frames of ``width``
    10-bit pixels: ``ddr`` (frame buffer, 8 pixels per beat, one frame written and read
    back), ``cds_ddr`` (a reset frame then a signal frame; ``cds_ddr_wide``: the same,
    ``wide`` pixels), ``tdi_ddr`` (``width`` columns, 16 stages, 12-bit pixels;
    ``tdi_ddr_wide``: ``wide`` columns, 32 stages, 4 pixels per clock; both 3 stages
    active, the rows of the steady state), plus ``writer`` and ``reader``: the frame
    buffer's line writer and reader alone (its layout written, then read)."""
    import numpy as np

    from tdicam.cosim.codec import frames_to_beats
    from tdicam.hdl.cds_ddr import CdsDdr
    from tdicam.hdl.ddr import DdrFrameBuffer
    from tdicam.model.ddr import LineLayout
    from tdicam.model.physics.memory import DDR_EFFICIENCY

    rng = np.random.default_rng(seed)
    out = {}
    wpl = LineLayout(width=width, channels=1, pixel_bits=10).words_per_line
    lines = _units(2 * wpl)
    fb = DdrFrameBuffer(width=width, rows=lines, elements=8)
    lay = fb.layout
    assert lay.words_per_line == wpl, (lay, wpl)
    stride = lay.line_stride // 8
    addrs = [y * stride + w for y in range(_units(wpl)) for w in range(wpl)]
    out["writer"] = Trace("writer", [[(0, a) for a in addrs]])
    out["reader"] = Trace("reader", [[(1, a) for a in addrs]])
    fr = rng.integers(0, 1 << 10, (1, lines, width))
    out["ddr"] = record(fb, frames_to_beats(fr, ppc=8), name="ddr")
    for name, w in (("cds_ddr", width), ("cds_ddr_wide", wide)):
        rows = _units(2 * LineLayout(width=w, channels=1, pixel_bits=10).words_per_line)
        cds = CdsDdr(width=w, rows=rows, pixel_bits=10)
        fr = rng.integers(0, 1 << 10, (2, rows, w))
        out[name] = record(cds, frames_to_beats(fr), name=name,
                           side={"frame_kind": np.repeat([1, 0], rows * w)})
    for tr in out.values():
        tr.planned = DDR_EFFICIENCY
    out["tdi_ddr"] = _tdi_trace("tdi_ddr", width=width, stages=16, ppc=1, active=3, rng=rng)
    out["tdi_ddr_wide"] = _tdi_trace("tdi_ddr_wide", width=wide, stages=32, ppc=4, active=3,
                                     rng=rng)
    return out


#: the DDR blocks of :func:`block_traces`
BLOCKS = ("writer", "reader", "ddr", "cds_ddr", "cds_ddr_wide", "tdi_ddr", "tdi_ddr_wide")


# ---------------------------------------------------------------------------------------
# recorded LiteDRAM figures (so the default test run needs no LiteDRAM)
# ---------------------------------------------------------------------------------------

def trace_runs(trace):
    """A one-port trace as runs ``[is_read, first word address, count]`` of consecutive
    addresses in one direction (its compact form in a fixture)."""
    runs = []
    for rd, a in trace.ports[0]:
        if runs and runs[-1][0] == rd and runs[-1][1] + runs[-1][2] == a:
            runs[-1][2] += 1
        else:
            runs.append([int(rd), int(a), 1])
    return runs


def trace_from_runs(name, runs, planned=None):
    """Inverse of :func:`trace_runs`: the one-port :class:`Trace`."""
    return Trace(name, [[(rd, a0 + k) for rd, a0, n in runs for k in range(n)]],
                 planned=planned)


def fixture(block_results, traces, how, patterns=None):
    """The JSON-able record of LiteDRAM figures: ``{"how", "patterns": {name: {"lines",
    "efficiency", "window"}}, "blocks": {name: {"efficiency", "words", "window", "runs"}}}``
    (efficiencies in %, over the steady-state ``window`` of ``words`` words in that many
    cycles), from the steady :class:`ReplayResult`\\ s of the block ``traces``."""
    return {"how": how, "patterns": patterns or {},
            "blocks": {n: {"efficiency": round(100 * r.efficiency, 2), "words": r.words,
                           "window": r.cycles, "runs": trace_runs(traces[n])}
                       for n, r in block_results.items()}}
