"""The camera's system top (no Verilog simulator): CDS's reset frame through DDR
(``[pipeline.cds] memory = "ddr"``: cds_ddr with the MIG user interface at the top's
ports), NUC's coefficients loaded from NAND at power-up (``[pipeline.nuc] flash = "nand"``:
the NAND bus at the top's ports, the part's model beside the top in co-simulation), the
status outputs, and the coefficient buffer in the Amaranth simulator. The co-simulation
of the whole is cocotb_tests/test_system.py."""

import random
import re
from pathlib import Path

import numpy as np
import pytest

from tdicam.chain import design
from tdicam.chain.cosim import scene_data
from tdicam.chain.tbrun import status_ports
from tdicam.errors import TdicamError
from tdicam.scene.loader import load_scene

ROOT = Path(__file__).resolve().parents[1]
#: sha256 of ``tdicam verilog pipeline --no-csr`` of the system lanes scene (the tdicam
#: version in its header as ``VERSION``): the top of before the control bus was the default,
#: its lane trainers' gearbox a shifter and their settings registered once (issue 45).
NO_CSR_LANES_SHA256 = "fb369291d606a0ccd955ff3f468b7bf8314506be8742a9c6c1a6f2dae1016c5e"
CHAIN = ROOT / "scenes" / "ning2019_chain.toml"
SYSTEM = {"cds": {"memory": "ddr"}, "nuc": {"flash": "nand", "bad_blocks": 20,
                                             "flip_single": 0.25, "flip_double": 0.05}}


def _scene(pipeline=SYSTEM, ddr=True, **over):
    o = {"sensor": {"columns": 24}, "tdi": {"stages": 4}, "run": {"lines": 3},
         "pipeline": pipeline, **over}
    if ddr:
        o["ddr"] = {"base": 4096}
    return load_scene(CHAIN, overrides=o)


def test_cds_memory_ddr_plans_cds_ddr_with_reset_frames_in_the_stream():
    p = design.chain_plan(_scene())
    assert [s.block for s in p.steps] == ["cds_ddr", "nuc", "hdr", "tdi", "median3"]
    assert (p.lanes, p.lane_elems, p.reset_frames) == (2, 1, True)
    st = p.steps[0]
    assert st.params == {"width": 24, "rows": 4, "pixel_bits": 10, "base": 4096}
    assert st.ports == {"frame_kind": (1, 0)}             # reset frame, then its signal
    # the caller's --memory is about TDI's partial sums: it never moves the reset frame
    assert [s.block for s in design.chain_plan(_scene(), spill=False).steps][0] == "cds_ddr"
    assert [s.block for s in design.chain_plan(_scene(pipeline={})).steps][0] == "cds"
    assert design.chain_plan(_scene(pipeline={}), spill="auto").steps[0].block == "cds"
    assert not design.chain_plan(_scene(pipeline={})).reset_frames


def test_cds_in_ddr_needs_a_ddr_section():
    # the scene loader refuses it (before any run, plan or Verilog), naming the key
    with pytest.raises(TdicamError, match=r"^\[pipeline.cds\].memory = 'ddr' keeps its reset "
                       r"frames in DDR, but the scene has no \[ddr\] section") as exc:
        _scene(ddr=False)
    assert "\n" not in str(exc.value)
    with pytest.raises(TdicamError, match=r"^\[pipeline.cds\].memory: must be one of"):
        _scene(pipeline={"cds": {"memory": "sram"}})


def test_the_reset_frames_travel_before_their_signal_frames():
    sc = _scene()
    p = design.chain_plan(sc)
    data, _ = scene_data(sc, stages=4, dv_over_v=0.0, lines=3)
    lanes = data.lane_arrays(p)
    assert len(lanes) == 2 and all(len(a) == 1 for a in lanes)
    both = lanes[1][0]
    assert both.shape == (2 * p.frames, 4, 24)
    assert np.array_equal(both[0::2], data.reset[1]) and np.array_equal(both[1::2],
                                                                        data.signal[1])
    ax = design.top(p, data, board=True)
    stim = design.stimulus(p, data, ax)
    ctrl = dict(status_ports(ax))                          # (no input among them)
    assert "cds_ddr_frame_kind" not in ctrl
    names = [n for n, _ in __import__("tdicam.cosim", fromlist=["x"]).stream_ports(ax)[2]]
    assert names[0] == "cds_ddr_frame_kind"                # the most significant ctrl bit
    width = sum(w for _, w in __import__("tdicam.cosim", fromlist=["x"]).stream_ports(ax)[2])
    kind = (stim.ctrl >> np.uint64(width - 1)) & np.uint64(1)
    frame = np.cumsum(stim.first) - 1
    assert np.array_equal(kind, (frame % 2 == 0).astype(np.uint64))


