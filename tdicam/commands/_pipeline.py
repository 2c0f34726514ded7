"""``tdicam verilog pipeline`` and ``tdicam synth pipeline``: the arguments that pick a
scene's chain (:func:`scene_design`), then the chain's Verilog or its synthesis
(:mod:`tdicam.chain.design`, :func:`tdicam.hw.synth.synth`)."""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from tdicam.blocks.steps import SceneData
from tdicam.beats import PPC_CHOICES
from tdicam.chain.design import (ECP5_85F, MEMORY, PARTS, PipelineBlock, chain_plan, chain_text,
                                 check_options, load_pipeline_scene, top, verilog_header,
                                 xc7_share)
from tdicam.commands._parsing import ArgsParser, add_source, source_path
from tdicam.errors import TdicamError
from tdicam.files import check_file, write_file
from tdicam.hdl.csr import BUSES
from tdicam.hw.record import row_of
from tdicam.hw.synth import synth, tool_versions
from tdicam.hw.verilog import convert
from tdicam.model.calib import load_image

__all__ = ["add_pipeline_options", "scene_design", "verilog_command", "synth_command",
           "clock_target"]


def add_pipeline_options(ap, *, width=False):
    """The options that pick a scene's chain, shared by ``tdicam verilog|synth|export
    pipeline``: ``--scene`` (or ``--example``) ``--stages --lines [--width] --memory --device --ppc``.
    ``--memory`` is one of :data:`tdicam.chain.design.MEMORY` (``auto``: by ``--device``'s
    block RAM); without it, the scene places the memory (``[pipeline.tdi].memory``)."""
    add_source(ap, flag="--scene", help="scene file (its [pipeline] section)")
    ap.add_argument("--stages", type=int, help="TDI stages (default: the first of "
                    "[tdi].stages)")
    ap.add_argument("--lines", type=int, help="output lines (default [run].lines)")
    if width:
        ap.add_argument("--width", type=int, help="only the first N columns (default: all)")
    ap.add_argument("--memory", choices=tuple(MEMORY),
                    help="TDI partial sums on chip or in DDR (auto: DDR when they exceed "
                         "--device's block RAM; default: the scene's [pipeline.tdi].memory; "
                         "DDR needs the scene's [ddr] section)")
    ap.add_argument("--device", default="ecp5-85f", help="device for --memory auto")
    ap.add_argument("--ppc", type=int, help="pixels per clock of every block, "
                    f"{', '.join(map(str, PPC_CHOICES))} (default: the scene's "
                    "[run.rtl].pixels_per_clock, else 1)")
    ap.add_argument("--csr", action=argparse.BooleanOptionalAction, default=True,
                    help="the run-time settings and status behind the control bus "
                         "(--bus) and irq on the top's register map (the default; "
                         "--no-csr: the loose run-time ports); verilog and export write "
                         "the map's SystemRDL, C header, Markdown reference and Python "
                         "driver beside the Verilog")
    ap.add_argument("--bus", choices=BUSES, default=BUSES[0],
                    help="the control bus: AXI4-Lite (s_axil_*) or Wishbone B4 "
                         "classic/pipelined (wb_*)")


