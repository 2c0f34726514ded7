"""Planning service behind ``tdicam plan``: size a digital-TDI camera and say whether it works.

:func:`plan_scenes` builds the validated scenes from a scene file and option overrides,
:func:`plan_report` computes every number (a JSON-ready dict), :func:`report_text` prints it,
:func:`figures` draws it. The command (:mod:`tdicam.commands.plan`) only parses arguments.

What is planned, for every GSD x stage count, and in detail for the most demanding point:
the line period and required frame rate (Qu 2010), the rolling-shutter window, the partial-sum
memory on chip or in DDR (Qu 2010, Ning 2019), what the gateware must do (the pixel rate into
the TDI block, the pixels per clock and clock that meet it, and whether the reference TDI
synthesis does), the SNR (Tao 2012) and the MTF at Nyquist: the camera model of
:mod:`tdicam.model.mtf` — the one the scene simulator renders — with the paper's product
(Yuan 2013) beside it.

Feasibility: :attr:`report["feasible"]` is False when any check of the design point says NO
(frame rate, window, DDR bandwidth of spilled partial sums, gateware pixel rate); the command
then exits with status 1 (:data:`EXIT_INFEASIBLE`).
"""

from __future__ import annotations

import math

import numpy as np

from tdicam.errors import TdicamError, check_range
from tdicam.model import mtf as _mtf
from tdicam.model import plan as P
from tdicam.model import tdi as _tdi
from tdicam.scene import load_scene

__all__ = ["DEFAULT_GSDS_M", "DEFAULT_STAGES", "DEFAULT_ALTITUDE_KM", "BOUNDS",
           "REFERENCE_TDI_FMAX_MHZ", "EXIT_INFEASIBLE", "plan_scenes", "check_bounds",
           "mtf_prediction", "gateware_plan", "plan_report", "report_text", "figures"]

#: Qu 2010 Table 2 grid, used when neither a scene nor orbit options are given.
DEFAULT_GSDS_M = (5.0, 2.0, 1.0)
DEFAULT_STAGES = (12, 24, 48, 96)
DEFAULT_ALTITUDE_KM = 600.0

#: Exit status of ``tdicam plan`` when the feasibility report says NO (bad input: 2).
EXIT_INFEASIBLE = 1

#: Physical bounds of the planning inputs, ``"section.key": (lo, hi)``, checked on top of the
#: scene schema (which only asks for positive values) and stated in ``tdicam plan --help``.
#: They exclude absurd input (a 1e12 km orbit, a 1e-300 m GSD, a turntable at 1e-12 rad/s)
#: whose arithmetic would be garbage, and nothing a real camera or lab rig does.
BOUNDS = {
    "orbit.altitude_km": (0, 100_000),          # ground to 2.8 x geostationary
    "orbit.gsd_m": (1e-3, 100_000),
    "turntable.angular_speed_rad_s": (1e-6, 1000),
    "turntable.distance_m": (1e-3, 1000),
    "target.signal_e": (0, 10**12),
    "sensor.full_well_e": (1, 10**9),
    "sensor.read_noise_e": (0, 10**6),
    "sensor.dark_current_e_per_s": (0, 10**12),
    "sensor.row_blanking_us": (0, 10**6),
    "sensor.pixel_clock_mhz": (1e-3, 10**6),
    "sensor.max_frame_rate_hz": (1e-3, 10**9),
}

#: Fmax in MHz of the reference TDI accumulator synthesis per pixels-per-clock: the README's
#: ``tdicam synth --reference`` figures (``tdi`` rows: width 1280, 96 stages, 12-bit pixels,
#: ECP5-85F speed 8, median of 3 placement seeds). Update this table with them;
#: ``tdicam plan --fpga-clock-mhz X`` overrides it.
REFERENCE_TDI_FMAX_MHZ = {1: 66.8, 4: 71.4}

