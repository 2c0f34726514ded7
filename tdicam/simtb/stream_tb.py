"""cocotb side of the stream co-simulation (see :mod:`tdicam.cosim`).

The simulator runs in a run folder holding ``job.json`` and the stimulus chunks
``stim_NNNNNN.bin``; this module drives the generated testbench ``tdicam_tb`` in the job's
mode and leaves ``out.hex`` (every output transfer) and ``summary.json`` there.
"""

import json
from pathlib import Path

import cocotb
from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge


class TB:
    """Owns the testbench's clock (generated in HDL), reset, source and sink."""

    def __init__(self, dut, job):
        self.dut = dut
        self.job = job
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
        from tdicam.cosim import codec   # per-beat mode only: fast mode starts light
        job, words = self.job, []
        rec = codec.stimulus_word_bytes(elem_padded_bits=job["in_padded"],
                                        count=job["in_count"], ctrl_bits=job["ctrl_bits"])
        for path in sorted(Path(".").glob("stim_*.bin")):
            words += codec.stimulus_words_bin(path.read_bytes(), rec)
        return words[: job["n_in"]]

    async def run_beats(self):
        from tdicam.cosim.pauses import StreamDriver
        dut, job = self.dut, self.job
        words = self._stimulus()
        cb = job["ctrl_bits"]
        iw = job["in_padded"] * job["in_count"]
        ow = job["out_padded"] * job["out_count"]
        data_mask = (1 << iw) - 1
        ctrl_mask = (1 << cb) - 1
        drv = StreamDriver([(w >> (iw + 2 + cb)) & 1 for w in words], seed=job["seed"],
                           idle=job["idle"], backpressure=job["backpressure"],
                           rst_cycles=job["rst_cycles"], drain=job["drain"],
                           max_cycles=job["max_cycles"])
        out, trace = [], []
        dut.beat_mode.value = 1
        s_tready, m_tvalid = dut.s_tready, dut.m_tvalid
        m_tdata, m_tuser, m_tlast = dut.m_tdata, dut.m_tuser, dut.m_tlast
        b_tvalid, b_tready, b_rst = dut.b_tvalid, dut.b_tready, dut.b_rst
        # start from reset, as the fast engine does before it starts (not counted)
        b_rst.value, b_tvalid.value, b_tready.value = 1, 0, 0
        for _ in range(job["rst_cycles"]):
            await FallingEdge(dut.clk)
        while not drv.finished:
            await FallingEdge(dut.clk)
            rst, valid, ready = drv.drive()
            b_rst.value = int(rst)
            b_tvalid.value = int(valid)
            b_tready.value = int(ready)
            if valid:
                w = words[drv.idx]
                dut.b_tdata.value = w & data_mask
                dut.b_tlast.value = (w >> iw) & 1
                dut.b_tuser.value = (w >> (iw + 1)) & 1
                dut.b_ctrl.value = (w >> (iw + 2)) & ctrl_mask
            await ReadOnly()
            cycle = drv.cycle
            took, fired = drv.settle(s_tready.value, m_tvalid.value)
            if fired:
                d = m_tdata.value
                text = f"{d.to_unsigned():0{ow // 4}x}" if d.is_resolvable else "x" * (ow // 4)
                out.append(f"{drv.seg:02x} {int(m_tuser.value) << 1 | int(m_tlast.value):x} "
                           f"{text}\n")
            trace += [f"i {cycle}\n"] * took + [f"o {cycle}\n"] * fired
        self.cycles, self.accepted, self.timeout = drv.cycle, drv.idx, drv.timeout
        Path("out.hex").write_text("".join(out))
        if job.get("trace"):
            Path("trace.txt").write_text("".join(trace))


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
