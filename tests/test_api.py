"""The public Python API (issue 31): every name in ``tdicam.__all__`` documented, ``import
tdicam`` light, and each function equal to the command that calls it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tdicam
from tdicam.cli import main
from tdicam.paths import SCENES


def test_public_names_are_documented():
    assert tdicam.__all__ == ["Scene", "Simulation", "simulate", "Plan", "plan", "sweep",
                              "examples", "blocks", "verilog", "cosimulate", "TdicamError"]
    for name in tdicam.__all__:
        obj = getattr(tdicam, name)
        doc = obj.__doc__ or ""
        assert doc.strip(), name
        if callable(obj) and not isinstance(obj, type) and name != "blocks":
            assert "Returns\n    -------" in doc, f"{name}: no numpydoc Returns section"
    for method in ("load", "from_dict", "example", "with_run"):
        assert "Returns" in getattr(tdicam.Scene, method).__doc__, method
    assert "Returns" in tdicam.blocks.Block.golden_model.__doc__
    assert "Public" in tdicam.__doc__ and "internal" in tdicam.__doc__


def test_import_is_light():
    code = ("import sys, tdicam; heavy = [m for m in ('tdicam.api', 'xarray', 'tdicam.engine', "
            "'amaranth') if m in sys.modules]; print(heavy, tdicam.__version__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[0] == "[]", out
    from importlib.metadata import version
    assert out[1] == version("tdicam") == tdicam.__version__
    assert "simulate" in dir(tdicam)
    with pytest.raises(AttributeError):
        tdicam.no_such_name


def test_examples_and_scene_constructors():
    ex = tdicam.examples()
    assert set(ex) == {p.stem for p in SCENES.glob("*.toml")}
    assert all(text and "\n" not in text for text in ex.values())
    sc = tdicam.Scene.example("orbit_600km_1m_96")
    assert sc == tdicam.Scene.load(SCENES / "orbit_600km_1m_96.toml")
    d = tdicam.Scene.from_dict({"orbit": {"altitude_km": 600.0, "gsd_m": 1.0}})
    assert d.line_period_s == pytest.approx(sc.line_period_s)
    assert sc.with_run(lines=8, seed=3).run.lines == 8
    with pytest.raises(tdicam.TdicamError, match="no bundled scene 'nope'; valid: "):
        tdicam.Scene.example("nope")
    with pytest.raises(tdicam.TdicamError, match="lines = 0 is out of range"):
        sc.with_run(lines=0)


def test_simulate_save_is_tdicam_run(tmp_path):
    """``simulate(...).save(dir)`` and ``tdicam run`` write the same files, the same arrays
    and the same measurements; the dataset holds the run's images and numbers."""
    path = SCENES / "tao2012_ibis5_rolling_1_5_10.toml"
    sim = tdicam.simulate(path, lines=16, impact=False)
    rep = sim.save(tmp_path / "api")
    assert main(["run", str(path), "--lines", "16", "--no-impact", "-o",
                 str(tmp_path / "cli")]) == 0
    cli = json.loads((tmp_path / "cli" / "report.json").read_text())
    assert sorted(rep["files"]) == sorted(cli["files"])
    for name in rep["files"]:
        if name.endswith((".npy", ".tif")):
            assert (tmp_path / "api" / name).read_bytes() == \
                (tmp_path / "cli" / name).read_bytes(), name
    strip = ("seconds", "lines_per_s", "exposure_pixels_per_s")
    rows = [{k: v for k, v in r.items() if k not in strip} for r in cli["measurements"]]
    assert [{k: v for k, v in r.items() if k not in strip} for r in rep["measurements"]] == rows
    ds = sim.dataset
    assert ds["tdi"].dims == ("line", "pixel") and ds["tdi"].attrs["units"] == "DN"
    assert np.array_equal(ds["tdi"].values, np.load(tmp_path / "cli" / "tdi.npy"))
    assert list(ds["stages"].values) == [1, 5, 10]
    gains = [r["snr"]["gain_db"] for r in cli["measurements"]]
    assert np.allclose(ds["snr_gain_db"].values[:, 0], gains)
    assert ds.attrs["tdicam"] == tdicam.__version__ and ds.attrs["seed"] == sim.scene.run.seed
    assert ds.attrs["scene"] == str(path)
    other = tdicam.simulate(path, lines=16, impact=False, seed=5).dataset
    assert other.attrs["seed"] == 5 and not np.array_equal(other["tdi"].values,
                                                           ds["tdi"].values)


def test_plan_is_tdicam_plan(capsys):
    p = tdicam.plan(stages=[12, 24], gsd_m=[2.0])
    assert main(["plan", "--stages", "12", "24", "--gsd-m", "2", "--json"]) == 0
    assert p.to_dict() == json.loads(capsys.readouterr().out)
    assert p.feasible is p.to_dict()["feasible"] and len(p.points) == 2
    assert p.text().splitlines()[0]
    with pytest.raises(tdicam.TdicamError, match="unknown option 'stage'"):
        tdicam.plan(stage=[12])
    with pytest.raises(tdicam.TdicamError, match="^ddr_efficiency = 2"):
        tdicam.plan(ddr_efficiency=2)


