"""Block ``lvds``: LVDS receiver with bit training, bitslip and lane deskew (Ning et al. 2019 §4.1).

Not a video stream: golden cases describe a link (per-lane analogue parameters, the
sensor's schedule, retrain requests) and store the golden status events and final status;
``cocotb_tests/test_lvds.py`` co-simulates them with :mod:`tdicam.cosim.lvds`.
``--phy xilinx7`` / ``--phy ecp5`` generate the receiver behind the 7-series
(IBUFDS/IDELAYE2/ISERDESE2) or ECP5 (DELAYF/IDDRX2F/ECLKSYNCB/CLKDIVF) input primitives
(:data:`tdicam.hdl.lvds_phy.PHYS`) instead of the generic core.

As the camera's front end (``--lanes-per-gain`` > 0, and in a scene's pipeline when the scene
has a ``[sensor.lvds]`` section: :attr:`tdicam.blocks.Use.source`) the top is
:class:`tdicam.hdl.lvds_front.LvdsFront`: the receiver, the lane-to-pixel reordering and the
crossing into the processing clock, its output the pipeline's pixel stream
(:mod:`tdicam.model.lvds_front`).
"""

import numpy as np

from tdicam.errors import TdicamError
from tdicam.hdl.lvds_phy import PHYS
from tdicam.hdl.lvds_front import WORD_DOMAIN
from tdicam.model import lvds
from tdicam.blocks import PPC_PARAM, Bench, SynthRef, Use
from tdicam.blocks import Block, Case, Param
from tdicam.blocks.steps import Step
from tdicam.model import lvds_front

# ---- top
#: The tracker's probe margin (taps) of a scene with [sensor.lvds].tracking: the trained tap
#: sits pick - 1 = 4 taps above its run's start.
TRACK_MARGIN = 4

#: Lanes the front end takes (both gains together) and the depths of its crossing FIFO.
MAX_LANES = 128
FIFO_DEPTHS = (4, 8, 16, 32, 64, 128, 256)

__all__ = ["BLOCK", "link_from_arrays", "link_arrays", "golden_arrays", "case_link", "OVERFLOW"]

#: The front's status output (the top's port: stage ``lvds``, the front's ``fifo_overflow``)
#: that says a lane word was lost in its crossing FIFO.
OVERFLOW = "lvds_fifo_overflow"


def _top(*, lanes, word_bits, settle, min_run, pick, deskew_depth, phy, lanes_per_gain=0,
         columns=0, bits=12, ppc=1, fifo_depth=16, pairs=0, eye=0, track=0):
    kw = dict(word_bits=word_bits, settle=settle, min_run=min_run, pick=pick,
              deskew_depth=deskew_depth, eye=bool(eye))
    if lanes_per_gain:
        from tdicam.hdl.lvds_front import LvdsFront
        return LvdsFront(lanes_per_gain=lanes_per_gain, gains=lanes // lanes_per_gain,
                         bits=bits, columns=columns, ppc=ppc, fifo_depth=fifo_depth, phy=phy,
                         pairs=bool(pairs), track=track, **kw)
    if track:
        if phy == "ecp5":
            raise TdicamError(f"--track = {track} needs --phy none or xilinx7 (12-bit words): "
                              f"the ecp5 PHY has no monitor sampler")
        kw["track"] = track
    return PHYS[phy](lanes=lanes, **kw)


def _check(p):
    if p["pick"] > p["min_run"]:
        raise TdicamError(f"--pick = {p['pick']} must not exceed --min-run = {p['min_run']}")
    lpg = p["lanes_per_gain"]
    if lpg:
        if p["lanes"] not in (lpg, 2 * lpg):
            raise TdicamError(f"--lanes = {p['lanes']} must be --lanes-per-gain = {lpg} or "
                              f"twice it (one or two gain channels)")
        if p["columns"] < lpg:
            raise TdicamError(f"--columns = {p['columns']} must be at least --lanes-per-gain "
                              f"= {lpg} (every lane carries a column)")
        if lpg % p["ppc"]:
            raise TdicamError(f"--ppc = {p['ppc']} does not divide --lanes-per-gain = {lpg}")
        rem = lvds_front.last_word_columns(p["columns"], lpg)
        if rem % p["ppc"]:
            raise TdicamError(f"--ppc = {p['ppc']} does not divide the {rem} columns of a "
                              f"line's last word clock (--columns = {p['columns']} on "
                              f"--lanes-per-gain = {lpg}; the lanes above pad that slot)")
        if p["bits"] > p["word_bits"]:
            raise TdicamError(f"--bits = {p['bits']} exceeds --word-bits = {p['word_bits']}")