# (argparse dest, scene section, scene key, option, type, nargs, help)
SCENE_OPTIONS = (
    ("altitude_km", "orbit", "altitude_km", "--altitude-km", float, None,
     "orbit altitude in km (default 600)"),
    ("gsd_m", "orbit", "gsd_m", "--gsd-m", float, "+",
     "ground sample distance(s) in m; several give several table blocks (default 5 2 1)"),
    ("angular_speed_rad_s", "turntable", "angular_speed_rad_s", "--angular-speed-rad-s", float,
     None, "turntable angular speed in rad/s (instead of an orbit)"),
    ("distance_m", "turntable", "distance_m", "--distance-m", float, None,
     "sensor-to-turntable-axis distance in m"),
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
     "full well in electrons (default 20000); the signal is clipped at it"),
    ("read_noise_e", "sensor", "read_noise_e", "--read-noise-e", float, None,
     "RMS read noise in electrons (default 0: an ideal readout, which makes the SNR "
     "optimistic; CMOS sensors have about 2-20 e-)"),
    ("dark_current_e_per_s", "sensor", "dark_current_e_per_s", "--dark-current-e-per-s", float,
     None, "dark current in electrons per second (default 0)"),
    ("row_blanking_us", "sensor", "row_blanking_us", "--row-blanking-us", float, None,
     "row blanking in us (default 3.5); needs --pixel-clock-mhz (or the scene's)"),
    ("pixel_clock_mhz", "sensor", "pixel_clock_mhz", "--pixel-clock-mhz", float, None,
     "pixel rate over all channels in MHz: gives the row time t_rb + columns/f_s"),
    ("max_frame_rate_hz", "sensor", "max_frame_rate_hz", "--max-frame-rate-hz", float, None,
     "datasheet full-frame rate: gives the row time 1/(rows F)"),
    ("signal_e", "target", "signal_e", "--signal-e", float, None,
     "electrons per pixel per exposure (default 1000)"),
    ("dv_over_v", "motion", "dv_over_v", "--dv-over-v", float, "+",
     "relative velocity mismatch(es), each in (-1, 1), exclusive (default 0)"),
)


def bounds_text(section, key) -> str:
    """``; valid lo..hi`` for the help of a bounded option ('' when unbounded)."""
    b = BOUNDS.get(f"{section}.{key}")
    return "" if b is None else f"; valid {b[0]:g}..{b[1]:g}"


# --------------------------------------------------------------------------------------
# scene assembly
# --------------------------------------------------------------------------------------


def plan_scenes(scene_path, given: dict):
    """One validated Scene per GSD (or the single turntable scene).

    Parameters
    ----------
    scene_path : str or None
        Scene file; options override it.
    given : dict
        Option values by argparse dest (only those given), as :data:`SCENE_OPTIONS`.

    Returns
    -------
    (list of Scene, dict)
        The scenes and the names of the overridden keys (``"section.key" -> option``) for
        messages.
    """
    orbit_opts = {"altitude_km", "gsd_m"} & given.keys()
    table_opts = {"angular_speed_rad_s", "distance_m"} & given.keys()
    if orbit_opts and table_opts:
        raise TdicamError("give orbit options (--altitude-km, --gsd-m) or turntable options "
                          "(--angular-speed-rad-s, --distance-m), not both")
    overrides: dict = {}
    labels = {}
    for dest, sec, key, opt, *_ in SCENE_OPTIONS:
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
    if scene_path is not None:
        base = load_scene(scene_path)  # validates the file on its own first
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
        scenes.append(load_scene(scene_path, overrides=ov, labels=labels))
    for sc in scenes:
        check_bounds(sc, labels)
    if "row_blanking_us" in given and scenes[0].sensor.pixel_clock_mhz is None:
        raise TdicamError("--row-blanking-us needs --pixel-clock-mhz (or [sensor]."
                          "pixel_clock_mhz in the scene): the row time is t_rb + columns / f_s")
    return scenes, labels


def check_bounds(scene, labels=None) -> None:
    """Raise a one-line :class:`TdicamError` when a scene value is outside :data:`BOUNDS`.

    The value is named by its option when it came from one (``labels``), else as
    ``[section].key``.
    """
    labels = labels or {}
    for path, (lo, hi) in BOUNDS.items():
        sec, key = path.split(".")
        part = getattr(scene, sec, None)
        value = None if part is None else getattr(part, key, None)
        if value is None:
            continue
        check_range(labels.get(path, f"[{sec}].{key}"), value, lo, hi, integer=False)


# --------------------------------------------------------------------------------------
# computation
# --------------------------------------------------------------------------------------


