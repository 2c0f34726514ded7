"""Scene-file schema and loader (tdicam/scene/loader.py)."""

import dataclasses
import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

from tdicam.errors import TdicamError
from tdicam.model.physics import plan
from tdicam.scene.loader import BUNDLED_IMAGES, Scene, load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[1]
BUNDLED_SCENE = ROOT / "scenes" / "orbit_600km_1m_96.toml"
ORBIT = "[orbit]\naltitude_km = 600\ngsd_m = 1.0\n"


def picture(path, a, mode=None):
    """Save the array ``a`` as a PNG (with PIL ``mode``) or a TIFF; returns ``path``."""
    if path.suffix.lower() in (".tif", ".tiff"):
        import tifffile
        tifffile.imwrite(path, a, **({"photometric": "rgb", "planarconfig": "separate"}
                                     if mode == "planar" else {}))
    else:
        from PIL import Image
        Image.fromarray(a, mode).save(path)
    return path


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def load_text(tmp_path, text):
    return load_scene(write(tmp_path, text))


def error_of(tmp_path, text):
    with pytest.raises(TdicamError) as exc:
        load_text(tmp_path, text)
    message = str(exc.value)
    assert "\n" not in message
    return message


# ------------------------------------------------------------------ good scenes


def test_bundled_scene():
    sc = load_scene(BUNDLED_SCENE)
    assert isinstance(sc, Scene)
    assert sc.orbit.altitude_km == 600.0 and sc.orbit.gsd_m == 1.0 and sc.turntable is None
    assert (sc.sensor.columns, sc.sensor.rows, sc.sensor.bits) == (1280, 1024, 12)
    assert sc.tdi.stages == (96,) and sc.tdi.domain == "digital"
    assert sc.line_period_s == pytest.approx(1.0 / plan.ground_speed(600e3), rel=1e-15)
    assert sc.timing.m0 == 96
    assert sc.target.kind == "bars" and sc.target.period_px == 4.0
    assert sc.source.endswith("orbit_600km_1m_96.toml")


def test_defaults(tmp_path):
    sc = load_text(tmp_path, ORBIT)
    s = sc.sensor
    assert (s.columns, s.rows, s.bits, s.pitch_um) == (1280, 1024, 12, 5.5)
    assert s.conversion_gain_e_per_dn == pytest.approx(20000 / 4096)
    assert (s.read_noise_e, s.dark_current_e_per_s, s.prnu, s.dsnu_e) == (0, 0, 0, 0)
    assert s.row_blanking_us == 3.5 and s.pixel_clock_mhz is None and s.row_time_s is None
    assert s.gains == (1.0,) and s.shutter == "rolling"
    assert sc.timing is None
    assert sc.tdi.stages == (1,) and sc.tdi.direction == "forward" and sc.tdi.output_bits == 12
    assert sc.motion.dv_over_v == (0.0,) and sc.motion.drift_deg == 0.0
    assert sc.target.kind == "flat" and sc.target.signal_e == 1000.0
    assert sc.pipeline.blocks == ("tdi",) and sc.pipeline.after_lines("median3") is None
    assert sc.pipeline.hdr.threshold_dn == 3072
    assert (sc.run.lines, sc.run.seed, sc.run.fidelity, sc.run.rtl) == (256, 0, "auto", None)


