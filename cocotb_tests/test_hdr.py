"""Co-simulation of the generated ``hdr`` Verilog against its golden model."""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.blocks.hdr import scene_frames
from tdicam.beats import mark_resets
from tdicam.cosim.codec import frames_to_beats
from tdicam.cosim.testing import beat_cases, check_beats, check_case, FULL, WIDE_PPC
from tdicam.model.hdr import hdr, hdr_config

CASES = [c.name for c in blocks.get("hdr").cases()]


BEAT_SHORT, BEAT_LONG = beat_cases("hdr")


@pytest.mark.parametrize("case", BEAT_SHORT)
def test_golden_per_beat(case, sim):
    """Golden cases (ppc 1 and 8, resets at every ppc), cocotb driving each beat with random
    idle and backpressure."""
    check_case("hdr", case, sim=sim, mode="beat", idle=0.3, backpressure=0.4, seed=11)


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="per-beat ppc 2/4 cases (fast mode runs them): set "
                                     "TDICAM_FULL=1")
@pytest.mark.parametrize("case", BEAT_LONG)
def test_golden_per_beat_ppc_long(case, sim):
    check_case("hdr", case, sim=sim, mode="beat", idle=0.3, backpressure=0.4, seed=11)


@pytest.mark.parametrize("case", CASES)
def test_golden_fast(case, sim):
    check_case("hdr", case, sim=sim, mode="fast", idle=0.25, backpressure=0.25, seed=7)


@pytest.mark.parametrize("idle,bp", [(0.0, 0.0), (0.0, 0.9), (0.9, 0.0)])
def test_extreme_stalls(sim, idle, bp):
    """Full throughput, nearly always stalled sink, nearly always idle source."""
    res = check_case("hdr", "scene_12b", sim=sim, mode="fast", idle=idle, backpressure=bp,
                     seed=3)
    if idle == bp == 0.0:
        arrays, params = golden.load("hdr", "scene_12b")
        n = arrays["hg"].size
        starts = len(arrays["hg"]) - 1  # frame starts after a measured band
        stall = 12 + 4 + 3
        # 1 pixel/clock apart from the frame-start divisions; latency 4; drain 2000
        assert res.cycles <= n + starts * stall + 4 + 2000 + 2


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


@pytest.mark.parametrize("ppc", [2, 4, 8])
def test_full_rate_ppc(sim, ppc):
    """No idle cycle, no backpressure: one beat of ``ppc`` pixels per clock apart from the
    frame-start divisions (three cycles longer than at ppc 1)."""
    res = check_case("hdr", f"scene_12b_p{ppc}", sim=sim, mode="fast", idle=0.0,
                     backpressure=0.0, seed=3)
    arrays, params = golden.load("hdr", f"scene_12b_p{ppc}")
    n = arrays["hg"].size // ppc
    starts = len(arrays["hg"]) - 1
    stall = 12 + 4 + 3 + 4       # frame_start_cycles at ppc > 1
    assert res.cycles <= n + starts * stall + 4 + 2000 + 2


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
