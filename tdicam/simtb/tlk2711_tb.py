"""cocotb side of the output links' pin-level co-simulation (see
:func:`tdicam.cosim.tlk2711.run_cocotb`).

The DUT is the generated ``tlk2711`` top with ``--pins`` (and with ``--crossing`` two
clocks: ``clk`` for the pixels, ``link_clk`` for the links). For every scenario of
``job.json`` the testbench starts the clocks at the scenario's periods, holds both resets,
and runs two coroutines: the source offers the stimulus beats of ``stim_<k>.npy`` (columns:
the ``ppc`` pixels, first, last, reset-before) on ``s_axis`` with random idle cycles,
resetting both domains where a beat asks for it; the sink samples every link's TXD, TKLSB
and TKMSB and the links' reset at each link clock's falling edge
(:class:`tdicam.cosim.tlk2711.PinSink`), until the last segment's words are all out and the
links have been idle for a while. The capture goes to ``capture_<k>.json``, judged by
:func:`tdicam.cosim.tlk2711.check`.
"""

import json
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly, Timer

from tdicam.cosim.tlk2711 import PinSink, scenario


async def _reset(dut, sc, hold):
    dut.rst.value = 1
    if sc["crossing"]:
        dut.link_rst.value = 1
    for _ in range(hold):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    if sc["crossing"]:
        dut.link_rst.value = 0


async def _scenario(dut, sc, k):
    stim = np.load(f"stim_{k}.npy")
    ppc, bits, links = sc["ppc"], sc["bits"], sc["links"]
    padded = -(-bits // 8) * 8
    clocks = [Clock(dut.clk, sc["proc_ps"], unit="ps")]
    if sc["crossing"]:
        clocks.append(Clock(dut.link_clk, sc["link_ps"], unit="ps"))
    for c in clocks:
        c.start()
    link_clk = dut.link_clk if sc["crossing"] else dut.clk
    hold = -(-sc["rst_cycles"] * max(sc["proc_ps"], sc["link_ps"]) // sc["proc_ps"])
    state = {"done": False}
    out = PinSink(scenario(sc["name"]))
    link_rst = dut.link_rst if sc["crossing"] else dut.rst
    pins = [(getattr(dut, f"link{j}_txd"), getattr(dut, f"link{j}_tklsb"),
             getattr(dut, f"link{j}_tkmsb")) for j in range(links)]
    dut.s_axis_tvalid.value = 0
    await _reset(dut, sc, hold)

    async def source():
        rng = np.random.default_rng(sc["seed"])
        i = 0
        while i < len(stim) and not state["done"]:
            await FallingEdge(dut.clk)
            row = stim[i]
            if row[ppc + 2] and state.get("served") != i:
                state["served"] = i
                dut.s_axis_tvalid.value = 0
                await _reset(dut, sc, hold)
                await FallingEdge(dut.clk)
            offer = rng.random() >= sc["idle"]
            dut.s_axis_tvalid.value = int(offer)
            if offer:
                data = 0
                for e in range(ppc):
                    data |= int(row[e]) << (e * padded)
                dut.s_axis_tdata.value = data
                dut.s_axis_tuser.value = int(row[ppc])
                dut.s_axis_tlast.value = int(row[ppc + 1])
            await ReadOnly()
            i += bool(offer and int(dut.s_axis_tready.value))
        await FallingEdge(dut.clk)
        dut.s_axis_tvalid.value = 0

    async def sink():
        for _ in range(sc["max_link_cycles"]):
            await FallingEdge(link_clk)
            w = [int(t.value) | int(lo.value) << 16 | int(hi.value) << 17
                 for t, lo, hi in pins]
            if out.sample(w, int(link_rst.value)):
                break
        state["done"] = True

    src = cocotb.start_soon(source())
    await sink()
    await src
    for c in clocks:
        c.stop()
    await Timer(1, unit="ns")
    Path(f"capture_{k}.json").write_text(json.dumps(out.capture()))


@cocotb.test()
async def run_job(dut):
    """Every scenario of the job, one after the other on the same build."""
    job = json.loads(Path("job.json").read_text())
    for k, sc in enumerate(job["scenarios"]):
        await _scenario(dut, sc, k)