# ---- cases
def link_arrays(link, *, cycles, retrains=(), n_check=16):
    """Arrays describing a link run (what a golden case stores as input)."""
    lanes = link.lanes
    after = [ln.after if ln.after is not None else ln for ln in lanes]
    f = lambda xs, a: np.array([getattr(x, a) for x in xs], np.float64)  # noqa: E731
    return {
        "skew_ps": f(lanes, "skew_ps"), "eye_ps": f(lanes, "eye_ps"),
        "jitter_ps": f(lanes, "jitter_ps"), "tap_ps": f(lanes, "tap_ps"),
        "seed": np.array([ln.seed for ln in lanes], np.int64),
        "change_at": np.array([-1 if ln.change_at is None else ln.change_at for ln in lanes],
                              np.int64),
        "after_skew_ps": f(after, "skew_ps"), "after_eye_ps": f(after, "eye_ps"),
        "after_jitter_ps": f(after, "jitter_ps"), "after_tap_ps": f(after, "tap_ps"),
        "link": np.array([link.word_bits, link.train_word, link.sync_word, link.line_words,
                          cycles, n_check], np.int64),
        "schedule": np.array([(n, int(m == "data")) for n, m in link.schedule],
                             np.int64).reshape(-1, 2),
        "retrains": np.array(sorted(retrains), np.int64),
    }


def link_from_arrays(a):
    """(link, cycles, retrains, n_check) from :func:`link_arrays` output."""
    w, train, sync, line, cycles, n_check = (int(x) for x in a["link"])
    lanes = []
    for i in range(len(a["skew_ps"])):
        after = None
        if a["change_at"][i] >= 0:
            after = lvds.Lane(skew_ps=float(a["after_skew_ps"][i]),
                              eye_ps=float(a["after_eye_ps"][i]),
                              jitter_ps=float(a["after_jitter_ps"][i]),
                              tap_ps=float(a["after_tap_ps"][i]))
        lanes.append(lvds.Lane(
            skew_ps=float(a["skew_ps"][i]), eye_ps=float(a["eye_ps"][i]),
            jitter_ps=float(a["jitter_ps"][i]), tap_ps=float(a["tap_ps"][i]),
            seed=int(a["seed"][i]),
            change_at=None if after is None else int(a["change_at"][i]), after=after))
    sched = tuple((int(n), "data" if m else "train") for n, m in a["schedule"])
    link = lvds.Link(lanes, word_bits=w, train_word=train, sync_word=sync, line_words=line,
                     schedule=sched)
    return link, cycles, tuple(int(k) for k in a["retrains"]), n_check


def golden_arrays(link, params, *, cycles, retrains=(), n_check=16):
    """Golden run of ``link`` with block ``params``: events and final status as arrays."""
    g = lvds.run(link, cycles=cycles, retrains=retrains, n_check=n_check,
                 settle=params["settle"], min_run=params["min_run"], pick=params["pick"])
    fin = g.final
    col = lambda key, dt: np.array([f[key] for f in fin], dt)  # noqa: E731
    return {
        "events": np.array(g.events, np.int64).reshape(-1, 7),
        "tap": col("tap", np.uint8), "slip": col("slip", np.uint8),
        "locked": col("locked", np.uint8), "error": col("error", np.uint8),
        "run": col("run", np.uint8), "scan": col("scan", np.uint32),
    }


def _data_start(w, n_check, settle):
    return lvds.training_words(w, n_check, settle) + 16


def _case(build):
    def make(params, rng):
        link, cycles, retrains, n_check = build(params, rng)
        out = link_arrays(link, cycles=cycles, retrains=retrains, n_check=n_check)
        out.update(golden_arrays(link, params, cycles=cycles, retrains=retrains,
                                 n_check=n_check))
        return out
    return make


def _random(n, *, n_check=16, words=400, max_word_delay=1):
    def build(params, rng):
        w = params["word_bits"]
        lanes = [lvds.random_lane(rng, max_word_delay=max_word_delay, word_bits=w)
                 for _ in range(n)]
        nd = _data_start(w, n_check, params["settle"])
        link = lvds.Link(lanes, word_bits=w, line_words=32, schedule=((nd, "data"),))
        return link, nd + words, (), n_check
    return build