def scene_design(prog, extra):
    """(parsed arguments, :class:`~tdicam.blocks.steps.ChainPlan`, :class:`SceneData` or None) of
    ``tdicam verilog|synth pipeline`` arguments ``extra``."""
    ap = ArgsParser(prog=prog, description="The whole pipeline of a scene "
                                 "([pipeline] blocks in order, NUC coefficients identity "
                                 "unless --calib).")
    add_pipeline_options(ap)
    ap.add_argument("--calib", action="append", default=[],
                    help="calibration image file (tdicam calib write), one per channel")
    ap.add_argument("--taps", action="store_true", help="expose every block's output")
    ap.add_argument("--html", action="store_true",
                    help="with -o (and the bus): also the HTML register reference (peakrdl-html; "
                         "a folder, ~8 MB with its fonts)")
    from tdicam.hdl.lvds_phy import PHYS
    ap.add_argument("--phy", choices=tuple(PHYS),
                    help="with the sensor's lanes ([sensor.lvds]): the generic simulated "
                         "PHY (default), the 7-series IDELAYE2/ISERDESE2 or the ECP5 "
                         "DELAYF/IDDRX2F primitives")
    ap.add_argument("--part", choices=PARTS, default=PARTS[0],
                    help="with the sensor's lanes: the whole top (default), only its front "
                         "end (lanes to pixel stream) or the chain after it (pixel stream "
                         "to output): the two devices of a split camera")
    ns = ap.parse_args(list(extra))
    ns.scene = source_path(ns)
    sc = load_pipeline_scene(ns.scene, ns.stages)
    check_options(sc, lines=ns.lines, device=ns.device, ppc=ns.ppc)
    images = [load_image(path) for path in ns.calib]     # a missing file is named first
    p = chain_plan(sc, stages=ns.stages, lines=ns.lines, device=ns.device, ppc=ns.ppc,
                   spill=MEMORY.get(ns.memory),
                   phy=ns.phy, part=ns.part)
    data = None
    if ns.calib:
        if len(ns.calib) != p.lanes:
            raise TdicamError(f"--calib: the pipeline has {p.lanes} channel(s), got "
                              f"{len(ns.calib)} image(s)")
        coeffs = []
        for path, img in zip(ns.calib, images):
            if img.shape != (p.stages, p.width):
                raise TdicamError(f"--calib {path}: a {img.shape[0]} x {img.shape[1]} image; "
                                  f"the pipeline's frames are {p.stages} x {p.width}")
            coeffs.append((np.asarray(img.gain), np.asarray(img.offset)))
        data = SceneData([], None, coeffs)
    return ns, p, data


