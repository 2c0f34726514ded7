"""``tdicam plan``: size a digital-TDI camera from the orbit (or turntable) and the sensor.

Prints seed 000's Table 2 (line period and minimum frame rate per GSD and stage count) and a
feasibility report for the most demanding point of the table (highest required frame rate):
required vs available frame rate, the rolling-shutter window (n_lines, M0, back porch),
partial-sum width and line-buffer memory of the basic and optimized structures, the DDR
bandwidth the partial sums would need in external memory vs the interface, the expected SNR
gain (digital and charge domain) and the MTF at Nyquist. Parameters come from a scene file
(``--scene``), from options, or both (options override the file). ``--json`` prints the same
numbers for scripts; ``--plot DIR`` writes three PNG figures.

Without a scene or orbit options the command plans seed 000's example: 600 km, GSD 5, 2 and
1 m, 12/24/48/96 stages on a 1280 x 1024 12-bit sensor.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from tdicam.errors import TdicamError
from tdicam.model import plan as P
from tdicam.scene import load_scene

__all__ = ["register", "run", "plan_report", "DEFAULT_GSDS_M", "DEFAULT_STAGES"]

#: seed 000 Table 2 grid, used when neither a scene nor orbit options are given.
DEFAULT_GSDS_M = (5.0, 2.0, 1.0)
DEFAULT_STAGES = (12, 24, 48, 96)
DEFAULT_ALTITUDE_KM = 600.0

# (argparse dest, scene section, scene key, option, type, nargs, help)
_SCENE_OPTIONS = (
    ("altitude_km", "orbit", "altitude_km", "--altitude-km", float, None,
     "orbit altitude in km, >= 0 (default 600)"),
    ("gsd_m", "orbit", "gsd_m", "--gsd-m", float, "+",
     "ground sample distance(s) in m, > 0; several give several table blocks "
     "(default 5 2 1)"),
    ("angular_speed_rad_s", "turntable", "angular_speed_rad_s", "--angular-speed-rad-s", float,
     None, "turntable angular speed in rad/s, > 0 (instead of an orbit)"),
    ("distance_m", "turntable", "distance_m", "--distance-m", float, None,
     "sensor-to-turntable-axis distance in m, > 0"),
    ("stages", "tdi", "stages", "--stages", int, "+",
     "TDI stages, 1..rows (and <= M0 when the row timing is known; default 12 24 48 96)"),
    ("domain", "tdi", "domain", "--domain", str, None, "digital or charge (default digital)"),
    ("columns", "sensor", "columns", "--columns", int, None, "sensor columns (default 1280)"),
    ("rows", "sensor", "rows", "--rows", int, None, "sensor rows (default 1024)"),
    ("pitch_um", "sensor", "pitch_um", "--pitch-um", float, None, "pixel pitch in um"),
    ("fill_factor", "sensor", "fill_factor", "--fill-factor", float, None,
     "area fill factor in (0, 1]"),
    ("bits", "sensor", "bits", "--bits", int, None, "ADC bits per pixel (default 12)"),
    ("full_well_e", "sensor", "full_well_e", "--full-well-e", float, None,
     "full well in electrons"),
    ("read_noise_e", "sensor", "read_noise_e", "--read-noise-e", float, None,
     "RMS read noise in electrons"),
    ("dark_current_e_per_s", "sensor", "dark_current_e_per_s", "--dark-current-e-per-s", float,
     None, "dark current in electrons per second"),
    ("row_blanking_us", "sensor", "row_blanking_us", "--row-blanking-us", float, None,
     "row blanking in us (default 3.5, used with --pixel-clock-mhz)"),
    ("pixel_clock_mhz", "sensor", "pixel_clock_mhz", "--pixel-clock-mhz", float, None,
     "pixel rate over all channels in MHz: gives the row time t_rb + columns/f_s"),
    ("max_frame_rate_hz", "sensor", "max_frame_rate_hz", "--max-frame-rate-hz", float, None,
     "datasheet full-frame rate: gives the row time 1/(rows F)"),
    ("signal_e", "target", "signal_e", "--signal-e", float, None,
     "electrons per pixel per exposure (default 1000)"),
    ("dv_over_v", "motion", "dv_over_v", "--dv-over-v", float, "+",
     "relative velocity mismatch(es), each in (-1, 1) (default 0)"),
)
_OPTION_OF = {f"{sec}.{key}": opt for _, sec, key, opt, *_ in _SCENE_OPTIONS}


def register(subparsers) -> None:
    """Add the ``plan`` subcommand to an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "plan", help="size a digital-TDI camera: line/frame rate, window, memory, SNR, MTF",
        description=" ".join(__doc__.split("\n\n")[:2]).replace("``", ""))
    p.add_argument("--scene", metavar="FILE", help="scene TOML file (options override it)")
    metavars = {int: "N", float: "X", str: "NAME"}
    for dest, _sec, _key, opt, typ, nargs, text in _SCENE_OPTIONS:
        p.add_argument(opt, dest=dest, type=typ, nargs=nargs, default=None,
                       metavar=metavars[typ], help=text)
    p.add_argument("--onchip-kbit", type=float, default=None, metavar="X",
                   help="on-chip RAM available for the partial sums, kbit (1 kbit = 1024 bit; "
                        "the report's kbit/Mbit are binary too)")
    p.add_argument("--device", default=None, metavar="NAME",
                   help="FPGA part whose block RAM is the on-chip budget when --onchip-kbit "
                        "is not given: " + ", ".join(P.ONCHIP_RAM_BITS))
    p.add_argument("--ddr-bits", type=int, default=P.DDR_WORD_BITS, metavar="N",
                   help="DDR user-interface width in bits (default 256)")
    p.add_argument("--ddr-clock-mhz", type=float, default=P.DDR_USER_CLOCK_HZ / 1e6, metavar="X",
                   help="DDR user-interface clock in MHz (default 100)")
    p.add_argument("--ddr-efficiency", type=float, default=P.DDR_EFFICIENCY, metavar="X",
                   help="DDR interface efficiency in (0, 1] (default 0.8)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--plot", metavar="DIR", help="write PNG figures into DIR")
    p.set_defaults(func=run)


