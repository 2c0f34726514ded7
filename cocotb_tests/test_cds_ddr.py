"""Co-simulation of ``cds_ddr`` (digital CDS with the reset frame in DDR) with the HDL controller model inside, on
Icarus and Verilator, against its golden model: fast mode (HDL stimulus, HDL stalls on every
MIG ready signal with the default pattern, random idle input and output backpressure) and
per beat.

Budget: every small golden case on Icarus; CDS 512 x 16 on both simulators; ppc 2, 4 and 8
on Verilator (at 8 the widest frame, 65,536 columns).
"""

import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cosim.testing import case_names, check_case


@pytest.mark.parametrize("case", case_names("cds_ddr"))
def test_golden_fast_icarus(case):
    """Every small golden case, HDL stalls + 20 % idle + 20 % backpressure."""
    check_case("cds_ddr", case, sim="icarus", mode="fast", idle=0.2, backpressure=0.2, seed=7)


@pytest.mark.parametrize("case", ['random_24x4_12b', 'reset_mid_frame_24x4_12b', 'random_24x4_12b_p2', 'reset_mid_frame_24x4_12b_p8'])
def test_golden_per_beat_icarus(case):
    check_case("cds_ddr", case, sim="icarus", mode="beat", idle=0.3, backpressure=0.4, seed=11)


@pytest.mark.parametrize("sim", ["icarus", "verilator"])
def test_cds_512x16(sim):
    check_case("cds_ddr", "random_512x16_10b", sim=sim, mode="fast", idle=0.1,
               backpressure=0.1, seed=3)


@pytest.mark.parametrize("ppc", [2, 4, 8])
def test_cds_ppc_verilator(ppc):
    """ppc 2, 4, 8 on Verilator (Icarus runs every case above): random frames and a reset
    mid-frame (one build for the two 24 x 4 cases), and at ppc 8 the widest frame (65,536
    columns, 16-value words: 2 beats each)."""
    cases = [f"random_24x4_12b_p{ppc}", f"reset_mid_frame_24x4_12b_p{ppc}"]
    if ppc == 8:
        cases.insert(0, "widest_65536x1_12b_p8")
    for case in cases:
        check_case("cds_ddr", case, sim="verilator", mode="fast", idle=0.1,
                   backpressure=0.1, seed=5)


def test_golden_files_cover_every_case():
    for c in blocks.get("cds_ddr").cases():
        golden.load("cds_ddr", c.name)
