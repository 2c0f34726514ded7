"""Co-simulation of the generated ``cds`` Verilog against its golden model."""

import numpy as np
import pytest

from tdicam import blocks, golden
from tdicam.cosim.codec import frames_to_beats
from tdicam.cosim.testing import check_beats, check_case
from tdicam.model.cds import cds

CASES = [c.name for c in blocks.get("cds").cases()]


@pytest.mark.parametrize("case", CASES)
def test_golden_per_beat(case, sim):
    """Every golden case, cocotb driving each beat with random idle and backpressure."""
    check_case("cds", case, sim=sim, mode="beat", idle=0.3, backpressure=0.4, seed=11)


@pytest.mark.parametrize("case", CASES)
def test_golden_fast(case, sim):
    check_case("cds", case, sim=sim, mode="fast", idle=0.25, backpressure=0.25, seed=7)


@pytest.mark.parametrize("idle,bp", [(0.0, 0.0), (0.0, 0.9), (0.9, 0.0)])
def test_extreme_stalls(sim, idle, bp):
    """Full throughput, nearly always stalled sink, nearly always idle source."""
    res = check_case("cds", "random_12b", sim=sim, mode="fast", idle=idle, backpressure=bp,
                     seed=3)
    if idle == bp == 0.0:
        n = 3 * 16 * 24
        # 1 pixel/clock: n transfers + latency + the drain window (2000 quiet cycles)
        assert res.cycles <= n + 1 + 2000 + 2


def test_long_stream_crosses_memory_chunks():
    """More beats than the fast testbench's stimulus memory holds (65,536)."""
    rng = np.random.default_rng(5)
    sig = rng.integers(0, 1 << 10, (2, 40, 1000), dtype=np.uint16)
    rst = rng.integers(0, 1 << 10, (2, 40, 1000), dtype=np.uint16)
    params = blocks.get("cds").resolve({"pixel_bits": 10})
    stim = frames_to_beats(np.stack([sig, rst], -1), channels=2)
    exp = frames_to_beats(cds(sig, rst, pixel_bits=10))
    assert len(stim) > 65536
    check_beats("cds", params, stim, exp, sim="verilator", mode="fast", idle=0.1,
                backpressure=0.1)


def test_reset_mid_frame_case_is_really_cut():
    arrays, _ = golden.load("cds", "reset_mid_frame_12b")
    assert 0 < int(arrays["reset_before"][0]) < arrays["signal"][0].size
