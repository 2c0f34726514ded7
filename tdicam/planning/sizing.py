"""Planning service behind ``tdicam plan``: size a digital-TDI camera and say whether it works.

:func:`plan_scenes` builds the validated scenes from a scene file and option overrides,
:func:`plan_report` computes every number (a JSON-ready dict), :func:`report_text` prints it,
:func:`figures` draws it (both in :mod:`tdicam.planning.report`, re-exported here). The
command (:mod:`tdicam.commands.plan`) only parses arguments.

What is planned, for every GSD x stage count, and in detail for the most demanding point:
the line period and required frame rate (Qu et al. 2010), the rolling-shutter window, the partial-sum
memory on chip or in DDR (Qu et al. 2010, Ning et al. 2019), what the gateware must do (the pixel rate into
the TDI block, the pixels per clock and clock that meet it, and whether the reference TDI
synthesis does), the SNR (Tao et al. 2012) and the MTF at Nyquist: the camera model of
:mod:`tdicam.model.physics.mtf` — the one the scene simulator renders — with the paper's product
(Yuan et al. 2013) beside it.

Feasibility: :attr:`report["feasible"]` is False when any check of the design point says NO
(frame rate, window, DDR bandwidth of spilled partial sums, gateware pixel rate) or a
system row of the scene's blocks does (the sensor lanes' pixel rate; ``pipeline design``
when the gateware cannot build the chain); the command then exits with status 1
(:data:`EXIT_INFEASIBLE`). The verdict never turns a NO into yes, and every NO says what
would make it yes (the window's and frame rate's: :func:`window_fix`). A scene with
``[run.rtl]`` whose co-simulated design cannot be built is refused (exit 2), as ``tdicam
run`` refuses it (:func:`tdicam.chain.cosim.check_rtl_design`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tdicam.errors import TdicamError, check_range
from tdicam.hw import record
from tdicam.model.physics import plan
from tdicam.beats import PPC_CHOICES
from tdicam.model.ddr_traces import PATTERNS
from tdicam.model.ddr_efficiency import tdi_spill_efficiency
from tdicam.planning.camera import camera_plan, chain_silicon, front_rate, samples_per_s
from tdicam.planning.predict import mtf_left_out, mtf_prediction, snr_prediction
from tdicam.planning.report import figures, report_text
from tdicam.scene.loader import BOUNDS, load_scene

__all__ = ["DEFAULT_GSDS_M", "DEFAULT_STAGES", "DEFAULT_ALTITUDE_KM",
           "REFERENCE_TDI", "REFERENCE_TDI_FMAX_MHZ", "EXIT_INFEASIBLE", "PLAN_OPTIONS", "check_options",
           "plan_scenes", "run_memory", "verdict", "window_fix",
           "gateware_plan", "plan_report", "report_text", "figures"]

#: Qu et al. 2010 Table 2 grid, used when neither a scene nor orbit options are given.
DEFAULT_GSDS_M = (5.0, 2.0, 1.0)
DEFAULT_STAGES = (12, 24, 48, 96)
DEFAULT_ALTITUDE_KM = 600.0

#: Exit status of ``tdicam plan`` when the feasibility report says NO (bad input: 2).
EXIT_INFEASIBLE = 1

#: Parameters of the reference TDI synthesis rows the plan reads (the orbit design point's
#: 1280 columns x 96 stages, 12-bit pixels).
REFERENCE_TDI = {"width": 1280, "stages": 96, "pixel_bits": 12}

#: Fmax in MHz of the reference TDI accumulator per pixels-per-clock, as measured: the
#: ``tdi`` rows of the synthesis record (:mod:`tdicam.hw.record`, written by ``tdicam synth
#: --reference --record``; ECP5-85F speed 8, median of the placement seeds).
#: ``tdicam plan --fpga-clock-mhz X`` overrides it.
REFERENCE_TDI_FMAX_MHZ = record.fmax_by_ppc("tdi", **REFERENCE_TDI)

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


#: The plan's own options (not scene keys) with their physical ranges, checked under the
#: option's name by :func:`check_options` before any unit is converted:
#: (argparse dest, option, lo, hi, integer, lo_open).
PLAN_OPTIONS = (
    ("onchip_kbit", "--onchip-kbit", 0, 1e8, False, False),
    ("ddr_bits", "--ddr-bits", 1, 4096, True, False),
    ("ddr_clock_mhz", "--ddr-clock-mhz", 1, 10_000, False, False),
    ("ddr_efficiency", "--ddr-efficiency", 0, 1, False, True),
    ("fpga_clock_mhz", "--fpga-clock-mhz", 1, 10_000, False, False),
)


def check_options(values: dict) -> dict:
    """The plan's own options range-checked under the names the user typed.

    Parameters
    ----------
    values : dict
        Option values by argparse dest (:data:`PLAN_OPTIONS`; None: not given) and
        ``device``.

    Returns
    -------
    dict
        The same values (integers as ``int``), once each lies in its range: one
        :class:`TdicamError` line ``--OPTION = V is out of range; valid: lo..hi`` for the first
        that does not, and for an unknown ``--device``. The models these values feed check
        their own parameters too; this is what makes a message name the option, not the
        model's parameter, and keeps unit conversions (MHz -> Hz, kbit -> bit) finite.
    """
    out = dict(values)
    for dest, option, lo, hi, integer, lo_open in PLAN_OPTIONS:
        if out.get(dest) is not None:
            out[dest] = check_range(option, out[dest], lo, hi, integer=integer,
                                    lo_open=lo_open)
    if out.get("device") is not None and str(out["device"]).lower() not in plan.ONCHIP_RAM_BITS:
        raise TdicamError(f"--device = {out['device']!r} is not known; valid: "
                          f"{', '.join(plan.ONCHIP_RAM_BITS)}")
    return out


def bounds_text(section, key) -> str:
    """``; valid lo..hi`` for the help of an option whose scene key has a physical bound
    (:data:`tdicam.scene.loader.BOUNDS`; '' when it has none)."""
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
        messages; its ``"notes"`` says which of the default stage counts were left out.
        Without ``--stages`` (and without a scene file) the default grid
        :data:`DEFAULT_STAGES` keeps only the counts the sensor rows and the window ``M0``
        allow (at least one: ``min(rows, M0)``). Stage counts given above ``M0`` are kept:
        the plan's window check says NO.
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
        if "row_blanking_us" not in given:
            overrides["sensor"]["row_blanking_us"] = None
    if "row_blanking_us" in given and "pixel_clock_mhz" not in given:
        labels["sensor.pixel_clock_mhz"] = "--pixel-clock-mhz"
    base = None
    if scene_path is not None:
        # validates the file on its own first (stages above M0: the window's NO)
        base = load_scene(scene_path, window=False)
        # the co-simulated design refuses a run of the scene before its work: so does plan
        from tdicam.chain.cosim import check_rtl_design
        check_rtl_design(base, int(base.run.lines))
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
            g = given["gsd_m"]          # the API may give one number
            gsds = list(g) if isinstance(g, (list, tuple)) else [g]
            if not gsds:
                raise TdicamError("--gsd-m: must not be an empty list")
            labels["orbit.gsd_m"] = "--gsd-m"
            twice = sorted({g for g in gsds if gsds.count(g) > 1})
            if twice:
                raise TdicamError(f"--gsd-m: lists {twice[0]:g} more than once, got "
                                  f"{' '.join(f'{g:g}' for g in gsds)}; each GSD once")
        elif base is not None and base.orbit is not None:
            gsds = [base.orbit.gsd_m]
        else:
            gsds = list(DEFAULT_GSDS_M)
    defaults = base is None and "stages" not in given
    if defaults:
        labels["tdi.stages"] = "--stages (default " + " ".join(map(str, DEFAULT_STAGES)) + ")"

    def load(gsd, stages=None):
        ov = {k: (dict(v) if isinstance(v, dict) else v) for k, v in overrides.items()}
        if gsd is not None:
            ov["orbit"]["gsd_m"] = gsd
        if stages is not None:
            ov.setdefault("tdi", {})["stages"] = stages
        # stages above the window's M0 are the feasibility report's NO, not bad input
        return load_scene(scene_path, overrides=ov, labels=labels, window=False)

    scenes = []
    notes = []
    for gsd in gsds:
        if not defaults:
            scenes.append(load(gsd))
            continue
        # the default grid adapts: only the stage counts the sensor rows and window allow
        probe = load(gsd, [1])
        m0 = None if probe.timing is None else probe.timing.m0
        cap = probe.sensor.rows if m0 is None else min(probe.sensor.rows, m0)
        fit = [m for m in DEFAULT_STAGES if m <= cap] or [max(cap, 1)]
        out = [m for m in DEFAULT_STAGES if m not in fit]
        if out:
            why = (f"M0 = {m0}" if m0 is not None and m0 < probe.sensor.rows
                   else f"the {probe.sensor.rows} sensor rows")
            at = "" if gsd is None else f" at GSD {gsd:g} m"
            notes.append(f"default stages {' '.join(map(str, out))} left out{at}: above "
                         f"{why} (give --stages to plan them)")
        scenes.append(load(gsd, fit))
    labels["notes"] = notes
    return scenes, labels


# --------------------------------------------------------------------------------------
# computation
# --------------------------------------------------------------------------------------


def gateware_plan(stages, width, line_period_s, *, fpga_clock_mhz=None, scene_file=None,
                  chain_rate=None, front_rate=None) -> dict:
    """What the TDI gateware must do for the camera, and whether the measured synthesis does.

    The TDI block receives the M-row window, ``M x W`` pixels, every line period:
    ``rate = M W / T`` pixels per second. At ``ppc`` pixels per clock it needs a clock of
    ``rate / ppc``. ``ok`` says whether the reference Fmax (:data:`REFERENCE_TDI_FMAX_MHZ`, or
    ``fpga_clock_mhz`` for every ppc) reaches it at some ppc the block offers for this width
    (:data:`tdicam.beats.PPC_CHOICES`, ``W`` a multiple of ppc with >= 2 beats);
    ``margin`` is ``best pixel rate / rate - 1`` (negative: short).

    ``chain``: the scene's whole processing chain as placed and routed, from the synthesis
    record's ``pipeline`` rows of ``scene_file`` (a file name; :mod:`tdicam.hw.record`):
    per recorded ppc its Fmax, pixel rate ``Fmax x ppc`` and whether that reaches ``rate``
    (every block before TDI takes the M-row window at the same rate), or ``chain_rate`` when
    given (an area camera's ``[camera]``: the samples a gain channel a second its frames
    bring, :func:`tdicam.planning.camera.samples_per_s`); a split camera's front device
    (``part`` front) against ``front_rate`` when given instead (the pixels a second its
    crossing FIFO takes during a line from the lanes, :func:`tdicam.planning.camera.front_rate`);
    the best row decides ``chain_ok``. None without a record of the scene (``tdicam synth pipeline --scene S
    --record`` makes one) or with ``fpga_clock_mhz``.
    """
    rate = stages * width / line_period_s
    clocks = REFERENCE_TDI_FMAX_MHZ if fpga_clock_mhz is None else {
        p: float(fpga_clock_mhz) for p in PPC_CHOICES}
    options = []
    for ppc in PPC_CHOICES:
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
    need = chain_rate or rate
    need_what = ("a gain channel's samples at [camera].frame_rate_hz" if chain_rate
                 else "the sensor's window every line period")
    def clk(r):            # the processing clock's Fmax (the clock the pixels need)
        return (r.fmax_clocks or {}).get("clk", r.fmax_mhz)

    def row(r):
        part = r.params.get("part", "whole")
        n, what = ((front_rate, "a line from the lanes in its line's word clocks")
                   if part == "front" and front_rate else (need, need_what))
        rate_ = clk(r) * 1e6 * int(r.params.get("ppc", 1))
        return {"label": r.label, "ppc": int(r.params.get("ppc", 1)), "fmax_mhz": clk(r),
                "seeds": len(r.fmax_seeds), "width": r.params.get("width"), "date": r.date,
                "pixel_rate": rate_, "meets": rate_ >= n, "need": n, "need_what": what,
                "part": part}

    chain = None if scene_file is None or fpga_clock_mhz is not None else [
        row(r) for r in record.find("pipeline", scene=scene_file)
        if "bus" not in r.params] or None     # a bus row is the control bus's cost
    return {
        "pixel_rate": rate, "stages": stages, "width": width,
        "source": ("synthesis record (ECP5-85F speed 8)" if fpga_clock_mhz is None
                   else f"--fpga-clock-mhz {fpga_clock_mhz:g}"),
        "options": options,
        "ppc": None if chosen is None else chosen["ppc"],
        "clock_mhz": None if chosen is None else chosen["fmax_mhz"],
        "best_pixel_rate": None if best is None else best["pixel_rate"],
        "ok": None if best is None else bool(meeting),
        "margin": None if best is None else best["pixel_rate"] / rate - 1.0,
        "chain": chain,
        "chain_ok": None if chain is None else _chain_ok(chain),
    }


def _chain_ok(chain):
    """Whether the recorded chain keeps up (:func:`chain_silicon`'s rows all do)."""
    rows = chain_silicon(chain)
    return rows is not None and all(c["meets"] for c in rows)


def _snr(scene, stages):
    """SNR section of one point: the signal clipped at the full well (and said), no gain
    without signal."""
    import dataclasses


    s = scene.sensor
    t_line = scene.line_period_s
    dark_e = s.dark_current_e_per_s * t_line
    asked = scene.target.signal_e
    # the well holds one exposure (digital TDI) or the charge sum of m (charge domain)
    per_exposure_well = s.full_well_e / (stages if scene.tdi.domain == "charge" else 1)
    cap = max(per_exposure_well - dark_e, 0.0)
    signal = min(asked, cap)
    clipped = asked > cap
    sigma_ad = float(plan.quantization_noise(s.conversion_gain_e_per_dn))
    out = {"domain": scene.tdi.domain, "signal_e": signal, "signal_asked_e": asked,
           "clipped_at_full_well": clipped, "full_well_e": s.full_well_e, "dark_e": dark_e,
           "read_noise_e": s.read_noise_e, "sigma_ad_e": sigma_ad,
           "sigma_cmos_e": float(plan.temporal_noise(signal, s.read_noise_e, dark_e)),
           "single_db": None, "gain_digital": None, "gain_digital_db": None,
           "gain_charge": None, "gain_charge_db": None, "tdi_db": None, "predicted": None}
    if signal <= 0:
        return out          # no signal: no SNR, and no SNR gain to speak of
    sigma_cmos = out["sigma_cmos_e"]
    g_dig = float(plan.snr_gain_digital(stages, sigma_ad, sigma_cmos))
    g_chg = float(plan.snr_gain_charge(stages, sigma_ad, math.sqrt(signal + dark_e),
                                       s.read_noise_e))
    single = float(20 * np.log10(signal / (sigma_ad + sigma_cmos)))
    gain = g_dig if scene.tdi.domain == "digital" else g_chg
    sc = scene if not clipped else dataclasses.replace(
        scene, target=dataclasses.replace(scene.target, signal_e=signal))
    pred = snr_prediction(sc, stages)
    out.update({
        "single_db": single, "gain_digital": g_dig, "gain_digital_db": float(plan.gain_db(g_dig)),
        "gain_charge": g_chg, "gain_charge_db": float(plan.gain_db(g_chg)),
        "tdi_db": single + float(plan.gain_db(gain)),
        "predicted": {"single_db": pred["snr1_db"], "gain_db": pred["predicted_db"],
                      "tdi_db": pred["snr1_db"] + pred["predicted_db"], "rho": pred["rho"],
                      "sigma_fpn_e": pred["sigma_fpn_e"]}})
    return out


def _point(scene, stages, *, onchip_budget_bits, ddr_bits, ddr_clock_hz, ddr_eff,
           fpga_clock_mhz):
    s = scene.sensor
    t_line = scene.line_period_s
    required = float(plan.required_frame_rate(stages, s.rows, t_line))
    available = s.available_frame_rate_hz
    timing = scene.timing
    pattern = "given"
    if ddr_eff is None:
        pattern, ddr_eff = tdi_spill_efficiency(s.columns, stages, s.bits)
    mem = plan.tdi_memory(s.columns, stages, s.bits, t_line, onchip_budget_bits=onchip_budget_bits,
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
            # the frame rate holds m rows in a line period: the window's row time again
            "fix": (None if available is None or required <= available * (1 + 1e-12)
                    else window_fix(scene, stages)),
        },
        "window": None if timing is None else {
            "row_time_s": timing.row_time_s, "n_lines": timing.n_lines, "m0": timing.m0,
            "back_porch_s": timing.back_porch_s, "capped": timing.capped,
            "ok": stages <= timing.m0,
            "fix": None if stages <= timing.m0 else window_fix(scene, stages)},
        "memory": {
            "sum_bits": mem.sum_bits, "basic_lines": mem.basic_lines,
            "optimized_lines": mem.optimized_lines, "saving_lines": mem.saving_lines,
            "basic_bits": mem.basic_bits, "optimized_bits": mem.optimized_bits,
            "saving_bits": mem.saving_bits, "onchip_budget_bits": mem.onchip_budget_bits,
            "fits_onchip": mem.fits_onchip, "must_spill": mem.must_spill},
        "ddr": {"needed_bps": mem.ddr_needed_bps, "available_bps": mem.ddr_available_bps,
                "ok": mem.ddr_ok, "word_bits": ddr_bits, "user_clock_hz": ddr_clock_hz,
                "efficiency": ddr_eff, "pattern": pattern,
                "pattern_text": PATTERNS[pattern][1] if pattern in PATTERNS else
                "--ddr-efficiency"},
        "gateware": gateware_plan(
            stages, s.columns, t_line, fpga_clock_mhz=fpga_clock_mhz,
            scene_file=None if scene.source == "<command line>" else Path(scene.source).name,
            chain_rate=None if scene.camera is None else samples_per_s(scene, scene.camera),
            front_rate=front_rate(scene)),
        "snr": _snr(scene, stages),
        "mtf_nyquist": [mtf_prediction(scene, stages, dv) for dv in scene.motion.dv_over_v],
        "mtf_left_out": list(mtf_left_out(scene)),
    }


