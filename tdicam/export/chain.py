"""``tdicam export pipeline --scene S.toml``: a scene's whole chain as a FuseSoC core with a
self-checking testbench (see :mod:`tdicam.export.block`).

The export holds the pipeline top exactly as ``tdicam verilog pipeline --scene S.toml``
writes it (identity NUC coefficients in its calibration ROM; a chain with external parts --
the reset frame's DDR, the coefficients' NAND -- inside the co-simulation board with their
simulation models on its pins, :class:`tdicam.hdl.chain_board.Board`), and the fast-mode stream
testbench of :mod:`tdicam.cosim.tbgen` in its self-checking form. The stimulus is the
scene's raw data (every exposure frame of every channel and the CDS reset frames, from an
exact run of the scene simulator, :func:`tdicam.chain.cosim.scene_data`) made into the top's
input beats by :func:`tdicam.chain.design.stimulus`; the expected output is the last stage of
the golden chain (:func:`tdicam.chain.design.golden`) on the same data.

With ``csr`` (``tdicam export pipeline``'s default; ``--no-csr``: not) the top is
``tdicam verilog pipeline``'s with its control bus (its settings and status behind the
AXI4-Lite or Wishbone slave, :mod:`tdicam.hdl.csr`): the export carries the register map's
files under ``regs/`` (:func:`tdicam.chain.registers.file_texts`) and its testbench
configures the top over the bus (:func:`bus_config`, :mod:`tdicam.cosim.tbbus`).
"""

from __future__ import annotations

import re
from pathlib import Path

from tdicam.chain import design
from tdicam.beats import frames_to_beats
from tdicam.errors import TdicamError, check_range
from tdicam.export.block import MAX_BEATS, Export, stream_design, write_design

__all__ = ["export_pipeline", "pipeline_design", "bus_config", "STAGES"]

#: The stages of an export of a pipeline, in order (what its progress names).
STAGES = ("the scene's raw frames", "the top and its stimulus", "the golden chain's output",
          "writing the export (Verilog, vectors, testbench)")


def bus_config(regmap, bus="axi4-lite"):
    """The testbench's configuration of a top with the bus (:class:`BusConfig`): every
    setting written its reset value (the scene's) and the interrupt enable all ones; then
    the identity, the version and those read back."""
    from tdicam.cosim.tbbus import BusConfig
    en = regmap.get("camera", "irq_enable")
    rw = [r for r in regmap.registers if r.access == "rw" and r.block != "camera"]
    writes = [(r.offset, r.reset, f"{r.block}.{r.name}") for r in rw]
    writes.append((en.offset, (1 << en.width) - 1, "camera.irq_enable"))
    reads = [(regmap.get("camera", n).offset, regmap.get("camera", n).reset, f"camera.{n}")
             for n in ("id", "version")] + writes
    return BusConfig(tuple(writes), tuple(reads), bus)