def _members(ax):
    return {n: m.flow.name for n, m in ax.signature.members.items()}


def test_system_top_has_the_parts_interfaces_at_its_ports_and_the_board_their_models():
    """Synthesis form: each channel's MIG user interface and NAND bus are ports of the top
    (no model inside); the co-simulation board wires the DDR and NAND models to them and
    keeps the status outputs."""
    p = design.chain_plan(_scene())
    top = _members(design.top(p))
    for lane in ("", "_1"):
        for port, flow in (("app_addr", "Out"), ("app_rdy", "In"), ("app_rd_data", "In"),
                           ("app_wdf_data", "Out")):
            assert top[f"cds_ddr_{port}{lane}"] == flow
        for port, flow in (("nand_cle", "Out"), ("nand_re_n", "Out"), ("nand_dq_o", "Out"),
                           ("nand_dq_i", "In"), ("nand_rb_n", "In"), ("calib_loaded", "Out"),
                           ("bad_blocks", "Out"), ("corrected_words", "Out"),
                           ("uncorrectable_words", "Out"), ("calib_error", "Out")):
            assert top[f"nuc_{port}{lane}"] == flow
    assert top["startup_cycles"] == "Out" and top["cds_ddr_frame_kind"] == "In"
    board = _members(design.top(p, board=True))
    assert not any("app_" in n or "nand_" in n for n in board)
    for name in ("nuc_calib_loaded_1", "nuc_bad_blocks", "startup_cycles",
                 "cds_ddr_ddr_error", "cds_ddr_ddr_reads_1"):
        assert board[name] == "Out"
    # a chain without external parts is the same top either way
    plain = design.chain_plan(_scene(pipeline={}))
    assert _members(design.top(plain, board=True)) == _members(design.top(plain))
    assert "startup_cycles" not in _members(design.top(plain))


def test_golden_chain_loads_the_coefficients_from_nand_as_the_scene_simulator_does():
    """With flash = "nand" the golden chain's NUC gets the coefficients the camera loads
    from the faulty part (defaults where a word is uncorrectable): the chain's output is
    the scene simulator's, and differs from the chain on the ideal coefficients."""
    sc = _scene(pipeline={"nuc": {"flash": "nand", "bad_blocks": 200, "flip_single": 0.25,
                                  "flip_double": 0.2, "seed": 3}})
    p = design.chain_plan(sc)
    assert p.steps[1].device["bad_blocks"] == 200 and p.steps[1].device["seed"] == 3
    data, ex = scene_data(sc, stages=4, dv_over_v=0.0, lines=3)
    gold = design.golden(p, data)
    assert np.array_equal(gold[-1][2].reshape(ex.output.shape), ex.output)
    from dataclasses import replace
    bare = replace(p, steps=tuple(replace(s, device={}) for s in p.steps))
    nuc0 = [g for g in gold if g[0] == "nuc_0"][0][2]
    assert not np.array_equal([g for g in design.golden(bare, data) if g[0] == "nuc_0"][0][2],
                              nuc0)


