"""``tdicam bench``: the fidelity table through the CLI (short inputs, both simulators)."""

import dataclasses
import json
import re
import time

import numpy as np
import pytest

from tdicam.bench import build, chain, suite
from tdicam.cli import main

SIM_LEVELS = ["icarus beat", "icarus fast", "verilator beat", "verilator fast"]


def _bench(tmp_path, capsys, *args):
    js, png = tmp_path / "b.json", tmp_path / "b.png"
    code = main(["bench", *args, "--quick", "--json", str(js), "--png", str(png)])
    out = capsys.readouterr().out
    return code, json.loads(js.read_text()), png, out


def _check_png(png):
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_cds_quick_both_simulators(tmp_path, capsys):
    code, doc, png, out = _bench(tmp_path, capsys, "cds")
    assert code == 0
    rows = doc["rows"]
    assert [r["level"] for r in rows] == ["golden", "pysim"] + SIM_LEVELS
    assert {r["block"] for r in rows} == {"cds"}
    for r in rows[1:]:
        assert r["accuracy"] == "bit-exact" and r["mismatches"] == 0
        assert r["units"] > 0 and r["seconds"] > 0
        assert r["rate"] == pytest.approx(r["units"] / r["seconds"])
    # the golden model and the fast runs see the whole input, the slow levels a prefix
    assert rows[0]["units"] == rows[3]["units"] == rows[5]["units"] > rows[1]["units"]
    assert rows[0]["accuracy"] == "reference" and rows[0]["x_ref"] == 1.0
    for r in rows[3], rows[5]:
        assert r["x_beat"] == pytest.approx(r["rate"] / rows[rows.index(r) - 1]["rate"])
        assert r["build_s"] is not None
    assert doc["settings"]["repeat"] == 1 and doc["settings"]["build_time"] == "cached"
    assert "cores" in doc["machine"] and "Verilator" in doc["machine"]
    # printed: machine line, header, one line per row, legend, wall time
    lines = out.splitlines()
    assert lines[0] == doc["machine"]
    assert lines[1].split()[:4] == ["block", "level", "input", "median"]
    assert sum(ln.startswith("cds ") for ln in lines) == 6
    assert out.count("bit-exact") == 5 and "px/s" in out
    _check_png(png)
    # the same table again from the JSON, without running anything
    assert main(["bench", "--from-json", str(tmp_path / "b.json"), "--png", "none"]) == 0
    assert capsys.readouterr().out.splitlines()[:8] == lines[:8]


def test_secded_words_and_json_to_stdout(tmp_path, capsys):
    code = main(["bench", "secded_dec", "--quick", "--sims", "verilator,icarus", "--json",
                 "-", "--png", str(tmp_path / "s.png")])
    cap = capsys.readouterr()
    assert code == 0
    doc = json.loads(cap.out)                      # stdout is the JSON alone
    assert "secded_dec" in cap.err and "bit-exact" in cap.err
    assert [r["level"] for r in doc["rows"]] == ["golden", "pysim"] + SIM_LEVELS[2:] \
        + SIM_LEVELS[:2]
    assert suite.expand(["secded", "secded_dec"]) == ["secded_enc", "secded_dec"]
    assert {r["unit"] for r in doc["rows"]} == {"word"}
    assert all(r["accuracy"] == "bit-exact" for r in doc["rows"] if r["level"] != "golden")
    _check_png(tmp_path / "s.png")


def test_a_wrong_golden_model_is_counted_not_passed(monkeypatch, tmp_path, capsys):
    """Corrupt three output pixels of the golden model: every simulator row must count
    exactly those three mismatches and the command must fail."""
    cds = next(w for w in suite.STREAM_WORKS if w.name == "cds")

    def wrong(arrays):
        arrays["out"].reshape(-1)[[5, 700, 5000]] ^= 1

    works = tuple(dataclasses.replace(w, corrupt=wrong) if w is cds else w
                  for w in suite.STREAM_WORKS)
    monkeypatch.setattr(suite, "STREAM_WORKS", works)
    js = tmp_path / "w.json"
    assert main(["bench", "cds", "--quick", "--sims", "verilator", "--png", "none",
                 "--json", str(js)]) == 1
    rows = json.loads(js.read_text())["rows"]
    assert len(rows) == 4
    for r in rows[1:]:
        assert (r["mismatches"], r["accuracy"]) == (3, "3 mismatching"), r["level"]
    assert "3 mismatching" in capsys.readouterr().out


