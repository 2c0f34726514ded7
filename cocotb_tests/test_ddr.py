"""Co-simulation of the ``ddr`` block (the frame buffer behind the MIG user interface) on Icarus
and Verilator; its users ``cds_ddr`` and ``tdi_ddr`` are co-simulated in test_cds_ddr.py and
test_tdi_ddr.py.

Two kinds of runs:

* the block with the HDL controller model inside (fast mode: HDL stimulus, HDL stalls on
  every MIG ready signal with the default pattern, plus random idle input and output
  backpressure), against the golden model;
* the bare frame buffer with its MIG ports driven by the Python controller model
  (:func:`tdicam.cosim.ddr.run_ui_cosim`): memory checked word for word against the
  Table 2 packing, interface efficiency measured per phase (>= 80 % required).

Budget (every distinct parameter set is a simulator build; Verilator ~30-100 s each): all
small golden cases on Icarus; on Verilator the paper-size cases only (the 1280 x 1024
10-bit full frame round trip); the 72-channel full frame with ``TDICAM_FULL=1``.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cosim.ddr import run_ui_cosim
from tdicam.cosim.codec import Beats, frames_to_beats
from tdicam.cosim.testing import FULL, check_beats


# ---- paper-size cases, both simulators

def test_full_frame_1280x1024_verilator():
    """A whole 1280 x 1024 10-bit frame (8 pixels per beat, 55,296 words each way) and the
    first 40 lines of the next, bit-exact through writer, the HDL controller model and
    reader, fast mode, stalls on every ready. The buffer is a 64-line ring here: the
    Verilog of a 1024-line model memory (14 Mbit of zero init) takes minutes to generate;
    the 1024-line frame buffer itself runs in the next test against the Python model."""
    params = blocks.get("ddr").resolve({"width": 1280, "rows": 64, "ppc": 8})
    rng = np.random.default_rng(3)
    fr = rng.integers(0, 1024, (1, 1024, 1280, 1), dtype=np.uint16)
    nxt = rng.integers(0, 1024, (1, 1024, 1280, 1), dtype=np.uint16)
    stim = Beats.concat([frames_to_beats(fr, ppc=8), frames_to_beats(nxt, ppc=8).select(
        np.arange(1024 * 160) < 40 * 160)])
    check_beats("ddr", params, stim, stim, sim="verilator", mode="fast", idle=0.05,
                backpressure=0.05, seed=5)


def test_full_frame_1280x1024_python_model_verilator():
    """The 1024-line frame buffer (line y at y x 512 address units) with the Python
    controller model: the whole frame in DDR equals the Table 2 packing word for word, the
    read-back frame equals the input, and no model error."""
    r = run_ui_cosim(width=1280, rows=1024, ppc=8, sim="verilator", seed=8)
    assert r["error"] == "" and r["words"] == 1024 * 54
    assert r["mem_mismatches"] == 0, r["first_bad"]
    assert r["data_ok"] and r["flags_ok"]
    assert r["written_addrs"][-1] == 1023 * 512 + 53 * 8


@pytest.mark.slow
def test_full_frame_72ch_verilator():
    """The 72-channel layout with Table 2's 4096 line stride: 170 pixels x 72 channels =
    510 words per line, a full 1024-line frame through a 16-line ring, fast mode. Slow
    (a ~50 MB stimulus): TDICAM_FULL=1; the UI test covers the layout on every run."""
    if not FULL:
        pytest.skip("72-channel full frame: TDICAM_FULL=1 (the UI test covers the layout)")
    params = blocks.get("ddr").resolve({"width": 170, "rows": 16, "channels": 72,
                                        "ppc": 1, "line_stride": 4096})
    rng = np.random.default_rng(4)
    fr = rng.integers(0, 1024, (1, 1024, 170, 72), dtype=np.uint16)
    stim = frames_to_beats(fr, ppc=1, channels=72)
    check_beats("ddr", params, stim, stim, sim="verilator", mode="fast", idle=0.05,
                backpressure=0.05, seed=6)


def test_out_of_range_access_stops_the_stream():
    """A buffer whose lines run past the simulated memory: the model's sticky error blocks
    the input, so not every beat is accepted (the harness reports it)."""
    from tdicam.hdl.interfaces.axis import AxisTop
    from tdicam.hdl.ddr import DdrFrameBuffer
    from tdicam.hdl.simmodels.mig_model import SimTop
    from tdicam.hw.verilog import convert
    core = DdrFrameBuffer(width=48, rows=4, elements=8)
    top = SimTop(core, depth_words=4)        # 4 words: line 1 is already outside
    text = convert(AxisTop(top), "ddr_oob")
    assert "ddr_error" in text
    # simulate in Amaranth (one small case): the error rises and the input stops
    from amaranth.sim import Simulator
    sim = Simulator(top)
    sim.add_clock(1e-8)
    state = {}

    async def tb(ctx):
        ctx.set(top.o_stream.ready, 1)
        sent = 0
        for _ in range(400):
            ctx.set(top.i_stream.valid, 1)
            ctx.set(top.i_stream.payload.last, sent % 6 == 5)
            await ctx.tick()
            if ctx.get(top.i_stream.ready):
                sent += 1
        state["err"] = ctx.get(top.ddr_error)
        state["ready"] = ctx.get(top.i_stream.ready)
        state["sent"] = sent

    sim.add_testbench(tb)
    sim.run()
    assert state["err"] == 1 and state["ready"] == 0 and state["sent"] < 400


# ---- MIG ports driven by the Python model

@pytest.mark.parametrize("sim", ["icarus", "verilator"])
def test_ui_python_model_efficiency_and_packing(sim):
    """1296-pixel 10-bit lines, 24 pixels per beat (one word per beat), 32 lines: memory
    equals the Table 2 packing word for word, output = input, and the default stall
    pattern leaves >= 80 % interface efficiency for line writes and for line reads."""
    r = run_ui_cosim(width=1296, rows=32, ppc=24, sim=sim, seed=2)
    assert r["error"] == ""
    assert r["mem_mismatches"] == 0, r["first_bad"]
    assert r["data_ok"] and r["flags_ok"]
    assert r["write_eff"] >= 0.80, r
    assert r["read_eff"] >= 0.80, r


def test_ui_python_model_72ch_table2_verilator():
    """The paper's layout: 72 channels, channels 1-24 / 25-48 / 49-72 of a pixel in three
    words, lines 4096 address units apart, base 8192; one pixel (3 words) per beat."""
    r = run_ui_cosim(width=170, rows=4, channels=72, ppc=1, line_stride=4096, base=8192,
                     sim="verilator", seed=3)
    assert r["error"] == "" and r["mem_mismatches"] == 0 and r["data_ok"] and r["flags_ok"]
    assert r["written_addrs"][0] == 8192 and r["written_addrs"][-1] == 8192 + 3 * 4096 + 509 * 8
    assert r["write_eff"] >= 0.80 and r["read_eff"] >= 0.80, r


def test_ui_python_model_with_backpressure():
    r = run_ui_cosim(width=50, rows=3, ppc=1, sim="icarus", seed=4, backpressure=0.5)
    assert r["error"] == "" and r["mem_mismatches"] == 0 and r["data_ok"] and r["flags_ok"]


def test_golden_files_cover_every_case():
    for c in blocks.get("ddr").cases():
        golden.load("ddr", c.name)
