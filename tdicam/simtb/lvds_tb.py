"""cocotb side of the LVDS receiver co-simulation (see ``tdicam.cosim.lvds``).

The HDL testbench does all the work (link, groups of lanes, dumps); cocotb starts it, waits
for ``done`` and writes ``summary.json`` in the run folder.
"""

import json
from pathlib import Path

import cocotb
from cocotb.triggers import FallingEdge, RisingEdge


@cocotb.test()
async def run_job(dut):
    """Run the job described by the run folder's files and plusargs."""
    job = json.loads(Path("job.json").read_text())
    await FallingEdge(dut.clk)
    dut.start.value = 1
    await RisingEdge(dut.done)
    Path("summary.json").write_text(json.dumps(
        {"cycles": job["groups"] * (job["cycles"] + 3), "done": 1}))