def test_full_scene_and_sweeps(tmp_path):
    (tmp_path / "img").mkdir()
    picture(tmp_path / "img" / "field.PNG", np.full((8, 8), 200, np.uint8))
    sc = load_text(tmp_path, """
        [turntable]
        angular_speed_rad_s = 0.05
        distance_m = 0.5
        [target]
        kind = "image"
        path = "img/field.PNG"
        signal_e = 0
        [sensor]
        columns = 640
        rows = 512
        pitch_um = 5.2
        gains = [1.9, 1.0]
        pixel_clock_mhz = 48
        row_blanking_us = 3.5
        shutter = "global"
        [tdi]
        stages = [1, 4, 8]
        domain = "digital"
        direction = "reverse"
        output = "saturate"
        output_bits = 10
        [motion]
        dv_over_v = [0.0, -0.1, 0.25]
        drift_deg = 1.5
        [pipeline]
        blocks = ["cds", "nuc", "hdr", "median3", "tdi"]
        [pipeline.hdr]
        threshold_dn = 3500
        band_dn = 100
        [pipeline.median3]
        edge_enhance = true
        [run]
        lines = 64
        fidelity = "exact"
        [run.rtl]
        crop = [0, 0, 32, 16]
        simulator = "icarus"
        pixels_per_clock = 1
    """)
    assert sc.orbit is None
    assert sc.line_period_s == pytest.approx(5.2e-6 / (0.05 * 0.5))
    assert sc.target.path == (tmp_path / "img" / "field.PNG").resolve()
    assert sc.tdi.stages == (1, 4, 8) and sc.motion.dv_over_v == (0.0, -0.1, 0.25)
    assert sc.sensor.row_time_s == pytest.approx(3.5e-6 + 640 / 48e6)
    assert sc.timing.m0 == 12
    assert sc.pipeline.after_lines("median3") is False and sc.pipeline.median3.edge_enhance
    assert sc.pipeline.hdr.threshold_dn == 3500 and sc.pipeline.hdr.band_dn == 100
    assert sc.run.rtl.crop == (0, 0, 32, 16) and sc.run.rtl.pixels_per_clock == 1
    d = sc.to_dict()
    assert d["tdi"]["stages"] == [1, 4, 8] and isinstance(d["target"]["path"], str)


def test_scene_is_frozen(tmp_path):
    sc = load_text(tmp_path, ORBIT)
    with pytest.raises(dataclasses.FrozenInstanceError):
        sc.sensor.rows = 5
    with pytest.raises(dataclasses.FrozenInstanceError):
        sc.tdi = None


def test_bundled_image_and_max_frame_rate(tmp_path):
    sc = load_text(tmp_path, ORBIT + """
        [target]
        kind = "image"
        image = "camera"
        [sensor]
        max_frame_rate_hz = 650
        [tdi]
        stages = 96
    """)
    assert sc.target.image == "camera" and "camera" in BUNDLED_IMAGES
    assert sc.sensor.available_frame_rate_hz == pytest.approx(650.0)


def test_overrides_and_labels(tmp_path):
    path = write(tmp_path, ORBIT + "[tdi]\nstages = 8\n")
    sc = load_scene(path, overrides={"tdi": {"stages": 16}})
    assert sc.tdi.stages == (16,) and sc.orbit.gsd_m == 1.0
    with pytest.raises(TdicamError, match=r"^--stages = 0 is out of range; valid: 1..inf$"):
        load_scene(path, overrides={"tdi": {"stages": 0}}, labels={"tdi.stages": "--stages"})
    sc = load_scene(path, overrides={"orbit": None,
                                     "turntable": {"angular_speed_rad_s": 1.0, "distance_m": 1.0}})
    assert sc.orbit is None and sc.turntable.distance_m == 1.0


def test_scene_from_dict():
    sc = scene_from_dict({"orbit": {"altitude_km": 500, "gsd_m": 2}, "tdi": {"stages": 4}})
    assert sc.orbit.line_period_s == pytest.approx(float(plan.orbit_line_period(500e3, 2.0)))


# ------------------------------------------------------------------ file-level errors


def test_missing_file(tmp_path):
    with pytest.raises(TdicamError, match="scene file not found"):
        load_scene(tmp_path / "nope.toml")


def test_invalid_toml(tmp_path):
    assert "invalid TOML" in error_of(tmp_path, "[orbit\naltitude_km = 600\n")


def test_unknown_section_did_you_mean(tmp_path):
    msg = error_of(tmp_path, ORBIT + "[sensr]\nrows = 10\n")
    assert msg == "[sensr]: unknown section; did you mean 'sensor'?"


def test_section_not_a_table(tmp_path):
    assert error_of(tmp_path, "sensor = 5\n" + ORBIT) == "[sensor]: must be a table, got 5"