def _windows(params, rng):
    """Hand-made eyes: clipped windows, two windows, a tie, too narrow, dead, flickering."""
    w = params["word_bits"]
    tap = lvds.PAPER_TAP_PS
    ui = 1e6 / 300
    lane = lvds.Lane

    def at(first_tap, eye_taps, **kw):
        # eye starting just after tap `first_tap - 1`: phase u of tap t decreases with t
        eye = eye_taps * tap
        hi = (ui + eye) / 2
        skew = (-(hi - 1.0) - (first_tap - 1) * tap) % ui
        return lane(skew_ps=skew, eye_ps=eye, **kw)

    xt = lvds.XILINX_TAP_PS
    lanes = [
        lane(skew_ps=1515.0, eye_ps=20 * xt, tap_ps=xt, seed=1),  # clipped at tap 0 (12 taps)
        lane(skew_ps=2660.0, eye_ps=20 * xt, tap_ps=xt, seed=2),  # clipped at tap 31
        lane(skew_ps=910.0, eye_ps=9.6 * tap, seed=3),   # two 9-tap windows: tie, first wins
        lane(skew_ps=630.0, eye_ps=7.95 * tap, seed=4),  # 8-tap windows: error, no silent lock
        at(-3, 14.2, seed=5),                            # 11 + 14 taps: the widest wins
        lane(skew_ps=900.0, eye_ps=0.0, seed=6),                    # dead lane
        at(4, 15.0, jitter_ps=6 * tap, seed=7),                     # strong flicker: error
        at(6, 12.0, jitter_ps=2 * tap, seed=8),                     # mild flicker
        at(10, 20.0, seed=9),                                       # widest eye
    ]
    nd = _data_start(w, 8, params["settle"])
    link = lvds.Link(lanes, word_bits=w, line_words=16, schedule=((nd, "data"),))
    return link, nd + 300, (), 8


def _deskew(params, rng):
    """8 lanes, word delays 0..3 words on top of the bit skew: output must leave aligned."""
    w = params["word_bits"]
    ui = 1e6 / 300
    lanes = []
    for i in range(8):
        base = lvds.random_lane(rng, jitter=False, word_bits=w)
        eye = float(rng.uniform(14, 20)) * base.tap_ps
        lanes.append(lvds.Lane(skew_ps=base.skew_ps % ui + (i % 4) * w * ui, eye_ps=min(eye, ui),
                               tap_ps=base.tap_ps, seed=100 + i))
    nd = _data_start(w, 8, params["settle"])
    link = lvds.Link(lanes, word_bits=w, line_words=32, schedule=((nd, "data"),))
    return link, nd + 600, (), 8


def _retrain(params, rng):
    """Skew change after lock (error, then retrain recovers), a lane dying after lock, a lane
    dying during the bitslip search, a lane coming back to life at the retrain."""
    w = params["word_bits"]
    n_check, settle = 4, params["settle"]
    tw = lvds.training_words(w, n_check, settle)
    nd = tw + 16
    kr = nd + 300
    nd2 = kr + 1 + tw + 16
    p = lvds.step_words(n_check, settle)
    in_slip = lvds.N_TAPS * p + 1 + p // 2     # inside slip step 0
    lane = lvds.Lane
    lanes = [
        lane(skew_ps=700.0, eye_ps=2600.0, seed=11, change_at=nd + 120,
             after=lane(skew_ps=2400.0, eye_ps=2600.0)),              # skew jumps
        lane(skew_ps=1500.0, eye_ps=2500.0, jitter_ps=300.0, seed=12, change_at=nd + 77,
             after=lane(skew_ps=1500.0, eye_ps=0.0)),                 # dies after lock
        lane(skew_ps=300.0, eye_ps=2500.0, seed=13, change_at=in_slip,
             after=lane(skew_ps=300.0, eye_ps=0.0)),                  # dies in slip search
        lane(skew_ps=200.0, eye_ps=0.0, seed=14, change_at=kr - 40,
             after=lane(skew_ps=200.0, eye_ps=2800.0)),               # comes to life
        lane(skew_ps=4000.0, eye_ps=2900.0, jitter_ps=200.0, seed=15),  # steady
        lane(skew_ps=2500.0, eye_ps=2000.0, seed=16),                 # steady
    ]
    link = lvds.Link(lanes, word_bits=w, line_words=24,
                     schedule=((nd, "data"), (kr, "train"), (nd2, "data")))
    return link, nd2 + 200, (kr,), n_check


