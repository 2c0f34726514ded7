"""``tdicam run``'s report for a newcomer: the configuration first, every output explained,
papers cited by author and year, the bit-exact output as .npy, a labelled crop and a line
profile, and no stale files of an earlier run mixed with the new ones."""

import json
import re
import textwrap

import numpy as np
from PIL import Image

from tdicam.cli import main

SCENE = """
[orbit]
altitude_km = 600
gsd_m = 1.0
[target]
kind = "{kind}"
signal_e = 2000.0
[sensor]
columns = 48
rows = 128
bits = {bits}
read_noise_e = 5.0
max_frame_rate_hz = 5000
[tdi]
stages = [1, {m}]
[run]
lines = 24
fidelity = "{fidelity}"
"""
SHORTHAND = re.compile(r"(?i:seeds? 0\d\d)|\bSPEC\b|issue [0-9]|\.\./shared|/work/shared")


def run(tmp_path, out, kind="flat", bits=12, m=4, fidelity="exact"):
    scene = tmp_path / f"{kind}.toml"
    scene.write_text(textwrap.dedent(SCENE.format(kind=kind, bits=bits, m=m,
                                                  fidelity=fidelity)))
    assert main(["run", str(scene), "-o", str(out), "--no-impact"]) == 0
    return json.loads((out / "report.json").read_text()), (out / "report.md").read_text()


def test_report_starts_with_the_configuration_and_explains_outputs(tmp_path):
    rep, md = run(tmp_path, tmp_path / "o")
    head = md.split("## Effects")[0]
    assert md.splitlines()[2] == "## Configuration"
    for words in ("ground speed **6908.", "line period **144.8 us**", "full-frame rate",
                  "window: 48 columns x 4 rows", "stages: 1, 4", "requested **exact**, used "
                  "**exact**"):
        assert words in head, words
    for words in ("Raw exposure vs TDI output", "RMS DN", "bound", "M Delta",
                  "Footprint model", "## Papers", "Qu Hongsong, Zhang Ye, Jin Guang"):
        assert words in md, words
    assert not [ln for ln in md.splitlines() if SHORTHAND.search(ln)]
    c = rep["configuration"]
    assert c["window"] == {"columns": 48, "rows": 4, "m0": c["window"]["m0"]}
    assert abs(c["required_frame_rate_hz"] - 4 / (128 * c["line_period_s"])) < 1e-6
    assert c["fidelity_used"] == ["exact"]
    for f in rep["files"]:                      # every file listed is explained
        assert f"`{f}`: " in md, f


def test_npy_is_the_exact_output_and_tif_its_shifted_copy(tmp_path):
    out = tmp_path / "o"
    rep, md = run(tmp_path, out, bits=14, m=16)       # 14 + 4 = 18 bits: TIFF shift 2
    npy = np.load(out / "tdi.npy")
    assert npy.dtype.kind in "iu" and npy.shape == (24, 48)
    assert rep["tiff_shift"] == 2 and "shifted right by 2 bits" in md
    tif = np.asarray(Image.open(out / "tdi.tif"))
    np.testing.assert_array_equal(tif, (npy.astype(np.int64) >> 2).astype(np.uint16))
    assert int(npy.max()) > 65535 or int(npy.max()) >> 2 == int(tif.max())
    raw = np.load(out / "raw_exposure.npy")
    assert raw.shape == (24, 48) and raw.max() <= (1 << 14) - 1


def test_crop_and_profile_figures(tmp_path):
    out = tmp_path / "o"
    rep, _ = run(tmp_path, out, kind="bars", fidelity="fast")
    for f in ("crop.png", "profile.png"):
        assert f in rep["files"]
        img = Image.open(out / f)
        assert img.size[0] > 400 and img.size[1] > 250


