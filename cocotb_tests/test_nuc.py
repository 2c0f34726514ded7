"""Co-simulation of the generated ``nuc`` Verilog against its golden model.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.beats import mark_resets
from tdicam.cosim import golden
from tdicam.cosim.codec import frames_to_beats
from tdicam.cosim.testing import check_beats, check_case, WIDE_PPC
from tdicam.model.nuc import DEFAULT_FORMAT, nuc


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
