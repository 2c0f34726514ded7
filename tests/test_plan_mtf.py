"""The planned MTF (tdicam.model.physics.mtf, tdicam.planning.predict.mtf_prediction) against the scene
simulator's bar-target measurement, the paper's model beside it, and no negative MTF anywhere.

Default run: fast fidelity on 32-column, 64-line sine bars at Nyquist (a few seconds). The
long form (TDICAM_FULL=1) adds exact fidelity, reverse scan, a fill factor and a PSF.
"""

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from tdicam import engine
from tdicam.planning import sizing
from tdicam.planning.predict import mtf_prediction
from tdicam.cli import main
from tdicam.errors import TdicamError
from tdicam.run.measure import measure
from tdicam.model.physics.mtf import dirichlet
from tdicam.model.physics.plan import (NYQUIST, camera_mtf, mtf_system, mtf_velocity_mismatch,
                                       stage_lag)
from tdicam.model.physics.optics import Geometry
from tdicam.scene.loader import load_scene, scene_from_dict

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "orbit_600km_1m_96.toml"

FULL = os.environ.get("TDICAM_FULL") == "1"
STAGES = (1, 8, 32, 96)
M_DV = (0.0, 0.5, 1.0, 1.5)


def bar_scene(m, dv, shutter, *, direction="forward", fill=1.0, psf=0.0, lines=64,
              fidelity="fast"):
    """Sine bars at Nyquist along track; the orbit scene's timing (rolling skew 0.0104/stage)."""
    return scene_from_dict({
        "orbit": {"altitude_km": 600.0, "gsd_m": 1.0},
        "target": {"kind": "bars", "period_px": 2.0, "contrast": 0.5, "profile": "sine",
                   "signal_e": 5000.0},
        "sensor": {"columns": 32, "rows": 1024, "bits": 14, "full_well_e": 20000.0,
                   "shutter": shutter, "max_frame_rate_hz": 650.0, "fill_factor": fill},
        "optics": {"psf_sigma_px": psf},
        "tdi": {"stages": m, "direction": direction}, "motion": {"dv_over_v": dv},
        "run": {"lines": lines, "seed": 1, "fidelity": fidelity}})


def simulated(scene, m, dv):
    res = engine.simulate(scene, stages=m, dv_over_v=dv, impact=False)
    return measure(scene, res)["mtf"]


def cases():
    for shutter in ("global", "rolling"):
        for m in STAGES:
            for mdv in M_DV:
                if m == 1 and mdv >= 1.0:
                    continue            # dV/V >= 1: rejected (test_dv_out_of_range)
                yield pytest.param(m, mdv, shutter, id=f"{shutter}-M{m}-{mdv}")


@pytest.mark.parametrize("m, mdv, shutter", list(cases()))
def test_planned_mtf_equals_simulator(m, mdv, shutter):
    sc = bar_scene(m, mdv / m, shutter)
    got = simulated(sc, m, mdv / m)
    plan = mtf_prediction(sc, m, mdv / m)
    assert abs(plan["system"] - got["measured"]) < 0.01, (plan["system"], got)
    assert abs(plan["system"] - got["footprint_model"]) < 0.002, (plan["system"], got)
    assert plan["system"] >= 0 and got["yuan2013_model"] >= 0


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="long form: TDICAM_FULL=1")
@pytest.mark.parametrize("fidelity", ["fast", "exact"])
@pytest.mark.parametrize("direction, fill, psf", [("forward", 1.0, 0.0), ("reverse", 0.5, 0.0),
                                                  ("forward", 0.8, 0.4)])
def test_planned_mtf_equals_simulator_full(fidelity, direction, fill, psf):
    for shutter in ("global", "rolling"):
        for m in (2, 8, 32, 96):
            for mdv in (0.0, 0.25, 0.5, 1.0, 1.5, 2.5, -1.0):
                if abs(mdv / m) >= 1:
                    continue
                sc = bar_scene(m, mdv / m, shutter, direction=direction, fill=fill, psf=psf,
                               lines=128, fidelity=fidelity)
                got = simulated(sc, m, mdv / m)
                plan = mtf_prediction(sc, m, mdv / m)
                assert abs(plan["system"] - got["measured"]) < 0.01, (m, mdv, plan, got)
                assert abs(plan["system"] - got["footprint_model"]) < 0.002, (m, mdv, plan)


def test_orbit_scene_plans_what_the_simulator_measures():
    sc = load_scene(SCENE, overrides={"target": {"period_px": 2.0, "profile": "sine",
                                                 "contrast": 0.5},
                                      "sensor": {"columns": 32},
                                      "run": {"lines": 64, "fidelity": "fast"}})
    plan = mtf_prediction(sc, 96, 0.0)
    assert plan["system"] == pytest.approx(0.259, abs=0.001)       # not the paper's 0.409
    assert plan["paper"]["system"] == pytest.approx(0.409, abs=0.001)
    assert plan["skew_px"] == pytest.approx(0.996, abs=0.001)
    assert abs(simulated(sc, 96, 0.0)["measured"] - plan["system"]) < 0.01


def test_paper_model_reproduced():
    # Yuan et al. 2013: the mismatch factor is 0.637 at M dV/V = 1 and 0 at M dV/V = 2 (Nyquist)
    for m in (4, 8, 32, 96, 128):
        assert mtf_velocity_mismatch(NYQUIST, m, 1 / m) == pytest.approx(2 / math.pi)
        assert mtf_velocity_mismatch(NYQUIST, m, 2 / m) == pytest.approx(0, abs=1e-12)


