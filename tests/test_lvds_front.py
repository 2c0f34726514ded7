"""The camera's front end: sensor frames -> LVDS lanes -> pixel stream (issue 30).

Golden model (:mod:`tdicam.model.lvds_front`), the ``[sensor.lvds]`` scene section and its
effect row, and :class:`tdicam.hdl.lvds_front.LvdsFront` in Amaranth's simulator with two
clocks (:mod:`tdicam.cosim.lvds_front`): the clock-domain crossing at the worst rate ratio
the format allows (word clock faster and slower than the processing clock's share), a lane
whose eye is too narrow to train, a lane that dies mid-run and the retrain after it.
"""

import numpy as np
import pytest

from tdicam.cosim.lvds_front import FrontCase, frames_of, run_amaranth
from tdicam.errors import TdicamError
from tdicam.model import lvds as model
from tdicam.model import lvds_front as front

L, G, C, R = 4, 2, 16, 3          # 4 lanes a gain, 2 gains, 16 columns: P = 4 words a line
# eye centre, width (taps), whole-word delay: every lane trains (widths >= 12 taps)
GOOD = [(10, 14, 0), (12, 16, 1), (8, 12, 0), (20, 15, 2), (14, 18, 0), (9, 13, 1),
        (16, 20, 0), (11, 14, 1)]


def _frames(nf, seed=3, bits=12):
    rng = np.random.default_rng(seed)
    fr = [rng.integers(0, 1 << bits, (nf, R, C)) for _ in range(G)]
    fr[0][0, 0, 0] = (1 << bits) - 1          # full scale: sent as one less (sync code)
    return fr


def _lanes(spec=GOOD, over=None):
    return [front.eye_lane(c, w, word_delay=d, seed=i, **(over or {}).get(i, {}))
            for i, (c, w, d) in enumerate(spec)]


