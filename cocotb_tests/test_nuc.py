"""Co-simulation of the generated ``nuc`` Verilog against its golden model."""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.beats import mark_resets
from tdicam.cosim import golden
from tdicam.cosim.codec import frames_to_beats
from tdicam.cosim.testing import beat_cases, check_beats, check_case, FULL, WIDE_PPC
from tdicam.model.nuc import DEFAULT_FORMAT, nuc

CASES = [c.name for c in blocks.get("nuc").cases()]


BEAT_SHORT, BEAT_LONG = beat_cases("nuc")


@pytest.mark.parametrize("case", BEAT_SHORT)
def test_golden_per_beat(case, sim):
    """Golden cases (ppc 1 and 8, resets at every ppc), cocotb driving each beat with random
    idle and backpressure."""
    check_case("nuc", case, sim=sim, mode="beat", idle=0.3, backpressure=0.4, seed=11)


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="per-beat ppc 2/4 cases (fast mode runs them): set "
                                     "TDICAM_FULL=1")
@pytest.mark.parametrize("case", BEAT_LONG)
def test_golden_per_beat_ppc_long(case, sim):
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


# ---- pixels per clock (ppc 2, 4, 8; the golden cases above cover every ppc)


@pytest.mark.parametrize("ppc", [2, 4, 8])
def test_full_rate_ppc(sim, ppc):
    """No idle cycle, no backpressure: one beat of ``ppc`` pixels per clock."""
    res = check_case("nuc", f"random_12b_p{ppc}", sim=sim, mode="fast", idle=0.0,
                     backpressure=0.0, seed=3)
    n = 3 * 16 * 24 // ppc
    assert res.cycles <= n + 3 + 2000 + 2


@pytest.mark.parametrize("ppc", WIDE_PPC)
def test_widest_rows(sim, ppc):
    """Rows of 8192 pixels (the widest line any tdicam block takes; nuc itself has no width
    limit) with calibration-like coefficients, a full-scale row, a reset in the middle of a
    row."""
    rng = np.random.default_rng(ppc)
    shape = (2, 4, 8192)
    x = rng.integers(0, 4096, shape)
    x[1, 2] = 4095
    g = DEFAULT_FORMAT.gain_code(rng.normal(1.0, 0.05, shape))
    o = rng.integers(-300, 300, shape)
    params = blocks.get("nuc").resolve({"ppc": ppc})
    stim = frames_to_beats(DEFAULT_FORMAT.stream_elements(x, g, o), ppc=ppc, channels=3)
    exp = frames_to_beats(nuc(x, g, o), ppc=ppc)
    mark_resets(stim, exp, [(4 * 8192 + 4100) // ppc])
    check_beats("nuc", params, stim, exp, sim=sim, mode="fast", idle=0.1, backpressure=0.1)


@pytest.mark.parametrize("case", ["random_12b_p8", "saturate_wide_p8", "reset_mid_frame_12b",
                                  "identity_16b_p8"])
def test_golden_ecp5_dsp(case, sim):
    """The ECP5 synthesis top (``dsp="ecp5"``: each lane's multiplier a MULT18X18D with its
    own input registers, the product register in the fabric) with the model of
    :mod:`tdicam.cosim.mult18x18d`, against the golden vectors with 25 % idle and 25 %
    backpressure: random, saturating (the widest gain and offset), reset mid-frame and
    full-scale identity cases."""
    check_case("nuc", case, sim=sim, mode="fast", idle=0.25, backpressure=0.25, seed=11,
               ecp5=True)
