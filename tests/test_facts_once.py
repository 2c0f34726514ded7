"""Each fact stated once: the legal pixels-per-clock set has one definition
(:data:`tdicam.beats.PPC_CHOICES`) that every block, the chain and the scene reader import,
and ``--memory`` means one thing in every command that takes it."""

import ast
from pathlib import Path

import pytest

from tdicam import cli
from tdicam.beats import PPC_CHOICES
from tdicam.chain import design
from tdicam.commands import _pipeline

ROOT = Path(__file__).resolve().parents[1]
CHAIN = ROOT / "scenes" / "ning2019_chain.toml"


def _literal_sets(tree):
    """(line, values) of every tuple, list or set literal of integer constants."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)) and node.elts and all(
                isinstance(e, ast.Constant) and type(e.value) is int for e in node.elts):
            yield node.lineno, tuple(e.value for e in node.elts)


def _ppc_literals(root):
    """Places under ``root`` that write the legal ppc set (or all of it but 1) as a literal."""
    whole, rest = tuple(PPC_CHOICES), tuple(PPC_CHOICES[1:])
    for path in sorted(root.rglob("*.py")):
        for line, values in _literal_sets(ast.parse(path.read_text(), str(path))):
            if values in (whole, rest):
                yield f"{path.relative_to(ROOT)}:{line}"


def test_the_legal_ppc_set_is_defined_once():
    found = [p for d in ("tdicam", "hdl", "model") for p in _ppc_literals(ROOT / d)]
    assert found == ["tdicam/beats.py:24"], found


def test_the_ppc_literal_check_is_live(tmp_path):
    """The scan above finds a literal of the set written anywhere (it can fail)."""
    (tmp_path / "m.py").write_text("A = 1\nB = (1, 2, 4, 8)\nC = [2, 4, 8]\nD = (1, 2)\n")
    global ROOT
    old, ROOT = ROOT, tmp_path
    try:
        assert list(_ppc_literals(tmp_path)) == ["m.py:2", "m.py:3"]
    finally:
        ROOT = old


class _Planned(Exception):
    """Raised by the stand-in chain_plan: the commands stop right after choosing."""


@pytest.mark.parametrize("memory, spill", [(None, None), ("auto", "auto"), ("chip", False),
                                           ("ddr", True)])
def test_memory_means_one_thing_in_every_pipeline_command(memory, spill, monkeypatch,
                                                          tmp_path):
    """``--memory auto`` is "by --device's block RAM" in ``verilog``, ``synth`` and ``export
    pipeline`` alike, and no ``--memory`` leaves the placement to the scene. (``export``
    used to read ``auto`` as the scene's own placement while its help promised the
    device's RAM.)"""
    seen = []

    def plan(scene, **kw):
        seen.append(kw["spill"])
        raise _Planned

    monkeypatch.setattr(_pipeline, "chain_plan", plan)
    monkeypatch.setattr(design, "chain_plan", plan)
    opt = [] if memory is None else ["--memory", memory]
    for cmd in (["verilog", "pipeline"], ["synth", "pipeline"],
                ["export", "pipeline", "-o", str(tmp_path / "x")]):
        with pytest.raises(_Planned):
            cli.main([*cmd, "--scene", str(CHAIN), *opt])
    assert seen == [spill] * 3


def test_memory_auto_is_by_the_device():
    """The chain with its TDI placed in DDR by the scene, asked ``auto``: on chip, where the
    partial sums fit the device's block RAM."""
    from tdicam.scene.loader import load_scene
    sc = load_scene(CHAIN, overrides={"sensor": {"columns": 160}, "run": {"lines": 6},
                                      "pipeline": {"tdi": {"memory": "ddr"}},
                                      "ddr": {"base": 4096}})
    by_scene = design.chain_plan(sc, spill=design.MEMORY.get(None))
    by_device = design.chain_plan(sc, spill=design.MEMORY["auto"])
    assert [s.block for s in by_scene.steps][3] == "tdi_ddr"
    assert [s.block for s in by_device.steps][3] == "tdi"
