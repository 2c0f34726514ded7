"""Every ``tdicam run`` report answers the imaging questions: the SNR of every target (on a
region the target makes flat) and its gain over one read, PSNR and SSIM against the ideal
target for a picture, the per cent of pixels at full scale with a warning line when a stage
is saturated, and report.html with every figure inline. Each test fails on the code before
these were added (no ``region_snr``, ``vs_target``, ``clipping`` keys, no report.html)."""

import base64
import json
import textwrap
from html.parser import HTMLParser

import numpy as np
import pytest

from tdicam.cli import main
from tdicam.run.quality import MIN_REGION_PIXELS, fidelity, flat_region, relative

SCENE = """
[orbit]
altitude_km = 600
gsd_m = 1.0
[target]
kind = "{kind}"
signal_e = {signal}
{extra}
[sensor]
columns = 48
rows = 128
bits = 12
full_well_e = 20000.0
read_noise_e = 5.0
max_frame_rate_hz = 5000
[tdi]
stages = [1, 4]
[run]
lines = 24
fidelity = "fast"
"""


def run(tmp_path, capsys, kind="bars", signal=2000.0, extra=""):
    scene = tmp_path / f"{kind}.toml"
    scene.write_text(textwrap.dedent(SCENE.format(kind=kind, signal=signal, extra=extra)))
    out = tmp_path / "o"
    assert main(["run", str(scene), "-o", str(out), "--no-impact"]) == 0
    printed = capsys.readouterr().out
    rep = json.loads((out / "report.json").read_text())
    return rep, (out / "report.md").read_text(), printed, out


def test_a_bar_target_gets_a_measured_snr_and_its_gain_over_one_read(tmp_path, capsys):
    """The main job's target (bars) had no SNR: now on the bright bars, about sqrt(4) =
    6.02 dB better than one read at 4 stages, in the console, report.json and report.md."""
    rep, md, printed, _ = run(tmp_path, capsys)
    by_m = {r["stages"]: r["region_snr"] for r in rep["measurements"]}
    s4 = by_m[4]
    assert s4["pixels"] >= MIN_REGION_PIXELS and "brightest" in s4["region"]
    assert 4.5 < s4["gain_db"] < 7.5, s4
    assert abs(s4["output_db"] - s4["single_db"] - s4["gain_db"]) < 1e-9
    assert abs(by_m[1]["gain_db"]) < 1.5               # one stage: no gain
    assert f"m=4: SNR {s4['output_db']:.2f} dB, one read {s4['single_db']:.2f} dB, gain " \
           f"{s4['gain_db']:.2f} dB" in printed
    assert "## SNR on a flat region of the target" in md
    assert f"| 4 | {s4['region']} | {s4['pixels']} | {s4['output_db']:.2f} |" in md


def test_flat_region_of_bars_pictures_and_narrow_bars():
    bars = np.tile(np.repeat([1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0], 1), (10, 4))
    mask, how = flat_region(bars)
    assert "flat 3 x 3" in how and mask.any() and np.all(bars[mask] == 1.0)
    assert not mask[:, 3].any()                        # next to the dark bar: not flat
    narrow = np.tile([1.0, 1.0, 0.0, 0.0], (10, 8))    # 2-px bars: no flat 3 x 3 pixel
    mask, how = flat_region(narrow)
    assert "brightest level" in how and np.array_equal(mask, narrow == 1.0)
    # 5 x 5 steps: each level has 16 flat pixels (< 32), all four 64
    steps = np.repeat(np.repeat([[0.2, 0.5], [0.7, 0.4]], 5, axis=0), 5, axis=1)
    mask, how = flat_region(steps)
    assert how == "flat 3 x 3 pixels of the target, every level"
    assert len(np.unique(steps[mask])) == 4