@pytest.mark.parametrize("ppc", [1, 4])
def test_coefficient_buffer_loads_once_and_replays(ppc):
    """CoeffBuffer in the Amaranth simulator, random idle cycles on the load and random
    backpressure on the replay: the image comes out three times over, ppc pixels a beat,
    markers on pixel 0 and on each row's last beat; nothing before the load is complete."""
    from amaranth.sim import Simulator
    from tdicam.hdl.calib import CoeffBuffer

    rows, cols, eb = 3, 8, 16
    rng = random.Random(ppc)
    gain = [[rng.randrange(1 << eb) for _ in range(cols)] for _ in range(rows)]
    off = [[rng.randrange(1 << eb) for _ in range(cols)] for _ in range(rows)]
    dut = CoeffBuffer(rows=rows, cols=cols, elem_bits=eb, ppc=ppc)
    got, early = [], []

    async def load(ctx):
        for r in range(rows):
            for c in range(cols):
                while rng.random() < 0.3:
                    await ctx.tick()
                ctx.set(dut.i_stream.payload.data[0], gain[r][c])
                ctx.set(dut.i_stream.payload.data[1], off[r][c])
                ctx.set(dut.i_stream.valid, 1)
                await ctx.tick().until(dut.i_stream.ready)
                ctx.set(dut.i_stream.valid, 0)

    async def sink(ctx):
        n = 0
        while len(got) < 3 * rows * cols // ppc:
            ready = rng.random() > 0.3
            ctx.set(dut.o_stream.ready, ready)
            await ctx.delay(1e-9)
            if ctx.get(dut.o_stream.valid):
                if not ctx.get(dut.loaded):
                    early.append(n)
                if ready:
                    d = [ctx.get(dut.o_stream.payload.data[k]) for k in range(2 * ppc)]
                    got.append((d, ctx.get(dut.o_stream.payload.first),
                                ctx.get(dut.o_stream.payload.last)))
            await ctx.tick()
            n += 1

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(load)
    sim.add_testbench(sink)
    sim.run_until(2e-5)
    per_row = cols // ppc
    want = []
    for _ in range(3):
        for r in range(rows):
            for b in range(per_row):
                d = [v for c in range(b * ppc, (b + 1) * ppc) for v in (gain[r][c], off[r][c])]
                want.append((d, int(r == 0 and b == 0), int(b == per_row - 1)))
    assert got == want and not early


def test_plan_states_the_calibration_load_and_the_cds_ddr_bandwidth():
    """tdicam plan of the system scene: the NAND load time before the first frame (the
    model's scan of every block at t_R plus the image's pages, 50 MHz controller) and the
    reset frame's DDR bandwidth against the interface at cds_ddr's measured efficiency."""
    from tdicam.api import plan
    from tdicam.model import nand_store
    from tdicam.model.ddr_efficiency import MEASURED_EFFICIENCY, PLAN_MARGIN
    rep = plan(ROOT / "scenes" / "ning2019_gmax0504_system.toml").to_dict()
    rows = {r["name"]: r for r in rep["system"]}
    t = nand_store.timing(8, 256)
    assert rows["calibration load"]["value"] == pytest.approx(t.scan_s + t.load_s)
    assert 0.1 < rows["calibration load"]["value"] < 0.11            # 4096 blocks x 25 us
    ddr = rows["CDS DDR bandwidth"]
    line = rep["design"]["line_period_s"]
    assert ddr["value"] == pytest.approx(2 * 8 * 11 * 32 / line)       # 11 words a line
    assert ddr["efficiency"] == pytest.approx(min(MEASURED_EFFICIENCY["cds_ddr"]) / 100
                                              - PLAN_MARGIN)
    assert ddr["ok"] is True and rep["feasible"]
    text = plan(ROOT / "scenes" / "ning2019_gmax0504_system.toml").text()
    assert "NUC calibration from NAND before the first frame: 104.2 ms" in text
    assert "CDS reset frame in DDR (cds_ddr): 88 words" in text
    # a chain without external parts has no system section
    assert plan(CHAIN).to_dict()["system"] is None


def test_system_verilog_is_deterministic_and_holds_no_model():
    """`tdicam verilog pipeline` of a system chain: the same text twice; the parts' models
    (the MIG model's memory, the NAND part) are not in it, the controller sides are."""
    p = design.chain_plan(_scene())
    a, b = design.verilog(p), design.verilog(p)
    assert a == b
    assert "nuc_nand0" in a and "cds_ddr_app_rd_data_valid_1" in a
    assert not re.search(r"\brqd\b", a)                   # the MIG model's read queue
    assert not re.search(r"reg \[7:0\] pages \[", a)      # the NAND part's pages


