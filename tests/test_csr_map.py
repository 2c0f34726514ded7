"""The camera top's register map (tdicam.hdl.csr_map) and its files (tdicam.chain.registers).

The orbit chain's map from its ports (widths, access, reset values the scene's); the system
lanes scene's (the NAND load's status per lane, not the NAND bus; the sensor front end's
word-clock settings and status with their domain, its lane pins and retrain strobe left as
ports); the SystemRDL compiled by systemrdl-compiler; the C header
from peakrdl-cheader compiled with ``cc -fsyntax-only`` with every register's offset and reset
asserted equal to the map's (the cocotb test, cocotb_tests/test_csr.py, reads the gateware at
the header's offsets); the IP-XACT component's offsets the map's; ``tdicam verilog pipeline
-o DIR`` (the bus on by default) writes the files beside the Verilog (``--html`` the HTML
reference too), a missing tool one line naming the extra; the top with ``--no-csr`` keeps
its loose ports, its Verilog that of before (sha256 pinned); every word of the 12-bit space
reading its register's live value or 0 on both buses; the AXI4-Lite slave's handshakes,
byte strobes, write-1-to-clear and interrupt, the Wishbone slave's (classic and pipelined)
the same register file, and the clock-domain crossing of another domain's settings and
status, in Amaranth's simulator.
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
from tdicam.hdl.csr import BUSES, CsrTop
from tdicam.hdl.csr_map import ADDR_BITS, BLOCK_STRIDE, CAMERA_REGISTERS, Register, RegisterMap
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
    lv = {r.name: r for r in rm.registers if r.block == "lvds"}   # the word clock's, crossed
    assert {r.domain for r in lv.values()} == {"word"}
    assert [n for n, r in lv.items() if r.access == "rw"] == [
        "train_word", "sync_word", "n_check", "frame_rows"]
    assert lv["train_word"].reset == design.run_values(p)["lvds_train_word"]
    assert {r.hold for r in lv.values() if r.access == "rw"} == {"lvds_releasing"}
    assert "retrain" not in lv and "lane_raw" not in lv and "lane_tap" not in lv
    assert lv["lane_error"].fault and lv["lane_error"].mask and lv["lane_error"].access == "ro"
    assert lv["lanes_bad"].mask and not lv["lanes_bad"].fault
    assert lv["lane_errors"].access == "w1c" and lv["fifo_overflow"].fault
    assert rm.get("cds_ddr", "line_errors_1").access == "w1c"
    assert not any("nand_" in r.name or "app_" in r.name for r in rm.registers)
    registers.compile_rdl(registers.rdl_text(rm))


def test_the_fronts_eye_status_in_the_map_where_it_fits():
    """With ``[sensor.lvds].eye_status`` the front's training status is in the map where it
    fits in a register (the chosen taps, the slips, the eye widths found; the walking-1/0
    flags a lane mask), the 32-tap pass masks of every lane (128 bits) left as ports."""
    sc = design.load_pipeline_scene(ROOT / "scenes" / "ning2019_gmax0504_system_lanes.toml")
    from dataclasses import replace
    sc = replace(sc, sensor=replace(sc.sensor, lvds=replace(sc.sensor.lvds, eye_status=True)))
    rm = design.register_map(design.chain_plan(sc))
    lv = {r.name: r for r in rm.registers if r.block == "lvds"}
    assert {"lane_chosen_tap", "lane_slip", "lane_run", "lane_walk_ok"} <= set(lv)
    assert lv["lane_walk_ok"].mask and lv["lane_chosen_tap"].width == 20
    assert "lane_scan" not in lv and "lane_walk" not in lv          # 128 and 96 bits
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


#: sha256 of ``tdicam verilog pipeline --no-csr --stages 4`` of the orbit chain (the tdicam
#: version in its header as ``VERSION``): the top of before the control bus was the default
#: (at its 96 stages, 6b64da0c...: checked by hand, 20 s of elaboration), with median3 at
#: ppc 2 (4 stages of ppc 8) keeping its saturated column in registers of its own and the
#: DDR blocks' LineWriter early sums at ppc >= 2 (the whole camera's timing, 2026-12-02).
NO_CSR_ORBIT_SHA256 = "04525c71120657c6c576c47877c038fd4774ea4ef57fd2af972dfa2f1ba209eb"


def test_no_csr_is_the_loose_port_top_of_before(tmp_path):
    """``--no-csr``: the orbit chain's Verilog byte for byte that of before the bus was the
    default (the system lanes scene's: tests/test_system.py); ``--csr`` is still accepted,
    the default's meaning."""
    import hashlib
    import tdicam
    out = tmp_path / "o.v"
    assert cli.main(["verilog", "pipeline", "--no-csr", "--scene",
                     str(ROOT / "scenes" / "orbit_chain.toml"), "--stages", "4", "-o",
                     str(out)]) == 0
    text = out.read_text()
    assert "tdi_stages_active" in text.split(");")[0] and "s_axil_" not in text
    assert hashlib.sha256(text.replace(tdicam.__version__, "VERSION").encode()
                          ).hexdigest() == NO_CSR_ORBIT_SHA256


@pytest.mark.parametrize("flags", [[], ["--csr"]])
def test_verilog_csr_writes_the_maps_files_beside_the_verilog(flags, tmp_path, capsys):
    out = tmp_path / "top"
    assert cli.main(["verilog", "pipeline", "--scene", str(ROOT / "scenes" / "orbit_chain.toml"),
                     "--stages", "4", *flags, "-o", str(out)]) == 0
    names = sorted(f.name for f in out.iterdir())
    assert names == ["orbit_chain.h", "orbit_chain.rdl", "orbit_chain.xml",
                     "orbit_chain_registers.md", "orbit_chain_regs.py", "pipeline.v"]
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


def test_ipxact_component_has_the_maps_offsets():
    """The IP-XACT (IEEE 1685-2014) component from peakrdl-ipxact: every register at the
    map's absolute offset, with its width and reset."""
    import xml.etree.ElementTree as ET
    pytest.importorskip("peakrdl_ipxact")
    rm = design.register_map(_plan("ning2019_gmax0504_system_lanes"))
    ns = {"ipxact": "http://www.accellera.org/XMLSchema/IPXACT/1685-2014"}
    root = ET.fromstring(registers.ipxact(registers.compile_rdl(registers.rdl_text(rm))))

    def num(text):
        return int(text.replace("'h", "0x"), 0)
    got = {}
    block = root.find(".//ipxact:addressBlock", ns)
    for node in block:
        tag = node.tag.split("}")[1]
        if tag == "register":
            got[("camera", node.find("ipxact:name", ns).text)] = num(
                node.find("ipxact:addressOffset", ns).text)
        elif tag == "registerFile":
            base = num(node.find("ipxact:addressOffset", ns).text)
            for reg in node.findall("ipxact:register", ns):
                got[(node.find("ipxact:name", ns).text, reg.find("ipxact:name", ns).text)] = \
                    base + num(reg.find("ipxact:addressOffset", ns).text)
    assert got == {(r.block, r.name): r.offset for r in rm.registers}


@pytest.mark.parametrize("module", ["systemrdl", "peakrdl_ipxact"])
def test_verilog_csr_without_the_tools_is_one_line(module, tmp_path, capsys, monkeypatch):
    """A machine without the csr extra (its module's import fails): one line naming the
    extra, before any file is written."""
    import sys
    monkeypatch.setitem(sys.modules, module, None)       # import raises ImportError
    out = tmp_path / "top"
    assert cli.main(["verilog", "pipeline", "--scene", str(ROOT / "scenes" / "orbit_chain.toml"),
                     "--stages", "4", "--csr", "-o", str(out)]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'tdicam[csr]'" in err[0], err
    assert registers.TOOLS[module] in err[0] and "Traceback" not in err[0]
    assert not (out / "pipeline.v").exists()


@pytest.mark.skipif(importlib.util.find_spec("peakrdl_html") is None, reason="peakrdl-html")
def test_html_reference_on_request_deterministic(tmp_path):
    """``html_ref``: the HTML reference (peakrdl-html) beside the others, the same bytes
    twice (no time stamp, no path of the machine)."""
    rm = design.register_map(_plan("orbit_chain", stages=4))

    def texts(d):
        files = registers.write_files(rm, d, html_ref=True)
        top = Path(files["html"])
        return {str(f.relative_to(top)): f.read_bytes() for f in top.rglob("*.html")}
    a, b = texts(tmp_path / "a"), texts(tmp_path / "b")
    assert a == b and "index.html" in a and len(a) > len(rm.registers)
    assert not any(str(tmp_path).encode() in v for v in a.values())
    assert b"stages_active" in b"".join(a.values())


class _Core(wiring.Component):
    """A stand-in top: an idle output stream, a 12-bit setting, an 8-bit fault counter and a
    fault flag (the status driven by the testbench)."""

    def __init__(self):
        super().__init__({"o_stream": Out(pixel_signature(channels_shape(8, 1))),
                          "blk_level": In(12), "blk_errors": Out(8), "blk_error": Out(1)})

    def elaborate(self, platform):
        return Module()


def _slave(bus="axi4-lite"):
    core = _Core()
    regs = [Register("camera", n, 4 * k, 32 if n in ("id", "version", "frame_count") else
                     1 if n == "startup" else 2, acc, {"id": 7}.get(n, 0), None, False, "")
            for k, (n, acc, _) in enumerate(CAMERA_REGISTERS)]
    regs += [Register("blk", "level", 0x100, 12, "rw", 0x5A5, "blk_level", False, ""),
             Register("blk", "errors", 0x104, 8, "w1c", 0, "blk_errors", True, ""),
             Register("blk", "error", 0x108, 1, "ro", 0, "blk_error", True, "")]
    return core, CsrTop(core, RegisterMap("t", tuple(regs)), bus)


async def _write(ctx, dut, addr, data, strb=0xF, bready_after=0, w_after=0):
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

async def _read(ctx, dut, addr, rready_after=0):
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


def test_every_address_decoded_whole():
    """The select decodes every address bit (the read multiplexer per register block and
    the blocks' page matches): at reset every word of the 12-bit address space reads its
    register's value or 0, and writes to the aliases a partial decode would take (another
    page, a word past the block's) leave the setting alone."""
    core, dut = _slave()
    got = {}

    async def tb(ctx):
        for word in range(1 << (ADDR_BITS - 2)):
            got[4 * word] = await _read(ctx, dut, 4 * word)
        for alias in (0x500, 0x900, 0x140, 0x110, 0x120):
            await _write(ctx, dut, alias, 0xFFF)
        got["level"] = (await _read(ctx, dut, 0x100), ctx.get(core.blk_level))

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    level = got.pop("level")
    assert {a: v for a, v in got.items() if v} == {0x000: 7, 0x00C: 1, 0x100: 0x5A5}
    assert level == (0x5A5, 0x5A5)


@pytest.mark.parametrize("bus", BUSES)
def test_every_word_reads_its_registers_live_value_or_0(bus):
    """The read select with every register holding a value of its own (constants of many
    bits set, a setting written, a counter, the fault sources raised, the interrupt bits
    apart): each of the 1024 words of the 12-bit space reads exactly its register's value
    and every other word 0, on both buses (a register read through another's leg of the
    select, or an unmapped word decoded as a register's, fails here)."""
    ident, ver = 0x5444_4943, 0x0A0B_0C0D
    core = _Core()
    regs = [Register("camera", n, 4 * k, 32 if n in ("id", "version", "frame_count") else
                     1 if n == "startup" else 2, acc,
                     {"id": ident, "version": ver}.get(n, 0), None, False, "")
            for k, (n, acc, _) in enumerate(CAMERA_REGISTERS)]
    regs += [Register("blk", "level", 0x100, 12, "rw", 0x5A5, "blk_level", False, ""),
             Register("blk", "errors", 0x104, 8, "w1c", 0, "blk_errors", True, ""),
             Register("blk", "error", 0x108, 1, "ro", 0, "blk_error", True, "")]
    dut = CsrTop(core, RegisterMap("t", tuple(regs)), bus)
    axil = bus == "axi4-lite"
    got = {}

    async def access(ctx, addr, data=None):
        if axil:
            if data is None:
                return await _read(ctx, dut, addr)
            await _write(ctx, dut, addr, data)
        else:
            return await _wb(ctx, dut, addr, data)

    async def tb(ctx):
        ctx.set(dut.o_stream.ready, 1)
        ctx.set(core.o_stream.valid, 1)
        ctx.set(core.o_stream.payload.first, 1)
        for _ in range(13):                              # 13 frames started
            await ctx.tick()
        ctx.set(core.o_stream.valid, 0)
        ctx.set(core.blk_errors, 0xB6)
        ctx.set(core.blk_error, 1)
        await ctx.tick()
        await access(ctx, 0x100, 0xA5C)                  # level
        await access(ctx, 0x014, 0b01)                   # irq_enable
        await access(ctx, 0x018, 0b01)                   # irq_status: bit 0 cleared
        for word in range(1 << (ADDR_BITS - 2)):
            got[4 * word] = await access(ctx, 4 * word)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    assert {a: v for a, v in got.items() if v} == {
        0x000: ident, 0x004: ver, 0x008: 13, 0x00C: 1, 0x010: 0b11, 0x014: 0b01,
        0x018: 0b10, 0x100: 0xA5C, 0x104: 0xB6, 0x108: 1}


def test_axi_lite_slave_protocol_strobes_and_write_1_to_clear():
    """The slave on its own (Amaranth simulator): a write waits for both address and data
    and holds its response until bready; a read holds its data until rready; byte strobes;
    an unmapped address reads 0; a fault counter read since its clear, 1s clear those bits;
    a change of a fault source sets its interrupt bit, irq when enabled; 1s clear it."""
    core, dut = _slave()
    seen = {}

    def write(ctx, *args, **kw):
        return _write(ctx, dut, *args, **kw)

    def read(ctx, *args, **kw):
        return _read(ctx, dut, *args, **kw)

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


class _WordCore(wiring.Component):
    """A stand-in top whose block is in another clock domain (``word``): a 12-bit setting,
    a 16-bit status, a fault flag, a 4-lane fault mask and the status that holds the
    setting (``blk_run``)."""

    def __init__(self):
        super().__init__({"o_stream": Out(pixel_signature(channels_shape(8, 1))),
                          "blk_level": In(12), "blk_count": Out(16), "blk_error": Out(1),
                          "blk_lane_error": Out(4), "blk_run": Out(1)})

    port_domains = {n: "word" for n in ("blk_level", "blk_count", "blk_error",
                                        "blk_lane_error", "blk_run")}

    def elaborate(self, platform):
        return Module()


def test_another_domains_registers_cross_coherently():
    """Word-domain registers (a word clock 37 ns, the bus's 10 ns) through the crossing: a
    16-bit status changing every word clock (its two bytes always equal) is never read
    torn and is read within a few clocks; a setting written reaches the word side only
    while ``blk_run`` (its hold) is low; a flag through its synchronizer raises the
    interrupt; a lane of the fault mask rising raises it again after a clear."""
    core = _WordCore()
    regs = [Register("camera", n, 4 * k, 32 if n in ("id", "version", "frame_count") else
                     1 if n == "startup" else 2, acc, 0, None, False, "")
            for k, (n, acc, _) in enumerate(CAMERA_REGISTERS)]
    regs += [Register("blk", "level", 0x100, 12, "rw", 0x5A5, "blk_level", False, "",
                      "word", hold="blk_run"),
             Register("blk", "count", 0x104, 16, "ro", 0, "blk_count", False, "", "word"),
             Register("blk", "error", 0x108, 1, "ro", 0, "blk_error", True, "", "word"),
             Register("blk", "lane_error", 0x10C, 4, "ro", 0, "blk_lane_error", True, "",
                      "word", mask=True)]
    dut = CsrTop(core, RegisterMap("t", tuple(regs)))
    seen = {"torn": 0, "reads": 0, "levels": []}
    done = []

    async def word_side(ctx):
        k = 0
        ctx.set(core.blk_run, 1)
        async for _ in ctx.tick("word"):
            k = (k + 1) & 0xFF
            ctx.set(core.blk_count, k << 8 | k)
            seen["levels"].append(ctx.get(core.blk_level))
            if done:
                return

    async def tb(ctx):
        await ctx.tick().repeat(20)
        for _ in range(40):
            v = await _read(ctx, dut, 0x104)
            seen["torn"] += (v >> 8) != (v & 0xFF)
            seen["reads"] += 1
        seen["fresh"] = (await _read(ctx, dut, 0x104)) & 0xFF, ctx.get(core.blk_count) & 0xFF
        await _write(ctx, dut, 0x100, 0x123)
        await ctx.tick().repeat(40)
        seen["held"] = ctx.get(core.blk_level), await _read(ctx, dut, 0x100)
        ctx.set(core.blk_run, 0)
        await ctx.tick().repeat(40)
        seen["applied"] = ctx.get(core.blk_level)
        await _write(ctx, dut, 0x014, 0b11)           # irq_enable
        ctx.set(core.blk_error, 1)
        await ctx.tick().repeat(12)
        seen["flag"] = ctx.get(dut.irq), await _read(ctx, dut, 0x018), \
            await _read(ctx, dut, 0x108)
        await _write(ctx, dut, 0x018, 0b11)
        seen["cleared"] = ctx.get(dut.irq)
        ctx.set(core.blk_lane_error, 0b0100)
        await ctx.tick().repeat(30)
        seen["mask"] = ctx.get(dut.irq), await _read(ctx, dut, 0x018), \
            await _read(ctx, dut, 0x10C), await _read(ctx, dut, 0x010)
        done.append(1)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_clock(3.7e-8, domain="word")
    sim.add_testbench(tb)
    sim.add_testbench(word_side)
    sim.run()
    assert seen["reads"] == 40 and seen["torn"] == 0
    got, now = seen["fresh"]
    assert 0 < (now - got) & 0xFF <= 4                 # a few word clocks late
    assert seen["levels"][0] == 0x5A5                  # the reset value, before any transfer
    assert seen["held"] == (0x5A5, 0x123)              # held while blk_run is high
    assert seen["applied"] == 0x123
    assert seen["flag"] == (1, 0b01, 1) and seen["cleared"] == 0
    assert seen["mask"] == (1, 0b10, 0b0100, 0b11)


async def _wb(ctx, dut, addr, data=None, sel=0xF):
    """One Wishbone classic access (strobe held until ack): the value read, or None."""
    ctx.set(dut.wb_adr, addr >> 2)
    ctx.set(dut.wb_we, data is not None)
    ctx.set(dut.wb_dat_w, data or 0)
    ctx.set(dut.wb_sel, sel)
    ctx.set(dut.wb_cyc, 1)
    ctx.set(dut.wb_stb, 1)
    await ctx.tick()
    while not ctx.get(dut.wb_ack):
        await ctx.tick()
    value = ctx.get(dut.wb_dat_r)
    ctx.set(dut.wb_cyc, 0)
    ctx.set(dut.wb_stb, 0)
    ctx.set(dut.wb_we, 0)
    return None if data is not None else value


def test_wishbone_slave_same_register_file():
    """The Wishbone B4 slave (``bus="wishbone"``) on the AXI4-Lite test's register file:
    classic accesses read the identity, write a setting under a byte select, read 0 at an
    unmapped address, clear a fault counter by 1s and its interrupt; pipelined reads (a
    strobe each cycle, taken while ``stall`` is low) each get their own ack and value."""
    assert BUSES[0] == "axi4-lite"
    core, dut = _slave("wishbone")
    assert not any(n.startswith("s_axil_") for n in dut.signature.members)
    seen = {}

    async def tb(ctx):
        seen["id"] = await _wb(ctx, dut, 0x000)
        await _wb(ctx, dut, 0x100, 0xFFFF_F0C3, sel=0b0001)
        seen["level"] = (await _wb(ctx, dut, 0x100), ctx.get(core.blk_level))
        seen["unmapped"] = await _wb(ctx, dut, 0x10C)
        await _wb(ctx, dut, 0x014, 0b11)              # irq_enable
        ctx.set(core.blk_errors, 5)
        await ctx.tick()
        seen["irq"] = (ctx.get(dut.irq), await _wb(ctx, dut, 0x018),
                       await _wb(ctx, dut, 0x104))
        await _wb(ctx, dut, 0x104, 0xFF)
        await _wb(ctx, dut, 0x018, 0b01)
        seen["cleared"] = (await _wb(ctx, dut, 0x104), await _wb(ctx, dut, 0x018),
                           ctx.get(dut.irq))
        # pipelined: two reads back to back, the second held while stall is high
        got, addrs, cycles = [], [0x000, 0x100], 0
        ctx.set(dut.wb_cyc, 1)
        ctx.set(dut.wb_we, 0)
        while len(got) < 2 and cycles < 10:
            ctx.set(dut.wb_stb, bool(addrs))
            if addrs:
                ctx.set(dut.wb_adr, addrs[0] >> 2)
            taken = addrs and not ctx.get(dut.wb_stall)
            await ctx.tick()
            cycles += 1
            if taken:
                addrs.pop(0)
            if ctx.get(dut.wb_ack):
                got.append(ctx.get(dut.wb_dat_r))
        ctx.set(dut.wb_cyc, 0)
        ctx.set(dut.wb_stb, 0)
        seen["pipelined"] = (got, cycles)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    assert seen["id"] == 7
    assert seen["level"] == (0x5C3, 0x5C3)            # only the low byte written
    assert seen["unmapped"] == 0
    assert seen["irq"] == (1, 0b01, 5)
    assert seen["cleared"] == (0, 0, 0)
    assert seen["pipelined"] == ([7, 0x5C3], 4)


def test_a_map_of_another_top_is_refused():
    core = _Core()
    bad = RegisterMap("t", (Register("blk", "gain", 0x100, 8, "rw", 0, "blk_gain", False, ""),))
    with pytest.raises(TdicamError, match="port\\(s\\) blk_gain the top does not have"):
        CsrTop(core, bad)
    core._MustUse__silence = True
