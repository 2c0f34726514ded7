"""Trade-study sweeps over scene keys on Dask: resumable, one tidy table, one labelled dataset.

``tdicam sweep`` (:mod:`tdicam.commands.sweep`) is the command line of this service. The
sweep file, its points, runs and seeds: :mod:`tdicam.sweeps.file`. The store of finished runs
(resume), the table, the dataset and the figures: :mod:`tdicam.sweeps.results` and
:mod:`tdicam.sweeps.plots`.

Execution
---------
Each run is one task: :func:`tdicam.engine.simulate` then :func:`tdicam.run.measure.measure`.
Tasks go to a ``dask.distributed`` cluster — a local one of ``workers`` processes with one
thread each (default: the CPU count; ``TDICAM_THREADS=1`` in each worker), or an existing
scheduler at ``scheduler`` — or run in this process (``serial``). A worker that dies loses
only its running tasks, which Dask runs again elsewhere; a task that kills its worker
:data:`ALLOWED_FAILURES` times, or raises, is recorded as failed with a one-line error and
the sweep goes on.

The three modules stay apart so that each does one job: this one runs tasks, the others
read the sweep file and write the results.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import socket
import sys
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tdicam.files import check_dir, named, writing_in
from tdicam.version import __version__
from tdicam.errors import TdicamError, check_range
from tdicam.sweeps.file import (MAX_RUNS, STORE_FORMAT, Axis, SweepRun, Sweep, _show_point,
                                load_sweep, read_sweep, validate_sweep)
from tdicam.sweeps.results import (RESULT_COLUMNS, TIMING_COLUMNS, _jsonable, _read_record,
                                  _store_record, _write_atomic, read_table, write_results)

__all__ = ["MAX_RUNS", "ALLOWED_FAILURES", "STORE_FORMAT", "RESULT_COLUMNS", "TIMING_COLUMNS",
           "Axis", "SweepRun", "Sweep", "SweepResult", "load_sweep", "read_sweep", "validate_sweep",
           "finished_in", "run_sweep", "run_one", "read_table"]

#: A task whose worker dies this many times is recorded as failed.
ALLOWED_FAILURES = 3


def _one_line(exc) -> str:
    if isinstance(exc, TdicamError):
        return str(exc)
    text = " ".join(str(exc).split()) or "(no message)"
    return f"{type(exc).__name__}: {text}"


def _finite(v):
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def run_one(scene, impact=False) -> dict:
    """Simulate and measure one validated scene; never raises for an error of the run.

    Returns
    -------
    dict
        ``status`` (``ok`` or ``failed``), ``error`` (one line or None), ``row`` (the
        :data:`RESULT_COLUMNS` values), and the report parts: ``effects``, ``notes``,
        ``measurements``, ``speed``, ``worker``.
    """
    from tdicam import engine
    from tdicam.run.measure import measure
    t0 = time.perf_counter()
    worker = f"{socket.gethostname()}:{os.getpid()}"
    try:
        res = engine.simulate(scene, impact=impact)
        meas = measure(scene, res)
        out = np.asarray(res.output, np.float64)
        mean = float(out.mean()) - float(res.pedestal_output)
        noise = float(out.std()) if scene.target.kind == "flat" else None
    except Exception as exc:      # noqa: BLE001 - a failing run is recorded, the sweep goes on
        return {"status": "failed", "error": _one_line(exc), "row": None, "worker": worker,
                "task_seconds": time.perf_counter() - t0}
    snr, mtf = meas.get("snr", {}), meas.get("mtf", {})
    row = {
        "stages": int(res.stages), "dv_over_v": float(res.dv_over_v),
        "fidelity_requested": scene.run.fidelity, "fidelity": res.fidelity,
        "mean_dn": _finite(mean), "noise_dn": _finite(noise),
        "saturated": snr.get("saturated", mtf.get("saturated")),
        "snr_output_db": _finite(snr.get("output_db")),
        "snr_single_db": _finite(snr.get("single_db")),
        "snr_gain_db": _finite(snr.get("gain_db")),
        "snr_predicted_gain_db": _finite(snr.get("predicted_db")),
        "snr_eq28_gain_db": _finite(snr.get("eq28_db")),
        "mtf_frequency_cyc_per_px": _finite(mtf.get("frequency_cyc_per_px")),
        "m_dv_over_v": float(res.stages * res.dv_over_v),
        "mtf_measured": _finite(mtf.get("measured")),
        "mtf_measured_ctf": _finite(mtf.get("measured_ctf")),
        "mtf_model_yuan2013": _finite(mtf.get("yuan2013_model")),
        "mtf_model_footprint": _finite(mtf.get("footprint_model")),
        "seconds": float(res.seconds), "cpu_seconds": float(res.cpu_seconds),
        "task_seconds": time.perf_counter() - t0, "lines_per_s": _finite(res.lines_per_s),
    }
    return {"status": "ok", "error": None, "row": row, "worker": worker,
            "effects": [e.to_dict() for e in res.effects], "notes": list(res.notes),
            "measurements": json.loads(json.dumps(meas, default=_jsonable)),
            "speed": {"seconds": float(res.seconds), "cpu_seconds": float(res.cpu_seconds),
                      "lines_per_s": _finite(res.lines_per_s),
                      "exposure_pixels_per_s": _finite(res.exposure_pixels_per_s)}}


def _run_task(scene, impact):
    """Dask task body: :func:`run_one` (module-level so workers import it by name)."""
    return run_one(scene, impact)


@dataclass
class SweepResult:
    """What :func:`run_sweep` did: counts, failed runs, output files, timing."""

    sweep: Sweep
    out_dir: Path
    total: int
    computed: int
    reused: int
    failed: list
    missing: int
    files: list
    compute_seconds: float
    wall_seconds: float
    where: str
    saturated: int = 0

    def summary(self) -> str:
        """The lines ``tdicam sweep`` prints."""
        sw = self.sweep
        axes = ", ".join(f"{a.key} ({len(a.values)})" for a in sw.axes)
        if sw.zipped:
            axes += (", zip " + "+".join(z.key for z in sw.zipped)
                     + f" ({len(sw.zipped[0].values)})")
        rate = (f" ({self.computed / self.compute_seconds:.2f} runs/s)"
                if self.computed and self.compute_seconds > 0 else "")
        lines = [f"sweep {sw.name}: {len(sw.points)} points x {sw.repeats} repeats = "
                 f"{self.total} runs over {axes or 'no axes'}",
                 f"computed {self.computed}, reused {self.reused} from {self.out_dir}/points, "
                 f"failed {len(self.failed)}, missing {self.missing}; {self.where}: "
                 f"{self.compute_seconds:.1f} s{rate}, {self.wall_seconds:.1f} s in all"]
        if sw.validated < len(sw.points):
            lines.append(f"validated {sw.validated} of {len(sw.points)} points (--limit; "
                         f"every axis value checked): the others' runs are missing until a "
                         f"rerun reaches them")
        if sw.promoted:
            lines.append("axes taken from the scene's own lists: " + ", ".join(sw.promoted))
        for f in self.failed[:20]:
            lines.append(f"  failed: point {f['point']} ({_show_point(f['axes'])}) repeat "
                         f"{f['repeat']}: {f['error']}")
        if len(self.failed) > 20:
            lines.append(f"  ... and {len(self.failed) - 20} more failed runs "
                         f"(summary.json lists them all)")
        if self.saturated:
            lines.append(f"saturated: {self.saturated} run{'s' * (self.saturated > 1)} "
                         f"(output clipped at the full well "
                         f"or the ADC's full scale: no SNR or MTF measured; column "
                         f"'saturated')")
        if self.missing:
            lines.append(f"stopped early: {self.missing} runs not computed; run the same "
                         f"command again to finish (finished runs are reused)")
        lines.append(f"wrote {self.out_dir}/: " + ", ".join(self.files))
        return "\n".join(lines)


def _progress(total, initial, desc, enabled):
    if not enabled or not sys.stderr.isatty() or os.environ.get("CI"):
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, initial=initial, desc=desc, unit="run", leave=True)


def _local_cluster(workers):
    import logging

    from dask.distributed import LocalCluster
    n = workers if workers is not None else max(1, os.cpu_count() or 1)
    return LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                        dashboard_address=None, silence_logs=logging.CRITICAL,
                        env={"TDICAM_THREADS": "1"}), f"local Dask cluster of {n} workers"


def _connect(scheduler, timeout):
    from dask.distributed import Client
    try:
        return Client(scheduler, timeout=timeout)
    except Exception as exc:  # noqa: BLE001 - every failure to connect is one user error
        raise TdicamError(f"--scheduler {scheduler}: cannot connect within {timeout:g} s "
                          f"({_one_line(exc)})") from None


def _execute_dask(todo, sweep, client, on_done):
    """Submit every run in ``todo`` and pass each result to ``on_done`` as it finishes.

    Results are fetched in batches of whatever has finished (one round trip per batch, not
    per run); a batch that cannot be fetched whole is fetched run by run, and a run whose
    task failed (its worker died :data:`ALLOWED_FAILURES` times) becomes a failed record.
    """
    from dask.distributed import as_completed
    runs = list({r.hash: r for r in todo}.values())
    futures = client.map(_run_task, [r.scene for r in runs], [sweep.impact] * len(runs),
                         key=[f"tdicam-run-{r.hash}" for r in runs], pure=False)
    by_key = {f.key: r for f, r in zip(futures, runs)}
    pending = as_completed(futures, loop=client.loop)
    try:
        for batch in pending.batches():
            try:
                results = client.gather(batch)
            except Exception:  # noqa: BLE001 - one bad future: fetch the batch one by one
                results = [_result(f) for f in batch]
            for fut, result in zip(batch, results):
                fut.release()
                if not on_done(by_key[fut.key], result):
                    return
    finally:
        client.cancel([f for f in futures if not f.done()])


def _result(fut):
    try:
        return fut.result()
    except Exception as exc:  # noqa: BLE001 - KilledWorker and the like
        return {"status": "failed", "error": _one_line(exc), "row": None, "worker": None}


def finished_in(out_dir):
    """``finished(hash)`` for :func:`~tdicam.sweeps.file.validate_sweep`: whether
    ``out_dir/points`` holds run ``hash``'s finished (ok) record."""
    store = Path(out_dir) / "points"

    def finished(h):
        rec = _read_record(store, h)
        return rec is not None and rec["status"] == "ok"
    return finished