# --------------------------------------------------------------------------------------
# scene assembly
# --------------------------------------------------------------------------------------


def _scenes(args):
    """One validated Scene per GSD (or the single turntable scene)."""
    given = {dest: getattr(args, dest) for dest, *_ in _SCENE_OPTIONS
             if getattr(args, dest, None) is not None}
    orbit_opts = {"altitude_km", "gsd_m"} & given.keys()
    table_opts = {"angular_speed_rad_s", "distance_m"} & given.keys()
    if orbit_opts and table_opts:
        raise TdicamError("give orbit options (--altitude-km, --gsd-m) or turntable options "
                          "(--angular-speed-rad-s, --distance-m), not both")
    overrides: dict = {}
    labels = {}
    for dest, sec, key, opt, *_ in _SCENE_OPTIONS:
        if dest in given and dest != "gsd_m":
            value = given[dest]
            if isinstance(value, list) and len(value) == 1:
                value = value[0]
            overrides.setdefault(sec, {})[key] = value
            labels[f"{sec}.{key}"] = opt
    # one way of giving the row time replaces the other one from the scene file
    if "pixel_clock_mhz" in given and "max_frame_rate_hz" not in given:
        overrides.setdefault("sensor", {})["max_frame_rate_hz"] = None
    if "max_frame_rate_hz" in given and "pixel_clock_mhz" not in given:
        overrides.setdefault("sensor", {})["pixel_clock_mhz"] = None
    base = None
    if args.scene is not None:
        base = load_scene(args.scene)  # validates the file on its own first
    mode = ("turntable" if table_opts else "orbit" if orbit_opts
            else "turntable" if base is not None and base.turntable is not None else "orbit")
    if mode == "turntable":
        overrides["orbit"] = None
        if base is None or base.turntable is None:
            labels.update({"turntable": "--angular-speed-rad-s/--distance-m",
                           "turntable.angular_speed_rad_s": "--angular-speed-rad-s",
                           "turntable.distance_m": "--distance-m"})
        gsds = [None]
    else:
        overrides["turntable"] = None
        orbit = overrides.setdefault("orbit", {})
        if base is None or base.orbit is None:
            orbit.setdefault("altitude_km", DEFAULT_ALTITUDE_KM)
            labels.update({"orbit.altitude_km": "--altitude-km", "orbit.gsd_m": "--gsd-m"})
        if "gsd_m" in given:
            gsds = list(given["gsd_m"])
            labels["orbit.gsd_m"] = "--gsd-m"
        elif base is not None and base.orbit is not None:
            gsds = [base.orbit.gsd_m]
        else:
            gsds = list(DEFAULT_GSDS_M)
    if base is None and "stages" not in given:
        overrides.setdefault("tdi", {})["stages"] = list(DEFAULT_STAGES)
        labels["tdi.stages"] = "--stages (default " + " ".join(map(str, DEFAULT_STAGES)) + ")"
    scenes = []
    for gsd in gsds:
        ov = {k: (dict(v) if isinstance(v, dict) else v) for k, v in overrides.items()}
        if gsd is not None:
            ov["orbit"]["gsd_m"] = gsd
        scenes.append(load_scene(args.scene, overrides=ov, labels=labels))
    return scenes


