"""Co-simulation of the generated ``lvds`` Verilog against the link model and golden model.

Every test runs on Icarus and Verilator (fixture ``sim``). The testbench evaluates the link
model in HDL (see :mod:`tdicam.cosim.lvds`); ``test_link_matches_model`` proves it serves
exactly the words of :func:`tdicam.model.lvds.raw_words`.

Random lanes: Verilator runs the full form (500 lanes of 10-bit words and 104 lanes of
12-bit words, each trained then >= 10^4 checked words); Icarus (0.5-2 k word clocks/s for
8 lanes) runs 504 lanes' training and 64 checked words each in CI, and the full form
behind ``@pytest.mark.slow`` (``TDICAM_FULL=1``).
"""

import functools
import os

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.blocks.lvds import link_from_arrays
from tdicam.cosim.lvds import check_run, expected_outputs, linkcheck_tap, run_link
from tdicam.model import lvds

CASES = [c.name for c in blocks.get("lvds").cases()]
FULL = os.environ.get("TDICAM_FULL") == "1"
DATA_WORDS = 10_000


@functools.lru_cache(maxsize=None)
def _run_case(name, sim):
    """Simulate golden case ``name`` once per simulator (later tests reuse the run)."""
    arrays, params = golden.load("lvds", name)
    link, cycles, retrains, n_check = link_from_arrays(arrays)
    gold = lvds.run(link, cycles=cycles, retrains=retrains, n_check=n_check,
                    settle=params["settle"], min_run=params["min_run"], pick=params["pick"])
    res = run_link(link, params=params, cycles=cycles, retrains=retrains, n_check=n_check,
                   sim=sim)
    return arrays, link, gold, res, cycles, retrains


@pytest.mark.parametrize("case", CASES)
def test_golden_case(case, sim):
    """Status events (cycle exact), final status and deskewed words equal the golden model."""
    arrays, link, gold, res, cycles, retrains = _run_case(case, sim)
    got_events = np.array(res.events, np.int64).reshape(-1, 7)
    np.testing.assert_array_equal(got_events, arrays["events"])
    for key in ("tap", "slip", "locked", "error", "run", "scan"):
        got = np.array([f[key] for f in res.final], arrays[key].dtype)
        np.testing.assert_array_equal(got, arrays[key], err_msg=f"{case}: lane {key}")
    assert check_run(link, res, gold, cycles=cycles, retrains=retrains) == []
    locked = arrays["locked"].astype(bool)
    for grp, gl in enumerate(res.globals):
        ids = range(grp * res.lanes, min((grp + 1) * res.lanes, len(link.lanes)))
        mask = sum(1 << (i - grp * res.lanes) for i in ids if locked[i])
        assert gl["mask"] == mask, f"group {grp}: lane mask"
        assert gl["trained"] == 1


def test_windows_policies(sim):
    """Clipped windows, widest window, tie to the first, too narrow, dead, flicker."""
    arrays, *_ = _run_case("windows_10b", sim)
    assert arrays["tap"].tolist()[:4] == [4, 24, 5, 0]
    assert arrays["locked"].tolist() == [1, 1, 1, 0, 1, 0, 0, 1, 1]
    assert arrays["error"].tolist() == [0, 0, 0, 1, 0, 1, 1, 0, 0]
    assert arrays["run"].tolist()[:5] == [12, 12, 9, 8, 14]


def test_retrain_and_dying_lanes(sim):
    """Skew change after lock is reported, retrain recovers at another tap; a lane dying
    after lock or during the bitslip search is reported; a lane reviving locks on retrain."""
    arrays, link, gold, res, cycles, (kr,) = _run_case("retrain_10b", sim)
    ev = [tuple(e) for e in arrays["events"].tolist()]
    by_lane = {i: [e for e in ev if e[1] == i] for i in range(len(link.lanes))}
    # lane 0: locks, errors after its skew jump, relocks after the retrain at another tap
    l0 = by_lane[0]
    assert [e[2:4] for e in l0] == [(1, 0), (0, 1), (0, 0), (1, 0)]
    assert l0[1][0] < kr < l0[3][0] and l0[0][4] != l0[3][4]
    # lane 1 dies after lock; lane 2 dies during the bitslip search (error, never locked)
    assert [e[2:4] for e in by_lane[1]][:2] == [(1, 0), (0, 1)]
    assert [e[2:4] for e in by_lane[2]][0] == (0, 1) and by_lane[2][0][0] < kr
    # lane 3: dead at first, alive after the retrain
    assert [e[2:4] for e in by_lane[3]] == [(0, 1), (0, 0), (1, 0)]
    assert res.final[0]["locked"] == 1 and res.final[3]["locked"] == 1


