"""The camera top's register map (tdicam.hdl.csr_map) and its files (tdicam.chain.registers).

The orbit chain's map from its ports (widths, access, reset values the scene's); the system
lanes scene's (the NAND load's status per lane, not the NAND bus; the sensor front end's
word-clock ports left as ports); the SystemRDL compiled by systemrdl-compiler; the C header
from peakrdl-cheader compiled with ``cc -fsyntax-only`` with every register's offset and reset
asserted equal to the map's (the cocotb test, cocotb_tests/test_csr.py, reads the gateware at
the header's offsets); ``tdicam verilog pipeline --csr -o DIR`` writes the four files beside
the Verilog; the top without ``--csr`` keeps its loose ports; the AXI4-Lite slave's
handshakes, byte strobes, write-1-to-clear and interrupt in Amaranth's simulator.
"""

import importlib.util
import shutil
import subprocess
from pathlib import Path

import pytest
from amaranth.hdl import Module, Shape
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out
from amaranth.sim import Simulator

from tdicam import cli
from tdicam.chain import design, registers
from tdicam.errors import TdicamError
from tdicam.hdl.csr import CsrTop
from tdicam.hdl.csr_map import BLOCK_STRIDE, CAMERA_REGISTERS, Register, RegisterMap
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature

pytest.importorskip("systemrdl")
# tops built only to read their ports and maps (never elaborated)
pytestmark = pytest.mark.filterwarnings("ignore::amaranth.hdl.UnusedElaboratable")
ROOT = Path(__file__).resolve().parents[1]


def _plan(name, **kw):
    return design.chain_plan(design.load_pipeline_scene(ROOT / "scenes" / f"{name}.toml"), **kw)


@pytest.fixture(scope="module")
def orbit():
    p = _plan("orbit_chain", stages=4)
    ax = design.top(p, csr=True)
    return p, ax


def test_orbit_chain_map_from_its_ports(orbit):
    p, ax = orbit
    rm = ax.core.regmap
    pl = ax.core.core
    rows = [(r.block, r.name, r.offset, r.width, r.access, r.reset) for r in rm.registers]
    assert rows[:len(CAMERA_REGISTERS)] == [
        ("camera", n, 4 * k, 32 if n in ("id", "version", "frame_count") else
         1 if n == "startup" else 2, acc, r.reset)
        for k, ((n, acc, _), r) in enumerate(zip(CAMERA_REGISTERS, rm.registers))]
    width = {n: Shape.cast(m.shape).width for n, m in pl.signature.members.items()
             if m.is_port}
    tdi = 1 + [s.block for s in p.steps].index("tdi")
    assert rows[len(CAMERA_REGISTERS):] == [
        ("tdi", "stages_active", tdi * BLOCK_STRIDE, width["tdi_stages_active"], "rw", 4),
        ("tdi", "direction", tdi * BLOCK_STRIDE + 4, 1, "rw", 0),
        ("tdi", "frame_errors", tdi * BLOCK_STRIDE + 8, 16, "w1c", 0),
        ("median3", "height", (tdi + 1) * BLOCK_STRIDE, 16, "rw",
         design.run_values(p)["median3_height"]),
        ("median3", "marker_error", (tdi + 1) * BLOCK_STRIDE + 4, 1, "ro", 0)]
    assert [r.name for r in rm.faults] == ["frame_errors", "marker_error"]
    # the ports the map stands for are gone from the top; the bus and irq are there
    members = ax.signature.members
    assert not rm.ports & set(members) and "irq" in members and "s_axil_rdata" in members
    plain = design.top(p)
    assert rm.ports <= set(plain.signature.members)
    assert not any(n.startswith("s_axil") or n == "irq" for n in plain.signature.members)


def test_system_lanes_map_has_the_nand_load_status_not_its_bus():
    p = _plan("ning2019_gmax0504_system_lanes")
    rm = design.register_map(p)
    nuc = {r.name: r for r in rm.registers if r.block == "nuc"}
    assert set(nuc) == {f"{n}{s}" for n in ("calib_loaded", "bad_blocks", "corrected_words",
                                            "uncorrectable_words", "calib_error")
                        for s in ("", "_1")}
    assert nuc["bad_blocks_1"].access == "w1c" and nuc["bad_blocks_1"].fault
    assert nuc["calib_loaded"].access == "ro" and not nuc["calib_loaded"].fault
    assert rm.get("camera", "startup_cycles").access == "ro"
    assert not any(r.block == "lvds" for r in rm.registers)       # the word clock's ports
    assert rm.get("cds_ddr", "line_errors_1").access == "w1c"
    assert not any("nand_" in r.name or "app_" in r.name for r in rm.registers)
    registers.compile_rdl(registers.rdl_text(rm))


