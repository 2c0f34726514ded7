"""A scene's ``[pipeline]`` as one design: its gateware top, its golden chain, and the
whole-scene co-simulation of the one against the other.

:func:`chain_plan` turns a scene into a :class:`ChainPlan` (the blocks in order with their
registry parameters, run-time settings and side inputs). From a chain plan, :func:`top` builds
the Verilog top (:class:`tdicam.hdl.chain_top.Pipeline` behind
:class:`~tdicam.hdl.interfaces.axis.AxisTop`),
:func:`golden` runs the golden chain (:func:`tdicam.model.chain.chain`) and
:func:`stimulus` makes the top's input beats; :mod:`tdicam.chain.cosim` co-simulates the one
against the other.

Everything about a block comes from its registry entry (:mod:`tdicam.blocks`): its golden
function, stream key and side inputs, and in :attr:`tdicam.blocks.Block.pipeline` (a
:class:`tdicam.blocks.Use`) how a scene sets its parameters and where the gateware takes
its side inputs from. The orchestration below names no block.
"""

from __future__ import annotations


import dataclasses
from dataclasses import replace

import numpy as np

from tdicam.beats import PPC_CHOICES, check_ppc
from tdicam.blocks.steps import ChainPlan, SceneData, Step, StepContext
from tdicam.errors import TdicamError, check_choice, check_range

__all__ = ["Step", "ChainPlan", "SceneData", "StepContext", "uses", "chain_plan", "top", "golden",
           "stimulus", "output_shape", "verilog", "identity_data", "PipelineBlock",
           "check_options", "ECP5_85F", "XC7K325T", "xc7_share", "run_values", "register_map",
           "MEMORY", "scene_ppc", "sourced", "rate_ppc", "step_ppc", "out_ppc", "chain_text",
           "load_pipeline_scene", "link_plan", "link_words", "PARTS",
           "link_word_count"]


# --------------------------------------------------------------------------------------
# what each block contributes: its registry entry's ``pipeline`` (tdicam.blocks.Use)
# --------------------------------------------------------------------------------------


def uses():
    """Block name -> its :class:`tdicam.blocks.Use`, for every block with a gateware stage
    in a pipeline."""
    from tdicam import blocks
    return {b.name: b.pipeline for b in blocks.all_blocks() if b.pipeline is not None}


def _golden_stage(step, data):
    """The block's golden stage from its registry entry."""
    from tdicam import blocks
    from tdicam.model.chain import GoldenStage
    blk = blocks.get(step.block)
    use = blk.pipeline
    if use.chain_golden is not None:
        return GoldenStage(step.block, use.chain_golden(step, data), merge=use.merge,
                           group=step.group)
    params = blk.resolve(step.params)
    lane_keys = [blk.streams.stream] + [s.name for s in blk.streams.side_inputs
                                        if s.per == "pixel"]

    def fn(arrays, lane):
        scene = dict(step.inputs)
        if use.side is not None:
            scene.update(use.side(step, data, lane))
        scene.update(zip(lane_keys, arrays))
        out = np.asarray(blk.run_golden(scene, params)["out"])
        rows = 1 if use.lines else out.shape[-2]
        return out.reshape(-1, rows, out.shape[-1])
    return GoldenStage(step.block, fn, merge=use.merge, group=step.group)


_uses_table = uses


def _use(name):
    table = uses()
    if name not in table:
        raise TdicamError(f"pipeline: block {name!r} has no gateware stage; blocks with one: "
                          f"{', '.join(table)}")
    return table[name]


# --------------------------------------------------------------------------------------
# chain plan, top, golden chain
# --------------------------------------------------------------------------------------


#: ``--memory`` of ``tdicam verilog|synth|export pipeline``: a block's large memory (TDI's
#: partial sums) on chip, in DDR, or ``auto`` by the device's block RAM, as the ``spill``
#: argument of :func:`chain_plan` (no ``--memory``: None, the scene's own placement).
MEMORY = {"auto": "auto", "chip": False, "ddr": True}


def scene_ppc(scene):
    """The scene's ``[run.rtl].pixels_per_clock`` (1 without ``[run.rtl]``)."""
    return 1 if scene.run.rtl is None else int(scene.run.rtl.pixels_per_clock)


