"""Running a generated pipeline top's testbench (for :mod:`tdicam.chain.cosim` and
:mod:`tdicam.chain.lane_cosim`): the top's status ports, a cocotb or standalone run and its
result file, and the control-bus keys of a lane co-simulation's job.
"""

from __future__ import annotations

import json
import os

from tdicam.errors import TdicamError

__all__ = ["status_ports", "run_tb", "bus_job"]


def status_ports(axis_top):
    """[(name, width)] of the top's status outputs: its ``Out`` ports besides the streams,
    the taps and the output links' pins (the stages' status, the start-up counter, the
    external parts' models')."""
    from amaranth.hdl import Shape
    from amaranth.lib import wiring
    from tdicam.hdl.tlk2711 import pin_names
    from tdicam.model.tlk2711 import LINKS
    pins = {n for k in range(max(LINKS)) for n in pin_names(k)}       # the output links'
    return [(n, Shape.cast(mem.shape).width) for n, mem in axis_top.signature.members.items()
            if mem.flow == wiring.Out and not n.startswith(("m_axis_", "s_axis_", "tap"))
            and n not in pins]


def run_tb(bdir, sim, module, rundir, plus, result, what, **kw):
    """Run cocotb testbench ``module`` on a build (None: the standalone build,
    :func:`tdicam.cosim.run_standalone`); (its ``result`` JSON file, wall seconds, the
    simulator process's CPU seconds); a one-line error naming ``what`` when it failed."""
    from tdicam import cosim
    c0 = os.times()
    ok, wall = (cosim.run_standalone(bdir, rundir, plus) if module is None
                else cosim.run_cocotb(bdir, sim, module, rundir, plus, **kw))
    c1 = os.times()
    f = rundir / result
    if not ok or not f.exists():
        raise TdicamError(f"{sim} simulation of {what} failed; see {rundir / 'sim.log'}")
    cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system)
    return json.loads(f.read_text()), wall, cpu


def bus_job(regmap, ready, rundir):
    """The ``job.json`` keys of a lane co-simulation through the control bus
    (:mod:`tdicam.simtb.lanes_bus`): the driver (written into ``rundir``), the interrupt
    enabled for the lanes' fault (``lvds.lane_error``), the start-up registers watched, the
    ports the registers stand for (every status port of the loose-port top) and ``status``,
    the top's status ports and those."""
    from tdicam.chain import registers
    files = registers.write_files(regmap, rundir)
    faults = [f"{r.block}.{r.name}" for r in regmap.faults]
    by_port = {r.port: f"{r.block}.{r.name}" for r in regmap.registers if r.port}
    watch = {"lanes_trained": "lvds.trained", "frames_released": "lvds.releasing"}
    watch.update({f"{name}_done": by_port[name] for name in ready})
    return {"csr": {"driver": files["driver"], "watch": watch,
                    "irq_enable": 1 << faults.index("lvds.lane_error"),
                    "ports": {v: k for k, v in by_port.items() if not
                              regmap.get(*v.split(".")).access == "rw"}}}
