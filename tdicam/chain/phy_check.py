"""The ``[run.rtl] phy`` check of ``tdicam run``: a lanes scene's link from serial bits
through a device PHY's receiver (:func:`tdicam.cosim.lvds_pins.run_pins`), beside the
chain's own co-simulation (which the generic PHY, words in, feeds as before).

The link is the scene's ``[sensor.lvds]``: its lanes (:func:`tdicam.chain.cosim.lanes_of`:
skews, eyes and jitter in ps as the scene states them) seen through the PHY's delay tap
(:func:`tdicam.hdl.lvds_phy.tap_ps`), at the scene's bit rate made a whole number of fs a
bit (:func:`tdicam.cosim.lvds_pins.rate_for_ui`), the link model's own data after the
training. A lane passes when it trains as :func:`tdicam.cosim.lvds_pins.predict` says for
the PHY (locked or in error; tap up to its random band above the jitter-free prediction,
slip equal; an eye edge on a tap's sample to within :data:`EDGE_PS` may go either
way) and, locked, delivers from the data start every word the golden link model
sent (:func:`tdicam.model.lvds.sent_words`); a lane with no eye must report its error.
"""

from __future__ import annotations

import time
from dataclasses import replace

from tdicam.errors import TdicamError

__all__ = ["phy_check", "judge", "DATA_WORDS", "EDGE_PS"]

#: Words of data the pin-level run delivers after the training.
DATA_WORDS = 300
#: How close (ps) an eye edge may come to a tap's sample and count as a tie: the pins'
#: times are whole fs (skew, eye and bit rounded), the link model's exact; a tap whose
#: sample an edge meets to within this may pass or fail, the prediction with the eye that
#: much narrower or wider says which tap each gives.
EDGE_PS = 0.002


def phy_check(lv, lanes, phy, sim):
    """One report row: the scene's lanes (``lv``: :class:`tdicam.scene.schema.Lvds`;
    ``lanes``: the chain's, :func:`tdicam.chain.cosim.lanes_of`) from serial
    bits through ``phy``'s receiver on ``sim``. ``lanes``, ``words_compared``,
    ``mismatches``, ``taps_as_predicted``, ``lane_errors`` (lanes in error, as predicted or
    not), ``taps``, ``scans`` (pass masks) and the ``predicted_taps`` / ``predicted_scans``
    they were judged against (the tie's when an eye edge met a sample), ``problems`` and
    ``wall_seconds``; a failed run is ``status`` "error: ..."."""
    from tdicam.cosim import lvds_pins
    from tdicam.hdl.lvds_phy import tap_ps
    from tdicam.model import lvds
    t0 = time.perf_counter()
    row = {"phy": phy, "simulator": sim, "status": "ran"}
    try:
        if phy not in lvds_pins.PIN_PHYS:
            raise TdicamError(f"[run.rtl].phy = {phy} is not simulated from serial bits; "
                              f"valid: {', '.join(lvds_pins.PIN_PHYS)}")
        rate = lvds_pins.rate_for_ui(round(1e9 / lv.bit_rate_mbps))
        lanes = [replace(ln, tap_ps=tap_ps(phy), bit_rate_mbps=rate)
                 for ln in lanes]
        w = lv.word_bits
        nd = lvds.training_words(w, 16, 8) + (900 if phy == "ecp5" else 100)
        link = lvds.Link(lanes, word_bits=w, train_word=lv.train_word, line_words=32,
                         schedule=((nd, "data"),))
        res = lvds_pins.run_pins(link, phy, cycles=nd + DATA_WORDS, sim=sim)
    except TdicamError as exc:
        row.update(status=f"error: {exc}", wall_seconds=time.perf_counter() - t0)
        return row
    row.update(judge(link, phy, res, nd), wall_seconds=time.perf_counter() - t0)
    return row


def judge(link, phy, res, nd):
    """The row's figures of the pin-level run ``res`` of ``link`` (data from word ``nd``)
    through ``phy`` (see :func:`phy_check`)."""
    from tdicam.cosim import lvds_pins
    phase = lvds_pins.judged_phase(link, phy, res)
    pred = lvds_pins.predict(link, phy, word_phase=phase, jitter=False)
    # an eye edge on a tap's sample to within the pins' fs rounding: either side is right
    ties = [lvds_pins.predict(replace(link, lanes=tuple(
        replace(ln, eye_ps=max(ln.eye_ps + d, 0.0)) if ln.eye_ps else ln
        for ln in link.lanes)), phy, word_phase=phase, jitter=False) for d in (-EDGE_PS,
                                                                               EDGE_PS)]
    problems, errors, taps_ok, used = [], [], True, []
    ks = res.outputs[0]
    for i, (lane, p, f) in enumerate(zip(link.lanes, pred, res.final)):
        band = lvds_pins.band_taps(lane)
        p = next((q for q in (p, ties[0][i], ties[1][i]) if q.locked and
                  q.tap <= f["tap"] <= q.tap + band and f["slip"] == q.slip), p)
        used.append(p)
        if f["error"]:
            errors.append(i)
        if (f["locked"], f["error"]) != (int(p.locked), int(p.error)):
            taps_ok = False
            problems.append(f"lane {i}: locked {f['locked']} error {f['error']}, predicted "
                            f"{int(p.locked)} {int(p.error)}")
        elif p.locked and not (p.tap <= f["tap"] <= p.tap + band and f["slip"] == p.slip):
            taps_ok = False
            problems.append(f"lane {i}: tap {f['tap']} slip {f['slip']}, predicted tap "
                            f"{p.tap}..{p.tap + band} slip {p.slip}")
        if lane.eye_ps == 0 and not f["error"]:
            problems.append(f"lane {i}: no eye, and no error reported")
    mism, more = lvds_pins.word_problems(link, res, nd)
    problems += more
    return dict(lanes=len(link.lanes), words_compared=int(len(ks) * len(link.lanes)),
                mismatches=mism, taps_as_predicted=taps_ok, lane_errors=errors,
                taps=[f["tap"] for f in res.final], scans=[f["scan"] for f in res.final],
                predicted_scans=[p.scan_mask for p in used],
                predicted_taps=[p.tap if p.locked else None for p in used],
                problems=problems)