@pytest.mark.parametrize("text, expected", [
    (ORBIT + "[turntable]\nangular_speed_rad_s = 1\ndistance_m = 1\n", "got both"),
    ("[sensor]\nrows = 10\n", "got neither"),
])
def test_exactly_one_motion_section(tmp_path, text, expected):
    msg = error_of(tmp_path, text)
    assert msg.startswith("[orbit]: a scene needs exactly one of [orbit] and [turntable]")
    assert expected in msg


# ------------------------------------------------------------------ key-level errors


BAD_KEYS = [
    # range
    ("[sensor]\nread_noise_e = -1\n", "[sensor].read_noise_e = -1 is out of range; valid: 0..1000000"),
    ("[sensor]\nfill_factor = 0\n", "[sensor].fill_factor = 0 is out of range; valid: (0, 1]"),
    ("[sensor]\nbits = 40\n", "[sensor].bits = 40 is out of range; valid: 1..24"),
    ("[sensor]\nprnu = 1.0\n", "[sensor].prnu = 1.0 is out of range; valid: [0, 1)"),
    ("[sensor]\npitch_um = -5.5\n", "[sensor].pitch_um = -5.5 is out of range; valid: 0.1..1000"),
    ("[target]\nsignal_e = -3.0\n", "[target].signal_e = -3.0 is out of range; valid: 0..1000000000000"),
    ("[tdi]\nstages = 0\n", "[tdi].stages = 0 is out of range; valid: 1..inf"),
    ("[tdi]\nstages = [4, 0]\n",
     "[tdi].stages (entry 1 of the list) = 0 is out of range; valid: 1..inf"),
    ("[tdi]\nstages = []\n", "[tdi].stages: must not be an empty list"),
    ("[motion]\ndv_over_v = [0.0, 1.0]\n",
     "[motion].dv_over_v (entry 1 of the list) = 1.0 is out of range; valid: (-1, 1)"),
    ("[motion]\ndrift_deg = 90\n", "[motion].drift_deg = 90 is out of range; valid: (-90, 90)"),
    ("[run]\nlines = 0\n", "[run].lines = 0 is out of range; valid: 1..inf"),
    ("[run]\ntolerance = 0\n", "[run].tolerance = 0 is out of range; valid: (0, 1)"),
    ("[target]\nkind = \"bars\"\nperiod_px = 1\n",
     "[target].period_px = 1 is out of range; valid: 2..inf"),
    ("[target]\nkind = \"bars\"\ncontrast = 1.5\n",
     "[target].contrast = 1.5 is out of range; valid: (0, 1]"),
    ("[target]\nkind = \"siemens\"\nspokes = 2\n",
     "[target].spokes = 2 is out of range; valid: 4..720"),
    # types
    ("[sensor]\nrows = 1024.0\n", "[sensor].rows: must be an integer, got 1024.0"),
    ("[sensor]\nrows = true\n", "[sensor].rows: must be an integer, got true"),
    ("[sensor]\nread_noise_e = \"5\"\n", "[sensor].read_noise_e: must be a number, got '5'"),
    ("[sensor]\nread_noise_e = nan\n", "[sensor].read_noise_e: must be a finite number, got nan"),
    ("[pipeline]\nblocks = [\"tdi\", \"median3\"]\n[pipeline.median3]\nedge_enhance = 1\n",
     "[pipeline.median3].edge_enhance: must be true or false, got 1"),
    # choices
    ("[sensor]\nshutter = \"rolling-shutter\"\n",
     "[sensor].shutter: must be one of 'rolling', 'global', got 'rolling-shutter'; "
     "did you mean 'rolling'?"),
    ("[tdi]\ndomain = \"analog\"\n", "[tdi].domain: must be one of 'digital', 'charge', "
     "got 'analog'"),
    ("[run]\nfidelity = 3\n", "[run].fidelity: must be one of 'exact', 'fast', 'auto', got 3"),
    # unknown keys, with and without a close match
    ("[sensor]\nread_noise = 3\n",
     "[sensor].read_noise: unknown key; did you mean 'read_noise_e'?"),
    ("[tdi]\nzzz = 3\n", "[tdi].zzz: unknown key; valid: direction, domain, output, "
     "output_bits, stages"),
]


