"""``[run.rtl] phy``: the scene key (refused without ``[sensor.lvds]``) and the check of a
lanes scene's link from serial bits through a device PHY (:mod:`tdicam.chain.phy_check`):
0 mismatches and every tap as predicted; a lane with no eye reported as a lane error, not a
traceback; the report's row. One PHY on Icarus in CI, the other with TDICAM_FULL=1."""

import dataclasses
import functools
import json
import os
from dataclasses import replace

import numpy as np
import pytest

from tdicam.chain.lane_cosim import lanes_of
from tdicam.chain.phy_check import judge, phy_check
from tdicam.errors import TdicamError
from tdicam.run.report import phy_lines
from tdicam.scene.loader import load_scene

SCENE = "scenes/ning2019_gmax0504_system_lanes.toml"
FULL = os.environ.get("TDICAM_FULL") == "1"


def _scene(tmp_path, extra, base=SCENE):
    text = open(base).read().replace("[run.rtl]\n", "[run.rtl]\n" + extra + "\n")
    path = tmp_path / "s.toml"
    path.write_text(text)
    return load_scene(path)


def test_phy_key(tmp_path):
    sc = _scene(tmp_path, 'phy = "ecp5"')
    assert sc.run.rtl.phy == "ecp5"
    assert _scene(tmp_path, "").run.rtl.phy == "generic"
    with pytest.raises(TdicamError, match="phy"):
        _scene(tmp_path, 'phy = "spartan"')
    nolanes = open(SCENE).read().replace("[sensor.lvds]\nlanes_per_gain = 2", "")
    (tmp_path / "n.toml").write_text(nolanes.replace("[run.rtl]\n", '[run.rtl]\nphy = "xilinx7"\n'))
    with pytest.raises(TdicamError, match=r"needs the sensor's lanes"):
        load_scene(tmp_path / "n.toml")


@pytest.mark.parametrize("phy", ["xilinx7", "ecp5"])
def test_phy_check(tmp_path, phy):
    """The scene's 4 lanes from serial bits: 0 mismatches, taps as predicted; with lane 1's
    eye closed, that lane's error in the row (and the others still bit-exact)."""
    if phy == "ecp5" and not FULL:
        pytest.skip("TDICAM_FULL=1: the ECP5 PHY too")
    sc = _scene(tmp_path, f'phy = "{phy}"')
    lv = sc.sensor.lvds
    row = phy_check(lv, lanes_of(lv, 2), phy, "icarus")
    assert row["status"] == "ran", row
    assert (row["lanes"], row["mismatches"], row["taps_as_predicted"], row["lane_errors"],
            row["problems"]) == (4, 0, True, [], []), row
    assert row["words_compared"] > 4 * 200
    lanes = lanes_of(lv, 2)
    lanes[1] = replace(lanes[1], eye_ps=0.0)
    bad = phy_check(lv, lanes, phy, "icarus")
    assert (bad["mismatches"], bad["taps_as_predicted"], bad["lane_errors"]) == \
        (0, True, [1]), bad
    md = "\n".join(phy_lines([row, bad]))
    assert f"| {phy} | icarus | 4 |" in md and "| 1 (as predicted) |" in md


def test_judge_fails():
    """The judgement names a lane trained 3 taps off the prediction and a changed word."""
    import dataclasses
    from tdicam.cosim import lvds_pins
    from tdicam.hdl.lvds_phy import tap_ps
    from tdicam.model import lvds
    phy, rate = "xilinx7", lvds_pins.rate_for_ui(3333333)
    lv = load_scene(SCENE).sensor.lvds
    lanes = [dataclasses.replace(ln, tap_ps=tap_ps(phy), bit_rate_mbps=rate)
             for ln in lanes_of(lv, 2)]
    nd = lvds.training_words(lv.word_bits, 16, 8) + 100
    link = lvds.Link(lanes, word_bits=lv.word_bits, train_word=lv.train_word, line_words=32,
                     schedule=((nd, "data"),))
    pred = lvds_pins.predict(link, phy, word_phase=lvds_pins.WORD_PHASE[phy, lv.word_bits][0],
                             jitter=False)
    ks = 1000 + np.arange(50)
    data = np.stack([lvds.sent_words(link, i, nd + np.arange(50)) for i in range(4)], axis=1)
    final = [{"tap": p.tap, "slip": p.slip, "locked": 1, "error": 0, "scan": p.scan_mask}
             for p in pred]
    good = lvds_pins.PinRun(final, (ks, np.ones(50, bool), data), 0.0, 0.0, nd + 60)
    assert judge(link, phy, good, nd)["problems"] == []
    final[2] = dict(final[2], tap=pred[2].tap + 3)
    data = data.copy()
    data[7, 1] ^= 1
    bad = judge(link, phy, dataclasses.replace(good, final=final, outputs=(ks, np.ones(50, bool),
                                                                             data)), nd)
    assert not bad["taps_as_predicted"] and bad["mismatches"] == 1
    assert any(t.startswith("lane 2: tap") for t in bad["problems"])


