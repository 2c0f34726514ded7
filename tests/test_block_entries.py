"""The block entries' shared shape: what a scene-simulator step may read of a run is typed
(:class:`tdicam.blocks.steps.RunView`), and every entry file of ``tdicam/blocks/`` keeps its
parts in the same sectioned order (``docs/guide/blocks.md``, "Adding a block")."""

import ast
import dataclasses
import re
from pathlib import Path

from tdicam.blocks import ENTRY_SECTIONS
from tdicam.blocks.steps import RunView
from tdicam.engine.context import RunContext

BLOCKS = Path(__file__).resolve().parents[1] / "tdicam" / "blocks"


def _members(proto):
    names = set(getattr(proto, "__annotations__", {}))
    names |= {n for n, v in vars(proto).items()
              if not n.startswith("_") and (callable(v) or isinstance(v, property))}
    return names


def _run_reads(path):
    """(function, attribute) of every ``c.<attribute>`` read in a function of ``path`` whose
    first argument is the run ``c``."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.FunctionDef) and node.args.args and node.args.args[0].arg == "c":
            for sub in ast.walk(node):
                if (isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Name)
                        and sub.value.id == "c"):
                    yield node.name, sub.attr


def test_block_steps_read_only_the_run_view():
    members = _members(RunView)
    reads = {(p.name, f, a) for p in sorted(BLOCKS.glob("*.py")) for f, a in _run_reads(p)}
    assert {a for _, _, a in reads} >= {"scene", "prepared", "flash", "digital"}   # the scan is live
    stray = sorted(r for r in reads if r[2] not in members)
    assert not stray, f"block steps read run attributes RunView does not state: {stray}"


def test_the_engine_run_context_is_a_run_view():
    fields = {f.name for f in dataclasses.fields(RunContext)}
    missing = sorted(n for n in _members(RunView)
                     if n not in fields and not hasattr(RunContext, n))
    assert not missing, f"RunContext lacks RunView members {missing}"
    assert {"scene", "sensor", "zero_dn"} <= _members(RunView)


#: What each section holds, by the names the entries give their parts (a part by another
#: name may sit in any section: the rule is for the parts every entry has).
SECTION_OF = [
    ("entry", r"BLOCK"),
    ("simulator", r"_sim_\w+|SIM"),
    ("chain", r"_pipeline_\w+|_measured|_system|_front_\w+"),
    ("scene", r"\w*Options|_read_options|OPTIONS|\w+_MEMORY"),
    ("cases", r"_cases|_ppc_cases|_full_only|FULL_ONLY\w*|BUILDS|VERILATOR_\w+|ICARUS_\w+"
              r"|PER_BEAT|_golden|_to_beats|_to_case|_unstream|_example|_case|case_\w+"),
    ("top", r"_top|_ecp5_top|_synth_top|_core|_check"),
]
MARKER = re.compile(r"# ---- (\w+)$")


def _sections(path):
    """(section markers in file order, {top-level name: the section it sits in})."""
    marks, where, current = [], {}, None
    lines = path.read_text().splitlines()
    for node in ast.parse("\n".join(lines)).body:
        start = min([node.lineno] + [d.lineno for d in getattr(node, "decorator_list", [])])
        for ln in range(start - 1, -1, -1):       # the nearest marker above the node
            m = MARKER.match(lines[ln])
            if m:
                if not marks or marks[-1][0] != ln:
                    marks.append((ln, m.group(1)))
                current = m.group(1)
                break
        targets = ([node.name] if isinstance(node, (ast.FunctionDef, ast.ClassDef)) else
                   [t.id for t in getattr(node, "targets", []) if isinstance(t, ast.Name)])
        for name in targets:
            where[name] = current
    return [s for _, s in marks], where


def _entries():
    return sorted(p for p in BLOCKS.glob("[a-z]*.py")
                  if "BLOCK = Block(" in p.read_text())


def test_every_entry_keeps_the_sections_in_order():
    order = list(ENTRY_SECTIONS)
    assert len(_entries()) >= 15
    for path in _entries():
        marks, where = _sections(path)
        assert marks[0] == "top" and marks[-1] == "entry", (path.name, marks)
        assert all(m in order for m in marks), (path.name, marks)
        assert [order.index(m) for m in marks] == sorted({order.index(m) for m in marks}), \
            f"{path.name}: sections {marks} not in the order {order}"
        for name, sec in where.items():
            want = next((s for s, rx in SECTION_OF if re.fullmatch(rx, name)), None)
            assert want is None or sec == want, \
                f"{path.name}: {name} sits in section {sec!r}, belongs in {want!r}"


def test_the_section_check_is_live(tmp_path):
    bad = tmp_path / "x.py"
    bad.write_text("# ---- top\ndef _top():\n    pass\n# ---- entry\nBLOCK = 1\n"
                   "def _sim_step(c, fr):\n    pass\n")
    marks, where = _sections(bad)
    assert marks == ["top", "entry"] and where["_sim_step"] == "entry"
