"""Text and figures of a plan (:func:`tdicam.planning.sizing.plan_report`'s dict).

:func:`report_text` is the default output of ``tdicam plan``; :func:`figures` draws its three
figures (SNR gain, MTF at Nyquist vs velocity mismatch, frame rate) as matplotlib Figures
without pyplot. Every MTF printed or drawn is a modulus; contrast reversal is said in words.
"""

from __future__ import annotations

import math

import numpy as np

from tdicam.model.physics import plan
from tdicam.model.dram import WINDOW_REFRESHES, window_cycles
from tdicam.model.ddr_efficiency import BLOCK_TEXT, PLAN_MARGIN, closest_block
from tdicam.model.physics.memory import DDR_EFFICIENCY

__all__ = ["report_text", "figures"]


# --------------------------------------------------------------------------------------
# text output
# --------------------------------------------------------------------------------------


def _bits(n) -> str:
    for unit, scale in (("Gbit", 1 << 30), ("Mbit", 1 << 20), ("kbit", 1 << 10)):
        if abs(n) >= scale:
            return f"{n / scale:.2f} {unit}"
    return f"{n} bit"


def _rate(bps) -> str:
    return f"{bps / 1e9:.2f} Gbit/s" if bps >= 1e8 else f"{bps / 1e6:.2f} Mbit/s"


def _px(rate) -> str:
    return f"{rate / 1e9:.3g} G pixel/s" if rate >= 1e9 else f"{rate / 1e6:.1f} M pixel/s"


def _ok(flag) -> str:
    return "?" if flag is None else ("ok" if flag else "NO")


def _yes(flag) -> str:
    return "?" if flag is None else ("yes" if flag else "NO")


def _gateware_lines(g) -> list[str]:
    opts = g["options"]
    need = ", ".join(f"ppc {o['ppc']} {o['clock_needed_mhz']:.1f} MHz" for o in opts)
    lines = [f"  gateware       TDI input {_px(g['pixel_rate'])} ({g['stages']} rows x "
             f"{g['width']} columns per line period): clock needed at {need}"]
    known = [o for o in opts if o["fmax_mhz"] is not None]
    if not known:
        lines.append(f"                 {g['source']}: no Fmax for these ppc: ?")
        return lines
    have = ", ".join(f"ppc {o['ppc']} {o['fmax_mhz']:g} MHz = {_px(o['pixel_rate'])}"
                     for o in known)
    if g["ok"]:
        how = f"ppc {g['ppc']} at {g['clock_mhz']:g} MHz meets it"
    else:
        how = "no ppc meets it"
    lines.append(f"                 {g['source']}: {have}; {how}: {_yes(g['ok'])} "
                 f"(margin {g['margin'] * 100:+.1f} %)")
    for c in g.get("chain") or ():
        part = "" if c.get("part", "whole") == "whole" else f", the split's {c['part']} device"
        lines.append(f"  whole chain    {c['label']} (synthesis record {c['date']}{part}, "
                     f"{c['width']} columns, {c['seeds']} seed(s)): ppc {c['ppc']} at "
                     f"{c['fmax_mhz']:g} MHz = {_px(c['pixel_rate'])}, needs "
                     f"{_px(c['need'])} ({c['need_what']}); keeps up with the sensor: "
                     f"{_yes(c['meets'])}")
    return lines


def _mtf_lines(d) -> list[str]:
    lines = []
    left = d.get("mtf_left_out") or ()
    for i, mm in enumerate(d["mtf_nyquist"]):
        head = "  MTF @ Nyquist  " if i == 0 else "                 "
        if i == 0 and left:
            lines.append(f"{head}of the camera before {', '.join(left)} (the plan leaves "
                         f"it out: a median is not linear and has no MTF)")
            head = "                 "
        opt = "" if mm["optics"] == 1.0 else f" x optics {mm['optics']:.3f}"
        rev = ", contrast reversed" if mm["reversed"] else ""
        skew = (f"rolling skew {mm['skew_px']:.3g} px" if mm["no_skew_because"] is None
                else f"no rolling skew: {mm['no_skew_because']}")
        lines.append(f"{head}aperture {mm['aperture']:.3f} x smear {mm['smear']:.3f}{opt} x "
                     f"stages {mm['stages']:.3f} = {mm['system']:.3f}{rev} "
                     f"(M dV/V = {mm['m_dv_over_v']:.3g}, {skew}, "
                     f"M Delta = {mm['m_delta']:.3g} px; full-period "
                     f"exposure, image speed 1 - dV/V)")
        p = mm["paper"]
        lines.append(f"                 paper's model (Yuan et al. 2013): aperture {p['aperture']:.3f} x "
                     f"temporal M/(M+1) {p['temporal']:.3f} x mismatch {p['mismatch']:.3f} = "
                     f"{p['system']:.3f}")
    return lines


