"""Serial-bit co-simulation of the ``xilinx7`` and ``ecp5`` receivers
(:mod:`tdicam.cosim.lvds_pins`), on Icarus and Verilator: 8 lanes driven from their pins
with skew up to a whole word plus a fraction of a bit, random jitter on half of them,
duty-cycle distortion on a third, eyes of 11-22 taps, and a lane with no eye. Each lane must
train as the golden link model predicts (tap and bitslip; a jittered lane's tap up to its
random band later), the lane with no eye must report its error, and every locked lane must
deliver, from the data start, exactly the words sent: what the generic PHY delivers.
"""

import functools

import numpy as np
import pytest

from tdicam.cosim import lvds_pins
from tdicam.hdl.lvds_phy import tap_ps
from tdicam.model import lvds

#: The word phase of each PHY's deserializer (bits): the PHY's raw words are samples
#: (k - L) W + phase .. of the link model's sample numbering.
WORD_PHASE = {("xilinx7", 10): 0, ("xilinx7", 12): 6, ("ecp5", 10): 1, ("ecp5", 12): 1}
UI = 3333333          # fs: 300 Mb/s


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


def _link(phy, w, seed, n=8):
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
    link = lvds.Link(lanes, word_bits=w, line_words=32, schedule=((nd, "data"),))
    return link, tuple(dcd), nd


@functools.lru_cache(maxsize=None)
def _run(phy, w, sim):
    link, dcd, nd = _link(phy, w, seed=w + len(phy))
    return link, dcd, nd, lvds_pins.run_pins(link, phy, dcd=dcd, cycles=nd + 600, sim=sim)


def _check(phy, w, sim):
    link, dcd, nd, res = _run(phy, w, sim)
    pred = lvds_pins.predict(link, phy, dcd=dcd, word_phase=WORD_PHASE[phy, w], jitter=False)
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
    ks, syncs, data = res.outputs
    assert len(ks) > 500 and syncs[0] and np.array_equal(ks, ks[0] + np.arange(len(ks)))
    for i in range(len(link.lanes)):
        exp = lvds.sent_words(link, i, nd + np.arange(len(ks))) if i in locked else 0
        np.testing.assert_array_equal(data[:, i], exp, err_msg=f"{phy} lane {i}")
    return res


@pytest.mark.parametrize("phy", sorted(lvds_pins.PIN_PHYS))
def test_pins_10bit(phy, sim):
    """10-bit words from the pins: train, lock, deliver the sent words bit-exact."""
    _check(phy, 10, sim)


@pytest.mark.parametrize("phy", sorted(lvds_pins.PIN_PHYS))
def test_pins_12bit_icarus(phy):
    """12-bit words (7-series: DATA_WIDTH 6 and the 2:1 fabric gearbox; ECP5: three SCLK
    cycles a word), Icarus."""
    _check(phy, 12, "icarus")


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
