"""The layers of the code base are a contract: ``lint-imports`` (import-linter) checks the
``[tool.importlinter]`` contracts of pyproject.toml — commands > services > chain / engine /
scene > simulation and hardware tools > blocks > hdl > model > leaves, and no import cycle
between the modules of any package.

``hdl/`` and ``model/`` are installed as ``tdicam.hdl`` and ``tdicam.model``; import-linter reads
a package from one folder, so the test lays the three folders out as installed in a
temporary folder and checks that copy (what a wheel holds).
"""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tdicam.paths import REPO

LINT = Path(sys.executable).with_name("lint-imports")


def _installed_layout(dst):
    """``dst/tdicam`` laid out as installed: ``tdicam/``, with ``hdl/`` and ``model/`` inside."""
    ignore = shutil.ignore_patterns("__pycache__")
    shutil.copytree(REPO / "tdicam", dst / "tdicam", ignore=ignore)
    shutil.copytree(REPO / "hdl", dst / "tdicam" / "hdl", ignore=ignore)
    shutil.copytree(REPO / "model", dst / "tdicam" / "model", ignore=ignore)
    return dst


def _lint(root):
    if not LINT.exists():
        pytest.fail(f"{LINT} is missing: ./setup installs import-linter with the test extras")
    return subprocess.run([str(LINT), "--config", str(REPO / "pyproject.toml"), "--no-cache"],
                          cwd=root, env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"},
                          capture_output=True, text=True, timeout=300)


def test_layers_kept(tmp_path):
    res = _lint(_installed_layout(tmp_path))
    assert res.returncode == 0, res.stdout[-4000:] + res.stderr[-2000:]
    assert "0 broken" in res.stdout


@pytest.mark.parametrize("module, line, broken", [
    # the golden models may not reach up into the scene engine
    ("model/tdi.py", "import tdicam.engine", "tdicam.model is not allowed to import tdicam.engine"),
    # a block's registry entry may not use the camera built from it
    ("blocks/cds.py", "from tdicam.chain import design",
     "tdicam.blocks is not allowed to import tdicam.chain"),
    # a function-level import counts too
    ("hdl/cds.py", "def _later():\n    from tdicam.cosim import golden",
     "tdicam.hdl is not allowed to import tdicam.cosim"),
    # a cycle inside a package
    ("engine/streams.py", "from tdicam.engine import effects", "No cycles are allowed in tdicam.engine"),
])
def test_contract_is_live(tmp_path, module, line, broken):
    """An upward import (or a cycle) added to a copy of the tree breaks the contract."""
    root = _installed_layout(tmp_path)
    path = root / "tdicam" / module
    path.write_text(path.read_text() + "\n\n" + line + "\n")
    res = _lint(root)
    assert res.returncode != 0
    assert broken in res.stdout, res.stdout[-4000:]