# --------------------------------------------------------------------------------------
# computation
# --------------------------------------------------------------------------------------


def _point(scene, stages, *, onchip_budget_bits, ddr_bits, ddr_clock_hz, ddr_eff):
    s = scene.sensor
    t_line = scene.line_period_s
    required = float(P.required_frame_rate(stages, s.rows, t_line))
    available = s.available_frame_rate_hz
    timing = scene.timing
    mem = P.tdi_memory(s.columns, stages, s.bits, t_line, onchip_budget_bits=onchip_budget_bits,
                       word_bits=ddr_bits, user_clock_hz=ddr_clock_hz, efficiency=ddr_eff)
    # SNR: each exposure integrates for one line period (rolling-shutter TDI, seed 003).
    signal = scene.target.signal_e
    dark_e = s.dark_current_e_per_s * t_line
    sigma_ad = float(P.quantization_noise(s.conversion_gain_e_per_dn))
    sigma_shot = math.sqrt(signal + dark_e)
    sigma_cmos = float(P.temporal_noise(signal, s.read_noise_e, dark_e))
    g_dig = float(P.snr_gain_digital(stages, sigma_ad, sigma_cmos))
    g_chg = float(P.snr_gain_charge(stages, sigma_ad, sigma_shot, s.read_noise_e))
    single = (float(20 * np.log10(signal / (sigma_ad + sigma_cmos))) if signal > 0 else None)
    gain = g_dig if scene.tdi.domain == "digital" else g_chg
    # the planning model's prediction (quantization split into independent and shared
    # parts, noise in quadrature); eq 28 above is the paper's worst case
    pred = None
    if signal > 0:
        from tdicam.measure import snr_prediction
        pred = snr_prediction(scene, stages)
    f = P.NYQUIST
    aperture = float(P.mtf_aperture(f, s.q_over_p))
    temporal = float(P.mtf_temporal(f, stages))
    mismatch = []
    for dv in scene.motion.dv_over_v:
        mm = float(P.mtf_velocity_mismatch(f, stages, dv))
        mismatch.append({"dv_over_v": dv, "m_dv_over_v": stages * dv, "mismatch": mm,
                         "system": aperture * temporal * mm})
    return {
        "gsd_m": None if scene.orbit is None else scene.orbit.gsd_m,
        "line_period_s": t_line,
        "stages": stages,
        "frame_rate": {
            "required_hz": required,
            "available_hz": available,
            "ok": None if available is None else required <= available * (1 + 1e-12),
            "margin": None if available is None else available / required - 1.0,
        },
        "window": None if timing is None else {
            "row_time_s": timing.row_time_s, "n_lines": timing.n_lines, "m0": timing.m0,
            "back_porch_s": timing.back_porch_s, "capped": timing.capped,
            "ok": stages <= timing.m0},
        "memory": {
            "sum_bits": mem.sum_bits, "basic_lines": mem.basic_lines,
            "optimized_lines": mem.optimized_lines, "saving_lines": mem.saving_lines,
            "basic_bits": mem.basic_bits, "optimized_bits": mem.optimized_bits,
            "saving_bits": mem.saving_bits, "onchip_budget_bits": mem.onchip_budget_bits,
            "fits_onchip": mem.fits_onchip, "must_spill": mem.must_spill},
        "ddr": {"needed_bps": mem.ddr_needed_bps, "available_bps": mem.ddr_available_bps,
                "ok": mem.ddr_ok, "word_bits": ddr_bits, "user_clock_hz": ddr_clock_hz,
                "efficiency": ddr_eff},
        "snr": {
            "domain": scene.tdi.domain, "signal_e": signal, "dark_e": dark_e,
            "read_noise_e": s.read_noise_e, "sigma_ad_e": sigma_ad, "sigma_cmos_e": sigma_cmos,
            "single_db": single, "gain_digital": g_dig,
            "gain_digital_db": float(P.gain_db(g_dig)), "gain_charge": g_chg,
            "gain_charge_db": float(P.gain_db(g_chg)),
            "tdi_db": None if single is None else single + float(P.gain_db(gain)),
            "predicted": None if pred is None else {
                "single_db": pred["snr1_db"], "gain_db": pred["predicted_db"],
                "tdi_db": pred["snr1_db"] + pred["predicted_db"], "rho": pred["rho"],
                "sigma_fpn_e": pred["sigma_fpn_e"]}},
        "mtf_nyquist": {"aperture": aperture, "temporal": temporal, "mismatch": mismatch},
    }