def test_invalid_rdl_is_one_line():
    with pytest.raises(TdicamError, match="not valid SystemRDL"):
        registers.compile_rdl("addrmap x { reg { field {} f[40:0]; } r @ 0; };")


def _c_check(rm, tmp_path, header_map=None):
    """A C file asserting the header's (of ``header_map``, default ``rm``) offsets, resets
    and widths equal ``rm``'s, compiled with ``cc -fsyntax-only``."""
    header = registers.c_header(registers.compile_rdl(registers.rdl_text(header_map or rm)))
    (tmp_path / f"{rm.name}.h").write_text(header)
    lines = ["#include <stddef.h>", f'#include "{rm.name}.h"']
    for r in rm.registers:
        path = r.name if r.block == "camera" else f"{r.block}.{r.name}"
        macro = "__".join(x.upper() for x in (rm.name, *([] if r.block == "camera" else
                                                          [r.block]), r.name, "value"))
        lines += [f"_Static_assert(offsetof({rm.name}_t, {path}) == {r.offset:#x}, "
                  f'"{path}");',
                  f'_Static_assert({macro}_reset == {r.reset:#x}, "{path} reset");',
                  f'_Static_assert({macro}_bw == {r.width}, "{path} width");']
    (tmp_path / "check.c").write_text("\n".join(lines) + "\n")
    return subprocess.run(["cc", "-std=c11", "-fsyntax-only", "-Wall", "-Werror",
                           str(tmp_path / "check.c")], capture_output=True, text=True)


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("scene", ["orbit_chain", "ning2019_gmax0504_system_lanes"])
def test_c_header_compiles_with_the_maps_offsets(scene, tmp_path):
    rm = design.register_map(_plan(scene))
    res = _c_check(rm, tmp_path)
    assert res.returncode == 0, res.stderr
    # and the check can fail: one offset wrong
    from dataclasses import replace
    r = rm.registers[-1]
    bad = replace(rm, registers=rm.registers[:-1] + (replace(r, offset=r.offset + 4),))
    res = _c_check(bad, tmp_path, header_map=rm)
    assert res.returncode != 0 and r.name in res.stderr


