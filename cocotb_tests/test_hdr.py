"""Co-simulation of the generated ``hdr`` Verilog against its golden model.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.blocks.hdr import scene_frames
from tdicam.beats import mark_resets
from tdicam.cosim.codec import frames_to_beats
from tdicam.cosim.testing import check_beats, check_case, WIDE_PPC
from tdicam.model.hdr import hdr, hdr_config


def test_long_frames_1280_wide():
    """Two 1280 x 40 frames with a measured junction between them: more beats than the fast
    testbench's stimulus memory holds (65,536)."""
    cfg = hdr_config()
    hg, lg = scene_frames(cfg, np.random.default_rng(5), 2, 40, 1280)
    params = blocks.get("hdr").resolve({})
    stim = frames_to_beats(np.stack([hg, lg], -1), channels=2)
    exp = frames_to_beats(hdr(hg, lg))
    assert len(stim) > 65536
    check_beats("hdr", params, stim, exp, sim="verilator", mode="fast", idle=0.1,
                backpressure=0.1)


# ---- pixels per clock (ppc 2, 4, 8; the golden cases above cover every ppc)


@pytest.mark.parametrize("ppc", WIDE_PPC)
def test_widest_rows(sim, ppc):
    """Rows of 8192 pixels (the widest line any tdicam block takes; hdr itself has no width
    limit), three frames with measured junctions between them, a reset in the middle of a
    row of frame 1 (frames 1 and 2 then start from the reset state)."""
    cfg = hdr_config()
    hg, lg = scene_frames(cfg, np.random.default_rng(ppc), 3, 4, 8192)
    params = blocks.get("hdr").resolve({"ppc": ppc})
    stim = frames_to_beats(np.stack([hg, lg], -1), ppc=ppc, channels=2)
    cut = 4 * 8192 + 2 * 8192 + 4100            # pixels before the reset: frame 1 row 2
    keep = np.ones(len(stim), bool)
    keep[cut // ppc:2 * 4 * 8192 // ppc] = False  # the rest of frame 1 is not sent
    exp = frames_to_beats(np.concatenate([hdr(hg[:2], lg[:2]), hdr(hg[2:], lg[2:])]),
                          ppc=ppc)
    stim, exp = stim.select(keep), exp.select(keep)
    mark_resets(stim, exp, [cut // ppc])
    check_beats("hdr", params, stim, exp, sim=sim, mode="fast", idle=0.1, backpressure=0.1)


@pytest.mark.parametrize("case", ["extremes_12b_p8", "gain_change_multi_p8", "scene_12b_p2",
                                  "reset_mid_frame_multi", "extremes_coarse_16b"])
def test_golden_ecp5_dsp(case, sim):
    """The ECP5 synthesis top (``dsp="ecp5"``: each lane's multiplier a signed MULT18X18D
    with its own input registers, the product register in the fabric) with the model of
    :mod:`tdicam.cosim.mult18x18d`, against the golden vectors with 25 % idle and 25 %
    backpressure: full scale (negative junction differences), gain pairs changing between
    frames (the slope register), reset mid-frame at ppc 1, and 16-bit pixels without
    fraction bits (a 17-bit difference, the widest that fits one block)."""
    check_case("hdr", case, sim=sim, mode="fast", idle=0.25, backpressure=0.25, seed=11,
               ecp5=True)
