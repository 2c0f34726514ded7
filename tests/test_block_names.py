"""Outside ``tdicam/blocks/`` no string constant equal to a block name chooses behaviour: a
block's name in a comparison, an ``in`` test or a dict key means that the code knows the block
by name, and the next parameter or block would have to be added there too. Such knowledge
belongs to the block's registry entry (:mod:`tdicam.blocks`).

The test reads the AST of ``tdicam/``, ``hdl/`` and ``model/``. Names that are also something
other than a block are allowed where they mean that other thing (each entry says what).
"""

import ast

from tdicam import blocks
from tdicam.paths import REPO

#: (file, constant) -> what the constant means there, when it is not the block.
OTHER_MEANINGS = {
    ("tdicam/scene/docs.py", "tdi"): "the [tdi] section of a scene (stages, domain, output)",
    ("tdicam/scene/docs.py", "ddr"): "the [ddr] section of a scene (the DDR beside the FPGA)",
    ("tdicam/scene/docs.py", "lvds"): "the [sensor.lvds] section of a scene (the sensor's "
                                      "lanes), in the page's probe scene",
    ("tdicam/scene/loader.py", "ddr"): "the [ddr] section of a scene",
    ("tdicam/chain/design.py", "tdi"): "the [tdi] section of a scene (--stages overrides "
                                       "its stages)",
    ("tdicam/chain/design.py", "ddr"): "[pipeline.tdi] memory = \"ddr\" and --memory ddr (where "
                                       "partial sums live)",
    ("tdicam/planning/sizing.py", "ddr"): "the plan report's DDR bandwidth section",
    ("model/ddr_efficiency.py", "ddr"): "the recorded DDR traces' names (each DDR block's "
                                        "command order), the keys of the measured-efficiency "
                                        "table",
    ("model/ddr_efficiency.py", "cds_ddr"): "a recorded DDR trace's name (the efficiency "
                                            "table's key)",
    ("model/ddr_efficiency.py", "tdi_ddr"): "a recorded DDR trace's name (the efficiency "
                                            "table's key)",
    ("tdicam/scene/sections.py", "nuc"): "the [camera].nuc key (where NUC's coefficients "
                                         "are applied: per gain or after the merge)",
    ("tdicam/scene/sections.py", "tdi"): "the [tdi] section of a scene (its keys' table)",
    ("tdicam/scene/sections.py", "ddr"): "the [ddr] section of a scene (its keys' table)",
    ("tdicam/chain/cosim.py", "tdi"): "the [tdi] section of a scene's overrides (the lanes' "
                                      "fault cut: its stages)",
    ("model/physics/camera.py", "nuc"): "the [camera].nuc key (its reference table)",
    ("tdicam/planning/camera.py", "nuc"): "the [camera].nuc key (an option the plan shows)",
    ("tdicam/planning/camera.py", "ddr"): "a block's placement in DDR (Memory.placement)",
    ("tdicam/api.py", "tdi"): "the simulation dataset's `tdi` image (what tdicam run writes "
                              "as tdi.npy)",
}


def _constants(node):
    """String constants compared, tested with ``in`` or used as dict keys in ``node``."""
    if isinstance(node, ast.Compare):
        for c in (node.left, *node.comparators):
            yield c
            if isinstance(c, (ast.Tuple, ast.List, ast.Set)):
                yield from c.elts
    elif isinstance(node, ast.Dict):
        yield from (k for k in node.keys if k is not None)


def _uses(names):
    out = []
    for top in ("tdicam", "hdl", "model"):
        for path in sorted((REPO / top).rglob("*.py")):
            rel = path.relative_to(REPO).as_posix()
            if rel.startswith("tdicam/blocks/"):
                continue
            for node in ast.walk(ast.parse(path.read_text(), rel)):
                for c in _constants(node):
                    if isinstance(c, ast.Constant) and c.value in names:
                        out.append((rel, c.value, c.lineno))
    return out


def test_no_block_names_outside_the_registry():
    uses = [u for u in _uses(set(blocks.names())) if u[:2] not in OTHER_MEANINGS]
    assert not uses, "block names that choose behaviour outside tdicam/blocks/: " + ", ".join(
        f"{f}:{line} {name!r}" for f, name, line in uses)


def test_the_check_finds_a_block_name(tmp_path, monkeypatch):
    """The scan sees a comparison with a block name (the check is live)."""
    probe = tmp_path / "tdicam" / "probe.py"
    probe.parent.mkdir()
    probe.write_text("def f(name):\n    return {'nuc': 1}.get(name) if name == 'median3' else 0\n")
    monkeypatch.setitem(globals(), "REPO", tmp_path)
    found = {(f, n) for f, n, _ in _uses({"nuc", "median3"})}
    assert found == {("tdicam/probe.py", "nuc"), ("tdicam/probe.py", "median3")}


def test_other_meanings_are_still_used():
    """Every allowed entry still occurs (a stale entry would hide a new use)."""
    used = {u[:2] for u in _uses(set(blocks.names()))}
    assert set(OTHER_MEANINGS) <= used, set(OTHER_MEANINGS) - used


def _engine_constants(root, names):
    return [(p.name, node.value) for p in sorted((root / "tdicam" / "engine").glob("*.py"))
            for node in ast.walk(ast.parse(p.read_text()))
            if isinstance(node, ast.Constant) and node.value in names]


def test_the_engine_names_no_block(tmp_path):
    """The scene simulator knows the blocks only through their entries' ``Use.sim`` steps: no
    string constant in ``tdicam/engine/`` equals a block name (in any use), and the scan
    finds one when there is."""
    names = set(blocks.names())
    assert _engine_constants(REPO, names) == []
    (tmp_path / "tdicam" / "engine").mkdir(parents=True)
    (tmp_path / "tdicam" / "engine" / "probe.py").write_text("def f(c):\n    return c.ran('nuc')\n")
    assert _engine_constants(tmp_path, names) == [("probe.py", "nuc")]


def test_every_block_follows_the_naming_rule():
    """``hdl/<m>.py``, ``model/<m>.py`` and ``cocotb_tests/test_<m>.py`` exist for every block,
    ``m`` its name or the :attr:`~tdicam.blocks.Block.module` it states, and its golden
    vectors are ``golden/<name>/``; a block stating a module is one whose name is not it."""
    missing = []
    for b in blocks.all_blocks():
        stem = b.module or b.name
        assert b.module != b.name, f"{b.name}: module = its own name; leave it None"
        for path in (f"hdl/{stem}.py", f"model/{stem}.py", f"cocotb_tests/test_{stem}.py",
                     f"golden/{b.name}"):
            if not (REPO / path).exists():
                missing.append(f"{b.name}: {path}")
    assert not missing, missing
