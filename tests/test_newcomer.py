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
