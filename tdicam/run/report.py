"""The report of ``tdicam run``: the configuration it ran, the one-paragraph summary it
prints, and ``report.md`` — every table with the words a newcomer needs to read it (raw
exposure vs TDI output, the TIFF shift, the fidelities and their bound, PSNR and RMS DN,
M Delta, the footprint model) and the papers cited by author, title and year.

:func:`configuration` is stored in ``report.json`` under ``"configuration"``;
:func:`summary` and :func:`markdown` read only the report dict, so a stored report can be
re-rendered. The files are written by :func:`tdicam.run.runner.run_scene`.
"""

from __future__ import annotations

import math
from pathlib import Path

from tdicam.run.eyes import device_png
from tdicam.run.quality_report import markdown_lines, summary_lines
from tdicam.scene.sections import RTL_PHYS

__all__ = ["configuration", "config_lines", "summary", "markdown", "FILE_NOTES", "PAPERS",
           "phy_lines"]

#: The papers the model follows, as cited in the report (short name -> citation).
PAPERS = {
    "Qu et al. 2010": "Qu Hongsong, Zhang Ye, Jin Guang, \"Improving the function of "
                      "area-array CMOS image sensors with a digital-domain TDI algorithm\", "
                      "Optics and Precision Engineering 18(8), 2010",
    "Yuan et al. 2013": "Yuan Gaobin, Li Binqiao, Xu Jiangtao, Nie Kaiming, \"MTF "
                        "velocity-mismatch model of TDI area-array CMOS image sensors\", 2013",
    "Ning et al. 2019": "Ning Yonghui, Liu Hui, Zhao Qinglei, Guo Hanzhou, \"Design of a "
                        "large-array high-frame-rate CMOS imaging electronics system\", "
                        "Optics and Precision Engineering 27(5), 2019",
    "Tao et al. 2012": "Tao Shuping, Jin Guang, Qu Hongsong, He Xiaojun, Yang Xiubin, "
                       "\"Design and analysis of a digital-domain TDI CMOS camera for "
                       "high-resolution space imaging\", 2012",
    "Zhou et al. 2008": "Zhou Huaide, Liu Haiying, Xu Dong, Li Guangze, Wang Ye, Liu Jinguo, "
                        "\"TDI operation of interline-transfer area CCDs\", Optics and "
                        "Precision Engineering 16(9), 2008",
}

#: What each file ``tdicam run`` may write is (name -> one line).
FILE_NOTES = {
    "target.png": "the ideal target at the output pixels (relative radiance 0..1, no "
                  "sensor effects)",
    "raw_exposure.png": "one raw exposure of every ground line (a single read of the "
                        "sensor, HG channel), 8-bit, stretched from the 0.5th to the "
                        "99.5th percentile for viewing",
    "tdi.png": "the camera output after TDI (and the pipeline blocks), 8-bit, stretched the "
               "same way",
    "raw_exposure.tif": "the raw exposure as 16-bit DN values (not stretched)",
    "tdi.tif": "the output as 16-bit DN values; an output wider than 16 bits is shifted "
               "right to fit (the shift is stated below; tdi.npy has every bit)",
    "tdi.npy": "the output as exact DN values, every bit, its own integer dtype "
               "(numpy.load); with fidelity exact these are the golden TDI accumulator's "
               "outputs bit for bit",
    "raw_exposure.npy": "the raw exposure as exact DN values (numpy.load)",
    "crop.png": "a crop (up to 64 x 64, centred) of the raw exposure and the output side by "
                "side at full resolution, axes in pixels, on one relative scale (each above "
                "zero light over its mean, one colour range: the noise TDI removes shows)",
    "profile.png": "a normalised line profile through the crop: raw exposure and output "
                   "scaled to the target's mean, the target on the same axis",
    "difference.png": "the TDI output on the target's scale (least-squares gain and offset) "
                      "minus the ideal target, the whole image",
    "snr_vs_stages.png": "flat target: measured SNR gain against the stage count, with the "
                         "planning model and Tao et al. 2012 eq 28",
    "eyes.png": "the sensor lanes' training as the chain's co-simulation measured it (the "
                "generic PHY's eye-status ports, the link model's captures in): lanes x "
                "delay taps, the taps where the training word passed (green), the chosen "
                "tap (x), with tracking the tap at the end (o), lanes in error labelled; "
                "the numbers are report.json's rtl.eyes",
    **{device_png(phy): f"the sensor lanes' training as the {phy} PHY's receiver measured "
                        f"it from serial bits ([run.rtl].phy; its eye-status ports, over its "
                        f"own delay taps), drawn as eyes.png; the numbers are report.json's "
                        f"rtl.phy_checks[].eyes" for phy in RTL_PHYS if phy != "generic"},
    "mtf.png": "bar target: measured MTF with the planning model, Yuan et al. 2013's model "
               "and the footprint model",
    "pipeline_mismatch.fst": "RTL co-simulation: waveform around the first mismatch "
                             "(GTKWave, Surfer)",
    "report.json": "everything in this report, machine-readable (strict JSON: a value that "
                   "is not a finite number is null and listed under \"nulls\")",
    "report.md": "this report",
    "report.html": "this report as one HTML page, every figure above inline",
}


