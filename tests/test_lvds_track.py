"""Eye tracking of the LVDS receiver (issue 46 step 5): the link model's slow eye drift, the
tracker's corrections (:mod:`tdicam.hdl.lvds_track`) against its golden model
(:mod:`tdicam.model.lvds_track`), in Amaranth's simulator."""

from dataclasses import replace

import pytest

from tdicam.cosim.lvds import run_amaranth
from tdicam.errors import TdicamError
from tdicam.model import lvds, lvds_front, lvds_track

NC, ST, W = 4, 4, 10
LINE, ROWS, FRAMES = 12, 4, 20


def _link(drift):
    """Three lanes: lane 0's eye (14 taps) drifting ``drift`` taps up over 20 frames of 4
    lines, lane 1's (10 taps) as far down, lane 2 still."""
    d0 = lvds.training_words(W, NC, ST) + 20
    words = FRAMES * ROWS * LINE
    base = [lvds_front.eye_lane(c, wd, word_bits=W, seed=i, word_delay=i % 2)
            for i, (c, wd) in enumerate([(12, 14), (16, 10), (18, 14)])]
    lanes = [replace(base[0], drift_taps=drift, drift_from=d0, drift_words=words),
             replace(base[1], drift_taps=-drift, drift_from=d0, drift_words=words), base[2]]
    return lvds.Link(lanes, word_bits=W, line_words=LINE, schedule=((d0, "data"),)), \
        d0 + words + 60


@pytest.mark.parametrize("track", [4, 0], ids=["tracking", "no_tracking"])
def test_drift_of_6_taps_over_20_frames(track):
    """Eyes drifting 6 taps over 20 frames: with tracking every lane stays locked (0
    errors), the drifting lanes corrected one tap at a time, every correction at the word the
    golden model states; without it the same drift puts both drifting lanes in error, as
    the golden model says."""
    link, cycles = _link(6.0)
    gold = lvds.run(link, cycles=cycles, n_check=NC, settle=ST, track=track)
    final, corr = [], []
    events, outs, _ = run_amaranth(link, cycles, n_check=NC, settle=ST, track=track,
                                   final=final, corrections=corr)
    assert events == gold.events and final == gold.final
    want = sorted((eff, i, t) for i, r in enumerate(gold.trainings[0])
                  for _, t, eff in r.corrections)
    assert sorted(corr) == want == lvds_track.shown(want, cycles, lvds.LINK_LATENCY)
    if track:
        assert [f["error"] for f in final] == [0, 0, 0]
        # lane 0's tap sits 4 taps above its eye's low edge: it follows all 6 taps; lane
        # 1's eye is 10 wide: its tap moves once the high probe leaves the eye (5 taps)
        assert [f["corrections"] for f in final] == [6, 5, 0]
        assert [len(r.corrections) for r in gold.trainings[0]] == [6, 5, 0]
        up = [t for e, i, t in want if i == 0]
        down = [t for e, i, t in want if i == 1]
        assert up == list(range(up[0], up[0] + 6))          # one tap at a time, upwards
        assert down == list(range(down[0], down[0] - 5, -1))
    else:
        assert [f["error"] for f in final] == [1, 1, 0] and corr == []


def test_drift_model_moves_the_eye():
    """The link model's drift: the eye's passing taps move by the stated taps."""
    import numpy as np
    link, cycles = _link(6.0)
    link = lvds.Link(link.lanes, word_bits=W)                  # the training word throughout

    def passing(k):
        return [t for t in range(lvds.N_TAPS)
                if len(set(lvds.lane_words(link, 0, t, 0, np.arange(k, k + 16)).tolist())) == 1]
    before, after = passing(0), passing(cycles)
    # lane 0: an eye of 14 taps centred on tap 12 (taps 6..19), 6 taps up at the end
    assert [t for t in before if 4 < t < 26] == list(range(6, 20))
    assert [t for t in after if 4 < t < 30] == list(range(12, 26))


def test_drift_errors_are_one_line():
    with pytest.raises(TdicamError, match="drifts .* or changes"):
        lvds.Lane(skew_ps=0, eye_ps=2000, drift_taps=2, drift_words=10, change_at=5,
                  after=lvds.Lane(skew_ps=0, eye_ps=0))
    with pytest.raises(TdicamError, match="drift_words = 0 must be >= 1"):
        lvds.Lane(skew_ps=0, eye_ps=2000, drift_taps=2)