@pytest.mark.parametrize("extra, expected", BAD_KEYS)
def test_bad_keys(tmp_path, extra, expected):
    assert error_of(tmp_path, ORBIT + extra) == expected


@pytest.mark.parametrize("text, expected", [
    ("[orbit]\naltitude_km = -1\ngsd_m = 1\n",
     "[orbit].altitude_km = -1 is out of range; valid: 0..100000"),
    ("[orbit]\naltitude_km = 600\ngsd_m = 0\n", "[orbit].gsd_m = 0 is out of range; valid: 0.001..100000"),
    ("[orbit]\naltitude_km = 600\n", "[orbit].gsd_m: missing (required)"),
    ("[orbit]\naltitude_km = 600\ngsd = 1\n", "[orbit].gsd: unknown key; did you mean 'gsd_m'?"),
    ("[turntable]\nangular_speed_rad_s = 0\ndistance_m = 1\n",
     "[turntable].angular_speed_rad_s = 0 is out of range; valid: 1e-06..1000"),
    ("[turntable]\nangular_speed_rad_s = 1\ndistance_m = 0.0\n",
     "[turntable].distance_m = 0.0 is out of range; valid: 0.001..1000"),
])
def test_bad_motion_platform(tmp_path, text, expected):
    assert error_of(tmp_path, text) == expected


# ------------------------------------------------------------------ target


def test_image_file_must_exist(tmp_path):
    msg = error_of(tmp_path, ORBIT + "[target]\nkind = \"image\"\npath = \"missing.png\"\n")
    assert msg.startswith("[target].path: file not found:") and "missing.png" in msg


def test_image_path_relative_to_scene_file(tmp_path, monkeypatch):
    sub = tmp_path / "scenes"
    sub.mkdir()
    picture(sub / "a.tif", np.full((8, 8), 0.5, np.float32))
    monkeypatch.chdir(tmp_path)  # the cwd must not matter
    sc = load_scene(write(sub, ORBIT + "[target]\nkind = \"image\"\npath = \"a.tif\"\n"))
    assert sc.target.path == (sub / "a.tif").resolve()


_RGB = np.random.default_rng(1).integers(0, 256, (9, 12, 3), dtype=np.uint8)
_OPAQUE = np.full((9, 12, 1), 255, np.uint8)