def verilog_command(extra, output, *, show_help=False):
    """``tdicam verilog pipeline --scene S.toml [--no-csr] [--bus B] [-o FILE]``; returns
    the exit status. With the bus, ``-o`` may name a folder (the Verilog is then its
    ``pipeline.v``); the register map's files (:func:`tdicam.chain.registers.write_files`)
    go beside the Verilog."""
    if show_help:
        extra = ["--help"]
    csr = "--no-csr" not in extra
    folder = None
    if csr and output is not None and (Path(output).is_dir() or not Path(output).suffix):
        folder, output = Path(output), str(Path(output) / "pipeline.v")    # -o DIR
    if output is not None and not show_help and folder is None:
        check_file(output)
    ns, p, data = scene_design("tdicam verilog pipeline", extra)
    if folder is not None:                     # made once the arguments and scene are good
        folder.mkdir(parents=True, exist_ok=True)
        check_file(output)
    if ns.html and not (csr and output is not None):
        raise TdicamError("--html: the HTML register reference is written with -o DIR (and "
                          "without --no-csr)")
    if csr and output is not None:
        from tdicam.chain.registers import require
        require(html=ns.html)                      # the tools, before the work
    ax = top(p, data, taps=ns.taps, csr=ns.csr, bus=ns.bus)
    ax_lat = "variable" if ax.latency is None else f"{ax.latency} cycles"
    text = convert(ax, "pipeline", header=verilog_header(p, taps=ns.taps, csr=ns.csr,
                                                         bus=ns.bus))
    if output is not None:
        write_file(output, text)
        print(f"wrote {output}: module pipeline, {chain_text(p)}, {p.lanes} channel(s), "
              f"{p.width} x {p.stages} frames, latency {ax_lat}", file=sys.stderr)
        if ns.csr:
            from tdicam.chain.registers import write_files
            files = write_files(ax.core.regmap, str(Path(output).parent), html_ref=ns.html)
            print(f"wrote {', '.join(files.values())}: {len(ax.core.regmap.registers)} "
                  f"registers", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


def clock_target(name, given, derived):
    """The target of nextpnr's clock ``name`` as text: ``given`` ({clock: MHz}, the
    constraints written) by name, else ``derived`` ({domain: MHz}, e.g. the ECP5 PHY's
    ``sclk``) by the domain its net is named after (``...rx.sclk_clk``)."""
    if name in given:
        return f"target {given[name]:g}"
    leaf = name.split(".")[-1]
    for dom, mhz in derived.items():
        if leaf in (dom, f"{dom}_clk"):
            return f"target {mhz:g}, derived"
    return "no target given"


def synth_command(extra, *, seeds=3, freq_mhz=150.0, as_json=False, record=None,
                  xilinx=True, abc9=True, pnr=True):
    """``tdicam synth pipeline --scene S.toml [--seeds N] [--freq MHz] [--json]``: the whole
    chain's cost (:func:`tdicam.hw.synth.synth`) and whether it fits an ECP5-85F.
    ``record(rows)``, when given, receives the result as a synthesis-record row (block
    ``pipeline``, parameters ``scene`` (file name), ``blocks``, ``width``, ``stages``,
    ``ppc``) for ``tdicam plan`` (:mod:`tdicam.hw.record`). ``xilinx``: also the
    synth_xilinx cell counts (``--no-xilinx``: not). ``abc9``: False maps with
    ``synth_ecp5 -noabc9`` (``--no-abc9``). ``pnr`` False: the cell counts alone
    (``--no-pnr``)."""
    ns, p, data = scene_design("tdicam synth pipeline", extra)
    blk = PipelineBlock(p, data, csr=ns.csr, bus=ns.bus)
    res = synth(blk, seeds=seeds, freq_mhz=freq_mhz, xilinx=xilinx, abc9=abc9, pnr=pnr)
    if record is not None:
        blocks = " -> ".join(s.block for s in p.steps)
        ppc = p.ppc
        params = {"scene": Path(ns.scene).name, "blocks": blocks, "width": p.width,
                  "stages": p.stages, "ppc": ppc}
        if ns.phy not in (None, "none"):       # the lanes behind a device's primitives
            params["phy"] = ns.phy
        label = f"{Path(ns.scene).stem} chain ppc={ppc}"
        if ns.part != "whole":                 # a device of the split camera
            params["part"] = ns.part
            label += f" part={ns.part}"
        if ns.csr:                             # the control bus on the top
            params["bus"] = ns.bus
            label += f" bus={ns.bus}"
        record([row_of(label, "pipeline", params, res,
                       target_mhz=freq_mhz, tools=", ".join(tool_versions().values()))])
    if not pnr:          # not packed: the logic and carry cells' slots as the COMB floor
        res.comb = res.lut4 + 2 * res.ccu2c
    fits = {k: getattr(res, k) <= v for k, v in ECP5_85F.items()}
    if as_json:
        print(json.dumps({**res.to_dict(), "ecp5_85f": ECP5_85F, "fits": fits,
                          "xc7k325t": xc7_share(res.xilinx) if res.xilinx else None},
                         indent=1))
        return 0
    timing = (f"Fmax {res.fmax_mhz:.1f} MHz (seeds {res.fmax_seeds}, target {freq_mhz:g})"
              if pnr else "not placed and routed (--no-pnr: COMB is LUT4 + 2 x CCU2C, "
              "before packing)")
    print(f"pipeline {chain_text(p)} ({p.width} x {p.stages}, "
          f"{p.lanes} channel(s)): COMB {res.comb}, LUT4 {res.lut4}, CCU2C {res.ccu2c}, "
          f"FF {res.ff}, DP16KD {res.dp16kd}, MULT18X18D {res.mult18}, "
          f"TRELLIS_DPR16X4 {res.dpr16x4}, {timing}; xc7 {res.xilinx}")
    if len(res.fmax_clocks) > 1:
        want = {"clk": freq_mhz, **blk.clocks()}
        derived = blk.derived_clocks()
        print("Fmax per clock domain: " + ", ".join(
            f"{name} {mhz:.1f} MHz ({clock_target(name, want, derived)})"
            for name, mhz in res.fmax_clocks.items()))
    print("ECP5-85F: " + ("fits" if all(fits.values()) else "does not fit: " + ", ".join(
        f"{k} {getattr(res, k)} > {ECP5_85F[k]}" for k, ok in fits.items() if not ok)))
    if res.xilinx:
        print("xc7 against the XC7K325T: " + ", ".join(
            f"{k} {u:g} of {n} ({pct:g} %)" for k, (u, n, pct) in xc7_share(res.xilinx).items()))
    return 0
