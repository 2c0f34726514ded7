"""Co-simulation of the generated ``median3`` Verilog against its golden model.

The golden cases at ppc 1 and 8 and the reset cases at every ppc run per beat (cocotb drives
each cycle, random idle and backpressure) on both simulators, the other ppc 2 and 4 cases with
TDICAM_FULL=1; in fast mode the cases of each parameter set (every ppc; :data:`FULL_ONLY`
with TDICAM_FULL=1) run as one stream
(frames are independent, so back to back they also check that no line leaks from one case to
the next).
The 1280 x 64 stream is marked slow: set TDICAM_FULL=1 to run it (the benchmark
``bench/bench_median3.py`` runs it too, and asserts equality). The ECP5 synthesis top (line
buffers as DP16KD, with the DP16KD model) runs on Icarus, two parameter sets in CI, four with
TDICAM_FULL=1.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.blocks.median3 import BUILDS, FULL_ONLY_BUILDS, case_beats, stream_case
from tdicam.cosim.codec import Beats
from tdicam.cosim.testing import FULL, check_beats
from tdicam.hdl.median3 import Median3

BLOCK = blocks.get("median3")
#: Parameter sets co-simulated only with TDICAM_FULL=1 (each is a Verilator build of its
#: own): enhancement at ppc 2 and 4 and the 16-bit enhanced frames at ppc 8. CI keeps at every
#: ppc the smallest width, full scale and zeros, a reset mid-frame, and enhancement at ppc 1
#: and 8.
FULL_ONLY = () if FULL else FULL_ONLY_BUILDS


def _build_stream(build):
    """(params, stimulus, expected, resets, one-row frames) of all cases of one build."""
    params = BLOCK.resolve(BUILDS[build])
    stims, exps, resets, single = [], [], 0, 0
    offset = 0
    for case in BLOCK.cases():
        if case.params != BUILDS[build]:
            continue
        arrays, _ = golden.load(BLOCK, case.name)
        stim, exp = case_beats(arrays, params)
        stim.seg += offset
        exp.seg += offset
        offset = int(stim.seg.max())
        resets += int(stim.rst.sum())
        single += int((arrays["heights"] == 1).sum())
        stims.append(stim)
        exps.append(exp)
    return params, Beats.concat(stims), Beats.concat(exps), resets, single


@pytest.mark.parametrize("build", sorted(set(BUILDS) - set(FULL_ONLY)))
def test_golden_fast(build, sim):
    params, stim, exp, _, _ = _build_stream(build)
    check_beats("median3", params, stim, exp, sim=sim, mode="fast", idle=0.25,
                backpressure=0.25, seed=7)


@pytest.mark.filterwarnings("ignore::amaranth.hdl._ir.UnusedElaboratable")
@pytest.mark.parametrize("build", ["w24_12b", "enh_w16_12b", "p8_w24_12b", "p8_enh_w32_12b"])
@pytest.mark.parametrize("idle,bp", [(0.0, 0.0), (0.0, 0.9), (0.9, 0.0), (0.0, 0.5)])
def test_extreme_stalls(sim, build, idle, bp):
    """Full throughput, nearly always stalled sink, nearly always idle source, a source
    always offering into a sink ready half the time (at ppc >= 2 the output buffers of
    median3's neighbourhoods fill and drain on every level)."""
    params, stim, exp, resets, single = _build_stream(build)
    res = check_beats("median3", params, stim, exp, sim=sim, mode="fast", idle=idle,
                      backpressure=bp, seed=3)
    if idle == bp == 0.0:
        w = params["width"] // params["ppc"]     # beats per row
        lat = Median3(**params).latency
        # 1 beat/clock: the inputs, a reset's cycles, the last frame's border rows and
        # latency, the drain window (2000 quiet cycles); with enhance a 1-row frame may wait
        # for the previous frame's last 2 rows (<= width / ppc cycles, documented)
        tail = (3 * w if params["enhance"] else w) + lat + 4
        bound = len(stim) + 4 * resets + tail + single * w * params["enhance"] + 2000
        assert res.cycles <= bound, (res.cycles, bound)


def test_reset_cases_are_really_cut():
    arrays, _ = golden.load("median3", "reset_mid_frame_12b")
    sent, full = arrays["keep"], arrays["heights"] * 24
    assert sent[0] < full[0] and arrays["reset_after"][0] == 1     # cut mid-frame
    assert sent[2] == full[2] and arrays["reset_after"][2] == 1    # reset during its flush
    stim, exp = case_beats(arrays, BLOCK.resolve(BUILDS["w24_12b"]))
    assert stim.rst.sum() == 2 and exp.seg.max() == 2


@pytest.mark.slow
@pytest.mark.parametrize("enhance", [False, True])
def test_1280x64_stream(sim, enhance):
    """Three 1280 x 64 frames back to back, generated on the fly (TDICAM_FULL=1)."""
    if not FULL:
        pytest.skip("full form only (TDICAM_FULL=1); the w8192_8b golden case is the short form")
    params = BLOCK.resolve({"width": 1280, "pixel_bits": 12, "enhance": enhance})
    rng = np.random.default_rng(64)
    frames = [rng.integers(0, 4096, (64, 1280)) for _ in range(3)]
    stim, exp = case_beats(stream_case(frames, params), params)
    check_beats("median3", params, stim, exp, sim=sim, mode="fast", idle=0.1,
                backpressure=0.1)


#: Parameter sets co-simulated as the ECP5 synthesis top on Icarus (one build each): plain
#: and enhanced at ppc 1 and 8; CI runs the enhanced one at ppc 1 (both neighbourhoods:
#: tap and payload line buffers) and the plain one at ppc 8 (the orbit chain's), the other
#: two with TDICAM_FULL=1.
ECP5_BUILDS = ("w24_12b", "enh_w16_12b", "p8_w24_12b", "p8_enh_w32_12b")
ECP5_DEFAULT = ("enh_w16_12b", "p8_w24_12b")


@pytest.mark.parametrize("build", ECP5_BUILDS)
def test_golden_ecp5_line_buffers_icarus(build):
    """The ECP5 synthesis top (``bram="ecp5"``: every line buffer DP16KD primitives whose
    output register is the line buffers' output register) with the DP16KD model of
    :mod:`tdicam.cosim.dp16kd` on Icarus: all golden cases of the parameter set as one
    stream (resets, height changes, full scale), 25 % idle and 25 % backpressure, bit-exact
    (a read of a word never written, or written at the same edge, would show x)."""
    if build not in ECP5_DEFAULT and not FULL:
        pytest.skip("another Icarus build of the ECP5 variant: runs with TDICAM_FULL=1")
    params, stim, exp, _, _ = _build_stream(build)
    check_beats("median3", params, stim, exp, sim="icarus", mode="fast", idle=0.25,
                backpressure=0.25, seed=7, ecp5=True)