def plan_report(scenes, *, onchip_budget_bits=None, ddr_bits=P.DDR_WORD_BITS,
                ddr_clock_hz=P.DDR_USER_CLOCK_HZ, ddr_efficiency=P.DDR_EFFICIENCY) -> dict:
    """All planning numbers for the scenes (one per GSD) as a JSON-ready dict.

    Parameters
    ----------
    scenes : list of tdicam.scene.Scene
        Scenes differing only in ``[orbit].gsd_m`` (or one turntable scene).
    onchip_budget_bits : int, optional
        On-chip RAM for the partial sums, bits.
    ddr_bits, ddr_clock_hz, ddr_efficiency
        DDR user interface (defaults: seed 002's 256 bit, 100 MHz, 80 %).

    Returns
    -------
    dict
        ``points`` (one per GSD x stage count), ``design`` (the point with the highest
        required frame rate) and context (orbit, sensor, scene source).
    """
    first = scenes[0]
    s = first.sensor
    P.ddr_bandwidth_available(ddr_bits, ddr_clock_hz, ddr_efficiency)  # validate early
    points = [_point(sc, m, onchip_budget_bits=onchip_budget_bits, ddr_bits=ddr_bits,
                     ddr_clock_hz=ddr_clock_hz, ddr_eff=ddr_efficiency)
              for sc in scenes for m in sc.tdi.stages]
    design = max(range(len(points)), key=lambda i: points[i]["frame_rate"]["required_hz"])
    out = {
        "scene": None if first.source == "<command line>" else first.source,
        "mode": "orbit" if first.orbit is not None else "turntable",
        "sensor": {"columns": s.columns, "rows": s.rows, "bits": s.bits,
                   "pitch_um": s.pitch_um, "fill_factor": s.fill_factor,
                   "row_time_s": s.row_time_s,
                   "available_frame_rate_hz": s.available_frame_rate_hz},
        "points": points,
        "design_index": design,
        "design": points[design],
    }
    if first.orbit is not None:
        out["orbit"] = {"altitude_km": first.orbit.altitude_km,
                        "ground_speed_m_s": first.orbit.ground_speed_m_s}
    else:
        out["turntable"] = {"angular_speed_rad_s": first.turntable.angular_speed_rad_s,
                            "distance_m": first.turntable.distance_m}
    return out


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


