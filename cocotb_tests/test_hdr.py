"""Co-simulation of the generated ``hdr`` Verilog against its golden model."""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import vectors as golden
from tdicam.blocks.hdr import scene_frames
from tdicam.cosim.codec import frames_to_beats
from tdicam.cosim.testing import check_beats, check_case
from tdicam.model.hdr import hdr, hdr_config

CASES = [c.name for c in blocks.get("hdr").cases()]


@pytest.mark.parametrize("case", CASES)
def test_golden_per_beat(case, sim):
    """Every golden case, cocotb driving each beat with random idle and backpressure."""
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