def test_plan_states_the_lanes_pixel_rate_and_training_time():
    """With the sensor's lanes ([sensor.lvds], the front end as the chain's source) the
    plan also states lanes x lane rate = pixel rate against the window's and the training
    time before the first frame."""
    from tdicam.model import lvds
    from tdicam.planning import sizing
    sc = load_scene(ROOT / "scenes" / "ning2019_gmax0504_system.toml", overrides={
        "pipeline": {"blocks": ["nuc", "hdr", "tdi", "median3"], "cds": None},
        "sensor": {"lvds": {"lanes_per_gain": 2}}})
    rep = sizing.plan_report([sc])
    rows = {r["name"]: r for r in rep["system"]}
    lane = rows["lane pixel rate"]
    assert lane["value"] == pytest.approx(4 * 300e6 / 12 * 128 / 130)   # sync + header
    assert lane["needed"] == pytest.approx(2 * 8 * 256 / rep["design"]["line_period_s"])
    assert lane["ok"] is True and "4 lanes x 300 Mbit/s / 12 bit" in lane["text"]
    from tdicam import blocks
    settle = {q.name: q.default for q in blocks.get("lvds").params}["settle"]
    assert rows["lane training"]["value"] == pytest.approx(        # 25 M words/s a lane
        lvds.training_words(12, 16, settle) / 25e6)
    assert "calibration load" in rows


def _lanes_in_amaranth(*, lanes_per_gain=2, stages=3, lines=2, fifo_depth=None,
                       lead=40, tail=100, ddr=None):
    """The system scene with the sensor's lanes ([sensor.lvds]; a 16-column crop, 16-block
    NAND parts) whole in Amaranth's simulator, two clocks at the camera's rates (25 M
    words/s a lane: 300 Mbit/s of 12-bit words; 100 MHz processing), the MIG model's
    default stalls behind cds_ddr: (plan, golden output, run result, start-up record)."""
    from dataclasses import replace
    from tdicam.cosim.lvds_front import GOOD_LANES, plan_case, run_amaranth, scenario_lanes
    sc = load_scene(ROOT / "scenes" / "ning2019_gmax0504_system.toml", overrides={
        "sensor": {"columns": 16, "lvds": {"lanes_per_gain": lanes_per_gain}},
        "tdi": {"stages": stages}, "run": {"lines": lines}, "ddr": {"base": 0, **(ddr or {})}})
    p = design.chain_plan(sc)
    p = replace(p, steps=tuple(replace(s, device={**s.device, "blocks": 16}) if s.device
                               else s for s in p.steps))
    if fifo_depth is not None:
        p = replace(p, steps=(replace(p.steps[0], params={**p.steps[0].params,
                                                          "fifo_depth": fifo_depth}),)
                    + p.steps[1:])
    data, _ = scene_data(sc, stages=stages, dv_over_v=0.0, lines=lines)
    ax = design.top(p, data, board=True)
    ax._MustUse__silence = True                  # its board is simulated
    board = ax.core
    lanes = scenario_lanes((GOOD_LANES * 2)[:2 * lanes_per_gain])
    case = plan_case(p, data, lanes, word_ns=40.0, proc_ns=10.0, n_check=4, tail=tail,
                     lead=lead)
    settings = {f"{s.block}_{k}": v for s in p.steps[1:] for k, v in s.ports.items()
                if hasattr(board, f"{s.block}_{k}")}
    seen = {}

    def hook(ctx, dut, k):
        for name in ("lvds_trained", "nuc_calib_loaded", "nuc_calib_loaded_1",
                     "lvds_releasing"):
            if name not in seen and ctx.get(getattr(dut, name)):
                seen[name] = k
        for name in ("startup_cycles", "cds_ddr_ddr_writes", "cds_ddr_ddr_reads",
                     "cds_ddr_ddr_writes_1", "nuc_calib_error", "tdi_frame_errors"):
            seen[name] = ctx.get(getattr(dut, name))
    res = run_amaranth(case, dut=board, prefix="lvds_", settings=settings, elems=1,
                       hook=hook)
    return p, design.golden(p, data)[-1][2], res, seen, board