def _r3(x) -> float:
    """Round to 3 decimals without printing -0.000."""
    return round(x, 3) + 0.0


def _ok(flag) -> str:
    return "?" if flag is None else ("ok" if flag else "NO")


def _text(rep) -> str:
    s = rep["sensor"]
    lines = []
    head = (f"{s['columns']} x {s['rows']} sensor, {s['bits']}-bit, {s['pitch_um']:g} um pitch")
    if rep["mode"] == "orbit":
        o = rep["orbit"]
        lines.append(f"tdicam plan: {o['altitude_km']:g} km circular orbit, {head}")
        lines.append(f"ground-track speed v_g = {o['ground_speed_m_s'] / 1e3:.4f} km/s "
                     "(seed 000 eq 4)")
    else:
        t = rep["turntable"]
        lines.append(f"tdicam plan: turntable {t['angular_speed_rad_s']:g} rad/s at "
                     f"{t['distance_m']:g} m, {head}")
    if rep["scene"]:
        lines.append(f"scene: {rep['scene']}")
    avail = s["available_frame_rate_hz"]
    lines.append("")
    lines.append(f"Minimum frame rate, seed 000 Table 2 form: F_f >= m / (r T1), r = {s['rows']}"
                 + ("" if avail is None else f"; available {avail:.1f} frame/s"))
    hdr = f"{'GSD/m':>7}  {'T1/ms':>7}  {'m/stage':>7}  {'F_f/(frame/s)':>13}"
    if avail is not None:
        hdr += f"  {'fits':>4}"
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
        lines.append(row)

    d = rep["design"]
    fr, mem, ddr, snr, mtf = d["frame_rate"], d["memory"], d["ddr"], d["snr"], d["mtf_nyquist"]
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
                     f"(margin {fr['margin'] * 100:+.1f} %)")
    w = d["window"]
    if w is None:
        lines.append("  window         row time unknown: M0 not computed")
    else:
        cap = ", capped at the sensor rows" if w["capped"] else ""
        lines.append(f"  window         T_row {w['row_time_s'] * 1e6:.3f} us, n_lines "
                     f"{w['n_lines']}, M0 {w['m0']}, T_back {w['back_porch_s'] * 1e6:.3f} us"
                     f"{cap}: {_ok(w['ok'])} ({d['stages']} <= M0)")
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
                 f"{ddr['efficiency'] * 100:g} % = {_rate(ddr['available_bps'])}: {_ok(ddr['ok'])}")
    if mem.get("must_spill"):
        verdict = ("DDR sustains it (tdi_ddr block)" if ddr["ok"] else
                   "DDR bandwidth SHORT: lower stages, width or line rate, or a wider/faster "
                   "DDR interface")
        lines.append(f"  spill          partial sums must spill to DDR: {verdict}")
    elif mem["onchip_budget_bits"] is not None:
        lines.append("  spill          partial sums stay on chip")
    sig = (f"signal {snr['signal_e']:g} e-, read {snr['read_noise_e']:g} e-, "
           f"quantization {snr['sigma_ad_e']:.3g} e-")
    if snr["single_db"] is None:
        lines.append(f"  SNR            no signal ({sig})")
    else:
        lines.append(f"  SNR            one exposure {snr['single_db']:.2f} dB ({sig})")
    pr = snr["predicted"]
    if pr is not None:
        lines.append(f"                 predicted {snr['domain']} TDI gain "
                     f"+{pr['gain_db']:.2f} dB (quantization shared by the m exposures: "
                     f"{pr['rho']:.3g} of it), SNR {pr['single_db']:.2f} -> "
                     f"{pr['tdi_db']:.2f} dB")
    lines.append(f"                 paper's worst case: digital TDI G({d['stages']}) = "
                 f"{snr['gain_digital']:.3f} (+{snr['gain_digital_db']:.2f} dB, seed 003 eq 28); "
                 f"charge domain {snr['gain_charge']:.3f} (+{snr['gain_charge_db']:.2f} dB); "
                 f"sqrt(m) = {math.sqrt(d['stages']):.3f}")
    if snr["tdi_db"] is not None:
        lines.append(f"                 eq 28 SNR after {snr['domain']} TDI "
                     f"{snr['tdi_db']:.2f} dB")
    for mm in mtf["mismatch"]:
        lines.append(f"  MTF @ Nyquist  aperture {mtf['aperture']:.3f} x temporal "
                     f"{mtf['temporal']:.3f} x mismatch {_r3(mm['mismatch']):.3f} "
                     f"(M dV/V = {mm['m_dv_over_v']:.3g}) = {_r3(mm['system']):.3f}")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------