def case_link(arrays):
    return link_from_arrays(arrays)


# ---- chain
def _front_source(scene):
    return scene.sensor.lvds is not None


def _front_step(ctx):
    """The front end's step: the scene's ``[sensor.lvds]``, the chain's channels (two with a
    merging block; one without: the high-gain lanes only) and frame (rows = TDI stages),
    the crossing FIFO sized for the slowest processing clock the lane format allows and the
    worst DDR stall of the blocks behind it (``ctx.stall_cycles``;
    :func:`tdicam.model.lvds_front.fifo_depth`)."""
    lv = ctx.scene.sensor.lvds
    lpg, w = lv.lanes_per_gain, lv.word_bits
    lvds_front.check_geometry(ctx.width, ctx.m, lpg, w, ctx.bits,
                              key="[sensor.lvds].lanes_per_gain")
    # a word clock brings lpg columns of each channel (the width a multiple of ppc too, so
    # a line's last, padded word clock brings a multiple of ppc: lvds_front.last_word_columns)
    if lpg % ctx.ppc:
        raise TdicamError(f"pixels per clock (--ppc or [run.rtl].pixels_per_clock) = "
                          f"{ctx.ppc} does not divide [sensor.lvds].lanes_per_gain = {lpg}")
    word_mhz = lv.bit_rate_mbps / w
    slowest = lvds_front.min_proc_mhz(lpg, ctx.ppc, ctx.width, word_mhz)
    if lpg * ctx.lanes > MAX_LANES:
        raise TdicamError(f"[sensor.lvds].lanes_per_gain = {lpg} on {ctx.lanes} gains is "
                          f"{lpg * ctx.lanes} lanes; the front end takes at most {MAX_LANES} "
                          f"(lanes_per_gain <= {MAX_LANES // ctx.lanes})")
    depth = lvds_front.fifo_depth(lpg, ctx.ppc, ctx.width, word_mhz, slowest,
                                  stall_cycles=ctx.stall_cycles)
    if depth > FIFO_DEPTHS[-1]:
        bare = lvds_front.fifo_depth(lpg, ctx.ppc, ctx.width, word_mhz, slowest)
        raise TdicamError(
            f"the DDR's longest stall, {ctx.stall_cycles} processing clocks ([ddr]."
            f"refresh_cycles + [ddr].lat_hi), piles up words the sensor keeps sending: the "
            f"front's crossing FIFO would need {depth} entries ({bare} without the stall), "
            f"more than its {FIFO_DEPTHS[-1]}: lower [ddr].refresh_cycles or [ddr].lat_hi")
    params = {"lanes": lpg * ctx.lanes, "word_bits": w, "lanes_per_gain": lpg,
              "columns": ctx.width, "bits": ctx.bits, "fifo_depth": depth}
    if ctx.reset_frames:                 # reset/signal pairs: release from a reset frame
        params["pairs"] = 1
    if lv.eye_status:                    # [sensor.lvds].eye_status: the training published
        params["eye"] = 1
    if lv.tracking:                      # [sensor.lvds].tracking: the eyes followed
        params["track"] = TRACK_MARGIN
    ports = {"lane_raw": 0, "train_word": lv.train_word,
             "sync_word": lvds.default_sync_word(w), "n_check": 16, "frame_rows": ctx.m,
             "retrain": 0}
    return Step("lvds", params, ports, clocks={WORD_DOMAIN: word_mhz}), ctx.bits


def _front_hw(step, data, *, ecp5=False):
    """The front end as the chain's :class:`~tdicam.hdl.chain_top.SourceStage`: every input
    port of the component (lanes or pins, settings) becomes a top port ``lvds_<port>``; the
    frame kind the lanes' row headers carry travels with the beats to a later block's
    ``frame_kind`` (the CDS stage keeping the reset frame in DDR); its ``release`` is the
    top's start-up gate (frames before the calibration load are dropped whole and
    counted)."""
    from amaranth.lib import wiring
    from tdicam.hdl.chain_top import SourceStage
    from tdicam.blocks import get
    comp = _top(**get("lvds").resolve(step.params))
    ins = tuple(name for name, mem in comp.signature.members.items()
                if mem.flow == wiring.In and name != "release")
    return SourceStage("lvds", lambda lane: comp, ports=ins, out_slice=True,
                       carries=("frame_kind",), gate="release")


