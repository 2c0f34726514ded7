"""The store of finished runs and a sweep's results: table, dataset and figures.

Store and resume
----------------
Each finished run is written to ``DIR/points/<hash>.json``, ``hash`` = sha256 of the run's
fully validated scene (seed included), the ``impact`` option, :data:`STORE_FORMAT` and the
tdicam version. The file is written to a temporary name in the same directory and renamed,
so a process that dies never leaves a partial file under a final name; a file that does not
parse or holds another hash (one torn by an operating-system crash, say) is treated as
missing. A rerun (after a crash, Ctrl-C, ``limit``, or an edit of the sweep file) computes
only the runs without a finished record and reports how many it reused; failed runs are
tried again. The engine's code is not part of the hash: after changing it without a new
tdicam version, write to a fresh DIR to recompute. Each record is the run's report: the scene
settings, the effects table (ran or skipped and why), notes, measurements with the planning
model's predictions, speed and the table row.

Results (``DIR/``)
------------------
``results.parquet`` and ``results.csv``: one row per point x repeat in point order — the
axis values (columns named by key), ``point``, ``repeat``, ``seed``, ``hash``, ``status``
(``ok``, ``failed``, ``missing`` when stopped early), ``error``, then :data:`RESULT_COLUMNS`.
``saturated`` (flat and bar targets; empty for other targets and runs without a result) is
true when the signal (the bright bars') plus dark charge per exposure reaches the full well
or the ADC's full scale: the output is clipped, so the run's SNR or measured MTF columns are
empty (a flat run's predictions are for a signal at that level; the run's
``points/<hash>.json`` says why in ``measurements.snr.note`` / ``measurements.mtf.note``).
In ``sweep.nc`` it is 1.0 / 0.0, NaN where empty.
``sweep.nc`` (netCDF-4 via h5netcdf): the same values as an :class:`xarray.Dataset` with
one dimension per product axis, ``zip`` for the zip group (its keys as coordinates along
it), and ``repeat``. ``summary.json`` and the plots: ``snr_vs_stages.png`` (flat targets,
measured gain per repeat with mean and standard deviation, the planning model and Tao et
al. 2012 eq 28), ``mtf_vs_mismatch.png`` (bar targets: MTF at the bar frequency against
M dV/V with the velocity-mismatch model of Yuan et al. 2013) and
``time_vs_fidelity.png``.

Every column except :data:`TIMING_COLUMNS` is a deterministic function of the sweep file
and the tdicam version: equal between serial and cluster runs, between two runs, and
between a resumed and an uninterrupted sweep.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from tdicam.version import __version__
from tdicam.sweeps.file import STORE_FORMAT, SweepRun, Sweep

__all__ = ["RESULT_COLUMNS", "TIMING_COLUMNS", "table", "dataset", "read_table",
           "write_results"]

#: Result columns of the table after the axis and bookkeeping columns, in order.
RESULT_COLUMNS = (
    "stages", "dv_over_v", "fidelity_requested", "fidelity",
    "mean_dn", "noise_dn", "saturated",
    "snr_output_db", "snr_single_db", "snr_gain_db", "snr_predicted_gain_db",
    "snr_eq28_gain_db",
    "mtf_frequency_cyc_per_px", "m_dv_over_v", "mtf_measured", "mtf_measured_ctf",
    "mtf_model_yuan2013", "mtf_model_footprint",
    "seconds", "cpu_seconds", "task_seconds", "lines_per_s",
)
#: Columns that measure time and so differ from run to run.
TIMING_COLUMNS = ("seconds", "cpu_seconds", "task_seconds", "lines_per_s")
_STRING_COLUMNS = ("fidelity_requested", "fidelity", "status", "error", "hash")
_BOOL_COLUMNS = ("saturated",)
_BOOK_COLUMNS = ("point", "repeat", "seed", "hash", "status", "error")


def _jsonable(o):
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    return str(o)


def _record_path(store: Path, h: str) -> Path:
    return store / f"{h}.json"


def _read_record(store: Path, h: str):
    """The finished record of run ``h`` or None (absent, unreadable or not this run's)."""
    try:
        rec = json.loads(_record_path(store, h).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict) or rec.get("hash") != h or "status" not in rec:
        return None
    return rec


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.parent / f".tmp-{path.name}-{os.getpid()}-{os.urandom(4).hex()}"
    try:
        with open(tmp, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _store_record(store: Path, sweep: Sweep, run: SweepRun, result: dict) -> dict:
    point = sweep.points[run.point]
    rec = {"format": STORE_FORMAT, "tdicam": __version__, "hash": run.hash,
           "sweep": str(sweep.path), "axes": point, "repeat": run.repeat, "seed": run.seed,
           "scene_settings": run.settings, "impact": sweep.impact, **result}
    _write_atomic(_record_path(store, run.hash),
                  json.dumps(rec, indent=1, default=_jsonable, allow_nan=False))
    return rec


def _rows(sweep: Sweep, done: dict) -> list[dict]:
    rows = []
    for run in sweep.runs:
        rec = done.get(run.hash)
        row = {k: _coord_value(v) for k, v in sweep.points[run.point].items()}
        row.update({"point": run.point, "repeat": run.repeat, "seed": run.seed,
                    "hash": run.hash, "status": "missing" if rec is None else rec["status"],
                    "error": None if rec is None else rec.get("error")})
        vals = (rec or {}).get("row") or {}
        for c in RESULT_COLUMNS:
            row[c] = vals.get(c)
        rows.append(row)
    return rows


def _coord_value(v):
    return json.dumps(v) if isinstance(v, (list, dict)) else v


def table(sweep: Sweep, done: dict):
    """The tidy :class:`pandas.DataFrame` of ``sweep`` from the records in ``done``."""
    import pandas as pd
    df = pd.DataFrame(_rows(sweep, done), columns=list(sweep.keys) + list(_BOOK_COLUMNS)
                      + list(RESULT_COLUMNS))
    for c in RESULT_COLUMNS:
        if c in _STRING_COLUMNS:
            df[c] = df[c].astype(object)
        elif c == "stages":
            df[c] = df[c].astype("Int64")
        elif c in _BOOL_COLUMNS:
            df[c] = df[c].astype("boolean")
        else:
            df[c] = pd.to_numeric(df[c], errors="coerce").astype("float64")
    df["seed"] = df["seed"].astype("int64")
    return df


def dataset(sweep: Sweep, df):
    """The labelled N-D :class:`xarray.Dataset` of the table ``df``."""
    import xarray as xr
    dims = [a.key for a in sweep.axes] + (["zip"] if sweep.zipped else []) + ["repeat"]
    shape = sweep.shape
    coords = {a.key: _coord_array(a.values) for a in sweep.axes}
    if sweep.zipped:
        for z in sweep.zipped:
            coords[z.key] = ("zip", _coord_array(z.values))
        coords["zip"] = np.arange(len(sweep.zipped[0].values))
    coords["repeat"] = np.arange(sweep.repeats)
    data = {}
    for c in ("seed",) + _BOOK_COLUMNS[3:] + RESULT_COLUMNS:
        col = df[c]
        if c in _STRING_COLUMNS:
            arr = np.array(["" if v is None or v != v else str(v) for v in col], dtype=object)
        elif c == "seed":
            arr = col.to_numpy(np.int64)
        else:       # Int64 and boolean columns too: NA -> NaN
            arr = col.astype("Float64").to_numpy(np.float64, na_value=np.nan)
        data[c] = (dims, arr.reshape(shape))
    ds = xr.Dataset(data, coords=coords,
                    attrs={"title": f"tdicam sweep {sweep.name}", "tdicam": __version__,
                           "sweep": str(sweep.path), "scene": str(sweep.scene_path)})
    return ds


def _coord_array(values):
    if any(isinstance(v, (list, dict)) for v in values):
        return np.array([json.dumps(v) for v in values], dtype=object)
    if all(isinstance(v, bool) for v in values):
        return np.array([int(v) for v in values], dtype=np.int8)
    if all(isinstance(v, str) for v in values):
        return np.array(values, dtype=object)
    return np.asarray(values)


def read_table(out_dir):
    """The tidy table a sweep wrote into ``out_dir`` (from ``results.parquet``)."""
    import pandas as pd
    return pd.read_parquet(Path(out_dir) / "results.parquet")


def write_results(sweep: Sweep, out_dir: Path, done: dict) -> list[str]:
    """Write table, dataset and plots atomically; return the file names written."""
    df = table(sweep, done)
    files = []

    def atomic(name, writer):
        final = out_dir / name
        tmp = out_dir / f".tmp-{name}-{os.getpid()}"
        try:
            writer(tmp)
            os.replace(tmp, final)
        finally:
            tmp.unlink(missing_ok=True)
        files.append(name)

    atomic("results.parquet", lambda p: df.to_parquet(p, index=False))
    atomic("results.csv", lambda p: df.to_csv(p, index=False))
    ds = dataset(sweep, df)
    atomic("sweep.nc", lambda p: ds.to_netcdf(p, engine="h5netcdf"))
    from tdicam.sweeps import plots
    for name, fig in plots.figures(sweep, df):
        atomic(name, lambda p, fig=fig: plots.save(fig, p))
    return files
