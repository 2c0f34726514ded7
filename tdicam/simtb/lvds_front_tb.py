"""cocotb side of the front-end co-simulation (see :func:`tdicam.cosim.lvds_front.run_cocotb`).

The DUT is the generated :class:`tdicam.hdl.lvds_front.LvdsFront` (two clocks: ``word_clk``
for the lanes, ``clk`` for the pixels). For every scenario of ``job.json`` the testbench
resets both domains, starts the two clocks at the scenario's periods and runs two coroutines:
the word side serves each lane's raw word from the scenario's table (``raw_<k>.npy``:
``[lane, tap, cycle]``) for the tap the DUT loaded two word clocks earlier, pulses
``retrain`` and logs lane status changes and frame status; the processing side takes beats
with the scenario's ``ready`` probability and logs ``frame_kind`` at each frame's first. Results go to ``result_<k>.json``.
"""

import json
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, Timer

from tdicam.cosim.lvds_front import STATUS, WordDriver



def _get(sig):
    return int(sig.value)


async def start(dut, word_ps, proc_ps, settings, zero):
    """Start the word and processing clocks, hold both domains' resets for 4 word clocks
    with the ports ``zero`` at 0 and the run-time ``settings`` ({port: value}) set, release
    them (processing first); returns the two clocks."""
    wclk = Clock(dut.word_clk, word_ps, unit="ps")
    pclk = Clock(dut.clk, proc_ps, unit="ps")
    wclk.start()
    pclk.start()
    dut.rst.value = 1
    dut.word_rst.value = 1
    for sig in zero:
        sig.value = 0
    for name, v in settings.items():
        getattr(dut, name).value = v
    for _ in range(4):
        await FallingEdge(dut.word_clk)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
    await FallingEdge(dut.word_clk)
    dut.word_rst.value = 0
    return wclk, pclk


async def _scenario(dut, job, k):
    sc = job["scenarios"][k]
    raw = np.load(f"raw_{k}.npy")
    w, cycles = sc["word_bits"], sc["cycles"]
    res = {"beats": [], "kinds": [], "frame_status": [], "events": [], "status": {}}
    wclk, pclk = await start(dut, sc["word_ps"], sc["proc_ps"], sc["settings"],
                             (dut.lane_raw, dut.retrain, dut.o_stream__ready))
    done = [False]
    bits, n_out = sc["bits"], sc["elems"]
    emask = (1 << bits) - 1

    async def proc_side():
        rng = np.random.default_rng(sc["seed"])
        while not done[0]:
            await FallingEdge(dut.clk)
            rdy = int(rng.random() < sc["ready"])
            if rdy and _get(dut.o_stream__valid):
                pay = _get(dut.o_stream__payload)
                res["beats"].append([(pay >> (n_out * bits)) & 1,
                                     (pay >> (n_out * bits + 1)) & 1,
                                     [(pay >> (i * bits)) & emask for i in range(n_out)]])
                if (pay >> (n_out * bits)) & 1:
                    res["kinds"].append(_get(dut.frame_kind))
            dut.o_stream__ready.value = rdy

    proc = cocotb.start_soon(proc_side())
    drv = WordDriver(raw, w, sc["retrains"], res)
    for kk in range(cycles):
        # cycle kk: the word side's inputs, the status registers of the cycle
        dut.lane_raw.value, dut.retrain.value = drv.inputs(kk)
        drv.observe(kk, *(_get(getattr(dut, x)) for x in (
            "lane_ld", "lane_tap", "lane_locked", "lane_error", "frames_out")),
            lambda: _get(dut.frame_invalid))
        await FallingEdge(dut.word_clk)
    for name in STATUS:
        res["status"][name] = _get(getattr(dut, name))
    done[0] = True
    await proc
    wclk.stop()
    pclk.stop()
    await Timer(1, unit="ns")
    Path(f"result_{k}.json").write_text(json.dumps(res))


@cocotb.test()
async def run_job(dut):
    """Every scenario of the job, one after the other on the same build."""
    job = json.loads(Path("job.json").read_text())
    for k in range(len(job["scenarios"])):
        await _scenario(dut, job, k)
