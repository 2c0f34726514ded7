"""Serial-bit co-simulation of the ``xilinx7`` and ``ecp5`` receivers
(:mod:`tdicam.cosim.lvds_pins`), on Icarus and Verilator: 8 lanes driven from their pins
with skew up to a whole word plus a fraction of a bit, random jitter on half of them,
duty-cycle distortion on a third, eyes of 11-22 taps, and a lane with no eye. Each lane must
train as the golden link model predicts (tap and bitslip; a jittered lane's tap up to its
random band later), the lane with no eye must report its error, and every locked lane must
deliver, from the data start, exactly the words sent: what the generic PHY delivers.
With the eye-status ports on (``eye``), after a round of the walking-1/0 patterns, every
lane's published training (pass mask, eye width, chosen tap, slip and slip mask, walking
patterns) must be the golden link model's for that PHY (:func:`tdicam.cosim.lvds_pins.
eye_problems`: a jittered lane's mask free only inside its random band). Tracking from the
pins: the 7-series PHY with 12-bit words and its monitor sampler in each pair's N pin
follows eyes drifting 6 taps with the golden tracker's corrections and loses no word; the
same drift without tracking puts a lane in error.
"""

import dataclasses
import functools
import os

import numpy as np
import pytest

from tdicam.cosim import lvds_pins
from tdicam.hdl.lvds_phy import tap_ps
from tdicam.model import lvds

UI = 3333333          # fs: 300 Mb/s
FULL = os.environ.get("TDICAM_FULL") == "1"


def _lane(rng, phy, w, i, seed):
    """A lane whose eye the 32-tap scan sees whole (a run of >= 9 taps plus its random band,
    not clipped by tap 0 or 31): skew up to a word plus a fraction of a bit, eye 11-22 taps,
    jitter 0.5-2 taps on odd lanes, duty-cycle distortion 0.5-2 taps on every third."""
    tap, rate = tap_ps(phy), lvds_pins.rate_for_ui(UI)
    ui = UI / 1000
    while True:
        skew = float(rng.uniform(0, w * ui))
        d = float(rng.uniform(0.5, 2)) * tap if i % 3 == 0 else 0.0
        eye = min(float(rng.uniform(11, 22)) * tap + d, ui - d - 1)
        jit = float(rng.uniform(0.5, 2)) * tap if i % 2 else 0.0
        lane = lvds.Lane(skew_ps=skew, eye_ps=eye, jitter_ps=jit, tap_ps=tap,
                         bit_rate_mbps=rate, seed=100 * seed + i)
        p = lvds_pins.predict(lvds.Link([lane], word_bits=w), phy, dcd=(d,), jitter=False)[0]
        band = lvds_pins.band_taps(lane)
        if p.locked and p.run_len >= 9 + band and p.run_start > band \
                and p.run_start + p.run_len < 32 - band:
            return lane, d


def _link(phy, w, seed, n=8, walk=False):
    rng = np.random.default_rng(seed)
    lanes, dcd = [], []
    for i in range(n - 1):
        lane, d = _lane(rng, phy, w, i, seed)
        lanes.append(lane)
        dcd.append(d)
    lanes.append(lvds.Lane(skew_ps=float(rng.uniform(0, w * UI / 1000)), eye_ps=0.0,
                           tap_ps=tap_ps(phy), bit_rate_mbps=lvds_pins.rate_for_ui(UI), seed=n))
    dcd.append(0.0)                                      # the last lane: no eye
    # ECP5 training is longer (the delay moves a count per two word clocks)
    nd = lvds.training_words(w, 16, 8) + (900 if phy == "ecp5" else 100)
    # with walk: one round of the walking-1/0 patterns just before the data
    sched = ((nd - 2 * w, "walk"),) * walk + ((nd, "data"),)
    link = lvds.Link(lanes, word_bits=w, line_words=32, schedule=sched)
    return link, tuple(dcd), nd


@functools.lru_cache(maxsize=None)
def _run(phy, w, sim, eye=False):
    link, dcd, nd = _link(phy, w, seed=w + len(phy), walk=eye)
    return link, dcd, nd, lvds_pins.run_pins(link, phy, dcd=dcd, cycles=nd + 600, sim=sim,
                                             eye=eye)


