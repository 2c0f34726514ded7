"""Co-simulation of a scene's whole pipeline in RTL (``[run.rtl]`` of a scene file).

The scene's ``[pipeline]`` becomes one generated top (:mod:`tdicam.chain.design`); the scene's
raw data -- every exposure frame of every channel, the reset frames, the NUC calibration
codes -- runs through it in fast mode and every block's output (tap) is compared bit for
bit with the golden chain on the same data. Without ``crop`` the whole scene runs; with
``crop = [x0, y0, width, height]`` only the input columns and frames that make that output
window (the golden chain runs on the same cut data, so a 2-D block's borders are those of
the crop).

:func:`cosimulate` does the comparison for any plan and data: the top is built with every
block's output exposed (taps), tbgen's fast-mode testbench is extended to write each tap to
a file, and on a mismatch the run is repeated on Icarus up to the cycles around the first
one, dumped to an FST file.
"""

from __future__ import annotations

import json
import os
import shutil
import time

import numpy as np

from tdicam.chain import link_check
from tdicam.cosim import WAVE_WINDOW, keep_wave, wave_window
from tdicam.errors import TdicamError

__all__ = ["cosim_scene", "check_rtl_design", "check_lane_death", "scene_data", "cosimulate", "run_top",
           "beats_differ", "WAVE_WINDOW",
           "status_ports", "system_figures"]


def scene_data(scene, *, stages, dv_over_v, lines):
    """The raw data of one exact simulation of ``scene``: (:class:`~tdicam.chain.design.
    SceneData`, engine result).

    The frames are those the scene simulator hands out with ``keep_raw`` (every channel's
    raw frames, the reset frames and the NUC codes as they enter its pipeline blocks). The
    run is exact and has the same seed, so the frames are those of ``tdicam run``'s exact
    result.
    """
    from tdicam import engine
    from tdicam.chain.design import SceneData
    res = engine.simulate(scene, stages=stages, dv_over_v=dv_over_v, fidelity="exact",
                          lines=lines, impact=False, keep_raw=True)
    raw = res.raw_data
    if raw is None:
        raise TdicamError("[run.rtl]: the scene simulator gave no raw frames (digital TDI, "
                          "exact fidelity needed)")
    return SceneData(raw["signal"], raw["reset"], raw["coeffs"]), res


def cosim_scene(scene, res, crop, *, out_dir=None, corrupt=None):
    """Run the scene's pipeline in RTL and compare with its golden chain.

    Parameters
    ----------
    scene : Scene
    res : engine SceneResult
        The run's main result (stages, velocity mismatch and lines are taken from it).
    crop : (y0, h, x0, w)
        Used when ``[run.rtl].crop`` is given; without it the whole scene runs.
    out_dir : path or None
        Where the waveform of a mismatch goes.
    corrupt : callable or None
        Alters the golden stages first (tests: the check can fail).

    Returns
    -------
    dict
        ``simulator``, ``crop`` (None: whole scene), ``blocks`` (one entry per tap, then the
        ``pipeline`` entry with the totals: pixels compared, mismatches, input pixels, build
        and run seconds, input pixels/s, the first mismatch and the waveform path).
    """
    from tdicam.chain import design
    rt = scene.run.rtl
    m, lines = int(res.stages), int(res.output.shape[0])
    out = {"simulator": rt.simulator, "crop": None if rt.crop is None else list(rt.crop),
           "blocks": []}
    try:
        p = design.chain_plan(scene, stages=m, lines=lines)
        t0 = time.perf_counter()
        data, ex = scene_data(scene, stages=m, dv_over_v=res.dv_over_v, lines=lines)
        golden_s = time.perf_counter() - t0
        agree, gold = None, None
        extra = check_lane_death(scene, lines, stages=m)
        if rt.crop is not None:
            y0, h, x0, w = crop
            p = design.chain_plan(scene, stages=m, lines=h, width=w)
            data = data.crop(x0, w, y0, h + m - 1 + extra,
                             coeff_rows=scene.pipeline.nuc.coefficients == "frame")
        else:
            gold = design.golden(p, data)
            last = gold[-1][2]
            agree = bool(np.array_equal(last.reshape(ex.output.shape), ex.output))
            if not agree:
                raise TdicamError("[run.rtl]: the golden chain and the scene simulator's "
                                  "output differ")
        lv = scene.sensor.lvds
        front = None if lv is None else {
            "lanes": lanes_of(lv, p.lanes), "word_ns": 1e3 * lv.word_bits / lv.bit_rate_mbps,
            "dies": rt.lane_dies, "eye_taps": lv.eye_width_taps if lv.simulate else None,
            "drift": (lv.drift_taps, lv.drift_frames) if lv.drift_taps else None}
        rep = cosimulate(p, data, rt.simulator, gold=gold, corrupt=corrupt,
                         wave_dir=out_dir, front=front, csr=rt.csr)
    except TdicamError as exc:
        out["blocks"].append({"block": "pipeline", "status": f"error: {exc}"})
        return out
    for t in rep["taps"]:
        out["blocks"].append({"block": f"tap {t['tap']}", "status": "ran",
                              "pixels_compared": t["pixels"], "mismatches": t["mismatches"],
                              "beats": t["received"]})
    system = system_figures(p, rep)
    if system:
        out["system"] = system
    if (rep.get("lanes") or {}).get("eyes"):
        out["eyes"] = rep["lanes"]["eyes"]
    if (rep.get("lanes") or {}).get("corrections"):
        out["corrections"] = rep["lanes"]["corrections"]
    if rt.phy != "generic":
        from tdicam.chain.phy_check import phy_check
        out["phy_checks"] = [phy_check(lv, front["lanes"], rt.phy, rt.simulator,
                                       drift_words=rep.get("lanes", {}).get("drift_words"))]
    summary = {k: v for k, v in rep.items() if k not in ("taps", "link_words")}
    summary.update({"block": "pipeline", "status": "ran", "engine_agrees": agree,
                    "scene_data_seconds": golden_s})
    out["blocks"].append(summary)
    return out