def _front_system(step, ctx):
    """The plan: the lanes' pixel rate against the chain's (lanes x bit rate / word bits =
    the pixels a second the sensor sends, each line's sync and header word included) and
    the training time before the first frame (:func:`tdicam.model.lvds.training_words`: the
    tap scan and the word alignment, at most, in word clocks)."""
    from tdicam.blocks import get
    lv = ctx["scene"].sensor.lvds
    prm = get("lvds").resolve(step.params)
    lanes, w = prm["lanes"], prm["word_bits"]
    word_hz = lv.bit_rate_mbps * 1e6 / w
    lpg = prm["lanes_per_gain"]
    per_line = ctx["width"] / lpg             # columns a lane a line (a padded slot is none)
    rate = lanes * word_hz * per_line / lvds_front.line_words(ctx["width"], lpg)  # pixels/s
    need = ctx["lanes"] * ctx["rows"] * ctx["width"] / ctx["line_period_s"]
    train = lvds.training_words(w, step.ports["n_check"], prm["settle"]) / word_hz
    return [{"name": "lane pixel rate", "value": rate, "unit": "pixel/s", "ok": rate >= need,
             "needed": need,
             "text": f"sensor lanes: {lanes} lanes x {lv.bit_rate_mbps:g} Mbit/s / {w} bit = "
                     f"{lanes * word_hz / 1e6:.1f} M words/s, {rate / 1e6:.1f} M pixels/s "
                     f"after each line's sync and header words"
                     f"{_padded_text(ctx['width'], lpg)}; the window needs "
                     f"{need / 1e6:.2f} M pixels/s: {'OK' if rate >= need else 'NO'}"},
            _fifo_row(step, prm, lv, ctx),
            {"name": "lane training", "value": train, "unit": "s", "ok": None,
             "text": f"lane training before the first frame: at most {train * 1e6:.1f} us "
                     f"({lvds.training_words(w, step.ports['n_check'], prm['settle'])} word "
                     f"clocks: {lvds.N_TAPS} taps scanned and {w} bitslips)"},
            *_eye_rows(ctx["scene"], lanes, step.ports["n_check"], prm["settle"])]


def _padded_text(columns, lanes_per_gain):
    """The plan's words on a line's padded slots ('' when the lanes divide the columns)."""
    pad = lvds_front.padded_slots(columns, lanes_per_gain)
    return "" if not pad else (f" and {pad} padded slot(s) a gain (a line of {columns} columns "
                               f"is {lvds_front.line_words(columns, lanes_per_gain)} words a "
                               f"lane)")


def _eye_rows(scene, lanes, n_check, settle):
    """The plan's row for the eyes the scene gives (none when the link is ideal): the lanes
    whose training fails (their columns invalid in every frame; NO when no lane trains)."""
    if not scene.sensor.lvds.simulate:
        return []
    bad = lvds_front.scene_untrained_lanes(scene.sensor.lvds, len(scene.sensor.gains),
                                           scene.run.seed, n_check=n_check, settle=settle)
    ok = False if len(bad) == lanes else None
    if not bad:
        text = "lane eyes: every lane trains"
    elif ok is False:
        text = ("lane eyes: no lane can train (eyes too narrow or jitter too large): every "
                "column invalid: NO")
    else:
        text = (f"lane eyes: lane(s) {', '.join(map(str, bad))} of {lanes} cannot train (eye "
                f"too narrow): their columns are invalid in every frame")
    return [{"name": "lane eyes", "value": lanes - len(bad), "unit": "lanes", "ok": ok,
             "untrained": bad, "text": text}]