def _fmt(v, f=".3g"):
    if v is None:
        return "-"
    if isinstance(v, float) and math.isinf(v):
        return "inf"
    return format(v, f)


def configuration(scene, main, rows, fidelity_requested, tiff_shift, memory=None, lines=None):
    """What was simulated, as one dict: platform, ground (or surface) speed, line period,
    the full-frame rate the sensor needs for the window (Qu et al. 2010 eqs 6-9), the
    window, stages, mismatch, fidelity requested and used, bit widths, and the memory
    estimate (``memory``, a :class:`~tdicam.engine.budget.MemoryEstimate`).

    Before a run (``tdicam run --dry-run``) ``main`` and ``rows`` are None: the fidelity
    used is the estimate's per point, ``lines`` the lines to simulate, the output width is
    not known yet (None)."""
    from tdicam.model.physics import plan as _plan
    s = scene.sensor
    t_line = scene.line_period_s
    m_max = max(scene.tdi.stages)
    if scene.orbit is not None:
        platform = {"kind": "orbit", "altitude_km": scene.orbit.altitude_km,
                    "gsd_m": scene.orbit.gsd_m, "ground_speed_m_s": scene.orbit.ground_speed_m_s}
    else:
        t = scene.turntable
        platform = {"kind": "turntable", "angular_speed_rad_s": t.angular_speed_rad_s,
                    "distance_m": t.distance_m,
                    "surface_speed_m_s": t.angular_speed_rad_s * t.distance_m}
    timing = scene.timing
    return {
        "platform": platform,
        "line_period_s": t_line, "line_rate_hz": 1.0 / t_line,
        "required_frame_rate_hz": float(_plan.required_frame_rate(m_max, s.rows, t_line)),
        "available_frame_rate_hz": s.available_frame_rate_hz,
        "sensor": {"columns": s.columns, "rows": s.rows, "bits": s.bits,
                   "shutter": s.shutter, "gains": list(s.gains)},
        "window": {"columns": s.columns, "rows": m_max,
                   "m0": None if timing is None else timing.m0},
        "stages": list(scene.tdi.stages), "tdi_domain": scene.tdi.domain,
        "dv_over_v": list(scene.motion.dv_over_v),
        "lines": int(main.output.shape[0]) if main is not None
        else int(scene.run.lines if lines is None else lines),
        "pipeline": list(scene.pipeline.blocks),
        "fidelity_requested": fidelity_requested,
        "fidelity_used": sorted({r["fidelity"] for r in rows}) if rows is not None
        else sorted(set((memory.fidelity if memory is not None else {}).values())),
        "tolerance": scene.run.tolerance,
        "output_full_scale_dn": None if main is None else int(main.output_full_scale),
        "output_bits": None if main is None
        else max(1, int(main.output_full_scale).bit_length()),
        "tiff_shift": tiff_shift,
        "memory": None if memory is None else memory.to_dict(),
    }