def window_fix(scene, stages) -> str:
    """What gives ``M0 >= stages`` (Tao et al. 2012 eq 13: ``M0 = floor(T_line / T_row)``):
    a row time ``T_row <= T_line / stages``, i.e. the pixel clock or the row blanking (or
    the datasheet frame rate) that gives it, or fewer stages; the sensor's rows cap M0."""
    s = scene.sensor
    t_line = scene.line_period_s
    if stages > s.rows:
        return f"the sensor has {s.rows} rows: at most {s.rows} stages"
    t_row = t_line / stages
    ways = []
    if s.pixel_clock_mhz is not None:
        t_rb = s.row_blanking_us * 1e-6
        if t_row > t_rb:
            ways.append(f"[sensor].pixel_clock_mhz >= {s.columns / (t_row - t_rb) / 1e6:.4g} "
                        f"(at row_blanking_us = {s.row_blanking_us:g})")
        left = t_row - s.columns / (s.pixel_clock_mhz * 1e6)
        if left >= 0:
            ways.append(f"[sensor].row_blanking_us <= {left * 1e6:.4g}")
    else:
        ways.append(f"[sensor].max_frame_rate_hz >= {1 / (t_row * s.rows):.4g}")
    m0 = scene.timing.m0
    ways.append(f"stages <= {m0}" if m0 > 0 else "a longer line period (coarser GSD)")
    return f"T_row <= T_line / {stages} = {t_row * 1e6:.4g} us gives M0 >= {stages}: " \
           + " or ".join(ways)


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
    if point["gateware"]["chain_ok"] is False:
        no.append("chain pixel rate (synthesis record)")
    return no


