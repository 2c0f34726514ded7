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
    (_text(""), LV + "lanes_per_gain: 40 (the default, the GMAX0504's; give it) is more "
                     "lanes than [sensor].columns = 16"),
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
    (["--stages", "0"], True, "--stages = 0 is out of range; valid: 1.."),
    (["--stages", "99999999999999999999"], True,
     "--stages: must be <= 8 (the sensor rows, [sensor].rows), got 99999999999999999999"),
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
    (["verilog", "pipeline", "--no-csr", "--scene", "{S}", "-o", "{D}"], 2,
     "cannot write (it is a directory)"),
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
     "onchip_kbit = 1e+308 is out of range"),
    ("plan(ddr_bits=3)", lambda: tdicam.plan(ddr_bits=3), "ddr_bits = 3 is out of range"),
    ("plan(device=[])", lambda: tdicam.plan(device=[]), "device = [] is not known"),
    ("plan(stages=[])", lambda: tdicam.plan(stages=[]), "stages: must not be an empty list"),
    ("plan(gsd_m=[nan])", lambda: tdicam.plan(gsd_m=[NAN]), "gsd_m: must be a finite number"),
    ("sweep(None)", lambda: tdicam.sweep(None), "sweep file: expected a file name"),
    ("blocks.get([])", lambda: blocks.get([]), "unknown block []"),
    ("blocks.get({})", lambda: blocks.get({}), "unknown block {}"),
    ("verilog(lvds, ppc='2' is fine; ppc=nan)", lambda: tdicam.verilog("lvds", ppc=NAN),
     "ppc must be an integer, got nan"),
    ("lvds.golden_model", lambda: blocks.get("lvds").golden_model({"frames": FR}),
     "block lvds has no golden function on scene arrays"),
    ("cosimulate(lvds, arrays)", lambda: tdicam.cosimulate("lvds", {"frames": FR}),
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
    ("cosimulate(tdi, empty)", lambda: tdicam.cosimulate("tdi", {"frames": FR[:0]}),
     "frames must be a non-empty integer array of pixel codes, got shape (0, 4, 8)"),
    ("cosimulate(tdi, float)", lambda: tdicam.cosimulate("tdi", {"frames": FR * 1.5}),
     "got shape (2, 4, 8), dtype float64"),
    ("cosimulate(median3, empty)", lambda: tdicam.cosimulate("median3", {"frames": FR[:0]}),
     "non-empty integer array"),
    ("cosimulate(tdi, idle=nan)", lambda: tdicam.cosimulate("tdi", idle=NAN), "idle = nan is out"),
    ("cosimulate(tdi, sim='bogus')", lambda: tdicam.cosimulate("tdi", sim="bogus"),
     "unknown simulator 'bogus'"),
]