def config_lines(c):
    """The configuration section of report.md (Markdown lines) from :func:`configuration`."""
    p = c["platform"]
    if p["kind"] == "orbit":
        plat = (f"orbit at {p['altitude_km']:g} km, GSD {p['gsd_m']:g} m: ground speed "
                f"**{p['ground_speed_m_s']:.1f} m/s**")
    else:
        plat = (f"turntable at {p['angular_speed_rad_s']:g} rad/s, {p['distance_m']:g} m from "
                f"the axis: surface speed **{p['surface_speed_m_s']:.4g} m/s**")
    avail = c["available_frame_rate_hz"]
    fr = (f"**{c['required_frame_rate_hz']:.4g} Hz** full-frame rate needed to read the "
          f"{c['window']['rows']}-row window every line period (Qu et al. 2010 eqs 6-9)"
          + (f"; the sensor gives {avail:.4g} Hz" if avail is not None else
             "; the sensor's row timing is not given"))
    m0 = c["window"]["m0"]
    return [
        "## Configuration", "",
        f"* platform: {plat}",
        f"* line period **{c['line_period_s'] * 1e6:.4g} us** ({c['line_rate_hz']:.0f} "
        "lines/s, the real-time rate)",
        f"* frame rate: {fr}",
        f"* window: {c['window']['columns']} columns x {c['window']['rows']} rows of a "
        f"{c['sensor']['columns']} x {c['sensor']['rows']} {c['sensor']['bits']}-bit "
        f"{c['sensor']['shutter']}-shutter sensor"
        + (f" (M0 = {m0} rows fit in one line period)" if m0 is not None else ""),
        f"* stages: {', '.join(map(str, c['stages']))} ({c['tdi_domain']} TDI); dV/V: "
        f"{', '.join(f'{v:g}' for v in c['dv_over_v'])}; {c['lines']} output lines",
        f"* pipeline: {' -> '.join(c['pipeline'])}",
        f"* fidelity: requested **{c['fidelity_requested']}**, used "
        f"**{', '.join(c['fidelity_used'])}** (tolerance {c['tolerance']:g})",
        *([f"* output: {c['output_bits']} bits (full scale {c['output_full_scale_dn']} DN)"
           + (f"; tdi.tif is shifted right by {c['tiff_shift']} bits" if c["tiff_shift"]
              else "")] if c["output_bits"] is not None else []),
        *([_memory_md(c["memory"])] if c.get("memory") else []),
        ""]


def _memory_md(mem):
    avail = mem.get("available")
    return (f"* memory: estimated peak **{mem['estimated_peak']}** (resident, estimated from "
            f"the scene before the run)"
            + (f"; {avail} available" if avail else "; available memory unknown"))


_GUIDE = [
    "## How to read this report", "",
    "* **Raw exposure vs TDI output.** The raw exposure is one read of the sensor for each "
    "ground line: what a camera without TDI would give (one line period of light). The TDI "
    "output adds the m exposures of the same ground line (digital TDI: m reads summed in the "
    "FPGA; charge TDI: charge summed before one read), so its signal is about m times larger "
    "and its SNR up to sqrt(m) better; its DN values run up to m times the ADC full scale.",
    "* **DN** (digital number) is an ADC code; **RMS DN** is a root-mean-square difference in "
    "those codes, at the scale of the image it is measured on (the output's for the impact "
    "column). **PSNR** = 20 log10(full scale / RMS difference), dB.",
    "* **Fidelity.** *exact* generates and quantizes every exposure of every pixel and runs "
    "the bit-exact golden models of the blocks. *fast* draws the sum of the m exposures at "
    "once (exact in distribution for charge and read noise) and replaces the m ADC roundings "
    "by their statistics. *auto* uses fast for an effect where that effect's **bound** — the "
    "stated largest relative RMS error of the fast approximation for this scene — is below "
    "[run].tolerance, and exact elsewhere. The bound column gives it per effect (- : the "
    "effect is exact in both).",
    "* **Impact** of an effect: the output with the effect against the output without it, "
    "on a crop, with the same random numbers for every other effect; PSNR (peak = output "
    "full scale) and RMS DN. Small PSNR = the effect matters.",
    "* **M dV/V**: the image's velocity mismatch dV/V summed over M stages, in pixels: how "
    "far the image moves against the TDI clock while a ground line is integrated. "
    "**M Delta** adds the rolling-shutter skew (rows read one row time apart) to it: the "
    "total along-track misregistration of the M stages, the blur width the MTF sees.",
    "* **Footprint model**: the MTF of the exact footprint the simulator renders for each "
    "stage (pixel aperture, motion during the exposure, stage misregistration, optics); "
    "*planned* is the planning model of `tdicam plan`; *paper's model* is Yuan et al. 2013's "
    "aperture x temporal x sinc(f M dV/V).",
    ""]


def _reversed(t):
    return " (contrast reversed)" if t.get("planned_reversed") else ""