def test_sweep_from_a_dict(tmp_path, monkeypatch):
    monkeypatch.chdir(SCENES)
    import tdicam.sweeps.runner                  # the sweep service's package does not shadow the API
    assert tdicam.sweep is tdicam.api.sweep and callable(tdicam.sweep)
    ds = tdicam.sweep({"scene": "tao2012_ibis5_rolling_1_5_10.toml",
                       "axes": {"tdi.stages": [1, 4]}, "set": {"run.lines": 16}},
                      tmp_path / "sw", serial=True)
    assert ds.sizes["tdi.stages"] == 2 and ds.attrs["failed"] == 0
    assert list(ds["status"].values.ravel()) == ["ok", "ok"]
    assert (tmp_path / "sw" / "sweep.nc").is_file()


def test_block_tools():
    tdi = tdicam.blocks.get("tdi")
    text = tdicam.verilog("tdi", width=16, stages=4)
    assert text.startswith(f"// Generated by tdicam {tdicam.__version__}: block tdi\n")
    assert "module tdi(" in text
    frames = np.random.default_rng(1).integers(0, 4096, (6, 4, 16), dtype=np.uint16)
    out = tdi.golden_model({"frames": frames}, stages=4)["out"]
    assert out.shape[0] == 6 - 4 + 1 and out.shape[-1] == 16     # one line per full window
    with pytest.raises(tdicam.TdicamError, match="has no parameter nope; valid: width"):
        tdicam.verilog("tdi", nope=1)


def test_scenes_example_and_version_commands(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out.split("sweeps:")[0].splitlines()
    assert out[0] == "scenes:"
    assert [line.split()[0] for line in out[1:]] == sorted(tdicam.examples())
    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"tdicam {tdicam.__version__}\n"
    assert main(["run", "--example", "nope"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("tdicam: error: no bundled scene 'nope'; valid: ")
    assert main(["run", "--example", "orbit_600km_1m_96", "--dry-run"]) == 0
    assert "out/orbit_600km_1m_96" in capsys.readouterr().out


# -- a uniform API (issue 48 item 5) ----------------------------------------------------------

def test_scene_replace_validates_as_the_file_would():
    sc = tdicam.Scene.example("orbit_600km_1m_96")
    new = sc.replace({"sensor.read_noise_e": 5, "tdi.stages": [4, 8]})
    assert (new.sensor.read_noise_e, new.tdi.stages) == (5.0, (4, 8))
    assert sc.sensor.read_noise_e != 5.0 and new.source == sc.source     # the original stays
    assert new == tdicam.Scene.load(sc.source, overrides={"sensor": {"read_noise_e": 5},
                                                          "tdi": {"stages": [4, 8]}})
    # with_run and replace compose, in either order
    a = sc.with_run(lines=16, fidelity="fast").replace({"sensor.read_noise_e": 5})
    b = sc.replace({"sensor.read_noise_e": 5}).with_run(lines=16, fidelity="fast")
    assert a == b and (a.run.lines, a.run.fidelity) == (16, "fast")
    # None removes the key: its default applies, as a None override of the file does
    assert sc.replace({"sensor.read_noise_e": None}) == tdicam.Scene.load(
        sc.source, overrides={"sensor": {"read_noise_e": None}}) != sc
    for bad, msg in [({"sensor.read_noise_e": -1}, r"\[sensor\].read_noise_e = -1 is out of"),
                     ({"sensor.nope": 1}, r"\[sensor\].nope: unknown key"),
                     ({"sensor": 1}, "scene keys are section.key paths"),
                     ([("a.b", 1)], "expected a mapping of 'section.key'")]:
        with pytest.raises(tdicam.TdicamError, match=msg):
            sc.replace(bad)


def test_with_run_takes_the_fidelity():
    sc = tdicam.Scene.example("orbit_600km_1m_96")
    assert sc.with_run(fidelity="exact").run.fidelity == "exact"
    with pytest.raises(tdicam.TdicamError, match="fidelity = 'slow' is not valid; valid: exact"):
        sc.with_run(fidelity="slow")


def test_simulation_figures_and_coordinate_units(tmp_path):
    sim = tdicam.simulate(tdicam.Scene.example("orbit_600km_1m_96"), lines=16, impact=False)
    figs = sim.figures()
    names = [n for n, _ in figs]
    assert names[:2] == ["crop.png", "profile.png"] and "mtf.png" in names
    assert all(hasattr(f, "savefig") for _, f in figs)
    rep = sim.save(tmp_path / "o")
    assert set(names) <= set(rep["files"])
    units = {k: v.attrs.get("units") for k, v in sim.dataset.coords.items()}
    assert units == {"line": "line", "pixel": "px", "stages": "1", "dv_over_v": "1"}