# ---------------------------------------------------------------- the plan never turns NO to yes
LANES_SCENE = "scenes/ning2019_gmax0504_system_lanes.toml"
RTL = '[run.rtl]\nsimulator = "verilator"\ncrop = [0, 0, 32, 4]'
FIFO = "the front's crossing FIFO would need"
# (edits of the lanes scene, exit of `tdicam plan --scene`, fragment): each was
# "feasible: yes", exit 0 (the System section vanished when the chain could not be built)
VERDICT = [
    ((("lanes_per_gain = 2 ", "lanes_per_gain = 2\nbit_rate_mbps = 1 "),
      ("base = 0", "base = 0\nlat_hi = 1000")), 2, FIFO + " 1024 entries"),
    ((("base = 0", "base = 0\nlat_hi = 1000"),), 2,
     "[run.rtl]: the co-simulated design (the 32-column crop, 8 stages) cannot be built: "
     "pipeline: lvds (the chain's source): the DDR's longest stall, 1044 processing clocks "
     "([ddr].refresh_cycles + [ddr].lat_hi)"),
    ((("base = 0", "base = 0\nrefresh_cycles = 5000\nrefresh_period = 10000"),), 2,
     FIFO + " 4096 entries (16 without the stall), more than its 256: lower "
            "[ddr].refresh_cycles or [ddr].lat_hi"),
    ((("lanes_per_gain = 2 ", "lanes_per_gain = 128 "), ("columns = 256", "columns = 1024")),
     2, "[sensor.lvds].lanes_per_gain = 128 on 2 gains merged by the chain is 256 lanes; the "
        "front end takes at most 128: lanes_per_gain <= 64"),
    ((("base = 0", "base = 268435440"),), 2,
     "[ddr].base = 268435440: the reset frame (8 lines x stride 16) needs 128 address units "
     "above it and the memory has 268435456: give [ddr].base <= 268435328"),
    ((('[ddr]\ninterface = "mig"\nbase = 0\n', ""),), 2,
     "[pipeline.cds].memory = 'ddr' keeps its reset frames in DDR, but the scene has no "
     "[ddr] section"),
    ((("base = 0", "base = 0\nlat_hi = 1000"), (RTL, "")), 1,
     "pipeline design at 8 stages: pipeline: lvds (the chain's source): the DDR's longest "
     "stall, 1044 processing clocks"),
]


def _edited(path, edits, tmp_path):
    text = open(path).read()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    f = tmp_path / "s.toml"
    f.write_text(text)
    return f


@pytest.mark.parametrize("edits,code,fragment", VERDICT,
                         ids=[f"verdict{i}" for i in range(len(VERDICT))])
def test_plan_verdict_never_flips(edits, code, fragment, tmp_path, capsys):
    """The plan of a design the gateware cannot build is a refusal (exit 2, the run's and
    --dry-run's) or a NO row naming it (exit 1), never 'feasible: yes'."""
    f = _edited(LANES_SCENE, edits, tmp_path)
    assert main(["plan", "--scene", str(f)]) == code
    if code == 2:
        assert fragment in _one_line(capsys)
        # --dry-run (and so the run) refuses it alike, before any work
        assert main(["run", "--dry-run", str(f), "-o", str(tmp_path / "o")]) == 2
        assert fragment.split(": the co-simulated design")[-1] in _one_line(capsys)
    else:
        out = capsys.readouterr().out
        assert fragment in out and "feasible: NO (pipeline design)" in out
        assert "feasible: yes" not in out


def test_plan_no_ddr_no_beside_feasible_yes(capsys):
    """Qu et al. 2010's default plan printed 'DDR ...: NO' above 'feasible: yes' (the sums need
    not spill): every NO is in the verdict."""
    assert main(["plan"]) == 0
    out = capsys.readouterr().out
    assert "feasible: yes" in out and ": NO" not in out
    assert "short, but the sums need not spill (no on-chip budget given" in out


def test_plan_scene_stages_above_m0_is_no_with_the_fix(tmp_path, capsys):
    """A scene file of 100 stages where M0 = 96 was refused (exit 2) by plan --scene: it is
    the report's NO (exit 1), and the NO says which row time, frame rate or stages fix it."""
    f = _edited("scenes/orbit_600km_1m_96.toml", (("stages = 96", "stages = 100"),), tmp_path)
    assert main(["plan", "--scene", str(f)]) == 1
    out = capsys.readouterr().out
    assert ("NO (100 <= M0); to make it yes: T_row <= T_line / 100 = 1.448 us gives M0 >= "
            "100: [sensor].max_frame_rate_hz >= 674.6 or stages <= 96") in out
    assert "feasible: NO (frame rate, window (stages > M0))" in out
    f.write_text(f.read_text().replace("max_frame_rate_hz = 650.0",
                                       "pixel_clock_mhz = 500.0\nrow_blanking_us = 0.1"))
    assert main(["plan", "--scene", str(f)]) == 1
    assert ("[sensor].pixel_clock_mhz >= 949.8 (at row_blanking_us = 0.1) or stages <= 54"
            ) in capsys.readouterr().out


