"""Co-simulation of the generated ``nuc`` Verilog against its golden model."""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import vectors as golden
from tdicam.cosim.codec import frames_to_beats
from tdicam.cosim.testing import check_beats, check_case
from tdicam.model.nuc import DEFAULT_FORMAT, nuc

CASES = [c.name for c in blocks.get("nuc").cases()]


@pytest.mark.parametrize("case", CASES)
def test_golden_per_beat(case, sim):
    """Every golden case, cocotb driving each beat with random idle and backpressure."""
    check_case("nuc", case, sim=sim, mode="beat", idle=0.3, backpressure=0.4, seed=11)


@pytest.mark.parametrize("case", CASES)
def test_golden_fast(case, sim):
    check_case("nuc", case, sim=sim, mode="fast", idle=0.25, backpressure=0.25, seed=7)


@pytest.mark.parametrize("idle,bp", [(0.0, 0.0), (0.0, 0.9), (0.9, 0.0)])
def test_extreme_stalls(sim, idle, bp):
    """Full throughput, nearly always stalled sink, nearly always idle source."""
    res = check_case("nuc", "random_12b", sim=sim, mode="fast", idle=idle, backpressure=bp,
                     seed=3)
    if idle == bp == 0.0:
        n = 3 * 16 * 24
        # 1 pixel/clock: n transfers + latency (3) + the drain window (2000 quiet cycles)
        assert res.cycles <= n + 3 + 2000 + 2


def test_long_stream_1280_wide():
    """Two 1280 x 40 frames of calibration-like coefficients: more beats than the fast
    testbench's stimulus memory holds (65,536)."""
    rng = np.random.default_rng(5)
    shape = (2, 40, 1280)
    x = rng.integers(0, 4096, shape)
    g = DEFAULT_FORMAT.gain_code(rng.normal(1.0, 0.05, shape))
    o = rng.integers(-300, 300, shape)
    params = blocks.get("nuc").resolve({})
    stim = frames_to_beats(DEFAULT_FORMAT.stream_elements(x, g, o), channels=3)
    exp = frames_to_beats(nuc(x, g, o))
    assert len(stim) > 65536
    check_beats("nuc", params, stim, exp, sim="verilator", mode="fast", idle=0.1,
                backpressure=0.1)


def test_identity_case_is_identity():
    arrays, _ = golden.load("nuc", "identity_16b")
    np.testing.assert_array_equal(arrays["out"], arrays["x"])