def test_scene_rows(tmp_path, capsys):
    code, doc, png, out = _bench(tmp_path, capsys, "scene", "--sims", "none")
    assert code == 0
    rows = {r["level"]: r for r in doc["rows"]}
    assert list(rows) == ["scene fast", "scene auto", "scene exact"]
    assert rows["scene exact"]["x_ref"] == 1.0
    assert rows["scene exact"]["accuracy"].startswith("reference; other seed: PSNR")
    for fid in ("scene fast", "scene auto"):
        acc = rows[fid]["accuracy"]
        psnr, snr = float(acc.split()[1]), float(acc.split("SNR ")[-1].split()[0])
        assert psnr > 60 and abs(snr) < 0.5, acc        # fast agrees with exact in noise
        assert rows[fid]["x_ref"] > 10
        assert "x real time" in rows[fid]["note"]
    _check_png(png)


def test_benchmarks_come_from_the_registry():
    """The benchmark names are the block entries' groups (then the scene); a group runs
    its blocks, a block name the block alone; every DDR buffer is in the ddr group."""
    benched = [b for b in suite.blocks.in_order() if b.bench is not None]
    assert suite.NAMES == tuple(dict.fromkeys(b.bench.group for b in benched)) + ("scene",)
    assert suite.expand(["ddr"]) == [n for n in ("cds_ddr", "ddr", "tdi_ddr")]
    assert suite.expand(["tdi_ddr", "secded"]) == ["tdi_ddr", "secded_enc", "secded_dec"]
    assert {w.block for w in suite.STREAM_WORKS} == {b.name for b in benched if b.bench.work}
    assert {b.harness for b in benched if b.bench.work is None} <= set(suite.HARNESS_RUNNERS)
    assert suite.blocks.get("lvds").harness == "link"


def test_fresh_build_is_timed_in_its_own_folder():
    """Build seconds: the first run's own build when it built, else (fresh) a build from
    scratch in <block>.bench-* (Icarus here: cheap); cached reports the first run's 0."""
    blk = suite.blocks.get("cds")
    params = blk.resolve({"pixel_bits": 12})
    stamp = suite.cosim.build_dir_for("cds.bench", params, "icarus") / "stamp"

    def sources():
        return suite.stream_sources(blk, params)
    assert build.build_seconds(2.5, "fresh", "cds", params, "icarus", sources) == 2.5
    assert build.build_seconds(0.0, "cached", "cds", params, "icarus", sources) == 0.0
    t0 = time.time()
    assert build.build_seconds(0.0, "fresh", "cds", params, "icarus", sources) > 0
    assert stamp.stat().st_mtime >= t0 - 1
    assert build.fresh_build("cds", params, "icarus", sources()) > 0      # every time


def test_ddr_works_feed_their_blocks():
    """Stimulus and golden output of every DDR workload (no simulation): the round trip
    returns its input, CDS outputs only signal frames, TDI from frame `stages` on."""
    for w in suite.STREAM_WORKS:
        if w.block not in suite.expand(["ddr"]):
            continue
        blk, params, inp = suite.work_inputs(w)
        stim, exp = blk.streams.to_beats(blk.case_arrays(inp, params), params)
        px = inp["frames"].size
        assert stim.data.size == px, w.name
        if w.name == "ddr":
            assert np.array_equal(stim.data, exp.data)
        if w.name == "cds_ddr":
            assert exp.data.size == px * 3 // 4
        if w.name == "tdi_ddr":
            assert exp.data.size == (w.sizes["fast"] - 3) * 256


