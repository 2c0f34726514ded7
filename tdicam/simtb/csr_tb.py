"""cocotb side of the control-bus co-simulation of a camera top with ``--csr``
(:mod:`tdicam.hdl.csr`): the top itself (module ``pipeline``) with its clock from cocotb.

The run folder holds ``job.json`` (the input beats' tdata, tuser and tlast; the settings to
write; the generated driver's path; the mid-run change) and receives ``result.json``.
Through cocotbext-axi's ``AxiLiteMaster`` and the generated Python driver the test reads
every register at reset, writes every setting (its bits inverted, then the job's value), streams the input (the output taken every
cycle), reads every register again; then streams the input a second time with a setting
written in the middle of frame ``change.frame`` (the stream held while the write runs),
and reads the fault state before and after clearing it. Twice (settings inverted; after the
change) it also reads the words at ``job["probe"]``'s addresses (the C header's offsets).
"""

import importlib.util
import json
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, ReadOnly


def _driver(path):
    spec = importlib.util.spec_from_file_location("camera_regs", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


async def _read_all(regs):
    return {f"{r.block}.{r.name}": await r.read() for r in regs.registers()}


async def _probe(bus, addresses):
    """Whole words read at ``addresses`` ({name: byte address}, the C header's offsets)."""
    return {name: await bus.read(a) for name, a in addresses.items()}


async def _stream(dut, beats, hold_at=None, during=None):
    """Send ``beats`` ([tdata hex, tuser, tlast]); ``during`` (a coroutine function) runs
    with the stream held before beat ``hold_at``."""
    k = 0
    while k < len(beats):
        await FallingEdge(dut.clk)
        if k == hold_at and during is not None:
            dut.s_axis_tvalid.value = 0
            await during()
            during = None
            continue
        data, first, last = beats[k]
        dut.s_axis_tdata.value = int(data, 16)
        dut.s_axis_tuser.value = first
        dut.s_axis_tlast.value = last
        dut.s_axis_tvalid.value = 1
        await ReadOnly()
        k += int(dut.s_axis_tready.value)
    await FallingEdge(dut.clk)
    dut.s_axis_tvalid.value = 0


async def _sink(dut, out):
    """Take every output beat (tready always high)."""
    dut.m_axis_tready.value = 1
    while True:
        await FallingEdge(dut.clk)
        await ReadOnly()
        if int(dut.m_axis_tvalid.value):
            out.append([hex(int(dut.m_axis_tdata.value)), int(dut.m_axis_tuser.value),
                        int(dut.m_axis_tlast.value)])


@cocotb.test()
async def run_job(dut):
    from cocotbext.axi import AxiLiteBus, AxiLiteMaster
    job = json.loads(Path("job.json").read_text())
    drv = _driver(job["driver"])
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.s_axis_tvalid.value = 0
    dut.rst.value = 1
    master = AxiLiteMaster(AxiLiteBus.from_prefix(dut, "s_axil"), dut.clk, dut.rst)
    await ClockCycles(dut.clk, 5)
    dut.rst.value = 0
    await ClockCycles(dut.clk, 2)
    bus = drv.AxiLite(master)
    regs = drv.Camera(bus)
    res = {"reset": await _read_all(regs)}
    settings = {name: (getattr(getattr(regs, name.split(".")[0]), name.split(".")[1]), value)
                for name, value in job["settings"].items()}
    for reg, value in settings.values():          # every bit flipped, then the scene's
        await reg.write(value ^ reg.mask)
    res["inverted"] = await _read_all(regs)
    res["probe_inverted"] = await _probe(bus, job["probe"])
    for reg, value in settings.values():
        await reg.write(value)
    res["written"] = await _read_all(regs)
    out = []
    cocotb.start_soon(_sink(dut, out))
    await _stream(dut, job["beats"])
    await ClockCycles(dut.clk, job["drain"])
    res["out"] = list(out)
    res["after"] = await _read_all(regs)
    res["irq_after"] = int(dut.irq.value)

    # the second pass: a setting written in the middle of a frame
    ch = job["change"]
    block, reg = ch["register"].split(".")
    target = getattr(getattr(regs, block), reg)
    await regs.camera.irq_enable.write((1 << regs.camera.irq_enable.width) - 1)

    async def write():
        await target.write(ch["value"])
    await _stream(dut, job["beats"], hold_at=ch["beat"], during=write)
    await ClockCycles(dut.clk, job["drain"])
    res["changed"] = await _read_all(regs)
    res["irq_changed"] = int(dut.irq.value)
    res["probe_changed"] = await _probe(bus, job["probe"])
    for r in regs.registers():
        if r.access == "w1c":
            await r.clear()
    await ClockCycles(dut.clk, 2)
    res["cleared"] = await _read_all(regs)
    res["irq_cleared"] = int(dut.irq.value)
    Path("result.json").write_text(json.dumps(res))
