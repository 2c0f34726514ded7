"""``tdicam sweep``: expansion and validation, bit-identical results serial / Dask / rerun,
a worker killed mid-sweep, resume after an interruption, failed runs, one-line errors."""

import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tdicam.cli import main
from tdicam.errors import TdicamError
from tdicam.sweeps.runner import TIMING_COLUMNS, load_sweep, read_table, run_sweep

ROOT = Path(__file__).resolve().parents[1]
FULL = os.environ.get("TDICAM_FULL") == "1"

TINY = """
[orbit]
altitude_km = 600
gsd_m = 1.0
[target]
kind = "flat"
signal_e = 2000.0
[sensor]
columns = 24
rows = 128
read_noise_e = 5.0
black_level_dn = 32.0
max_frame_rate_hz = 650
[tdi]
stages = 1
[run]
lines = 12
fidelity = "exact"
"""

SWEEP = """
scene = "tiny.toml"
repeats = 2
[axes]
"tdi.stages" = [1, 2, 4]
target.signal_e = [500.0, 2000.0]
"""


def write(d, text, name):
    p = Path(d) / name
    p.write_text(textwrap.dedent(text))
    return p


def sweep_file(d, body=SWEEP, scene=TINY):
    write(d, scene, "tiny.toml")
    return write(d, body, "sweep.toml")


def values(df):
    """The table without the timing columns: what must be bit-identical."""
    return df.drop(columns=list(TIMING_COLUMNS))