def _check(phy, w, sim, eye=False):
    link, dcd, nd, res = _run(phy, w, sim, eye)
    phase = lvds_pins.run_phase(link, phy, res, dcd=dcd)
    assert phase is not None, f"{phy}: the slips match no word phase of the PHY"
    pred = lvds_pins.predict(link, phy, dcd=dcd, word_phase=phase, jitter=False)
    locked = []
    for i, (lane, p, f) in enumerate(zip(link.lanes, pred, res.final)):
        if lane.eye_ps == 0:
            assert (f["locked"], f["error"]) == (0, 1), f"lane {i}: no eye, no error"
            continue
        assert (f["locked"], f["error"]) == (1, 0) and p.locked, f"lane {i}: {f}"
        band = lvds_pins.band_taps(lane)
        assert p.tap <= f["tap"] <= p.tap + band, f"lane {i}: tap {f['tap']} vs {p.tap}"
        if not band:
            assert (f["tap"], f["run"], f["scan"]) == (p.tap, p.run_len, p.scan_mask), i
        assert f["slip"] == p.slip, f"lane {i}: slip {f['slip']} vs {p.slip}"
        locked.append(i)
    assert len(res.outputs[0]) > 500, f"{phy}: {len(res.outputs[0])} words delivered"
    assert [f["locked"] for f in res.final] == [int(i in locked) for i in range(len(link.lanes))]
    assert lvds_pins.word_problems(link, res, nd) == (0, []), phy
    if eye:
        assert lvds_pins.eye_problems(link, phy, res, dcd=dcd) == []
    return res


@pytest.mark.parametrize("phy", sorted(lvds_pins.PIN_PHYS))
def test_pins_10bit(phy, sim):
    """10-bit words from the pins: train, lock, deliver the sent words bit-exact."""
    _check(phy, 10, sim)


@pytest.mark.parametrize("phy", sorted(lvds_pins.PIN_PHYS))
def test_pins_12bit(phy, sim):
    """12-bit words (7-series: DATA_WIDTH 6 and the 2:1 fabric gearbox; ECP5: three SCLK
    cycles a word), Icarus (Verilator with TDICAM_FULL=1: the 7-series gearbox pairs at the
    other word phase there, :data:`tdicam.cosim.lvds_pins.WORD_PHASE`)."""
    if sim != "icarus" and not FULL:
        pytest.skip("TDICAM_FULL=1: on Verilator too")
    _check(phy, 12, sim)


def test_pin_link_errors():
    """Bad pin-level links are named in one line."""
    link, dcd, _ = _link("xilinx7", 10, 1)
    with pytest.raises(Exception, match="not simulated from pins"):
        lvds_pins.run_pins(link, "none", cycles=10)
    with pytest.raises(Exception, match="is not a whole number of fs"):
        lvds_pins.ui_fs(300.0)
    bad = lvds.Link([lvds.Lane(skew_ps=0, eye_ps=2000, tap_ps=tap_ps("ecp5"),
                               bit_rate_mbps=lvds_pins.rate_for_ui(UI))])
    with pytest.raises(Exception, match="is not the xilinx7 PHY's tap"):
        lvds_pins.run_pins(bad, "xilinx7", cycles=10)


#: The eye-status runs in CI: one simulator per PHY (the rest with TDICAM_FULL=1).
_EYE_CI = {("xilinx7", 10, "icarus"), ("ecp5", 10, "verilator")}


@pytest.mark.parametrize("w", [10, 12])
@pytest.mark.parametrize("phy", sorted(lvds_pins.PIN_PHYS))
def test_pins_eye_status(phy, w, sim):
    """The eye-status ports from the pins (``eye``): after a round of the walking-1/0
    patterns, every lane's pass mask, eye width, chosen tap, slip, slip mask and walking
    patterns are the golden link model's for the PHY; the lane with no eye reports its error
    (widest run below min_run, nothing walked); the words stay bit-exact."""
    if (phy, w, sim) not in _EYE_CI and not FULL:
        pytest.skip("TDICAM_FULL=1: every PHY x word size x simulator")
    res = _check(phy, w, sim, eye=True)
    dead = res.final[-1]
    assert (dead["locked"], dead["error"], dead["walk"], dead["walk_ok"]) == (0, 1, 0, 0)
    assert dead["run"] < 9
    assert sum(f["walk_ok"] for f in res.final) == len(res.final) - 1


def test_eye_rule_fails():
    """eye_problems names a lane whose published status differs from the golden model's
    (a mask bit outside the random band, a wrong chosen tap, a missing walking pattern, a
    dead lane without its error), and accepts a jittered lane's mask changed inside it."""
    phy, w = "xilinx7", 10
    link, dcd, nd = _link(phy, w, seed=w + len(phy), walk=True)
    cycles = nd + 600
    pred = lvds_pins.predict(link, phy, dcd=dcd, word_phase=lvds_pins.WORD_PHASE[phy, w][0],
                             jitter=False, eye=True, k_stop=cycles)
    full = (1 << 2 * w) - 1
    final = [{"tap": p.tap, "chosen_tap": p.tap, "slip": p.slip, "locked": int(p.locked),
              "error": int(p.error), "run": p.run_len, "scan": p.scan_mask,
              "slip_pass": p.slip_pass, "walk": p.walk, "walk_ok": int(p.walk == full)}
             for p in pred]
    good = lvds_pins.PinRun(final, (), 0.0, 0.0, cycles)
    assert lvds_pins.eye_problems(link, phy, good, dcd=dcd) == []
    j = next(i for i, ln in enumerate(link.lanes) if lvds_pins.band_taps(ln))
    p = pred[j]

    def changed(i, **kw):
        fin = [dict(f) for f in final]
        fin[i].update(kw)
        return lvds_pins.eye_problems(link, phy, dataclasses.replace(good, final=fin),
                                      dcd=dcd)

    # the first tap of a jittered lane's run lost (inside the band): the run one shorter,
    # the chosen tap one later
    inside = changed(j, scan=p.scan_mask & ~(1 << p.run_start), run=p.run_len - 1,
                     tap=p.tap + 1, chosen_tap=p.tap + 1)
    assert inside == []
    assert "pass mask" in changed(j, scan=p.scan_mask | 1 << (p.run_start - 1))[0]
    assert "chosen_tap" in changed(0, chosen_tap=pred[0].tap + 1)[0]
    assert "walk" in changed(0, walk=full >> 1, walk_ok=0)[0]
    dead = len(link.lanes) - 1
    assert any("no error" in e for e in changed(dead, error=0))