# ---------------------------------------------------------------- refusals before the work
OWN = ('[orbit]\naltitude_km = 500.0\ngsd_m = 0.5\n[target]\nkind = "bars"\nperiod_px = 4.0\n'
       '[sensor]\ncolumns = 2048\nrows = 64\nbits = 12\n[tdi]\nstages = 32\n'
       '[pipeline]\nblocks = ["nuc", "tdi", "median3"]\n[run]\nlines = 16\nfidelity = "fast"\n')
# (scene text, fragment): `tdicam run --dry-run`, `tdicam run` and `tdicam plan --scene`
# refuse it at once and alike (the run computed the whole scene first, then exited 1)
BEFORE = [
    (OWN, "[tdi].output: median3 after TDI takes at most 16-bit pixels; the TDI output is 17 "
          "bits: set output = 'saturate' with output_bits <= 16"),
    (OWN.replace("stages = 32", "stages = 128\noutput = 'saturate'\noutput_bits = 19").replace(
        "rows = 64", "rows = 256"), "the TDI output is 19 bits"),
    (open("scenes/orbit_chain.toml").read().replace("crop = [512, 0, 256, 32]",
                                                    "crop = [512, 0, 8, 32]"),
     "[run.rtl]: the co-simulated design (the 8-column crop, 96 stages) cannot be built: "
     "pipeline: nuc -> tdi: width = 8 with ppc = 8 gives 1 beat per row"),
]