def _not_foreign(out_dir):
    """Refuse a folder that holds something and is not a sweep's (no ``points/``): the
    results would overwrite, or sit among, files that are not ours."""
    if not out_dir.is_dir() or (out_dir / "points").is_dir():
        return
    other = sorted(p.name for p in out_dir.iterdir())
    if other:
        raise TdicamError(f"{out_dir}: holds files that are not a tdicam sweep's "
                          f"({', '.join(other[:3])}{', ...' if len(other) > 3 else ''}); "
                          f"to resume a sweep give -o its folder (the one holding points/), "
                          f"else a new or empty folder")


def run_sweep(sweep: Sweep, out_dir, *, workers=None, scheduler=None, serial=False,
              limit=None, progress=True, connect_timeout=10.0, on_run=None) -> SweepResult:
    """Run the missing runs of ``sweep`` and write the results into ``out_dir``.

    Parameters
    ----------
    sweep : Sweep
        From :func:`load_sweep`.
    out_dir : str or Path
        Results directory; ``out_dir/points`` is the store (see the module docstring).
    workers : int, optional
        Processes of the local Dask cluster (default: the CPU count).
    scheduler : str, optional
        Address of a running ``dask scheduler`` to use instead of a local cluster.
    serial : bool
        Run every task in this process, in order (debugging).
    limit : int, optional
        Stop after computing this many runs (the rest stay missing for a rerun).
    progress : bool
        Show a progress bar (on a terminal, not with ``CI`` set).
    connect_timeout : float
        Seconds to wait for ``scheduler``.
    on_run : callable(run, record) -> None, optional
        Called after each computed run is stored (a test hook).

    Returns
    -------
    SweepResult

    Raises
    ------
    TdicamError
        ``out_dir`` cannot be created or holds files that are not a sweep's, or the
        scheduler cannot be reached.
    """
    t0 = time.perf_counter()
    if workers is not None:
        check_range("--workers", workers, 1, 256)
    if limit is not None:
        check_range("--limit", limit, 0, None)
    _not_foreign(named(out_dir))
    made = [p for p in (Path(out_dir), Path(out_dir) / "points") if not p.exists()]
    out_dir = check_dir(out_dir)
    store = check_dir(out_dir / "points")
    try:
        return _run_sweep(sweep, out_dir, store, workers=workers, scheduler=scheduler,
                          serial=serial, limit=limit, progress=progress,
                          connect_timeout=connect_timeout, on_run=on_run, t0=t0)
    except BaseException:
        # refused or failed before any run was stored: leave nothing this call made
        for folder in reversed(made):
            with contextlib.suppress(OSError):
                folder.rmdir()          # only when still empty
        raise


