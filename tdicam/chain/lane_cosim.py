"""The sensor lanes' side of a pipeline co-simulation (:mod:`tdicam.chain.cosim`): a top
whose input is the sensor's LVDS lanes (``[sensor.lvds]``) run from the lanes' words
(:func:`run_lanes`), the lanes of a scene (:func:`lanes_of`), a lane's death mid-run
(:func:`check_lane_death`), and what the front end should have
delivered, the lanes' eyes and the tracker's corrections beside the golden models
(:func:`front_delivered`, :func:`eye_rows`, :func:`tracking_rows`).
"""

from __future__ import annotations

import json
import os
import shutil
import time

import numpy as np

from tdicam.chain import link_check
from tdicam.chain.tbrun import bus_job, run_tb, status_ports
from tdicam.errors import TdicamError

__all__ = ["PROC_NS", "HELD", "lanes_of", "ideal_lanes", "check_lane_death",
           "run_lanes", "front_delivered", "eye_rows", "tracking_rows"]

#: The processing clock of a co-simulation from the lanes (ns): 100 MHz, the MIG's clock of
#: Ning et al. 2019's camera.
PROC_NS = 10.0

#: Frames the sensor sends after a lane's death before the camera's controller retrains the
#: lanes (``[run.rtl].lane_dies``): the front holds them (dropped, counted).
HELD = 2


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


def run_lanes(p, data, sim, ax, taps, front, keep, t0):
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
        job.update(bus_job(regmap, ready, rundir))
    (rundir / "job.json").write_text(json.dumps(job))
    res, wall, cpu = run_tb(bdir, sim, "system_lanes_tb", rundir, [], "result.json",
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


def tracking_rows(front, n):
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


def eye_rows(p, info, front):
    """The lanes' training as the front published it beside the golden link model's
    (:func:`tdicam.cosim.lvds_front.lane_eyes`)."""
    from tdicam import blocks
    from tdicam.cosim.lvds_front import lane_eyes
    prm = blocks.get("lvds").resolve(p.steps[0].params)
    lanes = front.get("lanes") or ideal_lanes(prm["lanes"])
    return lane_eyes(info["front"]["eyes_golden"], info["status"], prm["word_bits"],
                     prefix="lvds_", tap_ps=lanes[0].tap_ps, eye_taps=front.get("eye_taps"),
                     min_run=prm["min_run"], trained=info["front"]["trained_taps"])


def front_delivered(p, data, got, front, dies):
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
