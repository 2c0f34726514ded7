"""A camera split over two devices at its front end (``chain_plan(part=...)``, ``tdicam
verilog|synth pipeline --part``): the front end alone (lanes to pixel stream) and the chain
after it (pixel stream to output) are the whole top's two halves, and the plan's verdict
on a split needs both halves measured and fast enough."""

from pathlib import Path

import pytest

from tdicam.chain import design
from tdicam.errors import TdicamError
from tdicam.hw import record
from tdicam.planning.camera import _silicon
from tdicam.planning.sizing import _chain_ok

ROOT = Path(__file__).resolve().parents[1]

LANES = ROOT / "scenes" / "ning2019_gmax0504_system_lanes.toml"
FULL = ROOT / "scenes" / "ning2019_gmax0504_full.toml"


@pytest.mark.parametrize("scene", [LANES, FULL], ids=["system_lanes", "full"])
def test_parts_are_the_halves_of_the_whole(scene):
    sc = design.load_pipeline_scene(scene, None)
    whole = design.chain_plan(sc)
    front = design.chain_plan(sc, part="front")
    chain = design.chain_plan(sc, part="chain")
    assert design.chain_plan(sc, part="whole") == whole
    assert whole.steps[0].block == "lvds"
    assert front.steps == whole.steps[:1] and front.links is None
    assert chain.steps == whole.steps[1:]
    assert chain.links == whole.links and chain.lanes == whole.lanes == front.lanes
    assert chain.reset_frames and whole.reset_frames


def test_parts_verilog_ports():
    sc = design.load_pipeline_scene(LANES, None)
    front = design.verilog(design.chain_plan(sc, part="front"))
    chain = design.verilog(design.chain_plan(sc, part="chain"))
    head = {name: text[text.index("module pipeline("):].split(");")[0]
            for name, text in (("front", front), ("chain", chain))}
    assert "lvds_lane_raw" in head["front"] and "word_clk" in head["front"]
    assert "m_axis_tdata" in head["front"] and "s_axis_tdata" not in head["front"]
    assert "cds_ddr" not in head["front"]
    assert "s_axis_tdata" in head["chain"] and "cds_ddr_frame_kind" in head["chain"]
    assert "lvds_" not in head["chain"] and "word_clk" not in head["chain"]


def test_parts_refused():
    orbit = design.load_pipeline_scene(ROOT / "scenes" / "orbit_chain.toml", None)
    with pytest.raises(TdicamError, match="--part front splits a camera at its front end"):
        design.chain_plan(orbit, part="front")
    with pytest.raises(TdicamError, match="part"):
        design.chain_plan(design.load_pipeline_scene(LANES, None), part="middle")
    with pytest.raises(TdicamError, match="not --part chain"):
        design.chain_plan(design.load_pipeline_scene(LANES, None), part="chain",
                          phy="xilinx7")


def _row(part, meets, date="2026-12-03"):
    return {"part": part, "meets": meets, "date": date, "pixel_rate": 2.0 if meets else 1.0}


def test_split_verdict_needs_both_parts():
    assert _chain_ok([_row("whole", True)]) is True
    assert _chain_ok([_row("whole", False)]) is False
    assert _chain_ok([_row("whole", False), _row("front", True), _row("chain", True)]) is True
    assert _chain_ok([_row("front", True)]) is False               # the chain not measured
    assert _chain_ok([_row("front", True), _row("chain", False)]) is False
    # the newest row of a part decides
    assert _chain_ok([_row("front", True), _row("chain", False, "2026-12-01"),
                      _row("chain", True, "2026-12-03")]) is True
    assert _chain_ok([_row("front", True), _row("chain", True, "2026-12-01"),
                      _row("chain", False, "2026-12-03")]) is False


def test_readme_table_tells_parts_apart():
    base = dict(block="pipeline", fmax_seeds=[130.0], target_mhz=200.0, date="2026-12-03",
                lut4=1, comb=1, ff=1, dp16kd=0, mult18=0)
    rows = [record.Row(label=f"full {part}", fmax_mhz=fmax,
                       params={"scene": "ning2019_gmax0504_full.toml", "ppc": 8, "part": part},
                       **base) for part, fmax in (("front", 130.0), ("chain", 125.0))]
    lines = [ln for ln in record.readme_table(rows, limits=design.ECP5_85F).splitlines()
             if "ning2019_gmax0504_full" in ln]
    assert len(lines) == 2
    assert "front end" in lines[0] and "clk 130.0" in lines[0]
    assert "TLK2711" in lines[1] and "clk 125.0" in lines[1]


def _rate_row(part, rate, date="2026-12-03", need=100.0):
    return {"part": part, "label": part, "ppc": 8, "fmax_mhz": rate / 8, "seeds": 3,
            "date": date, "pixel_rate": rate, "need": need, "meets": rate >= need}


def test_silicon_frame_rate_is_the_slowest_recorded_part():
    """The camera on the record: the chain device's newest row sets the frame rate read
    when it is below the budget's other read limits; a front device that cannot take a line
    from the lanes reads none; a whole top that keeps up stands alone; no record, or a split
    missing a part, gives none."""
    budget = {"frame_rate_hz": 25.0, "samples_per_gain_s": 100.0,
              "limits": {"lanes": 30.0, "processing": 40.0, "DDR interface": 35.0,
                         "output links": 10.0}}
    si = _silicon([_rate_row("front", 120.0), _rate_row("chain", 90.0, "2026-12-01"),
                   _rate_row("chain", 96.0)], budget)
    assert si["read_limiter"] == "chain device" and si["read_limit_hz"] == 24.0
    assert [r["pixel_rate"] for r in si["rows"]] == [120.0, 96.0] and not si["ok"]
    si = _silicon([_rate_row("front", 200.0), _rate_row("chain", 200.0)], budget)
    assert si["read_limiter"] == "lanes" and si["read_limit_hz"] == 30.0 and si["ok"]
    si = _silicon([_rate_row("front", 99.0), _rate_row("chain", 200.0)], budget)
    assert si["read_limiter"] == "front device" and si["read_limit_hz"] == 0 and not si["ok"]
    si = _silicon([_rate_row("whole", 110.0), _rate_row("front", 200.0),
                   _rate_row("chain", 90.0)], budget)
    assert [r["part"] for r in si["rows"]] == ["whole"] and si["ok"]
    assert _silicon([_rate_row("front", 200.0)], budget) is None
    assert _silicon(None, budget) is None
