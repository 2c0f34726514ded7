"""The wheel works outside the checkout (issue 31): built, installed into a new virtualenv
and run from an empty folder, with the scenes and golden vectors it carries.

Short form (CI, ~25 s of CPU): the wheel built without build isolation from a copy of the tracked
sources, a virtualenv without pip that sees the project's dependencies through a ``.pth``
file naming this environment's site-packages (a ``.pth`` in a folder added that way is not
read, so the checkout's editable tdicam stays invisible: the test checks ``tdicam.__file__``
is inside the new virtualenv), the wheel installed with ``--no-deps``, then light forms of
the commands. Full form (``TDICAM_FULL=1``): an isolated build, a fresh virtualenv with every
dependency from the package index, and the commands as the issue lists them.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

import pytest

from tdicam.paths import REPO

FULL = os.environ.get("TDICAM_FULL") == "1"
#: What the wheel is built from: the files pyproject.toml packages.
SOURCES = ("pyproject.toml", "README.md", "tdicam", "hdl", "model", "scenes", "golden")

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(REPO is None, reason="builds the wheel from a checkout"),
              pytest.mark.skipif(shutil.which("iverilog") is None, reason="needs iverilog")]


def _run(cmd, cwd, env, timeout=600):
    res = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True,
                         timeout=timeout)
    assert res.returncode == 0, f"{cmd} -> {res.returncode}\n{res.stdout[-3000:]}\n" \
                                f"{res.stderr[-3000:]}"
    return res.stdout


def _build(tmp: Path) -> Path:
    src = tmp / "src"
    src.mkdir()
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".lock")
    for name in SOURCES:
        p = REPO / name
        (shutil.copytree(p, src / name, ignore=ignore) if p.is_dir()
         else shutil.copy2(p, src / name))
    dist = tmp / "dist"
    cmd = [sys.executable, "-m", "build", "--wheel", "-o", str(dist), str(src)]
    if not FULL:
        cmd.insert(4, "--no-isolation")
    _run(cmd, tmp, os.environ.copy())
    wheels = list(dist.glob("tdicam-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def _venv(tmp: Path, wheel: Path) -> tuple[Path, dict]:
    venv = tmp / "venv"
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "VIRTUAL_ENV", "TDICAM_BUILD")}
    env["XDG_CACHE_HOME"] = str(tmp / "cache")      # the wheel's build folder
    if FULL:
        _run([sys.executable, "-m", "venv", str(venv)], tmp, env)
        _run([str(venv / "bin" / "python"), "-m", "pip", "install", "-q", str(wheel)], tmp,
             env, timeout=3000)
    else:
        _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp, env)
        py = venv / "bin" / "python"
        site = Path(_run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()"
                                         "['purelib'])"], tmp, env).strip())
        (site / "_tdicam_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
        _run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps",
              "--no-index", str(wheel)], tmp, env)
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    return venv, env


def test_wheel_outside_the_checkout(tmp_path):
    t0 = time.perf_counter()
    wheel = _build(tmp_path)
    venv, env = _venv(tmp_path, wheel)
    work = tmp_path / "empty"
    work.mkdir()
    py, tdicam = str(venv / "bin" / "python"), str(venv / "bin" / "tdicam")

    # the installed package, not the checkout's; its API and version
    info = json.loads(_run([py, "-c", "import json, importlib.metadata as m, tdicam; "
                                      "print(json.dumps([tdicam.__file__, tdicam.__all__, "
                                      "tdicam.__version__, m.version('tdicam')]))"],
                           work, env))
    assert Path(info[0]).resolve().is_relative_to(venv.resolve()), info[0]
    assert {"Scene", "simulate", "plan", "sweep", "blocks"} <= set(info[1])
    assert info[2] == info[3]
    assert _run([tdicam, "--version"], work, env).strip() == f"tdicam {info[3]}"

    # the bundled scenes, by name
    listing = _run([tdicam, "scenes"], work, env)
    assert "orbit_600km_1m_96 " in listing and str(venv.resolve()) in listing
    lines = [] if FULL else ["--lines", "16", "--no-impact"]
    _run([tdicam, "run", "--example", "orbit_600km_1m_96", "-o", "out"] + lines, work, env,
         timeout=3000)
    report = json.loads((work / "out" / "report.json").read_text())
    assert "tdi.png" in report["files"] and (work / "out" / "tdi.npy").is_file()

    # Verilog, the golden vectors' co-simulation, an export
    small = [] if FULL else ["--width", "64", "--stages", "4"]
    _run([tdicam, "verilog", "tdi", "-o", "tdi.v"] + small, work, env)
    assert (work / "tdi.v").read_text().startswith(f"// Generated by tdicam {info[3]}: block tdi")
    sim = [] if FULL else ["--fast", "--case", "random_64x4_p1"]
    out = _run([tdicam, "sim", "tdi", "--sim", "icarus"] + sim, work, env, timeout=3000)
    assert " 0 mismatches" in out
    _run([tdicam, "export", "cds", "-o", "x"], work, env)
    assert any((work / "x").iterdir())
    assert not list(work.glob("build")), "the wheel wrote a build folder into the cwd"

    # the manifest's hashes are checked on load: a damaged vector is one error line
    site = Path(info[0]).parent
    case = site / "golden" / "tdi" / "random_64x4_p1.npz"
    data = bytearray(case.read_bytes())
    data[-40] ^= 0xFF
    case.write_bytes(bytes(data))
    res = subprocess.run([tdicam, "sim", "tdi", "--sim", "icarus", "--fast", "--case",
                          "random_64x4_p1"], cwd=work, env=env, capture_output=True, text=True)
    assert res.returncode == 2, res
    err = res.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("tdicam: error: golden/tdi/random_64x4_p1.npz:"), err
    # the getting-started page's next commands, as written, from the empty folder (short
    # form: the ones that take seconds; the full form every one)
    for cmd in _next_commands():
        if FULL or cmd.split()[1] in QUICK_COMMANDS:
            res = subprocess.run(cmd, shell=True, cwd=work, env=env, capture_output=True,
                                 text=True, timeout=3000)
            assert res.returncode == 0, f"{cmd} -> {res.returncode}\n{res.stderr[-2000:]}"
    assert "[orbit]" in (work / "my.toml").read_text()
    print(f"wheel test ({'full' if FULL else 'short'} form): {time.perf_counter() - t0:.1f} s")


#: The getting-started commands the short form runs (each takes seconds).
QUICK_COMMANDS = ("scenes", "plan", "verilog")


def _next_commands():
    """The shell lines of docs/getting-started.md's "Next commands" block, comments cut."""
    text = (REPO / "docs" / "getting-started.md").read_text()
    block = text.split("## Next commands", 1)[1].split("```sh", 1)[1].split("```", 1)[0]
    cmds = [ln.split("#", 1)[0].strip() for ln in block.splitlines()]
    cmds = [c for c in cmds if c]
    assert cmds and all(c.startswith("tdicam ") for c in cmds), cmds
    return cmds