def mtf_prediction(scene, stages, dv_over_v, f=_mtf.NYQUIST) -> dict:
    """Planned along-track MTF of ``scene`` at ``f`` cycles/pitch, with the paper's model.

    The camera model (:func:`tdicam.model.mtf.camera_mtf_terms`): full-line-period exposure,
    smear at the image speed ``1 - dV/V``, rolling-shutter skew from the sensor's row time
    (forward/reverse scan; none for a global shutter, one stage or an unknown row time), the
    M-stage term and the optics PSF — the footprint the scene simulator renders. Beside it,
    ``paper``: Yuan 2013's ``aperture x temporal x mismatch`` (moduli). All values are moduli;
    ``reversed`` says when the camera's contrast is reversed. This is what a report prints.
    """
    s = scene.sensor
    dv = float(_mtf.check_dv_over_v(dv_over_v, "dv_over_v"))
    skew = 0.0
    if stages > 1:
        skew = _mtf.rolling_skew(s.row_time_s, scene.line_period_s, shutter=s.shutter,
                                 direction=scene.tdi.direction)
    cam = _mtf.camera_mtf_terms(f, stages, dv, skew, s.q_over_p, 1.0,
                                scene.optics.psf_sigma_px)
    paper = {"aperture": float(_mtf.mtf_aperture(f, s.q_over_p)),
             "temporal": float(_mtf.mtf_temporal(f, stages)),
             "mismatch": float(_mtf.mtf_velocity_mismatch(f, stages, dv)),
             "system": float(_mtf.mtf_system(f, stages, dv, s.q_over_p))}
    return {"f_cyc_per_px": float(f), "dv_over_v": dv, "m_dv_over_v": stages * dv,
            "skew_px": cam.skew_px, "m_delta": cam.m_delta, "exposure": cam.exposure,
            "aperture": cam.aperture, "smear": cam.smear, "optics": cam.optics,
            "stages": cam.stages, "system": cam.system, "reversed": bool(cam.reversed),
            "paper": paper}


def gateware_plan(stages, width, line_period_s, *, fpga_clock_mhz=None) -> dict:
    """What the TDI gateware must do for the camera, and whether the reference synthesis does.

    The TDI block receives the M-row window, ``M x W`` pixels, every line period:
    ``rate = M W / T`` pixels per second. At ``ppc`` pixels per clock it needs a clock of
    ``rate / ppc``. ``ok`` says whether the reference Fmax (:data:`REFERENCE_TDI_FMAX_MHZ`, or
    ``fpga_clock_mhz`` for every ppc) reaches it at some ppc the block offers for this width
    (:data:`tdicam.model.tdi.PPC_CHOICES`, ``W`` a multiple of ppc with >= 2 beats);
    ``margin`` is ``best pixel rate / rate - 1`` (negative: short).
    """
    rate = stages * width / line_period_s
    clocks = REFERENCE_TDI_FMAX_MHZ if fpga_clock_mhz is None else {
        p: float(fpga_clock_mhz) for p in _tdi.PPC_CHOICES}
    options = []
    for ppc in _tdi.PPC_CHOICES:
        if width % ppc or width // ppc < 2:
            continue
        fmax = clocks.get(ppc)
        options.append({
            "ppc": ppc, "clock_needed_mhz": rate / ppc / 1e6,
            "fmax_mhz": fmax,
            "pixel_rate": None if fmax is None else fmax * 1e6 * ppc,
            "meets": None if fmax is None else fmax * 1e6 * ppc >= rate})
    known = [o for o in options if o["fmax_mhz"] is not None]
    meeting = [o for o in known if o["meets"]]
    best = max(known, key=lambda o: o["pixel_rate"]) if known else None
    chosen = meeting[0] if meeting else None
    return {
        "pixel_rate": rate, "stages": stages, "width": width,
        "source": ("reference synthesis (ECP5-85F speed 8)" if fpga_clock_mhz is None
                   else f"--fpga-clock-mhz {fpga_clock_mhz:g}"),
        "options": options,
        "ppc": None if chosen is None else chosen["ppc"],
        "clock_mhz": None if chosen is None else chosen["fmax_mhz"],
        "best_pixel_rate": None if best is None else best["pixel_rate"],
        "ok": None if best is None else bool(meeting),
        "margin": None if best is None else best["pixel_rate"] / rate - 1.0,
    }