def system_plan(scene, point, *, ddr_bits, ddr_clock_hz):
    """The system section: the figures of the scene's pipeline blocks at the design point
    (each block's :attr:`tdicam.blocks.Use.system`: the calibration load before the first
    frame, the reset frame's DDR bandwidth), or None when no block of the chain has any; a
    chain the gateware cannot build (:func:`tdicam.chain.design.chain_plan` refuses it: a
    FIFO, lane count or DDR address range past the hardware's) is one NO row, ``pipeline
    design``, with the design's reason."""
    from tdicam.chain import design
    if scene.pipeline is None or not scene.pipeline.blocks:
        return None
    try:
        p = design.chain_plan(scene, stages=point["stages"])
    except TdicamError as exc:
        # a design the gateware cannot build is the plan's NO, never a missing section
        return [{"name": "pipeline design", "ok": False, "value": None, "unit": None,
                 "text": f"pipeline design at {point['stages']} stages: {exc}: NO"}]
    ctx = {"line_period_s": point["line_period_s"], "ddr_bits": ddr_bits,
           "ddr_clock_hz": ddr_clock_hz, "lanes": p.lanes, "rows": p.stages, "width": p.width,
           "scene": scene}
    uses = design.uses()
    rows = [r for st in p.steps if uses[st.block].system is not None
            for r in uses[st.block].system(st, ctx)]
    return rows or None


