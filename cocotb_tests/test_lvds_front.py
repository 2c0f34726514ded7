"""Co-simulation of the generated front end (:class:`tdicam.hdl.lvds_front.LvdsFront`,
Verilog module ``lvds_front``) with two clocks, against its golden model (issue 30).

One build per simulator (fixture ``sim``: Icarus and Verilator) runs every must-show
scenario of :data:`tdicam.cosim.lvds_front.SCENARIOS` in one simulator run (the testbench
resets both clock domains between them): the clock-domain crossing at the worst rate ratio
the lane format allows (word clock faster than the processing clock's share, r = P/(P+2))
and slower with backpressure, no pixel lost or duplicated; a lane whose eye is too narrow
to train, reported by number with its columns invalid and the other lanes bit-exact; a lane
that dies mid-frame, the frame filled and counted, frames held until the retrain.
``TDICAM_FULL=1`` adds the same at one pixel per clock (two more builds).
"""

import functools
import os

import pytest

from tdicam.cosim.lvds_front import SCENARIOS, check, run_cocotb

FULL = os.environ.get("TDICAM_FULL") == "1"


#: A width the 4 lanes a gain do not divide: 4 words a lane, the last word clock of a line
#: 2 columns (lanes 2 and 3 send a padded slot), as the GMAX0504's 5144 columns on 40 lanes.
PADDED = 14


@functools.lru_cache(maxsize=None)
def _run(sim, ppc, columns=None):
    cases, results, _, _ = run_cocotb(SCENARIOS, sim, ppc=ppc, columns=columns)
    return dict(zip(SCENARIOS, zip(cases, results)))


@pytest.mark.parametrize("name", SCENARIOS)
def test_front_scenario(name, sim):
    case, res = _run(sim, 2)[name]
    assert check(name, case, res) == []


@pytest.mark.parametrize("name", SCENARIOS)
def test_front_scenario_padded(name, sim):
    """Every scenario with a padded last word clock a line (:data:`PADDED` columns)."""
    case, res = _run(sim, 2, PADDED)[name]
    assert check(name, case, res) == []


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="the front at ppc 1: TDICAM_FULL=1")
@pytest.mark.parametrize("name", SCENARIOS)
def test_front_scenario_ppc1(name, sim):
    case, res = _run(sim, 1)[name]
    assert check(name, case, res) == []