#: The parts of a camera's top that ``part`` builds (:func:`chain_plan`): the whole top; only
#: its source (the sensor's front end, from the lanes to the pixel stream: one device of a
#: two-device split); everything after it (from the pixel stream to the top's output).
PARTS = ("whole", "front", "chain")


def chain_plan(scene, *, stages=None, lines=None, width=None, blocks=None, spill=None,
               device="ecp5-85f", ppc=None, phy=None, part="whole"):
    """The :class:`ChainPlan` of ``scene``'s ``[pipeline]`` (or of ``blocks`` in that order).

    ``ppc``: pixels per clock of the chain's input and of every block before a line-making
    one (1, 2, 4, 8; default the scene's ``[run.rtl].pixels_per_clock``, 1 without it),
    set as each block's ``ppc`` parameter (at 1 only where the block's own step states it:
    the ppc-1 parameters, Verilog and golden vectors stay those of before); ``width`` must
    be a multiple of it. A block after TDI of ``m`` stages gets ``m`` times fewer pixels a
    second and is built at :func:`rate_ppc` (``ppc / m`` rounded up to a choice: 1 for the
    bundled chains at 8), a width converter with a one-row FIFO before it
    (:func:`tdicam.hdl.chain_links.narrow`).

    ``spill``: True keeps a block's large memory (TDI's partial sums) in DDR through its
    ``spill`` variant (``tdi_ddr`` with the simulation MIG model), False on chip, ``"auto"``
    as below whatever the scene says; ``None``:
    as the scene places it (:attr:`tdicam.blocks.Memory.placement`, ``[pipeline.tdi].memory``),
    ``auto`` meaning DDR when it exceeds ``device``'s on-chip RAM
    (:data:`tdicam.model.physics.plan.ONCHIP_RAM_BITS`). A spill uses the DDR interface of the
    scene's ``[ddr]`` section.

    ``phy``: the PHY of the chain's source block (the sensor's front end, with a
    ``[sensor.lvds]`` section): ``"none"`` the generic simulated one, ``"xilinx7"`` the
    7-series primitives (its ``phy`` parameter); None: the block's default.

    ``part``: one of :data:`PARTS`: ``"whole"`` the top as the scene has it; with the
    sensor's lanes, ``"front"`` the plan of the front end alone (the top from the lanes to
    the pixel stream, no links) or ``"chain"`` the plan without it (the top from the pixel
    stream, as a scene without ``[sensor.lvds]``, to its output): the two devices of a
    split camera, each synthesized on its own (``tdicam synth pipeline --part``).

    Raises a one-line :class:`TdicamError` naming the blocks when the chain cannot be built:
    a block without a gateware stage, a per-exposure block after a line-making one, a
    merging block without two channels, a pixel width a block cannot take, a memory that
    does not fit on chip with no DDR variant, a spill without a ``[ddr]`` section, a DDR
    too slow for the scene's line rate, a spill asked of a chain with nothing to spill, a
    width not a multiple of ``ppc`` or too narrow for a block at it.
    """
    import tdicam.blocks
    check_choice("part", part, PARTS)
    if part != "whole" and not any(u.source is not None and u.source(scene)
                                   for u in _uses_table().values()):
        raise TdicamError(f"pipeline: --part {part} splits a camera at its front end, and "
                          f"this scene has none (no [sensor.lvds] section): use --part whole")
    names = list(scene.pipeline.blocks if blocks is None else blocks)
    if scene.tdi.domain != "digital":
        raise TdicamError("pipeline: [tdi].domain = 'charge' sums in the sensor; only a "
                          "digital-TDI chain has a gateware pipeline")
    m = int(scene.tdi.stages[0] if stages is None else stages)
    n_lines = int(scene.run.lines if lines is None else lines)
    w = int(scene.sensor.columns if width is None else width)
    ppc = scene_ppc(scene) if ppc is None else int(ppc)
    check_ppc(ppc, w, "pipeline: pixels per clock")
    uses = [_use(n) for n in names]
    for n, u in zip(names, uses):
        if u.source is not None:
            raise TdicamError(f"pipeline: block {n!r} has no gateware stage to list: it is "
                              f"the chain's source, placed by the scene")
    merge = any(u.merge for u in uses)
    ctx = StepContext(scene, m, w, n_lines, scene.sensor.bits, ppc=ppc,
                      ddr_base=0 if scene.ddr is None else scene.ddr.base)
    steps, prev, spilled, slower = [], "input", False, 1
    for name, u in zip(names, uses):
        if u.per_frame and ctx.after_lines:
            raise TdicamError(f"pipeline: {name} acts on single exposures and cannot follow "
                              f"{prev}, which sums them into lines")
        ctx.ppc = rate_ppc(ppc, slower)
        try:
            ctx.block = name
            step, out_bits = _at_ppc(*u.step(ctx), ctx.ppc)
            tdicam.blocks.get(name).resolve(step.params)
            go, why = _spills(u, step, scene, spill, device)
            if go and u.memory.spill is None:
                raise TdicamError(f"{why} and it has no DDR variant")
            if go and scene.ddr is None:
                raise TdicamError(f"{why}: it spills to DDR through {u.memory.spill}, but the "
                                  f"scene has no [ddr] section (the DDR interface a spill uses)")
            if go:
                spilled = True
                ctx.block = name = u.memory.spill
                step, out_bits = _at_ppc(*_use(name).step(ctx), ctx.ppc)
                tdicam.blocks.get(name).resolve(step.params)
        except TdicamError as exc:
            raise TdicamError(f"pipeline: {prev} -> {name}: {exc}") from None
        steps.append(step)
        ddr_end = _use(step.block).memory.ddr_end
        if ddr_end is not None:
            ctx.ddr_base = max(ctx.ddr_base, ddr_end(step))
        ctx.bits = out_bits
        ctx.after_lines = ctx.after_lines or u.lines
        slower *= m if u.lines else 1
        prev = name
    if spill is True and not spilled:
        raise TdicamError(f"pipeline: a DDR spill was asked but no block of "
                          f"{' -> '.join(names)} keeps its memory in DDR")
    # a block that makes the pixel stream itself (the sensor's front end) goes first; it
    # is sized for the longest hold of a DDR block after it (the MIG model's worst stall)
    from tdicam.model.dram import DEFAULT_STALLS, worst_stall
    held = [tdicam.blocks.get(s.block).resolve(s.params) for s in steps]
    stall = max([worst_stall(q) for q in held if set(DEFAULT_STALLS) <= set(q)] or [0])
    sourced = False
    for name, u in _uses_table().items():
        if u.source is not None and u.source(scene) and part != "chain":
            src = StepContext(scene, m, w, n_lines, scene.sensor.bits, ppc=ppc, block=name,
                              lanes=2 if merge else 1, stall_cycles=stall,
                              reset_frames=bool(steps) and bool(_use(steps[0].block).reset_frames))
            try:
                step, _ = _at_ppc(*u.step(src), ppc)
                if phy is not None:
                    step = replace(step, params={**step.params, "phy": phy})
                tdicam.blocks.get(name).resolve(step.params)
            except TdicamError as exc:
                raise TdicamError(f"pipeline: {name} (the chain's source): {exc}") from None
            # the block as placed (cds keeping its reset frame in DDR is cds_ddr)
            head = _use(steps[0].block) if steps else None
            if head is not None and head.elems != 1:
                raise TdicamError(f"pipeline: {steps[0].block} takes {head.elems} elements a "
                                  f"pixel; the sensor's front end ({name}) gives one")
            steps.insert(0, step)
            sourced = True
    if phy not in (None, "none") and not sourced:
        raise TdicamError(f"pipeline: --phy = {phy} needs the sensor's lanes in the chain "
                          f"(a [sensor.lvds] section in the scene)"
                          + (" and not --part chain" if part == "chain" else ""))
    # a first block taking the reset frames in the stream gets them from the lanes too:
    # the sensor sends each reset frame before its signal frame, its kind in the row headers
    first = _use(steps[int(sourced)].block) if len(steps) > int(sourced) else None
    plan = ChainPlan(tuple(steps), lanes=2 if merge else 1,
                     lane_elems=first.elems if first else 1, in_bits=scene.sensor.bits,
                     stages=m, width=w, frames=n_lines + m - 1, lines=n_lines,
                     source=str(scene.source), ppc=ppc,
                     reset_frames=bool(first and first.reset_frames),
                     ddr_interfaces=None if getattr(scene, "camera", None) is None
                     else scene.camera.ddr_interfaces)
    if part == "front":           # the front end alone: its pixel stream is the top's output
        return replace(plan, steps=plan.steps[:1], reset_frames=False)
    return plan if scene.pipeline.output != "links" else replace(
        plan, links=link_plan(scene, plan, ctx.bits, ddr_base=ctx.ddr_base))