def check_rtl_design(scene, lines, *, stages=None, lines_key="[run].lines") -> int:
    """Refuse a ``[run.rtl]`` co-simulation before any work when its design cannot be
    built: the chain of ``lines`` output lines at ``stages`` (default the scene's largest)
    over the crop (or the whole frame), planned as :func:`cosim_scene` plans it
    (:func:`tdicam.chain.design.chain_plan`: the pixels per clock over the crop width, the
    pixel widths, the front's FIFO, the DDR addresses), then ``lane_dies``
    (:func:`check_lane_death`). Returns what :func:`check_lane_death` returns (0 without
    ``[run.rtl]``).

    Raises
    ------
    TdicamError
        One line, ``[run.rtl]: the co-simulated design ...`` and the design's reason.
    """
    rt = scene.run.rtl
    if rt is None:
        return 0
    from tdicam.chain import design
    m = max(scene.tdi.stages) if stages is None else stages
    where = "the whole frame" if rt.crop is None else f"the {rt.crop[2]}-column crop"
    try:
        if rt.crop is None:
            design.chain_plan(scene, stages=m, lines=lines)
        else:
            design.chain_plan(scene, stages=m, lines=rt.crop[3], width=rt.crop[2])
    except TdicamError as exc:
        raise TdicamError(f"[run.rtl]: the co-simulated design ({where}, {m} stages) cannot "
                          f"be built: {exc}") from None
    return check_lane_death(scene, lines, stages=stages, lines_key=lines_key)