def test_a_failing_benchmark_is_a_row_and_an_exit_code(monkeypatch, capsys):
    def broken(**kw):
        raise RuntimeError("simulator exploded")
    monkeypatch.setitem(suite.RUNNERS, "scene", broken)
    assert main(["bench", "scene", "--png", "none", "--sims", "none"]) == 1
    cap = capsys.readouterr()
    row = next(ln for ln in cap.out.splitlines() if ln.startswith("scene "))
    assert "error" in row and "RuntimeError: simulator exploded" in row
    assert cap.err.endswith("bench: 1 row(s) not bit-exact or failed: scene error\n")


@pytest.mark.parametrize("args, msg", [
    (["nope"], "unknown benchmark 'nope'; valid: cds, tdi, nuc, hdr, median3, secded, lvds, "
               "ddr, scene, pipeline, camera"),
    (["cds", "--sims", "modelsim"], "--sims: unknown simulator 'modelsim'; valid: icarus, "
                                    "verilator, none"),
    (["cds", "--stalls", "1.5"], "--stalls = 1.5 is out of range; valid: [0, 1)"),
    (["cds", "--repeat", "0"], "--repeat = 0 is out of range; valid: 1..100"),
])
def test_errors_are_one_line(args, msg, capsys):
    assert main(["bench", *args]) == 2
    err = capsys.readouterr().err
    assert err == f"tdicam: error: {msg}\n"


def test_from_json_needs_a_bench_file(tmp_path, capsys):
    bad = tmp_path / "x.json"
    bad.write_text("{}")
    assert main(["bench", "--from-json", str(bad)]) == 2
    assert capsys.readouterr().err == (f"tdicam: error: --from-json {bad}: not a tdicam bench "
                                       f"JSON file (a table without 'rows', 'machine', "
                                       f"'settings', 'wall_s'; 'tdicam bench --json FILE' "
                                       f"writes one)\n")


def test_table_formatting():
    rows = [suite.row("x", "golden", "pixel", 1000, 1e-4, x_ref=1.0, accuracy="reference",
                       input="1,000 px"),
            suite.row("x", "verilator fast", "pixel", 1000, 0.5, x_ref=2e-4, x_beat=12.0,
                       accuracy="bit-exact", input="1,000 px", build_s=12.34)]
    text = suite.format_table(rows).splitlines()
    assert "10 Mpx/s" in text[2] and "100 ns/px" in text[2]
    assert "1/5k" in text[3] and "12.0" in text[3] and "12.3" in text[3]
    md = suite.format_table(rows, markdown=True).splitlines()
    assert md[0].startswith("| block | level |") and len(md) == 4


def test_lvds_quick_both_simulators(tmp_path, capsys):
    code, doc, _, _ = _bench(tmp_path, capsys, "lvds")
    assert code == 0
    got = {r["level"]: r for r in doc["rows"]}
    assert got["verilator fast"]["accuracy"] == got["icarus fast"]["accuracy"] == "bit-exact"
    assert got["pysim"]["accuracy"] == "bit-exact" and got["pysim"]["units"] == 8
    assert got["verilator beat"]["accuracy"] == "n/a"
    assert np.isclose(got["golden"]["x_ref"], 1.0)


def _pipeline_stand_in(seen):
    """A stand-in for :func:`tdicam.bench.chain.pipeline_run` (Icarus finds 3 mismatches)."""
    def fake(scene, *, sim, lines, idle, backpressure, ppc):
        seen.append((scene, sim, lines, ppc))
        return {"chain": ["cds", "tdi"], "frames": 10, "rows": 8, "width": 64,
                "input_pixels": 1_000_000, "cycles": 1_100_000, "compared": 512,
                "mismatches": 3 if sim == "icarus" else 0, "golden_s": 0.5, "build_s": 7.0,
                "run_s": 1.0 if sim == "verilator" else 4.0, "cpu_s": 0.8, "load": 1.5}
    return fake