def _snr(scene, stages):
    """SNR section of one point: the signal clipped at the full well (and said), no gain
    without signal."""
    import dataclasses

    from tdicam.measure import snr_prediction

    s = scene.sensor
    t_line = scene.line_period_s
    dark_e = s.dark_current_e_per_s * t_line
    asked = scene.target.signal_e
    # the well holds one exposure (digital TDI) or the charge sum of m (charge domain)
    per_exposure_well = s.full_well_e / (stages if scene.tdi.domain == "charge" else 1)
    cap = max(per_exposure_well - dark_e, 0.0)
    signal = min(asked, cap)
    clipped = asked > cap
    sigma_ad = float(P.quantization_noise(s.conversion_gain_e_per_dn))
    out = {"domain": scene.tdi.domain, "signal_e": signal, "signal_asked_e": asked,
           "clipped_at_full_well": clipped, "full_well_e": s.full_well_e, "dark_e": dark_e,
           "read_noise_e": s.read_noise_e, "sigma_ad_e": sigma_ad,
           "sigma_cmos_e": float(P.temporal_noise(signal, s.read_noise_e, dark_e)),
           "single_db": None, "gain_digital": None, "gain_digital_db": None,
           "gain_charge": None, "gain_charge_db": None, "tdi_db": None, "predicted": None}
    if signal <= 0:
        return out          # no signal: no SNR, and no SNR gain to speak of
    sigma_cmos = out["sigma_cmos_e"]
    g_dig = float(P.snr_gain_digital(stages, sigma_ad, sigma_cmos))
    g_chg = float(P.snr_gain_charge(stages, sigma_ad, math.sqrt(signal + dark_e),
                                    s.read_noise_e))
    single = float(20 * np.log10(signal / (sigma_ad + sigma_cmos)))
    gain = g_dig if scene.tdi.domain == "digital" else g_chg
    sc = scene if not clipped else dataclasses.replace(
        scene, target=dataclasses.replace(scene.target, signal_e=signal))
    pred = snr_prediction(sc, stages)
    out.update({
        "single_db": single, "gain_digital": g_dig, "gain_digital_db": float(P.gain_db(g_dig)),
        "gain_charge": g_chg, "gain_charge_db": float(P.gain_db(g_chg)),
        "tdi_db": single + float(P.gain_db(gain)),
        "predicted": {"single_db": pred["snr1_db"], "gain_db": pred["predicted_db"],
                      "tdi_db": pred["snr1_db"] + pred["predicted_db"], "rho": pred["rho"],
                      "sigma_fpn_e": pred["sigma_fpn_e"]}})
    return out


def _point(scene, stages, *, onchip_budget_bits, ddr_bits, ddr_clock_hz, ddr_eff,
           fpga_clock_mhz):
    s = scene.sensor
    t_line = scene.line_period_s
    required = float(P.required_frame_rate(stages, s.rows, t_line))
    available = s.available_frame_rate_hz
    timing = scene.timing
    mem = P.tdi_memory(s.columns, stages, s.bits, t_line, onchip_budget_bits=onchip_budget_bits,
                       word_bits=ddr_bits, user_clock_hz=ddr_clock_hz, efficiency=ddr_eff)
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
        "gateware": gateware_plan(stages, s.columns, t_line, fpga_clock_mhz=fpga_clock_mhz),
        "snr": _snr(scene, stages),
        "mtf_nyquist": [mtf_prediction(scene, stages, dv) for dv in scene.motion.dv_over_v],
    }


def _verdict(point) -> list[str]:
    """Names of the design point's checks that say NO."""
    no = []
    if point["frame_rate"]["ok"] is False:
        no.append("frame rate")
    if point["window"] is not None and point["window"]["ok"] is False:
        no.append("window (stages > M0)")
    if point["memory"]["must_spill"] and point["ddr"]["ok"] is False:
        no.append("DDR bandwidth")
    if point["gateware"]["ok"] is False:
        no.append("gateware pixel rate")
    return no


