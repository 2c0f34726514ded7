"""The run service behind ``tdicam run``: a scene in, the camera's images, figures and a
report out.

:func:`run_scene` simulates every point of the scene's sweep (``[tdi].stages`` x
``[motion].dv_over_v``) with the scene simulator (:mod:`tdicam.engine`), which runs only the
effects the scene needs at the scene's fidelity, and writes into the output directory (the
images are of the largest stage count of the sweep):

* ``target.png``, ``raw_exposure.png``, ``tdi.png`` (8-bit, stretched for viewing);
  ``raw_exposure.tif``, ``tdi.tif`` (16-bit TIFF of the DN values; wider outputs are shifted
  right to fit, the shift is in the report); ``raw_exposure.npy``, ``tdi.npy`` (the DN values
  with every bit, in their own integer dtype);
* ``crop.png`` (a 64 x 64 crop of the raw exposure and the output, axes in pixels, on one
  relative scale), ``profile.png`` (a normalised line profile through it, the target on the
  same axis) and, for a target that is not constant, ``difference.png`` (the output on the
  target's scale minus the target);
* ``snr_vs_stages.png`` when the scene sweeps stages on a flat target, ``mtf.png`` on a bar
  target (model curves and measured points, vs M dV/V when the mismatch is swept);
* ``eyes.png`` with ``[run.rtl]`` of a scene whose lanes publish their training
  (``[sensor.lvds].eye_status``): lanes x delay taps, pass/fail, the chosen tap marked
  (:mod:`tdicam.run.eyes`; its numbers in report.json's ``rtl.eyes``);
* ``report.json``, ``report.md`` and ``report.html``  (report.md with every figure inline,
  :mod:`tdicam.run.html`; :mod:`tdicam.run.report`): the configuration (ground
  speed, line period, required frame rate, window, stages, fidelity), the effects table
  (ran/skipped, why, fidelity and error bound, time, impact), measured SNR/MTF next to the
  planning model's prediction, speed and, with ``[run.rtl]``, the RTL co-simulation of the
  chosen blocks on the crop.

Files of an earlier run in the same directory are never mixed with the new ones: what the
previous ``report.json`` lists and this run does not write again is removed; any other file
there (not written by tdicam) is left alone and listed in the report.

With ``progress``, long work shows where it is (:class:`tdicam.progress.Progress`): on a
terminal a bar over the exposures simulated, named by the stage (each sweep point, the
measurements, the figures, the RTL co-simulation, the report); elsewhere one line per stage on
stderr. The command line is :mod:`tdicam.commands.run`.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tdicam.files import check_dir, staged_dir, writing_in
from tdicam.progress import Progress
from tdicam.run.figures import write_figures
from tdicam.run.html import html_report
from tdicam.run.report import FILE_NOTES, configuration, markdown, summary

__all__ = ["run_scene", "check_output", "SceneRun", "simulate_scene", "write_run", "memory_check",
           "main_tiff_shift", "strict_json"]


def run_scene(scene, out_dir, *, fidelity=None, lines=None, force=(), impact=True, rtl=True,
              progress=True, labels=None):
    """Simulate every sweep point of ``scene``, write images, figures and reports.

    :func:`simulate_scene` then :func:`write_run`, with ``out_dir`` checked first
    (:func:`check_output`): a bad output path is refused before the work. A run refused or
    failed at any point leaves ``out_dir`` as it was. Returns the report dict (also written
    as ``report.json``).
    """
    check_output(out_dir)
    return write_run(simulate_scene(scene, fidelity=fidelity, lines=lines, force=force,
                                    impact=impact, rtl=rtl, progress=progress,
                                    labels=labels), out_dir)


def check_output(out_dir) -> Path:
    """``out_dir`` as a Path once :func:`write_run` can write there (a folder one can write
    in, or a name one can create), else the one-line error; nothing is made."""
    return check_dir(out_dir, create=False)


@dataclass
class SceneRun:
    """The computed sweep points of a scene, before anything is written (:func:`write_run`).

    ``main`` is the engine's result (:class:`tdicam.engine.SceneResult`) of the point whose
    images are kept (the largest stage count at the first ``dV/V``); ``rows`` the
    measurements of every point in sweep order (stages outer, ``dV/V`` inner); ``crop`` the
    ``(y0, h, x0, w)`` window of the ``[run.rtl]`` co-simulation (None: none); ``plan`` the
    plan's verdict on the scene (:func:`tdicam.planning.sizing.verdict`: a scene the
    planned camera cannot run is simulated all the same, and its report says so);
    ``progress`` whether the run shows its progress (so does :func:`write_run` of it, by
    default).
    """

    scene: object
    fidelity: str | None
    main: object
    rows: list
    memory: object
    crop: tuple | None
    started: float
    plan: dict | None = None
    progress: bool = False


def simulate_scene(scene, *, fidelity=None, lines=None, force=(), impact=True, rtl=True,
                   progress=True, labels=None) -> SceneRun:
    """Simulate every sweep point of ``scene`` (``[tdi].stages`` x ``[motion].dv_over_v``)
    and measure it; nothing is written.

    Before any work the run's peak memory is estimated
    (:func:`tdicam.engine.budget.estimate`) and a run that cannot fit the memory available
    is refused; every point is checked (:func:`tdicam.engine.check_point`) and
    ``TDICAM_THREADS`` read. ``labels`` names overridden keys in messages as the user wrote
    them (``{"run.lines": "--lines"}``). ``rtl``: keep the ``[run.rtl]`` crop, co-simulated
    by :func:`write_run`.
    """
    from tdicam import engine
    from tdicam.planning.sizing import verdict
    from tdicam.run.measure import measure
    engine.threads()
    mem = memory_check(scene, fidelity=fidelity, lines=lines, force=force, impact=impact,
                       rtl=rtl, labels=labels)
    n_lines = int(scene.run.lines if lines is None else lines)
    stages = scene.tdi.stages
    dvs = scene.motion.dv_over_v
    points = [(m, dv) for m in stages for dv in dvs]
    m_show = max(stages)
    total = sum((n_lines + m - 1) * m * scene.sensor.columns for m, _ in points)
    bar = Progress(Path(scene.source).stem, total, unit="px", enabled=bool(progress),
                   stages=len(points) + 1)
    main, rows = None, []
    t_all = time.perf_counter()
    crop = None
    if rtl and scene.run.rtl is not None:
        c = scene.run.rtl.crop or (0, 0, min(scene.sensor.columns, 32), min(n_lines, 8))
        x0, y0, w, h = c
        crop = (y0, h, x0, w)
    try:
        for m, dv in points:
            show = (m == m_show and dv == dvs[0])
            bar.stage(f"simulating m={m} dV/V={dv:g}" + (" and each effect's impact"
                                                          if impact and show else ""))
            res = engine.simulate(scene, stages=m, dv_over_v=dv, fidelity=fidelity,
                                  force=force, lines=n_lines, impact=impact and show,
                                  progress=bar.update, keep_crop=crop if show else None)
            meas = measure(scene, res)
            meas.update({"fidelity": res.fidelity, "seconds": res.seconds,
                         "lines_per_s": res.lines_per_s,
                         "exposure_pixels_per_s": res.exposure_pixels_per_s})
            if res.flash is not None:
                meas["nand"] = res.flash
            rows.append(meas)
            if show:
                main = res       # only the images of the main point are kept
            del res
        bar.stage("done")
    finally:
        bar.close()
    return SceneRun(scene, fidelity, main, rows, mem, crop, t_all, verdict(scene),
                    bool(progress))


def write_run(run: SceneRun, out_dir, *, progress=None) -> dict:
    """Write ``run``'s images, figures and reports into ``out_dir`` (the module docstring
    lists them); with a ``[run.rtl]`` crop, co-simulate it first.

    The files are written into a staging folder and moved to ``out_dir`` at the end
    (:func:`tdicam.files.staged_dir`): a failure leaves ``out_dir`` as it was. Returns the
    report dict (also written as ``report.json``). ``progress``: name each stage as it
    starts (:class:`tdicam.progress.Progress`; default: as the run did).
    """
    progress = run.progress if progress is None else progress
    steps = 3 if run.crop is not None else 2      # the stages _write names
    with staged_dir(out_dir) as stage, \
            Progress(f"{Path(run.scene.source).stem}: writing", enabled=bool(progress),
                     stages=steps) as bar:
        report = _write(run, Path(out_dir), stage, bar)
    for name in report["stale_files"]["removed"]:
        (Path(out_dir) / name).unlink(missing_ok=True)
    return report


def memory_check(scene, *, fidelity=None, lines=None, force=(), impact=True, rtl=True,
                 labels=None):
    """The run's :class:`~tdicam.engine.budget.MemoryEstimate`, with the memory available;
    a one-line :class:`~tdicam.errors.TdicamError` when it does not fit (what it needs,
    what there is, what to change) or, with ``rtl``, when ``[run.rtl].lane_dies`` cannot be
    placed in the co-simulation, or its design cannot be built
    (:func:`tdicam.chain.cosim.check_rtl_design`)."""
    from tdicam.chain.cosim import check_rtl_design
    from tdicam.engine import budget
    if rtl:
        check_rtl_design(scene, int(scene.run.lines if lines is None else lines),
                         lines_key=(labels or {}).get("run.lines", "[run].lines"))
    est = budget.estimate(scene, fidelity=fidelity, lines=lines, force=force, impact=impact,
                          rtl=rtl)
    return budget.check_fits(scene, est, fidelity=fidelity, lines=lines, labels=labels)


def _write(run, out_dir, stage, bar):
    """The files of :func:`write_run`, written into ``stage``; ``bar`` names the stages."""
    from tdicam import engine
    scene, main, rows, crop, fidelity = run.scene, run.main, run.rows, run.crop, run.fidelity
    mem, t_all = run.memory, run.started
    final_dir, out_dir = out_dir, stage
    previous = _previous_files(final_dir)
    bar.stage("images and figures")
    with writing_in(out_dir):
        files = _write_images(out_dir, main)
        files += write_figures(out_dir, scene, rows, main)
    rtl_report = None
    if crop is not None:
        from tdicam.chain.cosim import cosim_scene
        bar.stage("co-simulating the RTL crop")
        rtl_report = cosim_scene(scene, main, crop, out_dir=out_dir)
        wave = (rtl_report or {}).get("waveform")
        if wave and Path(wave).parent.resolve() == out_dir.resolve():
            files.append(Path(wave).name)
        rtl_report = _moved(rtl_report, str(out_dir), str(final_dir))
        if (rtl_report or {}).get("eyes"):
            from tdicam.run.eyes import EYES_PNG, eye_figure
            with writing_in(out_dir):
                eye_figure(rtl_report["eyes"], out_dir / EYES_PNG,
                           title="The chain's co-simulation (generic PHY): pass mask over "
                                 "the delay taps")
            files.append(EYES_PNG)
        for row in (rtl_report or {}).get("phy_checks") or []:
            if row.get("eyes"):
                from tdicam.run.eyes import device_png, eye_figure
                with writing_in(out_dir):
                    eye_figure(row["eyes"], out_dir / device_png(row["phy"]),
                               title=f"The {row['phy']} receiver from serial bits: pass "
                                     f"mask over its delay taps")
                files.append(device_png(row["phy"]))
    real_time = 1.0 / scene.line_period_s
    requested = fidelity or scene.run.fidelity
    bar.stage("the report")
    report = {
        "scene": scene.source,
        "configuration": configuration(scene, main, rows, requested,
                                       main_tiff_shift(main), memory=mem),
        "scene_settings": scene.to_dict(),
        "fidelity_requested": requested,
        "effects": [e.to_dict() for e in main.effects],
        "effects_config": {"stages": main.stages, "dv_over_v": main.dv_over_v,
                           "fidelity": main.fidelity},
        "notes": main.notes,
        "measurements": rows,
        "speed": {"lines_per_s": main.lines_per_s, "real_time_lines_per_s": real_time,
                  "x_real_time": main.lines_per_s / real_time,
                  "exposure_pixels_per_s": main.exposure_pixels_per_s,
                  "lines": int(main.output.shape[0]), "width": int(main.output.shape[1]),
                  "stages": main.stages, "seconds": main.seconds,
                  "fidelity": main.fidelity, "cpu_seconds": main.cpu_seconds,
                  "exposure_pixels_per_cpu_s": (main.exposure_pixels / main.cpu_seconds
                                                if main.cpu_seconds > 0 else None),
                  "threads": engine.threads(), "cpus": os.cpu_count(),
                  "load_average_1min": _loadavg()},
        "rtl": rtl_report,
        "plan": run.plan,
        "wall_seconds": time.perf_counter() - t_all,
        "files": files,
        "tiff_shift": main_tiff_shift(main),
        "stale_files": _stale(final_dir, previous, files),
    }
    report["summary"] = summary(scene, report)
    report = strict_json(report)
    with writing_in(out_dir):
        (out_dir / "report.json").write_text(json.dumps(report, indent=2, default=_json,
                                                        allow_nan=False))
        md = markdown(scene, report)
        (out_dir / "report.md").write_text(md)
        (out_dir / "report.html").write_text(html_report(md, out_dir, files, FILE_NOTES))
    return report


_REPORTS = ("report.json", "report.md", "report.html")


def _previous_files(out_dir):
    """Names an earlier ``tdicam run`` wrote into ``out_dir`` (its report.json's list), or
    None when there is no readable earlier report."""
    try:
        old = json.loads((out_dir / "report.json").read_text())
        names = [str(f) for f in old.get("files", [])]
    except (OSError, ValueError, AttributeError):
        return None
    # only plain names inside out_dir: a damaged report must not point elsewhere
    return {n for n in names if n and Path(n).name == n and n not in (".", "..")}


def _stale(out_dir, previous, files):
    """What the earlier run wrote and this one does not (``removed``: :func:`run_scene`
    removes them once the new files are in place), and the rest of the folder's files
    (``other``: not tdicam's, left alone)."""
    if not out_dir.is_dir():
        return {"removed": [], "other": []}
    removed = [name for name in sorted((previous or set()) - set(files) - set(_REPORTS))
               if (out_dir / name).is_file()]
    keep = set(files) | set(_REPORTS) | set(removed)
    other = sorted(p.name + ("/" if p.is_dir() else "") for p in out_dir.iterdir()
                   if p.name not in keep and not p.name.startswith(".tdicam-staging-"))
    return {"removed": removed, "other": other}


def _moved(v, old, new):
    """``v`` (a report part) with the staging folder's path ``old`` replaced by ``new`` in
    its strings."""
    if isinstance(v, str):
        return v.replace(old, new)
    if isinstance(v, dict):
        return {k: _moved(x, old, new) for k, x in v.items()}
    if isinstance(v, list):
        return [_moved(x, old, new) for x in v]
    return v


def _loadavg():
    try:
        return os.getloadavg()[0]
    except OSError:
        return None


def strict_json(report):
    """``report`` with every non-finite number (inf, nan) replaced by null, and the reason
    listed under ``"nulls"`` (JSON path -> what the value was): report.json is strict JSON,
    readable by every parser."""
    nulls = {}

    def walk(v, path):
        if isinstance(v, (float, np.floating)) and not math.isfinite(v):
            nulls[path] = f"{float(v)!r}: not a finite number"
            return None
        if isinstance(v, dict):
            return {k: walk(x, f"{path}.{k}") for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [walk(x, f"{path}[{i}]") for i, x in enumerate(v)]
        return v
    out = walk(report, "$")
    if nulls:
        out["nulls"] = nulls
    return out


def _json(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    return str(o)


def main_tiff_shift(res):
    bits = max(1, int(res.output_full_scale).bit_length())
    return max(0, bits - 16)


def _to8(img, lo=None, hi=None):
    a = np.asarray(img, np.float64)
    lo = float(np.percentile(a, 0.5)) if lo is None else lo
    hi = float(np.percentile(a, 99.5)) if hi is None else hi
    if hi <= lo:
        hi = lo + 1.0
    return np.clip((a - lo) / (hi - lo) * 255.0 + 0.5, 0, 255).astype(np.uint8)


def _write_images(out_dir, res):
    from PIL import Image
    files = []

    def png(name, arr):
        Image.fromarray(arr).save(out_dir / name)
        files.append(name)
    png("target.png", _to8(res.target, 0.0, 1.0))
    png("raw_exposure.png", _to8(res.raw))
    png("tdi.png", _to8(res.output))
    try:
        import tifffile
    except ImportError:
        tifffile = None
    shift = main_tiff_shift(res)
    for name, arr, sh in (("raw_exposure.tif", res.raw, 0), ("tdi.tif", res.output, shift)):
        a = (np.asarray(arr, np.int64) >> sh).clip(0, 65535).astype(np.uint16)
        if tifffile is not None:
            tifffile.imwrite(out_dir / name, a)
        else:
            Image.fromarray(a).save(out_dir / name)
        files.append(name)
    for name, arr in (("raw_exposure.npy", res.raw), ("tdi.npy", res.output)):
        np.save(out_dir / name, np.asarray(arr))
        files.append(name)
    return files