def report_text(rep) -> str:
    """The plan as text (the default output of ``tdicam plan``)."""
    s = rep["sensor"]
    lines = []
    head = (f"{s['columns']} x {s['rows']} sensor, {s['bits']}-bit, {s['pitch_um']:g} um pitch")
    if rep["mode"] == "orbit":
        o = rep["orbit"]
        lines.append(f"tdicam plan: {o['altitude_km']:g} km circular orbit, {head}")
        lines.append(f"ground-track speed v_g = {o['ground_speed_m_s'] / 1e3:.4f} km/s "
                     "(Qu et al. 2010 eq 4)")
    else:
        t = rep["turntable"]
        lines.append(f"tdicam plan: turntable {t['angular_speed_rad_s']:g} rad/s at "
                     f"{t['distance_m']:g} m, {head}")
    if rep["scene"]:
        lines.append(f"scene: {rep['scene']}")
    mem = rep.get("run_memory")
    if mem and "refused" in mem:
        lines.append(f"run: 'tdicam run {rep['scene']}' refuses the scene: {mem['refused']}")
    elif mem:
        fits = {True: "fits", False: "does NOT fit: see 'tdicam run --dry-run'",
                None: "the machine's memory is unknown"}[mem["fits"]]
        lines.append(f"run memory: 'tdicam run {rep['scene']}' peaks at about "
                     f"{mem['estimated_peak']} (estimate)"
                     + ("" if mem["available"] is None else f", {mem['available']} available")
                     + f": {fits}")
    avail = s["available_frame_rate_hz"]
    lines.append("")
    lines.append(f"Minimum frame rate, Qu et al. 2010 Table 2 form: F_f >= m / (r T1), r = {s['rows']}"
                 + ("" if avail is None else f"; available {avail:.1f} frame/s"))
    hdr = f"{'GSD/m':>7}  {'T1/ms':>7}  {'m/stage':>7}  {'F_f/(frame/s)':>13}"
    if avail is not None:
        hdr += f"  {'fits':>4}"
    windows = any(p["window"] is not None for p in rep["points"])
    if windows:
        hdr += f"  {'M0':>5}  {'m <= M0':>7}"
    lines.append(hdr)
    prev = object()
    for p in rep["points"]:
        key = (p["gsd_m"], p["line_period_s"])
        first = key != prev
        prev = key
        gsd = ("-" if p["gsd_m"] is None else f"{p['gsd_m']:g}") if first else ""
        t1 = f"{p['line_period_s'] * 1e3:.3f}" if first else ""
        row = (f"{gsd:>7}  {t1:>7}  {p['stages']:>7}  "
               f"{p['frame_rate']['required_hz']:>13.1f}")
        if avail is not None:
            row += f"  {_ok(p['frame_rate']['ok']):>4}"
        if windows:
            w = p["window"]
            row += (f"  {'?':>5}  {'?':>7}" if w is None else
                    f"  {w['m0']:>5}  {_ok(w['ok']):>7}")
        lines.append(row)
    lines.extend(rep.get("notes", ()))

    d = rep["design"]
    fr, mem, ddr, snr = d["frame_rate"], d["memory"], d["ddr"], d["snr"]
    where = (f"GSD {d['gsd_m']:g} m, " if d["gsd_m"] is not None else "") + f"{d['stages']} stages"
    many = len(rep["points"]) > 1
    lines.append("")
    lines.append(f"Feasibility at {where}"
                 + (" (the most demanding point)" if many else "")
                 + f", line period {d['line_period_s'] * 1e6:.2f} us")
    if fr["available_hz"] is None:
        lines.append(f"  frame rate     required {fr['required_hz']:.1f} frame/s; available "
                     "unknown (give --max-frame-rate-hz or --pixel-clock-mhz)")
    else:
        lines.append(f"  frame rate     required {fr['required_hz']:.1f} frame/s, available "
                     f"{fr['available_hz']:.1f} frame/s: {_ok(fr['ok'])} "
                     f"(margin {fr['margin'] * 100:+.1f} %)"
                     + ("" if fr.get("fix") is None else f"; to make it yes: {fr['fix']}"))
    w = d["window"]
    if w is None:
        lines.append("  window         row time unknown: M0 not computed")
    else:
        cap = ", capped at the sensor rows" if w["capped"] else ""
        lines.append(f"  window         T_row {w['row_time_s'] * 1e6:.3f} us, n_lines "
                     f"{w['n_lines']}, M0 {w['m0']}, T_back {w['back_porch_s'] * 1e6:.3f} us"
                     f"{cap}: {_ok(w['ok'])} ({d['stages']} <= M0)"
                     + ("" if w.get("fix") is None else f"; to make it yes: {w['fix']}"))
    extra = mem["sum_bits"] - s["bits"]
    lines.append(f"  partial sums   {mem['sum_bits']} bits ({s['bits']}-bit pixels + "
                 f"ceil(log2 {d['stages']}) = {extra})")
    lines.append(f"  line buffers   basic m(m-1)/2 = {mem['basic_lines']} lines = "
                 f"{_bits(mem['basic_bits'])}; optimized m-1 = {mem['optimized_lines']} lines = "
                 f"{_bits(mem['optimized_bits'])}")
    lines.append(f"                 saving (m-1)(m-2)/2 = {mem['saving_lines']} lines = "
                 f"{_bits(mem['saving_bits'])}")
    if mem["onchip_budget_bits"] is not None:
        lines.append(f"  on-chip        {_bits(mem['optimized_bits'])} of "
                     f"{_bits(mem['onchip_budget_bits'])}: {_ok(mem['fits_onchip'])}")
    lines.append(f"  DDR            partial sums in DDR need {_rate(ddr['needed_bps'])} "
                 f"(read + write {mem['optimized_lines']} lines per line period); "
                 f"{ddr['word_bits']}-bit @ {ddr['user_clock_hz'] / 1e6:g} MHz x "
                 f"{ddr['efficiency'] * 100:.1f} % = {_rate(ddr['available_bps'])}: "
                 + (_ok(ddr['ok']) if ddr['ok'] is not False or mem.get("must_spill") else
                    "short, but the sums need not spill (" + (
                        "they fit on chip" if mem["onchip_budget_bits"] is not None else
                        "no on-chip budget given: --onchip-kbit or --device checks it")
                    + "): not part of the verdict"))
    if ddr.get("pattern", "given") != "given":
        lines.append(f"                 efficiency of the access pattern '{ddr['pattern']}' "
                     f"({ddr['pattern_text']}) on the DRAM timing model, less "
                     f"{PLAN_MARGIN * 100:g} points (the band the model is held to against "
                     "LiteDRAM's DDR3 controller)")
        name, eff, src = closest_block(DDR_EFFICIENCY)
        lines.append(f"  DDR margin     efficiencies over {WINDOW_REFRESHES} refresh intervals "
                     f"({window_cycles()} cycles) of steady state; the block closest to the "
                     f"{DDR_EFFICIENCY * 100:g} % assumed for the DDR blocks other than the "
                     f"spill: {BLOCK_TEXT[name]}, {eff:.1f} % ({src}, "
                     f"{eff - DDR_EFFICIENCY * 100:+.1f} points)")
    if mem.get("must_spill"):
        verdict = ("DDR sustains it (tdi_ddr block)" if ddr["ok"] else
                   "DDR bandwidth SHORT: lower stages, width or line rate, or a wider/faster "
                   "DDR interface")
        lines.append(f"  spill          partial sums must spill to DDR: {verdict}")
    elif mem["onchip_budget_bits"] is not None:
        lines.append("  spill          partial sums stay on chip")
    lines.extend(_gateware_lines(d["gateware"]))
    sig = (f"signal {snr['signal_e']:g} e-, read {snr['read_noise_e']:g} e-, "
           f"quantization {snr['sigma_ad_e']:.3g} e-")
    if snr["clipped_at_full_well"]:
        over = f" over {d['stages']} stages" if snr["domain"] == "charge" else ""
        lines.append(f"  full well      signal {snr['signal_asked_e']:g} e- (+ dark "
                     f"{snr['dark_e']:.3g} e-) exceeds the full well {snr['full_well_e']:g} e-"
                     f"{over}: clipped to {snr['signal_e']:g} e- (saturated; the SNR below is "
                     f"a full well's)")
    if snr["single_db"] is None:
        lines.append(f"  SNR            no signal ({sig}): no SNR and no TDI gain")
    else:
        lines.append(f"  SNR            one exposure {snr['single_db']:.2f} dB ({sig})")
        pr = snr["predicted"]
        lines.append(f"                 predicted {snr['domain']} TDI gain "
                     f"+{pr['gain_db']:.2f} dB (quantization shared by the m exposures: "
                     f"{pr['rho']:.3g} of it), SNR {pr['single_db']:.2f} -> "
                     f"{pr['tdi_db']:.2f} dB")
        lines.append(f"                 paper's worst case: digital TDI G({d['stages']}) = "
                     f"{snr['gain_digital']:.3f} (+{snr['gain_digital_db']:.2f} dB, Tao et al. 2012 "
                     f"eq 28); charge domain {snr['gain_charge']:.3f} "
                     f"(+{snr['gain_charge_db']:.2f} dB); sqrt(m) = {math.sqrt(d['stages']):.3f}")
        lines.append(f"                 eq 28 SNR after {snr['domain']} TDI "
                     f"{snr['tdi_db']:.2f} dB")
    lines.extend(_mtf_lines(d))
    if rep.get("system"):
        lines.append("")
        lines.append("System (the scene's pipeline as one design, at the design point):")
        lines.extend(f"  {r['text']}" for r in rep["system"])
    if rep.get("camera"):                # the whole camera's budget (tdicam.planning.camera)
        from tdicam.planning.camera import camera_lines
        lines += [""] + camera_lines(rep["camera"])
    lines.append("")
    if rep["feasible"]:
        lines.append("feasible: yes (no check says NO)")
    else:
        lines.append(f"feasible: NO ({', '.join(rep['infeasible'])})")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------