@pytest.mark.parametrize("text,fragment", BEFORE, ids=[f"before{i}" for i in range(len(BEFORE))])
def test_refused_before_the_work(text, fragment, tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(text)
    out = tmp_path / "o"
    for argv in (["run", "--dry-run", str(f), "-o", str(out)], ["run", str(f), "-o", str(out)],
                 ["plan", "--scene", str(f)]):
        assert main(argv) == 2
        assert fragment in _one_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize("cmd", ["verilog", "export"])
def test_pipeline_stages_above_m0_refused_as_the_scene_refuses_them(cmd, tmp_path, capsys):
    """export pipeline --stages 97 on the orbit chain (M0 = 96) was exported, verilog
    pipeline wrote its Verilog; [tdi].stages = 97 in the scene is refused: so is the option."""
    out = tmp_path / "o"
    width = ["--width", "16"] if cmd == "export" else []      # under the export's limit
    assert main([cmd, "pipeline", "--scene", "scenes/orbit_chain.toml", "--stages", "97",
                 *width, "-o", str(out)]) == 2
    assert "--stages: must be <= M0 = 96 (rows read in one line period" in _one_line(capsys)
    assert not out.exists()


def test_run_of_a_scene_the_plan_calls_infeasible_says_so(tmp_path, capsys):
    """The lanes at 1 Mbit/s (the plan: NO) were simulated without a word: the console and
    report.md state the plan's NO and its reason; the run still runs (exit 0)."""
    f = tmp_path / "s.toml"
    f.write_text(_text(LANES + "bit_rate_mbps = 1\n"))
    assert main(["run", str(f), "-o", str(tmp_path / "o"), "--no-impact"]) == 0
    line = ("plan: feasible: NO (sensor lanes: 8 lanes x 1 Mbit/s / 12 bit = 0.7 M words/s, "
            "0.4 M pixels/s after each line's sync and header words; the window needs 0.88 M "
            "pixels/s: NO): the camera as planned cannot run this scene; simulated all the same")
    assert line in capsys.readouterr().out
    assert line in (tmp_path / "o" / "report.md").read_text()
    import json
    assert json.loads((tmp_path / "o" / "report.json").read_text())["plan"]["feasible"] is False


def test_plan_and_run_say_the_planned_mtf_leaves_median3_out(capsys):
    """The orbit chain measures 0.05-0.07 after median3 on period-4 bars where the plan
    predicted 0.73-0.81 for the camera without it: the plan says it leaves the median out;
    the run's comparison says the two do not compare."""
    assert main(["plan", "--scene", "scenes/orbit_chain.toml"]) in (0, 1)
    assert ("MTF @ Nyquist  of the camera before median3 (the plan leaves it out: a median is "
            "not linear and has no MTF)") in capsys.readouterr().out
    from tdicam.run import report
    t = {"planned_before": "median3"}
    assert report._before(t) == " before median3: not comparable"
    from tdicam.planning.predict import mtf_left_out
    assert mtf_left_out(tdicam.Scene.load("scenes/orbit_chain.toml")) == ("median3",)
    assert mtf_left_out(tdicam.Scene.load("scenes/orbit_600km_1m_96.toml")) == ()


# ---------------------------------------------------------------- sweeps: one key, two spellings
SWEEP_SCENE = "scenes/tao2012_ibis5_rolling_1_5_10.toml"
TWICE = [
    ({"axes": {"tdi.stages": [1, 4], "tdi": {"stages": [2]}}},
     '[axes]\n"tdi.stages" = [1, 4]\n[axes.tdi]\nstages = [2]\n',
     '[axes] tdi.stages: given twice, as [axes] "tdi.stages" and as [axes.tdi] stages'),
    ({"set": {"sensor.columns": 128, "sensor": {"columns": 64}}, "axes": {"tdi.stages": [1]}},
     '[set]\n"sensor.columns" = 128\n[set.sensor]\ncolumns = 64\n[axes]\n"tdi.stages" = [1]\n',
     '[set] sensor.columns: given twice, as [set] "sensor.columns" and as [set.sensor] '
     'columns'),
]


@pytest.mark.parametrize("doc,toml,fragment", TWICE, ids=["axes", "set"])
def test_sweep_key_in_two_spellings_is_refused(doc, toml, fragment, tmp_path, capsys):
    """The last spelling won silently (one point swept of three)."""
    import os
    doc = {"scene": os.path.abspath(SWEEP_SCENE), **doc}
    with pytest.raises(tdicam.TdicamError) as e:
        tdicam.sweep(doc, tmp_path / "o", serial=True)
    assert fragment in str(e.value) and "\n" not in str(e.value)
    # the file: the same line, exit 2
    f = tmp_path / "sw.toml"
    f.write_text(f'scene = "{doc["scene"]}"\n' + toml)
    assert main(["sweep", str(f), "-o", str(tmp_path / "o"), "--serial"]) == 2
    assert fragment in _one_line(capsys)
    assert not (tmp_path / "o").exists()


# ---------------------------------------------------------------- the API: types and names
P = "scenes/orbit_600km_1m_96.toml"
SWEEP = "scenes/sweeps/tao2012_snr_vs_stages.toml"
API_47 = [
    ("simulate(impact='no')", lambda: tdicam.simulate(_lanes_scene(), impact="no"),
     "simulate: impact must be True or False, got 'no'"),
    ("simulate(rtl='no')", lambda: tdicam.simulate(_lanes_scene(), rtl="no"),
     "simulate: rtl must be True or False, got 'no'"),
    ("sweep(serial='no')", lambda: tdicam.sweep(SWEEP, serial="no"),
     "sweep: serial must be True or False, got 'no'"),
    ("Scene.load(None)", lambda: tdicam.Scene.load(None),
     "Scene.load: path: a scene file name is needed"),
    ("plan({...})", lambda: tdicam.plan({"orbit": {}}),
     "plan: scene: expected a scene file's name or a Scene, got dict"),
    ("plan(changed Scene)", lambda: tdicam.plan(tdicam.Scene.load(P, overrides={
        "tdi": {"stages": 4}})), "plan: scene: this Scene is not its scene file's content"),
    ("columns=numpy.bool_", lambda: tdicam.Scene.from_dict({
        "orbit": {"altitude_km": 600, "gsd_m": 1.0}, "sensor": {"columns": np.bool_(True)}}),
     "[sensor].columns: must be an integer, got True"),
    ("plan(stages=[0])", lambda: tdicam.plan(stages=[0]), "stages = 0 is out of range"),
    ("plan(onchip_kbit=-1)", lambda: tdicam.plan(onchip_kbit=-1),
     "onchip_kbit = -1 is out of range"),
    ("sweep(workers=0)", lambda: tdicam.sweep(SWEEP, workers=0),
     "workers = 0 is out of range; valid: 1..256"),
    ("Scene.load(overrides=str)", lambda: tdicam.Scene.load(P, overrides="tdi.stages=4"),
     "overrides: must be a mapping {section: {key: value}}, got 'tdi.stages=4'"),
    ("Scene.from_dict({1: {}})", lambda: tdicam.Scene.from_dict({1: {}}),
     "section names must be strings, got 1"),
    ("from_dict(base_dir=5)", lambda: tdicam.Scene.from_dict({}, base_dir=5),
     "Scene.from_dict: base_dir: expected a file name, got int"),
    ("sweep(src, 5)", lambda: tdicam.sweep(SWEEP, 5), "out_dir: expected a file name, got int"),
    ("Scene.load(NUL)", lambda: tdicam.Scene.load("a\0b.toml"),
     "scene file: a file name cannot hold a NUL character"),
]


@pytest.mark.parametrize("call,fragment,named", [(*r[1:], r in API_47) for r in API + API_47],
                         ids=[r[0] for r in API + API_47])
def test_api_probes(call, fragment, named):
    with pytest.raises(tdicam.TdicamError) as e:
        call()
    assert fragment in str(e.value) and "\n" not in str(e.value)
    if named:                   # the Python argument's name, not the command line's flag
        assert "--" not in str(e.value).split(":")[0]


def test_api_takes_numpy_integers_and_bools():
    sc = tdicam.Scene.from_dict({"orbit": {"altitude_km": 600, "gsd_m": 1.0},
                                 "sensor": {"columns": np.int64(16), "rows": np.int32(8)},
                                 "run": {"lines": 8}})
    assert sc.sensor.columns == 16 and type(sc.sensor.columns) is int
    assert tdicam.plan(tdicam.Scene.load(P)).feasible in (True, False)


def test_simulation_save_refuses_what_is_no_folder(tmp_path):
    sim = tdicam.simulate(_lanes_scene(), impact=np.bool_(False))
    for bad, fragment in ((5, "out_dir: expected a file name, got int"),
                          (str(tmp_path / "a\0b"), "out_dir: a file name cannot hold a NUL")):
        with pytest.raises(tdicam.TdicamError, match="^" + fragment):
            sim.save(bad)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv", [["run", "--dry-run", "-o", "{d}/o"], ["verilog", "pipeline",
                                                                        "-o", "{d}/x.v"]])
def test_tdi_spill_above_the_ddr_base_is_refused_naming_the_key(argv, tmp_path, capsys):
    """The TDI partial sums in DDR (orbit_4096_ddr_spill) with ``[ddr].base`` near the top:
    --dry-run refused the same as ``verilog pipeline``, naming [ddr].base and the highest
    base that fits (it used to pass --dry-run, and ``verilog pipeline`` said 'address space
    too small' without the key)."""
    from tdicam.scene.examples import example_path
    f = _edited(example_path("orbit_4096_ddr_spill"), (("base = 0", "base = 268435000"),),
                tmp_path)
    args = [a.format(d=tmp_path) for a in argv]
    cmd = args[:2] + ["--scene", str(f)] + args[2:] if args[0] == "verilog" else \
        [args[0], str(f)] + args[1:]
    assert main(cmd) == 2
    assert ("[ddr].base = 268435000: the partial-sum buffer (95 lines x stride 2528) needs "
            "240160 address units above it and the memory has 268435456: give [ddr].base <= "
            "268195296") in _one_line(capsys)
