"""The control bus side of :mod:`tdicam.simtb.system_lanes_tb` on a top with ``--csr``
(:mod:`tdicam.hdl.csr`): the sensor front end's word-clock status is read through the
AXI4-Lite slave (cocotbext-axi's ``AxiLiteMaster``, the generated Python driver), not from
ports.

:class:`LaneBus` polls the front's registers while the sensor's words run: the frame status
of every finished frame (``lvds.frame_invalid`` read between two equal reads of
``lvds.frames_out``: the two cross in one snapshot, so the value read belongs to that
count), the word clock at which each register of ``job["csr"]["watch"]`` ({key:
"block.register"}: the lanes trained, the calibration loaded, frames released) first read
non-zero; and serves the
interrupt as a processor would: on ``irq`` it reads ``camera.irq_status`` and
``lvds.lane_error``, logs them with the word clock and clears the status (write 1s). Only ``job["csr"]["irq_enable"]`` is enabled.
"""

import importlib.util

from cocotb.triggers import ClockCycles

__all__ = ["LaneBus"]


def _driver(path):
    spec = importlib.util.spec_from_file_location("camera_regs", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class LaneBus:
    """The bus of ``dut`` (``job["csr"]``: ``driver``, the generated driver's path;
    ``irq_enable``, ``watch``, ``ports``), logging into ``res`` (``frame_status``, ``startup``, ``irq``,
    ``registers``); ``clock()``: the current word clock."""

    def __init__(self, dut, job, res, clock):
        from cocotbext.axi import AxiLiteBus, AxiLiteMaster
        self.dut, self.res, self.clock, self.job = dut, res, clock, job["csr"]
        master = AxiLiteMaster(AxiLiteBus.from_prefix(dut, "s_axil"), dut.clk, dut.rst)
        drv = _driver(self.job["driver"])
        self.regs = drv.Camera(drv.AxiLite(master))
        self.running = True
        res["irq"] = []

    async def poll(self):
        """Until :attr:`running` is cleared: the frame status, the start-up, the interrupt."""
        lv, cam = self.regs.lvds, self.regs.camera
        await cam.irq_enable.write(self.job["irq_enable"])
        seen, up = 0, self.res["startup"]
        watch = {key: getattr(getattr(self.regs, name.split(".")[0]), name.split(".")[1])
                 for key, name in self.job["watch"].items()}
        while self.running:
            if int(self.dut.irq.value):
                status = await cam.irq_status.read()
                self.res["irq"].append([self.clock(), status, await lv.lane_error.read()])
                await cam.irq_status.write(status)
            for key, reg in watch.items():
                if key not in up and await reg.read():
                    up[key] = self.clock()
            n = await lv.frames_out.read()
            if n != seen:
                mask = await lv.frame_invalid.read()
                if await lv.frames_out.read() != n:
                    continue                        # a frame ended between: read again
                if n != seen + 1:
                    raise AssertionError(f"frames {seen} -> {n} between two polls: the bus "
                                         f"poll misses frames")
                self.res["frame_status"].append(mask)
                seen = n
            await ClockCycles(self.dut.clk, 2)

    async def read(self, block=None):
        """{top port: value} of the registers (of ``block``) that stand for a port
        (``job["csr"]["ports"]``: {"block.register": port})."""
        ports = self.job["ports"]
        return {ports[f"{r.block}.{r.name}"]: await r.read() for r in self.regs.registers()
                if f"{r.block}.{r.name}" in ports and block in (None, r.block)}

    async def read_all(self):
        """{"block.register": value} of every register."""
        return {f"{r.block}.{r.name}": await r.read() for r in self.regs.registers()}