def run_memory(source):
    """What ``tdicam run SOURCE`` would need: its estimated peak memory
    (:func:`tdicam.engine.budget.estimate`, the ``"memory"`` entry of report.json) with the
    memory available now and ``fits`` (True, False, or None when the machine says nothing);
    ``{"refused": message}`` when ``tdicam run`` refuses the scene (stages above ``M0``)."""
    from tdicam.engine import budget
    from tdicam.scene.loader import load_scene
    try:
        scene = load_scene(source)
    except TdicamError as exc:      # stages above M0: the plan's NO, the run's refusal
        return {"refused": str(exc)}
    est = budget.estimate(scene)
    est.available_bytes = budget.available_bytes()
    return {**est.to_dict(), "fits": None if est.available_bytes is None
            else bool(est.peak_bytes <= est.available_bytes)}


def verdict(scene) -> dict:
    """The plan's verdict on one scene (what ``tdicam plan --scene`` says), for a run's
    console and report: ``feasible`` (True, False; None when the scene cannot be planned)
    and ``reasons``, one phrase per check that says NO (or why there is no plan)."""
    try:
        rep = plan_report([scene], memory=False)
    except TdicamError as exc:
        return {"feasible": None, "reasons": [f"not planned: {exc}"]}
    d = rep["design"]
    fr, w, g = d["frame_rate"], d["window"], d["gateware"]
    why = {"frame rate": lambda: f"frame rate: {fr['required_hz']:.1f} frame/s needed, "
                                 f"{fr['available_hz']:.1f} available",
           "window (stages > M0)": lambda: f"window: {d['stages']} stages > M0 = {w['m0']}",
           "DDR bandwidth": lambda: f"DDR bandwidth: {d['ddr']['needed_bps'] / 1e9:.3g} Gbit/s "
                                    f"needed, {d['ddr']['available_bps'] / 1e9:.3g} available",
           "gateware pixel rate": lambda: f"gateware pixel rate: {g['pixel_rate'] / 1e9:.3g} G "
                                          f"pixel/s into TDI, the synthesised TDI reaches "
                                          f"{g['best_pixel_rate'] / 1e9:.3g} G"}
    rows = {r["name"]: r["text"] for r in rep["system"] or () if r["ok"] is False}
    reasons = [why[n]() if n in why else rows.get(n, n) for n in rep["infeasible"]]
    return {"feasible": rep["feasible"], "reasons": reasons}