def test_phy_check_error_row():
    """A link the PHY cannot take is the row's status, not a traceback."""
    from tdicam.scene.schema import Lvds
    lv = Lvds(lanes_per_gain=1, word_bits=12, bit_rate_mbps=300.0, mapping="x", train_word=1,
              tap_ps=78.125, eye_centre_taps=(16.0,), eye_width_taps=(20.0,), jitter_ps=0.0,
              simulate=True)
    row = phy_check(lv, lanes_of(lv, 1), "generic-not-a-phy", "icarus")
    assert row["status"].startswith("error: ")
    assert "| generic-not-a-phy | icarus | error" in "\n".join(phy_lines([row]))


PINS = "scenes/ning2019_gmax0504_system_lanes_pins.toml"


@pytest.mark.parametrize("phy", ["xilinx7", "ecp5"])
def test_bundled_pins_scene(phy):
    """The bundled board-like lanes (skew up to a whole word, eyes down to 11 taps, 60 ps of
    jitter) from serial bits through each PHY: 0 mismatches, every lane at its predicted
    tap, none in error; the skews span a word (lane 3 one word behind lane 0)."""
    from tdicam.model import lvds
    sc = load_scene(PINS).replace({"run.rtl.phy": phy})
    lv = sc.sensor.lvds
    assert (sc.run.rtl.phy, lv.skew_bits, min(lv.eye_width_taps), lv.jitter_ps) == \
        (phy, (0, 5, 11, 12), 11.0, 60.0)
    lanes = lanes_of(lv, 2)
    ui = 1e6 / lv.bit_rate_mbps
    assert lanes[3].skew_ps - lanes[0].skew_ps > (lv.word_bits - 1) * ui
    row = phy_check(lv, lanes, phy, "icarus")
    assert row["status"] == "ran", row
    assert (row["mismatches"], row["taps_as_predicted"], row["lane_errors"],
            row["problems"]) == (0, True, [], []), row
    # the skew is felt: without it the same eyes train to other slips / deliver other words
    link = lvds.Link(lanes, word_bits=lv.word_bits, train_word=lv.train_word)
    delays = [lvds.train_lane(link, i, 0).word_delay for i in range(4)]
    assert delays[3] != delays[0], delays


@pytest.mark.parametrize("value, msg", [
    (13, r"skew_bits.*13"),
    ([0, 1, 2], r"skew_bits: must be one number or one per lane \(4"),
    (1.5, r"skew_bits.*integer"),
    (-1, r"skew_bits.*-1"),
])
def test_skew_bits_refused(value, msg):
    """skew_bits: whole bits, 0 .. a word, one or one per lane; else one line naming it."""
    with pytest.raises(TdicamError, match=msg) as e:
        load_scene(PINS).replace({"sensor.lvds.skew_bits": value})
    assert "\n" not in str(e.value)


@pytest.mark.skipif(not FULL, reason="TDICAM_FULL=1: tdicam run of the bundled pins scene")
def test_run_pins_scene(tmp_path):
    """``tdicam run`` of the bundled pins scene: every tap of the chain's co-simulation
    (generic PHY) and the lanes from serial bits (xilinx7) with 0 mismatches."""
    from tdicam.run.runner import run_scene
    rep = run_scene(load_scene(PINS), tmp_path, impact=False, progress=False)
    rtl = rep["rtl"]
    (row,) = rtl["phy_checks"]
    assert (row["phy"], row["mismatches"], row["taps_as_predicted"], row["lane_errors"]) == \
        ("xilinx7", 0, True, []), row
    assert len(rtl["blocks"]) == 10 and all((b["status"], b["mismatches"]) == ("ran", 0)
                                            for b in rtl["blocks"]), rtl["blocks"]
    # the eye status from the device PHY (eye_status): every lane's mask, tap and walking
    # check as predicted, the picture beside the chain's
    assert row["problems"] == [] and [e["agree"] for e in row["eyes"]] == [True] * 4
    assert [e["mask"] for e in row["eyes"]] == row["scans"]
    assert {"eyes.png", "eyes_xilinx7.png"} <= set(rep["files"])
    md = (tmp_path / "report.md").read_text()
    assert "picture eyes_xilinx7.png" in md and "lane 1 (xilinx7): locked, eye " in md


