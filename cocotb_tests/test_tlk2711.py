"""Co-simulation of the generated ``tlk2711`` Verilog against its golden model.

The word stream (the registry's top, ``tdicam sim tlk2711``): the golden cases at ppc 1 and 8
and the reset cases at every ppc per beat (cocotb drives each cycle, random idle and
backpressure), and in fast mode all cases of a parameter set as one stream with a reset
before each case (the frame numbers restart), at full rate, nearly always stalled and
nearly always idle. Icarus runs every parameter set; Verilator the two-link ones (every
ppc) and one one-link set, the others with TDICAM_FULL=1 (each is a Verilator build).

The pins (``--pins``, ``--crossing``: two clocks): the scenarios of
:mod:`tdicam.cosim.tlk2711` (one clock; the link clock faster and slower than the processing
clock; a reset of both domains mid-frame; 8 pixels a clock into 2 links) on both simulators,
the last one on Verilator with TDICAM_FULL=1.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import pytest

from tdicam import blocks
from tdicam.beats import Beats
from tdicam.blocks.tlk2711 import BUILDS, VERILATOR_BUILDS
from tdicam.cosim import golden
from tdicam.cosim.testing import FULL, check_beats
from tdicam.cosim.tlk2711 import PARAMS, SCENARIOS, check, run_cocotb

BLOCK = blocks.get("tlk2711")
#: Parameter sets Verilator runs in every run (each a build): the two-link ones at every ppc
#: and 12-bit pixels into one link at 8 pixels a clock; all with TDICAM_FULL=1.


def _skip(sim, build):
    if sim == "verilator" and build not in VERILATOR_BUILDS and not FULL:
        pytest.skip(f"{build}: another Verilator build; runs with TDICAM_FULL=1")


def _build_stream(build):
    """(params, stimulus, expected, resets) of every case of one build, a reset before each
    case but the first (its frame numbers restart at 0)."""
    params = BLOCK.resolve(BUILDS[build])
    stims, exps, seg = [], [], 0
    for case in BLOCK.cases():
        if case.params != BUILDS[build]:
            continue
        arrays, _ = golden.load(BLOCK, case.name)
        stim, exp = BLOCK.streams.to_beats(arrays, params)
        if stims:
            stim.rst[0] = True
        stim.seg += seg
        exp.seg += seg
        seg = int(stim.seg.max()) + 1
        stims.append(stim)
        exps.append(exp)
    stim = Beats.concat(stims)
    return params, stim, Beats.concat(exps), int(stim.rst.sum())


@pytest.mark.parametrize("build", sorted(BUILDS))
def test_golden_fast(build, sim):
    """Every case of the parameter set as one stream, a reset before each case."""
    _skip(sim, build)
    params, stim, exp, resets = _build_stream(build)
    assert resets >= 4                    # 3 between the 4 cases, 2 inside the reset case
    check_beats("tlk2711", params, stim, exp, sim=sim, mode="fast", idle=0.25,
                backpressure=0.25, seed=7)


#: The pin-level scenarios by parameter set (one build each).
_PIN_RUNS = {p: [n for n, s in SCENARIOS.items() if s["params"] == p] for p in PARAMS}


@pytest.mark.parametrize("params", sorted(_PIN_RUNS))
def test_pins_two_clocks(params, sim):
    """The transmitter with its pins: each link's words at the pins, IDLEs dropped, are the
    golden words (a segment cut by a reset: a prefix), every marker follows two IDLEs, the
    links idle together, and the decoder gives the frames back; with --crossing at link
    clocks faster and slower than the processing clock."""
    if sim == "verilator" and params == "ppc8" and not FULL:
        pytest.skip("another Verilator build (8 pixels a clock): runs with TDICAM_FULL=1")
    cases, captures, _, _ = run_cocotb(_PIN_RUNS[params], sim)
    for case, cap in zip(cases, captures):
        check(case, cap)
