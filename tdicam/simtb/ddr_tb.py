"""cocotb side of the DDR user-interface co-simulation (see ``cocotb_tests/test_ddr.py``).

The DUT is :class:`tdicam.hdl.ddr.DdrFrameBuffer` with its MIG user-interface ports exposed
(no HDL memory model); this module plays the controller with the Python model
:class:`tdicam.model.dram.MigSim` every cycle, drives the pixel stream, and runs one frame in
two phases: writes alone (``hold_reads`` high) until every word of the frame is in the
model's memory, then reads. It checks the memory word for word against
:func:`tdicam.model.ddr.pack_lines` and the output beats against the input, and measures
the interface efficiency of each phase (data beats / cycles from the phase's first data
beat to its last). Results go to ``result.json`` in the run folder.
"""

import json
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly

from tdicam.errors import TdicamError
from tdicam.model.ddr import LineLayout, pack_lines, words_to_ints
from tdicam.model.dram import MigSim


@cocotb.test()
async def run_job(dut):
    job = json.loads(Path("job.json").read_text())
    data = np.load("stim.npz")
    beats = data["beats"].astype(np.int64)            # (n, elements)
    n, E = beats.shape
    per_line = job["beats_per_line"]
    lay = LineLayout(**job["layout"])
    padded = job["padded"]
    words_pl = lay.words_per_line
    rows = job["rows"]
    n_words = rows * words_pl
    mig = MigSim(capacity_bytes=job["capacity_bytes"], **job["stalls"])
    words_in = [sum(int(v) << (k * padded) for k, v in enumerate(b)) for b in beats]
    bp = job.get("backpressure", 0.0)
    rng = np.random.default_rng(job.get("seed", 1))

    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    dut.hold_reads.value = 1
    dut.s_axis_tvalid.value = 0
    dut.m_axis_tready.value = 0
    for name in ("app_rdy", "app_wdf_rdy", "app_rd_data_valid"):
        getattr(dut, name).value = 0
    dut.app_rd_data.value = 0
    for _ in range(3):
        await FallingEdge(dut.clk)
    dut.rst.value = 0

    out, idx, cycle = [], 0, 0
    phase = "write"
    t_wfirst = t_wlast = t_rfirst = t_rlast = None
    error = ""
    while cycle < job["max_cycles"]:
        await FallingEdge(dut.clk)
        cycle += 1
        o = mig.outputs()
        dut.app_rdy.value = int(o["app_rdy"])
        dut.app_wdf_rdy.value = int(o["app_wdf_rdy"])
        dut.app_rd_data_valid.value = int(o["app_rd_data_valid"])
        dut.app_rd_data.value = o["app_rd_data"]
        if idx < n:
            dut.s_axis_tdata.value = words_in[idx]
            dut.s_axis_tuser.value = int(idx % (rows * per_line) == 0)
            dut.s_axis_tlast.value = int(idx % per_line == per_line - 1)
        dut.s_axis_tvalid.value = int(idx < n)
        ready = phase == "read" and rng.random() >= bp
        dut.m_axis_tready.value = int(ready)
        dut.hold_reads.value = int(phase == "write")
        await ReadOnly()
        app_en = int(dut.app_en.value)
        cmd = int(dut.app_cmd.value) if app_en else 0
        wren = int(dut.app_wdf_wren.value)
        if idx < n and int(dut.s_axis_tready.value):
            idx += 1
        if ready and int(dut.m_axis_tvalid.value):
            out.append((int(dut.m_axis_tdata.value), int(dut.m_axis_tuser.value),
                        int(dut.m_axis_tlast.value)))
        if wren and o["app_wdf_rdy"] and t_wfirst is None:
            t_wfirst = cycle
        if app_en and o["app_rdy"]:
            if cmd == 0:
                t_wlast = cycle
            elif t_rfirst is None:
                t_rfirst = cycle
        if o["app_rd_data_valid"]:
            t_rlast = cycle
        try:
            mig.step(app_en=app_en, app_cmd=cmd,
                     app_addr=int(dut.app_addr.value) if app_en else 0,
                     app_wdf_wren=wren,
                     app_wdf_data=int(dut.app_wdf_data.value) if wren else 0,
                     app_wdf_end=int(dut.app_wdf_end.value))
        except TdicamError as exc:
            error = str(exc)
            break
        if phase == "write" and mig.stats["writes"] == n_words:
            phase = "read"
        if len(out) == n and mig.stats["reads"] == n_words:
            break
    # memory vs the golden packing, word for word
    frame = beats.reshape(rows, -1)
    gold = pack_lines(frame, lay)
    mism, first_bad = 0, None
    for y in range(rows):
        for w, word in enumerate(words_to_ints(gold[y])):
            a = lay.line_addr(y) + 8 * w
            if mig.mem.get(a) != word:
                mism += 1
                if first_bad is None:
                    first_bad = [y, w, a, hex(mig.mem.get(a, 0)), hex(word)]
    mask = (1 << padded) - 1
    got = [[(d >> (k * padded)) & mask for k in range(E)] for d, _, _ in out]
    exp = beats.tolist()
    data_ok = got == exp
    flags_ok = [(f, la) for _, f, la in out] == [
        (int(k % (rows * per_line) == 0), int(k % per_line == per_line - 1))
        for k in range(n)]
    Path("result.json").write_text(json.dumps({
        "cycles": cycle, "accepted": idx, "out": len(out), "error": error,
        "writes": mig.stats["writes"], "reads": mig.stats["reads"],
        "write_cycles": None if t_wlast is None else t_wlast - t_wfirst + 1,
        "read_cycles": None if t_rlast is None else t_rlast - t_rfirst + 1,
        "words": n_words, "mem_mismatches": mism, "first_bad": first_bad,
        "data_ok": data_ok, "flags_ok": flags_ok,
        "written_addrs": sorted(mig.mem)[:4] + sorted(mig.mem)[-2:]}))