DRIFT = "scenes/ning2019_gmax0504_system_lanes_drift.toml"
#: The drift's span for the CI form: the drift scene's 20 frames as its co-simulation sends
#: them (the 32-column crop's frames of 8 rows x 18 words a lane); ``tdicam run`` passes
#: the chain's own (test_run_drift_scene).
DRIFT_WORDS = 20 * 8 * 18


def _as_row(row):
    """A judgement as phy_check's row (the run's own keys added)."""
    return dict(row, phy="xilinx7", simulator="icarus", status="ran", wall_seconds=1.0)


@functools.lru_cache(maxsize=None)
def _drift_run(tracking):
    """The drift scene's lanes from the pins (xilinx7, Icarus), tracking on or off: the
    link, its data start, the run and the row."""
    from tdicam.chain.phy_check import pin_link
    from tdicam.cosim import lvds_pins
    sc = load_scene(DRIFT).replace({"sensor.lvds.tracking": tracking})
    lv = sc.sensor.lvds
    link, nd, cycles, track, _ = pin_link(lv, lanes_of(lv, 2), "xilinx7",
                                          drift_words=DRIFT_WORDS)
    res = lvds_pins.run_pins(link, "xilinx7", cycles=cycles, sim="icarus", eye=True,
                             track=track)
    return link, nd, res, judge(link, "xilinx7", res, nd, track=track, eye=True)


def test_drift_from_pins_tracking():
    """The drift scene from serial bits through the 7-series receiver with tracking: eyes
    drifting 6 taps (up, down, still, up) over 20 frames' words: 0 mismatches, no lane in
    error, every correction (count, new tap, effect word) the golden tracker's, one tap at a
    time towards the drift; the device's eye status in the row (masks, the trained and the
    tracked tap) as predicted."""
    from tdicam.commands.run import rtl_failed
    from tdicam.cosim import lvds_pins
    link, nd, res, row = _drift_run(True)
    assert (row["mismatches"], row["taps_as_predicted"], row["lane_errors"],
            row["problems"], row["corrections_as_predicted"]) == (0, True, [], [], True), row
    assert row["words_compared"] > 4 * DRIFT_WORDS
    gold = lvds_pins.predict(link, "xilinx7", word_phase=lvds_pins.run_phase(link, "xilinx7",
                                                                              res),
                             jitter=False, track=4, k_stop=res.cycles, eye=True)
    assert [len(c) for c in row["corrections"]] == [p.count for p in gold]
    for lane, c in zip(link.lanes, row["corrections"]):
        taps = [t for _, t in c]
        sign = int(np.sign(lane.drift_taps))
        assert taps == [taps[0] + sign * j for j in range(len(taps))]
        assert bool(taps) == bool(sign)
    for e, f, lane, c in zip(row["eyes"], res.final, link.lanes, row["corrections"]):
        assert (e["mask"], e["tap"], e["agree"], e["walk_ok"]) == (f["scan"], f["tap"], True,
                                                                   True)
        assert e["tap"] == e["trained_tap"] + int(np.sign(lane.drift_taps)) * len(c)
    assert not rtl_failed({"blocks": [], "phy_checks": [_as_row(row)]})
    md = "\n".join(phy_lines([_as_row(row)]))
    assert "| xilinx7 | icarus | 4 |" in md and "(as predicted)" in md
    assert f"* lane 0: {gold[0].count} correction(s): " in md
    assert md.count("as the golden tracker predicts") == 4


def test_drift_from_pins_no_tracking():
    """The same drift without tracking: the drifting lanes in error at the end, as the
    golden model predicts (the row's lane errors, no problem: not a failure of the run),
    their words judged up to their predicted first wrong word, the still lane's all."""
    from tdicam.commands.run import rtl_failed
    link, nd, res, row = _drift_run(False)
    drifting = [i for i, ln in enumerate(link.lanes) if ln.drift_taps]
    assert (row["mismatches"], row["taps_as_predicted"], row["problems"]) == (0, True, []), row
    assert row["lane_errors"] == drifting and "corrections" not in row
    assert sorted(int(i) for i in row["words_judged_until"]) == drifting
    assert all(100 < n < len(res.outputs[0]) for n in row["words_judged_until"].values())
    assert not rtl_failed({"blocks": [], "phy_checks": [_as_row(row)]})
    md = "\n".join(phy_lines([_as_row(row)]))
    assert f"{', '.join(map(str, drifting))} (as predicted)" in md