def pipeline_design(scene_path, *, stages=None, lines=None, width=None, memory=None,
                    device="ecp5-85f", seed=1, idle=0.1, backpressure=0.1, ppc=None,
                    progress=None, csr=False, bus="axi4-lite"):
    """(:class:`~tdicam.export.block.Design`, plan, input beats, expected beats) of the scene's
    pipeline on its first ``width`` columns (default: all) and ``lines`` output lines
    (default ``[run].lines``), at ``ppc`` pixels per clock (default the scene's
    ``[run.rtl].pixels_per_clock``, else 1; stated in the export's parameters when not
    1); ``memory`` one of :data:`tdicam.chain.design.MEMORY` (None: as the scene places it);
    ``progress`` a :class:`tdicam.progress.Progress` told each stage (:data:`STAGES`);
    ``csr``: the top with its control bus ``bus`` (the module docstring)."""
    stage = progress.stage if progress is not None else (lambda text: None)
    from tdicam.chain.cosim import scene_data
    from tdicam.chain.design import SceneData
    from tdicam.hdl.chain_board import Board
    if memory is not None and memory not in design.MEMORY:
        raise TdicamError(f"--memory = {memory} is not valid; valid: "
                          f"{', '.join(design.MEMORY)}")
    sc = design.load_pipeline_scene(scene_path, stages)
    w = sc.sensor.columns if width is None else check_range("--width", width, 1,
                                                             sc.sensor.columns)
    design.check_options(sc, lines=lines, device=device, ppc=ppc, width=w)
    spill = design.MEMORY.get(memory)
    p = design.chain_plan(sc, stages=stages, lines=lines, width=w, device=device, spill=spill,
                          ppc=ppc)
    if design.sourced(p):
        raise TdicamError(f"{Path(scene_path).name}: the chain's input is the sensor's lanes "
                          f"([sensor.lvds]); the export drives pixel beats (the front end's "
                          f"lane co-simulation is tdicam.cosim.lvds_front)")
    beats = p.frames * p.stages * p.width // p.ppc
    if beats > MAX_BEATS:
        raise TdicamError(f"the pipeline of {Path(scene_path).name} takes {beats} input beats "
                          f"({p.frames} frames of {p.stages} x {p.width}), over the export limit "
                          f"of {MAX_BEATS}; cut it with --width / --lines")
    stage(STAGES[0])
    raw, _ = scene_data(sc, stages=p.stages, dv_over_v=None, lines=p.lines)
    raw = raw.crop(0, p.width, 0, p.frames)
    # the calibration ROM of `tdicam verilog pipeline --scene` holds identity coefficients
    data = SceneData(raw.signal, raw.reset, design.identity_data(p).coeffs)
    stage(STAGES[1])
    # with the external parts' models, if any
    top = design.top(p, data, board=True, csr=csr, bus=bus)
    stim = design.stimulus(p, data, top)
    stage(STAGES[2])
    exp = frames_to_beats(design.golden(p, data)[-1][2], ppc=design.out_ppc(p))
    name = Path(scene_path).name
    params = {"scene": name, "stages": p.stages, "lines": p.lines, "width": p.width,
              "memory": memory or "scene", "blocks": " -> ".join(s.block for s in p.steps)}
    if csr:
        params["csr"] = bus
    rows = [("scene", name, "scene file ([pipeline] blocks in order)"),
            ("stages", p.stages, "TDI stages (rows per exposure frame)"),
            ("lines", p.lines, "output lines"),
            ("width", p.width, "columns (the scene's first ones)"),
            ("memory", memory or "scene", "TDI partial sums: chip, ddr, auto by the device, "
                                          "or as the scene places them")]
    if p.ppc != 1:
        params["ppc"] = p.ppc
        rows.append(("ppc", p.ppc, "pixels per clock of the input (of each block: its "
                                   "ppc parameter below)"))
    rows += [(f"{k + 1}. {s.block}", ", ".join(f"{a}={v}" for a, v in s.params.items()),
              "registry parameters" + (f"; run-time ports {s.ports}" if s.ports else ""))
             for k, s in enumerate(p.steps)]
    stem = re.sub(r"[^A-Za-z0-9_]", "_", Path(scene_path).stem)
    summary = (f"The camera pipeline of scene `{name}`: {params['blocks']}, {p.lanes} "
               f"channel(s), frames of {p.stages} x {p.width} pixels, {p.frames} exposure "
               f"frames in, {p.lines} lines out; NUC calibration "
               + ("ROM or NAND part with identity coefficients; the top with its external parts' "
                  "simulation models beside it" if isinstance(top.core.core if csr else top.core,
                                                             Board)
                  else "ROM with identity coefficients"))
    d = stream_design("pipeline", summary, rows, params, top, stim, exp,
                      cases=[f"scene {name}"], seed=seed, idle=idle,
                      backpressure=backpressure, core=f"tdicam:pipeline:{stem}",
                      rtl_header=design.verilog_header(p, csr=csr, bus=bus),
                      bus=bus_config(top.core.regmap, bus) if csr else None)
    if csr:
        from dataclasses import replace
        from tdicam.chain.registers import file_texts
        d = replace(d, extra={f"regs/{n}": t for n, t in
                              file_texts(top.core.regmap).items()})
    return d, p, stim, exp


def export_pipeline(scene_path, out_dir, *, force=False, progress=None, **kw):
    """Write the export folder of the scene's pipeline (see :func:`pipeline_design` for
    ``kw`` and ``progress``). Raises a one-line :class:`TdicamError` for a bad scene, option
    or folder."""
    d, p, stim, exp = pipeline_design(scene_path, progress=progress, **kw)
    if progress is not None:
        progress.stage(STAGES[3])
    files = write_design(d, out_dir, force=force)
    return Export(Path(out_dir), "pipeline", d.params, [f"scene {d.params['scene']}"],
                  len(stim), len(exp), files)