def _drift_link(w=12):
    """Four 12-bit 7-series lanes, eyes 13-16 taps: lane 0's eye drifts 6 taps up, lane 1's
    6 down (over 1200 words from just after the data start), lanes 2, 3 stay."""
    phy, rate, tap = "xilinx7", lvds_pins.rate_for_ui(UI), tap_ps("xilinx7")
    rng = np.random.default_rng(46)
    nd = lvds.training_words(w, 16, 8) + 100
    lanes = []
    for i, (drift, lo, hi) in enumerate(((6, 2, 6), (-6, 11, 15), (0, 4, 14), (0, 4, 14))):
        while True:
            lane = lvds.Lane(skew_ps=float(rng.uniform(0, w * UI / 1000)),
                             eye_ps=float(rng.uniform(13, 16)) * tap, tap_ps=tap,
                             bit_rate_mbps=rate, seed=460 + i, drift_taps=float(drift),
                             drift_from=nd + 50 if drift else 0, drift_words=1200)
            p = lvds_pins.predict(lvds.Link([lane], word_bits=w), phy, jitter=False)[0]
            if p.locked and lo <= p.run_start <= hi and p.run_start + p.run_len + 6 < 32:
                lanes.append(lane)
                break
    return lvds.Link(lanes, word_bits=w, line_words=32, schedule=((nd, "data"),)), nd


@functools.lru_cache(maxsize=None)
def _drift_run(track, sim="icarus"):
    link, nd = _drift_link()
    return link, nd, lvds_pins.run_pins(link, "xilinx7", cycles=nd + 1500, sim=sim,
                                        track=track)


def test_pins_drift_tracking(sim):
    """Tracking behind the 7-series PHY from the pins (12-bit words: the monitor sampler in
    each pair's N pin, IBUFDS_DIFF_OUT -> IDELAYE2 -> ISERDESE2): eyes drifting 6 taps up
    and 6 down are followed without losing a word (every word sent from the data start
    delivered, no lane error), with the corrections the golden model (tracking margin 4)
    makes: the same count, final tap and each correction's effect word; without tracking
    the lane drifting up errors, as the golden model says (Icarus; Verilator with
    TDICAM_FULL=1)."""
    if sim != "icarus" and not FULL:
        pytest.skip("TDICAM_FULL=1: on Verilator too")
    link, nd, on = _drift_run(4, sim)
    ks, syncs, data = on.outputs
    assert len(ks) > 1000 and syncs[0] and np.array_equal(ks, ks[0] + np.arange(len(ks)))
    for i, f in enumerate(on.final):
        assert (f["locked"], f["error"]) == (1, 0), f"lane {i}: {f}"
        np.testing.assert_array_equal(data[:, i], lvds.sent_words(link, i, nd + np.arange(
            len(ks))), err_msg=f"lane {i}")
    phase = lvds_pins.run_phase(link, "xilinx7", on)
    gold = lvds_pins.predict(link, "xilinx7", word_phase=phase, jitter=False, track=4,
                             k_stop=on.cycles)
    assert [(f["tap"], f["slip"], f["corrections"]) for f in on.final] == \
        [(p.tap, p.slip, p.count) for p in gold]
    assert on.corrections == sorted((e, i, t) for i, p in enumerate(gold)
                                    for _, t, e in p.corrections)
    assert gold[0].count == 6 and gold[1].count >= 1 and not gold[2].count
    _, _, off = _drift_run(0, sim)
    gold = lvds_pins.predict(link, "xilinx7", word_phase=phase, jitter=False,
                             k_stop=off.cycles)
    assert [(f["locked"], f["error"]) for f in off.final] == \
        [(int(p.locked), int(p.error)) for p in gold]
    assert (off.final[0]["locked"], off.final[0]["error"]) == (0, 1) and not off.corrections