def test_drift_judge_fails():
    """The judgement of a drift names a correction one probe pair late, a lost correction
    and a changed word before the predicted error; the run then fails."""
    from tdicam.commands.run import rtl_failed
    from tdicam.model import lvds_track
    link, nd, res, row = _drift_run(True)
    q = 2 * lvds_track.probe_words(8, 16)
    corr = list(res.corrections)
    e, lane, t = corr[2]
    late = dataclasses.replace(res, corrections=corr[:2] + [(e + q, lane, t)] + corr[3:])
    bad = judge(link, "xilinx7", late, nd, track=4, eye=True)
    assert not bad["corrections_as_predicted"]
    assert any(p.startswith(f"lane {lane}: corrections") for p in bad["problems"])
    assert rtl_failed({"blocks": [], "phy_checks": [_as_row(bad)]})
    lost = dataclasses.replace(res, corrections=corr[1:])
    assert judge(link, "xilinx7", lost, nd, track=4, eye=True)["problems"]
    link, nd, res, row = _drift_run(False)
    i = int(next(iter(row["words_judged_until"])))
    ks, syncs, data = res.outputs
    data = data.copy()
    data[row["words_judged_until"][str(i)] - 1, i] ^= 1
    off = judge(link, "xilinx7", dataclasses.replace(res, outputs=(ks, syncs, data)), nd,
                eye=True)
    assert off["mismatches"] == 1 and off["problems"] == [f"lane {i}: 1 words differ from "
                                                          f"those sent"]


def test_tracking_phy_refused():
    """Tracking from the pins needs the 7-series PHY with 12-bit words: ecp5 (or 10-bit
    words) with tracking refused when the scene is read, in one line."""
    for change, what in (({"run.rtl.phy": "ecp5"}, "ecp5"),
                         ({"sensor.lvds.word_bits": 10, "sensor.rows": 1000},
                          "word_bits = 10")):
        with pytest.raises(TdicamError, match=rf"phy.*{what}.*tracks from serial bits only "
                                              r"as xilinx7 with 12-bit words") as e:
            load_scene(DRIFT).replace(change)
        assert "\n" not in str(e.value)


@pytest.mark.skipif(not FULL, reason="TDICAM_FULL=1: tdicam run of the bundled drift scene")
def test_run_drift_scene(tmp_path):
    """``tdicam run`` of the bundled drift scene: the chain's co-simulation (generic PHY,
    tracking) with 0 mismatches, and the same lanes drifting the same 6 taps over the same
    20 frames' words from serial bits through the 7-series receiver with tracking: 0
    mismatches, no lane in error, every correction the golden tracker's, listed in
    report.json and report.md; the device's eye picture written; exit status 0."""
    from tdicam.commands.run import rtl_failed
    from tdicam.run.runner import run_scene
    rep = run_scene(load_scene(DRIFT), tmp_path, impact=False, progress=False)
    rtl = rep["rtl"]
    (row,) = rtl["phy_checks"]
    assert (row["phy"], row["mismatches"], row["taps_as_predicted"], row["lane_errors"],
            row["problems"], row["corrections_as_predicted"]) == \
        ("xilinx7", 0, True, [], [], True), row
    chain = rtl["blocks"][-1]
    assert row["drift"]["words"] == chain["lanes"]["drift_words"]
    assert row["drift"]["taps"] == [6.0, -6.0, 0.0, 6.0]
    assert [bool(c) for c in row["corrections"]] == [True, True, False, True]
    assert not rtl_failed(rtl) and "eyes_xilinx7.png" in rep["files"]
    saved = json.loads((tmp_path / "report.json").read_text())["rtl"]["phy_checks"][0]
    assert saved["corrections"] == row["corrections"]
    md = (tmp_path / "report.md").read_text()
    for i, c in enumerate(row["corrections"]):
        text = ", ".join(f"{e} ({t})" for e, t in c) or "none"
        assert f"* lane {i}: {len(c)} correction(s): {text}; as the golden tracker " \
               f"predicts" in md