def test_system_from_serial_lanes_to_output_in_amaranth():
    """The system scene with the sensor's lanes ([sensor.lvds], 2 lanes a gain as the
    scene's window, a 16-column crop, 3 TDI stages, a 16-block NAND part) whole in
    Amaranth's simulator, two clocks at the camera's rates (25 M words/s a lane: 300 Mbit/s
    of 12-bit words; 100 MHz processing):
    the lanes carry each reset frame before its signal frame (the kind in the row headers:
    the front's frame_kind drives cds_ddr's), the start-up -- lane training (word clock),
    the NAND scan and calibration load (processing clock), then frames released -- and the
    output of median3 equal to the golden chain's, bit for bit. The rate ratio is
    r = f_clk / (2 f_word) = 2 (r = 1: :func:`test_front_fifo_takes_the_ddr_stalls_at_r_1`)."""
    from tdicam.cosim.lvds_front import frames_of
    p, exp, res, seen, board = _lanes_in_amaranth()
    assert [s.block for s in p.steps] == ["lvds", "cds_ddr", "nuc", "hdr", "tdi", "median3"]
    assert p.reset_frames and p.steps[0].params["pairs"] == 1
    assert "cds_ddr_frame_kind" not in board.signature.members   # it comes from the lanes
    st = res["status"]
    assert (st["frames_out"], st["frames_dropped"], st["fifo_overflow"], st["lane_error"]) \
        == (2 * p.frames, 0, 0, 0)
    got = frames_of(res["beats"], exp.shape[1], 16, 1, 1)[0]
    assert got.shape == exp.shape and np.array_equal(got, exp)
    # start-up: the calibration loaded and the lanes trained before the first frame is
    # released; the top held its input for the load (processing clocks)
    assert max(seen["nuc_calib_loaded"], seen["nuc_calib_loaded_1"],
               seen["lvds_trained"]) < seen["lvds_releasing"]
    assert abs(seen["startup_cycles"] - 4 * seen["nuc_calib_loaded"]) <= 8
    assert seen["nuc_calib_error"] == 0 and seen["tdi_frame_errors"] == 0
    # each reset frame went to DDR and came back once (channel 0), channel 1 the same
    assert seen["cds_ddr_ddr_writes"] == seen["cds_ddr_ddr_reads"] == \
        seen["cds_ddr_ddr_writes_1"] > 0
    print(f"start-up: lanes trained at word clock {seen['lvds_trained']}, calibration "
          f"loaded after {seen['startup_cycles']} processing clocks, first frame released "
          f"at word clock {seen['lvds_releasing']}")


#: A MIG model stall pattern with long refreshes (200 of every 2000 cycles, reads up to 90
#: cycles late): the worst stall 290 processing clocks (tdicam.model.dram.worst_stall)
LONG_STALLS = {"refresh_period": 2000, "refresh_cycles": 200, "lat_hi": 90}


def test_front_fifo_takes_the_ddr_stalls_at_r_1():
    """4 lanes a gain at 25 M words/s into a 100 MHz processing clock: r = f_clk / (4 f_word)
    = 1, the front's no-backpressure stream behind cds_ddr and the MIG model's long
    refreshes. The crossing FIFO is sized with the DDR model's worst stall (refresh cycles
    + the longest read latency, 290 clocks = 73 entries at the slowest clock the lanes
    allow): no overflow, every frame out, median3's output bit-exact; at the depth of
    before the margin (16, the line burst only) the FIFO overflows and pixels are lost."""
    from tdicam.cosim.lvds_front import frames_of
    from tdicam.model import lvds_front
    from tdicam.model.dram import worst_stall
    p, exp, res, _, _ = _lanes_in_amaranth(lanes_per_gain=4, stages=8, ddr=LONG_STALLS)
    assert worst_stall(p.steps[1].params) == 290
    slowest = 25.0 * 4 * 4 / 6                     # P = 4 words a line + sync + header
    depth = p.steps[0].params["fifo_depth"]
    assert depth == lvds_front.fifo_depth(4, 1, 16, 25.0, slowest, stall_cycles=290) == 128
    assert lvds_front.fifo_depth(4, 1, 16, 25.0, slowest) == 16        # without the margin
    st = res["status"]
    assert (st["frames_out"], st["frames_dropped"], st["fifo_overflow"]) == (2 * p.frames, 0, 0)
    got = frames_of(res["beats"], exp.shape[1], 16, 1, 1)[0]
    assert got.shape == exp.shape and np.array_equal(got, exp)
    # the depth of before: overflow, pixels lost (a shorter run shows it)
    _, exp, res, _, _ = _lanes_in_amaranth(lanes_per_gain=4, stages=3, ddr=LONG_STALLS,
                                           fifo_depth=16)
    assert res["status"]["fifo_overflow"] == 1
    assert len(res["beats"]) < exp.size