def test_scene_keys_and_refusals_are_one_line():
    """[sensor.lvds] drift_taps / drift_frames / tracking: read next to the other keys,
    bad values refused in one line naming the key; tracking needs the generic PHY."""
    from tdicam import blocks
    from tdicam.scene.loader import scene_from_dict
    base = {"orbit": {"altitude_km": 600.0, "gsd_m": 5.0},
            "sensor": {"columns": 16, "rows": 100, "bits": 10, "gains": [4.9, 0.8],
                       "lvds": {"lanes_per_gain": 2, "drift_taps": [6, -6, 0, 6],
                                "drift_frames": 20, "tracking": True}}}
    lv = scene_from_dict(base).sensor.lvds
    assert (lv.drift_taps, lv.drift_frames, lv.tracking, lv.simulate) == \
        ((6.0, -6.0, 0.0, 6.0), 20, True, True)
    for key, value, match in (("drift_taps", [1, 2], "drift_taps: must be one number or one "
                                                     "per lane \\(4"),
                              ("drift_frames", 0, "drift_frames"),
                              ("tracking", "yes", "tracking: must be true or false")):
        bad = {**base, "sensor": {**base["sensor"],
                                  "lvds": {**base["sensor"]["lvds"], key: value}}}
        with pytest.raises(TdicamError, match=match) as e:
            scene_from_dict(bad)
        assert "\n" not in str(e.value)
    with pytest.raises(TdicamError, match="--track = 4 needs --phy none or xilinx7"):
        blocks.get("lvds").build({"lanes": 2, "phy": "ecp5", "track": 4})
    with pytest.raises(TdicamError, match="--track = 4 with --phy xilinx7 needs --word-bits 12"):
        blocks.get("lvds").build({"lanes": 2, "phy": "xilinx7", "track": 4})


# ---------------------------------------------------------------- property
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from tdicam.cosim.testing import FULL  # noqa: E402


@settings(max_examples=30 if FULL else 3, deadline=None, derandomize=not FULL,
          database=None)
@given(seed=st.integers(0, 1 << 30), word_bits=st.sampled_from([10, 12]),
       margin=st.integers(1, 8), drift=st.lists(st.integers(-8, 8), min_size=3, max_size=3),
       nc=st.integers(1, 6), eye=st.booleans())
def test_tracking_and_eye_status_equal_golden_property(seed, word_bits, margin, drift, nc,
                                                       eye):
    """Random lanes (skew up to a word, eyes 3-20 taps, jitter on or off, either tap size),
    drifting -8..8 taps, a random probe margin and n_check, the eye status and the walking
    round on or off: the gateware's status events, final status (masks, taps, corrections)
    and every correction's effect word equal the golden model's."""
    import numpy as np
    rng = np.random.default_rng(seed)
    tw = lvds.training_words(word_bits, nc, ST)
    d0 = tw + 10 + 2 * word_bits
    words = 400
    lanes = [replace(lvds.random_lane(rng, max_word_delay=1, word_bits=word_bits),
                     drift_taps=float(d), drift_from=d0, drift_words=words) if d else
             lvds.random_lane(rng, max_word_delay=1, word_bits=word_bits) for d in drift]
    sched = ((tw + 10, "walk"), (d0, "data")) if eye else ((d0, "data"),)
    link = lvds.Link(lanes, word_bits=word_bits, line_words=12, schedule=sched)
    cycles = d0 + words + 40
    gold = lvds.run(link, cycles=cycles, n_check=nc, settle=ST, eye=eye, track=margin)
    final, corr = [], []
    events, _, _ = run_amaranth(link, cycles, n_check=nc, settle=ST, eye=eye, track=margin,
                                final=final, corrections=corr)
    assert events == gold.events and final == gold.final
    want = sorted((e, i, t) for i, r in enumerate(gold.trainings[0])
                  for _, t, e in r.corrections)
    assert sorted(corr) == lvds_track.shown(want, cycles, lvds.LINK_LATENCY)