def check_lane_death(scene, lines, *, stages=None, lines_key="[run].lines") -> int:
    """Refuse ``[run.rtl].lane_dies`` before any work when the co-simulation of ``lines``
    output lines at ``stages`` (default the scene's largest) cannot place it: no crop, a
    crop that leaves no room for the frames the sensor sends until the retrain, a lane
    death in a reset frame or in one of the last :data:`HELD` + 1 frames the sensor sends.
    ``lines_key`` names where ``lines`` came from (``--lines``). Returns the extra output
    lines of raw frames the crop takes (0 without a lane death).

    Raises
    ------
    TdicamError
        One line naming ``[run.rtl].lane_dies`` and its value.
    """
    rt = scene.run.rtl
    if rt is None or rt.lane_dies is None:
        return 0
    lane, f = rt.lane_dies
    key = f"[run.rtl].lane_dies = [{lane}, {f}]"
    if rt.crop is None:
        raise TdicamError(f"{key}: needs a [run.rtl].crop (the sensor sends the crop's frames "
                          f"and those held for the retrain)")
    from tdicam.chain import design
    x0, y0, w, h = rt.crop
    m = max(scene.tdi.stages) if stages is None else stages
    p = design.chain_plan(scene, stages=m, lines=h, width=w)
    per = 2 if p.reset_frames else 1
    extra = -(-HELD // per)           # the sensor sends the frames held for the retrain too
    if y0 + h + extra > lines:
        raise TdicamError(f"{key}: the crop must end {extra} line(s) before {lines_key} = "
                          f"{lines} (the frames held for the retrain); it ends at {y0 + h}")
    _check_death(lane, f, p.lanes * scene.sensor.lvds.lanes_per_gain,
                 (h + m - 1 + extra) * per, p.reset_frames)
    return extra


def _check_death(lane, f, lanes, frames, reset_frames):
    if not 0 <= lane < lanes or f + 1 + HELD >= frames:
        raise TdicamError(f"[run.rtl].lane_dies = [{lane}, {f}]: needs a lane 0.."
                          f"{lanes - 1} and a frame before the last {HELD + 1} of the "
                          f"{frames} the sensor sends")
    if reset_frames and f % 2 == 0:
        raise TdicamError(f"[run.rtl].lane_dies = [{lane}, {f}]: frame {f} is a reset frame; "
                          f"the sensor sends reset and signal frames in turn: give a signal "
                          f"frame (odd)")


def lanes_of(lv, gains):
    """The lanes of a scene's ``[sensor.lvds]`` for a co-simulation: the scene's eyes and
    jitter when it simulates the link, else ideal lanes."""
    from tdicam.model import lvds_front
    if lv.simulate:
        return lvds_front.scene_lanes(lv, gains)
    return ideal_lanes(lv.lanes_per_gain * gains)


def ideal_lanes(n):
    """``n`` lanes with a wide-open eye (20 taps centred on tap 16), no jitter."""
    from tdicam.model import lvds_front
    return [lvds_front.eye_lane(16, 20, seed=i) for i in range(n)]


def status_ports(axis_top):
    """[(name, width)] of the top's status outputs: its ``Out`` ports besides the streams,
    the taps and the output links' pins (the stages' status, the start-up counter, the
    external parts' models')."""
    from amaranth.hdl import Shape
    from amaranth.lib import wiring
    from tdicam.hdl.tlk2711 import pin_names
    from tdicam.model.tlk2711 import LINKS
    pins = {n for k in range(max(LINKS)) for n in pin_names(k)}       # the output links'
    return [(n, Shape.cast(mem.shape).width) for n, mem in axis_top.signature.members.items()
            if mem.flow == wiring.Out and not n.startswith(("m_axis_", "s_axis_", "tap"))
            and n not in pins]


def system_figures(p, rep):
    """What the co-simulated camera saw, from its status outputs: each block's
    :attr:`tdicam.blocks.Use.measured` figures (the calibration load, the DDR traffic) for a
    :func:`cosimulate` report ``rep`` of plan ``p``; [] when no block has any."""
    from tdicam.chain import design
    uses = design.uses()
    return [r for s in p.steps if uses[s.block].measured is not None
            for r in uses[s.block].measured(s, rep.get("status_outputs", {}), {
                "cycles": rep["cycles"], "rows": p.stages, "width": p.width,
                "lanes": rep.get("lanes")})]


def _testbench(axis_top, taps, *, wave, standalone, links=None):
    """tbgen's fast-mode testbench with every tap written to ``tap<k>.hex`` (the output
    file's format) and its cycle to ``tap<k>.cyc``, and every status output's value at the
    end of the run to ``status.txt`` (``name value`` lines, decimal); with ``wave`` tbgen's
    waveform window (``wave.fst`` of cycles ``+wave_from .. +wave_to``); ``standalone``:
    tbgen's standalone form (clock from the C++ loop, no cocotb); ``links`` (a top that
    ends in the output links, :class:`~tdicam.blocks.steps.LinkPlan`): the links' words
    as the output (:func:`_link_capture`)."""
    from tdicam.cosim import stream_ports, tbgen
    in_bits, out_bits, ctrl = stream_ports(axis_top)
    if links is not None:
        out_bits = link_check.PADDED * links.links
    tb = tbgen.stream_testbench("pipeline", in_bits=in_bits, out_bits=out_bits,
                                ctrl_ports=ctrl, wave=wave, per_beat=False,
                                standalone=standalone)
    decl, conn, opens, writes, closes = [], [], [], [], []
    status = status_ports(axis_top)
    if status:
        decl += [f"  wire [{w - 1}:0] st_{n};\n" for n, w in status] + ["  integer sfd;\n"]
        conn += [f"    .{n}(st_{n})," for n, _ in status]
        closes.append('      sfd = $fopen("status.txt", "w");')
        closes += [f'      $fwrite(sfd, "{n} %0d\\n", st_{n});' for n, _ in status]
        closes.append("      $fclose(sfd);")
    for k, (name, bits, count) in enumerate(taps):
        padded = -(-bits // 8) * 8
        base = f"tap{k}_{name}"
        decl.append(f"  wire {base}_valid, {base}_ready, {base}_first, {base}_last;\n"
                    f"  wire [{bits * count - 1}:0] {base}_data;\n"
                    f"  integer tfd{k}, tcd{k};\n")
        conn += [f"    .{base}_{s}({base}_{s})," for s in ("valid", "ready", "first", "last",
                                                         "data")]
        parts = []
        for e in range(count - 1, -1, -1):
            piece = f"{base}_data[{bits * (e + 1) - 1}:{bits * e}]"
            parts.append(piece if padded == bits else f"{padded - bits}'d0, {piece}")
        opens.append(f'    tfd{k} = $fopen("tap{k}.hex", "w"); tcd{k} = $fopen("tap{k}.cyc", '
                     f'"w");')
        writes.append(
            f"      if ({base}_valid && {base}_ready) begin\n"
            f'        $fwrite(tfd{k}, "%h %h %h\\n", seg, {{2\'b00, {base}_first, {base}_last}},'
            f" {{{', '.join(parts)}}});\n"
            f'        $fwrite(tcd{k}, "%h\\n", cycles);\n'
            f"      end")
        closes.append(f"      $fclose(tfd{k}); $fclose(tcd{k});")
    extra = "".join(decl)
    marker = "  pipeline dut (\n    .clk(clk),\n"
    if marker not in tb:
        raise TdicamError("pipeline: the fast-mode testbench changed shape; update "
                          "tdicam.chain.design._testbench")
    tb = tb.replace(marker, extra + marker + "\n".join(conn) + "\n")
    if links is not None:
        tb = link_check.capture_testbench(tb, links.links)
    body = ["  initial begin", *opens, "  end",
            "  always @(posedge clk) begin",
            "    if (running && !rst) begin", *writes, "    end",
            "    if (running && (drain_cnt >= drain || cycles >= max_cycles)) begin",
            *closes, "    end"]
    body.append("  end\n")
    i = tb.rindex("endmodule")
    return tb[:i] + "\n".join(body) + tb[i:]


def _hexcol(raw, digits):
    table = np.full(256, 0, np.uint64)
    for i, c in enumerate(b"0123456789abcdef"):
        table[c] = i
    lines = np.frombuffer(raw, np.uint8).reshape(-1, digits + 1)[:, :digits]
    out = np.zeros(len(lines), np.uint64)
    for k in range(digits):
        out = (out << np.uint64(4)) | table[lines[:, k]]
    return out


def run_top(p, data, sim, *, taps=True, wave=None, seed=1, idle=0.0, backpressure=0.0,
              keep=False, front=None, ecp5=False, csr=False):
    """Build (cached) and run the top on the scene data in fast mode.

    Returns ``(got, info)``: ``got["out"]`` the output beats and, with ``taps``, ``got[k]``
    = (beats, cycle of each beat) of tap ``k``; ``info`` the testbench summary plus
    ``build_seconds`` (0 when the build was cached), ``run_seconds`` (simulator wall time),
    ``run_cpu_seconds`` (the simulator process's CPU time, build excluded) and
    ``input_beats``.

    ``wave = (from, to)`` writes ``wave.fst`` of those cycles (Icarus) and stops there.
    ``ecp5``: the chain's ECP5 synthesis top (what ``tdicam synth pipeline`` places: DP16KD
    and MULT18X18D instances) with the primitives' simulation models
    (:mod:`tdicam.cosim.dp16kd`, :mod:`tdicam.cosim.mult18x18d`).

    A top whose input is the sensor's lanes (a ``[sensor.lvds]`` scene) runs from the lanes
    (:func:`_run_lanes`; ``front``: its ``lanes`` and ``word_ns``); ``idle`` and
    ``backpressure`` do not apply (the sensor sets the pace). ``csr`` (a top from the lanes
    only): the top with the control bus, the front's status read through it
    (:mod:`tdicam.simtb.lanes_bus`; ``info["registers"]``, ``info["irq"]``).
    """
    from tdicam import cosim
    from tdicam.chain import design
    from tdicam.cosim import codec, tbgen
    from tdicam.hw.verilog import convert
    t0 = time.perf_counter()
    if design.sourced(p) and wave is not None:
        raise TdicamError("the chain's input is the sensor's lanes ([sensor.lvds]): no "
                          "waveform re-run of a lane co-simulation")
    if csr and not design.sourced(p):
        raise TdicamError("run_top(csr=True): the bus co-simulation from here is the lanes' "
                          "(a [sensor.lvds] scene); cocotb_tests/test_csr.py runs the others")
    ax = design.top(p, data, taps=taps, board=True, ecp5=ecp5, csr=csr)
    if design.sourced(p):
        return _run_lanes(p, data, sim, ax, taps, front or {}, keep, t0)
    tap_shapes = ax.core.tap_shapes if taps else []
    dut = convert(ax, "pipeline")
    # Verilator: the standalone testbench (no cocotb, no timing scheduler; ~2x the cycles
    # per second); Icarus (and its waveform re-run): cocotb starts the engine
    standalone = sim == "verilator" and wave is None
    if p.links is not None and backpressure:
        raise TdicamError("the output links take no backpressure (their word clock sets "
                          "the pace): give backpressure = 0")
    tb = _testbench(ax, tap_shapes, wave=wave is not None, standalone=standalone,
                    links=p.links)
    key = {"plan": p.source, "steps": [[s.block, s.params] for s in p.steps],
           "taps": taps, "wave": wave is not None, "standalone": standalone} | \
        ({"ecp5": True} if ecp5 else {})
    elab = time.perf_counter() - t0
    sources = {"pipeline.v": dut, "tb.v": tb}
    if ecp5:
        from tdicam.cosim import dp16kd, mult18x18d
        sources.update({dp16kd.FILE: dp16kd.MODEL, mult18x18d.FILE: mult18x18d.MODEL})
    bdir, build_s = cosim.build_sources("pipeline", key, sim, sources, standalone=standalone)
    stim = design.stimulus(p, data, ax)
    _, _, ctrl = cosim.stream_ports(ax)
    ctrl_bits = max(1, sum(w for _, w in ctrl))
    bits, count, padded, _ = ax._in
    n_in = len(stim)
    n_out = int(np.prod(design.output_shape(p))) // design.out_ppc(p)       # output beats
    out_padded, out_count = (ax._out[2], ax._out[1]) if p.links is None else \
        (link_check.PADDED, p.links.links)
    if p.links is not None:             # the output beats are the links' words
        n_out = design.link_word_count(p)
    max_cycles = (n_in + n_out) * 4 + 100_000 + ax.core.startup_bound if wave is None \
        else int(wave[1]) + 2
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    for name, data in tbgen.stimulus_files(stim, elem_padded_bits=padded, ctrl_bits=ctrl_bits):
        (rundir / name).write_bytes(data)
    job = {"mode": "fast", "n_in": n_in, "n_out": n_out, "idle": idle,
           "backpressure": backpressure, "seed": int(seed), "max_cycles": max_cycles,
           "drain": 2000, "rst_cycles": tbgen.RST_CYCLES, "in_padded": padded,
           "in_count": count, "ctrl_bits": ctrl_bits, "out_padded": out_padded,
           "out_count": out_count}
    (rundir / "job.json").write_text(json.dumps(job))
    plus = [f"+n_in={n_in}", f"+n_out={n_out}", f"+max_cycles={max_cycles}", "+drain=2000",
            f"+idle={round(idle * 256)}", f"+bp={round(backpressure * 256)}",
            f"+seed={int(seed) & 0x7fffffff}"]
    if wave is not None:
        plus += [f"+wave_from={int(wave[0])}", f"+wave_to={int(wave[1])}"]
    info, wall, cpu = _run_tb(bdir, sim, None if standalone else "stream_tb", rundir, plus,
                              "summary.json", "the pipeline", waves=wave is not None)
    st = rundir / "status.txt"
    info["status"] = {} if not st.exists() else {
        ln.split()[0]: int(ln.split()[1]) for ln in st.read_text().splitlines() if ln.strip()}
    got = {"out": codec.decode_output((rundir / "out.hex").read_bytes(),
                                      elem_padded_bits=out_padded, count=out_count)}
    for k, (name, b, c) in enumerate(tap_shapes):
        got[k] = (codec.decode_output((rundir / f"tap{k}.hex").read_bytes(),
                                      elem_padded_bits=-(-b // 8) * 8, count=c),
                  _hexcol((rundir / f"tap{k}.cyc").read_bytes(), 8))
    info.update({"build_seconds": build_s, "elaborate_seconds": elab, "run_seconds": wall,
                 "run_cpu_seconds": cpu,
                 "rundir": str(rundir), "input_beats": n_in, "build_dir": str(bdir)})
    if not keep and wave is None:
        shutil.rmtree(rundir, ignore_errors=True)
    return got, info


def _run_tb(bdir, sim, module, rundir, plus, result, what, **kw):
    """Run cocotb testbench ``module`` on a build (None: the standalone build,
    :func:`tdicam.cosim.run_standalone`); (its ``result`` JSON file, wall seconds, the
    simulator process's CPU seconds); a one-line error naming ``what`` when it failed."""
    from tdicam import cosim
    c0 = os.times()
    ok, wall = (cosim.run_standalone(bdir, rundir, plus) if module is None
                else cosim.run_cocotb(bdir, sim, module, rundir, plus, **kw))
    c1 = os.times()
    f = rundir / result
    if not ok or not f.exists():
        raise TdicamError(f"{sim} simulation of {what} failed; see {rundir / 'sim.log'}")
    cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system)
    return json.loads(f.read_text()), wall, cpu


#: The processing clock of a co-simulation from the lanes (ns): 100 MHz, the MIG's clock of
#: Ning et al. 2019's camera.
PROC_NS = 10.0

#: Frames the sensor sends after a lane's death before the camera's controller retrains the
#: lanes (``[run.rtl].lane_dies``): the front holds them (dropped, counted).
HELD = 2


def lane_fault_cut(scene_path):
    """(plan, data, ``front``) of the lanes' fault cut the co-simulation tests run: a lanes
    scene on 16 columns, 3 stages, 2 output lines, 16-block NAND parts, one frame pair more
    (held for the retrain); lane 3's eye 6 taps wide (no run of 9: cannot train) and lane 0
    dying in the middle of frame 3 (``front`` for :func:`cosimulate`, 25 MHz words)."""
    from dataclasses import replace
    from tdicam.chain import design
    from tdicam.cosim.lvds_front import GOOD_LANES, scenario_lanes
    from tdicam.scene.loader import load_scene
    sc = load_scene(scene_path, overrides={"sensor": {"columns": 16}, "tdi": {"stages": 3},
                                           "run": {"lines": 3, "rtl": {"crop": None}}})
    p = design.chain_plan(sc, lines=2)
    p = replace(p, steps=tuple(replace(s, device={**s.device, "blocks": 16}) if s.device
                               else s for s in p.steps))
    data, _ = scene_data(sc, stages=3, dv_over_v=0.0, lines=3)
    data = data.crop(0, 16, 0, p.frames + 1)
    spec = list(GOOD_LANES[:4])
    spec[3] = (12, 6, 0)
    return p, data, {"word_ns": 40.0, "dies": (0, 3), "lanes": scenario_lanes(spec)}


def _death(p, data, front, lanes, kw):
    """The lanes and sensor schedule of ``front["dies"] = (lane, frame)``: the lane dies in
    the middle of that frame (its middle line's middle word); the sensor sends :data:`HELD`
    more frames, trains (the retrain) and sends the rest. Returns (lanes, segments, the
    first pixel word of the frame, ``r P + j``, the death can reach: the lane's skew makes
    the raw word at the death carry bits of earlier data words)."""
    import math
    from dataclasses import replace
    from tdicam.cosim.lvds_front import plan_case
    from tdicam.model import lvds
    lane, f = front["dies"]
    nf = len(data.lane_arrays(p)[0][0])
    _check_death(lane, f, len(lanes), nf, p.reset_frames)
    segs = (f + 1 + HELD, nf - f - 1 - HELD)
    probe = plan_case(p, data, lanes, segments=segs, **kw)
    lw, rows = probe.p + 2, p.stages
    line, word = rows // 2, lw // 2
    at = probe.segment_starts[0] + (f * rows + line) * lw + word
    lanes = list(lanes)
    # the lane's words arrive skewed: the raw word at the death carries bits of the data
    # words up to ceil(skew / word) before it
    back = math.ceil(lanes[lane].skew_ps / (probe.word_bits * lanes[lane].ui_ps))
    lanes[lane] = replace(lanes[lane], change_at=at,
                          after=lvds.Lane(skew_ps=0.0, eye_ps=0.0))
    return lanes, segs, max(0, line * probe.p + word - 2 - back)


def _run_lanes(p, data, sim, ax, taps, front, keep, t0):
    """:func:`run_top` of a top whose input is the sensor's lanes: the sensor's frames
    (reset frames before their signal frames when the chain keeps them) sent on the lanes
    after its training (:func:`tdicam.cosim.lvds_front.plan_case`), the first frame after
    the top's start-up bound (the calibration load), the word clock at ``front["word_ns"]``
    (default 40 ns: 300 Mbit/s of 12-bit words), the processing clock at
    ``front["proc_ns"]`` (default :data:`PROC_NS`; it must take a line's beats in the line's
    word clocks: :func:`tdicam.model.lvds_front.min_proc_mhz`);
    ``front["lanes"]``: the lanes (default ideal eyes). ``info["startup"]``: the word clock
    at which the lanes had trained, each holding stage's ready port came up, and frames
    were released."""
    import math
    from dataclasses import replace
    from tdicam import blocks, cosim
    from tdicam.hdl.csr import BUS_PREFIXES
    from tdicam.chain import design
    from tdicam.cosim import codec
    from tdicam.cosim.lvds_front import driver_tables, plan_case
    from tdicam.hw.verilog import convert
    from tdicam.model import lvds
    from tdicam.model.lvds_front import min_proc_mhz
    word_ns = float(front.get("word_ns", 40.0))
    proc_ns = float(front.get("proc_ns", PROC_NS))
    step = p.steps[0]
    n = step.params["lanes"]
    lanes = front.get("lanes") or ideal_lanes(n)
    prm = blocks.get("lvds").resolve(step.params)
    slowest = min_proc_mhz(prm["lanes_per_gain"], prm["ppc"], prm["columns"], 1e3 / word_ns)
    if 1e3 / proc_ns < slowest * (1 - 1e-9):
        raise TdicamError(f"the processing clock of the lanes' co-simulation ({proc_ns:g} ns) "
                          f"cannot take {prm['lanes']} lanes' words at {word_ns:g} ns: a "
                          f"period <= {1e3 / slowest:.4g} ns (>= {slowest:.4g} MHz) is needed")
    tw = lvds.training_words(prm["word_bits"], step.ports["n_check"], prm["settle"])
    lead = max(40, math.ceil(ax.core.startup_bound * proc_ns / word_ns) - tw + 40)
    kw = dict(word_ns=word_ns, proc_ns=proc_ns, n_check=step.ports["n_check"], lead=lead,
              tail=40, walk=bool(prm["eye"]), track=prm["track"])
    died, segs = None, None
    if front.get("dies") is not None:
        lanes, segs, died = _death(p, data, front, lanes, kw)
    if front.get("drift") is not None:
        lanes = _drift(plan_case(p, data, lanes, segments=segs, **kw), lanes, *front["drift"])
    case = plan_case(p, data, lanes, segments=segs, **kw)
    tap_shapes = ax.core.tap_shapes if taps else []
    values = {f"{s.block}_{k}": v for s in p.steps for k, v in s.ports.items()}
    settings = {name: int(values[name]) for name, mem in ax.signature.members.items()
                if mem.flow.name == "In" and name not in ("lvds_lane_raw", "lvds_retrain",
                                                          "lvds_lane_mon_raw")
                and not name.startswith(("m_axis_", *BUS_PREFIXES))}
    regmap = getattr(ax.core, "regmap", None)
    pipe = ax.core.core if regmap is not None else ax.core
    ready = [f"{st.name}_{st.ready}" + (f"_{k}" if k else "")
             for st, nl in pipe.core._holds() for k in range(nl)] \
        if hasattr(pipe, "core") else []
    dut = convert(ax, "pipeline")
    elab = time.perf_counter() - t0
    key = {"plan": p.source, "steps": [[s.block, s.params] for s in p.steps], "taps": taps,
           "lanes": True} | ({"csr": "axi4-lite"} if regmap is not None else {})
    bdir, build_s = cosim.build_sources("pipeline-lanes", key, sim, {"pipeline.v": dut},
                                        top="pipeline")
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    raw, steady = driver_tables(case)
    np.save(rundir / "raw.npy", raw.astype(np.int32))
    if steady is not None:            # the lanes on their trained taps from steady[0] on
        np.save(rundir / "steady.npy", steady[2].astype(np.int32))
    n_out = int(np.prod(design.output_shape(p))) // design.out_ppc(p)
    if p.links is not None:             # the output beats are the links' words
        n_out = design.link_word_count(p)
    job = {"word_ps": int(word_ns * 1000), "proc_ps": int(proc_ns * 1000),
           "settings": settings, "word_bits": case.word_bits, "word_cycles": case.cycles,
           "n_out": n_out, "drain": 2000,
           "max_cycles": math.ceil(case.cycles * word_ns / proc_ns) + 100_000,
           "taps": [f"tap{k}_{name}" for k, (name, _, _) in enumerate(tap_shapes)],
           "ready": ready, "status": [name for name, _ in status_ports(ax)
                                      if not name.startswith(BUS_PREFIXES)],
           "retrains": list(case.retrains), "track": case.track,
           "steady": None if steady is None else {"k0": steady[0], "taps": steady[1]}}
    if p.links is not None:
        from tdicam.model.tlk2711 import IDLE
        job["links"] = {"links": p.links.links, "link_ps": round(1e6 / p.links.clock_mhz),
                        "idle": IDLE, "padded": link_check.PADDED}
    if regmap is not None:
        job.update(_bus_job(regmap, ready, rundir))
    (rundir / "job.json").write_text(json.dumps(job))
    res, wall, cpu = _run_tb(bdir, sim, "system_lanes_tb", rundir, [], "result.json",
                             "the pipeline from the lanes", top="pipeline")
    if res.get("steady_miss"):
        k, i, t, want = res["steady_miss"]
        raise TdicamError(f"the lanes' co-simulation: lane {i} sampled at tap {t} at word "
                          f"clock {k}, after its training to tap {want} (the golden "
                          f"receiver's); the steady lane table holds the trained taps only")
    from tdicam.beats import Beats

    def beats(rows, bits, count, stride):
        mask = (1 << bits) - 1
        data_ = [[(int(d) >> (e * stride)) & mask for e in range(count)] for _, _, d, _ in rows]
        return Beats(np.asarray(data_, np.uint64).reshape(len(rows), count),
                     [r[0] for r in rows], [r[1] for r in rows]), \
            np.asarray([r[3] for r in rows], np.int64)
    ob, oc, opad, _ = ax._out if p.links is None else \
        (18, p.links.links, link_check.PADDED, None)        # the links' words
    got = {"out": beats(res["beats"], ob, oc, opad)[0]}
    listed = []
    for k, (name, b, c) in enumerate(tap_shapes):
        bt, cyc = beats(res["taps"][k], b, c, b)
        if k == 0 and p.lanes > 1:
            # the front's tap carries every channel (pixel-major); the golden chain has
            # one array a channel
            listed += [(Beats(bt.data[:, j::p.lanes], bt.first, bt.last), cyc)
                       for j in range(p.lanes)]
        else:
            listed.append((bt, cyc))
    got.update(enumerate(listed))
    from tdicam.model import lvds_front
    info = {"cycles": res["cycles"], "timeout": res["timeout"], "status": res["status"],
            "startup": {**res["startup"], "word_clock_ns": word_ns, "proc_clock_ns": proc_ns,
                        "first_frame_sent": case.segment_starts[0]},
            "front": {"frame_status": res["frame_status"], "retrains": len(case.retrains),
                      "frames_sent": len(case.frames[0]), "died_word": died,
                      "untrained": lvds_front.untrained_lanes(
                          [ln if ln.change_at is None else replace(ln, change_at=None,
                                                                   after=None)
                           for ln in lanes], prm["word_bits"], case.link.train_word,
                          n_check=case.n_check, settle=case.settle),
                      "eyes_golden": case.golden_run().final if case.walk else None,
                      "trained_taps": [next((ev[3] for ev in r.events if ev[1]), None)
                                       for r in case.golden_run().trainings[-1]],
                      "corrections": res.get("corrections"),
                      "drift_words": next((ln.drift_words for ln in lanes if ln.drift_taps),
                                          None),
                      "corrections_golden": _corrections(case) if case.track else None},
            **({"registers": res["registers"], "irq": res["irq"]} if regmap is not None
               else {}),
            "build_seconds": build_s, "elaborate_seconds": elab, "run_seconds": wall,
            "run_cpu_seconds": cpu, "rundir": str(rundir),
            "input_beats": 0, "build_dir": str(bdir)}
    if not keep:
        shutil.rmtree(rundir, ignore_errors=True)
    return got, info


def _bus_job(regmap, ready, rundir):
    """The ``job.json`` keys of a lane co-simulation through the control bus
    (:mod:`tdicam.simtb.lanes_bus`): the driver (written into ``rundir``), the interrupt
    enabled for the lanes' fault (``lvds.lane_error``), the start-up registers watched, the
    ports the registers stand for (every status port of the loose-port top) and ``status``,
    the top's status ports and those."""
    from tdicam.chain import registers
    files = registers.write_files(regmap, rundir)
    faults = [f"{r.block}.{r.name}" for r in regmap.faults]
    by_port = {r.port: f"{r.block}.{r.name}" for r in regmap.registers if r.port}
    watch = {"lanes_trained": "lvds.trained", "frames_released": "lvds.releasing"}
    watch.update({f"{name}_done": by_port[name] for name in ready})
    return {"csr": {"driver": files["driver"], "watch": watch,
                    "irq_enable": 1 << faults.index("lvds.lane_error"),
                    "ports": {v: k for k, v in by_port.items() if not
                              regmap.get(*v.split(".")).access == "rw"}}}


def beats_differ(got, exp):
    """Per beat of the common length of two :class:`~tdicam.beats.Beats`: True where the
    data or a frame marker (first, last) differs."""
    n = min(len(got), len(exp))
    return (got.data[:n] != exp.data[:n]).any(axis=1) | (got.first[:n] != exp.first[:n]) \
        | (got.last[:n] != exp.last[:n])


def _first_pixel(shape, d, got, exp, ppc):
    """Beat ``d`` (the first that differs) as its first differing pixel: beat, frame, line,
    column, expected and received value (None where a beat is missing or extra)."""
    _, rows, w = shape
    e = 0
    if d < len(got) and d < len(exp):
        diff = got.data[d] != exp.data[d]
        e = int(np.argmax(diff)) if diff.any() else 0
    px = d * ppc + e
    return {"beat": d, "frame": px // (rows * w), "line": (px // w) % rows,
            "column": px % w,
            "expected": int(exp.data[d, e]) if d < len(exp) else None,
            "received": int(got.data[d, e]) if d < len(got) else None}


def _first_diff(got, exp):
    """Index of the first differing beat (or of the first missing/extra one), or None."""
    n = min(len(got), len(exp))
    bad = beats_differ(got, exp)
    if bad.any():
        return int(np.argmax(bad))
    return None if len(got) == len(exp) else n


def cosimulate(p, data, sim="verilator", *, gold=None, corrupt=None, wave_dir=None, seed=1,
               idle=0.0, backpressure=0.0, front=None, ecp5=False, csr=False):
    """Run ``data`` through the generated top and compare every tap with the golden chain.

    Parameters
    ----------
    gold : list or None
        :func:`tdicam.chain.design.golden` of ``(p, data)`` if already computed.
    corrupt : callable(list of (name, ndarray)) or None
        Alters the golden stages before the comparison (to show the check can fail).
    wave_dir : path or None
        Where the waveform of a mismatch is written (``<wave_dir>/pipeline_mismatch.fst``, FST: GTKWave, Surfer);
        None: no waveform.
    ecp5 : bool
        Run the chain's ECP5 synthesis top (:func:`run_top`).
    csr : bool
        A top from the lanes with the control bus, the front's status read through it
        (:func:`run_top`): ``registers`` (every register at the end) and ``irq`` ([word
        clock, ``irq_status``, ``lvds.lane_error``] of each interrupt served) in the result.

    Returns
    -------
    dict
        ``pixels_compared`` (output pixels), ``mismatches`` (output beats that differ, plus
        missing or extra ones), ``input_pixels``, ``build_seconds``, ``run_seconds``,
        ``input_pixels_per_s`` (run time only), ``cycles``, ``taps`` (per stage: beats and
        mismatches; beats of the stage's pixels per clock), ``status_outputs`` (every status output of
        the top and its parts' models at the end of the run, {port: value}) and, on a
        mismatch, ``first_mismatch`` (block,
        tap, beat, frame, line, column of its first differing pixel,
        expected, received, cycle) and ``waveform``. A top that ends in the output links
        (``p.links``): ``mismatches`` counts the link words (IDLEs dropped, every link's
        word of a slot one beat) that differ from :func:`tdicam.chain.design.link_words`
        of the golden output (plus missing or extra ones), ``words_compared`` the words of
        every link, ``pixels_compared`` the kept images' pixels, ``link_words`` the words
        received, ``(links, n)`` uint32 (:func:`tdicam.model.tlk2711.decode` reads them).
    """
    from tdicam.chain import design
    from tdicam.beats import frames_to_beats
    dies = (front or {}).get("dies")
    if dies is None:
        gold = design.golden(p, data) if gold is None else [list(g) for g in gold]
        if corrupt is not None:
            corrupt(gold)
    got, info = run_top(p, data, sim, seed=seed, idle=idle, backpressure=backpressure,
                        front=front, ecp5=ecp5, csr=csr)
    lane_fault = None
    if "front" in info:
        # what the front delivered: the golden front's frames (a dead lane's cut frame as
        # it measured), the golden chain on them
        delivered, lane_fault = _delivered(p, data, got, info["front"], dies)
        if info["front"]["drift_words"] is not None:
            lane_fault["drift_words"] = int(info["front"]["drift_words"])
        if info["front"]["corrections_golden"] is not None:
            lane_fault["corrections"] = _tracking(info["front"], lane_fault["lanes"])
            lane_fault["problems"] += lane_fault["corrections"]["problems"]
        if info["front"]["eyes_golden"] is not None:
            lane_fault["eyes"] = _eyes(p, info, front)
            lane_fault["problems"] += [e["text"] for e in lane_fault["eyes"]
                                       if not e["agree"]]
        if dies is not None:
            gold = design.golden(p, delivered)
            if corrupt is not None:
                corrupt(gold)
    rep = {"simulator": sim, "blocks": [s.block for s in p.steps],
           "input_pixels": int(sum(a.size for lane in data.lane_arrays(p) for a in lane)),
           "cycles": int(info["cycles"]), "timeout": bool(info["timeout"]),
           "build_seconds": info["build_seconds"], "run_seconds": info["run_seconds"],
           "taps": []}
    if info.get("status"):
        rep["status_outputs"] = info["status"]
    if info.get("startup"):
        rep["startup"] = info["startup"]
    if lane_fault is not None:
        rep["lanes"] = lane_fault
    rep.update({k: info[k] for k in ("registers", "irq") if k in info})
    rep["input_pixels_per_s"] = rep["input_pixels"] / max(info["run_seconds"], 1e-9)
    first = None
    ppcs = {s.block: design.step_ppc(s) for s in p.steps}
    for k, (name, block, arr) in enumerate(gold):
        ppc = ppcs[block]
        exp = frames_to_beats(arr, ppc=ppc)
        g, cyc = got[k]
        d = _first_diff(g, exp)
        n = min(len(g), len(exp))
        bad = int(((g.data[:n] != exp.data[:n]).any(axis=1)).sum()) + abs(len(g) - len(exp))
        rep["taps"].append({"tap": name, "beats": len(exp), "pixels": len(exp) * ppc,
                            "received": len(g), "mismatches": bad})
        if d is not None and first is None:
            first = _first_pixel(arr.shape, d, g, exp, ppc)
            cycle = int(cyc[min(d, len(cyc) - 1)]) if len(cyc) else int(info["cycles"])
            first.update({"block": block, "tap": name, "cycle": cycle})
    out = got["out"]
    if p.links is None:
        exp_out = frames_to_beats(gold[-1][2], ppc=design.out_ppc(p))
    else:
        exp_out = link_check.golden_beats(design.link_words(p, gold))
        rep["link_words"] = out.data.T.astype(np.uint32)
    d = _first_diff(out, exp_out)
    n = min(len(out), len(exp_out))
    rep["pixels_compared"] = int(n) * int(out.data.shape[1])
    if p.links is not None:
        rep["words_compared"] = rep.pop("pixels_compared")
        rep["pixels_compared"] = int(sum(im.size for im in link_check.kept_images(p, gold)))
    rep["mismatches"] = int(((out.data[:n] != exp_out.data[:n]).any(axis=1)
                             | (out.first[:n] != exp_out.first[:n])
                             | (out.last[:n] != exp_out.last[:n])).sum()) \
        + abs(len(out) - len(exp_out))
    problems = [] if lane_fault is None else lane_fault["problems"]
    if problems:              # the front's status is part of the result: never silent
        rep["mismatches"] += len(problems)
    if first is not None:
        rep["first_mismatch"] = first
        rep["message"] = (f"first mismatch in block {first['block']} (tap {first['tap']}): "
                          f"frame {first['frame']}, line {first['line']}, column "
                          f"{first['column']}: expected {first['expected']}, received "
                          f"{first['received']} (cycle {first['cycle']})")
        if wave_dir is not None and front is None:
            rep["waveform"] = _waveform(p, data, first["cycle"], wave_dir, seed, idle,
                                        backpressure)
            rep["message"] += f"; waveform {rep['waveform']}"
    elif d is not None and p.links is not None:
        rep["message"] = (f"the output links' word {d} (IDLEs not counted) differs from "
                          f"the golden chain's through the frame selector and "
                          f"model.tlk2711: received "
                          f"{[hex(int(x)) for x in out.data[d]] if d < len(out) else None}, "
                          f"expected "
                          f"{[hex(int(x)) for x in exp_out.data[d]] if d < len(exp_out) else None}")
    elif d is not None:
        rep["message"] = f"output beat {d} differs"
    elif problems:
        rep["message"] = "the front's status differs from its golden model: " + \
            "; ".join(problems)
    else:
        rep["message"] = "match"
    return rep


def _tracking(front, n):
    """The tracker's corrections the testbench saw beside the golden model's: per lane the
    list of ``(effect word, new tap)``, and ``problems`` when they differ."""
    got = sorted(tuple(c) for c in front["corrections"] or [])
    want = front["corrections_golden"]
    per = {i: [(e, t) for e, lane, t in got if lane == i] for i in range(n)}
    probs = [] if got == want else [
        f"eye tracking: corrections {got[:4]} differ from the golden model's {want[:4]}"]
    return {"per_lane": per, "count": len(got), "problems": probs}


def _drift(probe, lanes, taps, frames):
    """``lanes`` with the scene's drift (``taps`` a lane over ``frames`` frames as the
    sensor sends them, from the first data word of ``probe``, the case without it)."""
    from dataclasses import replace
    if not taps or not any(taps):
        return lanes
    nr = np.asarray(probe.frames[0]).shape[1]
    words = frames * nr * (probe.p + 2)
    return [replace(ln, drift_taps=float(t), drift_from=probe.segment_starts[0],
                    drift_words=words) if t else ln for ln, t in zip(lanes, taps)]


def _corrections(case):
    """The golden model's corrections of the run: ``(effect word, lane, new tap)``."""
    from tdicam.model import lvds, lvds_track
    g = case.golden_run()
    return lvds_track.shown(sorted((eff, i, t) for tr in g.trainings for i, r in enumerate(tr)
                                   for _, t, eff in r.corrections), case.cycles,
                            lvds.LINK_LATENCY)


def _eyes(p, info, front):
    """The lanes' training as the front published it beside the golden link model's
    (:func:`tdicam.cosim.lvds_front.lane_eyes`)."""
    from tdicam import blocks
    from tdicam.cosim.lvds_front import lane_eyes
    prm = blocks.get("lvds").resolve(p.steps[0].params)
    lanes = front.get("lanes") or ideal_lanes(prm["lanes"])
    return lane_eyes(info["front"]["eyes_golden"], info["status"], prm["word_bits"],
                     prefix="lvds_", tap_ps=lanes[0].tap_ps, eye_taps=front.get("eye_taps"),
                     min_run=prm["min_run"], trained=info["front"]["trained_taps"])


def _delivered(p, data, got, front, dies):
    """The frames the sensor's front end should have delivered and the lanes' report.

    The golden front (:mod:`tdicam.model.lvds_front`) on the frames the sensor sent: the
    lanes that did not train (``front["untrained"]``, from the link model) read 0; with
    ``dies = (lane, frame)`` the frame cut by the death
    (:func:`~tdicam.model.lvds_front.cut_frame`, its fill point measured on the front's
    output and checked to lie within two lines of the death), :data:`HELD` frames dropped, the dead lane's columns 0 after the
    retrain. Returns (:class:`~tdicam.chain.design.SceneData` of the delivered frames,
    report: lane numbers, frames sent/released/dropped/affected, retrains, the expected and
    seen frame status, ``problems``)."""
    from tdicam import blocks
    from tdicam.blocks.steps import SceneData
    from tdicam.cosim.lvds_front import cds_kinds
    from tdicam.model import lvds_front
    prm = blocks.get("lvds").resolve(p.steps[0].params)
    L, w = prm["lanes_per_gain"], prm["word_bits"]
    sent = [lane[0] for lane in data.lane_arrays(p)]
    nf = len(sent[0])
    kinds = cds_kinds(nf) if p.reset_frames else None
    bad = list(front["untrained"])
    rep = {"lanes": p.lanes * L, "untrained": bad, "frames_sent": nf,
           "retrains": front["retrains"], "problems": []}
    if dies is None:
        px, _ = lvds_front.receive(sent, bad, L, w)
        status, dropped = [lvds_front.lane_mask(bad)] * nf, 0
    else:
        lane, f = dies
        healthy = lvds_front.receive(sent, bad, L, w)[0][:, f]
        seen, size = [], p.stages * p.width
        for k in range(p.lanes):
            a = got[k][0].data.reshape(-1)
            if a.size % size:
                rep["problems"].append(f"channel {k}: the front delivered {a.size} pixels, "
                                       f"not whole {p.stages} x {p.width} frames")
            seen.append(a[:a.size // size * size].reshape(-1, p.stages, p.width))
        if any(len(a) <= f for a in seen):
            observed = np.zeros_like(healthy)
            rep["problems"].append(f"frame {f} (cut by lane {lane}'s death) not delivered")
        else:
            observed = np.stack([a[f] for a in seen]).astype(np.int64)
        cut, fill = lvds_front.cut_frame(healthy, observed, L, lane, front["died_word"])
        if fill > front["died_word"] + 2 * lvds_front.line_words(p.width, L):
            rep["problems"].append(f"frame {f}: filled from word {fill}, more than two "
                                   f"lines after lane {lane} died (word "
                                   f"{front['died_word']})")
        px, kinds, status, dropped = lvds_front.lane_death(
            sent, L, w, bad_lanes=bad, lane=lane, frame=f, cut=cut, kinds=kinds,
            held=HELD, pairs=p.reset_frames)
        rep.update({"died": lane, "died_in_frame": f, "died_at_word": front["died_word"],
                    "filled_from_word": fill})
    rep.update({"frames_released": len(status), "frames_dropped": dropped,
                "frames_affected": sum(1 for s in status if s),
                "frame_status": front["frame_status"], "expected_frame_status": status})
    if front["frame_status"] != status:
        rep["problems"].append(f"frame status {front['frame_status']}, expected {status}")
    if p.reset_frames:
        delivered = SceneData([a[1::2] for a in px], [a[0::2] for a in px], data.coeffs)
    else:
        delivered = SceneData(list(px), data.reset, data.coeffs)
    return delivered, rep


def _waveform(p, data, cycle, wave_dir, seed, idle, backpressure):
    """Re-run on Icarus (same stimulus, same idle/backpressure seed: the same cycles) up to
    the window's end, dumping cycles ``cycle +- WAVE_WINDOW`` to an FST file."""
    from pathlib import Path
    _, info = run_top(p, data, "icarus", wave=wave_window(cycle), seed=seed, idle=idle,
                        backpressure=backpressure)
    return keep_wave(Path(info["rundir"]) / "wave.fst",
                     Path(wave_dir) / "pipeline_mismatch.fst", "the pipeline")
