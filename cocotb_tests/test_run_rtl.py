"""``tdicam run`` with ``[run.rtl]``: the scene's chain (here tdi -> median3) runs as one
generated top on a crop of the scene's raw frames and every block's output is compared with
the golden chain; the check can fail (a corrupted golden stage is named)."""

import os
from pathlib import Path

import numpy as np
import pytest

from tdicam import engine
from tdicam.run.runner import run_scene
from tdicam.chain.cosim import cosim_scene
from tdicam.scene.loader import load_scene

ROOT = Path(__file__).resolve().parents[1]
CROP = [8, 2, 16, 6]                     # x0, y0, width, height of the output
FULL = os.environ.get("TDICAM_FULL") == "1"
SIMS = ["icarus", "verilator"] if FULL else ["icarus"]


def _scene(pipeline, simulator, ppc=1):
    return load_scene(ROOT / "scenes" / "orbit_600km_1m_96.toml", overrides={
        "sensor": {"columns": 64}, "tdi": {"stages": 4}, "pipeline": {"blocks": pipeline},
        "run": {"lines": 16, "fidelity": "exact",
                "rtl": {"crop": CROP, "simulator": simulator, "pixels_per_clock": ppc}}})


@pytest.fixture(scope="module", params=SIMS)
def report(request, tmp_path_factory):
    out = tmp_path_factory.mktemp("rtl")
    sc = _scene(["tdi", "median3"], request.param)
    return run_scene(sc, out, impact=False, progress=False), out, request.param


def test_run_cosimulates_the_chain_on_the_crop(report):
    rep, out, simulator = report
    got = {b["block"]: b for b in rep["rtl"]["blocks"]}
    assert list(got) == ["tap tdi", "tap median3", "pipeline"]
    for name, b in got.items():
        assert b["status"] == "ran", b
        assert b["mismatches"] == 0, b
        assert b["pixels_compared"] == CROP[2] * CROP[3]        # the whole output crop
    assert got["pipeline"]["input_pixels"] == (CROP[3] + 3) * 4 * CROP[2]
    assert got["pipeline"]["build_seconds"] >= 0 and got["pipeline"]["run_seconds"] > 0
    md = (out / "report.md").read_text()
    assert "## RTL co-simulation" in md and "| tap tdi | ran | 96 | 0 |" in md
    assert f"RTL pipeline on {simulator}: 96 pixels compared, 0 mismatches" in rep["summary"]


def test_run_at_4_pixels_per_clock_matches_in_fewer_cycles(report, tmp_path):
    """``[run.rtl] pixels_per_clock = 4``: the same crop through the top at 4 pixels per
    clock (Icarus; the median after TDI's 4 stages at 1 behind a width converter),
    bit-exact on every tap, in fewer clock cycles than at ppc 1 (a quarter of the input
    beats; the fixed reset and drain cycles stay, and the last output line leaves at one
    pixel a clock)."""
    rep1, _, simulator = report
    if simulator != "icarus":
        pytest.skip("compared with the Icarus run at ppc 1")
    rep = run_scene(_scene(["tdi", "median3"], "icarus", ppc=4), tmp_path, impact=False,
                    progress=False)
    got = {b["block"]: b for b in rep["rtl"]["blocks"]}
    assert [got[k]["mismatches"] for k in ("tap tdi", "tap median3", "pipeline")] == [0] * 3
    assert got["pipeline"]["pixels_compared"] == CROP[2] * CROP[3]
    beats1 = got["pipeline"]["input_pixels"]                 # input beats at ppc 1
    c1 = {b["block"]: b for b in rep1["rtl"]["blocks"]}["pipeline"]["cycles"]
    assert got["pipeline"]["cycles"] <= c1 - beats1 * 3 // 4 * 0.6, (got["pipeline"], c1)


def test_corrupted_golden_stage_is_named(report, tmp_path):
    # same scene, same crop: the simulator build of the module fixture is reused
    sc = _scene(["tdi", "median3"], report[2])
    x0, y0, w, h = CROP
    res = engine.simulate(sc, impact=False)

    def corrupt(gold):
        a = gold[0][2].copy()
        a.reshape(-1)[7] ^= 1
        gold[0][2] = a

    bad = cosim_scene(sc, res, (y0, h, x0, w), corrupt=corrupt)["blocks"][-1]
    assert bad["status"] == "ran" and bad["first_mismatch"]["block"] == "tdi"
    assert (bad["first_mismatch"]["frame"], bad["first_mismatch"]["column"]) == (0, 7)
    assert bad["mismatches"] == 0                    # only the tap differs from its stage
    assert "waveform" not in bad                     # no output folder given
