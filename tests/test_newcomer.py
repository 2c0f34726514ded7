"""What a newcomer reads is plain text that stands on its own: every command's ``--help``
(each subcommand, each block's parameters) has no reST markup, and the README, the help texts
and the scene-format page cite the papers by author and year, never the internal shorthand
("seed 000", "SPEC 3.2", "issue 10") or the specification outside the repository."""

import argparse
import contextlib
import io
import re
from pathlib import Path

import pytest

from tdicam import blocks, cli

ROOT = Path(__file__).resolve().parents[1]
#: Internal shorthand a user's clone cannot resolve.
SHORTHAND = re.compile(r"(?i:seeds? ?0\d\d)|\bSPEC\b|issue [0-9]|\.\./shared|/work/shared")
#: reST markup that argparse would print verbatim.
REST = re.compile(r"``|:(func|class|mod|data|meth|attr|obj|ref):`")


def _capture(argv):
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        try:
            cli.main(argv)
        except SystemExit:
            pass
    return buf.getvalue()


def all_help_texts():
    """``{command line: help text}`` for tdicam, every subcommand (recursively), every
    block's parameter help and the pipeline's."""
    parser = cli.build_parser()
    out = {"tdicam --help": parser.format_help()}

    def walk(p, name):
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub_name, sub in action.choices.items():
                    out[f"{name} {sub_name} --help"] = sub.format_help()
                    walk(sub, f"{name} {sub_name}")
    walk(parser, "tdicam")
    for cmd in ("verilog", "export", "synth"):
        for b in blocks.names():
            out[f"tdicam {cmd} {b} --help"] = _capture([cmd, b, "--help"])
    for argv in (["verilog", "pipeline", "--help"], ["synth", "pipeline", "--help"]):
        out["tdicam " + " ".join(argv)] = _capture(argv)
    return out


@pytest.fixture(scope="module")
def helps():
    return all_help_texts()


def test_help_covers_every_subcommand(helps):
    for cmd in ("run", "sweep", "demo", "verilog", "export", "golden", "sim", "plan", "bench",
                "synth", "calib"):
        assert helps[f"tdicam {cmd} --help"].startswith(f"usage: tdicam {cmd}")
    assert "tdicam calib write --help" in helps
    assert all(helps[f"tdicam verilog {b} --help"].strip() for b in blocks.names())


def test_help_texts_have_no_rest_markup(helps):
    bad = [f"{k}: {line.strip()}" for k, v in helps.items() for line in v.splitlines()
           if REST.search(line)]
    assert not bad, "\n".join(bad)


def test_help_texts_cite_papers_not_shorthand(helps):
    bad = [f"{k}: {line.strip()}" for k, v in helps.items() for line in v.splitlines()
           if SHORTHAND.search(line)]
    assert not bad, "\n".join(bad)


def test_plain_text_strips_markup():
    assert cli.plain_text("see :func:`~tdicam.run.runner.run_scene` and ``x = 1``") == \
        "see run_scene and x = 1"
    assert cli.plain_text(":mod:`tdicam.model.calib`") == "tdicam.model.calib"


#: What a user reads: the README and every page of the documentation site (the notebook too).
USER_PAGES = ["README.md"] + sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*")
                                    if p.suffix in (".md", ".ipynb") and "_build" not in p.parts)


@pytest.mark.parametrize("name", USER_PAGES)
def test_user_pages_cite_papers_not_shorthand(name):
    text = (ROOT / name).read_text()
    bad = [line for line in text.splitlines() if SHORTHAND.search(line)]
    assert not bad, "\n".join(bad)


SCENES = sorted((ROOT / "scenes").rglob("*.toml"))


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.name)
def test_bundled_scenes_are_named_and_commented_plainly(path):
    """Scene files are named after what they show (paper, setup), not "seed002_..."; their
    comments cite papers (issue 18)."""
    assert not SHORTHAND.search(path.name), path.name
    bad = [line for line in path.read_text().splitlines() if SHORTHAND.search(line)]
    assert not bad, "\n".join(bad)


def test_readme_lists_the_papers():
    text = (ROOT / "README.md").read_text()
    for cite in ("Qu, Zhang, Jin", "Yuan, Li, Xu, Nie", "Ning, Liu, Zhao, Guo",
                 "Tao, Jin, Qu, He, Yang", "Zhou, Liu, Xu, Li, Wang, Liu"):
        assert cite in text


# -- the installed package stands on its own (issue 48 item 1) --------------------------------

#: A path a wheel does not carry (the repository's docs/ or scenes/ folder).
NOT_INSTALLED = re.compile(r"\bdocs/|\bscenes/")


def test_help_texts_point_only_at_what_is_installed(helps):
    """A help text that sends a wheel user to ``docs/scene-format.md`` or ``scenes/sweeps/``
    is a dead end: they point at ``tdicam scenes`` (--show, --reference) instead."""
    bad = {k: [ln for ln in v.splitlines() if NOT_INSTALLED.search(ln)] for k, v in helps.items()}
    bad = {k: v for k, v in bad.items() if v}
    assert not bad, bad


def test_scenes_lists_scenes_and_sweeps(capsys):
    from tdicam.scene.examples import examples, sweeps
    assert cli.main(["scenes"]) == 0
    out = capsys.readouterr().out
    scenes_part, sweeps_part = out.split("sweeps:\n")
    assert [ln.split()[0] for ln in scenes_part.splitlines()[1:]] == list(examples())
    assert [ln.split()[0] for ln in sweeps_part.splitlines()[:-1]] == list(sweeps())
    assert len(sweeps()) >= 2