def test_pipeline_is_named_not_default_and_reports_what_it_ran(monkeypatch):
    """``tdicam bench pipeline``: only when named; its rows carry the run's own figures
    (a mismatch is counted, Icarus only with --quick, the target judged on wall time at
    ppc 8), one row per ppc (1 and 8) side by side."""
    assert "pipeline" not in suite.expand([]) and suite.expand(["pipeline"]) == ["pipeline"]
    seen = []
    monkeypatch.setattr(chain, "pipeline_run", _pipeline_stand_in(seen))
    rows = suite.run(["pipeline"], sims=("icarus", "verilator"), repeat=1, quick=False)
    by = {r["level"]: r for r in rows}
    assert by["icarus fast"]["accuracy"] == "n/a" and seen == [
        (chain.PIPELINE_SCENE, "verilator", None, 1),
        (chain.PIPELINE_SCENE, "verilator", None, 8)]
    assert chain.PIPELINE_SCENE.name == "orbit_chain.toml"
    v = by["verilator fast ppc 8"]
    assert v["accuracy"] == "bit-exact" and v["rate"] == 1e6 and "target 8,000,000 px/s " \
        "not met" in v["note"] and v["build_s"] == 7.0 and by["golden"]["rate"] == 2e6
    assert "target judged at ppc 8" in by["verilator fast ppc 1"]["note"]
    assert "1,100,000 cycles; 1,250,000 px per simulator CPU s; load 1.5; " in v["note"]
    seen.clear()
    rows = suite.run(["pipeline"], sims=("icarus",), repeat=1, quick=True)
    assert seen == [(chain.QUICK_SCENE, "icarus", 8, 1), (chain.QUICK_SCENE, "icarus",
                                                          8, 8)]
    assert [r["accuracy"] for r in rows] == ["reference", "3 mismatching", "3 mismatching"]
    assert "not met" in rows[2]["note"]


def test_pipeline_rows_have_their_own_legend(monkeypatch, capsys):
    """The pipeline rows are one run each with the build timed apart: their legend says what
    ran, once, and per wall and simulator CPU second, not the blocks' medians of --repeat
    runs and fresh builds; beside other rows each has its own line."""
    monkeypatch.setattr(chain, "pipeline_run", _pipeline_stand_in([]))
    assert main(["bench", "pipeline", "--sims", "verilator", "--png", "none"]) == 0
    out = capsys.readouterr().out
    assert "medians of" not in out and "fresh build" not in out, out
    legend = next(x for x in out.splitlines() if x.startswith("pipeline rows: "))
    for part in ("the whole orbit_chain.toml scene, through the top at 1 and 8 pixels per "
                 "clock", "each row is one run",
                 "--repeat not used", "the build is timed apart",
                 "throughput = input pixels per wall second",
                 "input pixels per CPU second of the simulator process",
                 "the 1-minute load average after the run"):
        assert part in legend, (part, legend)
    both = suite.legend(repeat=3, stalls=0.1, build="fresh", quick=True,
                        names=["cds", "pipeline"]).splitlines()
    assert len(both) == 2 and both[0].startswith("other rows: medians of 3 run(s)") \
        and both[1].startswith("pipeline rows: 8 output lines of ning2019_chain.toml")


def test_bench_counts_k_of_n_and_keeps_what_finished_when_interrupted(monkeypatch, capsys,
                                                                       tmp_path):
    """Long work shows where it is: a stage line per benchmark, [k/n] with the time left;
    ^C after the first keeps its row in the table and the JSON (exit 130)."""
    def first(**kw):
        return [suite.na_row("scene", "golden", "-", "stand-in")]

    def interrupted(**kw):
        raise KeyboardInterrupt
    monkeypatch.setitem(suite.RUNNERS, "scene", first)
    monkeypatch.setitem(suite.RUNNERS, "pipeline", interrupted)
    monkeypatch.setattr(suite, "TIMES_FILE", tmp_path / "times.json")
    out = tmp_path / "b.json"
    assert main(["bench", "scene", "pipeline", "--png", "none", "--sims", "none",
                 "--json", str(out)]) == 130
    cap = capsys.readouterr()
    err = cap.err.splitlines()
    assert err[0] == ("bench: 2 benchmark(s), no estimate yet (the first run of these here; "
                      "the next one will say)")
    assert err[1].startswith("bench: [1/2] scene (") and err[2].startswith("bench: [2/2] pipeline (")
    assert "about" in err[2] and "s left)" in err[2]
    assert "interrupted after 1 of 2 benchmarks" in cap.err
    assert any(ln.startswith("scene ") and "stand-in" in ln for ln in cap.out.splitlines())
    assert [r["block"] for r in json.loads(out.read_text())["rows"]] == ["scene"]



