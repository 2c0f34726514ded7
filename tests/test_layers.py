"""The layers of the code base are a contract: ``lint-imports`` (import-linter) checks the
``[tool.importlinter]`` contracts of pyproject.toml — commands > services > chain / engine /
scene > simulation and hardware tools > blocks > hdl > model > leaves, and no import cycle
between the modules of any package.

``hdl/`` and ``model/`` are installed as ``tdicam.hdl`` and ``tdicam.model``; import-linter reads
a package from one folder, so the test lays the three folders out as installed in a
temporary folder and checks that copy (what a wheel holds).

A project module is imported under its own name (``from tdicam.model import lvds``, or
``lvds as _lvds`` to keep it private), never renamed (``lvds as link``).
"""

import ast
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
    # the registry may not reach the tools that generate and co-simulate its blocks (the
    # public API's tdicam.verilog / tdicam.cosimulate do): no ignore_imports hides it
    ("blocks/__init__.py", "def _later():\n    from tdicam.hw.verilog import generate",
     "tdicam.blocks is not allowed to import tdicam.hw"),
    ("blocks/lvds.py", "def _later():\n    from tdicam.cosim.cases import run_cases",
     "tdicam.blocks is not allowed to import tdicam.cosim"),
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


# ------------------------------------------------------------------------------------------
# one name per module: a project module is imported under its own name
# ------------------------------------------------------------------------------------------

#: The folders whose Python files the alias check reads.
ALIAS_TREES = ("tdicam", "hdl", "model", "tests", "cocotb_tests", "bench")


def _module_file(root, dotted):
    """The file of project module ``dotted`` (``tdicam.hdl.x`` in ``hdl/``, ``tdicam.model.x``
    in ``model/``), or None when it is no project module (a function, a third-party module)."""
    parts = dotted.split(".")
    if parts[0] != "tdicam":
        return None
    if parts[1:2] in (["hdl"], ["model"]):
        parts = parts[1:]
    base = root.joinpath(*parts)
    for p in (base.with_suffix(".py"), base / "__init__.py"):
        if p.exists():
            return p
    return None


def _renaming_aliases(root):
    """``(file, line, module, alias)`` of every project module imported under another name
    (``_name``, the module's own name kept private, is its own name)."""
    out = []
    for top in ALIAS_TREES:
        for path in sorted((root / top).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.ImportFrom) and node.module and not node.level:
                    pairs = [(f"{node.module}.{a.name}", a.asname) for a in node.names]
                elif isinstance(node, ast.Import):
                    pairs = [(a.name, a.asname) for a in node.names]
                else:
                    continue
                for dotted, alias in pairs:
                    own = dotted.rsplit(".", 1)[-1]
                    if alias in (None, own, "_" + own) or _module_file(root, dotted) is None:
                        continue
                    out.append((path.relative_to(root).as_posix(), node.lineno, dotted, alias))
    return out


def test_no_module_is_imported_under_another_name():
    """``from tdicam.model import lvds`` (or ``lvds as _lvds``), never ``lvds as link``: a
    module is read under one name everywhere."""
    found = _renaming_aliases(REPO)
    assert not found, "project modules imported under another name: " + ", ".join(
        f"{f}:{line} {mod} as {alias}" for f, line, mod, alias in found)


def test_the_alias_check_finds_a_renaming_alias(tmp_path):
    """The check sees a renamed module (it is live) and lets a renamed function pass."""
    for top in ALIAS_TREES:
        (tmp_path / top).mkdir()
    (tmp_path / "model" / "lvds.py").write_text("def rotations():\n    pass\n")
    (tmp_path / "tdicam" / "probe.py").write_text(
        "from tdicam.model import lvds as link\nfrom tdicam.model import lvds as _lvds\n"
        "from tdicam.model.lvds import rotations as rot\nimport numpy as np\n")
    assert _renaming_aliases(tmp_path) == [("tdicam/probe.py", 1, "tdicam.model.lvds", "link")]