@pytest.mark.parametrize("m, gap", [(1, 0.168), (8, 0.044), (32, 0.012), (96, 0.004)])
def test_paper_exposure_vs_full_line_period(m, gap):
    # the paper exposes M/(M+1) of a line period, the camera the whole of it
    assert float(mtf_system(NYQUIST, m) - camera_mtf(NYQUIST, m)) == pytest.approx(
        gap, abs=0.001)


def test_smear_at_the_image_speed_depends_on_the_sign():
    a, b = camera_mtf(NYQUIST, 8, 0.05), camera_mtf(NYQUIST, 8, -0.05)
    assert a != pytest.approx(b, abs=1e-3)            # the image moves 0.95 or 1.05 px
    assert float(mtf_system(NYQUIST, 8, 0.05)) == float(mtf_system(NYQUIST, 8, -0.05))
    assert float(a) == pytest.approx(abs(np.sinc(0.5) * np.sinc(0.5 * 0.95)
                                         * dirichlet(0.5 * 0.05, 8)))


def test_geometry_uses_the_planning_model():
    g = Geometry(stages=32, dv_over_v=0.02, skew=0.01, q_over_p=0.9, psf_sigma_px=0.3)
    f = np.linspace(0, 0.5, 7)
    np.testing.assert_allclose(np.abs(g.mtf_along(f)),
                               camera_mtf(f, 32, 0.02, 0.01, 0.9, 1.0, 0.3), rtol=0,
                               atol=1e-15)


@pytest.mark.parametrize("call", [
    lambda: Geometry(stages=4, dv_over_v=1.0),
    lambda: Geometry(stages=4, dv_over_v=-1.5),
    lambda: camera_mtf(0.5, 8, 1.0),
    lambda: stage_lag(1.0),
    lambda: mtf_prediction(bar_scene(8, 0, "global"), 1, 1.0),
])
def test_dv_out_of_range(call):
    with pytest.raises(TdicamError, match=r"dv_over_v = -?1\.?5? is out of range; valid: "
                                          r"-1\.\.1, excluding -1 and 1") as exc:
        call()
    assert "\n" not in str(exc.value)


def _mtf_numbers(node, path=""):
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _mtf_numbers(v, f"{path}.{k}")
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _mtf_numbers(v, f"{path}[{i}]")
    elif isinstance(node, float) and "dv_over_v" not in path:
        yield path, node


def test_no_negative_mtf_in_plan(capsys):
    dvs = [str(x / 8) for x in (0, 1, 1.5, 2, 2.5, 3)]          # M dV/V through 2 and 3
    code = main(["plan", "--gsd-m", "1", "--stages", "8", "--dv-over-v", *dvs, "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert code in (0, 1)
    mtf = rep["design"]["mtf_nyquist"]
    for path, value in _mtf_numbers(mtf):
        assert value >= 0, path
    assert [mm["reversed"] for mm in mtf] == [False, False, False, False, True, True]
    main(["plan", "--gsd-m", "1", "--stages", "8", "--dv-over-v", "0.375"])
    out = capsys.readouterr().out
    assert "contrast reversed" in out and "-0." not in out.split("MTF @ Nyquist")[1]


def test_no_negative_mtf_in_figures():
    scenes, _ = sizing.plan_scenes(None, {"gsd_m": [1.0], "stages": [8]})
    rep = sizing.plan_report(scenes)
    figs = dict(sizing.figures(rep, scenes))
    lines = [ln for ax in figs["mtf_mismatch.png"].axes for ln in ax.get_lines()]
    assert len(lines) > 8
    for ln in lines:
        y = np.asarray(ln.get_ydata(), float)
        assert np.all(y >= 0), ln.get_label()
    assert max(np.asarray(ln.get_xdata(), float).max() for ln in lines) >= 3


@pytest.mark.parametrize("shutter, mdv", [("global", 2.5), ("global", 3.0), ("rolling", 1.5),
                                          ("rolling", 2.0)])
def test_no_negative_mtf_in_report(shutter, mdv):
    sc = bar_scene(96, mdv / 96, shutter)
    got = simulated(sc, 96, mdv / 96)
    for key in ("yuan2013_model", "footprint_model"):
        assert got[key] >= 0, key


@pytest.mark.parametrize("name, rolling", [("tao2012_ibis5_rolling_1_5_10", True),
                                           ("ning2019_gmax0504_hdr", False)])
def test_mtf_mismatch_figure_says_what_its_curves_leave_out_and_marks_the_design(name,
                                                                                rolling):
    """plan --plot's mtf_mismatch.png said "global shutter" for a rolling-shutter scene and
    did not mark the design point: the curves are without the skew; the star is the
    design, with its skew."""
    import tdicam
    p = tdicam.plan(tdicam.Scene.example(name))
    fig = dict(p.figures())["mtf_mismatch.png"]
    ax = fig.axes[1]
    title = ax.get_title()
    assert ("rolling shutter's skew" in title) == rolling
    assert ("global shutter" in title and "star" not in title) == (not rolling)
    star = [ln for ln in ax.get_lines() if ln.get_label().startswith("design: M = ")]
    assert len(star) == 1
    design = p.to_dict()["design"]
    assert star[0].get_ydata()[0] == pytest.approx(design["mtf_nyquist"][0]["system"])
