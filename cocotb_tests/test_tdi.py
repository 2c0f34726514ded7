"""Co-simulation of the generated ``tdi`` Verilog against its golden vectors, on Icarus and
Verilator, per-beat (cocotb drives every cycle) and fast (HDL-side stimulus and stalls).

What runs by default (CI budget: every distinct Verilator parameter set is a ~30 s build):

* 64 x 4 cases (random, full scale, stage and direction changes, reset mid-frame,
  malformed frames; ppc 1 full width and ppc 4 saturating): per-beat and fast, both
  simulators.
* 14-bit/ppc 2 and 8-bit/ppc 8 cases: fast (and two of them per-beat) on Icarus
  (Verilator with TDICAM_FULL=1); the Amaranth simulator runs them too (tests/test_tdi.py).
* 256 x 32 cases (m_max with a full-scale band, reverse scan, m = 1; ppc 1 and 4): fast
  without stalls on Icarus, checking one beat per clock (Verilator with TDICAM_FULL=1).
* the paper's 1280 x 96 cases (98 frames, 12 M / 3 M beats): fast on Verilator; on Icarus a
  short form (the same 1280 x 96 design run at small stage counts, both directions), the
  full ppc 4 case with TDICAM_FULL=1 (ppc 1 is 12 M beats: several minutes).

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import os

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.blocks.tdi import pack_ctrl, stream_arrays
from tdicam.cosim import stream_ports
from tdicam.cosim.codec import Beats
from tdicam.cosim.testing import check_beats, check_case
from tdicam.hdl.tdi import TdiAccumulator
from tdicam.model.tdi import tdi_stream


FULL = os.environ.get("TDICAM_FULL") == "1"
LATENCY = TdiAccumulator(width=64, stages=4).latency   # the same at every parameter
CASES = {c.name: c for c in blocks.get("tdi").cases()}
SMALL = [n for n, c in CASES.items() if "fast-only" not in c.tags]
MEDIUM = [n for n, c in CASES.items() if "fast-only" in c.tags and "big" not in c.tags]


def _budget(case, sim):
    if not FULL and blocks.get("tdi").suite.full_only(CASES[case], sim, "fast"):
        pytest.skip("another Verilator build (~30 s): runs with TDICAM_FULL=1")


@pytest.mark.parametrize("case", MEDIUM)
def test_golden_fast_full_rate(case, sim):
    """256 x 32 cases without stalls: one beat per clock, so the cycle count is the beat
    count plus the latency and the drain window (2000 quiet cycles) — the same frames take
    4x fewer cycles at ppc = 4 (pixels per clock scale with ppc)."""
    _budget(case, sim)
    res = check_case("tdi", case, sim=sim, mode="fast", idle=0.0, backpressure=0.0, seed=1)
    arrays, params = golden.load("tdi", case)
    n = len(arrays["first"])
    assert n + 2000 <= res.cycles <= n + 2000 + LATENCY + 2
    # the same pixels at ppc 1 and 4: 33 frames of 32 rows, 10 of 8, 2 of 1, 256 wide
    assert n * params["ppc"] == (33 * 32 + 10 * 8 + 2 * 1) * 256


@pytest.mark.parametrize("ppc", [1, 4])
def test_paper_sensor_1280x96_verilator(ppc):
    """The paper's 1280 x 96 stage, 12-bit case (98 frames, 12 M / 3 M beats), fast mode."""
    check_case("tdi", f"texture_1280x96_p{ppc}", sim="verilator", mode="fast", idle=0.1,
               backpressure=0.1, seed=3)


@pytest.mark.slow
@pytest.mark.parametrize("ppc", [4, 1])
def test_paper_sensor_1280x96_icarus(ppc):
    """Full form of the Icarus run of the 1280 x 96 golden case (minutes)."""
    if not FULL:
        pytest.skip("3 M / 12 M beats on Icarus: TDICAM_FULL=1 (short form runs always)")
    check_case("tdi", f"texture_1280x96_p{ppc}", sim="icarus", mode="fast", idle=0.1,
               backpressure=0.1, seed=3)


def _settings_stream(params, seq, rng):
    """Beats, expected beats and model result for [(m, direction, frames)]."""
    settings = [(m, d) for m, d, n in seq for _ in range(n)]
    frames = [rng.integers(0, 1 << params["pixel_bits"], (m, params["width"]))
              for m, _ in settings]
    a = stream_arrays(frames, settings, params)
    want = tdi_stream(a["pixels"], a["first"], a["last"], a["stages_active"], a["direction"],
                      **params)
    stim = Beats(a["pixels"], a["first"], a["last"],
                 ctrl=pack_ctrl(a["stages_active"], a["direction"]))
    return stim, Beats(want.data, want.first, want.last), want


