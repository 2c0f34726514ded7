"""Simulator builds and cocotb runs: the build cache under ``build/cosim`` (or
``TDICAM_BUILD``), one locked build per source set, progress for long builds, and running a
cocotb test module on a build.

Layer: part of :mod:`tdicam.cosim`; imports :mod:`tdicam.hw.tools` and the leaves.
"""

import contextlib
import fcntl
import hashlib
import json
import os
import time
from pathlib import Path

from tdicam.errors import TdicamError
from tdicam.hw.tools import tool_env
from tdicam.paths import BUILD
from tdicam.cosim import tbgen

__all__ = ["BUILD_ROOT", "WAVE_DIR", "BUILD_NOTICE_S", "build_dir_for", "check_build_root",
           "build_sources", "run_cocotb"]

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


def _public_vlt(top, public=None):
    """Verilator control file: every signal of module ``top`` public and writable, or only
    those of ``public``, (name, written) pairs: written ones writable, the others
    read-only."""
    if public is None:
        return f'`verilator_config\npublic_flat_rw -module "{top}" -var "*"\n'
    return "`verilator_config\n" + "".join(
        f'public_flat_{"rw" if rw else "rd"} -module "{top}" -var "{name}"\n'
        for name, rw in public)


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


def build_sources(name, params, sim, sources, *, top=tbgen.TB_TOP, public=None):
    """Build (or reuse) a simulator build of Verilog ``sources`` ({file name: text}).

    ``public``: (name, written) pairs, the only signals of ``top`` a Verilator build makes
    public (e.g. :data:`tdicam.cosim.tbgen.FAST_PUBLIC` for a fast-mode-only testbench);
    None: every signal of ``top``, writable.

    Cached under :func:`build_dir_for` ``(name, params, sim)``, keyed by the source texts,
    the simulator and its arguments, and locked so concurrent runs share one build.
    Returns (build dir, seconds spent building).
    """
    bdir = build_dir_for(name, params, sim)
    # -g2005: Verilog-2005 initializer semantics, which yosys' trick for evaluating
    # always @* blocks at time 0 relies on (with -g2012 they stay X until an input moves).
    args = list(_VERILATOR_ARGS) if sim == "verilator" else ["-g2005"]
    if sim == "verilator":
        sources = {**sources, "public.vlt": _public_vlt(top, public)}
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