def test_bench_states_its_time_up_front_from_the_last_run_here(monkeypatch, capsys, tmp_path):
    """The second run of the same benchmarks says how long they took here last time."""
    def quick(**kw):
        return [suite.na_row("scene", "golden", "-", "stand-in")]
    monkeypatch.setitem(suite.RUNNERS, "scene", quick)
    monkeypatch.setattr(suite, "TIMES_FILE", tmp_path / "times.json")
    argv = ["bench", "scene", "--png", "none", "--sims", "none", "--quick"]
    assert main(argv) == 0
    assert "no estimate yet" in capsys.readouterr().err
    assert main(argv) == 0
    assert re.search(r"^bench: 1 benchmark\(s\), about \d+\.\d min \(their last run on this "
                     r"machine\)$", capsys.readouterr().err, re.M)
    assert suite.estimate(["scene", "pipeline"], quick=True, sims=(), repeat=1,
                          build="cached") is None           # one of them never ran here


def test_camera_is_named_not_default_and_extrapolates_the_whole_frame(monkeypatch):
    """``tdicam bench camera``: only when named; a row for each cut of
    tdicam.bench.camera.CUT_LINES (every tap counted in its accuracy), then the whole
    5144 x 3800 frame pair extrapolated from them; Icarus: a row saying why not."""
    from tdicam.bench import camera
    assert "camera" not in suite.expand([]) and suite.expand(["camera"]) == ["camera"]
    seen = []

    class P:
        ppc, width, lanes = 8, 5144, 2

    def fake(lines, sim="verilator", **kw):
        seen.append((lines, sim))
        return {"plan": P, "lines": lines, "input_pixels": 4 * 5144 * lines,
                "cycles": 1000 + 100 * lines, "run_seconds": 1.0 + 0.01 * lines,
                "build_seconds": 9.0 if lines == 8 else 0.0, "startup_cycles": 1000,
                "mismatches": 0, "tap_mismatches": 0 if lines == 8 else 2, "load": 1.0,
                "links": True, "words_compared": 2578 * 2 * lines,
                "frame_buffer": {"writes": 322 * lines, "reads": 322 * lines, "stalls": 7,
                                 "error": 0} if lines == 16 else None,
                "status_outputs": {} if lines == 16 else {
                    "ddr_writes": 1200, "ddr_reads": 1201, "ddr_writes_1": 1300,
                    "ddr_reads_1": 1301}}
    monkeypatch.setattr(camera, "camera_run", fake)
    rows = suite.run(["camera"], sims=("icarus", "verilator"), repeat=1, quick=False)
    assert seen == [(n, "verilator") for n in camera.CUT_LINES]
    assert [r["accuracy"] for r in rows] == ["n/a", "bit-exact", "2 mismatching", "n/a"]
    whole = rows[-1]
    assert whole["input"] == "5144 x 3800 lines x 2 gains" and whole["units"] == \
        2 * 3800 * 5144 * 2
    assert whole["seconds"] == pytest.approx(1.0 + 0.01 * 3800)
    assert f"{1000 + 100 * 3800:,} cycles" in whole["note"]
    # each cut says its links' words were compared and what went through the frame buffer
    assert "the 41,248 link words compared" in rows[1]["note"]
    assert "(the frame buffer: 5,152 words written, 5,152 read)" in rows[2]["note"]
    # (a buffer on the gains' shared DDR: each interface's words)
    assert "frame buffer:" not in rows[1]["note"] and "each gain's DDR 1,200 words written " \
        "and 1,201 read, 1,300 words written and 1,301 read" in rows[1]["note"]
    assert "each gain's DDR" not in rows[2]["note"]
