"""``[run.rtl] phy``: the scene key (refused without ``[sensor.lvds]``) and the check of a
lanes scene's link from serial bits through a device PHY (:mod:`tdicam.chain.phy_check`):
0 mismatches and every tap as predicted; a lane with no eye reported as a lane error, not a
traceback; the report's row. One PHY on Icarus in CI, the other with TDICAM_FULL=1."""

import os
from dataclasses import replace

import numpy as np
import pytest

from tdicam.chain.cosim import lanes_of
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
    assert f"| {phy} | icarus | 4 |" in md and "| 1 |" in md


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
    good = lvds_pins.PinRun(final, (ks, np.ones(50, bool), data), 0.0, 0.0, 1)
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
