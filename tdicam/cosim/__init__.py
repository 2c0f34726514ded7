"""Co-simulation of generated Verilog with cocotb on Icarus Verilog or Verilator.

:func:`run_stream` builds (once per block, parameter set and simulator; cached on disk
under ``build/cosim``) a testbench around a stream block's Verilog top and runs the
cocotb test module ``stream_tb`` (:mod:`tdicam.simtb.stream_tb`) in one of two drive modes:

``beat``
    cocotb drives and samples the AXI4-Stream ports every cycle, with random idle cycles
    and backpressure. Slow; for protocol tests.
``fast``
    the stimulus sits in an HDL memory, the clock and the random idle/backpressure are in
    HDL, every output transfer is written to a file by the simulator; cocotb awaits once.

Both return the output transfers as :class:`~tdicam.beats.Beats` for comparison
against the golden model with :func:`compare`.

Layer: the simulation tools (drivers of Icarus, Verilator and the Amaranth simulator, the
idle/backpressure generator, the golden-vector store, the LiteDRAM replay). May import
:mod:`tdicam.hw` (Verilog generation, the simulators' setup), the blocks' registry and
everything below; imported by the camera, the services and the commands.
"""

import contextlib
import fcntl
import hashlib
import json
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from amaranth.hdl import Shape

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.paths import BUILD
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hw.tools import SIMULATORS, tool_env
from tdicam.hw.verilog import convert
from tdicam.beats import Beats
from tdicam.cosim.pauses import thresholds
from tdicam.cosim import codec, dp16kd, tbgen

__all__ = ["SIMULATORS", "MODES", "AMARANTH", "WAVE_DIR", "WAVE_WINDOW", "wave_window", "keep_wave", "SimResult",
           "Comparison", "CaseRun", "run_stream", "compare", "locate", "run_beats", "waveform",
           "run_case", "run_scene", "run_golden_case", "build_dir_for", "check_build_root", "tool_env",
           "stream_ports", "build_sources", "run_cocotb"]

MODES = ("beat", "fast")
BUILD_ROOT = Path(os.environ.get("TDICAM_BUILD", BUILD / "cosim"))
#: Where the co-simulation tests and ``tdicam sim`` write the waveform of a mismatch.
WAVE_DIR = BUILD_ROOT / "waves"
# cocotb's runner builds with --public-flat-rw (every signal of every module public and
# writable, which keeps Verilator from optimizing the design); --no-public-flat-rw takes it
# back and :func:`_public_vlt` makes only the top module's signals public (what cocotb reads
# and writes).
_VERILATOR_ARGS = ("--timing", "-Wno-fatal", "-Wno-lint", "-Wno-style",
                   "-CFLAGS", "-std=c++20 -fcoroutines -O2", "--x-assign", "fast",
                   "--x-initial", "unique", "--no-public-flat-rw")


def _public_vlt(top):
    """Verilator control file: every signal of module ``top`` public and writable."""
    return f'`verilator_config\npublic_flat_rw -module "{top}" -var "*"\n'


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


def check_build_root():
    """The build folder (``TDICAM_BUILD`` when set) is one we can write in, else one line
    naming the variable."""
    from tdicam.files import check_dir
    if "TDICAM_BUILD" not in os.environ:
        return
    try:
        check_dir(BUILD_ROOT, "TDICAM_BUILD")
    except TdicamError as exc:
        raise TdicamError(f"TDICAM_BUILD={os.environ['TDICAM_BUILD']}: {exc}") from None


@contextlib.contextmanager
def _locked(path):
    check_build_root()
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
    if sim == "verilator":
        sources = {**sources, "public.vlt": _public_vlt(top)}
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
            with _build_progress(sim, name):
                runner.build(sources=[bdir / f for f in sources], hdl_toplevel=top,
                             build_dir=bdir / "sim", build_args=args,
                             timescale=("1ns", "1ps"), log_file=log, always=True)
        except (RuntimeError, SystemExit) as exc:
            tail = log.read_text().strip().splitlines()[-1:] if log.exists() else []
            raise TdicamError(f"{sim} build of {name} failed ({exc}); see {log}: "
                              f"{' '.join(tail)}") from None
        (bdir / "stamp").write_text(stamp)
    return bdir, time.perf_counter() - t0


