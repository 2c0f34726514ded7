"""Co-simulation of ``nuc_ddr`` (per-pixel NUC with the coefficients in DDR) with the HDL
controller model inside, on Icarus and Verilator, against its golden model: fast mode (HDL
stimulus, HDL stalls on every MIG ready signal with the default pattern, random idle input
and output backpressure) and per beat.

Budget (a few cases: the hypothesis property in tests/test_properties.py covers the
parameter space in Amaranth's simulator): random and saturating frames at ppc 1 and 8 on
both simulators, pixels before any coefficients per beat, a full GMAX0504 row (5144 columns)
at ppc 8 on Verilator.
"""

import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cosim.testing import check_case


@pytest.mark.parametrize("sim", ["icarus", "verilator"])
@pytest.mark.parametrize("case", ["random_24x4_12b", "hard_24x8_12b_p8"])
def test_golden_fast(sim, case):
    """Coefficient frames mid-stream, extreme codes (saturation at both ends), HDL stalls
    + 20 % idle + 20 % backpressure."""
    check_case("nuc_ddr", case, sim=sim, mode="fast", idle=0.2, backpressure=0.2, seed=7)


@pytest.mark.parametrize("case", ["no_coeffs_first_24x4_12b", "random_24x4_12b_p2"])
def test_golden_per_beat_icarus(case):
    """Pixels before any coefficient frame get the defaults; ppc 2; per beat."""
    check_case("nuc_ddr", case, sim="icarus", mode="beat", idle=0.3, backpressure=0.4,
               seed=11)


def test_gmax0504_row_verilator():
    """A full 5144-column row of the GMAX0504 (643 words a coefficient line) at ppc 8."""
    check_case("nuc_ddr", "gmax0504_row_5144x2_10b_p8", sim="verilator", mode="fast",
               idle=0.1, backpressure=0.1, seed=5)


def test_golden_files_cover_every_case():
    for c in blocks.get("nuc_ddr").cases():
        golden.load("nuc_ddr", c.name)
