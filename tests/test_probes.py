"""Hostile-input probes of the newest surfaces (issue 32): the ``[sensor.lvds]`` section and
the LVDS front end in ``tdicam verilog|synth|export pipeline`` (``--phy``, ``--ppc``),
``[run.rtl] pixels_per_clock``, ``tdicam plan --scene``, ``tdicam bench pipeline`` and the
public API (wrong types, NaN/inf, huge ints, empty arrays, wrong dtypes and shapes).

One table per surface: each row is a command (or call), the exit status it must give and a
fragment of its one-line message. Every row is refused before any Verilog is generated or
simulator built (fast)."""

import numpy as np
import pytest

import tdicam
from tdicam import blocks
from tdicam.cli import main

BASE = ('[orbit]\naltitude_km = 600\ngsd_m = 1.0\n[sensor]\ncolumns = 16\nrows = 8\n'
        'bits = 12\ngains = [2.0, 1.0]\n[tdi]\nstages = 4\n[pipeline]\n'
        'blocks = ["hdr", "tdi"]\n[run]\nlines = 4\n')
LANES = "lanes_per_gain = 4\n"


def _text(lvds=LANES, rtl=None, sensor=""):
    text = BASE.replace("gains = [2.0, 1.0]\n", "gains = [2.0, 1.0]\n" + sensor)
    if rtl is not None:
        text += "[run.rtl]\n" + rtl
    if lvds is not None:
        text += "[sensor.lvds]\n" + lvds
    return text


LV = "[sensor.lvds]."
# (scene text, fragment): refused by `tdicam verilog pipeline` and `tdicam plan --scene`
SCENES = [
    (_text("lanes_per_gain = 0\n"), LV + "lanes_per_gain = 0 is out of range; valid: 1..128"),
    (_text("lanes_per_gain = 99999999999999999999\n"),
     LV + "lanes_per_gain = 99999999999999999999 is out of range"),
    (_text('lanes_per_gain = "4"\n'), LV + "lanes_per_gain: must be an integer, got '4'"),
    (_text("lanes_per_gain = true\n"), LV + "lanes_per_gain: must be an integer, got true"),
    (_text("lanes_per_gain = nan\n"), LV + "lanes_per_gain: must be an integer, got nan"),
    (_text("lanes_per_gain = [4]\n"), LV + "lanes_per_gain: must be an integer, got [4]"),
    (_text(""), LV + "lanes_per_gain: 40 (the default, the GMAX0504's; give it) does not "
                     "divide [sensor].columns = 16"),
    (_text(LANES + "word_bits = 11\n"), LV + "word_bits: must be 10 or 12, got 11"),
    (_text(LANES + "word_bits = 12.0\n"), LV + "word_bits: must be an integer, got 12.0"),
    (_text(LANES + "word_bits = 10\n"), LV + "word_bits: 10 is narrower than the 12-bit"),
    (_text(LANES + "bit_rate_mbps = nan\n"), LV + "bit_rate_mbps: must be a finite number"),
    (_text(LANES + "bit_rate_mbps = inf\n"), LV + "bit_rate_mbps: must be a finite number"),
    (_text(LANES + "bit_rate_mbps = 1e308\n"), LV + "bit_rate_mbps = 1e+308 is out of range"),
    (_text(LANES + "bit_rate_mbps = 0.5\n"), LV + "bit_rate_mbps = 0.5 is out of range"),
    (_text(LANES + 'mapping = ""\n'), LV + "mapping: must be one of 'interleaved', got ''"),
    (_text(LANES + "mapping = []\n"), LV + "mapping: must be one of 'interleaved', got []"),
    (_text(LANES + "train_word = 4096\n"), LV + "train_word = 4096 is out of range; valid: "
                                                "0..4095"),
    (_text(LANES + "train_word = 4095\n"), LV + "train_word: 0xfff repeats under rotation"),
    (_text(LANES + 'train_word = "0xB92"\n'), LV + "train_word: must be an integer"),
    (_text(LANES + "tap_ps = 0\n"), LV + "tap_ps = 0 is out of range; valid: 1..1000"),
    (_text(LANES + "eye_centre_taps = []\n"), LV + "eye_centre_taps: must be one number or "
                                                  "one per lane (8 = lanes_per_gain x 2"),
    (_text(LANES + "eye_centre_taps = [nan,1,1,1,1,1,1,1]\n"),
     LV + "eye_centre_taps: must be a finite number (entry 0 of the list), got nan"),
    (_text(LANES + "eye_centre_taps = 31.5\n"), LV + "eye_centre_taps = 31.5 is out of range"),
    (_text(LANES + "eye_centre_taps = true\n"), LV + "eye_centre_taps: must be a number"),
    (_text(LANES + "eye_width_taps = {a = 1}\n"), LV + "eye_width_taps: must be a number, "
                                                      "got a table"),
    (_text(LANES + "eye_width_taps = 1e9\n"), LV + "eye_width_taps = 1000000000.0 is out of "
                                                   "range; valid: 0..21.3333"),
    (_text(LANES + "jitter_ps = inf\n"), LV + "jitter_ps: must be a finite number, got inf"),
    (_text(LANES + "jitter_ps = 3334\n"), LV + "jitter_ps = 3334 is out of range"),
    (_text(LANES + "lanes = 4\n"), LV + "lanes: unknown key"),
    (_text(None, sensor="lvds = 5\n"), "[sensor.lvds]: must be a table, got 5"),
    (_text(None, sensor="lvds = [{lanes_per_gain = 4}]\n"), "[sensor.lvds]: must be a table"),
    (_text(LANES).replace("bits = 12", "bits = 16"),
     LV + "word_bits: 12 is narrower than the 16-bit pixels"),
    (_text(LANES + "word_bits = 10\n").replace("bits = 12", "bits = 10").replace(
        "rows = 8", "rows = 1022"),
     LV + "word_bits: 10-bit words cannot number the 1022 rows of a frame ([sensor].rows): "
          "the row header counts to 1021"),
    (_text(rtl="pixels_per_clock = 0\n"), "[run.rtl].pixels_per_clock: must be one of 1, 2, "
                                          "4, 8, got 0"),
    (_text(rtl="pixels_per_clock = 16\n"), "[run.rtl].pixels_per_clock: must be one of"),
    (_text(rtl="pixels_per_clock = 1.5\n"), "[run.rtl].pixels_per_clock: must be an integer"),
    (_text(rtl='pixels_per_clock = "8"\n'), "[run.rtl].pixels_per_clock: must be an integer"),
    (_text(rtl="pixels_per_clock = nan\n"), "[run.rtl].pixels_per_clock: must be an integer"),
    (_text(None, rtl="pixels_per_clock = 1180591620717411303424\n"),
     "[run.rtl].pixels_per_clock: must be one of 1, 2, 4, 8, got 1180591620717411303424"),
    (_text(rtl="pixels_per_clock = 8\n").replace("columns = 16", "columns = 12"),
     "[run.rtl].pixels_per_clock: 8 does not divide the [sensor].columns 12"),
]