def _run_sweep(sweep, out_dir, store, *, workers, scheduler, serial, limit, progress,
               connect_timeout, on_run, t0):
    """The body of :func:`run_sweep` once ``out_dir`` and its store exist: reuse the stored
    runs, compute the missing ones (up to ``limit``), write the results and the summary."""
    done = _stored_runs(sweep, store)
    reused = sum(1 for r in sweep.runs if r.hash in done)
    todo = [r for r in sweep.runs if r.hash and r.hash not in done]  # "": not validated
    computed = 0
    runs_of = Counter(r.hash for r in sweep.runs if r.hash)
    bar = _progress(len(sweep.runs), reused, sweep.name, progress)

    def on_done(run, result):
        nonlocal computed
        with writing_in(store):
            done[run.hash] = _store_record(store, sweep, run, result)
        computed += 1
        if bar is not None:
            bar.update(runs_of[run.hash])
        if on_run is not None:
            on_run(run, done[run.hash])
        return limit is None or computed < limit

    t_exec = time.perf_counter()
    try:
        where = _compute(todo, sweep, on_done, workers=workers, scheduler=scheduler,
                         serial=serial, limit=limit, connect_timeout=connect_timeout)
    finally:
        if bar is not None:
            bar.close()
    t_exec = time.perf_counter() - t_exec
    return _finish(sweep, out_dir, done, computed=computed, reused=reused, where=where,
                   t_exec=t_exec, t0=t0)