def summary(scene, rep):
    """The few lines ``tdicam run`` prints: speed, effects that ran, measurements."""
    sp = rep["speed"]
    lines = [f"{Path(scene.source).name}: {sp['lines']} lines x {sp['width']} px, "
             f"{sp['stages']} stages, {sp['fidelity']}: {sp['lines_per_s']:.0f} lines/s "
             f"({sp['x_real_time']:.2f}x real time {sp['real_time_lines_per_s']:.0f} lines/s), "
             f"{sp['exposure_pixels_per_s'] / 1e6:.1f} M exposure-pixels/s"]
    lines += plan_lines(rep.get("plan"))
    ran = [e["name"] for e in rep["effects"] if e["ran"]]
    lines.append(f"effects ran: {', '.join(ran)}")
    for r in rep["measurements"]:
        if "snr" in r:
            s = r["snr"]
            if s.get("saturated"):
                lines.append(f"  m={r['stages']}: {s['note']}")
            lines.append(f"  m={r['stages']}: SNR {_fmt(s['output_db'], '.2f')} dB, gain "
                         f"{_fmt(s['gain_db'], '.2f')} dB (predicted {s['predicted_db']:.2f}, "
                         f"eq 28 worst case {s['eq28_db']:.2f})")
        if "mtf" in r:
            t = r["mtf"]
            lines.append(f"  m={r['stages']} M dV/V={t['m_dv_over_v']:.3g}: MTF "
                         f"{_fmt(t['measured'], '.3f')} (planned {_fmt(t['planned'], '.3f')}"
                         f"{_reversed(t)}{_before(t)}, paper's model {_fmt(t['yuan2013_model'], '.3f')}"
                         f", footprint {t['footprint_model']:.3f})")
    lines += summary_lines(rep["measurements"])
    if rep["rtl"]:
        for b in rep["rtl"]["blocks"]:
            if b.get("status") == "ran":
                lines.append(f"  RTL {b['block']} on {rep['rtl']['simulator']}: "
                             f"{b['pixels_compared']} pixels compared, {b['mismatches']} "
                             f"mismatches")
            else:
                lines.append(f"  RTL {b['block']}: {b.get('status')}")
        for r in rep["rtl"].get("phy_checks") or []:
            lines.append(f"  RTL lanes from serial bits, {r['phy']} PHY: " + (
                f"{r['words_compared']} words compared, {r['mismatches']} mismatches, "
                f"training {'as' if r['taps_as_predicted'] else 'NOT as'} predicted"
                + _errors_text(r) + _corrections_text(r)
                if r["status"] == "ran" else r["status"]))
    return "\n".join(lines)


def _errors_text(r):
    """', lanes 0, 1 in error (as predicted)' of a phy check row, '' with none."""
    if not r["lane_errors"]:
        return ""
    return (f", lane(s) {', '.join(map(str, r['lane_errors']))} in error"
            + (" (as predicted)" if r["taps_as_predicted"] else ""))


def _corrections_text(r):
    """', 17 tracking corrections (as predicted)' of a phy check row with tracking."""
    if "corrections" not in r:
        return ""
    n = sum(len(c) for c in r["corrections"])
    return (f", {n} tracking correction(s)"
            + (" (as predicted)" if r["corrections_as_predicted"] else " (NOT as predicted)"))


