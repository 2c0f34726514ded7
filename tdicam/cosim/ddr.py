"""Co-simulation of the bare DDR user interface against the Python controller model.

:func:`run_ui_cosim` drives :class:`~tdicam.hdl.ddr.DdrFrameBuffer`'s MIG ports from
:class:`~tdicam.model.dram.MigSim` in cocotb (testbench :mod:`tdicam.simtb.ddr_tb`), to
check the packed memory word for word and measure the interface's efficiency.
"""

import json
import os
import shutil
import time

import numpy as np

from tdicam.errors import TdicamError
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.model.dram import DEFAULT_STALLS
from tdicam.hw.verilog import convert
from tdicam.cosim.build import build_sources, run_cocotb

__all__ = ["run_ui_cosim"]


def run_ui_cosim(*, width, rows, channels=1, ppc=1, pixel_bits=10, pixels_per_word=24,
                 line_stride=None, base=0, capacity_mib=1024, sim="verilator", seed=1,
                 backpressure=0.0, frame=None, stalls=None, max_cycles=None):
    """Run one frame through :class:`~tdicam.hdl.ddr.DdrFrameBuffer` with its MIG ports
    driven by :class:`~tdicam.model.dram.MigSim` in cocotb (:mod:`tdicam.simtb.ddr_tb`).

    Writes alone, then reads (``hold_reads``). Returns the tb's result dict: ``data_ok``,
    ``flags_ok`` (output = input), ``mem_mismatches`` (memory vs
    :func:`~tdicam.model.ddr.pack_lines`, word for word), ``error`` (a model error),
    ``write_cycles``/``read_cycles`` and ``words`` per phase, plus ``write_eff`` and
    ``read_eff`` = words / cycles of the phase, ``wall`` and ``build_time``.
    """
    from tdicam.hdl.ddr import DdrFrameBuffer
    stalls = dict(DEFAULT_STALLS if stalls is None else stalls)
    core = DdrFrameBuffer(width=width, rows=rows, channels=channels, elements=ppc * channels,
                          pixel_bits=pixel_bits, pixels_per_word=pixels_per_word,
                          line_stride=line_stride, base=base,
                          capacity_bytes=capacity_mib << 20)
    lay = core.layout
    top = AxisTop(core)
    key = {"width": width, "rows": rows, "channels": channels, "ppc": ppc,
           "pixel_bits": pixel_bits, "ppw": pixels_per_word, "stride": lay.line_stride,
           "base": base}
    bdir, build_time = build_sources("ddr_ui", key, sim, {"ddr_ui.v": convert(top, "ddr_ui")},
                                     top="ddr_ui")
    if frame is None:
        rng = np.random.default_rng(seed)
        frame = rng.integers(0, 1 << pixel_bits, (rows, width, channels))
    beats = np.asarray(frame).reshape(-1, ppc * channels)
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    np.savez(rundir / "stim.npz", beats=beats)
    words = rows * lay.words_per_line
    job = {"beats_per_line": width // ppc, "rows": rows, "padded": top._in[2],
           "layout": {"width": width, "channels": channels, "pixel_bits": pixel_bits,
                      "pixels_per_word": pixels_per_word, "line_stride": lay.line_stride,
                      "base": base},
           "capacity_bytes": capacity_mib << 20, "stalls": stalls, "seed": seed,
           "backpressure": backpressure,
           "max_cycles": max_cycles or 20 * (words + len(beats)) + 5000}
    (rundir / "job.json").write_text(json.dumps(job))
    ok, wall = run_cocotb(bdir, sim, "ddr_tb", rundir, [], top="ddr_ui")
    res_path = rundir / "result.json"
    if not ok or not res_path.exists():
        raise TdicamError(f"{sim} UI co-simulation of ddr failed; see {rundir / 'sim.log'}")
    res = json.loads(res_path.read_text())
    shutil.rmtree(rundir, ignore_errors=True)
    res["write_eff"] = res["words"] / res["write_cycles"] if res["write_cycles"] else 0.0
    res["read_eff"] = res["words"] / res["read_cycles"] if res["read_cycles"] else 0.0
    res.update(wall=wall, build_time=build_time, sim=sim)
    return res