def _one_line(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("text,fragment", SCENES, ids=[f"scene{i}" for i in range(len(SCENES))])
def test_scene_probes(text, fragment, tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(text)
    out = tmp_path / "o.v"
    for argv in (["verilog", "pipeline", "--scene", str(f), "-o", str(out)],
                 ["plan", "--scene", str(f)]):
        assert main(argv) == 2
        assert fragment in _one_line(capsys)
    assert not out.exists()


# (arguments after `--scene S`, scene with lanes?, fragment): tdicam verilog|synth|export
FLAGS = [
    (["--ppc", "0"], True, "--ppc = 0 is not valid; valid: 1, 2, 4, 8"),
    (["--ppc", "3"], False, "--ppc = 3 is not valid; valid: 1, 2, 4, 8"),
    (["--ppc", "-1"], True, "--ppc = -1 is not valid"),
    (["--ppc", "99999999999999999999"], True, "--ppc = 99999999999999999999 is not valid"),
    (["--ppc", "nan"], True, "argument --ppc: invalid int value: 'nan'"),
    (["--ppc", "1e3"], True, "argument --ppc: invalid int value: '1e3'"),
    (["--ppc", "8"], True, "pipeline: lvds (the chain's source): pixels per clock (--ppc or "
                           "[run.rtl].pixels_per_clock) = 8 does not divide "
                           "[sensor.lvds].lanes_per_gain = 4"),
    (["--phy", "XILINX7"], True, "argument --phy: invalid choice: 'XILINX7'"),
    (["--phy", ""], True, "argument --phy: invalid choice: ''"),
    (["--phy", "xilinx7"], False, "pipeline: --phy = xilinx7 needs the sensor's lanes"),
    (["--stages", "0"], True, "--stages = 0 is out of range; valid: 1..128"),
    (["--stages", "99999999999999999999"], True, "--stages = 99999999999999999999 is out"),
    (["--lines", "0"], True, "--lines = 0 is out of range"),
    (["--lines", "-1"], False, "--lines = -1 is out of range"),
    (["--lines", "1000000000"], True, "--lines = 1000000000 is out of range"),
    (["--device", ""], True, "--device = '' is not known"),
    (["--memory", "ddr"], True, "but the scene has no [ddr] section"),
    (["--calib", "/dev/zero"], True, "/dev/zero: not a tdicam calibration image"),
    (["--calib", "/nonexistent.bin"], True, "calibration image not found"),
]


@pytest.mark.parametrize("cmd", ["verilog", "synth"])
@pytest.mark.parametrize("args,lanes,fragment", FLAGS, ids=[" ".join(r[0]) for r in FLAGS])
def test_pipeline_flag_probes(cmd, args, lanes, fragment, tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(_text(LANES if lanes else None))
    out = tmp_path / "o.v"
    argv = [cmd, "pipeline", "--scene", str(f), *args] + (["-o", str(out)] if cmd == "verilog"
                                                           else [])
    assert main(argv) == 2
    assert fragment in _one_line(capsys)
    assert not out.exists()


# (argv with {S} for the lanes scene, {D} for tmp_path, exit, fragment)
COMMANDS = [
    (["export", "pipeline", "--scene", "{S}", "--ppc", "3", "-o", "{D}/e"], 2,
     "--ppc = 3 is not valid"),
    (["export", "pipeline", "--scene", "{S}", "--lines", "0", "-o", "{D}/e"], 2,
     "--lines = 0 is out of range"),
    (["export", "pipeline", "--scene", "{S}", "-o", "{D}/e"], 2,
     "s.toml: the chain's input is the sensor's lanes ([sensor.lvds]); the export drives "
     "pixel beats"),
    (["verilog", "pipeline", "--scene", "/dev/zero", "-o", "{D}/o.v"], 2,
     "/dev/zero: not a scene file: it goes on past 4 MiB"),
    (["verilog", "pipeline", "--scene", "{D}", "-o", "{D}/o.v"], 2, "scene file is a directory"),
    (["verilog", "pipeline", "--scene", "{S}", "-o", "{D}"], 2, "cannot write (it is a directory)"),
    (["verilog", "pipeline", "--scene", "{S}", "-o", "/nonexistent/dir/x.v"], 2,
     "cannot write (no folder '/nonexistent/dir')"),
    (["verilog", "pipeline", "--scene", "scenes/orbit_chain.toml", "--phy", "xilinx7", "-o",
      "{D}/o.v"], 2, "--phy = xilinx7 needs the sensor's lanes"),
    (["plan", "--scene", "{S}", "--pixel-clock-mhz", "1e308"], 2,
     "--pixel-clock-mhz = 1e+308 is out of range"),
    (["plan", "--scene", "{S}", "--fpga-clock-mhz", "nan"], 2, "--fpga-clock-mhz = nan is out"),
    (["plan", "--scene", "{S}", "--stages", "0"], 2, "--stages = 0 is out of range"),
    (["plan", "--scene", "scenes/orbit_chain.toml", "--device", "bogus"], 2,
     "--device = 'bogus' is not known"),
    (["bench", "pipeline", "--from-json", "/dev/zero"], 2, "not a tdicam bench JSON file"),
    (["bench", "pipeline", "--from-json", "{S}"], 2, "not a tdicam bench JSON file (not JSON"),
    (["bench", "pipeline", "--ppc", "3"], 2, "unrecognized arguments: --ppc 3"),
    (["bench", "bogus"], 2, "unknown benchmark 'bogus'"),
    (["run", "{S}", "-o", "{D}/run", "--lines", "0"], 2, "--lines = 0 is out of range"),
    (["verilog", "lvds", "--ppc", "3"], 2, "--ppc = 3 is not valid"),
    (["verilog", "lvds", "--phy", "bogus"], 2, "--phy = bogus is not valid; valid: none, xilinx7, ecp5"),
    (["verilog", "lvds", "--lanes", "99999999999999999999"], 2, "--lanes = 99999999999999999999"),
    (["verilog", "lvds", "--word-bits", "11"], 2, "--word-bits = 11 is not valid; valid: 10, 12"),
    (["verilog", "lvds", "--fifo-depth", "3"], 2, "--fifo-depth = 3 is not valid"),
    (["synth", "tdi", "--no-xilinx", "--record", "/dev/zero"], 2,       # before the tools
     "/dev/zero: not a synthesis record: it goes on past 4 MiB"),
    (["synth", "pipeline", "--scene", "{S}", "--record", "/nonexistent/d/r.json"], 2,
     "/nonexistent/d/r.json: cannot write (no folder '/nonexistent/d')"),
    (["sim", "lvds"], 2, "block lvds has no stream co-simulation"),
    (["sim", "tdi", "--idle", "nan"], 2, "--idle = nan is out of range; valid: [0, 1)"),
]


@pytest.mark.parametrize("argv,code,fragment", COMMANDS,
                         ids=[" ".join(r[0][:3]) + f"#{i}" for i, r in enumerate(COMMANDS)])
def test_command_probes(argv, code, fragment, tmp_path, capsys):
    s = tmp_path / "s.toml"
    s.write_text(_text())
    argv = [a.replace("{S}", str(s)).replace("{D}", str(tmp_path)) for a in argv]
    before = set(tmp_path.iterdir())
    assert main(argv) == code
    assert fragment in _one_line(capsys)
    assert set(tmp_path.iterdir()) == before          # nothing left at -o


# (edit of the lanes-faults system scene, fragment): refused by `tdicam run --dry-run` (and so
# by `tdicam run` before the scene simulation; the lane death was found only in the
# co-simulation, and not at all by --dry-run)
FAULTS = "scenes/ning2019_gmax0504_system_lanes_faults.toml"
DIES = "lane_dies = [0, 5]"
SYSTEM = [
    ((DIES, "lane_dies = [0, 4]"), "[run.rtl].lane_dies = [0, 4]: frame 4 is a reset frame"),
    ((DIES, "lane_dies = [0, 0]"), "[run.rtl].lane_dies = [0, 0]: frame 0 is a reset frame"),
    ((DIES, "lane_dies = [0, 21]"), "[run.rtl].lane_dies = [0, 21]: needs a lane 0..3 and a "
                                    "frame before the last 3 of the 24 the sensor sends"),
    ((DIES, "lane_dies = [0, 999999]"), "lane_dies = [0, 999999]: needs a lane 0..3"),
    (("crop = [0, 0, 32, 4]", "crop = [0, 28, 32, 4]"),
     "[run.rtl].lane_dies = [0, 5]: the crop must end 1 line(s) before [run].lines = 32"),
    (("lat_hi = 90", "lat_hi = 90\nlat_lo = 91"),
     "[ddr].lat_lo = 91 must be <= [ddr].lat_hi = 90"),
    (("lat_hi = 90", "lat_lo = 61"), "[ddr].lat_lo = 61 must be <= [ddr].lat_hi = 60 (the "
                                     "default)"),
    (("refresh_period = 2000", "refresh_period = 44"),
     "[ddr].refresh_cycles = 200 must be < [ddr].refresh_period = 44"),
    ((("refresh_period = 2000", "refresh_period = 1"), ("refresh_cycles = 200", "")),
     "[ddr].refresh_cycles = 44 (the default) must be < [ddr].refresh_period = 1"),
]


@pytest.mark.parametrize("edits,fragment", SYSTEM,
                         ids=[f"system{i}" for i in range(len(SYSTEM))])
def test_system_scene_probes(edits, fragment, tmp_path, capsys):
    text = open(FAULTS).read()
    for old, new in (edits if isinstance(edits[0], tuple) else (edits,)):
        assert old in text
        text = text.replace(old, new)
    f = tmp_path / "s.toml"
    f.write_text(text)
    assert main(["run", "--dry-run", str(f), "-o", str(tmp_path / "o")]) == 2
    assert fragment in _one_line(capsys)
    assert not (tmp_path / "o").exists()


def test_plan_of_the_bundled_chain_scene_is_an_answer(capsys):
    """orbit_chain's plan is a feasibility report (exit 0 or 1), never a refusal."""
    assert main(["plan", "--scene", "scenes/orbit_chain.toml"]) in (0, 1)
    out = capsys.readouterr().out
    assert "feasible:" in out and "whole chain" in out


def test_plan_names_the_lanes_whose_eyes_cannot_train(tmp_path, capsys):
    """A scene whose eyes no lane can train on planned 'feasible: yes' (every column would be
    invalid): the plan now says NO; one narrow lane is named, its columns invalid."""
    base = open("scenes/ning2019_gmax0504_system_lanes_faults.toml").read()
    assert main(["plan", "--scene", "scenes/ning2019_gmax0504_system_lanes_faults.toml"]) == 0
    assert ("lane eyes: lane(s) 3 of 4 cannot train (eye too narrow): their columns are "
            "invalid in every frame") in capsys.readouterr().out
    f = tmp_path / "dead.toml"
    f.write_text(base.replace("eye_width_taps = [20.0, 20.0, 20.0, 6.0]", "eye_width_taps = 0.0"))
    assert main(["plan", "--scene", str(f)]) == 1
    out = capsys.readouterr().out
    assert "lane eyes: no lane can train" in out and "feasible: NO (lane eyes)" in out


def test_plan_says_no_when_the_lanes_cannot_carry_the_frames(tmp_path, capsys):
    """One 300 Mbit/s lane per gain for 1280 columns x 1024 rows at the orbit's frame rate
    (10.2 Gbit/s a lane) was 'feasible: yes': the plan now checks the lanes' bit rate."""
    f = tmp_path / "o.toml"
    base = open("scenes/orbit_600km_1m_96.toml").read()
    f.write_text(base + "\n[sensor.lvds]\nlanes_per_gain = 1\n")
    assert main(["plan", "--scene", str(f)]) == 1
    out = capsys.readouterr().out
    assert "sensor lanes: 1 lanes x 300 Mbit/s / 12 bit = 25.0 M words/s, 25.0 M pixels/s " \
           "after each line's sync and header words; the window needs 848.86 M pixels/s: NO" \
           in out
    assert "feasible: NO (lane pixel rate)" in out
    f.write_text(base + "\n[sensor.lvds]\nlanes_per_gain = 40\n")     # the GMAX0504's 40
    assert main(["plan", "--scene", str(f)]) == 0
    assert "941.2 M pixels/s after each line's sync and header words; the window needs " \
           "848.86 M pixels/s: OK" in capsys.readouterr().out


# ---------------------------------------------------------------- the public API
def _lanes_scene():
    return tdicam.Scene.from_dict({"orbit": {"altitude_km": 600, "gsd_m": 1.0},
                                   "target": {"kind": "flat", "signal_e": 900.0},
                                   "sensor": {"columns": 16, "rows": 8, "bits": 12,
                                              "gains": [2.0, 1.0],
                                              "lvds": {"lanes_per_gain": 4}},
                                   "tdi": {"stages": 2},
                                   "pipeline": {"blocks": ["hdr", "tdi"]},
                                   "run": {"lines": 3, "fidelity": "exact"}})


NAN = float("nan")
FR = np.ones((2, 4, 8), np.uint16)
API = [
    ("Scene.load(123)", lambda: tdicam.Scene.load(123), "expected a file name, got int"),
    ("Scene.example([])", lambda: tdicam.Scene.example([]), "expected a name, got list"),
    ("Scene.from_dict([])", lambda: tdicam.Scene.from_dict([]), "must be a table of sections"),
    ("with_run(lines=nan)", lambda: _lanes_scene().with_run(lines=NAN),
     "lines must be an integer, got nan"),
    ("simulate(None)", lambda: tdicam.simulate(None), "expected a Scene or a scene file"),
    ("simulate(lines=2**70)", lambda: tdicam.simulate(_lanes_scene(), lines=2 ** 70),
     "lines = 1180591620717411303424 is out of range"),
    ("simulate(lines='3')", lambda: tdicam.simulate(_lanes_scene(), lines="3"),
     "lines must be an integer, got '3'"),
    ("simulate(seed=-1)", lambda: tdicam.simulate(_lanes_scene(), seed=-1), "seed = -1 is out"),
    ("simulate(fidelity=3)", lambda: tdicam.simulate(_lanes_scene(), fidelity=3),
     "fidelity = 3 is not valid"),
    ("simulate(force=5)", lambda: tdicam.simulate(_lanes_scene(), force=5),
     "force must be a list of effect names, got 5"),
    ("simulate(force='tdi')", lambda: tdicam.simulate(_lanes_scene(), force="tdi"),
     "force must be a list of effect names, got 'tdi'"),
    ("simulate(force=['nope'])", lambda: tdicam.simulate(_lanes_scene(), force=["nope"]),
     "unknown effect 'nope'"),
    ("simulate(labels=5)", lambda: tdicam.simulate(_lanes_scene(), labels=5),
     "labels must be a mapping"),
    ("plan(onchip_kbit=1e308)", lambda: tdicam.plan(onchip_kbit=1e308),
     "--onchip-kbit = 1e+308 is out of range"),
    ("plan(ddr_bits=3)", lambda: tdicam.plan(ddr_bits=3), "--ddr-bits = 3 is out of range"),
    ("plan(device=[])", lambda: tdicam.plan(device=[]), "--device = [] is not known"),
    ("plan(stages=[])", lambda: tdicam.plan(stages=[]), "--stages: must not be an empty list"),
    ("plan(gsd_m=[nan])", lambda: tdicam.plan(gsd_m=[NAN]), "--gsd-m: must be a finite number"),
    ("sweep(None)", lambda: tdicam.sweep(None), "sweep file: expected a file name"),
    ("blocks.get([])", lambda: blocks.get([]), "unknown block []"),
    ("blocks.get({})", lambda: blocks.get({}), "unknown block {}"),
    ("lvds.verilog(ppc='2' is fine; ppc=nan)", lambda: blocks.get("lvds").verilog(ppc=NAN),
     "--ppc must be an integer, got nan"),
    ("lvds.golden_model", lambda: blocks.get("lvds").golden_model({"frames": FR}),
     "block lvds has no golden function on scene arrays"),
    ("lvds.cosim(arrays)", lambda: blocks.get("lvds").cosim({"frames": FR}),
     "block lvds has no golden function on scene arrays"),
    ("tdi.golden_model(1-D)", lambda: blocks.get("tdi").golden_model(
        {"frames": np.zeros(8, np.uint16)}), "input 'frames' must be frames (..., rows, cols)"),
    ("tdi.golden_model(scalar)", lambda: blocks.get("tdi").golden_model(
        {"frames": np.uint16(3)}), "got shape ()"),
    ("median3.golden_model(scalar)", lambda: blocks.get("median3").golden_model(
        {"frames": np.uint16(3)}), "input 'frames' must be frames"),
    ("tdi.golden_model(float)", lambda: blocks.get("tdi").golden_model(
        {"frames": FR * 1.5}), "frames must be an integer array, got dtype float64"),
    ("tdi.golden_model(-1)", lambda: blocks.get("tdi").golden_model(
        {"frames": -FR.astype(np.int64)}), "frames has values outside 0..4095"),
    ("median3.golden_model(bool)", lambda: blocks.get("median3").golden_model(
        {"frames": FR.astype(bool)}), "got dtype bool"),
    ("tdi.cosim(empty)", lambda: blocks.get("tdi").cosim({"frames": FR[:0]}),
     "frames must be a non-empty integer array of pixel codes, got shape (0, 4, 8)"),
    ("tdi.cosim(float)", lambda: blocks.get("tdi").cosim({"frames": FR * 1.5}),
     "got shape (2, 4, 8), dtype float64"),
    ("median3.cosim(empty)", lambda: blocks.get("median3").cosim({"frames": FR[:0]}),
     "non-empty integer array"),
    ("tdi.cosim(idle=nan)", lambda: blocks.get("tdi").cosim(idle=NAN), "idle = nan is out"),
    ("tdi.cosim(sim='bogus')", lambda: blocks.get("tdi").cosim(sim="bogus"),
     "unknown simulator 'bogus'"),
]


@pytest.mark.parametrize("call,fragment", [r[1:] for r in API], ids=[r[0] for r in API])
def test_api_probes(call, fragment):
    with pytest.raises(tdicam.TdicamError) as e:
        call()
    assert fragment in str(e.value) and "\n" not in str(e.value)