def _stored_runs(sweep, store):
    """The sweep's runs already stored with status ``ok``: {hash: record}."""
    done = {}
    for run in sweep.runs:
        if run.hash and run.hash not in done:       # "": a point not validated (limit)
            rec = _read_record(store, run.hash)
            if rec is not None and rec["status"] == "ok":
                done[run.hash] = rec
    return done


def _compute(todo, sweep, on_done, *, workers, scheduler, serial, limit, connect_timeout):
    """Compute the runs ``todo`` (each distinct hash once), in this process with ``serial``
    else on Dask, until ``on_done`` returns False; where they ran, in words."""
    where = "serial"
    if todo and (limit is None or limit > 0):
        if serial:
            seen = set()
            for run in todo:
                if run.hash in seen:
                    continue
                seen.add(run.hash)
                if not on_done(run, run_one(run.scene, sweep.impact)):
                    break
        else:
            _run_on_dask(todo, sweep, on_done, workers, scheduler, connect_timeout)
            where = (f"Dask scheduler {scheduler}" if scheduler else
                     f"local Dask cluster of {workers or os.cpu_count() or 1} workers")
    elif not serial:
        where = "nothing to compute"
    return where


def _finish(sweep, out_dir, done, *, computed, reused, where, t_exec, t0):
    """Write the result files and ``summary.json`` into ``out_dir``; the SweepResult."""
    with writing_in(out_dir):
        files = write_results(sweep, out_dir, done)
    failed = [{"point": r.point, "repeat": r.repeat, "hash": r.hash,
               "axes": sweep.points[r.point], "error": done[r.hash]["error"]}
              for r in sweep.runs if r.hash in done and done[r.hash]["status"] != "ok"]
    missing = sum(1 for r in sweep.runs if r.hash not in done)
    saturated = sum(1 for r in sweep.runs
                    if ((done.get(r.hash) or {}).get("row") or {}).get("saturated"))
    result = SweepResult(sweep, out_dir, len(sweep.runs), computed, reused, failed, missing,
                         files, t_exec, time.perf_counter() - t0, where, saturated)
    summary = {"name": sweep.name, "sweep": str(sweep.path), "scene": str(sweep.scene_path),
               "axes": {a.key: list(a.values) for a in sweep.axes},
               "zip": {z.key: list(z.values) for z in sweep.zipped},
               "repeats": sweep.repeats, "runs": result.total, "computed": computed,
               "reused": reused, "failed": failed, "missing": missing,
               "saturated": saturated, "where": where,
               "compute_seconds": t_exec, "wall_seconds": result.wall_seconds,
               "files": files,
               "tdicam": __version__}
    with writing_in(out_dir):
        _write_atomic(out_dir / "summary.json", json.dumps(summary, indent=1,
                                                           default=_jsonable))
    result.files = files + ["summary.json"]
    return result


def _ignore_sigint_plugin():
    """A worker plugin (:class:`dask.distributed.WorkerPlugin`) for a local cluster: Ctrl-C
    reaches the whole process group, and only ``tdicam sweep`` itself should stop (it closes
    its workers, without their tracebacks)."""
    from dask.distributed import WorkerPlugin

    class IgnoreSigint(WorkerPlugin):
        def setup(self, worker):
            import signal
            try:
                signal.signal(signal.SIGINT, signal.SIG_IGN)
            except ValueError:      # not the worker process's main thread: leave it
                pass
    return IgnoreSigint()


def _run_on_dask(todo, sweep, on_done, workers, scheduler, connect_timeout):
    import dask
    from dask.distributed import Client
    # a local scheduler: every run queued on the workers at once (fewer round trips; Dask
    # steals work from a busy worker), a run that kills its worker tried ALLOWED_FAILURES times
    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES - 1,
                          "distributed.scheduler.worker-saturation": "inf"}):
        if scheduler:
            client, cluster = _connect(scheduler, connect_timeout), None
        else:
            cluster, _ = _local_cluster(workers)
            client = Client(cluster)
            client.register_plugin(_ignore_sigint_plugin(), name="tdicam-ignore-sigint")
        try:
            _execute_dask(todo, sweep, client, on_done)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