# figures
# --------------------------------------------------------------------------------------


def figures(rep, scenes) -> list:
    """The plan's figures as ``(file name, matplotlib Figure)`` pairs (no pyplot)."""
    from matplotlib.figure import Figure

    d = rep["design"]
    snr = d["snr"]
    out = []

    # 1. SNR gain vs stages, digital vs charge domain (Tao et al. 2012 eq 28, Zhou et al. 2008).
    m_max = max(128, d["stages"])
    m = np.arange(1, m_max + 1)
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    if snr["predicted"] is not None:
        shot = math.sqrt(snr["signal_e"] + snr["dark_e"])
        ax.plot(m, plan.gain_db(plan.snr_gain_digital_predicted(
            m, snr["sigma_ad_e"], math.hypot(snr["sigma_cmos_e"],
                                             snr["predicted"]["sigma_fpn_e"]),
            snr["predicted"]["rho"])), label="digital TDI (planning model)")
        ax.plot(m, plan.gain_db(plan.snr_gain_digital(m, snr["sigma_ad_e"], snr["sigma_cmos_e"])),
                "--", label="digital TDI (Tao et al. 2012 eq 28, worst case)")
        ax.plot(m, plan.gain_db(plan.snr_gain_charge(m, snr["sigma_ad_e"], shot,
                                                     snr["read_noise_e"])),
                label="charge-domain TDI")
        ax.set_title(f"signal {snr['signal_e']:g} e-, read noise {snr['read_noise_e']:g} e-, "
                     f"quantization {snr['sigma_ad_e']:.3g} e-", fontsize=9)
    else:
        ax.set_title("no signal: no SNR gain", fontsize=9)
    ax.plot(m, 10 * np.log10(m), "k:", label="sqrt(m)")
    ax.set_xlabel("stages m")
    ax.set_ylabel("SNR gain over one exposure / dB")
    ax.grid(True, alpha=0.3)
    ax.legend()
    out.append(("snr_gain.png", fig))

    # 2. MTF at Nyquist vs velocity mismatch: camera model and the paper's (Yuan et al. 2013).
    q = rep["sensor"]["fill_factor"] ** 0.5
    fig = Figure(figsize=(10, 4.2))
    ax1, ax2 = fig.subplots(1, 2)
    dv = np.linspace(0.0, 0.05, 501)
    x = np.linspace(0.0, 3.0, 601)
    for k, stages in enumerate((8, 32, 96, 128)):
        c = f"C{k}"
        ax1.plot(dv, plan.mtf_velocity_mismatch(plan.NYQUIST, stages, dv), color=c,
                 label=f"M = {stages}")
        ax2.plot(x, plan.camera_mtf(plan.NYQUIST, stages, x / stages, 0.0, q), color=c,
                 label=f"M = {stages}, camera model")
        ax2.plot(x, plan.mtf_system(plan.NYQUIST, stages, x / stages, q), "--", color=c, lw=0.8,
                 label=f"M = {stages}, paper's model")
    ax1.set_xlabel("dV/V")
    ax1.set_ylabel("velocity-mismatch MTF at Nyquist")
    ax1.set_title("Yuan et al. 2013 Fig. 8: |sinc(f p M dV/V)|", fontsize=9)
    ax2.plot(x, plan.mtf_velocity_mismatch(plan.NYQUIST, 128, x / 128), "k:",
             label="paper's mismatch factor alone")
    ax2.axvline(2.0, color="grey", lw=0.8)
    design = [r for r in d.get("mtf_nyquist") or [] if r.get("f_cyc_per_px") == plan.NYQUIST]
    for r in design:                    # the design point, with the scene's own skew
        ax2.plot([r["m_dv_over_v"]], [r["system"]], "k*", ms=11,
                 label=f"design: M = {d['stages']}, dV/V = {r['dv_over_v']:g} "
                       f"(MTF {r['system']:.3f})")
    ax2.set_xlabel("M dV/V")
    ax2.set_ylabel("system MTF at Nyquist (modulus)")
    rolling = rep["sensor"].get("shutter") == "rolling"
    skew = design[0]["skew_px"] if design and rolling else None
    ax2.set_title("curves: without the rolling shutter's skew (as a global shutter)\n"
                  f"star: the design, with its skew of {skew:.3g} px" if skew else
                  "global shutter; past the zeros the contrast is reversed", fontsize=9)
    for ax in (ax1, ax2):
        ax.set_ylim(bottom=0.0)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    out.append(("mtf_mismatch.png", fig))

    # 3. Frame rate vs stages for several GSDs (Qu et al. 2010 eq 9).
    rows = rep["sensor"]["rows"]
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    m = np.arange(1, min(rows, max(128, d["stages"])) + 1)
    if rep["mode"] == "orbit":
        v = rep["orbit"]["ground_speed_m_s"]
        gsds = sorted({0.5, 1.0, 2.0, 5.0} | {sc.orbit.gsd_m for sc in scenes})
        for g in gsds:
            ax.plot(m, plan.required_frame_rate(m, rows, plan.line_period(g, v)),
                    label=f"GSD {g:g} m")
        ax.set_title(f"{rep['orbit']['altitude_km']:g} km orbit, r = {rows}", fontsize=9)
    else:
        ax.plot(m, plan.required_frame_rate(m, rows, d["line_period_s"]),
                label=f"T_line {d['line_period_s'] * 1e6:.1f} us")
    avail = rep["sensor"]["available_frame_rate_hz"]
    if avail is not None:
        ax.axhline(avail, color="k", ls="--", lw=1, label=f"available {avail:.0f} frame/s")
    ax.set_yscale("log")
    ax.set_xlabel("stages m")
    ax.set_ylabel("required frame rate / (frame/s)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    out.append(("frame_rate.png", fig))
    return out