@pytest.mark.parametrize("over, match", [
    ({"ddr": {"base": 0, "refresh_period": 100, "refresh_cycles": 100}},
     r"^\[ddr\]\.refresh_cycles = 100 must be < \[ddr\]\.refresh_period = 100$"),
    ({"ddr": {"base": 0, "lat_lo": 50, "lat_hi": 40}},
     r"^\[ddr\]\.lat_lo = 50 must be <= \[ddr\]\.lat_hi = 40$"),
    ({"ddr": {"base": 0, "drop": 256}}, r"^\[ddr\]\.drop = 256 is out of range"),
    ({"run": {"rtl": {"lane_dies": [0, 1]}}},
     r"^\[run\.rtl\]\.lane_dies: needs the sensor's lanes \(\[sensor\.lvds\]\)"),
    ({"sensor": {"lvds": {"lanes_per_gain": 2}}, "run": {"rtl": {"lane_dies": [4, 1]}}},
     r"^\[run\.rtl\]\.lane_dies: needs a lane 0\.\.3 and a frame >= 0, got \[4, 1\]"),
    ({"sensor": {"lvds": {"lanes_per_gain": 2}}, "run": {"rtl": {"lane_dies": 3}}},
     r"^\[run\.rtl\]\.lane_dies: must be two integers \[lane, frame\], got 3"),
])
def test_ddr_stalls_and_lane_death_keys_are_checked_in_one_line(over, match):
    with pytest.raises(TdicamError, match=match) as exc:
        load_scene(ROOT / "scenes" / "ning2019_gmax0504_system.toml", overrides=over)
    assert "\n" not in str(exc.value)


def test_ddr_stall_keys_reach_the_ddr_blocks_and_the_report():
    """[ddr]'s stall settings become cds_ddr's MIG model parameters (only those given away
    from the defaults: the bundled scenes' Verilog unchanged) and the scene's dict."""
    sc = load_scene(ROOT / "scenes" / "ning2019_gmax0504_system_lanes_faults.toml")
    p = design.chain_plan(sc)
    assert {k: p.steps[1].params[k] for k in LONG_STALLS} == LONG_STALLS
    assert sc.to_dict()["ddr"] == {"interface": "mig", "base": 0, **LONG_STALLS}
    assert sc.run.rtl.lane_dies == (0, 5)
    plain = load_scene(ROOT / "scenes" / "ning2019_gmax0504_system.toml")
    assert plain.to_dict()["ddr"] == {"interface": "mig", "base": 0}
    assert "refresh_cycles" not in design.chain_plan(plain).steps[0].params
    assert "lane_dies" not in plain.to_dict()["run"]["rtl"]


def test_a_lane_death_in_a_reset_frame_is_refused_before_the_build():
    """With reset frames in the stream the dying lane's frame must be a signal frame; the
    co-simulation says so in one line before building anything."""
    from tdicam.chain.cosim import cosimulate
    sc = load_scene(ROOT / "scenes" / "ning2019_gmax0504_system.toml", overrides={
        "sensor": {"columns": 16, "lvds": {"lanes_per_gain": 2}}, "tdi": {"stages": 3},
        "run": {"lines": 2}})
    p = design.chain_plan(sc)
    data, _ = scene_data(sc, stages=3, dv_over_v=0.0, lines=2)
    for dies, match in (((0, 2), r"frame 2 is a reset frame"),
                        ((0, 7), r"needs a lane 0\.\.3 and a frame before the last 3")):
        with pytest.raises(TdicamError, match=r"^\[run\.rtl\]\.lane_dies = \[0, \d\]: .*"
                                              + match):
            cosimulate(p, data, "icarus", front={"dies": dies})


