"""The run service behind ``tdicam run``: a scene in, the camera's images, figures and a
report out.

:func:`run_scene` simulates every point of the scene's sweep (``[tdi].stages`` x
``[motion].dv_over_v``) with the scene simulator (:mod:`tdicam.engine`), which runs only the
effects the scene needs at the scene's fidelity, and writes into the output directory:

* ``target.png``, ``raw_exposure.png``, ``tdi.png`` (8-bit, scaled for viewing) and
  ``raw_exposure.tif``, ``tdi.tif`` (16-bit TIFF of the DN values; wider outputs are shifted
  right to fit, the shift is in the report) of the largest stage count of the sweep;
* ``snr_vs_stages.png`` when the scene sweeps stages on a flat target, ``mtf.png`` on a bar
  target (model curves and measured points, vs M dV/V when the mismatch is swept);
* ``report.json`` and ``report.md``: the effects table (ran/skipped, why, fidelity and error
  bound, time, impact), measured SNR/MTF next to the planning model's prediction, speed
  (lines/s against the orbit's real-time line rate, exposure-pixels/s) and, with
  ``[run.rtl]``, the RTL co-simulation of the chosen blocks on the crop (pixels compared,
  mismatches).

A progress bar (tqdm) is shown on a terminal and stays quiet when stdout is not a TTY or
``CI`` is set. The command line is :mod:`tdicam.commands.run`.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["run_scene", "main_tiff_shift", "strict_json"]


def _progress_bar(total, desc):
    quiet = not sys.stdout.isatty() or bool(os.environ.get("CI"))
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    if quiet:
        return None
    return tqdm(total=total, desc=desc, unit="px", unit_scale=True, leave=False)


def run_scene(scene, out_dir, *, fidelity=None, lines=None, force=(), impact=True, rtl=True,
              progress=True):
    """Simulate every sweep point of ``scene``, write images, figures and reports.

    Returns the report dict (also written as ``report.json``).
    """
    from tdicam import engine
    from tdicam.measure import measure
    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise TdicamError(f"-o {str(out_dir)!r}: cannot create the directory: "
                          f"{exc.strerror}") from None
    n_lines = int(scene.run.lines if lines is None else lines)
    stages = scene.tdi.stages
    dvs = scene.motion.dv_over_v
    points = [(m, dv) for m in stages for dv in dvs]
    m_show = max(stages)
    total = sum((n_lines + m - 1) * m * scene.sensor.columns for m, _ in points)
    bar = _progress_bar(total, Path(scene.source).stem) if progress else None
    results, rows = {}, []
    t_all = time.perf_counter()
    crop = None
    if rtl and scene.run.rtl is not None:
        c = scene.run.rtl.crop or (0, 0, min(scene.sensor.columns, 32), min(n_lines, 8))
        x0, y0, w, h = c
        crop = (y0, h, x0, w)
    try:
        for m, dv in points:
            show = (m == m_show and dv == dvs[0])
            res = engine.simulate(scene, stages=m, dv_over_v=dv, fidelity=fidelity,
                                  force=force, lines=n_lines, impact=impact and show,
                                  progress=(bar.update if bar is not None else None),
                                  keep_crop=crop if show else None)
            meas = measure(scene, res)
            meas.update({"fidelity": res.fidelity, "seconds": res.seconds,
                         "lines_per_s": res.lines_per_s,
                         "exposure_pixels_per_s": res.exposure_pixels_per_s})
            if res.flash is not None:
                meas["nand"] = res.flash
            rows.append(meas)
            results[(m, dv)] = res
    finally:
        if bar is not None:
            bar.close()
    main = results[(m_show, dvs[0])]
    files = _write_images(out_dir, main)
    files += _figures(out_dir, scene, rows, main)
    rtl_report = None
    if crop is not None:
        from tdicam.rtl import cosim_scene
        rtl_report = cosim_scene(scene, main, crop, out_dir=out_dir)
    real_time = 1.0 / scene.line_period_s
    report = {
        "scene": scene.source,
        "scene_settings": scene.to_dict(),
        "fidelity_requested": fidelity or scene.run.fidelity,
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
        "wall_seconds": time.perf_counter() - t_all,
        "files": files,
        "tiff_shift": main_tiff_shift(main),
    }
    report["summary"] = _summary(scene, report)
    report = strict_json(report)
    (out_dir / "report.json").write_text(json.dumps(report, indent=2, default=_json,
                                                    allow_nan=False))
    (out_dir / "report.md").write_text(_markdown(scene, report))
    return report


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
    return files


def _figures(out_dir, scene, rows, main):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from tdicam.planning import mtf_prediction
    files = []
    flat = [r for r in rows if "snr" in r and r["snr"]["gain_db"] is not None]
    if scene.target.kind == "flat" and flat:
        fig, ax = plt.subplots(figsize=(6, 4))
        ms = np.array([r["stages"] for r in flat])
        ax.plot(ms, [r["snr"]["gain_db"] for r in flat], "o", label=f"measured ({main.fidelity})")
        mm = np.arange(1, max(ms) + 1)
        from tdicam.measure import snr_prediction
        cds = any(e["name"] == "reset_frames" and e["ran"] for e in
                  [x.to_dict() for x in main.effects])
        preds = [snr_prediction(scene, int(k), cds=cds) for k in mm]
        ax.plot(mm, [p["predicted_db"] for p in preds], "-", label="planning model G(m)")
        ax.plot(mm, [p["eq28_db"] for p in preds], "--",
                label="seed 003 eq 28 (worst case)" if scene.tdi.domain == "digital"
                else "eq-28 form (charge)")
        ax.set_xscale("log")
        ax.set_xlabel("TDI stages m")
        ax.set_ylabel("SNR gain over one exposure (dB)")
        ax.set_title(f"{Path(scene.source).stem}: SNR vs stages ({scene.tdi.domain})")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out_dir / "snr_vs_stages.png", dpi=110)
        plt.close(fig)
        files.append("snr_vs_stages.png")
    bars = [r for r in rows if "mtf" in r]
    if bars:
        fig, ax = plt.subplots(figsize=(6, 4))
        if len({r["dv_over_v"] for r in bars}) > 1:
            x = [r["mtf"]["m_dv_over_v"] for r in bars]
            ax.plot(x, [r["mtf"]["measured"] for r in bars], "o", label="measured")
            f = bars[0]["mtf"]["frequency_cyc_per_px"]
            for m in sorted({r["stages"] for r in bars}):
                # dV/V in (-1, 1): the image moves forward
                xx = np.linspace(0, min(max(max(x), 2.0), 0.999 * m), 200)
                pred = [mtf_prediction(scene, m, v / m, f) for v in xx]
                ax.plot(xx, [p["system"] for p in pred], "-", label=f"planned, M={m}")
                ax.plot(xx, [p["paper"]["system"] for p in pred], ":",
                        label=f"paper's model (Yuan 2013), M={m}")
            ax.set_xlabel("M dV/V (pixels)")
            ax.set_title(f"MTF at {f:g} cycles/px vs velocity mismatch")
        else:
            g = main.geometry
            ff = np.linspace(0, 0.5, 101)
            ax.plot(ff, np.abs(g.mtf_along(ff)), "-", label="footprint model (along)")
            pred = [mtf_prediction(scene, g.stages, g.dv_over_v, v) for v in ff]
            ax.plot(ff, [p["system"] for p in pred], "--", label="planned (along)")
            ax.plot(ff, [p["paper"]["system"] for p in pred], ":",
                    label="paper's model, Yuan 2013 (along)")
            for r in bars:
                ax.plot([r["mtf"]["frequency_cyc_per_px"]], [r["mtf"]["measured"]], "o",
                        label=f"measured M={r['stages']}")
            ax.set_xlabel("spatial frequency (cycles/pixel)")
            ax.set_title("MTF")
        ax.set_ylabel("MTF")
        ax.set_ylim(0, 1.05)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out_dir / "mtf.png", dpi=110)
        plt.close(fig)
        files.append("mtf.png")
    return files


def _fmt(v, f=".3g"):
    if v is None:
        return "-"
    if isinstance(v, float) and math.isinf(v):
        return "inf"
    return format(v, f)


def _reversed(t):
    return " (contrast reversed)" if t.get("planned_reversed") else ""


def _summary(scene, rep):
    sp = rep["speed"]
    lines = [f"{Path(scene.source).name}: {sp['lines']} lines x {sp['width']} px, "
             f"{sp['stages']} stages, {sp['fidelity']}: {sp['lines_per_s']:.0f} lines/s "
             f"({sp['x_real_time']:.2f}x real time {sp['real_time_lines_per_s']:.0f} lines/s), "
             f"{sp['exposure_pixels_per_s'] / 1e6:.1f} M exposure-pixels/s"]
    ran = [e["name"] for e in rep["effects"] if e["ran"]]
    lines.append(f"effects ran: {', '.join(ran)}")
    for r in rep["measurements"]:
        if "snr" in r:
            s = r["snr"]
            lines.append(f"  m={r['stages']}: SNR {_fmt(s['output_db'], '.2f')} dB, gain "
                         f"{_fmt(s['gain_db'], '.2f')} dB (predicted {s['predicted_db']:.2f}, "
                         f"eq 28 worst case {s['eq28_db']:.2f})")
        if "mtf" in r:
            t = r["mtf"]
            lines.append(f"  m={r['stages']} M dV/V={t['m_dv_over_v']:.3g}: MTF "
                         f"{_fmt(t['measured'], '.3f')} (planned {_fmt(t['planned'], '.3f')}"
                         f"{_reversed(t)}, paper's model {_fmt(t['seed001_model'], '.3f')}"
                         f", footprint {t['footprint_model']:.3f})")
    if rep["rtl"]:
        for b in rep["rtl"]["blocks"]:
            if b.get("status") == "ran":
                lines.append(f"  RTL {b['block']} on {rep['rtl']['simulator']}: "
                             f"{b['pixels_compared']} pixels compared, {b['mismatches']} "
                             f"mismatches")
            else:
                lines.append(f"  RTL {b['block']}: {b.get('status')}")
    return "\n".join(lines)


def _ratio(a, b):
    """``a / b`` for the report, or "-" (no temporal noise: no light, no read noise)."""
    return f"{a / b:.3g}" if b else "-"


def _markdown(scene, rep):
    sp = rep["speed"]
    md = [f"# tdicam run: {Path(scene.source).name}", ""]
    md.append(f"Fidelity requested: **{rep['fidelity_requested']}**; effects table for "
              f"stages = {rep['effects_config']['stages']}, dV/V = "
              f"{rep['effects_config']['dv_over_v']:g} ({rep['effects_config']['fidelity']}).")
    md += ["", "## Effects", "",
           "| effect | ran | why | fidelity | bound | time (s) | impact (PSNR dB / RMS DN) |",
           "|---|---|---|---|---|---|---|"]
    for e in rep["effects"]:
        imp = e["impact"]
        if imp is None:
            imp_s = "-"
        elif imp.get("psnr_db") is not None:
            imp_s = f"{_fmt(imp['psnr_db'], '.1f')} / {imp['rms_dn']:.3g}"
        else:
            imp_s = imp.get("note", "-")
        md.append(f"| {e['label']} | {'ran' if e['ran'] else 'skipped'} | "
                  f"{e['why'].replace('|', '/')} | {e['fidelity']} | {_fmt(e['bound'], '.2g')} | "
                  f"{e['seconds']:.3f} | {imp_s} |")
    md += [""] + [f"* {n}" for n in rep["notes"]]
    md += ["", "Impact: the output with the effect against the output without it, on a crop "
           "(same random numbers for every other effect); PSNR peak = output full scale.", ""]
    snr = [r for r in rep["measurements"] if "snr" in r]
    if snr:
        md += ["## Flat-field SNR vs the planning model", "",
               "| stages | fidelity | SNR out (dB) | SNR 1 exposure (dB) | measured gain (dB) | "
               "predicted gain (dB) | measured - predicted | eq 28 worst case (dB) |",
               "|---|---|---|---|---|---|---|---|"]
        for r in snr:
            s = r["snr"]
            d = None if s["gain_db"] is None else s["gain_db"] - s["predicted_db"]
            md.append(f"| {r['stages']} | {r['fidelity']} | {_fmt(s['output_db'], '.2f')} | "
                      f"{_fmt(s['single_db'], '.2f')} | {_fmt(s['gain_db'], '.2f')} | "
                      f"{s['predicted_db']:.2f} | {_fmt(d, '+.2f')} | {s['eq28_db']:.2f} |")
        s0 = snr[0]["snr"]
        md += ["", f"SNR: {s0['signal_definition']} (mean dark charge {s0['dark_e']:.3g} e- "
               "per exposure); the same for measured and predicted values.",
               "", f"Noise figures used: s_AD = {s0['sigma_ad_e']:.3g} e-, temporal s_CMOS = "
               f"{s0['sigma_cmos_e']:.3g} e-, fixed pattern {s0['sigma_fpn_e']:.3g} e- "
               f"(s_AD / s_CMOS = {_ratio(s0['sigma_ad_e'], s0['sigma_cmos_e'])}). Predicted: "
               "temporal noise, the row-to-row fixed pattern and the independent part of the "
               "quantization noise grow as sqrt(m), only the part the m exposures share grows "
               f"as m (rho = {s0['rho']:.3g} of the quantization variance here; a scene with "
               f"detail at this level would have {s0['rho_detail']:.3g}; "
               "tdicam.model.plan.snr_gain_digital_predicted). Seed 003 eq 28 lets all of "
               "the quantization noise grow as m: the paper's worst case.", ""]
    mtf = [r for r in rep["measurements"] if "mtf" in r]
    if mtf:
        md += ["## MTF at the bar frequency", "",
               "| stages | M dV/V | M Delta (with skew) | measured | (pi/4) CTF | planned | "
               "paper's model | footprint model |", "|---|---|---|---|---|---|---|---|"]
        for r in mtf:
            t = r["mtf"]
            md.append(f"| {r['stages']} | {t['m_dv_over_v']:.3g} | {t['m_delta_effective']:.3g} "
                      f"| {_fmt(t['measured'], '.3f')} | {_fmt(t['measured_ctf'], '.3f')} | "
                      f"{_fmt(t['planned'], '.3f')}{_reversed(t)} | "
                      f"{_fmt(t['seed001_model'], '.3f')} | {t['footprint_model']:.3f} |")
        md += ["", "All MTF values are moduli (contrast reversal is flagged). Planned: the "
               "planning model (tdicam.planning.mtf_prediction, the same as `tdicam plan`): "
               "full-line-period exposure, smear at the image speed 1 - dV/V, rolling-shutter "
               "skew, the M-stage term and the optics, along track. Paper's model: Yuan, Li, "
               "Xu and Nie, \"MTF velocity-mismatch model of TDI area-array CMOS image "
               "sensors\" (2013), aperture x temporal x sinc(f M dV/V) with the plain "
               "velocity mismatch. Footprint model: the exact stage footprint the simulator "
               "renders (tdicam.model.optics.Geometry). M Delta: the stage misregistration "
               "over M stages including the rolling-shutter skew.", ""]
        md += [f"* stages {r['stages']}, M dV/V {r['mtf']['m_dv_over_v']:.3g}: "
               f"{r['mtf']['note']}" for r in mtf if r["mtf"].get("note")]
    nand = [(r, f) for r in rep["measurements"] for f in r.get("nand") or ()]
    if nand:
        md += ["## NUC coefficients from NAND flash", "",
               "| stages | M dV/V | channel | bad blocks | words | corrected | uncorrectable | "
               "defaulted pixels |", "|---|---|---|---|---|---|---|---|"]
        md += [f"| {r['stages']} | {r['stages'] * r['dv_over_v']:.3g} | {f['channel']} | "
               f"{f['bad_blocks']} | {f['words']} | {f['corrected_words']} | "
               f"{f['uncorrectable_words']} | {f['defaulted_pixels']} of {f['pixels']} |"
               for r, f in nand]
        md += ["", "The coefficients of the window rows are stored in a 4 Gb NAND flash "
               "(2,048 + 64-byte pages, 64 pages per block, 4,096 blocks) with the scene's "
               "faults and loaded back as the camera does at power-up: bad-block scan, "
               "block map, 64/72 SECDED words (one flipped bit corrected), the default "
               "coefficients (gain 1, offset 0: that pixel uncorrected) for a word with two.",
               ""]
    md += ["## Speed", "",
           f"{sp['lines']} lines x {sp['width']} px, {sp['stages']} stages, {sp['fidelity']}: "
           f"{sp['seconds']:.3g} s, **{sp['lines_per_s']:.0f} lines/s** = "
           f"{sp['x_real_time']:.2f}x the real-time {sp['real_time_lines_per_s']:.0f} lines/s; "
           f"{sp['exposure_pixels_per_s'] / 1e6:.1f} M exposure-pixels/s"
           + (f" ({sp['exposure_pixels_per_cpu_s'] / 1e6:.1f} M per CPU-second; "
              f"{sp['threads']} threads on {sp['cpus']} CPUs, load average "
              f"{_fmt(sp['load_average_1min'], '.2f')})"
              if sp.get("exposure_pixels_per_cpu_s") else "") + ".", ""]
    if rep["rtl"]:
        md += ["## RTL co-simulation", "",
               f"Simulator {rep['rtl']['simulator']}, crop (y0, h, x0, w) = "
               f"{rep['rtl']['crop']}.", "", "| block | status | pixels compared | mismatches |",
               "|---|---|---|---|"]
        for b in rep["rtl"]["blocks"]:
            md.append(f"| {b['block']} | {b.get('status')} | {b.get('pixels_compared', '-')} | "
                      f"{b.get('mismatches', '-')} |")
        md.append("")
    md += ["## Files", ""] + [f"* {f}" for f in rep["files"]]
    if rep["tiff_shift"]:
        md.append(f"* tdi.tif holds the output shifted right by {rep['tiff_shift']} bits")
    return "\n".join(md) + "\n"
