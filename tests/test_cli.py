"""CLI: Verilog generation, parameter errors, lint."""

import re
import subprocess
import sys

import pytest

from tdicam import blocks
from tdicam.cli import main
from tdicam.lint import lint


def run(*args):
    return subprocess.run([sys.executable, "-m", "tdicam", *args], capture_output=True,
                          text=True)


def test_verilog_is_deterministic_and_path_free(tmp_path):
    a, b = tmp_path / "a.v", tmp_path / "b.v"
    assert run("verilog", "cds", "-o", str(a)).returncode == 0
    assert run("verilog", "cds", "-o", str(b)).returncode == 0
    text = a.read_text()
    assert a.read_bytes() == b.read_bytes()
    assert not re.search(r"(/work|/tmp|/home|/root|\\.py:\d)", text)
    assert re.search(r"^module cds\(", text, re.M)
    for port in ("s_axis_tdata", "s_axis_tvalid", "s_axis_tready", "s_axis_tuser",
                 "s_axis_tlast", "m_axis_tdata", "m_axis_tvalid", "m_axis_tready",
                 "m_axis_tuser", "m_axis_tlast", "clk", "rst"):
        assert re.search(rf"^\s*(input|output) .*\b{port};", text, re.M), port


@pytest.mark.parametrize("name", blocks.names())
def test_every_stream_block_lints_clean(name, tmp_path):
    path = tmp_path / f"{name}.v"
    assert main(["verilog", name, "-o", str(path)]) == 0
    assert lint(path) == []


def test_lint_catches_a_real_problem(tmp_path):
    path = tmp_path / "bad.v"
    path.write_text("module bad(input [2:0] a, output [1:0] y, output z);\n"
                    "  assign y = a;\nendmodule\n")
    found = lint(path)
    assert any("WIDTHTRUNC" in line for line in found)  # 3 bits into 2
    assert any("UNDRIVEN" in line for line in found)  # z


@pytest.mark.parametrize("args,expect", [
    (["verilog", "nosuch"], "unknown block 'nosuch'; valid: "),
    (["verilog", "cds", "--widht", "3"], "block cds has no parameter --widht; valid: --pixel-bits"),
    (["verilog", "cds", "--pixel-bits", "99"], "--pixel-bits = 99 is out of range; valid: 8..16"),
    (["verilog", "cds", "--pixel-bits", "abc"], "--pixel-bits must be an integer"),
    (["sim", "cds", "--sim", "modelsim"], "invalid choice: 'modelsim'"),
    (["golden", "check", "nosuch"], "unknown block 'nosuch'"),
])
def test_bad_input_is_one_line(args, expect):
    proc = run(*args)
    assert proc.returncode == 2
    err = proc.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert expect in err
    assert "Traceback" not in err


def test_block_help_lists_params():
    proc = run("verilog", "cds", "--help")
    assert proc.returncode == 0
    assert "--pixel-bits (8..16, default 12)" in proc.stdout
