"""A scene's ``[pipeline]`` as one design: its gateware top, its golden chain, and the
whole-scene co-simulation of the one against the other.

:func:`plan` turns a scene into a :class:`Plan` (the blocks in order with their registry
parameters, run-time settings and side inputs). From a plan, :func:`top` builds the Verilog
top (:class:`tdicam.hdl.pipeline.Pipeline` behind :class:`~tdicam.hdl.axis.AxisTop`),
:func:`golden` runs the golden chain (:func:`tdicam.model.pipeline.chain`) and
:func:`stimulus` makes the top's input beats; :mod:`tdicam.rtl` co-simulates the one
against the other.

Everything about a block comes from its registry entry (:mod:`tdicam.blocks`): its golden
function, stream key and side inputs, and in :attr:`tdicam.blocks.Block.pipeline` (a
:class:`tdicam.blocks.Use`) how a scene sets its parameters and where the gateware takes
its side inputs from. The orchestration below names no block.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["Step", "Plan", "SceneData", "Context", "uses", "plan", "top", "golden", "stimulus",
           "output_shape", "verilog", "identity_data", "verilog_command", "synth_command",
           "ECP5_85F"]


@dataclass(frozen=True)
class Step:
    """One block of a plan: registry ``params``, run-time port values ``ports`` (gateware),
    ``inputs`` (the same settings as the registry's ``run`` side inputs, golden side) and
    ``group`` (incoming frames grouped into one, or None)."""

    block: str
    params: dict
    ports: dict = field(default_factory=dict)
    group: int | None = None
    inputs: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Plan:
    """A scene's chain: ``steps`` in order; input ``lanes`` (channels) of ``lane_elems``
    elements of ``in_bits``; frames of ``rows`` x ``width`` pixels, ``frames`` of them."""

    steps: tuple
    lanes: int
    lane_elems: int
    in_bits: int
    rows: int
    width: int
    frames: int
    lines: int
    source: str = ""

    @property
    def input_pixels(self):
        return self.frames * self.rows * self.width * self.lanes


@dataclass
class SceneData:
    """Raw scene data for the chain: per lane (channel) the signal frames and, with CDS,
    the reset frames, ``(frames, rows, width)``; per lane the NUC coefficient codes
    ``(gain, offset)``, ``(rows, width)`` each, or None."""

    signal: list
    reset: list | None = None
    coeffs: list | None = None

    def lane_arrays(self, plan):
        out = []
        for k in range(plan.lanes):
            arrs = [np.asarray(self.signal[k])]
            if plan.lane_elems == 2:
                if self.reset is None:
                    raise TdicamError("pipeline: the chain starts with a two-element block "
                                      "(CDS) but the scene data has no reset frames")
                arrs.append(np.asarray(self.reset[k]))
            out.append(arrs)
        return out

    def crop(self, x0, w, f0, nf):
        """The data of columns ``x0:x0+w`` and frames ``f0:f0+nf``."""
        cut = (lambda a: np.ascontiguousarray(np.asarray(a)[f0:f0 + nf, :, x0:x0 + w]))
        return SceneData([cut(s) for s in self.signal],
                         None if self.reset is None else [cut(r) for r in self.reset],
                         None if self.coeffs is None else
                         [(np.ascontiguousarray(g[:, x0:x0 + w]),
                           np.ascontiguousarray(o[:, x0:x0 + w])) for g, o in self.coeffs])


# --------------------------------------------------------------------------------------
# what each block contributes: its registry entry's ``pipeline`` (tdicam.blocks.Use)
# --------------------------------------------------------------------------------------


@dataclass
class Context:
    """What a block's :attr:`tdicam.blocks.Use.step` sees: the ``scene``, TDI stages ``m``,
    frame ``width``, output ``lines``, the chain's pixel width so far (``bits``), whether a
    line-making block came before (``after_lines``) and the block being planned."""

    scene: object
    m: int
    width: int
    lines: int
    bits: int
    after_lines: bool = False
    block: str = ""


def uses():
    """Block name -> its :class:`tdicam.blocks.Use`, for every block with a gateware stage
    in a pipeline."""
    from tdicam import blocks
    return {b.name: b.pipeline for b in blocks.all_blocks() if b.pipeline is not None}


def _golden_stage(step, data):
    """The block's golden stage from its registry entry."""
    from tdicam import blocks
    from tdicam.model.pipeline import GoldenStage
    blk = blocks.get(step.block)
    use = blk.pipeline
    params = blk.resolve(step.params)
    lane_keys = [blk.stream] + [s.name for s in blk.side_inputs if s.per == "pixel"]

    def fn(arrays, lane):
        scene = dict(step.inputs)
        if use.side is not None:
            scene.update(use.side(step, data, lane))
        scene.update(zip(lane_keys, arrays))
        out = np.asarray(blk.run_golden(scene, params)["out"])
        rows = 1 if use.lines else out.shape[-2]
        return out.reshape(-1, rows, out.shape[-1])
    return GoldenStage(step.block, fn, merge=use.merge, group=step.group)


def _use(name):
    table = uses()
    if name not in table:
        raise TdicamError(f"pipeline: block {name!r} has no gateware stage; blocks with one: "
                          f"{', '.join(table)}")
    return table[name]


# --------------------------------------------------------------------------------------
# plan, top, golden chain
# --------------------------------------------------------------------------------------


def plan(scene, *, stages=None, lines=None, width=None, blocks=None, spill=None,
         device="ecp5-85f"):
    """The :class:`Plan` of ``scene``'s ``[pipeline]`` (or of ``blocks`` in that order).

    ``spill``: True keeps a block's large memory (TDI's partial sums) in DDR through its
    ``spill`` variant (``tdi_ddr`` with the simulation MIG model), False on chip, ``"auto"``
    as below whatever the scene says; ``None``:
    as the scene places it (:attr:`tdicam.blocks.Use.placement`, ``[pipeline.tdi].memory``),
    ``auto`` meaning DDR when it exceeds ``device``'s on-chip RAM
    (:data:`tdicam.model.plan.ONCHIP_RAM_BITS`). A spill uses the DDR interface of the
    scene's ``[ddr]`` section.

    Raises a one-line :class:`TdicamError` naming the blocks when the chain cannot be built:
    a block without a gateware stage, a per-exposure block after a line-making one, a
    merging block without two channels, a pixel width a block cannot take, a memory that
    does not fit on chip with no DDR variant, a spill without a ``[ddr]`` section, a DDR
    too slow for the scene's line rate, a spill asked of a chain with nothing to spill.
    """
    from tdicam import blocks as registry
    names = list(scene.pipeline.blocks if blocks is None else blocks)
    if scene.tdi.domain != "digital":
        raise TdicamError("pipeline: [tdi].domain = 'charge' sums in the sensor; only a "
                          "digital-TDI chain has a gateware pipeline")
    m = int(scene.tdi.stages[0] if stages is None else stages)
    n_lines = int(scene.run.lines if lines is None else lines)
    w = int(scene.sensor.columns if width is None else width)
    uses = [_use(n) for n in names]
    merge = any(u.merge for u in uses)
    ctx = Context(scene, m, w, n_lines, scene.sensor.bits)
    steps, prev, spilled = [], "input", False
    for name, u in zip(names, uses):
        if u.per_frame and ctx.after_lines:
            raise TdicamError(f"pipeline: {name} acts on single exposures and cannot follow "
                              f"{prev}, which sums them into lines")
        try:
            ctx.block = name
            step, out_bits = u.step(ctx)
            registry.get(name).resolve(step.params)
            go, why = _spills(u, step, scene, spill, device)
            if go and u.spill is None:
                raise TdicamError(f"{why} and it has no DDR variant")
            if go and scene.ddr is None:
                raise TdicamError(f"{why}: it spills to DDR through {u.spill}, but the scene "
                                  f"has no [ddr] section (the DDR interface a spill uses)")
            if go:
                spilled = True
                ctx.block = name = u.spill
                step, out_bits = _use(name).step(ctx)
                registry.get(name).resolve(step.params)
        except TdicamError as exc:
            raise TdicamError(f"pipeline: {prev} -> {name}: {exc}") from None
        steps.append(step)
        ctx.bits = out_bits
        ctx.after_lines = ctx.after_lines or u.lines
        prev = name
    if spill is True and not spilled:
        raise TdicamError(f"pipeline: a DDR spill was asked but no block of "
                          f"{' -> '.join(names)} keeps its memory in DDR")
    return Plan(tuple(steps), lanes=2 if merge else 1,
                lane_elems=uses[0].elems if uses else 1, in_bits=scene.sensor.bits,
                rows=m, width=w, frames=n_lines + m - 1, lines=n_lines,
                source=str(scene.source))


def _spills(u, step, scene, spill, device):
    """Whether block use ``u`` keeps its memory in DDR, and why (a phrase for errors)."""
    from tdicam.model.plan import onchip_budget
    if u.memory_bits is None:
        return False, ""
    need, budget = u.memory_bits(step), onchip_budget(device)
    if spill is not None:
        asked, how = {True: "ddr", False: "chip", "auto": "auto"}[spill], "the caller"
    else:
        asked, how = (u.placement(scene) if u.placement else "auto"), "the scene"
    if asked == "auto":
        return need > budget, (f"its {u.memory} ({need} bits) exceed the {device}'s on-chip "
                               f"RAM ({budget} bits)")
    return asked == "ddr", f"its {u.memory} ({need} bits) are placed in DDR by {how}"


def identity_data(p):
    """Scene data placeholder for elaboration: no frames, side data that make each block a
    no-op (:attr:`tdicam.blocks.Use.identity`, e.g. identity NUC coefficients)."""
    fields = {}
    for st in p.steps:
        ident = _use(st.block).identity
        if ident is not None:
            fields.update({k: [v] * p.lanes for k, v in ident(st, (p.rows, p.width)).items()})
    return SceneData([], **fields)


def top(p, data=None, *, taps=False, ecp5=False):
    """The AXI4-Stream top of plan ``p`` (NUC calibration images from ``data``; ``ecp5``:
    each block's ECP5 synthesis top where it has one, for ``tdicam synth``)."""
    from tdicam.hdl.axis import AxisTop
    from tdicam.hdl.pipeline import Pipeline
    data = identity_data(p) if data is None or data.coeffs is None else data
    stages = [_use(s.block).hw(s, data, ecp5=ecp5) for s in p.steps]
    try:
        core = Pipeline(stages, in_bits=p.in_bits, lanes=p.lanes, lane_elems=p.lane_elems,
                        taps=taps)
    except TdicamError as exc:
        raise TdicamError(str(exc)) from None
    return AxisTop(core)


def verilog(p, data=None, *, taps=False):
    """Deterministic Verilog text of the top (module ``pipeline``), after
    :func:`verilog_header`."""
    from tdicam.verilog import convert
    return convert(top(p, data, taps=taps), "pipeline", header=verilog_header(p, taps=taps))


def verilog_header(p, *, taps=False):
    """The comment header of the pipeline's Verilog: tdicam version, the scene file's name
    (no path), the blocks in order with their parameters, channels, frame and lines."""
    import os
    from tdicam.verilog import header
    return header("pipeline", {
        "scene": os.path.basename(p.source), "blocks": " -> ".join(s.block for s in p.steps),
        "channels": p.lanes, "frame": f"{p.width}x{p.rows}", "lines": p.lines,
        "taps": taps} | {s.block: s.params for s in p.steps})


def golden(p, data):
    """Every stage's golden output, in the order of the top's taps: list of [tap name,
    block, ndarray (frames, rows, width)]."""
    from tdicam.model.pipeline import chain
    stages = [_golden_stage(s, data) for s in p.steps]
    out = []
    for (name, lanes), st in zip(chain(data.lane_arrays(p), stages), p.steps):
        for k, a in enumerate(lanes):
            out.append([name + (f"_{k}" if len(lanes) > 1 else ""), st.block, a])
    return out


def _ctrl(axis_top, p):
    """Packed run-time port values (first port in the most significant bits)."""
    from tdicam.cosim import stream_ports
    _, _, ctrl = stream_ports(axis_top)
    values = {f"{s.block}_{k}": v for s in p.steps for k, v in s.ports.items()}
    word = 0
    for name, width in ctrl:
        if name not in values:
            raise TdicamError(f"pipeline: no value for the top's input port {name}")
        word = (word << width) | (int(values[name]) & ((1 << width) - 1))
    return ctrl, word


def stimulus(p, data, axis_top):
    """Input beats of the scene data (every lane's elements in each beat)."""
    from tdicam.beats import frames_to_beats
    arrs = [a for lane in data.lane_arrays(p) for a in lane]
    stim = frames_to_beats(np.stack(arrs, axis=-1), channels=len(arrs))
    _, word = _ctrl(axis_top, p)
    stim.ctrl = np.full(len(stim), word, np.uint64)
    return stim


def output_shape(p):
    """(frames, rows, width) of the chain's output."""
    frames, rows = p.frames, p.rows
    for s in p.steps:
        if _use(s.block).lines:
            frames, rows = max(frames - s.params["stages"] + 1, 0), 1
        if s.group is not None:
            frames, rows = frames // s.group, rows * s.group
    return frames, rows, p.width



# --------------------------------------------------------------------------------------
# commands: tdicam verilog|synth pipeline --scene S.toml
# --------------------------------------------------------------------------------------

#: ECP5-85F (LFE5U-85F) resources: LUT4 slots, flip-flops, 18 kbit EBRs, 18x18 multipliers.
ECP5_85F = {"comb": 83640, "ff": 83640, "dp16kd": 208, "mult18": 156}


def _scene_args(prog, extra):
    from tdicam.cli import ArgsParser
    ap = ArgsParser(prog=prog, description="The whole pipeline of a scene "
                                 "([pipeline] blocks in order, NUC coefficients identity "
                                 "unless --calib).")
    ap.add_argument("--scene", required=True, help="scene file (its [pipeline] section)")
    ap.add_argument("--stages", type=int, help="TDI stages (default: the first of "
                    "[tdi].stages)")
    ap.add_argument("--lines", type=int, help="output lines per median image (default "
                    "[run].lines)")
    ap.add_argument("--calib", action="append", default=[],
                    help="calibration image file (tdicam calib write), one per channel")
    ap.add_argument("--taps", action="store_true", help="expose every block's output")
    ap.add_argument("--memory", choices=("auto", "chip", "ddr"),
                    help="TDI partial sums on chip or in DDR (auto: DDR when they exceed "
                         "--device's block RAM; default: the scene's [pipeline.tdi].memory; "
                         "DDR needs the scene's [ddr] section)")
    ap.add_argument("--device", default="ecp5-85f", help="device for --memory auto")
    ns = ap.parse_args(list(extra))
    from tdicam.scene import load_scene
    sc = load_scene(ns.scene)
    p = plan(sc, stages=ns.stages, lines=ns.lines, device=ns.device,
             spill={None: None, "auto": "auto", "chip": False, "ddr": True}[ns.memory])
    data = None
    if ns.calib:
        from tdicam.model.calib import load_image
        if len(ns.calib) != p.lanes:
            raise TdicamError(f"--calib: the pipeline has {p.lanes} channel(s), got "
                              f"{len(ns.calib)} image(s)")
        coeffs = []
        for path in ns.calib:
            img = load_image(path)
            if img.shape != (p.rows, p.width):
                raise TdicamError(f"--calib {path}: a {img.shape[0]} x {img.shape[1]} image; "
                                  f"the pipeline's frames are {p.rows} x {p.width}")
            coeffs.append((np.asarray(img.gain), np.asarray(img.offset)))
        data = SceneData([], None, coeffs)
    return ns, p, data


def verilog_command(extra, output, *, show_help=False):
    """``tdicam verilog pipeline --scene S.toml [-o FILE]``; returns the exit status."""
    import sys
    if show_help:
        extra = ["--help"]
    from tdicam.outputs import check_file, write_file
    from tdicam.verilog import convert
    if output is not None and not show_help:
        check_file(output)
    ns, p, data = _scene_args("tdicam verilog pipeline", extra)
    ax = top(p, data, taps=ns.taps)
    ax_lat = "variable" if ax.latency is None else f"{ax.latency} cycles"
    text = convert(ax, "pipeline", header=verilog_header(p, taps=ns.taps))
    if output is not None:
        write_file(output, text)
        print(f"wrote {output}: module pipeline, {' -> '.join(s.block for s in p.steps)}, "
              f"{p.lanes} channel(s), {p.width} x {p.rows} frames, latency {ax_lat}",
              file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


class _PipelineBlock:
    """The registry face of a plan for :func:`tdicam.synth.synth` (name, resolve, build)."""

    def __init__(self, p, data):
        self.name, self._p, self._data = "pipeline", p, data

    def resolve(self, params=None):
        return {"scene": self._p.source, "steps": [[s.block, s.params, s.ports]
                                                   for s in self._p.steps]}

    def build(self, params=None, *, ecp5=False):
        """The chain's top; ``ecp5``: each block's ECP5 synthesis top where it has one
        (:attr:`tdicam.blocks.Block.ecp5_top`, e.g. the TDI accumulator's DP16KD banks)."""
        return top(self._p, self._data, ecp5=ecp5)


def synth_command(extra, *, seeds=3, freq_mhz=150.0, as_json=False):
    """``tdicam synth pipeline --scene S.toml [--seeds N] [--freq MHz] [--json]``: the whole
    chain's cost (:func:`tdicam.synth.synth`) and whether it fits an ECP5-85F."""
    from tdicam.synth import synth
    ns, p, data = _scene_args("tdicam synth pipeline", extra)
    res = synth(_PipelineBlock(p, data), seeds=seeds, freq_mhz=freq_mhz)
    fits = {k: getattr(res, k) <= v for k, v in ECP5_85F.items()}
    if as_json:
        print(json.dumps({**res.to_dict(), "ecp5_85f": ECP5_85F, "fits": fits}, indent=1))
        return 0
    print(f"pipeline {' -> '.join(s.block for s in p.steps)} ({p.width} x {p.rows}, "
          f"{p.lanes} channel(s)): COMB {res.comb}, LUT4 {res.lut4}, CCU2C {res.ccu2c}, "
          f"FF {res.ff}, DP16KD {res.dp16kd}, MULT18X18D {res.mult18}, Fmax "
          f"{res.fmax_mhz:.1f} MHz (seeds {res.fmax_seeds}, target {freq_mhz:g}); xc7 "
          f"{res.xilinx}")
    print("ECP5-85F: " + ("fits" if all(fits.values()) else "does not fit: " + ", ".join(
        f"{k} {getattr(res, k)} > {ECP5_85F[k]}" for k, ok in fits.items() if not ok)))
    return 0