def _front_measured(step, status, info):
    """What the co-simulated front saw (its status at the end of the sensor's words, and
    ``info["lanes"]``, the lanes' report of :func:`tdicam.chain.cosim.cosimulate`): the
    lanes locked and in error by number (an untrained lane's columns are invalid in every
    frame, a dead lane's from its death on), frames released, dropped (held: before the
    start-up gate, after a lane loss until the retrain), affected (with invalid columns),
    the retrains and lane error events, and whether the crossing FIFO overflowed."""
    if "lvds_lane_locked" not in status:
        return []
    lanes = info.get("lanes") or {}
    n = lanes.get("lanes") or step.params["lanes"]
    locked = [i for i in range(n) if status["lvds_lane_locked"] >> i & 1]
    err = [i for i in range(n) if status["lvds_lane_error"] >> i & 1]
    untrained = lanes.get("untrained", [])
    died = lanes.get("died")
    text = (f"sensor lanes: {len(locked)} of {n} locked"
            + (f"; lane(s) {', '.join(map(str, err))} in error" if err else "")
            + (f" (did not train, eye too narrow: {', '.join(map(str, untrained))}; their "
               f"columns invalid in every frame)" if untrained else "")
            + (f"; lane {died} died in frame {lanes['died_in_frame']} (the frame filled from "
               f"pixel word {lanes['filled_from_word']} and flagged, its columns invalid "
               f"after the retrain)" if died is not None else ""))
    frames = (f"sensor frames: {status['lvds_frames_out']} released, "
              f"{status['lvds_frames_dropped']} dropped (held until the retrain or the "
              f"start-up), {status['lvds_frames_affected']} with invalid columns, "
              f"{lanes.get('retrains', 0)} retrain(s), {status['lvds_lane_errors']} lane "
              f"error event(s); crossing FIFO "
              + ("OVERFLOWED (pixels lost)" if status[OVERFLOW] else
                 f"no overflow (depth {step.params.get('fifo_depth', 16)})"))
    eyes = [{"name": f"lane {e['lane']} eye", "value": e["eye_taps_found"], "unit": "taps",
             "ok": bool(e["locked"] and e["walk_ok"]) if e["agree"] else False,
             **{k: e[k] for k in ("lane", "mask", "tap", "slip", "walk_ok", "agree")},
             "text": e["text"]} for e in lanes.get("eyes") or []]
    corr = lanes.get("corrections")
    track = [] if corr is None else [{
        "name": f"lane {i} tracking", "value": len(c), "unit": "corrections",
        "corrections": [list(x) for x in c], "ok": not corr["problems"],
        "text": f"lane {i}: eye tracking: {len(c)} correction(s)"
                + (": " + ", ".join(f"tap {t} from word {e}" for e, t in c) if c else "")
                + ("" if corr["problems"] else " (as the golden model states)")}
        for i, c in corr["per_lane"].items()]
    return [{"name": "sensor lanes", "value": len(locked), "unit": "lanes",
             "locked": locked, "error": err, "untrained": untrained, "died": died,
             "text": text}, *eyes, *track,
            {"name": "sensor frames", "value": status["lvds_frames_out"], "unit": "frames",
             "dropped": status["lvds_frames_dropped"],
             "affected": status["lvds_frames_affected"],
             "retrains": lanes.get("retrains", 0), "lane_errors": status["lvds_lane_errors"],
             "fifo_overflow": status[OVERFLOW],
             "frame_status": lanes.get("frame_status"), "text": frames}]


def _fifo_row(step, prm, lv, ctx):
    """The plan's line on the crossing FIFO: its depth and why (the line burst at the
    slowest processing clock the lanes allow, the DDR model's worst stall behind it, the
    synchronizer slack: :func:`tdicam.model.lvds_front.fifo_depth`)."""
    from tdicam.model.dram import worst_stall
    lpg, w, ppc = prm["lanes_per_gain"], prm["word_bits"], prm["ppc"]
    word_mhz = lv.bit_rate_mbps / w
    slowest = lvds_front.min_proc_mhz(lpg, ppc, prm["columns"], word_mhz)
    bare = lvds_front.fifo_depth(lpg, ppc, prm["columns"], word_mhz, slowest)
    depth = prm["fifo_depth"]
    scene = ctx["scene"]
    stall = worst_stall(dict(scene.ddr.stalls)) if scene.ddr is not None else 0
    why = (f"crossing FIFO: {depth} entries of one word a lane: a line's burst at the "
           f"slowest processing clock the lanes allow ({slowest:.1f} MHz x {ppc} pixel(s)) "
           f"and 8 for the synchronizers")
    if depth > bare:
        why += (f", plus the DDR model's worst stall behind it ({stall} clocks: refresh "
                f"cycles + the longest read latency, [ddr]) = "
                f"{-(-stall * word_mhz // slowest):.0f} word clocks of entries ({bare} "
                f"without it); the front has no backpressure")
    return {"name": "crossing FIFO", "value": depth, "unit": "entries", "ok": None,
            "without_stall_margin": bare, "stall_cycles": stall if depth > bare else 0,
            "text": why}


