"""Sweep throughput: runs/s serially and on a local Dask cluster of 1 and 2 worker processes.

A sweep of tiny scenes (flat target, exact fidelity; stages x signal x read noise, 64 points
by default) runs into a fresh directory each time: once in this process (``--serial``), then
on local clusters of 1 and 2 workers. Times cover the runs (submit to last result stored),
not the table, dataset and plots written after. For the clusters two figures: runs/s once
the cluster is up (the cluster is started first and passed as ``--scheduler``), and the time
of ``tdicam sweep --workers N`` from nothing, cluster start and stop included. Scaling efficiency =
runs/s with N workers / (N x runs/s with 1 worker). Every table is checked equal to the
serial one (timing columns aside).

    python bench/bench_sweep.py [--columns W] [--lines N] [--repeats R]
"""

import argparse
import logging
import os
import tempfile
import textwrap
from pathlib import Path

import pandas as pd

from tdicam.bench.util import machine, print_table
from tdicam.sweeps.runner import TIMING_COLUMNS, load_sweep, read_table, run_sweep

SCENE = """
[orbit]
altitude_km = 600
gsd_m = 1.0
[target]
kind = "flat"
signal_e = 2000.0
[sensor]
columns = {columns}
rows = 128
black_level_dn = 32.0
max_frame_rate_hz = 650
[tdi]
stages = 1
[run]
lines = {lines}
fidelity = "exact"
"""

SWEEP = """
scene = "scene.toml"
repeats = {repeats}
[axes]
"tdi.stages" = [1, 2, 4, 8]
"target.signal_e" = [250.0, 500.0, 1000.0, 2000.0]
"sensor.read_noise_e" = [0.0, 5.0, 10.0, 20.0]
"""


def _load():
    try:
        return "{:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
    except OSError:
        return "-"


def run(columns=64, lines=32, repeats=1):
    """Rows: mode, workers, runs, seconds, runs/s, efficiency, wall with cluster start."""
    from dask.distributed import Client, LocalCluster
    work = Path(tempfile.mkdtemp(prefix="bench_sweep_"))
    (work / "scene.toml").write_text(textwrap.dedent(SCENE.format(columns=columns,
                                                                  lines=lines)))
    (work / "sweep.toml").write_text(textwrap.dedent(SWEEP.format(repeats=repeats)))
    sw = load_sweep(work / "sweep.toml")
    n = len(sw.runs)
    rows, tables = [], {}
    dt = run_sweep(sw, work / "serial", serial=True, progress=False).compute_seconds
    tables["serial"] = read_table(work / "serial")
    rows.append({"mode": "serial (this process)", "workers": 1, "runs": n, "s": dt,
                 "rate": n / dt, "load": _load()})
    rate1 = None
    for k in (1, 2):
        with LocalCluster(n_workers=k, threads_per_worker=1, processes=True,
                          dashboard_address=None, env={"TDICAM_THREADS": "1"},
                          silence_logs=logging.CRITICAL) as cluster, \
                Client(cluster) as client:
            client.run(lambda: __import__("tdicam.sweeps.runner"))     # warm imports in the workers
            dt = run_sweep(sw, work / f"up{k}", scheduler=cluster.scheduler_address,
                           progress=False).compute_seconds
        cold = run_sweep(sw, work / f"cold{k}", workers=k, progress=False).compute_seconds
        rate = n / dt
        rate1 = rate if k == 1 else rate1
        tables[f"up{k}"] = read_table(work / f"up{k}")
        tables[f"cold{k}"] = read_table(work / f"cold{k}")
        rows.append({"mode": "local Dask cluster", "workers": k, "runs": n, "s": dt,
                     "rate": rate, "eff": rate / (k * rate1), "cold": cold, "load": _load()})
    ref = tables["serial"].drop(columns=list(TIMING_COLUMNS))
    for name, df in tables.items():
        pd.testing.assert_frame_equal(df.drop(columns=list(TIMING_COLUMNS)), ref,
                                      check_exact=True)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--columns", type=int, default=64)
    ap.add_argument("--lines", type=int, default=32)
    ap.add_argument("--repeats", type=int, default=1)
    a = ap.parse_args()
    print(machine())
    print(f"load average before: {_load()}")
    rows = run(a.columns, a.lines, a.repeats)
    print_table(rows, [("mode", "mode", "s"), ("workers", "workers", "d"),
                       ("runs", "runs", "d"), ("s", "seconds (cluster up)", ".2f"),
                       ("rate", "runs/s", ".2f"), ("eff", "scaling efficiency", ".2f"),
                       ("cold", "s with cluster start/stop", ".2f"),
                       ("load", "load avg 1/5/15 min after", "s")],
                title=f"\ntdicam sweep: {rows[0]['runs']} runs of {a.columns} x {a.lines} "
                      f"flat scenes, exact fidelity (tables equal to the serial run)")


if __name__ == "__main__":
    main()