def test_fidelity_scales_onto_the_target_and_measures_the_noise():
    """An image 100 + 50 t + Normal(0, 0.5) DN: after the fit, the error is 0.01 of the
    target's unit range: PSNR 40 dB; a noiseless image: infinite PSNR, SSIM 1."""
    rng = np.random.default_rng(1)
    t = rng.random((64, 64))
    f = fidelity(t, 100 + 50 * t + rng.normal(0, 0.5, t.shape), 100)
    assert abs(f["psnr_db"] - 40.0) < 0.3 and 0 < f["ssim"] < 1
    exact = fidelity(t, 300 + 7 * t, 0)
    assert exact["ssim"] == pytest.approx(1.0) and exact["psnr_db"] > 100
    assert fidelity(np.ones((8, 8)), np.ones((8, 8)), 0)["psnr_db"] is None


def test_an_image_target_gets_psnr_and_ssim_against_the_ideal_target(tmp_path, capsys):
    rep, md, printed, _ = run(tmp_path, capsys, kind="image", extra='image = "camera"')
    by_m = {r["stages"]: r for r in rep["measurements"]}
    f4, f1 = by_m[4]["vs_target"], by_m[1]["vs_target"]
    assert f4["data_range"] == 1.0 and "least-squares gain and offset" in f4["method"]
    assert 10 < f4["output"]["psnr_db"] < 60 and 0 < f4["output"]["ssim"] <= 1
    assert f4["output"]["ssim"] > f4["single"]["ssim"]  # 4 stages: less noise than one read
    assert by_m[4]["region_snr"]["gain_db"] > 2.0
    assert f"m=4: vs the ideal target: PSNR {f4['output']['psnr_db']:.2f} dB, SSIM " \
           f"{f4['output']['ssim']:.3f}" in printed
    assert "## PSNR and SSIM against the ideal target" in md and "data_range = 1" in md
    assert f"| 1 | {f1['output']['psnr_db']:.2f} |" in md


def test_a_saturated_scene_says_so_with_a_warning_line(tmp_path, capsys):
    """50,000 e- on a 20,000 e- well (the ADC's full scale, 4095 DN, is at the well): the
    well clips every pixel, and the read noise on top leaves most at 4095 DN; the console
    and report say so. 2,000 e-: no warning."""
    rep, md, printed, _ = run(tmp_path, capsys, kind="flat", signal=50000.0)
    warn = [ln for ln in printed.splitlines() if ln.startswith("WARNING: ")]
    assert len(warn) == 2
    for r, line in zip(rep["measurements"], warn):
        c, m = r["clipping"], r["stages"]
        assert c["raw"]["full_scale_dn"] == 4095 and c["output"]["full_scale_dn"] == 4095 * m
        raw, out = c["raw"]["at_full_scale_percent"], c["output"]["at_full_scale_percent"]
        assert raw > 80 and out > 30 and c["saturated"] == ["raw", "output"]
        assert line == (
            f"WARNING: m={m}: saturated: {raw:.1f} % of raw-exposure pixels at full scale "
            f"(4095 DN), {out:.1f} % of output pixels at full scale ({4095 * m} DN); the "
            f"images are clipped and their SNR and MTF measure the clipping (lower "
            f"[target].signal_e or the gain)")
        assert f"m={m}: at full scale: raw {raw:.1f} % (4095 DN), output {out:.1f} % " \
               f"({4095 * m} DN)" in printed
        assert f"* **{line}**" in md
    assert "## Saturation and clipping" in md
    rep, md, printed, _ = run(tmp_path, capsys, kind="flat")
    assert "WARNING" not in printed and "WARNING" not in md
    assert all(r["clipping"]["saturated"] == [] for r in rep["measurements"])
    assert "m=4: at full scale: raw 0.0 % (4095 DN), output 0.0 %" in printed


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images, self.links, self.tables, self.headings, self._h = {}, [], 0, [], None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images[a["alt"]] = a["src"]
        for key in ("href", "src"):
            if key in a and tag != "img":
                self.links.append(a[key])
        self.tables += tag == "table"
        if tag in ("h1", "h2"):
            self._h = ""

    def handle_data(self, data):
        if self._h is not None:
            self._h += data

    def handle_endtag(self, tag):
        if tag in ("h1", "h2") and self._h is not None:
            self.headings.append(self._h)
            self._h = None


