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
one, dumped to an FST file. A top whose input is the sensor's lanes runs through
:mod:`tdicam.chain.lane_cosim` (the lanes' words, a lane's death, the front's report).
"""

from __future__ import annotations

import json
import os
import shutil
import time

import numpy as np

from tdicam.chain import link_check
from tdicam.chain.tbrun import run_tb, status_ports
from tdicam.blocks.lvds import OVERFLOW
from tdicam.hdl.output_links import FRAME_BUFFER
from tdicam.chain.lane_cosim import (check_lane_death, eye_rows, front_delivered, lanes_of,
                                     run_lanes, tracking_rows)
from tdicam.cosim import WAVE_WINDOW, keep_wave, wave_window
from tdicam.errors import TdicamError

__all__ = ["cosim_scene", "check_rtl_design", "scene_data", "cosimulate", "run_top",
           "beats_differ", "WAVE_WINDOW",
           "system_figures", "lane_fault_cut", "OVERFLOW", "lead_with_overflow",
           "status_problems", "frame_buffer_traffic"]

# OVERFLOW (tdicam.blocks.lvds): the front's status output that says a lane word was lost in
# its crossing FIFO, named first in a failing run's message (the mismatches that follow are
# its consequence).


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


def system_figures(p, rep):
    """What the co-simulated camera saw, from its status outputs: each block's
    :attr:`tdicam.blocks.Use.measured` figures (the calibration load, the DDR traffic) for a
    :func:`cosimulate` report ``rep`` of plan ``p``; [] when no block has any."""
    from tdicam.chain import design
    uses = design.uses()
    out = [r for s in p.steps if uses[s.block].measured is not None
           for r in uses[s.block].measured(s, rep.get("status_outputs", {}), {
               "cycles": rep["cycles"], "rows": p.stages, "width": p.width,
               "lanes": rep.get("lanes")})]
    fb = frame_buffer_traffic(rep.get("status_outputs", {}))
    if fb is not None:
        out.append({"name": "frame buffer DDR traffic", "value": fb["writes"] + fb["reads"],
                    "unit": "words", "stall_cycles": fb["stalls"], "ok": not fb["error"],
                    "text": f"the output links' frame buffer ({p.links.buffer_rows} rows): "
                            f"{fb['writes']} words written, {fb['reads']} read back, "
                            f"{fb['stalls']} cycles waited on its MIG model"
                            + (", MIG model ERROR" if fb["error"] else "")})
    return out


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
    (:func:`run_lanes`; ``front``: its ``lanes`` and ``word_ns``); ``idle`` and
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
        return run_lanes(p, data, sim, ax, taps, front or {}, keep, t0)
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
    info, wall, cpu = run_tb(bdir, sim, None if standalone else "stream_tb", rundir, plus,
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
        delivered, lane_fault = front_delivered(p, data, got, info["front"], dies)
        if info["front"]["drift_words"] is not None:
            lane_fault["drift_words"] = int(info["front"]["drift_words"])
        if info["front"]["corrections_golden"] is not None:
            lane_fault["corrections"] = tracking_rows(info["front"], lane_fault["lanes"])
            lane_fault["problems"] += lane_fault["corrections"]["problems"]
        if info["front"]["eyes_golden"] is not None:
            lane_fault["eyes"] = eye_rows(p, info, front)
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
    problems, count, fb = status_problems(
        [] if lane_fault is None else lane_fault["problems"], rep.get("status_outputs", {}))
    if fb is not None:
        rep["frame_buffer"] = fb
    # the front's status and the buffer's model are part of the result: never silent
    rep["mismatches"] += count
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
        rep["message"] = "; ".join(problems)
    else:
        rep["message"] = "match"
    rep["message"] = lead_with_overflow(rep)
    return rep


def status_problems(front, status):
    """``(messages, count, frame_buffer)`` of what a run's status says went wrong beside its
    taps: the front's problems against its golden model (``front``, each counted) in one
    message, and the output links' frame buffer's MIG model error (status
    ``frame_buffer_ddr_error``) in another; ``frame_buffer`` :func:`frame_buffer_traffic`."""
    messages = [] if not front else \
        ["the front's status differs from its golden model: " + "; ".join(front)]
    fb = frame_buffer_traffic(status)
    if fb is not None and fb["error"]:
        messages.append(f"the frame buffer's MIG model flagged an error ({FRAME_BUFFER}_ddr_error"
                        f" = 1: an address outside its memory or a malformed command)")
    return messages, len(front) + int(bool(fb and fb["error"])), fb


def frame_buffer_traffic(status):
    """The output links' DDR frame buffer as its MIG model saw it (status outputs
    ``frame_buffer_ddr_*``): ``{"writes", "reads", "stalls", "error"}`` (256-bit words, the
    cycles the buffer waited on the model), or None without a frame buffer."""
    key = f"{FRAME_BUFFER}_ddr_"
    if f"{key}writes" not in status:
        return None
    return {n: int(status.get(key + n, 0)) for n in ("writes", "reads", "stalls", "error")}


def lead_with_overflow(rep):
    """``rep["message"]``, led by the front's lost words when its status shows them.

    A lane cannot wait: when the top does not take its words as fast as they come, the
    front's crossing FIFO overflows (status output :data:`OVERFLOW` = 1) and every mismatch
    after it follows from that, so a failing run names the cause first. A matching run, or
    one whose status has no overflow, keeps its message as it is.
    """
    msg = rep["message"]
    if msg != "match" and rep.get("status_outputs", {}).get(OVERFLOW):
        return (f"the front's crossing FIFO overflowed ({OVERFLOW} = 1: the top did not "
                f"take the lanes' words as fast as they came, and lanes cannot wait); "
                + msg)
    return msg


def _waveform(p, data, cycle, wave_dir, seed, idle, backpressure):
    """Re-run on Icarus (same stimulus, same idle/backpressure seed: the same cycles) up to
    the window's end, dumping cycles ``cycle +- WAVE_WINDOW`` to an FST file."""
    from pathlib import Path
    _, info = run_top(p, data, "icarus", wave=wave_window(cycle), seed=seed, idle=idle,
                        backpressure=backpressure)
    return keep_wave(Path(info["rundir"]) / "wave.fst",
                     Path(wave_dir) / "pipeline_mismatch.fst", "the pipeline")
