"""The synthesis record (tdicam/hw/silicon.json): complete, equal to the silicon page, read
by the plan, and refused in one line when damaged."""

from __future__ import annotations

import json
import re
import statistics
from dataclasses import asdict, replace
from pathlib import Path

import pytest

from tdicam.planning import sizing
from tdicam.cli import main
from tdicam.errors import TdicamError
from tdicam.hw import record
from tdicam.hw.synth import REFERENCE, SynthResult
from tdicam.paths import SCENES

ROOT = Path(__file__).resolve().parents[1]
SILICON = ROOT / "docs" / "guide" / "silicon.md"


def _doc_rows():
    rows = {}
    for line in SILICON.read_text(encoding="utf-8").splitlines():
        if line.startswith("| ") and not line.startswith("| block"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            rows.setdefault(cells[0], cells)
    return rows


def test_every_reference_row_is_measured_and_on_the_silicon_page():
    rows = record.load()
    labels = {r.label for r in rows}
    assert {r.label for r in REFERENCE} <= labels
    doc = _doc_rows()
    for r in rows:
        cells = doc.get(r.label)
        assert cells is not None, f"{r.label}: not in {SILICON.name}"
        spread = "1 seed" if len(r.fmax_seeds) == 1 else \
            f"{min(r.fmax_seeds):.1f}–{max(r.fmax_seeds):.1f}"
        assert f"{r.fmax_mhz:.1f} ({spread})" in " | ".join(cells), r.label
        numbers = [re.match(r"\d+", c) for c in cells[1:]]
        firsts = {int(m.group()) for m in numbers if m}
        for name in ("lut4", "comb", "mult18"):
            value = getattr(r, name)
            assert value is None or value in firsts, (r.label, name, value)
        assert sorted(r.fmax_seeds) == r.fmax_seeds
        # tdicam.hw.synth's median: the middle seed, the mean of the middle two for an
        # even count
        assert r.fmax_mhz == round(statistics.median(r.fmax_seeds), 1)


def test_plan_reads_the_tdi_fmax_from_the_record():
    tdi = record.find("tdi", **sizing.REFERENCE_TDI)
    assert {int(r.params["ppc"]): r.fmax_mhz for r in tdi} == sizing.REFERENCE_TDI_FMAX_MHZ
    assert set(sizing.REFERENCE_TDI_FMAX_MHZ) == {1, 4, 8}
    g = sizing.gateware_plan(96, 1280, 1 / 6908)
    assert [o["fmax_mhz"] for o in g["options"] if o["fmax_mhz"]] == \
        [sizing.REFERENCE_TDI_FMAX_MHZ[p] for p in (1, 4, 8)]


def _with_chain(tmp_path, monkeypatch, fmax):
    """A copy of the bundled record whose Ning et al. 2019 chain row has Fmax ``fmax``."""
    rows = [replace(r, fmax_mhz=fmax, fmax_seeds=[fmax], fmax_clocks=r.fmax_clocks and {
        k: fmax for k in r.fmax_clocks}) if r.block == "pipeline" else r
            for r in record.load()]
    path = tmp_path / "silicon.json"
    record.update(rows, path)
    monkeypatch.setattr(record, "RECORD", path)


def test_plan_says_whether_the_chain_keeps_up(tmp_path, monkeypatch, capsys):
    scene = str(SCENES / "ning2019_chain.toml")
    assert main(["plan", "--scene", scene]) == 0
    out = capsys.readouterr().out
    assert "whole chain    camera pipeline (Ning et al. 2019 chain)" in out
    assert "ppc 1 at 112.1 MHz" in out and "keeps up with the sensor: yes" in out
    # the same scene with a chain too slow for its 2.8 M pixel/s: the plan says NO
    _with_chain(tmp_path, monkeypatch, 0.3)        # 2.4 M pixel/s even at ppc 8
    assert main(["plan", "--scene", scene, "--json"]) == sizing.EXIT_INFEASIBLE
    d = json.loads(capsys.readouterr().out)
    point = d["points"][0]
    assert point["gateware"]["chain_ok"] is False
    assert d["infeasible"] == ["chain pixel rate (synthesis record)"]


def test_plan_of_the_orbit_chain_reads_its_ppc_8_row(capsys):
    """scenes/orbit_chain.toml: the plan's whole-chain line is the recorded ppc-8 place and
    route of its pipeline, and the verdict is Fmax x 8 against the sensor's rate."""
    rows = [r for r in record.find("pipeline", scene="orbit_chain.toml")
            if "bus" not in r.params]         # the bus rows: the control bus's cost
    assert [int(r.params["ppc"]) for r in rows] == [8]
    code = main(["plan", "--scene", str(SCENES / "orbit_chain.toml"), "--json"])
    g = json.loads(capsys.readouterr().out)["points"][0]["gateware"]
    (c,) = g["chain"]
    assert (c["ppc"], c["fmax_mhz"], c["width"]) == (8, rows[0].fmax_mhz, 1280)
    assert g["chain_ok"] == (rows[0].fmax_mhz * 8e6 >= g["pixel_rate"])
    assert abs(g["pixel_rate"] - 848.9e6) < 0.1e6
    # the recorded chain keeps up with the sensor: the plan says so and exits 0
    assert g["chain_ok"] and code == 0
    assert main(["plan", "--scene", str(SCENES / "orbit_chain.toml")]) == 0
    assert "keeps up with the sensor: yes" in capsys.readouterr().out


def test_a_scene_without_a_recorded_chain_has_none(capsys):
    assert main(["plan", "--scene", str(SCENES / "orbit_600km_1m_96.toml"), "--json"]) in (0, 1)
    d = json.loads(capsys.readouterr().out)
    assert d["points"][0]["gateware"]["chain"] is None


def test_update_replaces_by_label_and_keeps_order(tmp_path):
    res = SynthResult(block="cds", params={"pixel_bits": 12}, lut4=15, ccu2c=6, comb=33,
                      ff=15, fmax_mhz=320.0, fmax_seeds=[330.0, 310.0, 320.0],
                      xilinx={"LUT": 35, "FF": 15, "SRL": 2}, tool_seconds=12.3)
    row = record.row_of("cds", "cds", {"pixel_bits": 12}, res, target_mhz=150, load="0.5")
    assert row.fmax_seeds == [310.0, 320.0, 330.0] and row.xc7["LUTRAM+SRL"] == 2
    path = tmp_path / "r.json"
    record.update([row, replace(row, label="a", fmax_mhz=1.0)], path)
    record.update([replace(row, fmax_mhz=300.0)], path)
    rows = record.load(path)
    assert [r.label for r in rows] == ["a", "cds"] and rows[1].fmax_mhz == 300.0
    # every field stored; fmax_clocks only when recorded (a one-clock result has none)
    assert json.loads(path.read_text())["rows"][1] == \
        {k: v for k, v in asdict(rows[1]).items() if k != "fmax_clocks"}
    res.fmax_clocks = {"clk": 320.0, "word_clk": 200.0}
    record.update([record.row_of("two", "cds", {}, res, target_mhz=150)], path)
    assert json.loads(path.read_text())["rows"][2]["fmax_clocks"] == res.fmax_clocks
    assert record.load(path)[2].fmax_clocks == res.fmax_clocks


@pytest.mark.parametrize("text, message", [
    ("", "not a synthesis record: it is empty (0 bytes)"),
    ("[1, 2]", "not a tdicam synthesis record"),
    ('{"rows": [{"label": "x"}]}', "row 0: "),
    ('{"rows": [{"label": "x", "block": "cds", "params": {}, "fmax_mhz": -1, '
     '"fmax_seeds": [], "target_mhz": 150, "date": "2026-01-01"}]}', "fmax_mhz must be > 0"),
])
def test_a_damaged_record_is_one_line(tmp_path, text, message):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(TdicamError, match=re.escape(message)) as e:
        record.load(path)
    assert "\n" not in str(e.value) and str(path) in str(e.value)


def test_readme_silicon_table_is_the_record():
    """The README's "Silicon (ECP5-85F)" table is generated from the record: the chains at
    ppc 8 and the system scene from the lanes with its Fmax per clock domain."""
    from tdicam.chain.design import ECP5_85F
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    begin = "<!-- silicon table: generated from tdicam/hw/silicon.json -->\n"
    table = text[text.index(begin) + len(begin):text.index("<!-- end of silicon table -->")]
    assert table == record.readme_table(limits=ECP5_85F), \
        "README.md's silicon table is stale: paste tdicam.hw.record.readme_table()"
    assert table.count("\n") >= 4
    # a two-domain row shows each clock; a design over the part says what does not fit
    row = replace(record.load()[0], label="x", block="pipeline", date="2099-01-01",
                  params={"scene": "ning2019_chain.toml", "ppc": 8}, comb=90000,
                  fmax_clocks={"clk": 101.5, "word_clk": 180.2})
    t = record.readme_table([row], limits=ECP5_85F)
    assert "clk 101.5, word_clk 180.2" in t and "no: comb 90000 > 83640" in t


def test_readme_blocks_table_is_the_record():
    """README's table of the stream blocks at ppc 8 is generated from the record, with each
    block's LUT4 against its ppc-1 row (the issue's <= 8x) and the target met or not."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    begin = "<!-- blocks table: generated from tdicam/hw/silicon.json -->\n"
    table = text[text.index(begin) + len(begin):text.index("<!-- end of blocks table -->")]
    assert table == record.readme_blocks_table(), \
        "README.md's blocks table is stale: paste tdicam.hw.record.readme_blocks_table()"
    for block in ("cds", "nuc", "hdr", "median3", "tdi"):
        assert f"| {block}" in table
    base = record.load()
    one = replace(base[0], label="a", block="nuc", params={}, lut4=10, date="2099-01-01")
    eight = replace(one, label="b", params={"ppc": 8}, lut4=95, fmax_mhz=140.0,
                    fmax_seeds=[139.0, 140.0, 141.5], target_mhz=150.0)
    enh = replace(eight, label="c", block="median3", params={"ppc": 8, "enhance": True})
    t = record.readme_blocks_table([one, eight, enh])
    assert "| nuc | 95 (9.5x) |" in t and "140.0 (139.0-141.5, 3) | 150: **not met** |" in t
    assert "| median3 with edge enhancement | 95 (-) |" in t and "| median3 |" not in t


def test_whole_camera_row_is_at_the_plans_design_point(capsys):
    """scenes/ning2019_gmax0504_full.toml: the whole camera is recorded at the pixels per clock
    and the clock the camera budget asks (`tdicam plan`: 977 M samples/s a gain on 200 MHz at
    8 pixels a clock), with its xc7 counts, and the README's fit column is the record's."""
    from tdicam.chain.design import ECP5_85F
    assert main(["plan", "--scene", str(SCENES / "ning2019_gmax0504_full.toml"),
                 "--json"]) in (0, 1)
    cam = json.loads(capsys.readouterr().out)["camera"]["scene"]
    rows = [r for r in record.find("pipeline", scene="ning2019_gmax0504_full.toml")
            if int(r.params["ppc"]) == cam["ppc"]]
    assert rows, "the whole camera at the plan's ppc is not in the record"
    r = max(rows, key=lambda r: r.date)
    assert r.target_mhz == cam["config"]["clock_mhz"] and r.xc7
    fits = all(getattr(r, k) <= v for k, v in ECP5_85F.items())
    line = next(ln for ln in record.readme_table(limits=ECP5_85F).splitlines()
                if "ning2019_gmax0504_full.toml" in ln)
    assert line.endswith("| yes |") == fits