def test_report_html_embeds_every_figure_the_report_lists(tmp_path, capsys):
    rep, md, _, out = run(tmp_path, capsys)
    page = _Page()
    page.feed((out / "report.html").read_text())
    pngs = [f for f in rep["files"] if f.endswith(".png")]
    assert {"crop.png", "profile.png", "mtf.png", "tdi.png"} <= set(pngs)
    assert sorted(page.images) == sorted(pngs)
    for name, src in page.images.items():             # the file's bytes, inline
        assert src.startswith("data:image/png;base64,"), name
        assert base64.b64decode(src.split(",", 1)[1]) == (out / name).read_bytes(), name
    assert page.links == []                            # nothing fetched from outside
    seps = [ln for ln in md.splitlines() if ln.startswith("|---|")]
    assert page.tables == len(seps) >= 4                # the same tables as report.md
    assert [h for h in page.headings if h != "Figures"] == \
        [ln.lstrip("# ") for ln in md.splitlines() if ln.startswith(("# ", "## "))]
    assert "`report.html`" in md


def test_relative_puts_images_of_any_gain_on_one_scale():
    rng = np.random.default_rng(2)
    signal = 1 + 0.1 * rng.standard_normal((16, 16))
    one, many = relative(64 + 100 * signal, 64), relative(10 + 9600 * signal, 10)
    np.testing.assert_allclose(one, many)
    assert abs(one.mean() - 1) < 1e-12


def test_crop_panels_share_one_relative_scale_and_a_difference_image_is_written(
        tmp_path, capsys, monkeypatch):
    """crop.png stretched each panel on its own (DN colour bars), so the noise TDI removes
    did not show: now both panels are signal / mean with one colour range; the output minus
    the ideal target is difference.png (not for a flat target: nothing to subtract)."""
    from matplotlib.axes import Axes
    shown = []
    real = Axes.imshow

    def imshow(self, arr, *a, **kw):
        shown.append((np.asarray(arr, np.float64), kw.get("vmin"), kw.get("vmax")))
        return real(self, arr, *a, **kw)
    monkeypatch.setattr(Axes, "imshow", imshow)
    rep, _, _, out = run(tmp_path, capsys, kind="flat")
    (raw, lo1, hi1), (tdi, lo2, hi2) = shown[:2]           # crop.png's two panels
    assert lo1 is not None and (lo1, hi1) == (lo2, hi2)
    assert abs(raw.mean() - 1) < 1e-9 and abs(tdi.mean() - 1) < 1e-9
    assert tdi.std() < raw.std() / 1.5       # 4 stages: about half the noise, on one scale
    assert "difference.png" not in rep["files"] and not (out / "difference.png").exists()
    shown.clear()
    rep, md, _, out = run(tmp_path, capsys, kind="image", extra='image = "camera"')
    assert "difference.png" in rep["files"] and "`difference.png`: " in md
    diff = shown[2][0]
    assert diff.shape == (24, 48) and abs(diff.mean()) < 0.05 and shown[2][1] == -shown[2][2]


def test_the_scene_places_the_figures_crop():
    """``[run].figure_crop``: crop.png and profile.png show the crop the scene places (an
    image scene's sky need not be the centre), moved in to fit; centred without it."""
    import tdicam
    sc = tdicam.Scene.example("orbit_600km_1m_96").with_run(lines=96)
    centred = dict(tdicam.simulate(sc, impact=False).figures())["crop.png"]
    assert "crop at column 608, line 16" in centred._suptitle.get_text()
    placed = sc.replace({"run.figure_crop": [1250, 10]})
    fig = dict(tdicam.simulate(placed, impact=False).figures())["crop.png"]
    assert "crop at column 1216, line 10" in fig._suptitle.get_text()      # moved in to fit
    with pytest.raises(tdicam.TdicamError, match=r"\[run\].figure_crop: must lie inside"):
        sc.replace({"run.figure_crop": [0, 96]})