def test_stale_files_removed_foreign_files_listed_and_kept(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    rep, _ = run(tmp_path, out, kind="bars", fidelity="fast")
    assert "mtf.png" in rep["files"] and rep["stale_files"]["other"] == ["notes.txt"]
    rep, md = run(tmp_path, out, kind="flat", fidelity="fast")
    assert not (out / "mtf.png").exists()                  # written by tdicam, now stale
    assert rep["stale_files"]["removed"] == ["difference.png", "mtf.png"] and "`mtf.png`" in md
    assert (out / "notes.txt").read_text() == "mine"       # never touched
    assert "`notes.txt`" in md and (out / "snr_vs_stages.png").is_file()


def test_a_doctored_earlier_report_cannot_delete_outside_files(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    (out / "report.json").write_text(json.dumps({"files": ["../victim.txt", str(victim)]}))
    run(tmp_path, out)
    assert victim.read_text() == "keep"


def test_a_saturated_flat_field_is_reported_as_saturated_not_as_an_snr(tmp_path, capsys):
    """1e12 e- on a 20,000 e- well: the output is clipped flat; the report says so instead
    of a measured SNR (there is no noise left to measure) or a prediction at 1e12 e-."""
    scene = tmp_path / "sat.toml"
    scene.write_text(textwrap.dedent(SCENE.format(kind="flat", bits=12, m=4, fidelity="exact"))
                     .replace("signal_e = 2000.0", "signal_e = 1e12"))
    assert main(["run", str(scene), "-o", str(tmp_path / "o"), "--no-impact"]) == 0
    printed = capsys.readouterr().out
    rep = json.loads((tmp_path / "o" / "report.json").read_text())
    md = (tmp_path / "o" / "report.md").read_text()
    for r in rep["measurements"]:
        s = r["snr"]
        assert s["saturated"] and s["output_db"] is None and s["gain_db"] is None
        assert s["saturation_e"] == min(20000.0, 4095 * 20000 / 4096)
        assert s["snr1_db"] < 50                    # at the well, not at 1e12 e- (120 dB)
    assert "saturated: signal 1e+12 e-" in md and "saturated: signal 1e+12 e-" in printed
    ok, _ = run(tmp_path, tmp_path / "ok")           # 2000 e-: far from the well
    assert not any(r["snr"]["saturated"] for r in ok["measurements"])


def test_a_full_device_while_writing_the_images_is_one_line(tmp_path, monkeypatch, capsys):
    import errno

    from tdicam.run import runner

    def full(out_dir, res):
        raise OSError(errno.ENOSPC, "No space left on device", str(out_dir / "tdi.tif"))
    monkeypatch.setattr(runner, "_write_images", full)
    scene = tmp_path / "s.toml"
    scene.write_text(textwrap.dedent(SCENE.format(kind="flat", bits=12, m=4, fidelity="fast")))
    assert main(["run", str(scene), "-o", str(tmp_path / "o"), "--no-impact"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == f"tdicam: error: {tmp_path / 'o' / 'tdi.tif'}: cannot write (No space " \
                      "left on device)"
    assert all(ln.startswith("s: ") for ln in err[:-1]), err     # before it: the stage lines


def test_an_rtl_cosimulation_that_cannot_run_gives_exit_status_1(tmp_path, capsys,
                                                                  monkeypatch):
    """[run.rtl] that cannot run (here: the simulator fails to start; a scene the chain
    cannot take is refused when the scene is read, exit 2) is in the report and the exit
    status, not only a line of the summary."""
    from tdicam.chain import cosim
    from tdicam.errors import TdicamError

    def broken(*args, **kw):
        raise TdicamError("verilator: cannot start (not installed)")
    monkeypatch.setattr(cosim, "cosimulate", broken)
    scene = tmp_path / "s.toml"
    scene.write_text(textwrap.dedent(SCENE.format(kind="flat", bits=12, m=4, fidelity="fast"))
                     + "[run.rtl]\n")
    assert main(["run", str(scene), "-o", str(tmp_path / "o"), "--no-impact"]) == 1
    assert "RTL pipeline: error: verilator: cannot start" in capsys.readouterr().out
    rep = json.loads((tmp_path / "o" / "report.json").read_text())
    assert "verilator: cannot start" in json.dumps(rep["rtl"])
    bad = tmp_path / "bad.toml"
    bad.write_text(scene.read_text() + "pixels_per_clock = 3\n")
    assert main(["run", str(bad), "-o", str(tmp_path / "o2"), "--no-impact"]) == 2
    assert "[run.rtl].pixels_per_clock: must be one of 1, 2, 4, 8, got 3" in \
        capsys.readouterr().err
    assert not (tmp_path / "o2").exists()