def test_verilog_csr_writes_the_maps_files_beside_the_verilog(tmp_path, capsys):
    out = tmp_path / "top"
    assert cli.main(["verilog", "pipeline", "--scene", str(ROOT / "scenes" / "orbit_chain.toml"),
                     "--stages", "4", "--csr", "-o", str(out)]) == 0
    names = sorted(f.name for f in out.iterdir())
    assert names == ["orbit_chain.h", "orbit_chain.rdl", "orbit_chain_registers.md",
                     "orbit_chain_regs.py", "pipeline.v"]
    v = (out / "pipeline.v").read_text()
    assert "csr=axi4-lite" in v and "s_axil_awaddr" in v and "tdi_stages_active" not in \
        v.split(");")[0]
    assert "| 0x200|" in (out / "orbit_chain_registers.md").read_text().replace(
        "0x200|     tdi", "0x200|")
    spec = importlib.util.spec_from_file_location("regs", out / "orbit_chain_regs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rm = design.register_map(_plan("orbit_chain", stages=4))
    assert mod.OFFSETS == {f"{r.block}.{r.name}": r.offset for r in rm.registers}
    assert mod.FAULTS == ("tdi.frame_errors", "median3.marker_error")
    assert "wrote" in capsys.readouterr().err


class _Core(wiring.Component):
    """A stand-in top: an idle output stream, a 12-bit setting, an 8-bit fault counter and a
    fault flag (the status driven by the testbench)."""

    def __init__(self):
        super().__init__({"o_stream": Out(pixel_signature(channels_shape(8, 1))),
                          "blk_level": In(12), "blk_errors": Out(8), "blk_error": Out(1)})

    def elaborate(self, platform):
        return Module()


def _slave():
    core = _Core()
    regs = [Register("camera", n, 4 * k, 32 if n in ("id", "version", "frame_count") else
                     1 if n == "startup" else 2, acc, {"id": 7}.get(n, 0), None, False, "")
            for k, (n, acc, _) in enumerate(CAMERA_REGISTERS)]
    regs += [Register("blk", "level", 0x100, 12, "rw", 0x5A5, "blk_level", False, ""),
             Register("blk", "errors", 0x104, 8, "w1c", 0, "blk_errors", True, ""),
             Register("blk", "error", 0x108, 1, "ro", 0, "blk_error", True, "")]
    return core, CsrTop(core, RegisterMap("t", tuple(regs)))


def test_axi_lite_slave_protocol_strobes_and_write_1_to_clear():
    """The slave on its own (Amaranth simulator): a write waits for both address and data
    and holds its response until bready; a read holds its data until rready; byte strobes;
    an unmapped address reads 0; a fault counter read since its clear, 1s clear those bits;
    a change of a fault source sets its interrupt bit, irq when enabled; 1s clear it."""
    core, dut = _slave()
    seen = {}

    async def write(ctx, addr, data, strb=0xF, bready_after=0, w_after=0):
        ctx.set(dut.s_axil_awaddr, addr)
        ctx.set(dut.s_axil_awvalid, 1)
        for _ in range(w_after):                      # the address alone is not taken
            assert not ctx.get(dut.s_axil_awready)
            await ctx.tick()
        ctx.set(dut.s_axil_wdata, data)
        ctx.set(dut.s_axil_wstrb, strb)
        ctx.set(dut.s_axil_wvalid, 1)
        assert ctx.get(dut.s_axil_awready) and ctx.get(dut.s_axil_wready)
        await ctx.tick()
        ctx.set(dut.s_axil_awvalid, 0)
        ctx.set(dut.s_axil_wvalid, 0)
        for _ in range(bready_after):                 # the response waits for bready
            assert ctx.get(dut.s_axil_bvalid)
            await ctx.tick()
        ctx.set(dut.s_axil_bready, 1)
        assert ctx.get(dut.s_axil_bvalid) and ctx.get(dut.s_axil_bresp) == 0
        await ctx.tick()
        ctx.set(dut.s_axil_bready, 0)

    async def read(ctx, addr, rready_after=0):
        ctx.set(dut.s_axil_araddr, addr)
        ctx.set(dut.s_axil_arvalid, 1)
        assert ctx.get(dut.s_axil_arready)
        await ctx.tick()
        ctx.set(dut.s_axil_arvalid, 0)
        value = ctx.get(dut.s_axil_rdata)
        for _ in range(rready_after):                 # held until rready
            assert ctx.get(dut.s_axil_rvalid) and ctx.get(dut.s_axil_rdata) == value
            await ctx.tick()
        ctx.set(dut.s_axil_rready, 1)
        assert ctx.get(dut.s_axil_rvalid) and ctx.get(dut.s_axil_rresp) == 0
        await ctx.tick()
        ctx.set(dut.s_axil_rready, 0)
        return value

    async def tb(ctx):
        seen["id"] = await read(ctx, 0x000, rready_after=3)
        seen["level0"] = (await read(ctx, 0x100), ctx.get(core.blk_level))
        await write(ctx, 0x100, 0xFFFF_F0C3, strb=0b0001, w_after=2, bready_after=2)
        seen["level1"] = (await read(ctx, 0x100), ctx.get(core.blk_level))
        seen["unmapped"] = await read(ctx, 0x10C)
        await write(ctx, 0x014, 0b11)                 # irq_enable
        ctx.set(core.blk_errors, 5)
        await ctx.tick()
        seen["irq_on_count"] = (ctx.get(dut.irq), await read(ctx, 0x018))
        seen["errors"] = await read(ctx, 0x104)
        await write(ctx, 0x104, 0b100)
        seen["errors_cleared_bit2"] = await read(ctx, 0x104)
        ctx.set(core.blk_errors, 7)
        await ctx.tick()
        seen["errors_after_two_more"] = await read(ctx, 0x104)
        await write(ctx, 0x104, 0xFF)
        await write(ctx, 0x018, 0b01)
        seen["cleared"] = (await read(ctx, 0x104), await read(ctx, 0x018), ctx.get(dut.irq),
                           await read(ctx, 0x010))
        ctx.set(core.blk_error, 1)
        await ctx.tick()
        seen["flag"] = (await read(ctx, 0x018), await read(ctx, 0x010), ctx.get(dut.irq))

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    assert seen["id"] == 7
    assert seen["level0"] == (0x5A5, 0x5A5)
    assert seen["level1"] == (0x5C3, 0x5C3)           # only the low byte written
    assert seen["unmapped"] == 0
    assert seen["irq_on_count"] == (1, 0b01)
    assert seen["errors"] == 5 and seen["errors_cleared_bit2"] == 1
    assert seen["errors_after_two_more"] == 3
    assert seen["cleared"] == (0, 0, 0, 0)
    assert seen["flag"] == (0b10, 0b10, 1)


def test_a_map_of_another_top_is_refused():
    core = _Core()
    bad = RegisterMap("t", (Register("blk", "gain", 0x100, 8, "rw", 0, "blk_gain", False, ""),))
    with pytest.raises(TdicamError, match="port\\(s\\) blk_gain the top does not have"):
        CsrTop(core, bad)
    core._MustUse__silence = True