def plan_report(scenes, *, onchip_budget_bits=None, ddr_bits=plan.DDR_WORD_BITS,
                ddr_clock_hz=plan.DDR_USER_CLOCK_HZ, ddr_efficiency=None,
                fpga_clock_mhz=None, notes=(), memory=True) -> dict:
    """All planning numbers for the scenes (one per GSD) as a JSON-ready dict.

    Parameters
    ----------
    scenes : list of tdicam.scene.loader.Scene
        Scenes differing only in ``[orbit].gsd_m`` (or one turntable scene).
    onchip_budget_bits : int, optional
        On-chip RAM for the partial sums, bits.
    ddr_bits, ddr_clock_hz, ddr_efficiency
        DDR user interface (defaults: Ning et al. 2019's 256 bit, 100 MHz; efficiency: the
        TDI spill's access pattern on the memory model with DRAM timing,
        :func:`tdicam.model.ddr_efficiency.tdi_spill_efficiency`, per design point).
    fpga_clock_mhz : float, optional
        TDI block clock for every ppc instead of :data:`REFERENCE_TDI_FMAX_MHZ`.
    notes : sequence of str, optional
        Lines the report prints before the feasibility verdict (``plan_scenes``'s notes).
    memory : bool, optional
        Estimate the memory of ``tdicam run`` of the scene file (``run_memory``).

    Returns
    -------
    dict
        ``points`` (one per GSD x stage count), ``design`` (the point with the highest
        required frame rate), ``feasible`` (False when a check of ``design`` says NO, listed
        in ``infeasible``) and context (orbit, sensor, scene source).
    """
    first = scenes[0]
    s = first.sensor
    plan.ddr_bandwidth_available(ddr_bits, ddr_clock_hz, ddr_efficiency or 1)  # validate early
    sum_bits = max(plan.partial_sum_bits(sc.sensor.bits, max(sc.tdi.stages)) for sc in scenes)
    if ddr_bits < sum_bits:
        raise TdicamError(f"--ddr-bits = {ddr_bits} is out of range; valid: {sum_bits}..4096 "
                          f"(a DDR word holds at least one {sum_bits}-bit partial sum)")
    if fpga_clock_mhz is not None:      # called without check_options too
        check_options({"fpga_clock_mhz": fpga_clock_mhz})
    points = [_point(sc, m, onchip_budget_bits=onchip_budget_bits, ddr_bits=ddr_bits,
                     ddr_clock_hz=ddr_clock_hz, ddr_eff=ddr_efficiency,
                     fpga_clock_mhz=fpga_clock_mhz)
              for sc in scenes for m in sc.tdi.stages]
    design = max(range(len(points)), key=lambda i: points[i]["frame_rate"]["required_hz"])
    no = _verdict(points[design])
    system = system_plan(first, points[design], ddr_bits=ddr_bits, ddr_clock_hz=ddr_clock_hz)
    no += [r["name"] for r in system or () if r["ok"] is False]
    camera = camera_plan(first, chain=points[design]["gateware"]["chain"])  # [camera]'s budget
    no += [f"camera {n}" for n in (camera["scene"]["infeasible"] if camera else ())]
    out = {
        "scene": None if first.source == "<command line>" else first.source,
        "run_memory": (None if first.source == "<command line>" or not memory
                       else run_memory(first.source)),
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
        "notes": list(notes),
        "system": system,
    }
    if camera is not None:              # only a scene with [camera]: other plans as before
        out["camera"] = camera
    if first.orbit is not None:
        out["orbit"] = {"altitude_km": first.orbit.altitude_km,
                        "ground_speed_m_s": first.orbit.ground_speed_m_s}
    else:
        out["turntable"] = {"angular_speed_rad_s": first.turntable.angular_speed_rad_s,
                            "distance_m": first.turntable.distance_m}
    return out