def plan_report(scenes, *, onchip_budget_bits=None, ddr_bits=P.DDR_WORD_BITS,
                ddr_clock_hz=P.DDR_USER_CLOCK_HZ, ddr_efficiency=P.DDR_EFFICIENCY,
                fpga_clock_mhz=None) -> dict:
    """All planning numbers for the scenes (one per GSD) as a JSON-ready dict.

    Parameters
    ----------
    scenes : list of tdicam.scene.Scene
        Scenes differing only in ``[orbit].gsd_m`` (or one turntable scene).
    onchip_budget_bits : int, optional
        On-chip RAM for the partial sums, bits.
    ddr_bits, ddr_clock_hz, ddr_efficiency
        DDR user interface (defaults: Ning 2019's 256 bit, 100 MHz, 80 %).
    fpga_clock_mhz : float, optional
        TDI block clock for every ppc instead of :data:`REFERENCE_TDI_FMAX_MHZ`.

    Returns
    -------
    dict
        ``points`` (one per GSD x stage count), ``design`` (the point with the highest
        required frame rate), ``feasible`` (False when a check of ``design`` says NO, listed
        in ``infeasible``) and context (orbit, sensor, scene source).
    """
    first = scenes[0]
    s = first.sensor
    P.ddr_bandwidth_available(ddr_bits, ddr_clock_hz, ddr_efficiency)  # validate early
    if fpga_clock_mhz is not None:
        check_range("--fpga-clock-mhz", fpga_clock_mhz, 1, 10_000, integer=False)
    points = [_point(sc, m, onchip_budget_bits=onchip_budget_bits, ddr_bits=ddr_bits,
                     ddr_clock_hz=ddr_clock_hz, ddr_eff=ddr_efficiency,
                     fpga_clock_mhz=fpga_clock_mhz)
              for sc in scenes for m in sc.tdi.stages]
    design = max(range(len(points)), key=lambda i: points[i]["frame_rate"]["required_hz"])
    no = _verdict(points[design])
    out = {
        "scene": None if first.source == "<command line>" else first.source,
        "mode": "orbit" if first.orbit is not None else "turntable",
        "sensor": {"columns": s.columns, "rows": s.rows, "bits": s.bits,
                   "pitch_um": s.pitch_um, "fill_factor": s.fill_factor,
                   "shutter": s.shutter, "row_time_s": s.row_time_s,
                   "available_frame_rate_hz": s.available_frame_rate_hz},
        "points": points,
        "design_index": design,
        "design": points[design],
        "feasible": not no,
        "infeasible": no,
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
    return lines


def _mtf_lines(d) -> list[str]:
    lines = []
    for i, mm in enumerate(d["mtf_nyquist"]):
        head = "  MTF @ Nyquist  " if i == 0 else "                 "
        opt = "" if mm["optics"] == 1.0 else f" x optics {mm['optics']:.3f}"
        rev = ", contrast reversed" if mm["reversed"] else ""
        lines.append(f"{head}aperture {mm['aperture']:.3f} x smear {mm['smear']:.3f}{opt} x "
                     f"stages {mm['stages']:.3f} = {mm['system']:.3f}{rev} "
                     f"(M dV/V = {mm['m_dv_over_v']:.3g}, rolling skew "
                     f"{mm['skew_px']:.3g} px, M Delta = {mm['m_delta']:.3g} px; full-period "
                     f"exposure, image speed 1 - dV/V)")
        p = mm["paper"]
        lines.append(f"                 paper's model (Yuan 2013): aperture {p['aperture']:.3f} x "
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
                     "(Qu 2010 eq 4)")
    else:
        t = rep["turntable"]
        lines.append(f"tdicam plan: turntable {t['angular_speed_rad_s']:g} rad/s at "
                     f"{t['distance_m']:g} m, {head}")
    if rep["scene"]:
        lines.append(f"scene: {rep['scene']}")
    avail = s["available_frame_rate_hz"]
    lines.append("")
    lines.append(f"Minimum frame rate, Qu 2010 Table 2 form: F_f >= m / (r T1), r = {s['rows']}"
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
    lines.extend(_gateware_lines(d["gateware"]))
    sig = (f"signal {snr['signal_e']:g} e-, read {snr['read_noise_e']:g} e-, "
           f"quantization {snr['sigma_ad_e']:.3g} e-")
    if snr["clipped_at_full_well"]:
        lines.append(f"  full well      signal {snr['signal_asked_e']:g} e- (+ dark "
                     f"{snr['dark_e']:.3g} e-) exceeds the full well {snr['full_well_e']:g} e-"
                     f"{' over ' + str(d['stages']) + ' stages' if snr['domain'] == 'charge' else ''}"
                     f": clipped to {snr['signal_e']:g} e- (saturated; the SNR below is a "
                     f"full well's)")
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
                     f"{snr['gain_digital']:.3f} (+{snr['gain_digital_db']:.2f} dB, Tao 2012 "
                     f"eq 28); charge domain {snr['gain_charge']:.3f} "
                     f"(+{snr['gain_charge_db']:.2f} dB); sqrt(m) = {math.sqrt(d['stages']):.3f}")
        lines.append(f"                 eq 28 SNR after {snr['domain']} TDI "
                     f"{snr['tdi_db']:.2f} dB")
    lines.extend(_mtf_lines(d))
    lines.append("")
    if rep["feasible"]:
        lines.append("feasible: yes (no check says NO)")
    else:
        lines.append(f"feasible: NO ({', '.join(rep['infeasible'])}); exit status "
                     f"{EXIT_INFEASIBLE}")
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

    # 1. SNR gain vs stages, digital vs charge domain (Tao 2012 eq 28, Zhou 2008).
    m_max = max(128, d["stages"])
    m = np.arange(1, m_max + 1)
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    if snr["predicted"] is not None:
        shot = math.sqrt(snr["signal_e"] + snr["dark_e"])
        ax.plot(m, P.gain_db(P.snr_gain_digital_predicted(
            m, snr["sigma_ad_e"], math.hypot(snr["sigma_cmos_e"],
                                             snr["predicted"]["sigma_fpn_e"]),
            snr["predicted"]["rho"])), label="digital TDI (planning model)")
        ax.plot(m, P.gain_db(P.snr_gain_digital(m, snr["sigma_ad_e"], snr["sigma_cmos_e"])),
                "--", label="digital TDI (Tao 2012 eq 28, worst case)")
        ax.plot(m, P.gain_db(P.snr_gain_charge(m, snr["sigma_ad_e"], shot,
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

    # 2. MTF at Nyquist vs velocity mismatch: camera model and the paper's (Yuan 2013).
    q = rep["sensor"]["fill_factor"] ** 0.5
    fig = Figure(figsize=(10, 4.2))
    ax1, ax2 = fig.subplots(1, 2)
    dv = np.linspace(0.0, 0.05, 501)
    x = np.linspace(0.0, 3.0, 601)
    for k, stages in enumerate((8, 32, 96, 128)):
        c = f"C{k}"
        ax1.plot(dv, P.mtf_velocity_mismatch(P.NYQUIST, stages, dv), color=c,
                 label=f"M = {stages}")
        ax2.plot(x, P.camera_mtf(P.NYQUIST, stages, x / stages, 0.0, q), color=c,
                 label=f"M = {stages}, camera model")
        ax2.plot(x, P.mtf_system(P.NYQUIST, stages, x / stages, q), "--", color=c, lw=0.8,
                 label=f"M = {stages}, paper's model")
    ax1.set_xlabel("dV/V")
    ax1.set_ylabel("velocity-mismatch MTF at Nyquist")
    ax1.set_title("Yuan 2013 Fig. 8: |sinc(f p M dV/V)|", fontsize=9)
    ax2.plot(x, P.mtf_velocity_mismatch(P.NYQUIST, 128, x / 128), "k:",
             label="paper's mismatch factor alone")
    ax2.axvline(2.0, color="grey", lw=0.8)
    ax2.set_xlabel("M dV/V")
    ax2.set_ylabel("system MTF at Nyquist (modulus)")
    ax2.set_title("global shutter; past the zeros the contrast is reversed", fontsize=9)
    for ax in (ax1, ax2):
        ax.set_ylim(bottom=0.0)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    out.append(("mtf_mismatch.png", fig))

    # 3. Frame rate vs stages for several GSDs (Qu 2010 eq 9).
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
    out.append(("frame_rate.png", fig))
    return out
