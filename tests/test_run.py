"""``tdicam run``: end to end on small scenes, files and report, one-line errors."""

import json
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
    ("[target]\nsignal_e = -5\n", "[target].signal_e = -5 is out of range; valid: 0..inf"),
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
    from tdicam.model.targets import bundled_image
    from tdicam.scene import BUNDLED_IMAGES
    for name in BUNDLED_IMAGES:
        a = bundled_image(name)
        assert a.ndim == 2 and 0.0 <= a.min() and a.max() <= 1.0 and a.max() > 0.2, name
