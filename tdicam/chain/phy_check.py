"""The ``[run.rtl] phy`` check of ``tdicam run``: a lanes scene's link from serial bits
through a device PHY's receiver (:func:`tdicam.cosim.lvds_pins.run_pins`), beside the
chain's own co-simulation (which the generic PHY, words in, feeds as before).

The link is the scene's ``[sensor.lvds]``: its lanes (:func:`tdicam.chain.lane_cosim.lanes_of`:
skews, eyes and jitter in ps as the scene states them) seen through the PHY's delay tap
(:func:`tdicam.hdl.lvds_phy.tap_ps`), at the scene's bit rate made a whole number of fs a
bit (:func:`tdicam.cosim.lvds_pins.rate_for_ui`), the link model's own data after the
training. A drifting scene (``drift_taps``) drifts the same ps (``drift_taps x tap_ps``
of the scene, in the PHY's taps) over the same words as the chain's co-simulation
(``drift_words``: ``drift_frames`` of its frames), from the data start; the run goes on
:data:`DATA_WORDS` past the drift's end. With ``eye_status`` the receiver has the eye-status
ports and the sensor sends a round of the walking-1/0 patterns before the data; with
``tracking`` it tracks the eyes (:data:`tdicam.blocks.lvds.TRACK_MARGIN`; the 7-series PHY
with 12-bit words: its monitor sampler in each pair's N pin).

A lane passes when it trains as :func:`tdicam.cosim.lvds_pins.predict` says for the PHY,
judged over the whole run (locked or in error at the end, an error after lock included;
tap up to its random band above the jitter-free prediction, slip equal; an eye edge on a
tap's sample to within :data:`EDGE_PS` may go either way), with tracking every correction
the golden tracker's (:mod:`tdicam.model.lvds_track`: count, new tap and the word it takes
effect at; not judged on a jittered lane, whose probes meet its random band), and delivers
from the data start every word the golden link model sent
(:func:`tdicam.model.lvds.sent_words`): a lane in error after its lock up to its first
wrong word as predicted, less :data:`DRIFT_SLACK` words; a lane with no eye must report its
error. The pins index a drift by the sender's word, the link model by the deserializer's
raw word (:mod:`tdicam.cosim.lvds_pins`): they differ by the lane's delay and the PHY's
pipeline, a few words (4 seen with the 7-series' Verilator word phase), so a drifting lane
is judged against the predictions with the drift started up to :data:`DRIFT_SLACK` words
either side too, nearest first (the first that agrees with the run; each is the golden
tracker's for its start): a probe pair is 54 words, a correction one pair early or late is
still found. A lane in error *as predicted* is the scene's finding, not a failure: the row lists
it in ``lane_errors`` with no problem; only what differs from the prediction is a problem
(``problems``, which ``tdicam run`` counts as a failed co-simulation).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["phy_check", "pin_link", "judge", "device_eyes", "DATA_WORDS", "EDGE_PS", "DRIFT_SLACK"]

#: Words of data the pin-level run delivers after the training (and after a drift's end).
DATA_WORDS = 300
#: How close (ps) an eye edge may come to a tap's sample and count as a tie: the pins'
#: times are whole fs (skew, eye and bit rounded), the link model's exact; a tap whose
#: sample an edge meets to within this may pass or fail, the prediction with the eye that
#: much narrower or wider says which tap each gives.
EDGE_PS = 0.002
#: Words either side of the drift's start the judgement of a drifting lane also takes
#: (the pins' drift indexed by the sender's word, the model's by the deserializer's raw
#: word after the PHY's pipeline).
DRIFT_SLACK = 6


def phy_check(lv, lanes, phy, sim, *, drift_words=None):
    """One report row: the scene's lanes (``lv``: :class:`tdicam.scene.schema.Lvds`;
    ``lanes``: the chain's, :func:`tdicam.chain.lane_cosim.lanes_of`) from serial
    bits through ``phy``'s receiver on ``sim``; ``drift_words``: the words the scene's drift
    spans (the chain's co-simulation's; needed with ``drift_taps``). ``lanes``,
    ``words_compared``, ``mismatches``, ``taps_as_predicted`` (every lane's training and
    end state as predicted), ``lane_errors`` (lanes in error, as predicted or not), ``taps``,
    ``scans`` (pass masks) and the ``predicted_taps`` / ``predicted_scans`` they were judged
    against (the tie's when an eye edge met a sample), with tracking ``corrections`` and
    ``predicted_corrections`` (per lane ``[effect word, new tap]``, the pin run's port
    cycles) and ``corrections_as_predicted``, with the eye status ``eyes`` (one entry a
    lane, :func:`device_eyes`), ``drift`` (the drift judged: taps of the PHY per lane,
    words, first word), ``problems`` and ``wall_seconds``; a failed run is ``status``
    "error: ..."."""
    from tdicam.cosim import lvds_pins
    t0 = time.perf_counter()
    row = {"phy": phy, "simulator": sim, "status": "ran"}
    try:
        link, nd, cycles, track, drift = pin_link(lv, lanes, phy, drift_words=drift_words)
        res = lvds_pins.run_pins(link, phy, cycles=cycles, sim=sim, eye=lv.eye_status,
                                 track=track)
    except TdicamError as exc:
        row.update(status=f"error: {exc}", wall_seconds=time.perf_counter() - t0)
        return row
    tap = link.lanes[0].tap_ps
    given = [float(t) * lv.tap_ps / tap for t in lv.eye_width_taps] if lv.simulate else None
    row.update(judge(link, phy, res, nd, track=track, eye=lv.eye_status, eye_taps=given))
    if drift:
        row["drift"] = {"taps": drift, "tap_ps": tap, "words": int(drift_words),
                        "from_word": nd}
    row["wall_seconds"] = time.perf_counter() - t0
    return row


def pin_link(lv, lanes, phy, *, drift_words=None):
    """The pin-level run :func:`phy_check` makes of a scene's lanes: ``(link, nd, cycles,
    track, drift)`` (the link, its data start, the word clocks to simulate, the tracking
    margin or 0, each lane's drift in the PHY's taps or [] without one)."""
    from tdicam.blocks.lvds import TRACK_MARGIN
    from tdicam.cosim import lvds_pins
    from tdicam.hdl.lvds_phy import tap_ps
    from tdicam.model import lvds
    if phy not in lvds_pins.PIN_PHYS:
        raise TdicamError(f"[run.rtl].phy = {phy} is not simulated from serial bits; "
                          f"valid: {', '.join(lvds_pins.PIN_PHYS)}")
    rate = lvds_pins.rate_for_ui(round(1e9 / lv.bit_rate_mbps))
    tap = tap_ps(phy)
    w = lv.word_bits
    nd = lvds.training_words(w, 16, 8) + (900 if phy == "ecp5" else 100)
    drift = [float(d) * lv.tap_ps / tap for d in lv.drift_taps] if any(lv.drift_taps) else []
    if drift and not drift_words:
        raise TdicamError("[sensor.lvds].drift_taps: the phy check needs the words the drift "
                          "spans (drift_words, from the chain's co-simulation)")
    lanes = [replace(ln, tap_ps=tap, bit_rate_mbps=rate,
                     **({"drift_taps": drift[i], "drift_from": nd,
                         "drift_words": int(drift_words)} if drift and drift[i] else {}))
             for i, ln in enumerate(lanes)]
    sched = ((nd - 2 * w, "walk"),) * lv.eye_status + ((nd, "data"),)
    link = lvds.Link(lanes, word_bits=w, train_word=lv.train_word, line_words=32,
                     schedule=sched)
    cycles = nd + (int(drift_words) if drift else 0) + DATA_WORDS
    return link, nd, cycles, TRACK_MARGIN if lv.tracking else 0, drift


def _candidates(link, i):
    """The links lane ``i`` of a run is judged on, the exact one first: ``link``, and with
    the lane's eye edges :data:`EDGE_PS` either way (its eye narrower or wider, its skew
    earlier or later), its drift (if it drifts) started up to :data:`DRIFT_SLACK` words
    earlier or later."""
    ln = link.lanes[i]
    shifts = [0] + ([s for d in range(1, DRIFT_SLACK + 1) for s in (-d, d)]
                    if ln.drift_taps else [])
    ties = [(d, sk) for d in (0.0, -EDGE_PS, EDGE_PS) for sk in (0.0, -EDGE_PS, EDGE_PS)]
    for s in shifts:
        for d, sk in ties:
            lane = replace(ln, eye_ps=max(ln.eye_ps + d, 0.0) if ln.eye_ps else 0.0,
                           skew_ps=ln.skew_ps + sk,
                           drift_from=max(ln.drift_from + s, 0) if ln.drift_taps
                           else ln.drift_from)
            yield replace(link, lanes=link.lanes[:i] + (lane,) + link.lanes[i + 1:])


def _lane_verdict(lane, p, f, corr, band, track):
    """What differs between lane run ``f`` (final status; ``corr`` its corrections) and
    prediction ``p`` (a list of problem texts without the lane's number)."""
    out = []
    if (f["locked"], f["error"]) != (int(p.locked), int(p.error)):
        return [f"locked {f['locked']} error {f['error']}, predicted {int(p.locked)} "
                f"{int(p.error)}"]
    if p.lock_k is not None and not (p.tap <= f["tap"] <= p.tap + band
                                     and f["slip"] == p.slip):
        out.append(f"tap {f['tap']} slip {f['slip']}, predicted tap {p.tap}..{p.tap + band} "
                   f"slip {p.slip}")
    if track and not band:
        want = [(e, t) for _, t, e in p.corrections]
        if corr != want or f.get("corrections") != p.count:
            out.append(f"corrections {corr[:3]}{'..' if len(corr) > 3 else ''} "
                       f"({f.get('corrections')} counted), the golden tracker's "
                       f"{want[:3]}{'..' if len(want) > 3 else ''} ({p.count})")
    return out


def judge(link, phy, res, nd, *, track=0, eye=False, eye_taps=None):
    """The row's figures of the pin-level run ``res`` of ``link`` (data from word ``nd``)
    through ``phy``, with tracking of margin ``track`` and the eye status ``eye`` (``eyes``:
    :func:`device_eyes`, ``eye_taps`` the eye widths given, in the PHY's taps; see
    :func:`phy_check`)."""
    from tdicam.cosim import lvds_pins
    from tdicam.model import lvds
    phase = lvds_pins.judged_phase(link, phy, res)
    problems, errors, taps_ok, used, until = [], [], True, [], {}
    ks = res.outputs[0]
    got = {i: [(e, t) for e, lane, t in res.corrections if lane == i]
           for i in range(len(link.lanes))}
    for i, (lane, f) in enumerate(zip(link.lanes, res.final)):
        band = lvds_pins.band_taps(lane)
        first = None
        for cand in _candidates(link, i):
            seen = lvds_pins.seen_link(cand, word_phase=phase, jitter=False)
            p = lvds.train_lane(seen, i, 0, k_stop=res.cycles, eye=eye, track=track)
            bad = _lane_verdict(lane, p, f, got[i], band, track)
            free = lvds_pins.band_mask(p.scan_mask, band)
            mask_ok = not (f["scan"] ^ p.scan_mask) & ~free
            first = first or (p, seen, bad)
            if not bad and mask_ok:
                first = (p, seen, bad)
                break
        p, seen, bad = first
        used.append(p)
        if f["error"]:
            errors.append(i)
        if bad:
            taps_ok = False
            problems += [f"lane {i}: {t}" for t in bad]
        if lane.eye_ps == 0 and not f["error"]:
            problems.append(f"lane {i}: no eye, and no error reported")
        if p.lock_k is not None and p.error and f["error"]:
            until[i] = _first_wrong(seen, i, p, nd) - DRIFT_SLACK
    mism, more = lvds_pins.word_problems(link, res, nd, until)
    problems += more
    if eye:
        problems += lvds_pins.eye_problems(link, phy, res, track=track, pred=used)
    n_words = sum(min(max(until.get(i, len(ks)), 0), len(ks)) for i in range(len(link.lanes)))
    row = dict(lanes=len(link.lanes), words_compared=int(n_words),
               mismatches=mism, taps_as_predicted=taps_ok, lane_errors=errors,
               taps=[f["tap"] for f in res.final], scans=[f["scan"] for f in res.final],
               predicted_scans=[p.scan_mask for p in used],
               predicted_taps=[p.tap if p.lock_k is not None else None for p in used],
               trained_taps=[lvds_pins.trained_tap(p) for p in used],
               problems=problems)
    if until:
        row["words_judged_until"] = {str(i): int(n) for i, n in until.items()}
    if track:
        row["corrections"] = [[list(c) for c in got[i]] for i in range(len(link.lanes))]
        row["predicted_corrections"] = [[[e, t] for _, t, e in p.corrections] for p in used]
        row["corrections_as_predicted"] = all(
            got[i] == [(e, t) for _, t, e in p.corrections]
            for i, (p, ln) in enumerate(zip(used, link.lanes)) if not lvds_pins.band_taps(ln))
        row["latency_words"] = lvds.LINK_LATENCY
    if eye:
        row["eyes"] = device_eyes(phy, res, row, used, word_bits=link.word_bits,
                                  eye_taps=eye_taps)
    return row


def _first_wrong(seen, i, p, nd):
    """The first delivered word (counted from the data start ``nd``) of lane ``i`` that the
    golden model says is captured wrong: ``p`` locked and then lost the eye (``seen``: the
    link as the PHY sees it, :func:`tdicam.cosim.lvds_pins.seen_link`)."""
    from tdicam.cosim.lvds_pins import trained_tap
    from tdicam.model import lvds, lvds_track
    k_end = p.events[-1][0]
    ks = np.arange(p.lock_k, k_end + 1, dtype=np.int64)
    raw_tap = lvds_track.raw_tap_of(trained_tap(p), [(kc, t) for kc, t, _ in p.corrections],
                                    lvds.LINK_LATENCY)
    got = lvds._tap_words(seen, i, raw_tap, p.slip, ks)
    sent = lvds.sent_words(seen, i, ks - p.word_delay)
    bad = np.flatnonzero(got != sent)
    k = int(ks[bad[0]]) if len(bad) else k_end
    return k - p.word_delay - nd


def device_eyes(phy, res, row, pred, *, word_bits, eye_taps=None):
    """Each lane's training as the device PHY's receiver published it from the pins (its
    eye-status ports: pass mask over the 32 taps, eye width, chosen tap, slip and the slips
    that passed, walking-1/0 patterns; the tap training chose: the golden decision on the
    reported mask, :func:`tdicam.model.lvds.decide`), in the fields of
    :func:`tdicam.cosim.lvds_front.lane_eyes` (``eyes.png``'s), with ``golden`` the
    prediction ``pred`` it was judged against (``row``: :func:`judge`'s) and ``agree``
    whether the lane has no problem in ``row``; ``source`` names the receiver; ``eye_taps``:
    the eye widths given (the PHY's taps)."""
    from tdicam.hdl.lvds_phy import tap_ps
    from tdicam.model import lvds
    full = (1 << 2 * word_bits) - 1
    tp = tap_ps(phy)
    out = []
    for i, (f, p) in enumerate(zip(res.final, pred)):
        bad = [t for t in row["problems"] if t.startswith(f"lane {i}:")]
        mask = [(f["scan"] >> t) & 1 for t in range(lvds.N_TAPS)]
        trained = lvds.decide(mask, p.words)[2] if p.lock_k is not None else None
        e = {"lane": i, "source": f"{phy} receiver from serial bits", "mask": f["scan"],
             "taps": mask, "tap": f["chosen_tap"],
             "trained_tap": f["chosen_tap"] if trained is None else int(trained),
             "slip": f["slip"], "slip_mask": f["slip_pass"], "eye_taps_found": f["run"],
             "eye_ps_found": f["run"] * tp, "walk": f["walk"], "walk_ok": bool(f["walk_ok"]),
             "locked": f["locked"], "error": f["error"],
             "eye_taps_given": None if eye_taps is None else round(float(eye_taps[i]), 3),
             "golden": {"mask": p.scan_mask, "eye_taps_found": p.run_len,
                        "tap": p.tap if p.lock_k is not None else 0, "slip": p.slip,
                        "slip_mask": p.slip_pass, "walk": p.walk, "locked": int(p.locked),
                        "error": int(p.error)},
             "agree": not bad}
        walk = ("every bit seen as 1 and 0" if e["walk"] == full else
                f"patterns {e['walk']:#x} of {full:#x}")
        given = "" if eye_taps is None else f" (scene: {e['eye_taps_given']:g})"
        e["text"] = (f"lane {i} ({phy}): {'locked' if f['locked'] else 'in error'}, eye "
                     f"{f['run']} taps of {tp:g} ps{given}, tap {e['trained_tap']}"
                     + ("" if e["trained_tap"] == e["tap"] else
                        f" ({e['tap']} at the end, tracked)")
                     + f", slip {f['slip']}; walking 1/0: {walk}; "
                     + ("as predicted" if not bad else "; ".join(bad)))
        out.append(e)
    return out
