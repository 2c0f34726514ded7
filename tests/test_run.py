"""``tdicam run``: end to end on small scenes, files and report, one-line errors."""

import json
import math
import os
import textwrap
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tdicam.cli import main

ROOT = Path(__file__).resolve().parents[1]
SMALL = """
[orbit]
altitude_km = 600
gsd_m = 1.0
[target]
kind = "flat"
signal_e = 2000.0
[sensor]
columns = 64
rows = 128
read_noise_e = 5.0
black_level_dn = 32.0
max_frame_rate_hz = 650
[tdi]
stages = [1, 4]
[run]
lines = 32
"""


def write(tmp_path, text, name="s.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def test_run_writes_images_figures_reports(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(write(tmp_path, SMALL)), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "lines/s" in text and "\r" not in text          # no progress bar off a TTY
    for f in ("target.png", "raw_exposure.png", "tdi.png", "raw_exposure.tif", "tdi.tif",
              "snr_vs_stages.png", "report.json", "report.md"):
        assert (out / f).is_file(), f
    rep = json.loads((out / "report.json").read_text())
    names = [e["name"] for e in rep["effects"]]
    assert names[0] == "optics" and "tdi" in names
    assert {r["stages"] for r in rep["measurements"]} == {1, 4}
    assert rep["speed"]["lines"] == 32 and rep["speed"]["real_time_lines_per_s"] > 6900
    assert Image.open(out / "tdi.png").size == (64, 32)
    tif = np.asarray(Image.open(out / "tdi.tif"))
    assert tif.dtype == np.uint16 and tif.shape == (32, 64)
    md = (out / "report.md").read_text()
    assert "| effect | ran |" in md and "eq 28" in md


def test_run_bundled_orbit_scene_fast(tmp_path):
    out = tmp_path / "orbit"
    assert main(["run", str(ROOT / "scenes" / "orbit_600km_1m_96.toml"), "-o", str(out),
                 "--lines", "64", "--fidelity", "fast", "--no-impact"]) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["speed"]["fidelity"] == "fast" and rep["measurements"][0]["mtf"]["measured"] > 0.5
    assert (out / "mtf.png").is_file()


BAD = [
    ("[target]\nkind = \"flat\"\nsignal = 3\n", "[target].signal: unknown key"),
    ("[sensor]\ncolumns = \"wide\"\n", "[sensor].columns: must be an integer"),
    ("[tdi]\nstages = 200\n[sensor]\nmax_frame_rate_hz = 650\n", "[tdi].stages: must be <= M0"),
    ("[target]\nsignal_e = -5\n",
     "[target].signal_e = -5 is out of range; valid: 0..1000000000000"),
    ("[target]\nkind = \"image\"\npath = \"nope.png\"\n", "[target].path: file not found"),
    ("[optics]\npsf_sigma_px = -1\n", "[optics].psf_sigma_px = -1 is out of range; valid: 0..inf"),
    ("[target]\nkind = \"bars\"\nprofile = \"triangle\"\n", "[target].profile: must be one of"),
]


@pytest.mark.parametrize("body,msg", BAD)
def test_bad_scenes_one_line_errors(tmp_path, capsys, body, msg):
    p = write(tmp_path, "[orbit]\naltitude_km = 600\ngsd_m = 1.0\n" + body)
    assert main(["run", str(p), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and msg in err, err


def test_missing_scene_file(tmp_path, capsys):
    assert main(["run", str(tmp_path / "none.toml")]) == 2
    assert "scene file not found" in capsys.readouterr().err


def test_corrupt_image_file(tmp_path, capsys):
    (tmp_path / "bad.png").write_bytes(b"not a png")
    p = write(tmp_path, "[orbit]\naltitude_km = 600\ngsd_m = 1.0\n"
                        "[target]\nkind = \"image\"\npath = \"bad.png\"\n[run]\nlines = 4\n"
                        "[sensor]\ncolumns = 16\n")
    assert main(["run", str(p), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "[target].path: cannot read image" in err and err.count("\n") == 0


def test_user_png_target(tmp_path):
    img = (np.arange(32 * 48).reshape(32, 48) % 256).astype(np.uint8)
    Image.fromarray(img).save(tmp_path / "pic.png")
    p = write(tmp_path, "[orbit]\naltitude_km = 600\ngsd_m = 1.0\n"
                        "[target]\nkind = \"image\"\npath = \"pic.png\"\nsignal_e = 500\n"
                        "[run]\nlines = 16\n[sensor]\ncolumns = 24\n[tdi]\nstages = 2\n")
    assert main(["run", str(p), "-o", str(tmp_path / "o"), "--no-impact"]) == 0


def test_bundled_images_load():
    from tdicam.model.physics.targets import bundled_image
    from tdicam.scene.loader import BUNDLED_IMAGES
    for name in BUNDLED_IMAGES:
        a = bundled_image(name)
        assert a.ndim == 2 and 0.0 <= a.min() and a.max() <= 1.0 and a.max() > 0.2, name


def _strict_load(path):
    def bad(name):
        raise ValueError(f"{path}: non-strict JSON constant {name}")
    return json.loads(Path(path).read_text(), parse_constant=bad)


@pytest.mark.parametrize("scene", sorted(p.name for p in (ROOT / "scenes").glob("*.toml")))
def test_bundled_scene_reports_are_strict_json(tmp_path, scene):
    """Every bundled scene's report.json parses with a strict parser (no Infinity/NaN;
    issue 18: flat_snr_sweep_96 wrote "psnr_db": Infinity)."""
    from tdicam.scene.loader import load_scene
    from tdicam.run.runner import run_scene
    sc = load_scene(ROOT / "scenes" / scene)
    run_scene(sc, tmp_path, lines=16, rtl=False, progress=False)
    rep = _strict_load(tmp_path / "report.json")
    for e in rep["effects"]:
        imp = e["impact"] or {}
        if "psnr_db" in imp and imp["psnr_db"] is None:
            assert "no change" in imp["note"]


def test_flat_zero_signal_reports_no_snr(tmp_path, capsys):
    """signal_e = 0 on a flat target: a report, not a math domain error (issue 18)."""
    text = SMALL.replace("signal_e = 2000.0", "signal_e = 0.0")
    no_noise = text.replace("read_noise_e = 5.0", "read_noise_e = 0.0")  # s_CMOS = 0
    for k, src in enumerate((text, text.replace("[tdi]", "dark_current_e_per_s = 100.0\n[tdi]"),
                             no_noise)):
        out = tmp_path / f"out{k}"
        assert main(["run", str(write(tmp_path, src)), "-o", str(out)]) == 0
        rep = _strict_load(out / "report.json")
        for r in rep["measurements"]:
            assert r["snr"]["snr1_db"] is None and "no signal" in r["snr"]["note"]
            assert r["snr"]["single_db"] is None or math.isfinite(r["snr"]["single_db"])


def test_bar_mtf_below_noise_is_not_measurable(tmp_path):
    """A bar contrast far below the noise: no MTF number, a note saying why (issue 18:
    contrast 1e-6 reported a measured MTF of 23.9 and a CTF-based MTF of 2106)."""
    bars = SMALL.replace('kind = "flat"', 'kind = "bars"\nperiod_px = 4.0\ncontrast = 1e-6')
    out = tmp_path / "out"
    assert main(["run", str(write(tmp_path, bars)), "-o", str(out)]) == 0
    rep = _strict_load(out / "report.json")
    for r in rep["measurements"]:
        t = r["mtf"]
        assert t["measured"] is None and t["measured_ctf"] is None
        assert "not measurable" in t["note"] and "noise" in t["note"]
    assert "not measurable" in (out / "report.md").read_text()
    full = SMALL.replace('kind = "flat"', 'kind = "bars"\nperiod_px = 4.0\ncontrast = 1.0')
    out2 = tmp_path / "out2"
    assert main(["run", str(write(tmp_path, full, "f.toml")), "-o", str(out2)]) == 0
    for r in _strict_load(out2 / "report.json")["measurements"]:
        assert 0.3 < r["mtf"]["measured"] < 1.1 and "note" not in r["mtf"]


@pytest.mark.parametrize("contrast,columns", [(1e-3, 16), (1e-3, 64), (3e-3, 64), (1.0, 64)])
def test_ctf_follows_the_noise_rule_and_nothing_above_one_unexplained(contrast, columns):
    """The (pi/4) CTF takes the profile's min and max, which noise dominates at low contrast
    (contrast 1e-3 gave a CTF-based MTF of 2.83 while the fit said 0.958): it is 'not
    measurable' below MIN_MODULATION_SNR x the noise of those extremes; at full contrast it
    agrees with the fitted MTF. An MTF or CTF above 1 always comes with a note saying why."""
    from tdicam.engine import simulate
    from tdicam.run.measure import measure
    from tdicam.scene.loader import load_scene
    sc = load_scene(ROOT / "scenes" / "orbit_600km_1m_96.toml", overrides={
        "target": {"contrast": contrast}, "sensor": {"columns": columns}, "run": {"lines": 128}})
    t = measure(sc, simulate(sc, impact=False))["mtf"]
    assert t["measured"] is not None and abs(t["measured"] - t["footprint_model"]) < 0.1
    if contrast < 0.01:
        assert t["measured_ctf"] is None and "(pi/4) CTF not measurable" in t["note"]
    else:
        assert abs(t["measured_ctf"] - t["measured"]) < 0.05 and "note" not in t
    for v in (t["measured"], t["measured_ctf"]):
        assert v is None or v <= 1.0 or "> 1" in t.get("note", "")


def test_mtf_above_one_says_why():
    """The reason given for an MTF above 1: within the fit's noise, or the edge
    enhancement of the median3 block."""
    from tdicam.run.measure import _above_one
    from tdicam.scene.loader import load_scene
    sc = load_scene(ROOT / "scenes" / "ning2019_chain.toml")
    assert _above_one(sc, 0.9, 0.01, 0.95) is None
    assert "within the noise" in _above_one(sc, 1.02, 0.01, None)
    assert "edge enhancement" in _above_one(sc, 1.3, 0.01, None)
    assert "harmonics" in _above_one(sc, 0.9, 0.01, 1.2)


def test_saturated_bars_have_no_measured_mtf(tmp_path):
    """Bright bars over the full well: the output is clipped flat, so no measured MTF and a
    note (the hostile pass of issue 18: it reported a measured MTF of 0.000); bars just below
    the well still measure one."""
    from tdicam.run.measure import measure, saturation_e
    from tdicam.scene.loader import load_scene
    from tdicam import engine
    path = write(tmp_path, SMALL.replace('kind = "flat"', 'kind = "bars"\nprofile = "sine"\n'
                                                           'period_px = 4.0\ncontrast = 0.5'))
    sc = load_scene(path)
    cap = saturation_e(sc, sc.tdi.stages[0])
    for signal, sat in ((50 * cap, True), (0.6 * cap, False)):
        s = load_scene(path, overrides={"target": {"signal_e": signal}})
        t = measure(s, engine.simulate(s, impact=False))["mtf"]
        assert t["saturated"] is sat and (t["measured"] is None) is sat, (signal, t)
        if sat:
            assert t["note"].startswith("not measurable: saturated: the bright bars' signal")
        else:
            assert 0.3 < t["measured"] < 1.1 and "note" not in t


def test_bar_mtf_planned_and_paper_model(tmp_path):
    """report.json/report.md print the planned MTF (tdicam.planning.predict.mtf_prediction) and the
    paper's model (Yuan et al. 2013 with the plain dV/V, no skew) beside the measured one; no
    negative MTF anywhere while M dV/V sweeps through 2, 3 and 6 (contrast reversal at the
    bar frequency 0.25, flagged) (issue 20)."""
    from tdicam.model.physics.mtf import mtf_system
    from tdicam.planning.predict import mtf_prediction
    from tdicam.scene.loader import load_scene
    src = SMALL.replace('kind = "flat"', 'kind = "bars"\nperiod_px = 4.0') \
        .replace("[tdi]", 'shutter = "rolling"\n[tdi]') \
        .replace("stages = [1, 4]", "stages = [1, 8]\n[motion]\ndv_over_v = [0.0, 0.25, "
                 "0.375, 0.75]")
    p = write(tmp_path, src)
    out = tmp_path / "out"
    assert main(["run", str(p), "-o", str(out), "--no-impact"]) == 0
    rep = _strict_load(out / "report.json")
    sc = load_scene(p)
    rows = [r for r in rep["measurements"] if "mtf" in r]
    assert len(rows) == 8
    for r in rows:
        t, m, dv = r["mtf"], r["stages"], r["dv_over_v"]
        pred = mtf_prediction(sc, m, dv, 0.25)
        assert t["planned"] == pytest.approx(pred["system"])
        assert t["planned_reversed"] == pred["reversed"]
        assert t["yuan2013_model"] == pytest.approx(float(mtf_system(0.25, m, dv, 1.0)))
        if m == 8 and dv == 0.75:
            assert t["planned_reversed"]
        if m == 8 and dv == 0.0:       # rolling-shutter skew: the camera, not the paper
            assert t["m_delta_effective"] != 0 and t["planned"] < t["yuan2013_model"]
    for r in rows:                     # every MTF value of the report is a modulus
        for k in ("measured", "measured_ctf", "planned", "yuan2013_model", "footprint_model"):
            assert r["mtf"][k] is None or r["mtf"][k] >= 0, (r, k)
    md = (out / "report.md").read_text()
    assert "paper's model" in md and "| planned |" in md and "contrast reversed" in md


def test_nand_flash_scene_reports_counters(tmp_path):
    """The bundled NAND scene: report.json and report.md give the flash counters (bad
    blocks, corrected / uncorrectable words, defaulted pixels) (issue 22)."""
    from tdicam.scene.loader import load_scene
    from tdicam.run.runner import run_scene
    sc = load_scene(ROOT / "scenes" / "ning2019_nand_calib_faults.toml")
    rep = run_scene(sc, tmp_path, lines=16, impact=False, rtl=False, progress=False)
    f = _strict_load(tmp_path / "report.json")["measurements"][0]["nand"][0]
    assert f == rep["measurements"][0]["nand"][0]
    assert f["bad_blocks"] == 200 and f["corrected_words"] > 0
    assert f["defaulted_pixels"] == 2 * f["uncorrectable_words"] > 0
    md = (tmp_path / "report.md").read_text()
    assert "## NUC coefficients from NAND flash" in md
    assert f"| {f['defaulted_pixels']} of {f['pixels']} |" in md


@pytest.mark.parametrize("dsnu", [0.0, 1.5])
def test_measured_snr_excludes_dark_like_the_prediction(tmp_path, dsnu):
    """One SNR definition (issue 18): signal = photo-electrons, dark charge excluded, in the
    measured and the predicted SNR alike. At 20 e- light and 2 e- dark the measured
    single-exposure SNR counted the dark as signal (+0.83 dB over the prediction)."""
    from tdicam.run.measure import SNR_DEFINITION, mean_dark_e, measure
    from tdicam import engine
    from tdicam.scene.loader import load_scene
    src = SMALL.replace("signal_e = 2000.0", "signal_e = 20.0") \
        .replace("read_noise_e = 5.0", "read_noise_e = 1.0\nconversion_gain_e_per_dn = 0.5\n"
                 f"dark_current_e_per_s = {2.0 / 144.76e-6:.6g}\ndsnu_e = {dsnu}") \
        .replace("columns = 64", "columns = 512").replace("lines = 32", "lines = 64") \
        .replace("stages = [1, 4]", "stages = 1")
    sc = load_scene(write(tmp_path, src))
    assert abs(sc.line_period_s - 144.76e-6) < 1e-7
    assert mean_dark_e(sc) == pytest.approx(2.0, abs=0.01 if dsnu == 0 else 0.2)
    s = measure(sc, engine.simulate(sc, fidelity="exact", impact=False))["snr"]
    assert s["signal_definition"] == SNR_DEFINITION and "dark charge excluded" in SNR_DEFINITION
    assert abs(s["single_db"] - s["snr1_db"]) < 0.15, s
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "s.toml"), "-o", str(out), "--no-impact"]) == 0
    assert "dark charge excluded" in (out / "report.md").read_text()


FULL = os.environ.get("TDICAM_FULL") == "1"
SCENES = sorted(p.name for p in (ROOT / "scenes").glob("*.toml"))
#: Short form: every bundled scene at most this wide, and the schema's pixel limit lowered
#: so that its largest [run].lines is this many lines (the code path of the real maximum:
#: the lines that are not a multiple of any chunk, the full output held and written).
SHORT_COLUMNS, SHORT_MAX_LINES = 64, 601


def _lines_values(sc, max_lines):
    return sorted({1, sc.run.lines, 457 if max_lines > 457 else max_lines - 1, max_lines})


def _check_run_at_lines(tmp_path, path, over, lines):
    """``tdicam run`` at ``[run].lines = lines``: either the schema refuses it in one line
    naming [run].lines (1 line for an along-track bar chart, a crop) or the run writes raw
    exposure and TDI output of exactly ``lines`` lines, the report agreeing; or the memory
    estimate refuses it in one line and -o is not created."""
    from tdicam.errors import TdicamError
    from tdicam.scene.loader import load_scene
    from tdicam.run.runner import run_scene
    over = {k: dict(v) for k, v in over.items()}
    over.setdefault("run", {})["lines"] = lines
    try:
        sc = load_scene(path, overrides=over)
    except TdicamError as exc:
        assert "[run].lines" in str(exc) and "\n" not in str(exc), exc
        return
    out = tmp_path / f"l{lines}"
    try:
        rep = run_scene(sc, out, impact=False, rtl=False, progress=False)
    except TdicamError as exc:
        assert "memory" in str(exc) and "[run].lines <=" in str(exc), exc
        assert not out.exists()
        return
    raw, tdi = np.load(out / "raw_exposure.npy"), np.load(out / "tdi.npy")
    cols = sc.sensor.columns
    assert raw.shape == tdi.shape == (lines, cols), (raw.shape, tdi.shape)
    assert np.asarray(Image.open(out / "raw_exposure.tif")).shape == (lines, cols)
    assert Image.open(out / "tdi.png").size == Image.open(out / "target.png").size == (cols, lines)
    assert rep["speed"]["lines"] == rep["configuration"]["lines"] == lines
    assert rep["configuration"]["memory"]["estimated_peak_bytes"] > 0


@pytest.mark.parametrize("scene", SCENES)
def test_every_lines_the_schema_allows_runs(tmp_path, monkeypatch, scene):
    """[run].lines at 1, the scene's default, a non-round value and the schema's maximum
    (lowered with the scene's width: see SHORT_MAX_LINES): raw exposure and TDI output have
    the lines asked for (fast runs gave 256 raw lines, then crashed above ~448 lines)."""
    from tdicam.scene import loader
    from tdicam.scene.loader import load_scene
    path = ROOT / "scenes" / scene
    base = load_scene(path)
    cols = min(base.sensor.columns, SHORT_COLUMNS)
    over = {"sensor": {"columns": cols}, "run": {"rtl": None}}
    monkeypatch.setattr(loader, "MAX_OUTPUT_PIXELS", cols * SHORT_MAX_LINES)
    for lines in _lines_values(base, SHORT_MAX_LINES):
        _check_run_at_lines(tmp_path, path, over, lines)
    with pytest.raises(loader.TdicamError, match=r"\[run\]\.lines: .* simulate at most 601"):
        load_scene(path, overrides={**over, "run": {"rtl": None, "lines": SHORT_MAX_LINES + 1}})


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="every bundled scene at its own width up to 2**27 output "
                                      "pixels (minutes, GBs): set TDICAM_FULL=1")
@pytest.mark.parametrize("scene", SCENES)
def test_every_lines_the_schema_allows_runs_full(tmp_path, scene):
    """The long form: each scene as written, at the real maximum [run].lines (runs, or is
    refused by the memory estimate in one line)."""
    from tdicam.scene.loader import MAX_OUTPUT_PIXELS, load_scene
    path = ROOT / "scenes" / scene
    base = load_scene(path)
    for lines in _lines_values(base, MAX_OUTPUT_PIXELS // base.sensor.columns):
        _check_run_at_lines(tmp_path, path, {"run": {"rtl": None}}, lines)