def assert_same(a, b):
    pd.testing.assert_frame_equal(values(a), values(b), check_exact=True)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny sweep run serially once: (sweep file, table)."""
    d = tmp_path_factory.mktemp("ref")
    path = sweep_file(d)
    res = run_sweep(load_sweep(path), d / "out", serial=True, progress=False)
    assert res.computed == 12 and res.reused == 0 and not res.failed and not res.missing
    return path, read_table(d / "out")


# ---------------------------------------------------------------------------------------
# the sweep file
# ---------------------------------------------------------------------------------------


def test_points_ranges_zip_promotion_and_seeds(tmp_path):
    path = sweep_file(tmp_path, """
        scene = "tiny.toml"
        repeats = 3
        [set]
        run.lines = 8
        [axes]
        target.signal_e = { start = 100, stop = 400, step = 100 }
        sensor.read_noise_e = { start = 1.0, stop = 100.0, num = 3, log = true }
        [zip]
        "motion.dv_over_v" = [0.0, 0.1]
        "motion.drift_deg" = [0.0, 0.5]
        """, TINY.replace("stages = 1", "stages = [1, 3]"))
    sw = load_sweep(path)
    assert [a.key for a in sw.axes] == ["target.signal_e", "sensor.read_noise_e", "tdi.stages"]
    assert sw.promoted == ("tdi.stages",)
    assert sw.axes[0].values == (100, 200, 300, 400)
    assert all(isinstance(v, int) for v in sw.axes[0].values)
    assert sw.axes[1].values == (1.0, 10.0, 100.0)
    assert sw.shape == (4, 3, 2, 2, 3) and len(sw.points) == 48 and len(sw.runs) == 144
    p = sw.points[-1]
    assert p == {"target.signal_e": 400, "sensor.read_noise_e": 100.0, "tdi.stages": 3,
                 "motion.dv_over_v": 0.1, "motion.drift_deg": 0.5}
    last = sw.runs[-1].scene
    assert (last.target.signal_e, last.sensor.read_noise_e, last.tdi.stages,
            last.motion.dv_over_v, last.motion.drift_deg, last.run.lines) == \
        (400.0, 100.0, (3,), (0.1,), 0.5, 8)
    seeds = [r.seed for r in sw.runs]
    assert len(set(seeds)) == len(seeds) and len({r.hash for r in sw.runs}) == len(seeds)
    assert all(r.scene.run.seed == r.seed for r in sw.runs)
    imp = load_sweep(path, impact=True)           # impact is part of the hash, not the seed
    assert [r.seed for r in imp.runs] == seeds and imp.runs[0].hash != sw.runs[0].hash
    # seeds follow the point's scene, not its position: reorder the axes, same seeds
    path2 = write(tmp_path, path.read_text().replace(
        "target.signal_e = { start = 100, stop = 400, step = 100 }\n", "").replace(
        "[zip]", "target.signal_e = [400, 300, 200, 100]\n[zip]"), "sweep2.toml")
    sw2 = load_sweep(path2)
    assert len(sw2.runs) == 144
    by_scene = {(json.dumps(sw.points[r.point], sort_keys=True), r.repeat): r.seed
                for r in sw.runs}
    assert all(by_scene[(json.dumps(sw2.points[r.point], sort_keys=True), r.repeat)] == r.seed
               for r in sw2.runs)


BAD = [
    ('[axes]\n"tdi.stagse" = [1, 2]\n', "[tdi].stagse: unknown key; did you mean 'stages'?"),
    ('[axes]\n"tdx.stages" = [1, 2]\n', "[tdx]: unknown section"),
    ('[axes]\n"tdi.stages" = []\n', "[axes] tdi.stages: empty axis"),
    ('[axes]\n"target.signal_e" = {start = 5, stop = 1, step = 1}\n',
     "[axes] target.signal_e: empty axis"),
    ('[axes]\n"target.signal_e" = [100.0, -1.0]\n',
     'point target.signal_e = -1.0: [target].signal_e = -1.0 is out of range; valid: '
     '0..1000000000000'),
    ('[axes]\n"tdi.stages" = [1, 20]\n', "tdi.stages = 20: [tdi].stages: must be <= M0 = 12"),
    ('[axes]\n"sensor.bits" = [8, 8]\n', "[axes] sensor.bits: value 8 is listed twice"),
    ('[axes]\n"stages" = [1, 2]\n', "axis keys are section.key paths"),
    ('[zip]\n"tdi.stages" = [1, 2]\n"motion.dv_over_v" = [0.1]\n',
     "[zip] motion.dv_over_v: 1 values, but tdi.stages has 2"),
    ('repeats = 0\n', "repeats = 0 is out of range"),
    ('repeat = 2\n', "repeat: unknown key; did you mean 'repeats'?"),
    ('[axes]\n"target.signal_e" = {start = 0, stop = 1e6, num = 5001}\n',
     "target.signal_e (5001) x repeats (1) = 5001 runs, over the limit of 5000"),
]


@pytest.mark.parametrize("body,msg", BAD)
def test_bad_sweep_files_one_line_errors(tmp_path, capsys, body, msg):
    path = sweep_file(tmp_path, 'scene = "tiny.toml"\n' + body)
    with pytest.raises(TdicamError) as info:
        load_sweep(path)
    assert msg in str(info.value) and str(path) in str(info.value)
    assert main(["sweep", str(path), "-o", str(tmp_path / "o"), "--serial"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and msg in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_limit_is_lifted_by_force(tmp_path, monkeypatch):
    import tdicam.sweeps.file
    monkeypatch.setattr(tdicam.sweeps.file, "MAX_RUNS", 20)     # expanding 5000 runs takes ~10 s
    path = sweep_file(tmp_path, 'scene = "tiny.toml"\nrepeats = 3\n[axes]\n'
                                '"target.signal_e" = {start = 1, stop = 7, step = 1}\n')
    with pytest.raises(TdicamError, match=r"target.signal_e \(7\) x repeats \(3\) = 21 runs, "
                                          r"over the limit of 20; reduce the axes or pass --force"):
        load_sweep(path)
    assert len(load_sweep(path, force=True).runs) == 21


def test_missing_scene_and_unreachable_scheduler(tmp_path, capsys):
    path = write(tmp_path, 'scene = "nope.toml"\n', "s.toml")
    assert main(["sweep", str(path), "--serial"]) == 2
    assert "scene file not found" in capsys.readouterr().err
    with socket.socket() as s:            # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    addr = f"tcp://127.0.0.1:{port}"
    path = sweep_file(tmp_path)
    t0 = time.perf_counter()
    assert main(["sweep", str(path), "-o", str(tmp_path / "o"), "--scheduler", addr,
                 "--connect-timeout", "1"]) == 2
    err = capsys.readouterr().err
    assert time.perf_counter() - t0 < 30
    assert err.count("\n") == 1 and f"--scheduler {addr}: cannot connect" in err
    assert "Traceback" not in err
    assert not list((tmp_path / "o" / "points").glob("*.json"))


# ---------------------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------------------


def test_outputs_table_dataset_plots_reports(reference):
    import xarray as xr
    path, df = reference
    out = path.parent / "out"
    assert list(df.columns[:8]) == ["tdi.stages", "target.signal_e", "point", "repeat", "seed",
                                    "hash", "status", "error"]
    assert len(df) == 12 and (df["status"] == "ok").all() and df["error"].isna().all()
    assert (df["stages"] == df["tdi.stages"]).all() and (df["fidelity"] == "exact").all()
    assert not df["saturated"].any() and df["saturated"].notna().all()
    assert (df["task_seconds"] > 0).all() and (df["snr_predicted_gain_db"][df["stages"] == 1] == 0).all()
    assert (abs(df["snr_gain_db"][df["stages"] == 1]) < 0.3).all()   # one stage: no gain
    assert (df["snr_gain_db"][df["stages"] > 1] > 1.5).all()
    m4 = df[df["stages"] == 4]
    assert (abs(m4["snr_gain_db"] - m4["snr_predicted_gain_db"]) < 3).all()
    csv = pd.read_csv(out / "results.csv")
    assert np.allclose(csv["snr_gain_db"], df["snr_gain_db"], rtol=1e-12)
    ds = xr.open_dataset(out / "sweep.nc", engine="h5netcdf")
    assert dict(ds.sizes) == {"tdi.stages": 3, "target.signal_e": 2, "repeat": 2}
    assert list(ds["tdi.stages"].values) == [1, 2, 4]
    g = ds["snr_gain_db"].sel({"tdi.stages": 2, "target.signal_e": 500.0, "repeat": 1})
    row = df[(df["tdi.stages"] == 2) & (df["target.signal_e"] == 500.0) & (df["repeat"] == 1)]
    assert float(g) == float(row["snr_gain_db"].iloc[0])
    assert str(ds["fidelity"].values[0, 0, 0]) == "exact"
    ds.close()
    for f in ("snr_vs_stages.png", "time_vs_fidelity.png"):
        assert (out / f).stat().st_size > 10000, f
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["runs"], summary["computed"], summary["failed"]) == (12, 12, [])
    assert summary["axes"] == {"tdi.stages": [1, 2, 4], "target.signal_e": [500.0, 2000.0]}
    assert not (out / "mtf_vs_mismatch.png").exists()       # flat target: no MTF figure
    rec = json.loads((out / "points" / f"{df['hash'][5]}.json").read_text())
    assert rec["status"] == "ok" and rec["seed"] == df["seed"][5]
    assert rec["scene_settings"]["run"]["seed"] == rec["seed"]
    assert {e["name"] for e in rec["effects"]} >= {"shot_noise", "read_noise", "tdi"}
    assert any(not e["ran"] and e["why"] for e in rec["effects"])
    assert rec["measurements"]["snr"]["predicted_db"] == rec["row"]["snr_predicted_gain_db"]
    assert not list((out / "points").glob(".tmp-*")) and not list(out.glob(".tmp-*"))


def test_serial_local_cluster_and_rerun_bit_identical(reference, tmp_path):
    path, ref = reference
    res = run_sweep(load_sweep(path), tmp_path / "dask", workers=2, progress=False)
    assert res.computed == 12 and "local Dask cluster of 2 workers" in res.where
    df = read_table(tmp_path / "dask")
    assert_same(df, ref)
    workers = {json.loads(p.read_text())["worker"]
               for p in (tmp_path / "dask" / "points").glob("*.json")}
    assert len(workers) == 2                      # both worker processes did runs
    res = run_sweep(load_sweep(path), tmp_path / "again", serial=True, progress=False)
    assert_same(read_table(tmp_path / "again"), ref)
    # a rerun into the same directory reuses every run
    res = run_sweep(load_sweep(path), tmp_path / "again", serial=True, progress=False)
    assert (res.computed, res.reused) == (0, 12)
    assert_same(read_table(tmp_path / "again"), ref)


def test_worker_killed_mid_sweep(reference, tmp_path):
    from dask.distributed import Client, LocalCluster
    path, ref = reference
    killed = []
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None, env={"TDICAM_THREADS": "1"}) as cluster, \
            Client(cluster) as client:
        pids = client.run(os.getpid)              # {worker address: pid}

        def kill_one(run, rec):
            # kill a worker that holds unfinished runs (they must be run again elsewhere)
            busy = {a: k for a, k in client.processing().items() if k}
            if not killed and busy:
                addr = sorted(busy)[0]
                killed.append((pids[addr], busy[addr]))
                os.kill(pids[addr], signal.SIGKILL)

        res = run_sweep(load_sweep(path), tmp_path / "o", scheduler=cluster.scheduler_address,
                        progress=False, on_run=kill_one)
        assert killed and killed[0][0] not in client.run(os.getpid).values()
        assert all(k.startswith("tdicam-run-") for k in killed[0][1])
    assert (res.computed, res.reused, res.failed, res.missing) == (12, 0, [], 0)
    files = sorted(p.name for p in (tmp_path / "o" / "points").glob("*.json"))
    df = read_table(tmp_path / "o")
    assert files == sorted(f"{h}.json" for h in df["hash"]) and df["hash"].is_unique
    assert_same(df, ref)
    for key in killed[0][1]:                      # the lost runs finished on another worker
        rec = json.loads((tmp_path / "o" / "points" / f"{key[11:]}.json").read_text())
        assert rec["status"] == "ok" and not rec["worker"].endswith(f":{killed[0][0]}")


def test_resume_computes_only_missing_runs(reference, tmp_path):
    path, ref = reference
    out = tmp_path / "o"
    first = run_sweep(load_sweep(path), out, serial=True, limit=5, progress=False)
    assert (first.computed, first.reused, first.missing) == (5, 0, 7)
    part = read_table(out)
    assert (part["status"] == "missing").sum() == 7
    ran = []
    second = run_sweep(load_sweep(path), out, serial=True, progress=False,
                       on_run=lambda run, rec: ran.append(run.hash))
    assert (second.computed, second.reused, second.missing) == (7, 5, 0)
    assert set(ran) == set(part.loc[part["status"] == "missing", "hash"])
    assert_same(read_table(out), ref)
    # a torn record (not written by the atomic writer) and a stray temp file are not finished
    rec = out / "points" / f"{ref['hash'][3]}.json"
    rec.write_text(rec.read_text()[:200])
    (out / "points" / f".tmp-{ref['hash'][4]}.json-1-ab").write_text("{")
    third = run_sweep(load_sweep(path), out, serial=True, progress=False)
    assert (third.computed, third.reused) == (1, 11)
    assert_same(read_table(out), ref)


def test_limit_bounds_the_validation_and_a_rerun_finishes(reference, tmp_path, monkeypatch):
    """``--limit N`` validates only the points of the N runs it computes plus every value of
    every axis once (the points one axis away from the first), not every point; reruns
    validate further and end equal to the sweep run at once."""
    import tdicam.scene.loader as loader
    from tdicam.api import sweep
    calls = []
    real = loader.scene_from_dict
    monkeypatch.setattr(loader, "scene_from_dict",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    path, ref = reference                         # 3 stages x 2 signals, 2 repeats: 12 runs
    out = tmp_path / "o"
    ds = sweep(path, out, serial=True, limit=3)
    # the base scene; the cross check: point 0, stages 2 and 4 (points 2, 4), signal 2000
    # (point 1); then the points of the 3 runs to compute: points 0 and 1 (two repeats each)
    assert len(calls) == 1 + 4 + 2
    summary = ds.attrs["summary"]
    assert "computed 3, reused 0" in summary and "missing 9" in summary
    assert "validated 2 of 6 points (--limit" in summary
    part = read_table(out)
    assert (part["status"] == "missing").sum() == 9
    later = part[part["point"] >= 2]
    assert (later["seed"] == -1).all() and (later["hash"].fillna("") == "").all()
    calls.clear()
    sweep(path, out, serial=True, limit=2)        # reuses 3, validates up to 2 new runs
    assert len(calls) == 1 + 4 + 3
    assert (read_table(out)["status"] == "ok").sum() == 5
    ds = sweep(path, out, serial=True)
    assert "computed 7, reused 5" in ds.attrs["summary"]
    assert_same(read_table(out), ref)
    ds = sweep(path, out, serial=True, limit=0)   # finished points validated: all reused
    assert "computed 0, reused 12" in ds.attrs["summary"]
    assert "validated" not in ds.attrs["summary"]
    assert_same(read_table(out), ref)


def test_limit_still_checks_every_axis_value(tmp_path):
    """A bad value far from the first point is found before any run, even with --limit 1."""
    path = sweep_file(tmp_path, 'scene = "tiny.toml"\n[axes]\n"tdi.stages" = [1, 2, 4]\n'
                                '"target.signal_e" = [500.0, 2000.0, 3000.0, -5.0]\n')
    assert main(["sweep", str(path), "-o", str(tmp_path / "o"), "--serial", "--limit", "1"]) == 2
    with pytest.raises(TdicamError, match=r"point tdi.stages = 1, target.signal_e = -5.0: "):
        from tdicam.api import sweep
        sweep(path, tmp_path / "o", serial=True, limit=1)
    assert not (tmp_path / "o").exists()


def test_ctrl_c_then_rerun(reference, tmp_path):
    path, ref = reference
    out = tmp_path / "o"
    env = dict(os.environ, TDICAM_THREADS="1")
    cmd = [sys.executable, "-m", "tdicam", "sweep", str(path), "-o", str(out), "--serial"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if list((out / "points").glob("*.json")):
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    done = len(list((out / "points").glob("*.json")))
    if proc.returncode == 0:                      # finished before the signal arrived
        pytest.skip("the sweep finished before SIGINT")
    assert proc.returncode == 130 and "interrupted" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    # under load the signal can arrive after the last point, while the table is written:
    # every point is then on disk and the rerun only reuses them
    assert 1 <= done <= 12
    res = run_sweep(load_sweep(path), out, serial=True, progress=False)
    assert (res.reused, res.computed) == (done, 12 - done)
    assert_same(read_table(out), ref)


def test_failed_run_recorded_sweep_goes_on(tmp_path, capsys, monkeypatch):
    # 8 stages of 14-bit pixels make 17 bits, over median3's 16: the scene loader refuses
    # the point before any run (the sweep's validation: exit 2, nothing written) ...
    scene = TINY.replace("max_frame_rate_hz = 650", "max_frame_rate_hz = 650\nbits = 14")
    scene += '[pipeline]\nblocks = ["tdi", "median3"]\n'
    path = sweep_file(tmp_path, 'scene = "tiny.toml"\n[axes]\n"tdi.stages" = [1, 8, 2]\n', scene)
    assert main(["sweep", str(path), "-o", str(tmp_path / "o"), "--serial"]) == 2
    assert "median3 after TDI takes at most 16-bit pixels" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
    # ... so, for a run that fails in the middle of a sweep, the loader's check is taken out
    # (a failure no check before the work foresees): the engine refuses the point then
    from tdicam.scene import loader
    monkeypatch.setattr(loader, "_check_chain", lambda *a: None)
    assert main(["sweep", str(path), "-o", str(tmp_path / "o"), "--serial"]) == 1
    out = capsys.readouterr().out
    assert "failed 1" in out and "failed: point 1 (tdi.stages = 8) repeat 0:" in out
    assert "median3 after TDI takes at most 16-bit pixels" in out
    df = read_table(tmp_path / "o")
    assert list(df["status"]) == ["ok", "failed", "ok"] and df["snr_gain_db"].isna()[1]
    assert "17 bits" in df["error"][1] and df["error"].isna()[[0, 2]].all()
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["failed"][0]["axes"] == {"tdi.stages": 8}
    res = run_sweep(load_sweep(path), tmp_path / "o", serial=True, progress=False)
    assert (res.computed, res.reused, len(res.failed)) == (1, 2, 1)   # failed runs retried


def test_saturated_column(tmp_path, capsys):
    """A run whose flat output is clipped (signal over the full well) says so in the table,
    the dataset, summary.json and the printed summary; its SNR columns stay empty."""
    import xarray as xr
    path = sweep_file(tmp_path, 'scene = "tiny.toml"\n[axes]\n'
                                '"target.signal_e" = [500.0, 60000.0]\n')
    assert main(["sweep", str(path), "-o", str(tmp_path / "o"), "--serial"]) == 0
    assert "saturated: 1 run (output clipped" in capsys.readouterr().out
    df = read_table(tmp_path / "o")
    assert str(df["saturated"].dtype) == "boolean"
    assert list(df["saturated"]) == [False, True]
    assert df["snr_output_db"].notna()[0] and df["snr_output_db"].isna()[1]
    assert list(pd.read_csv(tmp_path / "o" / "results.csv")["saturated"]) == [False, True]
    with xr.open_dataset(tmp_path / "o" / "sweep.nc", engine="h5netcdf") as ds:
        assert list(ds["saturated"].values.ravel()) == [0.0, 1.0]
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["saturated"] == 1


def test_mtf_sweep_zip_and_time_plot(tmp_path):
    import xarray as xr
    scene = TINY.replace('kind = "flat"', 'kind = "bars"\nprofile = "sine"\nperiod_px = 4.0')
    scene = scene.replace("stages = 1", "stages = 4").replace("lines = 12", "lines = 32")
    path = sweep_file(tmp_path, 'scene = "tiny.toml"\n[axes]\n'
                                '"motion.dv_over_v" = {start = 0.0, stop = 0.25, num = 3}\n'
                                '[zip]\n"run.fidelity" = ["exact", "fast"]\n'
                                '"run.lines" = [32, 40]\n', scene)
    res = run_sweep(load_sweep(path), tmp_path / "o", serial=True, progress=False)
    assert not res.failed
    df = read_table(tmp_path / "o")
    assert list(df["m_dv_over_v"].unique()) == [0.0, 0.5, 1.0]
    assert df["mtf_measured"].notna().all() and df["mtf_model_yuan2013"].notna().all()
    assert (df["saturated"] == False).all()              # noqa: E712 - bars below the well
    assert df.groupby("m_dv_over_v")["mtf_model_yuan2013"].mean().is_monotonic_decreasing
    assert (abs(df["mtf_measured"] - df["mtf_model_footprint"]) < 0.02).all()
    assert set(df["fidelity"]) == {"exact", "fast"}
    for f in ("mtf_vs_mismatch.png", "time_vs_fidelity.png"):
        assert (tmp_path / "o" / f).stat().st_size > 10000
    ds = xr.open_dataset(tmp_path / "o" / "sweep.nc", engine="h5netcdf")
    assert dict(ds.sizes) == {"motion.dv_over_v": 3, "zip": 2, "repeat": 1}
    assert list(ds["run.fidelity"].values) == ["exact", "fast"]
    assert list(ds["run.lines"].values) == [32, 40]
    assert list(ds["fidelity"].values[1, :, 0]) == ["exact", "fast"]
    assert np.array_equal(ds["mtf_measured"].values.ravel(), df["mtf_measured"].to_numpy())
    ds.close()


BUNDLED = sorted((ROOT / "scenes" / "sweeps").glob("*.toml"))


@pytest.mark.parametrize("path", BUNDLED, ids=[p.stem for p in BUNDLED])
def test_bundled_sweeps_validate(path):
    sw = load_sweep(path)
    assert 20 <= len(sw.runs) <= 100


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="runs both bundled sweeps (minutes): set TDICAM_FULL=1")
def test_bundled_sweeps_reproduce_the_papers_curves(tmp_path):
    sweeps = ROOT / "scenes" / "sweeps"
    res = run_sweep(load_sweep(sweeps / "tao2012_snr_vs_stages.toml"), tmp_path / "tao",
                    workers=2, progress=False)
    assert not res.failed and not res.missing
    df = read_table(tmp_path / "tao")
    assert set(df["stages"]) >= {1, 5, 10} and set(df["fidelity"]) == {"exact", "fast"}
    gain = df.groupby(["run.fidelity", "stages"])[["snr_gain_db", "snr_predicted_gain_db"]].mean()
    assert (abs(gain["snr_gain_db"] - gain["snr_predicted_gain_db"]) < 0.5).all()
    res = run_sweep(load_sweep(sweeps / "yuan2013_mtf_vs_mismatch.toml"), tmp_path / "yuan",
                    workers=2, progress=False)
    assert not res.failed and not res.missing
    df = read_table(tmp_path / "yuan")
    assert list(df["m_dv_over_v"].unique()) == [0.25 * i for i in range(9)]
    meas = df[df["mtf_measured"].notna()]             # near M dV/V = 2 the MTF is ~0
    assert set(meas["m_dv_over_v"]) >= {0.25 * i for i in range(8)}
    assert (abs(meas["mtf_measured"] - meas["mtf_model_footprint"]) < 0.02).all()
    assert (abs(meas["mtf_measured"] - meas["mtf_model_yuan2013"]) < 0.06).all()
    assert meas.groupby("m_dv_over_v")["mtf_measured"].mean().is_monotonic_decreasing
