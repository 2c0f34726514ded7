"""Long work shows where it is (issue 48 item 4): ``tdicam run`` draws a moving bar on a
terminal and writes stage lines elsewhere; the Python API is quiet unless asked."""

import fcntl
import os
import re
import struct
import subprocess
import sys
import termios
import time

import pytest

from tdicam import cli
from tdicam.progress import Progress

BAR_PERCENT = re.compile(rb"(\d+)%\|")


def _run_on_a_terminal(argv, cwd, timeout=600):
    """Everything ``argv`` writes to a pseudo-terminal of 120 x 40 characters."""
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    p = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave, cwd=cwd, env=env,
                         close_fds=True)
    os.close(slave)
    out, t0 = b"", time.monotonic()
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:                 # the child closed the terminal
            break
        if not chunk:
            break
        out += chunk
        assert time.monotonic() - t0 < timeout, out[-2000:]
    os.close(master)
    assert p.wait(timeout=60) == 0, out[-3000:].decode(errors="replace")
    return out


def test_run_on_a_terminal_draws_a_bar_that_moves(tmp_path):
    out = _run_on_a_terminal(
        [sys.executable, "-m", "tdicam", "run", "--example", "orbit_600km_1m_96", "-o",
         str(tmp_path / "o"), "--fidelity", "exact", "--lines", "128", "--no-impact"],
        tmp_path)
    shown = [int(m) for m in BAR_PERCENT.findall(out)]
    assert len(set(shown)) >= 3 and 0 in shown and 100 in shown, shown   # 0, between, 100
    assert b"simulating m=96" in out and b"writing" in out


def test_run_off_a_terminal_writes_stage_lines(tmp_path, capsys):
    assert cli.main(["run", "--example", "orbit_600km_1m_96", "-o", str(tmp_path / "o"),
                     "--lines", "16", "--no-impact"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("orbit_600km_1m_96: [1/2] simulating m=96 dV/V=0 (")
    assert any(ln.startswith("orbit_600km_1m_96: writing: [2/2] the report (") for ln in err)
    assert "\r" not in "".join(err)


def test_the_api_is_quiet_unless_asked(capsys):
    import tdicam
    sim = tdicam.simulate(tdicam.Scene.example("orbit_600km_1m_96"), lines=16, impact=False)
    assert sim.dataset["tdi"].shape[0] == 16
    assert capsys.readouterr().err == ""


def test_stage_lines_count_and_estimate(capsys, monkeypatch):
    clock = iter([0.0, 1.0, 3.0, 10.0])
    monkeypatch.setattr(time, "perf_counter", lambda: next(clock))
    p = Progress("job", 100, stages=2, bar=False)        # t0 = 0
    p.stage("first")                                      # at 1 s, nothing done
    p.update(25)
    p.stage("second")                                     # at 3 s: 25 of 100 in 3 s
    err = capsys.readouterr().err.splitlines()
    assert err == ["job: [1/2] first (1 s)", "job: [2/2] second (3 s, about 9 s left)"]
    assert p.eta() == pytest.approx(75 / (25 / 10))      # at 10 s


def test_disabled_progress_says_nothing(capsys):
    with Progress("job", 10, enabled=False) as p:
        p.stage("x")
        p.update(10)
    assert capsys.readouterr().err == ""


def test_demo_names_each_step_with_k_of_n(monkeypatch, tmp_path, capsys):
    """``tdicam demo``: a stage line per step ([k/n]) on stderr, the table row of each
    co-simulation as it finishes (the simulators stood in for: the steps are what is
    tested here; cocotb_tests run the real ones)."""
    from tdicam import demo
    calls = []

    def fake_cases(block, *, sim, mode, report, **kw):
        calls.append((sim, mode))
        row = {"case": "c", "pixels": 10, "mismatches": 0, "timeout": 0, "wall_s": 1.0,
               "build_s": 0.0, "cycles": 20}
        report(row)
        return [row]
    monkeypatch.setattr(demo, "run_cases", fake_cases)
    monkeypatch.setattr(demo, "lint", lambda path: [])
    assert cli.main(["demo", "cds", "-o", str(tmp_path)]) == 0
    cap = capsys.readouterr()
    err = cap.err.splitlines()
    assert [ln.split(" (")[0] for ln in err] == [
        "demo cds: [1/6] Verilog and lint", "demo cds: [2/6] golden vectors",
        "demo cds: [3/6] icarus beat", "demo cds: [4/6] icarus fast",
        "demo cds: [5/6] verilator beat", "demo cds: [6/6] verilator fast"]
    assert "s left)" in err[-1]
    assert calls == list(demo.RUNS) and cap.out.rstrip().endswith("result: PASS")
