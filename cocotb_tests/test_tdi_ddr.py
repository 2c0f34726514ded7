"""Co-simulation of ``tdi_ddr`` (TDI with its partial sums in DDR) with the HDL controller model inside, on
Icarus and Verilator, against its golden model: fast mode (HDL stimulus, HDL stalls on every
MIG ready signal with the default pattern, random idle input and output backpressure) and
per beat.

Budget: every small golden case on Icarus; on Verilator TDI 512 x 16 and the wide spill case
(W = 4096, m = 32, ppc 4, which ``tdicam plan`` says must spill on an ECP5-25F); Icarus runs
short forms of the big ones, the full forms with ``TDICAM_FULL=1``.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import numpy as np

from tdicam import blocks
from tdicam.blocks.tdi import pack_ctrl, stream_arrays
from tdicam.cosim import golden
from tdicam.cosim.codec import Beats
from tdicam.cosim.testing import FULL, case_names, check_beats, check_case
from tdicam.model.tdi import tdi_stream


def test_tdi_512x16_verilator():
    for case in ("random_512x16_p1", "stages_512x16_p1"):
        check_case("tdi_ddr", case, sim="verilator", mode="fast", idle=0.1,
                   backpressure=0.1, seed=3)


def test_tdi_512x16_icarus():
    """The 512 x 16 golden case (147 k beats) on Icarus; the stage/direction case with FULL."""
    check_case("tdi_ddr", "random_512x16_p1", sim="icarus", mode="fast", idle=0.1,
               backpressure=0.1, seed=3)
    if FULL:
        check_case("tdi_ddr", "stages_512x16_p1", sim="icarus", mode="fast", idle=0.1,
                   backpressure=0.1, seed=3)


def test_tdi_medium_cases_icarus():
    for case in case_names("tdi_ddr", fast_only=True):
        if blocks.get("tdi_ddr").resolve(
                [c for c in blocks.get("tdi_ddr").cases() if c.name == case][0].params
        )["width"] in (320, 1024):
            check_case("tdi_ddr", case, sim="icarus", mode="fast", idle=0.1,
                       backpressure=0.1, seed=4)


WIDE = {"width": 4096, "stages": 32, "pixel_bits": 12, "ppc": 4}


def _wide_stream(seq, seed):
    params = blocks.get("tdi_ddr").resolve(WIDE)
    rng = np.random.default_rng(seed)
    settings = [(m, d) for m, d, n in seq for _ in range(n)]
    frames = [rng.integers(0, 4096, (m, params["width"])) for m, _ in settings]
    a = stream_arrays(frames, settings, params)
    want = tdi_stream(a["pixels"], a["first"], a["last"], a["stages_active"], a["direction"],
                      **{k: params[k] for k in ("width", "stages", "pixel_bits", "out_bits",
                                                "ppc")})
    stim = Beats(a["pixels"], a["first"], a["last"],
                 ctrl=pack_ctrl(a["stages_active"], a["direction"]))
    return params, stim, Beats(want.data, want.first, want.last), want


def test_wide_spill_case_is_one_the_plan_spills():
    from tdicam.model.physics.plan import tdi_memory
    mem = tdi_memory(4096, 32, 12, 1e-3, device="ecp5-25f")
    assert mem.must_spill and not tdi_memory(4096, 32, 12, 1e-3, device="ecp5-85f").must_spill


def test_wide_spill_verilator():
    """W = 4096, m = 32, 12-bit, 4 pixels/clock: 35 frames at m = 32 (4 output lines after
    the fill) then a reverse run at m = 5; ~1.2 M cycles."""
    seq = [(32, 0, 35), (5, 1, 8)] if not FULL else [(32, 0, 40), (5, 1, 8), (31, 1, 33)]
    params, stim, exp, want = _wide_stream(seq, 9)
    assert len(want.first) >= 4 * 1024
    check_beats("tdi_ddr", params, stim, exp, sim="verilator", mode="fast", idle=0.05,
                backpressure=0.05, seed=2)


def test_wide_spill_icarus_short():
    """Short form on Icarus: the same W = 4096, m_max = 32 design at m = 3 forward and m = 2
    reverse (every partial sum still goes through DDR)."""
    seq = [(3, 0, 5), (2, 1, 4)] if not FULL else [(32, 0, 34)]
    params, stim, exp, want = _wide_stream(seq, 10)
    if not FULL:
        assert len(want.first) == (3 + 3) * 1024     # 3 lines at m = 3, 3 at m = 2
    check_beats("tdi_ddr", params, stim, exp, sim="icarus", mode="fast", idle=0.05,
                backpressure=0.05, seed=2)


def test_golden_files_cover_every_case():
    for c in blocks.get("tdi_ddr").cases():
        golden.load("tdi_ddr", c.name)