def link_plan(scene, p, bits, *, ddr_base=0):
    """The :class:`~tdicam.blocks.steps.LinkPlan` of a scene whose ``[pipeline].output`` is
    ``"links"``, for its chain plan ``p`` whose output is ``bits``-bit pixels:
    ``[camera]``'s links, word clock and pixel bits (at least ``bits``, else a one-line
    error);
    ``keep`` = ``frame_rate_hz / output_frame_rate_hz`` (a whole number,
    :func:`tdicam.model.frame_select.keep_every`).

    The images and where the links learn a frame's end: the chain's frame markers (a
    frame ends where the next one's ``first`` comes). A 2-D block after TDI (median3)
    already frames the run's lines into one image (its group, ``[run].lines`` rows: the
    sensor's 3800 for the whole frame, a cut's lines for a cut); those frames are the
    links' images. A chain whose output frames are single lines (no 2-D block) is
    gathered by the selector, ``image_rows`` frames an image: the sensor's rows, or the
    run's lines when it runs fewer.

    The frame buffer: when the links carry fewer frames a second than the sensor makes
    (:func:`tdicam.chain.link_rates.link_buffer_images` > 0, the whole frame's budget: the
    camera of Ning et al. 2019, 25 frame/s against the links' 10.2), the kept images wait
    in DDR before the links: ``buffer_rows`` = that many images of ``image_rows`` (a cut
    keeps the whole camera's buffer on its own rows). A chain from the lanes whose links
    send a row slower than the lanes bring one
    (:func:`tdicam.chain.link_rates.links_keep_up` False) has one image of room even when
    the frame rate fits: lanes cannot wait for the links. The buffer's lines start at
    ``ddr_base`` (the first address above the chain's DDR blocks' regions): it shares
    their DDR interfaces, its lines dealt to them in turn
    (:class:`~tdicam.hdl.output_links.OutputLinks`)."""
    from tdicam.blocks.steps import LinkPlan
    from tdicam.model.frame_select import keep_every
    from tdicam.chain.link_rates import link_buffer_images, links_keep_up
    cam = scene.camera
    if bits > cam.link_pixel_bits:
        raise TdicamError(f"pipeline: the chain's output is {bits}-bit pixels, "
                          f"[camera].link_pixel_bits = {cam.link_pixel_bits} would drop bits; "
                          f"give link_pixel_bits >= {bits}")
    frames, rows, _ = output_shape(p)
    image = rows if rows > 1 else min(int(scene.sensor.rows), max(frames, 1))
    images = link_buffer_images(scene)
    if not images and sourced(p) and not links_keep_up(scene):
        images = 1
    return LinkPlan(links=cam.links, pixel_bits=cam.link_pixel_bits,
                    clock_mhz=cam.link_clock_mhz,
                    keep=keep_every(cam.frame_rate_hz, cam.output_frame_rate_hz),
                    image_rows=image, frame_rows=rows,
                    buffer_rows=images * image, buffer_base=ddr_base if images else 0)


