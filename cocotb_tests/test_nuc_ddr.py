"""Co-simulation of ``nuc_ddr`` (per-pixel NUC with the coefficients in DDR) particular to
the block: its Verilator runs (the standard suite, cocotb_tests/test_streams.py, runs it on
Icarus per beat and in fast mode, as its registry entry's Block.suite says) and a full
GMAX0504 row (5144 columns) at ppc 8. The hypothesis property in tests/test_properties.py
covers the parameter space in Amaranth's simulator.
"""

import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cosim.testing import check_case


@pytest.mark.parametrize("case", ["random_24x4_12b", "hard_24x8_12b_p8"])
def test_golden_fast_verilator(case):
    """Coefficient frames mid-stream, extreme codes (saturation at both ends), HDL stalls
    + 20 % idle + 20 % backpressure, on Verilator."""
    check_case("nuc_ddr", case, sim="verilator", mode="fast", idle=0.2, backpressure=0.2,
               seed=7)


def test_gmax0504_row_verilator():
    """A full 5144-column row of the GMAX0504 (643 words a coefficient line) at ppc 8."""
    check_case("nuc_ddr", "gmax0504_row_5144x2_10b_p8", sim="verilator", mode="fast",
               idle=0.1, backpressure=0.1, seed=5)


def test_golden_files_cover_every_case():
    for c in blocks.get("nuc_ddr").cases():
        golden.load("nuc_ddr", c.name)