def test_deskew_spans_three_words(sim):
    """The deskew case really has lanes up to 3 words apart and they leave aligned."""
    arrays, link, gold, res, cycles, retrains = _run_case("deskew_8lanes", sim)
    delays = [r.word_delay for r in gold.trainings[0]]
    assert max(delays) - min(delays) >= 3
    ks, syncs, data = res.outputs[0]
    assert len(ks) > 500 and syncs[0] and syncs.sum() == len(range(0, len(ks), 32))
    assert check_run(link, res, gold, cycles=cycles) == []


def test_link_matches_model(sim):
    """The testbench's link serves, word for word, the raw words of the Python link model
    (random lanes with jitter, a lane change, training then data)."""
    rng = np.random.default_rng(21)
    lanes = [lvds.random_lane(rng, max_word_delay=3) for _ in range(15)]
    lanes.append(lvds.Lane(skew_ps=500.0, eye_ps=2000.0, jitter_ps=400.0, seed=9,
                           change_at=150, after=lvds.Lane(skew_ps=1700.0, eye_ps=900.0,
                                                          jitter_ps=150.0)))
    link = lvds.Link(lanes, line_words=7, schedule=((100, "data"), (220, "train"),
                                                    (260, "data")))
    res = run_link(link, cycles=400, sim=sim, linkcheck=True)
    for grp, (ks, _, data) in enumerate(res.outputs):
        assert np.array_equal(ks, np.arange(400))
        for j in range(res.lanes):
            taps = np.where(ks >= 2, linkcheck_tap(ks - 2, j), 0)
            exp = lvds.raw_words(link, grp * res.lanes + j, taps, ks)
            np.testing.assert_array_equal(data[:, j], exp, err_msg=f"lane {grp * 8 + j}")


def _random_link(n, word_bits, seed, n_check, words):
    rng = np.random.default_rng(seed)
    lanes = [lvds.random_lane(rng, max_word_delay=1, word_bits=word_bits) for _ in range(n)]
    nd = lvds.training_words(word_bits, n_check, 8) + 16
    link = lvds.Link(lanes, word_bits=word_bits, line_words=64, schedule=((nd, "data"),))
    return link, nd + words + 16


def _check_random(n, word_bits, seed, *, n_check, words, sim):
    link, cycles = _random_link(n, word_bits, seed, n_check, words)
    params = {"word_bits": word_bits}
    gold = lvds.run(link, cycles=cycles, n_check=n_check)
    res = run_link(link, params=params, cycles=cycles, n_check=n_check, sim=sim)
    assert check_run(link, res, gold, cycles=cycles) == []
    results = gold.trainings[0]
    runs = np.array([r.run_len for r in results])
    locked = np.array([f["locked"] for f in res.final], bool)
    error = np.array([f["error"] for f in res.final], bool)
    # a run of >= 9 taps locks; anything else reports error: never a silent lock
    np.testing.assert_array_equal(locked, runs >= 9)
    np.testing.assert_array_equal(error, runs < 9)
    for grp, gl in enumerate(res.globals):
        ids = range(grp * res.lanes, min((grp + 1) * res.lanes, n))
        assert gl["mask"] == sum(1 << (i - grp * res.lanes) for i in ids if locked[i])
    # every locked lane delivered >= `words` checked words (check_run compared each one)
    exp = expected_outputs(link, gold, lanes=res.lanes, cycles=cycles)
    for grp, segs in enumerate(exp):
        if any(locked[grp * res.lanes:(grp + 1) * res.lanes]):
            assert len(segs) == 1 and segs[0][1] >= words
    # the draw covers what it must: both tap sizes, jitter on and off, locks and errors
    jit = np.array([ln.jitter_ps > 0 for ln in link.lanes])
    taps = np.array([ln.tap_ps for ln in link.lanes])
    assert locked[jit].any() and locked[~jit].any() and error.any()
    assert locked[taps == lvds.XILINX_TAP_PS].any() and locked[taps == lvds.PAPER_TAP_PS].any()
    return res


def test_random_lanes_verilator_full():
    """500 random 10-bit lanes and 104 random 12-bit lanes, >= 10^4 words each."""
    _check_random(500, 10, 500, n_check=16, words=DATA_WORDS, sim="verilator")
    _check_random(104, 12, 501, n_check=16, words=DATA_WORDS, sim="verilator")


def test_random_lanes_icarus_short():
    """504 random lanes trained on Icarus, 64 checked words each (full form: slow test)."""
    _check_random(504, 10, 502, n_check=8, words=64, sim="icarus")


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="full Icarus sweep: set TDICAM_FULL=1 (~15 min)")
def test_random_lanes_icarus_full():
    _check_random(500, 10, 500, n_check=16, words=DATA_WORDS, sim="icarus")