# ---------------------------------------------------------------- golden model, format
def test_lane_payload_is_the_line_format():
    fr = _frames(2)
    pay = front.lane_payload(fr, L, 12)
    assert len(pay) == G * L and all(len(p) == 2 * R * (C // L + 2) for p in pay)
    lw = C // L + 2
    for g in range(G):
        for k in range(L):
            words = pay[g * L + k].reshape(2, R, lw)
            assert (words[:, :, 0] == 0xFFF).all()
            assert (words[:, :, 1] == np.arange(R)).all()
            assert np.array_equal(words[:, :, 2:], front.wire_code(fr[g][:, :, k::L], 12))
    assert front.wire_code([4095, 4094, 0], 12).tolist() == [4094, 4094, 0]
    # the link model carries the payload in its data segments, sync words included
    link = model.Link(_lanes(), word_bits=12, line_words=lw, schedule=((50, "data"),),
                      payload=pay)
    n = np.arange(50, 50 + 2 * R * lw)
    assert np.array_equal(model.sent_words(link, 5, n), pay[5])
    assert (model.sent_words(link, 5, np.arange(50)) == link.train_word).all()
    # past the payload: the link model's own data, sync every line
    after = model.sent_words(link, 5, np.arange(50 + 2 * R * lw, 50 + 4 * R * lw))
    assert (after[::lw] == 0xFFF).all()


def test_invalid_columns_follow_the_convention():
    inv = front.invalid_columns([1, 6], C, L, G)
    assert np.flatnonzero(inv[0]).tolist() == [1, 5, 9, 13]
    assert np.flatnonzero(inv[1]).tolist() == [2, 6, 10, 14]
    px, inv2 = front.receive(_frames(1), [6], L, 12)
    assert (px[1][..., 2::4] == 0).all() and np.array_equal(inv2, front.invalid_columns(
        [6], C, L, G))


def test_fifo_depth_from_the_rates():
    # P = 4: the processing side must take >= 4/6 of the word rate's entries
    assert front.fifo_depth(4, 1, 16, 25.0, 100.0) == 8         # r = 1: slack only
    assert front.fifo_depth(40, 8, 5120, 25.0, 130.0) == 8       # GMAX0504, r = 1.04
    assert front.fifo_depth(40, 8, 5120, 25.0, 124.0) == 16      # r = 0.992: 128 x 0.008
    assert front.fifo_depth(4, 2, 16, 25.0, 100.0 / 3) == 16     # r = 4/6: 2 + 8 -> 16
    with pytest.raises(TdicamError, match="needs >= 123.1 MHz"):
        front.fifo_depth(40, 8, 5120, 25.0, 120.0)                # below P / (P + 2)
    with pytest.raises(TdicamError, match="needs >= 33.33 MHz"):
        front.fifo_depth(4, 2, 16, 25.0, 33.0)
    with pytest.raises(TdicamError, match="does not divide the 18 columns"):
        front.check_geometry(18, 4, 4, 12, 12)


# ---------------------------------------------------------------- gateware, two clocks
def _check_released(res, frames, bad, order=None):
    got = frames_of(res["beats"], R, C, res.get("ppc", 1), G)
    exp, _ = front.receive(frames, bad, L, 12)
    if order is not None:
        exp = exp[:, order]
    assert got.shape == exp.shape
    assert np.array_equal(got, exp)


# word clock faster (r = 4/6, the bound) and slower (r = 5.6) than the processing side's share
@pytest.mark.parametrize("word_ns,proc_ns,ppc,ready", [(12.0, 9.0, 2, 1.0),
                                                      (100.0, 9.0, 2, 0.5),
                                                      (60.0, 10.0, 1, 0.8)])
def test_cdc_no_pixel_lost_or_duplicated(word_ns, proc_ns, ppc, ready):
    frames = _frames(5)
    case = FrontCase(frames, _lanes(), L, ppc=ppc, word_ns=word_ns, proc_ns=proc_ns,
                     ready=ready)
    res = run_amaranth(case)
    res["ppc"] = ppc
    st = res["status"]
    assert st["fifo_overflow"] == 0
    assert (st["frames_out"], st["frames_dropped"], st["frames_affected"]) == (5, 0, 0)
    assert res["frame_status"] == [0] * 5
    _check_released(res, frames, [])


def test_narrow_eye_lane_reported_and_its_columns_invalid():
    spec = list(GOOD)
    spec[5] = (12, 6, 0)                       # 6 taps: no run of 9, lane 5 cannot train
    frames = _frames(4)
    case = FrontCase(frames, _lanes(spec), L, word_ns=40.0, proc_ns=10.0)
    gold = case.golden_run()
    bad = [i for i, f in enumerate(gold.final) if f["error"]]
    assert bad == [5]
    res = run_amaranth(case)
    st = res["status"]
    assert st["lane_error"] == 1 << 5 and st["lane_locked"] == 0xFF & ~(1 << 5)
    assert res["frame_status"] == [1 << 5] * 4   # every frame: lane 5's columns invalid
    assert (st["frames_out"], st["frames_affected"]) == (4, 4)
    _check_released(res, frames, bad)          # the other lanes' pixels bit-exact


def test_lane_dies_mid_run_then_retrain():
    """Lane 2 dies in the middle of frame 2: frame 2 is finished with invalid words and
    counted affected, frames 3 and 4 are held (dropped, counted) until the retrain; the
    retrain finds lane 2 dead (error), frames 5..7 come out with its columns invalid."""
    frames = _frames(8, seed=5)
    lw = C // L + 2
    probe = FrontCase(frames, _lanes(), L, segments=(5, 3))
    die_at = probe.segment_starts[0] + int(2.5 * R * lw)
    spec = _lanes(over={2: {"change_at": die_at,
                            "after": model.Lane(skew_ps=0.0, eye_ps=0.0)}})
    case = FrontCase(frames, spec, L, segments=(5, 3), word_ns=40.0, proc_ns=10.0)
    res = run_amaranth(case)
    st = res["status"]
    full = (1 << G * L) - 1
    assert res["frame_status"] == [0, 0, full, 1 << 2, 1 << 2, 1 << 2]
    assert (st["frames_out"], st["frames_dropped"], st["frames_affected"]) == (6, 2, 4)
    assert st["lane_errors"] == 2 and st["need_retrain"] == 0
    assert any(ev[1] == 2 and ev[3] == 1 and ev[0] < case.retrains[0] for ev in res["events"])
    got = frames_of(res["beats"], R, C, 1, G)
    exp, _ = front.receive(frames, [], L, 12)
    assert np.array_equal(got[:, :2], exp[:, :2])              # before the death: exact
    exp_after, _ = front.receive([f[5:] for f in frames], [2], L, 12)
    assert np.array_equal(got[:, 3:], exp_after)               # after the retrain
    # frame 2: the words before the fault are the sensor's (lane 2's columns excepted)
    keep = ~front.invalid_columns([2], C, L, G)
    first_row = got[:, 2, 0]
    assert np.array_equal(first_row[keep], exp[:, 2, 0][keep])


# ---------------------------------------------------------------- scene section and effect
def _scene(lvds=None, **sensor):
    from tdicam.scene.loader import scene_from_dict
    sen = {"columns": 16, "rows": 8, "bits": 12, "full_well_e": 4000.0,
           "gains": [2.0, 1.0], **sensor}
    if lvds is not None:
        sen["lvds"] = lvds
    return scene_from_dict({"orbit": {"altitude_km": 600, "gsd_m": 1.0},
                            "target": {"kind": "flat", "signal_e": 900.0},
                            "sensor": sen, "tdi": {"stages": 2},
                            "pipeline": {"blocks": ["hdr", "tdi"]},
                            "run": {"lines": 6, "fidelity": "exact"}})


@pytest.mark.parametrize("lvds,match", [
    ({"lanes_per_gain": 3}, r"\[sensor.lvds\].lanes_per_gain: 3 does not divide"),
    ({"word_bits": 10}, r"\[sensor.lvds\].word_bits: 10 is narrower than the 12-bit"),
    ({"train_word": 0x555}, r"\[sensor.lvds\].train_word: 0x555 repeats under rotation"),
    ({"eye_width_taps": [10, 12]}, r"eye_width_taps: must be one number or one per lane \(8"),
    ({"eye_centre_taps": 32}, r"eye_centre_taps = 32 is out of range; valid: 0..31"),
    ({"jitter_ps": -1}, r"jitter_ps = -1 is out of range"),
    ({"mapping": "blocks"}, r"mapping: must be one of 'interleaved', got 'blocks'"),
    ({"lanes": 4}, r"\[sensor.lvds\].lanes: unknown key"),
])
def test_scene_section_errors_are_one_line(lvds, match):
    with pytest.raises(TdicamError, match=match) as e:
        _scene({"lanes_per_gain": 4, **lvds})
    assert "\n" not in str(e.value)


def test_scene_defaults_gmax0504_and_no_section_is_ideal():
    sc = _scene({}, columns=80)
    lv = sc.sensor.lvds
    assert (lv.lanes_per_gain, lv.word_bits, lv.bit_rate_mbps, lv.simulate) == (40, 12, 300.0,
                                                                              False)
    assert lv.train_word == model.default_train_word(12)
    plain = _scene()
    assert plain.sensor.lvds is None and "lvds" not in plain.to_dict()["sensor"]


def test_effect_row_and_invalid_columns_in_the_simulator():
    from tdicam.engine import simulate
    base = simulate(_scene(), impact=False, keep_raw=True)
    row = {e.name: e for e in base.effects}["sensor_lanes"]
    assert not row.ran and row.why == "no [sensor.lvds]: ideal lanes, no link simulated"
    # ideal lanes: the same pixels (no code reaches the sync word at this light level)
    ideal = simulate(_scene({"lanes_per_gain": 4}), impact=False)
    assert np.array_equal(ideal.output, base.output)
    assert "no eye given: the link is ideal" in {e.name: e for e in ideal.effects}[
        "sensor_lanes"].why
    # lane 1 (high gain) 6 taps wide: it cannot train, columns 1, 5, 9, 13 of HG are 0
    widths = [14.0] * 8
    widths[1] = 6.0
    sim = simulate(_scene({"lanes_per_gain": 4, "eye_width_taps": widths}), impact=False,
                   keep_raw=True)
    row = {e.name: e for e in sim.effects}["sensor_lanes"]
    assert row.ran and "lanes 1 fail" in row.why
    assert any("lanes 1 did not train" in n for n in sim.notes)
    assert (sim.single[:, 1::4] == 0).all() and (base.single[:, 1::4] > 0).all()
    keep = np.ones(16, bool)
    keep[1::4] = False
    assert np.array_equal(sim.single[:, keep], base.single[:, keep])