def phy_lines(rows):
    """report.md's rows of the ``[run.rtl] phy`` checks (:mod:`tdicam.chain.phy_check`):
    the table, the drift, every tracking correction against the golden tracker's, each
    lane's training as the device PHY published it, the problems."""
    md = ["The sensor's lanes from serial bits through the device PHY's receiver "
          "([run.rtl].phy), beside the chain's co-simulation above (which the generic PHY, "
          "words in, feeds): each lane's words against the golden link model's, its "
          "training (tap, slip, locked or in error at the end) and with tracking every "
          "correction against the prediction for the PHY. A lane in error that the golden "
          "model predicts (a drift without tracking) is the scene's finding, not a failure: "
          "its words are judged up to its predicted first wrong one. Only what differs from "
          "the prediction is listed as a problem below, and makes the co-simulation fail.",
          "", "| PHY | simulator | lanes | words compared | mismatches | training as "
          "predicted | lanes in error | tracking corrections | wall (s) |",
          "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["status"] != "ran":
            md.append(f"| {r['phy']} | {r['simulator']} | {r['status']} | - | - | - | - | - | "
                      f"{r['wall_seconds']:.1f} |")
            continue
        errs = ", ".join(map(str, r["lane_errors"])) or "none"
        if r["lane_errors"] and r["taps_as_predicted"]:
            errs += " (as predicted)"
        corr = "-" if "corrections" not in r else (
            f"{sum(len(c) for c in r['corrections'])} "
            f"({'as' if r['corrections_as_predicted'] else 'NOT as'} predicted)")
        md.append(f"| {r['phy']} | {r['simulator']} | {r['lanes']} | {r['words_compared']} "
                  f"| {r['mismatches']} | {'yes' if r['taps_as_predicted'] else 'no'} | "
                  f"{errs} | {corr} | {r['wall_seconds']:.1f} |")
    md.append("")
    for r in rows:
        md += _drift_lines(r)
    md += [f"* {r['phy']}: {t}" for r in rows for t in r.get("problems", [])]
    return md + ([""] if any(r.get("problems") for r in rows) else [])


def _drift_lines(r):
    """report.md's lines of one phy check's drift, corrections and eye status."""
    md = []
    d = r.get("drift")
    if d:
        md += [f"{r['phy']}: the eyes drift {', '.join(f'{t:g}' for t in d['taps'])} taps "
               f"(of {d['tap_ps']:g} ps, lane by lane) over {d['words']} words from word "
               f"{d['from_word']} (the chain's co-simulation's frames), as "
               f"[sensor.lvds].drift_taps / drift_frames state them.", ""]
    if "corrections" in r:
        md += [f"{r['phy']}: every tracking correction from the pins, each as (the word it "
               f"takes effect at: the first raw word sampled with the new tap, port cycles of "
               f"the pin run; the new tap), beside the golden tracker's "
               f"(tdicam.model.lvds_track):", ""]
        for i, (got, want) in enumerate(zip(r["corrections"], r["predicted_corrections"])):
            text = ", ".join(f"{e} ({t})" for e, t in got) or "none"
            md.append(f"* lane {i}: {len(got)} correction(s): {text}; "
                      + ("as the golden tracker predicts" if got == want else
                         "the golden tracker predicts " +
                         (", ".join(f"{e} ({t})" for e, t in want) or "none")))
        md.append("")
    if r.get("eyes"):
        md += [f"{r['phy']}: each lane's training as its receiver published it from the pins "
               f"(eye-status ports; picture {device_png(r['phy'])}):", ""]
        md += [f"* {e['text']}" for e in r["eyes"]] + [""]
    return md


def plan_lines(verdict):
    """What the plan says of a scene it calls infeasible (``tdicam plan``'s NO and its
    reasons), for the console and report.md; [] when it is feasible."""
    if not verdict or verdict["feasible"] is not False:
        return []
    return [f"plan: feasible: NO ({'; '.join(verdict['reasons'])}): the camera as planned "
            f"cannot run this scene; simulated all the same ('tdicam plan --scene' says more)"]


def _before(t):
    """`` before median3: not comparable`` when the planned MTF leaves out a block the
    measurement is taken after."""
    return "" if not t.get("planned_before") else \
        f" before {t['planned_before']}: not comparable"


def _ratio(a, b):
    """``a / b`` for the report, or "-" (no temporal noise: no light, no read noise)."""
    return f"{a / b:.3g}" if b else "-"


def markdown(scene, rep):
    """The text of ``report.md``: configuration first, how to read it, then the tables."""
    sp = rep["speed"]
    md = [f"# tdicam run: {Path(scene.source).name}", ""]
    md += config_lines(rep["configuration"])
    md += [t for line in plan_lines(rep.get("plan")) for t in (f"**{line}**", "")] + _GUIDE
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
    md += ["", "Impact and bound: see How to read this report above.", ""]
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
        sat = [f"* m = {r['stages']}: **{r['snr']['note']}**" for r in snr
               if r["snr"].get("saturated")]
        md += [""] + sat if sat else []
        md += ["", f"SNR: {s0['signal_definition']} (mean dark charge {s0['dark_e']:.3g} e- "
               "per exposure); the same for measured and predicted values.",
               "", f"Noise figures used: s_AD = {s0['sigma_ad_e']:.3g} e-, temporal s_CMOS = "
               f"{s0['sigma_cmos_e']:.3g} e-, fixed pattern {s0['sigma_fpn_e']:.3g} e- "
               f"(s_AD / s_CMOS = {_ratio(s0['sigma_ad_e'], s0['sigma_cmos_e'])}). Predicted: "
               "temporal noise, the row-to-row fixed pattern and the independent part of the "
               "quantization noise grow as sqrt(m), only the part the m exposures share grows "
               f"as m (rho = {s0['rho']:.3g} of the quantization variance here; a scene with "
               f"detail at this level would have {s0['rho_detail']:.3g}; "
               "tdicam.model.physics.plan.snr_gain_digital_predicted). Tao et al. 2012 eq 28 lets all of "
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
                      f"{_fmt(t['planned'], '.3f')}{_reversed(t)}{_before(t)} | "
                      f"{_fmt(t['yuan2013_model'], '.3f')} | {t['footprint_model']:.3f} |")
        md += ["", "All MTF values are moduli (contrast reversal is flagged). Planned: the "
               "planning model (tdicam.planning.predict.mtf_prediction, the same as `tdicam plan`): "
               "full-line-period exposure, smear at the image speed 1 - dV/V, rolling-shutter "
               "skew, the M-stage term and the optics, along track. Paper's model: Yuan, Li, "
               "Xu and Nie, \"MTF velocity-mismatch model of TDI area-array CMOS image "
               "sensors\" (2013), aperture x temporal x sinc(f M dV/V) with the plain "
               "velocity mismatch. Footprint model: the exact stage footprint the simulator "
               "renders (tdicam.model.physics.optics.Geometry). M Delta: the stage misregistration "
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
        rows = ("of every row of the frame (an area camera: [pipeline.nuc].coefficients = "
                "\"frame\", each pixel its own gain and offset)"
                if scene.pipeline.nuc.coefficients == "frame" else "of the window rows")
        md += ["", f"The coefficients {rows} are stored in a 4 Gb NAND flash "
               "(2,048 + 64-byte pages, 64 pages per block, 4,096 blocks) with the scene's "
               "faults and loaded back as the camera does at power-up: bad-block scan, "
               "block map, 64/72 SECDED words (one flipped bit corrected), the default "
               "coefficients (gain 1, offset 0: that pixel uncorrected) for a word with two.",
               ""]
    md += markdown_lines(rep["measurements"])
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
               f"Simulator {rep['rtl']['simulator']}, "
               + ("the whole output." if rep['rtl']['crop'] is None else
                  f"[run.rtl].crop [x0, y0, width, height] = {rep['rtl']['crop']}."),
               "", "| block | status | pixels compared | mismatches |",
               "|---|---|---|---|"]
        for b in rep["rtl"]["blocks"]:
            md.append(f"| {b['block']} | {b.get('status')} | {b.get('pixels_compared', '-')} | "
                      f"{b.get('mismatches', '-')} |")
        md.append("")
        if rep["rtl"].get("phy_checks"):
            md += phy_lines(rep["rtl"]["phy_checks"])
        if rep["rtl"].get("system"):
            md += ["What the co-simulated camera saw (its status outputs):", ""]
            md += [f"* {r['text']}" for r in rep["rtl"]["system"]] + [""]
    md += ["## Files", ""]
    md += [f"* `{f}`: {FILE_NOTES.get(f, '')}".rstrip(": ") for f in rep["files"]]
    md += ["* `report.json`: " + FILE_NOTES["report.json"], "* `report.md`: this report",
           "* `report.html`: " + FILE_NOTES["report.html"]]
    if rep["tiff_shift"]:
        md.append(f"* tdi.tif holds the output shifted right by {rep['tiff_shift']} bits "
                  f"(divided by {2 ** rep['tiff_shift']}, rounded down); tdi.npy holds every bit")
    stale = rep.get("stale_files") or {}
    if stale.get("removed"):
        md += ["", "Removed from this folder, written by an earlier `tdicam run` and not by "
               "this one: " + ", ".join(f"`{f}`" for f in stale["removed"]) + "."]
    if stale.get("other"):
        md += ["", "Also in this folder, not written by this run (left alone): "
               + ", ".join(f"`{f}`" for f in stale["other"]) + "."]
    md += ["", "## Papers", ""] + [f"* {k}: {v}." for k, v in PAPERS.items()]
    return "\n".join(md) + "\n"