@pytest.mark.parametrize("name", ["orbit_600km_1m_96", "tao2012_snr_vs_stages"])
def test_scenes_show_prints_the_bundled_file(name, capsys):
    from tdicam.scene.examples import KINDS
    assert cli.main(["scenes", "--show", name]) == 0
    path = next(p for d in KINDS.values() if (p := d / f"{name}.toml").is_file())
    assert capsys.readouterr().out == path.read_text()


def test_scenes_show_unknown_is_one_line(capsys):
    assert cli.main(["scenes", "--show", "nope"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "no bundled scene 'nope'" in err[0] and "tao2012" in err[0]


def test_scenes_reference_is_the_scene_format_page(capsys):
    from tdicam.scene.docs import render
    assert cli.main(["scenes", "--reference"]) == 0
    assert capsys.readouterr().out == render() + "\n"


def test_a_shown_scene_runs_as_the_users_own(tmp_path, capsys):
    assert cli.main(["scenes", "--show", "orbit_600km_1m_96"]) == 0
    mine = tmp_path / "my.toml"
    mine.write_text(capsys.readouterr().out)
    assert cli.main(["run", str(mine), "--dry-run", "-o", str(tmp_path / "o")]) == 0


def test_plan_takes_a_bundled_scene(capsys):
    assert cli.main(["plan", "--example", "orbit_600km_1m_96", "--json"]) in (0, 1)
    import json
    assert json.loads(capsys.readouterr().out)["scene"]
    assert cli.main(["plan", "--example", "nope"]) == 2
    assert "no bundled scene 'nope'" in capsys.readouterr().err


def test_plan_refuses_a_scene_and_an_example(tmp_path, capsys):
    assert cli.main(["plan", "--scene", "x.toml", "--example", "orbit_chain"]) == 2
    assert "not allowed with" in capsys.readouterr().err


def test_sweep_takes_a_bundled_sweep(monkeypatch, tmp_path):
    import tdicam.api
    from tdicam.scene.examples import sweep_path
    seen = {}

    def fake(source, out, **kw):
        seen["source"] = source
        raise tdicam.api.TdicamError("stop here")
    monkeypatch.setattr(tdicam.api, "sweep", fake)
    assert cli.main(["sweep", "--example", "tao2012_snr_vs_stages"]) == 2
    assert seen["source"] == sweep_path("tao2012_snr_vs_stages")


@pytest.mark.parametrize("argv", [["verilog", "pipeline"], ["synth", "pipeline"],
                                  ["export", "pipeline", "-o", "x"]])
def test_pipeline_commands_take_a_bundled_scene(argv, monkeypatch, capsys):
    """``--example NAME`` reaches the pipeline commands' scene reader as the bundled file
    (the reader stood in for: what it does with the file, test_pipeline and test_export
    show)."""
    from tdicam.chain import design
    from tdicam.commands import _pipeline
    from tdicam.errors import TdicamError
    from tdicam.scene.examples import example_path
    seen = []

    def reader(path, *a, **kw):
        seen.append(path)
        raise TdicamError("stop here")
    monkeypatch.setattr(_pipeline, "load_pipeline_scene", reader)
    monkeypatch.setattr(design, "load_pipeline_scene", reader)
    assert cli.main([*argv, "--example", "orbit_chain"]) == 2
    assert "stop here" in capsys.readouterr().err
    assert [str(p) for p in seen] == [str(example_path("orbit_chain"))]


# -- tdicam sim picks the simulator and names what it leaves out (issue 48 item 4) ----------

def test_sim_auto_gives_small_cases_to_icarus_and_large_ones_to_verilator():
    from tdicam.cosim.cases import AUTO_ICARUS_VALUES, case_values, pick_simulators
    plan = pick_simulators("tdi", "fast")
    assert set(plan) == {"icarus", "verilator"}
    assert all(case_values("tdi", c) <= AUTO_ICARUS_VALUES for c in plan["icarus"])
    assert all(case_values("tdi", c) > AUTO_ICARUS_VALUES for c in plan["verilator"])
    assert "texture_1280x96_p1" in plan["verilator"] and "random_64x4_p1" in plan["icarus"]
    assert pick_simulators("cds", "beat") == {"icarus": [c.name for c in
                                                         blocks.get("cds").cases()]}


def test_sim_runs_each_case_on_its_simulator_and_names_the_skipped(monkeypatch, capsys):
    """``tdicam sim tdi`` per beat: every case that runs per beat on the simulator auto
    picks for it, and the fast-only cases it leaves out named with --fast (the simulators
    stood in for: tests/test_cli and cocotb_tests run them)."""
    from tdicam.commands import sim
    from tdicam.cosim.cases import pick_simulators, skipped
    calls = []

    def fake(block, *, sim, cases, on_case, **kw):
        calls.append((sim, cases))
        rows = [{"case": c, "pixels": 1, "mismatches": 0, "cycles": 1, "wall_s": 1.0,
                 "timeout": False} for c in cases or ["all"]]
        for r in rows:
            on_case(r)
        return rows
    monkeypatch.setattr(sim, "cosimulate", fake)
    assert cli.main(["sim", "tdi"]) == 0
    out = capsys.readouterr().out
    assert calls == list(pick_simulators("tdi", "beat").items())
    left = skipped("tdi", "beat")
    assert len(left) == 4
    assert f"not run per beat: 4 fast-only case(s) ({', '.join(left)})" in out
    assert "run them with --fast" in out and "tdi (auto: " in out
    assert cli.main(["sim", "tdi", "--sim", "icarus", "--fast"]) == 0
    assert calls[-1] == ("icarus", None) and "not run per beat" not in capsys.readouterr().out