def link_word_count(p):
    """Words a link of plan ``p`` sends besides its IDLEs (the frames' SOF and number, every
    row's SOL, number, payload, EOL and CRC) for the chain's output: what the links'
    co-simulation waits for."""
    from tdicam.model import tlk2711
    lk = p.links
    frames, rows, w = output_shape(p)
    total = frames * rows
    heights = [lk.image_rows] * (total // lk.image_rows) + \
        ([total % lk.image_rows] if total % lk.image_rows else [])
    per_row = tlk2711.line_words(w, pixel_bits=lk.pixel_bits, links=lk.links) - 2
    return sum(2 + h * per_row for h in heights[::lk.keep])


def link_words(p, gold):
    """The words the links of plan ``p`` send for the golden chain's output ``gold`` (the
    last of :func:`golden`'s stages): its frames gathered into images, one in ``keep``
    (:func:`tdicam.model.frame_select.link_images`), through
    :func:`tdicam.model.tlk2711.tlk2711`; ``(links, n)`` uint32."""
    from tdicam.model import tlk2711
    from tdicam.model.frame_select import link_images
    lk = p.links
    imgs = link_images(gold[-1][2], image_rows=lk.image_rows, keep=lk.keep)
    return tlk2711.tlk2711(imgs, pixel_bits=lk.pixel_bits, links=lk.links)


def rate_ppc(ppc, slower):
    """Pixels per clock of a block whose stream is ``slower`` times slower than the chain's
    input at ``ppc`` (after TDI of ``m`` stages: ``m``): the fewest of :data:`PPC_CHOICES`
    that carry its pixels at the input's full rate, ``ppc / slower`` rounded up (the
    orbit chain at 8, after 96 stages: 1; Ning et al. 2019's at 8, after 8 stages: 1)."""
    return min(c for c in PPC_CHOICES if c * slower >= ppc)


def step_ppc(step):
    """Pixels a beat of a plan step's block (its ``ppc`` parameter, 1 without one)."""
    return int(step.params.get("ppc", 1))


def out_ppc(p):
    """Pixels a beat of plan ``p``'s output stream (its last block's)."""
    return step_ppc(p.steps[-1]) if p.steps else p.ppc


def chain_text(p):
    """The blocks of plan ``p`` in order with their pixels per clock, and the width
    converters between them: ``"nuc -> tdi -> median3 at 8 pixels per clock"``, or
    ``"nuc -> tdi (8 pixels per clock) -> 8:1 width converter -> median3 (1 pixel per
    clock)"``; a plan that ends in the output links says so after them."""
    def at(n):
        return f"{n} pixel{'s' if n > 1 else ''} per clock"
    lk = p.links
    links = "" if lk is None else (
        f" -> frame selector (1 image in {lk.keep}) -> {lk.links} TLK2711 link"
        f"{'s' if lk.links > 1 else ''} ({lk.pixel_bits}-bit pixels, link_clk "
        f"{lk.clock_mhz:g} MHz)")
    ppcs = [step_ppc(s) for s in p.steps]
    if len(set(ppcs + [p.ppc])) <= 1:
        return f"{' -> '.join(s.block for s in p.steps)} at {at(p.ppc)}{links}"
    parts, cur = [], p.ppc
    for s, n in zip(p.steps, ppcs):
        if n < cur:
            parts[-1] += f" ({at(cur)})"
            parts.append(f"{cur // n}:1 width converter")
        parts.append(s.block)
        cur = n
    return " -> ".join(parts) + f" ({at(cur)}){links}"


def _at_ppc(step, out_bits, ppc):
    """``step`` with its block's ``ppc`` parameter set to ``ppc`` (unchanged at 1: the
    block's default); a one-line error when the block takes one pixel per clock only."""
    from tdicam import blocks
    if ppc == 1 and step.params.get("ppc", 1) == 1:
        return step, out_bits
    if "ppc" not in {p.name for p in blocks.get(step.block).params}:
        raise TdicamError(f"{step.block} takes one pixel per clock, the chain {ppc}")
    return replace(step, params={**step.params, "ppc": ppc}), out_bits


def _spills(u, step, scene, spill, device):
    """Whether block use ``u`` keeps its memory in DDR, and why (a phrase for errors)."""
    from tdicam.model.physics.plan import onchip_budget
    mem = u.memory
    if mem.bits is None and mem.placement is None:
        return False, ""
    if spill is not None and mem.caller_places:
        asked, how = {True: "ddr", False: "chip", "auto": "auto"}[spill], "the caller"
    else:
        asked, how = (mem.placement(scene) if mem.placement else "auto"), "the scene"
    if mem.bits is None:                # placed by the scene only, never by size
        return asked == "ddr", f"its {mem.holds} are placed in DDR by {how}"
    need, budget = mem.bits(step), onchip_budget(device)
    if asked == "auto":
        return need > budget, (f"its {mem.holds} ({need} bits) exceed the {device}'s on-chip "
                               f"RAM ({budget} bits)")
    return asked == "ddr", f"its {mem.holds} ({need} bits) are placed in DDR by {how}"


def identity_data(p):
    """Scene data placeholder for elaboration: no frames, side data that make each block a
    no-op (:attr:`tdicam.blocks.Use.identity`, e.g. identity NUC coefficients)."""
    fields = {}
    for st in p.steps:
        ident = _use(st.block).identity
        if ident is not None:
            fields.update({k: [v] * p.lanes for k, v in ident(st, (p.stages, p.width)).items()})
    return SceneData([], **fields)


def sourced(p):
    """Whether plan ``p``'s chain starts at a source block (the sensor's front end): its top
    then takes the sensor's lanes, not pixel beats (no ``s_axis_*`` ports)."""
    return bool(p.steps) and _use(p.steps[0].block).source is not None


def top(p, data=None, *, taps=False, ecp5=False, board=False, csr=False, bus="axi4-lite"):
    """The AXI4-Stream top of plan ``p`` (NUC calibration images from ``data``; ``ecp5``:
    each block's ECP5 synthesis top where it has one, for ``tdicam synth``; ``board``: for
    co-simulation, the top inside a :class:`~tdicam.hdl.chain_board.Board` with the
    simulation models of its external parts on its pins, when it has any; ``csr``: the
    settings and status behind the slave :class:`~tdicam.hdl.csr.CsrTop` on
    :func:`register_map`'s map, ``bus`` one of :data:`tdicam.hdl.csr.BUSES`)."""
    from tdicam.hdl.interfaces.axis import AxisTop
    from tdicam.hdl.chain_board import Board
    from tdicam.hdl.chain_top import Pipeline
    data = identity_data(p) if data is None or data.coeffs is None else data
    stages = [_use(s.block).hw(s, data, ecp5=ecp5) for s in p.steps]
    try:
        core = Pipeline(stages, in_bits=p.in_bits, lanes=p.lanes, lane_elems=p.lane_elems,
                        taps=taps, ppc=p.ppc, width=p.width,
                        bram="ecp5" if ecp5 else "generic", links=p.links)
    except TdicamError as exc:
        raise TdicamError(str(exc)) from None
    shared = core.shared_ddr
    if shared and p.ddr_interfaces not in (None, p.lanes):
        raise TdicamError(f"pipeline: [camera].ddr_interfaces = {p.ddr_interfaces}: the "
                          f"generated top has one DDR interface a gain channel ({p.lanes}), "
                          f"its DDR users sharing it; give ddr_interfaces = {p.lanes} or "
                          f"leave it out")
    pipeline = core
    if board and core.has_devices():
        core = Board(core)
    if csr:
        from tdicam.hdl.csr import CsrTop
        core = CsrTop(core, register_map(p, pipeline), bus)
    return AxisTop(core)


def run_values(p):
    """{top port: value} of plan ``p``'s run-time settings (the scene's; a tuple: a
    per-frame pattern)."""
    return {f"{s.block}_{k}": v for s in p.steps for k, v in s.ports.items()}


def register_map(p, pipeline=None):
    """The :class:`~tdicam.hdl.csr_map.RegisterMap` of plan ``p``'s top (``pipeline``: its
    :class:`~tdicam.hdl.chain_top.Pipeline`, made when not given), its settings' reset
    values the scene's."""
    import os
    from tdicam.hdl.csr_map import register_map as _map
    import re
    if pipeline is None:
        made = top(p)
        pipeline = made.core
        made._MustUse__silence = pipeline._MustUse__silence = True    # for its ports only
    name = re.sub(r"\W", "_", os.path.splitext(os.path.basename(p.source))[0]) or "pipeline"
    name = "t_" + name if name[0].isdigit() else name
    return _map(pipeline, run_values(p), name=name)


def verilog(p, data=None, *, taps=False):
    """Deterministic Verilog text of the top (module ``pipeline``), after
    :func:`verilog_header`."""
    from tdicam.hw.verilog import convert
    return convert(top(p, data, taps=taps), "pipeline", header=verilog_header(p, taps=taps))


def verilog_header(p, *, taps=False, csr=False, bus="axi4-lite"):
    """The comment header of the pipeline's Verilog: tdicam version, the scene file's name
    (no path), the blocks in order with their parameters, channels, frame and lines (and
    ``csr``, the bus, when the control bus is on)."""
    import os
    from tdicam.hw.verilog import header
    return header("pipeline", {
        "scene": os.path.basename(p.source), "blocks": " -> ".join(s.block for s in p.steps),
        "channels": p.lanes, "frame": f"{p.width}x{p.stages}", "lines": p.lines,
        "taps": taps} | ({"csr": bus} if csr else {})
        | {s.block: s.params for s in p.steps}
        | ({} if p.links is None else {"links": {
            k: v for k, v in dataclasses.asdict(p.links).items()
            if k not in ("buffer_rows", "buffer_base") or v}}))   # (no buffer: as it was)


def golden(p, data):
    """Every stage's golden output, in the order of the top's taps: list of [tap name,
    block, ndarray (frames, rows, width)]."""
    from tdicam.model.chain import chain
    stages = [_golden_stage(s, data) for s in p.steps]
    out = []
    for (name, lanes), st in zip(chain(data.lane_arrays(p), stages), p.steps):
        for k, a in enumerate(lanes):
            out.append([name + (f"_{k}" if len(lanes) > 1 else ""), st.block, a])
    return out


def _ctrl(axis_top, p):
    """Packed run-time port values (first port in the most significant bits), one word per
    input frame of the ports' per-frame pattern (a tuple value, :class:`Step`): the words of
    frames ``0 .. n-1``, repeating."""
    from math import lcm
    from tdicam.cosim import stream_ports
    _, _, ctrl = stream_ports(axis_top)
    values = run_values(p)
    period = lcm(1, *(len(v) for v in values.values() if isinstance(v, tuple)))
    words = []
    for f in range(period):
        word = 0
        for name, width in ctrl:
            if name not in values:
                raise TdicamError(f"pipeline: no value for the top's input port {name}")
            v = values[name]
            v = v[f % len(v)] if isinstance(v, tuple) else v
            word = (word << width) | (int(v) & ((1 << width) - 1))
        words.append(word)
    return ctrl, words


def stimulus(p, data, axis_top):
    """Input beats of the scene data (every lane's elements in each beat), each with the
    run-time port values of its frame."""
    from tdicam.beats import frames_to_beats
    arrs = [a for lane in data.lane_arrays(p) for a in lane]
    stim = frames_to_beats(np.stack(arrs, axis=-1), ppc=p.ppc, channels=len(arrs))
    _, words = _ctrl(axis_top, p)
    frame = np.cumsum(stim.first) - 1
    stim.ctrl = np.asarray(words, np.uint64)[frame % len(words)]
    return stim


def output_shape(p):
    """(frames, rows, width) of the chain's output (pixels; :func:`out_ppc` of them a
    beat)."""
    frames, rows = p.frames, p.stages
    for s in p.steps:
        if _use(s.block).lines:
            frames, rows = max(frames - s.params["stages"] + 1, 0), 1
        if s.group is not None:
            frames, rows = frames // s.group, rows * s.group
    return frames, rows, p.width


#: ECP5-85F (LFE5U-85F) resources: LUT4 slots, flip-flops, 18 kbit EBRs, 18x18 multipliers.
ECP5_85F = {"comb": 83640, "ff": 83640, "dp16kd": 208, "mult18": 156}

#: XC7K325T (Kintex-7) resources as yosys ``synth_xilinx`` counts them: 6-input LUTs,
#: flip-flops, 36 kbit block RAMs (two RAMB18 a RAMB36), DSP48E1 slices.
XC7K325T = {"LUT": 203800, "FF": 407600, "RAMB36": 445, "DSP48": 840}


def xc7_share(counts, part=None):
    """{resource: (used, the part's, percent)} of yosys ``synth_xilinx`` ``counts`` ({cell
    class: n}, :func:`tdicam.hw.synth.parse_xilinx`) against ``part`` (default
    :data:`XC7K325T`); block RAM in RAMB36 (a RAMB18 is half of one); LUT the logic LUTs
    (distributed RAM and shift registers, ``LUTRAM`` and ``SRL``, take LUT sites too: not
    counted here)."""
    part = XC7K325T if part is None else part
    used = {"LUT": counts.get("LUT", 0), "FF": counts.get("FF", 0),
            "RAMB36": counts.get("RAMB36", 0) + counts.get("RAMB18", 0) / 2,
            "DSP48": counts.get("DSP48", 0)}
    return {k: (used[k], part[k], round(100 * used[k] / part[k], 1)) for k in part}


def load_pipeline_scene(scene_path, stages=None):
    """The scene of ``tdicam verilog|synth|export pipeline``: with ``--stages`` the scene
    at that stage count, checked as ``[tdi].stages`` is (its range, ``M0``, the pixel
    widths of the blocks after TDI) and named ``--stages``: a value the scene refuses is
    refused as an option alike."""
    from tdicam.scene.loader import load_scene
    if stages is None:
        return load_scene(scene_path)
    return load_scene(scene_path, overrides={"tdi": {"stages": stages}},
                      labels={"tdi.stages": "--stages"})


def check_options(scene, *, lines=None, device=None, ppc=None, width=None):
    """The command-line options of a scene's pipeline (``verilog``, ``synth`` and ``export
    pipeline``), checked under their names before a plan is made: ``--lines`` within the
    bound of the scene's ``[run].lines`` (its output pixels), ``--device`` a known part,
    ``--ppc`` one of :data:`PPC_CHOICES` dividing the frame width (``width``, default the
    scene's columns)."""
    from tdicam.model.physics.plan import ONCHIP_RAM_BITS
    from tdicam.scene.loader import MAX_OUTPUT_PIXELS
    if ppc is not None:
        check_ppc(ppc, scene.sensor.columns if width is None else width, "--ppc")
    if device is not None and str(device).lower() not in ONCHIP_RAM_BITS:
        raise TdicamError(f"--device = {device!r} is not known; valid: "
                          f"{', '.join(ONCHIP_RAM_BITS)}")
    if lines is not None:
        check_range("--lines", lines, 1, MAX_OUTPUT_PIXELS // scene.sensor.columns)


class PipelineBlock:
    """The registry face of a plan for :func:`tdicam.hw.synth.synth` (name, resolve, build)."""

    def __init__(self, p, data, *, csr=False, bus="axi4-lite"):
        self.name, self._p, self._data, self._csr, self._bus = "pipeline", p, data, csr, bus

    def resolve(self, params=None):
        return {"scene": self._p.source, "steps": [[s.block, s.params, s.ports]
                                                   for s in self._p.steps]} | (
            {"csr": self._bus} if self._csr else {})

    def clocks(self, params=None):
        """The top's clocks besides ``clk`` ({clock port: MHz}): each step's other clock
        domains (the sensor lanes' word clock, ``word_clk``), its PHY's clock pins (the
        ECP5 PHY's edge clock ``lvds_clk_eclk`` at half the bit rate) and the output links'
        word clock (``link_clk``, ``[camera].link_clock_mhz``)."""
        from tdicam.hdl.lvds_front import WORD_DOMAIN
        from tdicam.hdl.lvds_phy import pin_clocks
        from tdicam.hdl.tlk2711 import LINK_DOMAIN
        out = {f"{dom}_clk": mhz for s in self._p.steps for dom, mhz in s.clocks.items()}
        if self._p.links is not None:
            out[f"{LINK_DOMAIN}_clk"] = self._p.links.clock_mhz
        for s in self._p.steps:      # a PHY's pin clocks (the ECP5 edge clock) by their port
            if WORD_DOMAIN in s.clocks and "word_bits" in s.params:
                out.update({f"{s.block}_{name}": mhz for name, mhz in pin_clocks(
                    s.params.get("phy", "none"), s.clocks[WORD_DOMAIN],
                    s.params["word_bits"]).items()})
        return out

    def derived_clocks(self, params=None):
        """The clocks the top derives from its clock pins ({domain: MHz}; nextpnr constrains
        them itself, e.g. the ECP5 PHY's ``sclk`` = ``ECLK / 2``)."""
        from tdicam.hdl.lvds_front import WORD_DOMAIN
        from tdicam.hdl.lvds_phy import derived_clocks
        out = {}
        for s in self._p.steps:
            if WORD_DOMAIN in s.clocks and "word_bits" in s.params:
                out.update(derived_clocks(s.params.get("phy", "none"), s.clocks[WORD_DOMAIN],
                                          s.params["word_bits"]))
        return out

    def build(self, params=None, *, ecp5=False):
        """The chain's top; ``ecp5``: each block's ECP5 synthesis top where it has one
        (:attr:`tdicam.blocks.Block.ecp5_top`, e.g. the TDI accumulator's DP16KD banks)."""
        return top(self._p, self._data, ecp5=ecp5, csr=self._csr, bus=self._bus)
