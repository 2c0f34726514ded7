"""Co-simulation of ``cds_ddr`` (digital CDS with the reset frame in DDR) with the HDL controller model inside, on
Icarus and Verilator, against its golden model: fast mode (HDL stimulus, HDL stalls on every
MIG ready signal with the default pattern, random idle input and output backpressure) and
per beat.

Budget: every small golden case on Icarus; CDS 512 x 16 on both simulators; ppc 2, 4 and 8
on Verilator (at 8 the widest frame, 65,536 columns).

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cosim.testing import check_case


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
