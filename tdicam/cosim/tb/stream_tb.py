"""cocotb side of the stream co-simulation (see ``tdicam.cosim``).

The simulator runs in a run folder holding ``job.json`` and the stimulus chunks
``stim_NNNNNN.hex``; this module drives the generated testbench ``tdicam_tb`` in the job's
mode and leaves ``out.hex`` (every output transfer) and ``summary.json`` there.
"""

import json
import random
from pathlib import Path

import cocotb
from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge


class TB:
    """Owns the testbench's clock (generated in HDL), reset, source and sink."""

    def __init__(self, dut, job):
        self.dut = dut
        self.job = job
        self.rng = random.Random(job["seed"])
        self.cycles = 0
        self.accepted = 0
        self.timeout = False

    # ---- fast mode: HDL engine does everything; await once
    async def run_fast(self):
        dut = self.dut
        dut.beat_mode.value = 0
        await FallingEdge(dut.clk)
        dut.start.value = 1
        await RisingEdge(dut.done)
        self.cycles = int(dut.cycles.value)
        self.accepted = int(dut.in_idx.value)
        self.timeout = bool(int(dut.timeout.value))

    # ---- per-beat mode: Python drives and samples every cycle
    def _stimulus(self):
        words = []
        for path in sorted(Path(".").glob("stim_*.hex")):
            words += [int(x, 16) for x in path.read_text().split()]
        return words[: self.job["n_in"]]

    async def run_beats(self):
        dut, job, rng = self.dut, self.job, self.rng
        words = self._stimulus()
        cb = job["ctrl_bits"]
        iw = job["in_padded"] * job["in_count"]
        ow = job["out_padded"] * job["out_count"]
        idle, bp = job["idle"], job["backpressure"]
        n_in = job["n_in"]
        data_mask = (1 << iw) - 1
        ctrl_mask = (1 << cb) - 1
        out = []
        idx = seg = drain = 0
        rst_left = job["rst_cycles"]  # start from reset, as the fast engine does
        served = False
        valid = False
        dut.beat_mode.value = 1
        s_tready, m_tvalid = dut.s_tready, dut.m_tvalid
        m_tdata, m_tuser, m_tlast = dut.m_tdata, dut.m_tuser, dut.m_tlast
        b_tvalid, b_tready, b_rst = dut.b_tvalid, dut.b_tready, dut.b_rst
        while True:
            await FallingEdge(dut.clk)
            self.cycles += 1
            w = words[idx] if idx < n_in else 0
            if rst_left == 0 and idx < n_in and (w >> (iw + 2 + cb)) & 1 and not served:
                rst_left, served, valid = job["rst_cycles"], True, False
                seg += 1
            if rst_left:
                rst_left -= 1
                b_rst.value = 1
                b_tvalid.value = 0
                b_tready.value = 0
                await ReadOnly()
                continue
            b_rst.value = 0
            if idx < n_in:
                if not valid:  # once asserted, tvalid stays until the transfer
                    valid = rng.random() >= idle
                dut.b_tdata.value = w & data_mask
                dut.b_tlast.value = (w >> iw) & 1
                dut.b_tuser.value = (w >> (iw + 1)) & 1
                dut.b_ctrl.value = (w >> (iw + 2)) & ctrl_mask
            else:
                valid = False
            b_tvalid.value = int(valid)
            ready = rng.random() >= bp
            b_tready.value = int(ready)
            await ReadOnly()
            fired = ready and m_tvalid.value
            if fired:
                d = m_tdata.value
                text = f"{d.to_unsigned():0{ow // 4}x}" if d.is_resolvable else "x" * (ow // 4)
                out.append(f"{seg:02x} {int(m_tuser.value) << 1 | int(m_tlast.value):x} "
                           f"{text}\n")
            if valid and s_tready.value:
                idx += 1
                served = valid = False
            if fired:
                drain = 0
            elif idx >= n_in:
                drain += 1
            if drain >= job["drain"] or self.cycles >= job["max_cycles"]:
                self.timeout = self.cycles >= job["max_cycles"]
                break
        self.accepted = idx
        Path("out.hex").write_text("".join(out))


@cocotb.test()
async def run_job(dut):
    """Run the job in ``job.json`` and write ``summary.json``."""
    job = json.loads(Path("job.json").read_text())
    tb = TB(dut, job)
    if job["mode"] == "fast":
        await tb.run_fast()
    else:
        await tb.run_beats()
    Path("summary.json").write_text(json.dumps(
        {"cycles": tb.cycles, "accepted": tb.accepted, "timeout": tb.timeout}))