# plots
# --------------------------------------------------------------------------------------


def _plots(rep, scenes, outdir) -> list[Path]:
    from matplotlib.figure import Figure  # no pyplot: no GUI backend involved

    out = Path(outdir)
    if out.exists() and not out.is_dir():
        raise TdicamError(f"--plot: {str(out)!r} exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise TdicamError(f"--plot: cannot create {str(out)!r}: {exc.strerror}") from None
    d = rep["design"]
    snr = d["snr"]
    files = []

    # 1. SNR gain vs stages, digital vs charge domain (seed 003 eq 28, seed 004).
    m_max = max(128, d["stages"])
    m = np.arange(1, m_max + 1)
    shot = math.sqrt(snr["signal_e"] + snr["dark_e"])
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    if snr["predicted"] is not None:
        ax.plot(m, P.gain_db(P.snr_gain_digital_predicted(
            m, snr["sigma_ad_e"], math.hypot(snr["sigma_cmos_e"], snr["predicted"]["sigma_fpn_e"]),
            snr["predicted"]["rho"])), label="digital TDI (planning model)")
    ax.plot(m, P.gain_db(P.snr_gain_digital(m, snr["sigma_ad_e"], snr["sigma_cmos_e"])),
            "--", label="digital TDI (seed 003 eq 28, worst case)")
    ax.plot(m, P.gain_db(P.snr_gain_charge(m, snr["sigma_ad_e"], shot, snr["read_noise_e"])),
            label="charge-domain TDI")
    ax.plot(m, 10 * np.log10(m), "k:", label="sqrt(m)")
    ax.set_xlabel("stages m")
    ax.set_ylabel("SNR gain over one exposure / dB")
    ax.set_title(f"signal {snr['signal_e']:g} e-, read noise {snr['read_noise_e']:g} e-, "
                 f"quantization {snr['sigma_ad_e']:.3g} e-", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend()
    files.append(out / "snr_gain.png")
    fig.savefig(files[-1], dpi=100)

    # 2. MTF at Nyquist vs velocity mismatch (seed 001 Fig. 8).
    q = rep["sensor"]["fill_factor"] ** 0.5
    fig = Figure(figsize=(10, 4.2))
    ax1, ax2 = fig.subplots(1, 2)
    dv = np.linspace(0.0, 0.05, 501)
    x = np.linspace(0.0, 3.0, 601)
    for stages in (8, 32, 96, 128):
        ax1.plot(dv, P.mtf_velocity_mismatch(P.NYQUIST, stages, dv), label=f"M = {stages}")
        ax2.plot(x, P.mtf_system(P.NYQUIST, stages, x / stages, q), label=f"M = {stages}")
    ax1.set_xlabel("dV/V")
    ax1.set_ylabel("velocity-mismatch MTF at Nyquist")
    ax1.set_title("seed 001 Fig. 8: sinc(f p M dV/V)", fontsize=9)
    ax2.plot(x, P.mtf_velocity_mismatch(P.NYQUIST, 1, x), "k:", label="mismatch factor alone")
    ax2.axvline(2.0, color="grey", lw=0.8)
    ax2.set_xlabel("M dV/V")
    ax2.set_ylabel("system MTF at Nyquist")
    ax2.set_title("aperture x temporal x mismatch (tolerance M dV/V = 2)", fontsize=9)
    for ax in (ax1, ax2):
        ax.axhline(0.0, color="grey", lw=0.8)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    files.append(out / "mtf_mismatch.png")
    fig.savefig(files[-1], dpi=100)

    # 3. Frame rate vs stages for several GSDs (seed 000 eq 9).
    rows = rep["sensor"]["rows"]
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    m = np.arange(1, min(rows, max(128, d["stages"])) + 1)
    if rep["mode"] == "orbit":
        v = rep["orbit"]["ground_speed_m_s"]
        gsds = sorted({0.5, 1.0, 2.0, 5.0} | {sc.orbit.gsd_m for sc in scenes})
        for g in gsds:
            ax.plot(m, P.required_frame_rate(m, rows, P.line_period(g, v)), label=f"GSD {g:g} m")
        ax.set_title(f"{rep['orbit']['altitude_km']:g} km orbit, r = {rows}", fontsize=9)
    else:
        ax.plot(m, P.required_frame_rate(m, rows, d["line_period_s"]),
                label=f"T_line {d['line_period_s'] * 1e6:.1f} us")
    avail = rep["sensor"]["available_frame_rate_hz"]
    if avail is not None:
        ax.axhline(avail, color="k", ls="--", lw=1, label=f"available {avail:.0f} frame/s")
    ax.set_yscale("log")
    ax.set_xlabel("stages m")
    ax.set_ylabel("required frame rate / (frame/s)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    files.append(out / "frame_rate.png")
    fig.savefig(files[-1], dpi=100)
    return files


# --------------------------------------------------------------------------------------
# entry point
# --------------------------------------------------------------------------------------


def run(args) -> int:
    """Run ``tdicam plan`` for parsed arguments; returns the exit code."""
    budget = None
    if args.onchip_kbit is not None:
        if not math.isfinite(args.onchip_kbit) or args.onchip_kbit < 0:
            raise TdicamError(f"--onchip-kbit: must be >= 0, got {args.onchip_kbit:g}")
        budget = int(round(args.onchip_kbit * 1024))
    elif getattr(args, "device", None) is not None:
        budget = P.onchip_budget(args.device)
    if args.ddr_bits < 1:
        raise TdicamError(f"--ddr-bits: must be >= 1, got {args.ddr_bits}")
    if not (math.isfinite(args.ddr_clock_mhz) and args.ddr_clock_mhz > 0):
        raise TdicamError(f"--ddr-clock-mhz: must be > 0, got {args.ddr_clock_mhz:g}")
    if not (math.isfinite(args.ddr_efficiency) and 0 < args.ddr_efficiency <= 1):
        raise TdicamError(f"--ddr-efficiency: must be in (0, 1], got {args.ddr_efficiency:g}")
    scenes = _scenes(args)
    rep = plan_report(scenes, onchip_budget_bits=budget, ddr_bits=args.ddr_bits,
                      ddr_clock_hz=args.ddr_clock_mhz * 1e6, ddr_efficiency=args.ddr_efficiency)
    if args.plot:
        rep["plots"] = [str(f) for f in _plots(rep, scenes, args.plot)]
    if args.json:
        print(json.dumps(rep, indent=2, allow_nan=False, default=_json_default))
    else:
        print(_text(rep))
        if args.plot:
            print("\nwrote " + ", ".join(rep["plots"]))
    return 0


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