#: Seconds a simulator build runs before :func:`_build_progress` says so on stderr.
BUILD_NOTICE_S = 2.0


@contextlib.contextmanager
def _build_progress(sim, name):
    """Long work shows progress: a build still running after :data:`BUILD_NOTICE_S`
    prints ``building Verilator model of NAME ...`` on stderr, and its elapsed time when
    it ends; a quick (or cached) build prints nothing."""
    import sys
    import threading
    label = {"verilator": "Verilator", "icarus": "Icarus"}.get(sim, sim)
    t0 = time.perf_counter()
    shown = threading.Event()

    def notice():
        shown.set()
        print(f"building {label} model of {name} ...", file=sys.stderr, flush=True)
    timer = threading.Timer(BUILD_NOTICE_S, notice)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        if shown.is_set():
            print(f"building {label} model of {name}: done in "
                  f"{time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)


def _build(blk, params, sim, wave=False, ecp5=False):
    """Build (or reuse) the testbench (``wave``: with the waveform window, its own build;
    ``ecp5``: the block's ECP5 top, :attr:`~tdicam.blocks.Block.ecp5_top`, with the DP16KD
    model :data:`tdicam.cosim.dp16kd.MODEL`, its own build); returns (build dir, seconds
    spent building, top)."""
    top = blk.build(params, ecp5=ecp5)
    if not isinstance(top, AxisTop):
        raise TdicamError(f"block {blk.name} is not a video stream block")
    in_bits, out_bits, ctrl = stream_ports(top)
    sources = {f"{blk.name}.v": convert(top, blk.name)}
    if ecp5:
        sources[dp16kd.FILE] = dp16kd.MODEL
    sources["tb.v"] = tbgen.stream_testbench(blk.name, in_bits=in_bits, out_bits=out_bits,
                                             ctrl_ports=ctrl, wave=wave)
    bdir, build_time = build_sources(blk.name + ".ecp5" * ecp5 + ".wave" * wave, params, sim,
                                     sources)
    return bdir, build_time, top


# the simulator's Python: no pytest assertion rewriting (cocotb would otherwise parse and
# rewrite every module imported after it, numpy and amaranth included: ~1 s per run; the
# testbench modules report their own failures)
_SIM_ENV = {"COCOTB_REWRITE_ASSERTION_FILES": ""}


def run_cocotb(bdir, sim, test_module, rundir, plusargs, *, top=tbgen.TB_TOP, waves=False):
    """Run cocotb module ``test_module`` (a module of :mod:`tdicam.simtb`, or a dotted
    path) on the build in ``bdir`` with ``rundir`` as working folder; returns (passed, wall
    seconds). ``waves``: let the testbench's ``$dumpfile`` write FST (Icarus; the runner
    passes ``-none`` otherwise)."""
    runner = _runner(sim)
    if "." not in test_module:
        test_module = f"tdicam.simtb.{test_module}"
    results = rundir / "results.xml"
    saved = os.environ.pop("PYTEST_CURRENT_TEST", None)
    saved_waves = os.environ.get("WAVES")
    if waves:
        os.environ["WAVES"] = "1"
    t0 = time.perf_counter()
    try:
        runner.test(test_module=test_module, hdl_toplevel=top, hdl_toplevel_lang="verilog",
                    build_dir=bdir / "sim", test_dir=rundir, plusargs=plusargs,
                    results_xml=str(results), log_file=rundir / "sim.log",
                    timescale=("1ns", "1ps"), extra_env=_SIM_ENV)
        ok = True
    except (SystemExit, RuntimeError):
        ok = False
    finally:
        if saved is not None:
            os.environ["PYTEST_CURRENT_TEST"] = saved
        if waves:
            if saved_waves is None:
                os.environ.pop("WAVES", None)
            else:
                os.environ["WAVES"] = saved_waves
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

    out: Beats
    cycles: int
    wall: float
    build_time: float
    timeout: bool
    accepted: int
    trace: list | None = None
    wave: str | None = None


def run_stream(block, params, stim, *, n_out, sim, mode="fast", idle=0.0, backpressure=0.0,
               seed=1, max_cycles=None, drain=None, keep=False, trace=False, wave=None,
               ecp5=False):
    """Co-simulate ``stim`` (:class:`~tdicam.beats.Beats`) through a stream block.

    Parameters
    ----------
    n_out : int
        Output transfers the golden model expects (sizes the ``max_cycles`` default).
        The run stops once every input was accepted and no output moved for ``drain``
        cycles (so lost and duplicated outputs both show), or at ``max_cycles``.
    idle, backpressure : float in [0, 1)
        Probability of an idle input cycle / of ``m_axis_tready`` low on a cycle, drawn by
        :class:`tdicam.cosim.pauses.Pauses` from ``seed``: the same pattern in both modes.
    trace : bool
        Record ``SimResult.trace``: ``("i" | "o", cycle)`` of every input and output
        transfer, cycle 0 the first after the initial reset.
    wave : (first, last) cycle or None
        Fast mode on Icarus only: dump every testbench signal of those cycles (counted like
        ``trace``) to ``SimResult.wave`` (an FST file in the kept run folder) and stop the
        run after them (a separate build with the waveform window; see
        :func:`tdicam.cosim.tbgen.stream_testbench`).
    ecp5 : bool
        Simulate the block's ECP5 synthesis top (:attr:`tdicam.blocks.Block.ecp5_top`:
        vendor primitives) with the DP16KD model of :mod:`tdicam.cosim.dp16kd`.
    """
    if mode not in MODES:
        raise TdicamError(f"unknown mode {mode!r}; valid: {', '.join(MODES)}")
    if wave is not None and (sim, mode) != ("icarus", "fast"):
        raise TdicamError("a waveform window is written by Icarus in fast mode")
    idle_thr, bp_thr = thresholds(idle, backpressure)
    blk = blocks.get(block)
    params = blk.resolve(params)
    bdir, build_time, top = _build(blk, params, sim, wave=wave is not None, ecp5=ecp5)
    _, _, ctrl = stream_ports(top)
    ctrl_bits = max(1, sum(w for _, w in ctrl))
    bits, count, padded, _ = top._in
    n_in = len(stim)
    if max_cycles is None:
        slow = 1.0 / ((1 - idle) * (1 - backpressure))
        max_cycles = int((n_in + n_out) * 4 * slow) + 100_000
    if wave is not None:
        max_cycles = min(max_cycles, int(wave[1]) + 2)
    if drain is None:
        drain = 2000
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    for name, data in tbgen.stimulus_files(stim, elem_padded_bits=padded, ctrl_bits=ctrl_bits):
        (rundir / name).write_bytes(data)
    seed = int(seed) & 0x7fffffff
    job = {"mode": mode, "n_in": n_in, "n_out": int(n_out), "idle": idle,
           "backpressure": backpressure, "seed": seed, "max_cycles": max_cycles,
           "trace": bool(trace),
           "drain": drain, "rst_cycles": tbgen.RST_CYCLES, "in_padded": padded,
           "in_count": count, "ctrl_bits": ctrl_bits, "out_padded": top._out[2],
           "out_count": top._out[1]}
    (rundir / "job.json").write_text(json.dumps(job))
    plusargs = [f"+n_in={n_in}", f"+n_out={int(n_out)}", f"+max_cycles={max_cycles}",
                f"+drain={drain}", f"+idle={idle_thr}",
                f"+bp={bp_thr}", f"+seed={seed}"] + ["+trace"] * bool(trace)
    if wave is not None:
        plusargs += [f"+wave_from={int(wave[0])}", f"+wave_to={int(wave[1])}"]
    ok, wall = run_cocotb(bdir, sim, "stream_tb", rundir, plusargs, waves=wave is not None)
    summary = rundir / "summary.json"
    if not ok or not summary.exists():
        raise TdicamError(f"{sim} simulation of {block} failed; see {rundir / 'sim.log'}")
    info = json.loads(summary.read_text())
    out = codec.decode_output((rundir / "out.hex").read_bytes(),
                              elem_padded_bits=top._out[2], count=top._out[1])
    events = None
    if trace:
        events = [(k, int(c)) for k, c in (ln.split() for ln in
                                           (rundir / "trace.txt").read_text().splitlines())]
    if not keep and wave is None:
        shutil.rmtree(rundir, ignore_errors=True)
    return SimResult(out, info["cycles"], wall, build_time, bool(info["timeout"]),
                     info["accepted"], events,
                     None if wave is None else str(rundir / "wave.fst"))


@dataclass
class Comparison:
    """Result of comparing simulated output with the golden beats.

    ``first`` (None when they match) locates the first mismatch: ``segment``, ``beat`` (in
    the segment), ``index`` (output transfer of the whole run), ``element`` (in the beat),
    ``expected`` and ``received`` (None for a missing or extra beat) and, when the expected
    beats are image frames (``tuser`` marks), ``frame`` (in the segment), ``line`` and
    ``column``.
    """

    checked: int
    mismatches: int
    message: str
    first: dict | None = None

    @property
    def ok(self):
        return self.mismatches == 0


def locate(exp, beat, element=0):
    """Frame, line and column of element ``element`` of expected beat ``beat`` of one
    segment's beats ``exp``, from the frame markers (``first`` starts a frame, ``last`` ends
    a line), or {} when ``exp`` carries no frame (a block whose output is not an image)."""
    if not len(exp) or not exp.first.any() or beat >= len(exp):
        return {}
    frame = int(np.cumsum(exp.first[:beat + 1])[-1]) - 1
    start = int(np.flatnonzero(exp.first[:beat + 1])[-1]) if frame >= 0 else 0
    line_ends = np.flatnonzero(exp.last[start:beat])
    line_start = start + (int(line_ends[-1]) + 1 if len(line_ends) else 0)
    return {"frame": max(frame, 0), "line": len(line_ends),
            "column": (beat - line_start) * exp.data.shape[1] + element}


def _where(first):
    """``frame F line L column C (segment S beat B)`` or ``segment S beat B``."""
    at = f"segment {first['segment']} beat {first['beat']}"
    if "frame" in first:
        return f"frame {first['frame']} line {first['line']} column {first['column']} ({at})"
    return at


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
    first_msg, first = "", None
    for s in segs:
        g, e = got.select(got.seg == s), exp.select(exp.seg == s)
        n = min(len(g), len(e))
        bad = (g.data[:n] != e.data[:n]).any(axis=1) | (g.first[:n] != e.first[:n]) \
            | (g.last[:n] != e.last[:n])
        extra = len(g) - len(e)
        count_bad = extra if s == last and extra != 0 else max(extra, 0)
        checked += n
        mismatches += int(bad.sum()) + abs(count_bad)
        if first is None and (bad.any() or count_bad):
            k = int(np.argmax(bad)) if bad.any() else n
            el = int(np.argmax(g.data[k] != e.data[k])) if bad.any() else 0
            first = {"segment": int(s), "beat": k, "index": int((got.seg < s).sum()) + k,
                     "element": el,
                     "expected": int(e.data[k, el]) if k < len(e) else None,
                     "received": int(g.data[k, el]) if k < len(g) else None,
                     **locate(e, k, el)}
            if bad.any():
                first_msg = (f"first at {_where(first)}: expected {first['expected']}, "
                             f"received {first['received']} (beat: got data "
                             f"{g.data[k].tolist()} tuser {int(g.first[k])} tlast "
                             f"{int(g.last[k])}, expected {e.data[k].tolist()} tuser "
                             f"{int(e.first[k])} tlast {int(e.last[k])})")
            else:
                first_msg = f"segment {s}: {len(g)} beats out, expected {len(e)}"
    return Comparison(checked, mismatches, first_msg or "match", first)


#: Drivers :func:`run_beats` accepts besides :data:`SIMULATORS`: the Amaranth simulator.
AMARANTH = "amaranth"


@dataclass
class CaseRun:
    """One co-simulation checked against the golden model (:func:`run_beats`).

    Attributes
    ----------
    block, sim, mode : str
        What ran: ``sim`` one of :data:`SIMULATORS` or ``"amaranth"`` (mode ``"beat"``).
    result : SimResult
        The simulator's output and timing.
    comparison : Comparison
        Beat-by-beat comparison with the expected beats.
    n_in, n_out : int
        Stimulus beats and expected output beats.
    elements : int
        Output elements (pixels, bytes) per beat.
    waveform : dict or None
        On a mismatch, when :func:`run_beats` was given a ``wave_dir``: ``path`` of the FST
        file, ``cycles`` (first, last) it holds and ``cycle`` of the first mismatching
        output transfer (see :func:`waveform`); ``path`` None and ``error`` when it could
        not be written (no Icarus).
    """

    block: str
    sim: str
    mode: str
    result: SimResult
    comparison: Comparison
    n_in: int
    n_out: int
    elements: int
    waveform: dict | None = None

    @property
    def mismatches(self):
        """Mismatching beats, every expected beat counted when the run timed out."""
        return self.comparison.mismatches + (self.n_out if self.result.timeout else 0)

    @property
    def ok(self):
        return (self.comparison.ok and not self.result.timeout
                and self.result.accepted == self.n_in)

    @property
    def pixels(self):
        return self.comparison.checked * self.elements

    def message(self):
        """One line: what went wrong (or ``match``), naming block, simulator and mode."""
        r, where = self.result, f"{self.block} {self.sim} {self.mode}"
        if r.timeout:
            return f"{where}: timed out after {r.cycles} cycles"
        if not self.comparison.ok:
            return (f"{where}: {self.comparison.mismatches} mismatches; "
                    f"{self.detail()}")
        if r.accepted != self.n_in:
            return f"{where}: accepted {r.accepted} of {self.n_in} input beats"
        return "match"

    def detail(self):
        """The comparison's message and, if written, where the waveform is."""
        w = self.waveform
        if w is None:
            return self.comparison.message
        if w["path"] is None:
            return f"{self.comparison.message}; no waveform: {w['error']}"
        return (f"{self.comparison.message}; waveform {w['path']} (cycles {w['cycles'][0]}.."
                f"{w['cycles'][1]}, mismatch at cycle {w['cycle']}, Icarus)")

    def row(self):
        """The dict ``tdicam sim`` prints and returns per case."""
        r = self.result
        return {"beats": self.comparison.checked, "pixels": self.pixels,
                "mismatches": self.comparison.mismatches, "cycles": r.cycles,
                "wall_s": r.wall, "build_s": r.build_time, "timeout": r.timeout,
                "message": self.detail(),
                "waveform": (self.waveform or {}).get("path")}


def run_beats(block, params, stim, exp, *, sim, mode="fast", idle=0.0, backpressure=0.0,
              seed=1, wave_dir=None, label=None, **kw):
    """Co-simulate ``stim`` through ``block`` and compare the output with ``exp``.

    The one co-simulation path of tests, ``tdicam sim``, ``tdicam run`` and ``tdicam
    bench``: ``sim`` is a Verilog simulator (:func:`run_stream`, ``mode`` beat or fast) or
    ``"amaranth"`` (:func:`tdicam.cosim.pysim.run_pysim`, the Verilog top in Amaranth's
    simulator). ``kw`` goes to the driver (``max_cycles``, ``drain``, ``keep``).
    ``wave_dir``: on a mismatch of a Verilog simulator, write the waveform of the cycles
    around the first one there (:func:`waveform`; ``label`` names the file, e.g. the case);
    a run that matches costs nothing more.
    Returns a :class:`CaseRun`.
    """
    blk = blocks.get(block) if isinstance(block, str) else block
    params = blk.resolve(params)
    if sim == AMARANTH:
        from tdicam.cosim.pysim import run_pysim
        out, cycles, wall = run_pysim(blk.name, params, stim, idle=idle,
                                      backpressure=backpressure, seed=seed, **kw)
        res = SimResult(out, cycles, wall, 0.0, False, len(stim))
        mode = "beat"
    else:
        res = run_stream(blk.name, params, stim, n_out=len(exp), sim=sim, mode=mode,
                         idle=idle, backpressure=backpressure, seed=seed, **kw)
    elements = exp.data.shape[1] if len(exp) else 1
    run = CaseRun(blk.name, sim, mode, res, compare(res.out, exp), len(stim), len(exp),
                  elements)
    if wave_dir is not None and run.comparison.first is not None and sim != AMARANTH:
        try:
            run.waveform = waveform(blk, params, stim, exp, run.comparison.first, wave_dir,
                                    idle=idle, backpressure=backpressure, seed=seed,
                                    label=label or f"{sim}-{mode}-seed{seed}",
                                    ecp5=kw.get("ecp5", False))
        except TdicamError as exc:     # the mismatch is the news; say why there is no wave
            run.waveform = {"path": None, "error": str(exc)}
    return run


#: Cycles of waveform kept before and after the first mismatch.
WAVE_WINDOW = 64


def wave_window(cycle):
    """The cycles ``(first, last)`` of the waveform around a mismatch at ``cycle``."""
    return max(0, cycle - WAVE_WINDOW), cycle + WAVE_WINDOW


def keep_wave(src, dst, what):
    """Move the waveform ``src`` a run wrote to ``dst`` and remove the run's folder; a
    one-line error naming ``what`` and the folder when the simulator wrote none."""
    from pathlib import Path
    src, dst = Path(src), Path(dst)
    if not src.exists():
        raise TdicamError(f"Icarus wrote no waveform for {what}; see {src.parent}")
    from tdicam.files import check_dir
    check_dir(dst.parent, "wave_dir")
    shutil.move(str(src), dst)
    shutil.rmtree(src.parent, ignore_errors=True)
    return str(dst)


def waveform(block, params, stim, exp, first, wave_dir, *, idle, backpressure, seed, label,
             ecp5=False):
    """Write the waveform around a mismatch: ``<wave_dir>/<block>-<label>.fst``.

    The stimulus runs again on Icarus in fast mode with the same idle/backpressure pattern
    (:class:`tdicam.cosim.pauses.Pauses` draws the same one in both modes and simulators, so the
    DUT sees the same cycles): once with the transfer trace, for the cycle of output
    transfer ``first["index"]`` (the last transfer's cycle when it is missing), then with
    the waveform window ``cycle +- WAVE_WINDOW``. Returns ``{"path", "cycles": (first,
    last), "cycle"}``.
    """
    from pathlib import Path
    blk = blocks.get(block) if isinstance(block, str) else block
    kw = dict(n_out=len(exp), sim="icarus", mode="fast", idle=idle,
              backpressure=backpressure, seed=seed, ecp5=ecp5)
    traced = run_stream(blk.name, params, stim, trace=True, **kw)
    outs = [c for k, c in traced.trace if k == "o"]
    cycle = outs[min(first["index"], len(outs) - 1)] if outs else traced.cycles
    lo, hi = wave_window(cycle)
    res = run_stream(blk.name, params, stim, wave=(lo, hi), **kw)
    path = keep_wave(res.wave, Path(wave_dir) / f"{blk.name}-{label}.fst", blk.name)
    return {"path": path, "cycles": (lo, hi), "cycle": int(cycle)}


def run_case(block, params, arrays, *, corrupt=None, **kw):
    """:func:`run_beats` on case arrays (a golden case's, or :meth:`Block.case_arrays` of
    scene arrays): the block's ``to_beats`` makes stimulus and expected beats.
    ``corrupt(arrays)`` may alter a copy of the arrays first (to show a check can fail)."""
    blk = blocks.get(block) if isinstance(block, str) else block
    if blk.to_beats is None:
        raise TdicamError(f"block {blk.name} has no stream co-simulation; run its cocotb "
                          f"tests (pytest cocotb_tests/test_{blk.name}.py)")
    params = blk.resolve(params)
    if corrupt is not None:
        arrays = {k: np.array(v, copy=True) for k, v in arrays.items()}
        corrupt(arrays)
    stim, exp = blk.to_beats(arrays, params)
    return run_beats(blk, params, stim, exp, **kw)


def run_scene(block, arrays, params=None, **kw):
    """:func:`run_case` on scene arrays (frames and side inputs, see
    :mod:`tdicam.blocks`): parameters fitted to the arrays, golden outputs from the
    block's golden function. Returns (:class:`CaseRun`, the output as scene arrays)."""
    blk = blocks.get(block) if isinstance(block, str) else block
    p = blk.scene_params(arrays, params)
    run = run_case(blk, p, blk.case_arrays(arrays, p), **kw)
    out = blk.from_beats(run.result.out, arrays, p) if run.ok else None
    return run, out


def run_golden_case(block, case, **kw):
    """:func:`run_case` on the stored golden ``case`` (name) of ``block`` (a waveform, if
    any, is named after the case)."""
    from tdicam.cosim import vectors as golden
    blk = blocks.get(block) if isinstance(block, str) else block
    arrays, params = golden.load(blk, case)
    kw.setdefault("label", f"{case}-{kw.get('sim')}-{kw.get('mode', 'fast')}")
    return run_case(blk, params, arrays, **kw)