@pytest.mark.parametrize("name, a, mode, msg", [
    ("two.png", np.full((2, 2), 9, np.uint8), None, "2 x 2 pixels; need at least 8 x 8"),
    ("line.png", np.full((1, 40), 9, np.uint8), None, "1 x 40 pixels; need at least 8 x 8"),
    ("narrow.tif", np.ones((40, 7), np.float32), None, "40 x 7 pixels; need at least 8 x 8"),
    ("rgba.png", np.concatenate([_RGB, _OPAQUE - 1], axis=2), "RGBA",
     "the alpha channel is not opaque in 108 pixels; flatten the picture onto a background"),
    ("la.png", np.concatenate([_RGB[..., :1], _OPAQUE // 2], axis=2), "LA",
     "the alpha channel is not opaque in 108 pixels"),
    ("five.tif", np.ones((9, 12, 5), np.uint8), None, "shape 9 x 12 x 5 (several pages, "
                                                      "planar channels or more than 4"),
    ("planar.tif", np.ones((3, 9, 12), np.uint8), "planar", "shape 3 x 9 x 12 (several pages"),
    ("neg.tif", np.full((9, 12), -0.5, np.float32), None, "108 negative values (smallest "
                                                          "-0.5); a radiance is >= 0"),
    ("nan.tif", np.full((9, 12), np.nan, np.float32), None,
     "picture contains NaN or infinite values"),
    ("cplx.tif", np.ones((9, 12), np.complex64), None, "pixels of type complex64 are not grey "
                                                       "levels"),
])
def test_bad_pictures_are_refused_with_the_scene(tmp_path, name, a, mode, msg):
    """A picture the target cannot use is refused when the scene is read, in one line that
    names the key, the file and the problem (issue 18: a 2 x 2 picture and an RGBA one with
    transparent pixels ran)."""
    path = picture(tmp_path / name, a, mode)
    got = error_of(tmp_path, ORBIT + f'[target]\nkind = "image"\npath = "{name}"\n')
    assert got.startswith(f"[target].path {str(path.resolve())!r}: {msg}"), got


def test_picture_conversions(tmp_path):
    """Palette, 16-bit, opaque RGBA / LA and float pictures give the documented grey levels
    (a palette PNG used to give its palette indices)."""
    from PIL import Image
    from tdicam.model.physics.targets import load_image
    grey = _RGB @ np.array([0.299, 0.587, 0.114]) / 255
    pal = Image.fromarray(_RGB).convert("P", palette=Image.Palette.ADAPTIVE, colors=256)
    pal.save(tmp_path / "pal.png")
    want = np.asarray(pal.convert("RGB")) @ np.array([0.299, 0.587, 0.114]) / 255
    assert np.allclose(load_image(tmp_path / "pal.png"), want, atol=1e-12)
    rgba = picture(tmp_path / "rgba.png", np.concatenate([_RGB, _OPAQUE], axis=2), "RGBA")
    assert np.allclose(load_image(rgba), grey, atol=1e-12)
    la = picture(tmp_path / "la.png", np.concatenate([_RGB[..., :1], _OPAQUE], axis=2), "LA")
    assert np.allclose(load_image(la), _RGB[..., 0] / 255, atol=1e-12)
    codes = np.arange(9 * 12, dtype=np.uint16).reshape(9, 12) * 600
    p16 = tmp_path / "deep.png"
    Image.fromarray(codes).save(p16)
    assert np.allclose(load_image(p16), codes / 65535, atol=1e-12)
    f = picture(tmp_path / "f.tif", (codes / 2.0).astype(np.float32))
    assert np.allclose(load_image(f), codes / codes.max(), atol=1e-6)
    assert not load_image(f).flags.writeable


def test_image_must_be_png_or_tiff(tmp_path):
    (tmp_path / "a.jpg").write_bytes(b"x")
    msg = error_of(tmp_path, ORBIT + "[target]\nkind = \"image\"\npath = \"a.jpg\"\n")
    assert msg == "[target].path: must be a PNG or TIFF file (.png, .tif, .tiff), got 'a.jpg'"


@pytest.mark.parametrize("target, expected", [
    ("kind = \"image\"\n", "[target].path: kind = 'image' needs exactly one of"),
    ("kind = \"image\"\nimage = \"camera\"\npath = \"x.png\"\n", "got both"),
    ("kind = \"image\"\nimage = \"camra\"\n",
     "[target].image: unknown bundled image 'camra'; did you mean 'camera'?"),
    ("kind = \"edge\"\nperiod_px = 4\n",
     "[target].period_px: not used with kind = 'edge' (it belongs to kind 'bars')"),
    ("kind = \"flat\"\ncontrast = 0.5\n", "[target].contrast: not used with kind = 'flat'"),
    ("kind = \"barz\"\n", "[target].kind: must be one of 'image', 'bars', 'edge', 'siemens', "
     "'flat', got 'barz'; did you mean 'bars'?"),
])
def test_bad_target(tmp_path, target, expected):
    msg = error_of(tmp_path, ORBIT + "[target]\n" + target)
    assert msg.startswith("[target].") and expected in msg


# ------------------------------------------------------------------ sensor cross-checks


@pytest.mark.parametrize("sensor, expected", [
    ("gains = [1.0, 2.0, 3.0]\n", "[sensor].gains: must be a list of one or two gains"),
    ("gains = 4.9\n", "[sensor].gains: must be a list of one or two gains, got 4.9"),
    ("gains = [0.8, 4.9]\n",
     "[sensor].gains: two gains must be [high, low] with high > low, got [0.8, 4.9]"),
    ("gains = [4.9, 0]\n", "[sensor].gains (entry 1 of the list) = 0 is out of range; valid: (0, 1000000]"),
    ("pixel_clock_mhz = 100\nmax_frame_rate_hz = 650\n",
     "[sensor].max_frame_rate_hz: give either [sensor].pixel_clock_mhz"),
    ("pixel_clock_mhz = 0\n", "[sensor].pixel_clock_mhz = 0 is out of range; valid: 0.001..1000000"),
])
def test_bad_sensor(tmp_path, sensor, expected):
    assert error_of(tmp_path, ORBIT + "[sensor]\n" + sensor).startswith(expected)


# ------------------------------------------------------------------ stages vs window


def test_stages_above_sensor_rows(tmp_path):
    msg = error_of(tmp_path, ORBIT + "[sensor]\nrows = 64\n[tdi]\nstages = [8, 65]\n")
    assert msg.startswith("[tdi].stages: must be <= 64 (the sensor rows")


def test_stages_above_m0(tmp_path):
    # 1280 px at 100 MHz plus 3.5 us blanking: T_row 16.3 us, 144.76 us / 16.3 us -> M0 = 8
    msg = error_of(tmp_path, ORBIT + "[sensor]\npixel_clock_mhz = 100\n[tdi]\nstages = 9\n")
    assert msg.startswith("[tdi].stages: must be <= M0 = 8 (rows read in one line period")
    assert msg.endswith("got 9")
    sc = load_text(tmp_path, ORBIT + "[sensor]\npixel_clock_mhz = 100\n[tdi]\nstages = 8\n")
    assert sc.timing.m0 == 8


def test_stages_with_m0_zero(tmp_path):
    msg = error_of(tmp_path, ORBIT + "[sensor]\npixel_clock_mhz = 1\n")
    assert msg.startswith("[tdi].stages: no TDI is possible") and "M0 = 0" in msg


def test_tao2012_default_blanking_limits_96_stages(tmp_path):
    # with Tao et al. 2012's 3.5 us blanking even the fastest pixel clock the schema takes gives 41
    msg = error_of(tmp_path, ORBIT + "[sensor]\npixel_clock_mhz = 1e6\n[tdi]\nstages = 96\n")
    assert "M0 = 41" in msg
    assert math.floor(plan.orbit_line_period(600e3, 1.0) / 3.5e-6) == 41


# ------------------------------------------------------------------ pipeline and run


@pytest.mark.parametrize("pipeline, expected", [
    ("blocks = [\"cds\", \"nuc\"]\n", "[pipeline].blocks: must contain 'tdi' once"),
    ("blocks = [\"tdi\", \"tdi\"]\n", "[pipeline].blocks: block 'tdi' is listed 2 times"),
    ("blocks = [\"tdi\", \"median5\"]\n",
     "[pipeline].blocks: unknown block 'median5'; did you mean 'median3'?"),
    ("blocks = [\"tdi\", \"cds\"]\n", "[pipeline].blocks: cds, nuc and hdr act on single"),
    ("blocks = [\"nuc\", \"cds\", \"tdi\"]\n", "[pipeline].blocks: cds, nuc and hdr act on single"),
    ("blocks = \"tdi\"\n", "[pipeline].blocks: must be a list of block names, got 'tdi'"),
    ("blocks = [\"tdi\"]\n[pipeline.hdr]\nthreshold_dn = 100\n",
     "[pipeline].hdr: options given but 'hdr' is not in [pipeline].blocks"),
    ("blocks = [\"hdr\", \"tdi\"]\n[pipeline.hdr]\nthreshold_dn = 4095\n",
     "[pipeline.hdr].threshold_dn = 4095 is out of range; valid: 1..4094"),
    ("blocks = [\"hdr\", \"tdi\"]\n[pipeline.hdr]\nthreshold = 100\n",
     "[pipeline.hdr].threshold: unknown key; did you mean 'threshold_dn'?"),
    ("blocks = [\"tdi\"]\n[pipeline.tdi]\nx = 1\n", "[pipeline.tdi].x: unknown key"),
])
def test_bad_pipeline(tmp_path, pipeline, expected):
    assert error_of(tmp_path, ORBIT + "[pipeline]\n" + pipeline).startswith(expected)


NUC = "blocks = [\"nuc\", \"tdi\"]\n[pipeline.nuc]\n"


@pytest.mark.parametrize("nuc, expected", [
    ("flash = \"usb\"\n", "[pipeline.nuc].flash: "),
    ("bad_blocks = 3\n", "[pipeline.nuc].bad_blocks: is a NAND flash fault: set flash"),
    ("flash = \"none\"\nflip_single = 0.1\n", "[pipeline.nuc].flip_single: is a NAND"),
    ("flash = \"nand\"\nflip_single = 1.5\n",
     "[pipeline.nuc].flip_single = 1.5 is out of range; valid: 0..1"),
    ("flash = \"nand\"\nflip_single = 0.6\nflip_double = 0.6\n",
     "[pipeline.nuc].flip_double: flip_single + flip_double must be <= 1"),
    ("flash = \"nand\"\nbad_blocks = 4096\n",
     "[pipeline.nuc].bad_blocks = 4096 is out of range; valid: 0..4095"),
    ("flash = \"nand\"\nbad_blocks = 1.5\n", "[pipeline.nuc].bad_blocks"),
    ("flash = \"nand\"\nseed = -1\n", "[pipeline.nuc].seed = -1 is out of range"),
    ("flash = \"nand\"\necc = false\n", "[pipeline.nuc].ecc: must be true with flash"),
    ("flash = \"nand\"\ngain_frac_bits = 15\n",
     "[pipeline.nuc].gain_frac_bits: must be <= 14 with flash"),
    ("flash = \"nand\"\nbad_block = 3\n",
     "[pipeline.nuc].bad_block: unknown key; did you mean 'bad_blocks'?"),
])
def test_bad_nuc_flash(tmp_path, nuc, expected):
    """[pipeline.nuc] flash options: one-line errors naming the key (issue 22)."""
    msg = error_of(tmp_path, ORBIT + "[pipeline]\n" + NUC + nuc)
    assert msg.startswith(expected) and "\n" not in msg, msg


def test_nuc_flash_options(tmp_path):
    sc = load_text(tmp_path, ORBIT + "[pipeline]\n" + NUC + "flash = \"nand\"\n"
                   "bad_blocks = 10\nflip_single = 0.1\nflip_double = 0.01\nseed = 4\n")
    o = sc.pipeline.nuc
    assert (o.flash, o.bad_blocks, o.flip_single, o.flip_double, o.seed) == \
        ("nand", 10, 0.1, 0.01, 4)
    assert load_text(tmp_path, ORBIT).pipeline.nuc.flash == "none"


def test_median_after_tdi(tmp_path):
    sc = load_text(tmp_path, ORBIT + "[pipeline]\nblocks = [\"cds\", \"tdi\", \"median3\"]\n")
    assert sc.pipeline.after_lines("median3") is True


@pytest.mark.parametrize("rtl, expected", [
    ("crop = [0, 0, 2000, 16]\n", "[run.rtl].crop: must lie inside the 1280 x 256 output"),
    ("crop = [0, 0, 16]\n", "[run.rtl].crop: must be four integers"),
    ("crop = [-1, 0, 16, 16]\n", "[run.rtl].crop: needs x0, y0 >= 0"),
    ("simulator = \"modelsim\"\n", "[run.rtl].simulator: must be one of 'icarus', 'verilator'"),
    ("pixels_per_clock = 3\n", "[run.rtl].pixels_per_clock: must be one of 1, 2, 4, 8, got 3"),
    ("pixels_per_clock = 8\ncrop = [0, 0, 12, 16]\n",
     "[run.rtl].pixels_per_clock: 8 does not divide the [run.rtl].crop width 12: a beat "
     "carries 8 pixels of a line"),
])
def test_bad_rtl(tmp_path, rtl, expected):
    assert error_of(tmp_path, ORBIT + "[run.rtl]\n" + rtl).startswith(expected)


def test_rtl_pixels_per_clock(tmp_path):
    """1, 2, 4 or 8 pixels per clock dividing the width co-simulated: the crop's, or
    without a crop the sensor's columns."""
    for ppc in (1, 2, 4, 8):
        sc = load_text(tmp_path, ORBIT + f"[run.rtl]\npixels_per_clock = {ppc}\n")
        assert sc.run.rtl.pixels_per_clock == ppc
    sc = load_text(tmp_path, ORBIT + "[run.rtl]\npixels_per_clock = 4\ncrop = [3, 0, 12, 8]\n")
    assert sc.run.rtl.crop == (3, 0, 12, 8)
    msg = error_of(tmp_path, ORBIT + "[sensor]\ncolumns = 1284\n[run.rtl]\npixels_per_clock = 8\n")
    assert msg == ("[run.rtl].pixels_per_clock: 8 does not divide the [sensor].columns 1284: "
                   "a beat carries 8 pixels of a line")


def test_rtl_csr_key(tmp_path):
    """``[run.rtl].csr``: false by default (the loose-port top); true for a scene with the
    sensor's lanes (the lanes' top co-simulated through its bus); true without lanes, or
    not a boolean, one line naming the key."""
    assert load_text(tmp_path, ORBIT + "[run.rtl]\n").run.rtl.csr is False
    lanes = ROOT / "scenes" / "ning2019_gmax0504_system_lanes.toml"
    text = lanes.read_text().replace("[run.rtl]\n", "[run.rtl]\ncsr = true\n", 1)
    assert load_text(tmp_path, text).run.rtl.csr is True
    msg = error_of(tmp_path, ORBIT + "[run.rtl]\ncsr = true\n")
    assert msg.startswith("[run.rtl].csr: true needs the sensor's lanes ([sensor.lvds])")
    assert "\n" not in msg
    assert error_of(tmp_path, ORBIT + "[run.rtl]\ncsr = 1\n").startswith(
        "[run.rtl].csr: must be true or false")


def test_rtl_needs_digital_tdi(tmp_path):
    msg = error_of(tmp_path, ORBIT + "[tdi]\ndomain = \"charge\"\n[run.rtl]\n")
    assert msg == ("[run.rtl]: needs [tdi].domain = 'digital' (charge-domain TDI sums in the "
                   "sensor: there is no gateware chain to co-simulate)")


def test_scene_with_a_byte_order_mark_is_read(tmp_path):
    """Some editors start UTF-8 files with a byte-order mark: the scene is the same."""
    p = tmp_path / "bom.toml"
    p.write_bytes(b"\xef\xbb\xbf" + BUNDLED_SCENE.read_bytes())
    a, b = load_scene(p).to_dict(), load_scene(BUNDLED_SCENE).to_dict()
    assert a.pop("source") != b.pop("source") and a == b


@pytest.mark.parametrize("path,msg", [("/dev/zero", "/dev/zero: not a scene file: it goes on "
                                                    "past 4 MiB"),
                                      (".", "scene file is a directory: '.'")])
def test_files_that_are_not_scenes(path, msg):
    with pytest.raises(TdicamError, match="^" + msg.replace(".", r"\.").replace("(", r"\(")):
        load_scene(path)


def test_median3_enhance_gain_reaches_engine_and_chain():
    """``[pipeline.median3] enhance_gain``: one entry (the block's registry entry) sets it for
    the scene engine's golden run and for the gateware chain."""
    import numpy as np
    from tdicam import engine
    from tdicam.chain import design
    base = {"orbit": {"altitude_km": 600.0, "gsd_m": 1.0}, "target": {"kind": "bars"},
            "sensor": {"bits": 12, "columns": 64, "rows": 8}, "tdi": {"stages": [4]},
            "run": {"lines": 16}}
    outs = []
    for gain in (1, 3):
        sc = scene_from_dict({**base, "pipeline": {"blocks": ["tdi", "median3"], "median3": {
            "edge_enhance": True, "enhance_gain": gain}}})
        step = design.chain_plan(sc).steps[-1]
        assert step.params["enhance_gain"] == gain
        outs.append(engine.simulate(sc, impact=False).output)
    assert not np.array_equal(outs[0], outs[1])
    with pytest.raises(TdicamError, match=r"enhance_gain: is the edge enhancement's gain"):
        scene_from_dict({**base, "pipeline": {"blocks": ["tdi", "median3"],
                                              "median3": {"enhance_gain": 3}}})
