"""``tdicam run`` with ``[run.rtl]``: the median3 and tdi blocks of a scene's chain are
co-simulated on a crop (both simulators) against their golden models on the same crop input, and
the check can fail (a corrupted expected output gives mismatches)."""

from pathlib import Path

import numpy as np
import pytest

from tdicam import blocks, cosim, engine
from tdicam.scenerun import run_scene
from tdicam.rtl import cosim_block
from tdicam.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
CROP = [8, 2, 16, 6]                     # x0, y0, width, height of the output


def _scene(pipeline, simulator):
    return load_scene(ROOT / "scenes" / "orbit_600km_1m_96.toml", overrides={
        "sensor": {"columns": 64}, "tdi": {"stages": 4}, "pipeline": {"blocks": pipeline},
        "run": {"lines": 16, "fidelity": "exact",
                "rtl": {"crop": CROP, "simulator": simulator}}})


@pytest.fixture(scope="module", params=cosim.SIMULATORS)
def report(request, tmp_path_factory):
    out = tmp_path_factory.mktemp("rtl")
    sc = _scene(["tdi", "median3"], request.param)
    return run_scene(sc, out, impact=False, progress=False), out, request.param


def test_run_cosimulates_tdi_and_median3_on_the_crop(report):
    rep, out, simulator = report
    got = {b["block"]: b for b in rep["rtl"]["blocks"]}
    assert set(got) == {"tdi", "median3"}
    for name, b in got.items():
        assert b["status"] == "ran", b
        assert b["mismatches"] == 0, b
        assert not b["timeout"]
        assert b["pixels_compared"] == CROP[2] * CROP[3]        # the whole output crop
    md = (out / "report.md").read_text()
    assert "## RTL co-simulation" in md and "| tdi | ran | 96 | 0 |" in md
    assert f"RTL median3 on {simulator}: 96 pixels compared, 0 mismatches" in rep["summary"]


@pytest.mark.parametrize("name", ["tdi", "median3"])
def test_corrupted_expected_gives_mismatches(report, name):
    # same scene, same crop: the simulator builds of the module fixture are reused
    sc = _scene(["tdi", "median3"], report[2])
    x0, y0, w, h = CROP
    res = engine.simulate(sc, impact=False, keep_crop=(y0, h, x0, w))

    def corrupt(a):
        a["out"] = np.array(a["out"], copy=True)
        a["out"].reshape(-1)[7] ^= 1

    bad = cosim_block(name, blocks.get(name), res.frames_crop[name], sc.run.rtl,
                       corrupt=corrupt)
    assert bad["status"] == "ran"
    assert bad["mismatches"] > 0
    good = cosim_block(name, blocks.get(name), res.frames_crop[name], sc.run.rtl)
    assert good["mismatches"] == 0