def test_plan_states_the_crossing_fifo_depth_and_why():
    """tdicam plan of the lanes scene: the crossing FIFO's depth with the DDR stall margin
    (cds_ddr behind the front, the MIG model's refresh 44 + read latency 60 clocks)."""
    from tdicam.planning import sizing
    rep = sizing.plan_report([load_scene(ROOT / "scenes" /
                                         "ning2019_gmax0504_system_lanes.toml")])
    row = {r["name"]: r for r in rep["system"]}["crossing FIFO"]
    assert (row["value"], row["without_stall_margin"], row["stall_cycles"]) == (64, 16, 104)
    assert "worst stall behind it (104 clocks" in row["text"]


def test_two_clock_verilog_is_the_same_in_every_process(tmp_path):
    """A top with the lanes' word clock and the processing clock: the same Verilog under
    different string hashes (Amaranth took its undefined domains from a set of names, so the
    clock ports came out in an order that changed from one run to the next)."""
    import os
    import subprocess
    import sys
    texts = []
    for seed in ("1", "2"):
        out = tmp_path / f"lanes_{seed}.v"
        subprocess.run([sys.executable, "-m", "tdicam", "verilog", "pipeline", "--no-csr",
                        "--scene",
                        str(ROOT / "scenes" / "ning2019_gmax0504_system_lanes.toml"), "-o",
                        str(out)], check=True, capture_output=True,
                       env={**os.environ, "PYTHONHASHSEED": seed})
        texts.append(out.read_text())
    assert texts[0] == texts[1]
    assert ", clk, rst, word_clk, word_rst," in texts[0]
    # --no-csr: the loose-port top of before the bus was the default (issue 49), pinned
    import hashlib
    import tdicam
    assert hashlib.sha256(texts[0].replace(tdicam.__version__, "VERSION").encode()
                          ).hexdigest() == NO_CSR_LANES_SHA256


def test_a_failing_run_names_the_fronts_lost_words_first():
    from tdicam.chain.cosim import OVERFLOW, lead_with_overflow
    bad = "first mismatch in block median3 (tap median3): frame 1, line 0, column 7"
    lost = lead_with_overflow({"message": bad, "status_outputs": {OVERFLOW: 1}})
    assert lost.startswith("the front's crossing FIFO overflowed (lvds_fifo_overflow = 1")
    assert lost.endswith("; " + bad) and "\n" not in lost
    # no overflow, no status, or a match: the message as it was
    assert lead_with_overflow({"message": bad, "status_outputs": {OVERFLOW: 0}}) == bad
    assert lead_with_overflow({"message": bad}) == bad
    assert lead_with_overflow({"message": "match", "status_outputs": {OVERFLOW: 1}}) == "match"


def test_the_frame_buffers_model_error_and_the_fronts_problems_are_counted():
    """A run's status beside its taps: the front's problems (each one counted) in one
    message, the output links' frame buffer's MIG model error in another; without a frame
    buffer among the status outputs, none of it."""
    from tdicam.chain.cosim import frame_buffer_traffic, status_problems
    ok = {"frame_buffer_ddr_writes": 24, "frame_buffer_ddr_reads": 24,
          "frame_buffer_ddr_stalls": 5, "frame_buffer_ddr_error": 0}
    assert frame_buffer_traffic(ok) == {"writes": 24, "reads": 24, "stalls": 5, "error": 0}
    assert frame_buffer_traffic({"ddr_writes": 3}) is None
    assert status_problems([], ok) == ([], 0, frame_buffer_traffic(ok))
    msgs, n, fb = status_problems(["lane 3 unlocked", "lane 5 unlocked"],
                                  {**ok, "frame_buffer_ddr_error": 1})
    assert n == 3 and fb["error"] == 1 and len(msgs) == 2
    assert msgs[0] == ("the front's status differs from its golden model: lane 3 unlocked; "
                       "lane 5 unlocked")
    assert msgs[1].startswith("the frame buffer's MIG model flagged an error "
                              "(frame_buffer_ddr_error = 1")
    assert status_problems(["x"], {}) == (
        ["the front's status differs from its golden model: x"], 1, None)