@pytest.mark.parametrize("ecp5", [False, True], ids=["generic", "ecp5"])
@pytest.mark.parametrize("ppc", [4])
def test_paper_sensor_1280x96_icarus_short(ppc, ecp5):
    """Short form on Icarus: the 1280 x 96 Verilog (95-line memory) run at m = 3 forward,
    m = 5 reverse and m = 2, with refills between; every output line compared. ``ecp5``:
    the top ``tdicam synth`` places on the ECP5 (128 DP16KD instances, 15 banks of the
    18-bit part in use, with the DP16KD model of :mod:`tdicam.cosim.dp16kd`)."""
    params = blocks.get("tdi").resolve({"width": 1280, "stages": 96, "ppc": ppc})
    rng = np.random.default_rng(8)
    stim, exp, want = _settings_stream(params, [(3, 0, 5), (5, 1, 7), (2, 0, 3)], rng)
    assert len(want.first) == (3 + 3 + 2) * 1280 // ppc
    check_beats("tdi", params, stim, exp, sim="icarus", mode="fast", idle=0.1,
                backpressure=0.2, seed=4, ecp5=ecp5)


@pytest.mark.parametrize("width,ppc", [(8, 2), (16, 8)])
def test_ecp5_banks_narrow_rows_icarus(width, ppc):
    """The ECP5 top's hazard window: rows of 4 and 2 beats (fewer than its 7
    :attr:`~tdicam.hdl.tdi.TdiAccumulator.row_cycles`), so a line is read again right after
    the shortest gap the frame control leaves; stage and direction changes between, 20 %
    idle and 30 % backpressure, against the beat-level model."""
    params = blocks.get("tdi").resolve({"width": width, "stages": 5, "ppc": ppc})
    rng = np.random.default_rng(width)
    stim, exp, _ = _settings_stream(params, [(5, 0, 12), (4, 1, 9), (2, 0, 6), (5, 0, 8)],
                                    rng)
    check_beats("tdi", params, stim, exp, sim="icarus", mode="fast", idle=0.2,
                backpressure=0.3, seed=9, ecp5=True)


ECP5_DEFAULT = ("stages_64x4_p1",)


@pytest.mark.parametrize("case", SMALL + ["mixed_256x32_p1"])
def test_golden_ecp5_banks_icarus(case):
    """The ECP5 synthesis top (``bram="ecp5"``: DP16KD instances whose output register is
    the bank register) with the DP16KD model of :mod:`tdicam.cosim.dp16kd` on Icarus,
    against the golden vectors with 25 % idle and 25 % backpressure: one case by default
    (x18 and x1 primitives, stage and direction changes), every small case and the 256 x 32
    ppc 1 one (four banks of the 18-bit part) with TDICAM_FULL=1."""
    if case not in ECP5_DEFAULT and not FULL:
        pytest.skip("another Icarus build of the ECP5 variant: runs with TDICAM_FULL=1")
    check_case("tdi", case, sim="icarus", mode="fast", idle=0.25, backpressure=0.25, seed=7,
               ecp5=True)


def test_random_malformed_stream(sim):
    """A random stream with invalid settings, cut and long frames, wrong tlast and missing
    tuser, generated here (not stored), against the beat-level model."""
    rng = np.random.default_rng(21)
    params = blocks.get("tdi").resolve({"width": 64, "stages": 4, "pixel_bits": 12,
                                        "ppc": 1})
    parts = []
    m, d = 4, 0
    for _ in range(60):
        if rng.random() < 0.08:
            m, d = int(rng.integers(0, 6)), int(rng.integers(0, 2))
        a = stream_arrays([rng.integers(0, 4096, (max(m, 1), 64))], [(m, d)], params)
        n = len(a["first"])
        r = rng.random()
        if r < 0.06:
            c = int(rng.integers(1, n))
            a = {k: v[:c] for k, v in a.items()}
        elif r < 0.12:
            j = int(rng.integers(0, n))
            a["last"][j] = ~a["last"][j]
        elif r < 0.15:
            a["first"][0] = False
        parts.append(a)
    a = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    stim = Beats(a["pixels"], a["first"], a["last"],
                 ctrl=pack_ctrl(a["stages_active"], a["direction"]))
    want = tdi_stream(a["pixels"], a["first"], a["last"], a["stages_active"], a["direction"],
                      **params)
    assert want.frame_errors >= 10 and len(want.first) >= 30 * 64   # errors and output
    assert (want.data == 0).all(axis=1).sum() >= 64                  # zero-padded lines
    exp = Beats(want.data, want.first, want.last)
    check_beats("tdi", params, stim, exp, sim=sim, mode="fast", idle=0.2, backpressure=0.3,
                seed=2)


def test_ctrl_packing_matches_ports():
    top = blocks.get("tdi").build({"width": 64, "stages": 4})
    _, _, ctrl = stream_ports(top)
    assert ctrl == [("stages_active", 3), ("direction", 1)]