def _front_golden(step, data=None):
    """What the front delivers of the sensor's frames with every lane trained: the wire
    codes (the all-ones sync code sent as one less)."""
    w = step.params["word_bits"]
    return lambda arrays, lane: lvds_front.wire_code(arrays[0], w)


# ---- entry
BLOCK = Block(
    name="lvds",
    summary="LVDS receiver: IDELAY bit training, bitslip, lane deskew (Ning et al. 2019 §4.1)",
    params=(
        Param("lanes", 8, "lanes (80 = GMAX0504: 40 HG + 40 LG)", lo=1, hi=MAX_LANES),
        Param("word_bits", 10, "bits per word", choices=(10, 12)),
        Param("settle", 8, "word clocks ignored after a tap load or bitslip", lo=4, hi=64),
        Param("min_run", 9, "shortest accepted run of passing taps", lo=1, hi=32),
        Param("pick", 5, "sample at this tap of the run (1 = first)", lo=1, hi=32),
        Param("deskew_depth", 8, "deskew FIFO words per lane", choices=(8, 16, 32)),
        Param("phy", "none", "none: the core (simulated); xilinx7: IDELAYE2/ISERDESE2 "
              "wrapper; ecp5: DELAYF/IDDRX2F wrapper", choices=tuple(PHYS), type=str),
        Param("lanes_per_gain", 0, "> 0: the camera's front end (lanes -> pixel stream), "
              "lanes per gain channel", lo=0, hi=64, implicit_default=True),
        Param("columns", 0, "front end: frame width (>= lanes_per_gain; a last partial word "
              "clock padded)", lo=0,
              hi=65536, implicit_default=True),
        Param("bits", 12, "front end: pixel bits (<= word_bits)", lo=1, hi=12,
              implicit_default=True),
        PPC_PARAM,
        Param("fifo_depth", 16, "front end: crossing FIFO entries (power of two)",
              choices=FIFO_DEPTHS, implicit_default=True),
        Param("pairs", 0, "front end: 1 = reset/signal frame pairs (released from a reset "
              "frame on)", choices=(0, 1), implicit_default=True),
        Param("track", 0, "> 0: track each locked lane's eye with a monitor sampler this many "
              "taps either side (generic PHY; xilinx7 with 12-bit words)", lo=0, hi=15,
              implicit_default=True),
        Param("eye", 0, "1 = the eye status ports: chosen tap, slip mask, walking-1/0 "
              "patterns received (and, as the front end, the tap pass masks, runs, slips)",
              choices=(0, 1), implicit_default=True),
    ),
    top=_top,
    cases=lambda: [
        Case("random8_10b", {"word_bits": 10}, _case(_random(8)), seed=1),
        Case("random8_12b", {"word_bits": 12}, _case(_random(8)), seed=2),
        Case("random8_nc1", {"word_bits": 10}, _case(_random(8, n_check=1)), seed=3,
             tags=("n_check=1",)),
        Case("windows_10b", {"word_bits": 10}, _case(_windows), seed=4,
             tags=("clipped", "several-windows", "tie", "narrow", "dead", "flicker")),
        Case("deskew_8lanes", {"word_bits": 10}, _case(_deskew), seed=5, tags=("deskew",)),
        Case("retrain_10b", {"word_bits": 10}, _case(_retrain), seed=6,
             tags=("retrain", "dies-after-lock", "dies-in-bitslip")),
        Case("retrain_12b", {"word_bits": 12}, _case(_retrain), seed=7,
             tags=("retrain",)),
    ],
    check=_check,
    model_version="lvds-1",
    order=70,
    bench=Bench("lvds"),
    harness="link",                 # not a video stream: the link testbench verifies it
    synth=(SynthRef("lvds", {"lanes": 8}, note="8 lanes x 10 bit, core (no PHY)"),),
    pipeline=Use(_front_step, _front_hw, source=_front_source, chain_golden=_front_golden,
                 system=_front_system, measured=_front_measured),
)
