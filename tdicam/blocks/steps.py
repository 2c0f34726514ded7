"""The data of a scene's chain that blocks and tools share: a :class:`ChainPlan` of :class:`Step` s,
the :class:`StepContext` a block's :attr:`tdicam.blocks.Use.step` plans from, and the raw
:class:`SceneData` the chain runs on; for the scene simulator (:mod:`tdicam.engine`), the
:class:`Frames` its frame stacks travel in and a block's :class:`Sim` rows (its steps there).

:mod:`tdicam.chain.design` makes plans from scenes; each block's registry entry
(:mod:`tdicam.blocks`) turns a :class:`StepContext` into its :class:`Step`, and its
:attr:`tdicam.blocks.Use.sim` steps (:attr:`tdicam.blocks.SceneSim.steps`) say what the block does to the simulator's frame stacks
(the engine generates its effect rows for the blocks from them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Protocol, runtime_checkable

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["Step", "ChainPlan", "LinkPlan", "SceneData", "StepContext", "Frames", "Sim", "RunView"]


@dataclass(frozen=True)
class Step:
    """One block of a plan: registry ``params``, run-time port values ``ports`` (gateware),
    ``inputs`` (the same settings as the registry's ``run`` side inputs, golden side) and
    ``group`` (incoming frames grouped into one, or None), ``device`` (settings of the
    block's external part: the NAND flash holding NUC's coefficients, its geometry and
    faults; empty: none), ``clocks`` (the block's clock domains besides the processing
    clock, {domain: MHz}: the sensor lanes' word clock of the front end). A ``ports`` value
    that is a tuple is a per-frame pattern: input frame ``f`` presents element ``f % len``."""

    block: str
    params: dict
    ports: dict = field(default_factory=dict)
    group: int | None = None
    inputs: dict = field(default_factory=dict)
    device: dict = field(default_factory=dict)
    clocks: dict = field(default_factory=dict)


@dataclass(frozen=True)
class ChainPlan:
    """A scene's chain (:func:`tdicam.chain.design.chain_plan` makes it): ``steps`` in order;
    input ``lanes`` (channels) of ``lane_elems`` elements of ``in_bits``; frames of ``stages``
    x ``width`` pixels (one row per TDI stage: the sensor's window), ``frames`` of them;
    ``ppc`` pixels per beat of every block's stream (``width`` a multiple of it);
    ``reset_frames``: each lane's reset frames travel in the stream as frames of their own,
    each before its signal frame (the first block stores them,
    :attr:`tdicam.blocks.Use.reset_frames`), instead of beside each pixel;
    ``ddr_interfaces``: the scene's ``[camera].ddr_interfaces`` (None without ``[camera]``):
    the top has one DDR interface a channel lane, and refuses another count when its DDR
    users share them; ``links``: the output links the top ends in (None: its pixel
    stream)."""

    steps: tuple
    lanes: int
    lane_elems: int
    in_bits: int
    stages: int
    width: int
    frames: int
    lines: int
    source: str = ""
    ppc: int = 1
    reset_frames: bool = False
    ddr_interfaces: int | None = None
    links: LinkPlan | None = None

    @property
    def input_pixels(self):
        return self.frames * self.stages * self.width * self.lanes


@dataclass(frozen=True)
class LinkPlan:
    """The camera's output links at the end of a chain (``[pipeline].output = "links"``,
    the numbers ``[camera]``'s): ``links`` TLK2711s (1, 2) of ``pixel_bits`` a pixel at
    ``clock_mhz``; images of ``image_rows`` rows (the sensor's, or a shorter run's lines)
    made of the chain's frames of ``frame_rows`` rows each, one image in ``keep`` sent
    (:mod:`tdicam.model.frame_select`); ``buffer_rows`` > 0: the kept images wait in a
    DDR frame buffer of that many rows before the links
    (:class:`~tdicam.hdl.output_links.OutputLinks`), 0: none; its lines from DDR address
    ``buffer_base`` on (above the chain's other DDR regions: the buffer shares their
    interfaces)."""

    links: int
    pixel_bits: int
    clock_mhz: float
    keep: int
    image_rows: int
    frame_rows: int = 1
    buffer_rows: int = 0
    buffer_base: int = 0


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
            if plan.reset_frames:
                if self.reset is None:
                    raise TdicamError("pipeline: the chain starts with a block that stores "
                                      "reset frames but the scene data has no reset frames")
                r = np.asarray(self.reset[k])
                both = np.empty((2 * len(arrs[0]),) + arrs[0].shape[1:], arrs[0].dtype)
                both[0::2], both[1::2] = r, arrs[0]          # reset frame, then its signal
                arrs = [both]
            elif plan.lane_elems == 2:
                if self.reset is None:
                    raise TdicamError("pipeline: the chain starts with a two-element block "
                                      "(CDS) but the scene data has no reset frames")
                arrs.append(np.asarray(self.reset[k]))
            out.append(arrs)
        return out

    def crop(self, x0, w, f0, nf, *, coeff_rows=False):
        """The data of columns ``x0:x0+w`` and frames ``f0:f0+nf``; ``coeff_rows``: the
        coefficients have a row a frame (an area camera's, ``[pipeline.nuc].coefficients =
        "frame"``), rows ``f0:f0+nf`` of them kept too."""
        cut = (lambda a: np.ascontiguousarray(np.asarray(a)[f0:f0 + nf, :, x0:x0 + w]))
        rows = slice(f0, f0 + nf) if coeff_rows else slice(None)
        return SceneData([cut(s) for s in self.signal],
                         None if self.reset is None else [cut(r) for r in self.reset],
                         None if self.coeffs is None else
                         [(np.ascontiguousarray(g[rows, x0:x0 + w]),
                           np.ascontiguousarray(o[rows, x0:x0 + w])) for g, o in self.coeffs])


@dataclass
class StepContext:
    """What a block's :attr:`tdicam.blocks.Use.step` sees: the ``scene``, TDI stages ``m``,
    frame ``width``, output ``lines``, the chain's pixel width so far (``bits``), whether a
    line-making block came before (``after_lines``), the block being planned and the
    pixels per clock of every block (``ppc``: :func:`tdicam.chain.design.chain_plan` sets it in
    each step's parameters) and the chain's channel lanes (``lanes``: 2 with a merging
    block, known when a source block is planned); ``stall_cycles``: the longest the blocks
    after a source block may hold the stream at once (the DDR model's worst stall,
    :func:`tdicam.model.dram.worst_stall`, of a DDR block in the chain; 0 without one);
    ``reset_frames``: the chain after a source block takes reset frames in the stream,
    each before its signal frame; ``ddr_base``: the first DDR address unit above the regions
    of the DDR blocks planned before (``[ddr].base`` before any; see
    :attr:`tdicam.blocks.Memory.ddr_end`), where a DDR block sharing the interface puts its own."""

    scene: object
    m: int
    width: int
    lines: int
    bits: int
    after_lines: bool = False
    block: str = ""
    ppc: int = 1
    lanes: int = 1
    stall_cycles: int = 0
    reset_frames: bool = False
    ddr_base: int = 0


@dataclass
class Frames:
    """Frame stacks on their way through the blocks of the scene simulator.

    ``channels`` holds one stack per ADC channel (HG, LG) until a merging block makes one;
    ``resets`` the reset frames (with CDS); ``bits`` the pixel width the next block gets;
    ``timer`` the run's timer; ``keep`` cuts the RTL crop out of a stack (None: keep nothing)
    into ``crop`` (per block: its scene arrays, output and parameters); after the
    line-making block ``out`` holds the output lines, ``full_scale`` their largest value and
    ``keep_out`` the output crop ``(y0, h, x0, w)``.
    """

    channels: list
    resets: list | None
    bits: int
    timer: object
    keep: object = None
    crop: dict = field(default_factory=dict)
    out: np.ndarray | None = None        # output lines (after the line-making block)
    full_scale: int = 0                  # of ``out``
    keep_out: tuple | None = None        # (y0, h, x0, w) of the output crop


@runtime_checkable
class RunView(Protocol):
    """What a block's scene-simulator step (:class:`Sim`) may read of the engine's run: the
    whole of it. The engine's :class:`tdicam.engine.context.RunContext` is one
    (``tests/test_block_entries.py`` checks that it has every member and that no block step
    reads another attribute of its run argument ``c``).

    Attributes
    ----------
    scene : tdicam.scene.Scene
        The scene being run.
    m : int
        TDI stages (rows a ground line sums).
    sensor : tdicam.scene.schema.Sensor
        ``scene.sensor``.
    gains : tuple of float
        Channel gains converted in this pass (both with dual gain, else the high gain).
    zero_dn : float
        DN of zero light after the exposure blocks (0 with CDS, else the ADC pedestal).
    digital : bool
        The TDI sum is digital (``[tdi].domain``).
    prepared : dict
        Side inputs the blocks' ``prepare`` made for this pass (NUC's ideal coefficients
        under ``"coeffs"``); a step reads it, ``prepare`` writes it.
    flash : dict
        Per channel, the NAND store's counters of this run; NUC's step writes them once.
    frame_rows : bool
        An area camera (``[pipeline.nuc].coefficients = "frame"``): frame ``r`` is sensor
        row ``r``, the fixed pattern and NUC's coefficients a row per frame.
    """

    scene: object
    m: int
    prepared: dict
    flash: dict

    @property
    def sensor(self): ...

    @property
    def gains(self) -> tuple: ...

    @property
    def zero_dn(self) -> float: ...

    @property
    def digital(self) -> bool: ...

    @property
    def frame_rows(self) -> bool: ...


@dataclass(frozen=True)
class Sim:
    """One step of a block in the scene simulator (:mod:`tdicam.engine`): a row of its
    effects table, named after the block (``<name>_<where>`` with ``where``).

    The functions take the engine's run ``c``, a :class:`RunView` (what they may read of it),
    and a :class:`Frames` ``fr``, which they update in place (the block's golden model on its
    scene arrays, through the entry).

    Attributes
    ----------
    label : str
        The report's label of the row.
    exact : callable(RunView, Frames)
        The step on the frame stacks (exact fidelity; also fast when ``fast`` is None and
        ``stage`` is ``output``).
    stage : {"blocks", "lines", "output"}
        ``blocks``: on the frame stacks before the line-making block (per exposure);
        ``lines``: the line-making block (``Use.lines``); ``output``: on its output lines.
    where : {"pre", "post"} or None
        For a block that may run on either side of the line-making block, the side this
        row is (``[pipeline].blocks`` order decides which runs).
    fast : callable(RunView, Frames) or None
        The step on the fast aggregate (None: no step of its own there; an ``output`` row
        runs ``exact``).
    aggregated : bool
        Fast fidelity changes how it is computed (the record shows the fidelity).
    per_exposure : bool
        Not linear on single exposures: fast fidelity cannot aggregate it (runs exact).
    prepare : callable(RunView, gain_map, dark_map) -> dict, or None
        Side inputs the block takes from the fixed pattern (``gain_map`` and ``dark_map`` of
        the rows each output pixel sums), as :class:`SceneData` fields (NUC's ideal
        coefficients); the engine keeps them in ``c.prepared``.
    subtract : callable(signal, reset, bits) -> ndarray, or None
        A block taking reset frames: its golden model on one frame and its reset frame (the
        fast path's raw single exposure).
    pedestal : callable(scene) -> float, or None
        DN its reset frames add to the ADC pedestal (the mean reset level).
    notes : callable(RunView) -> list of str, or None
        What the run's notes say of the step once the run is over (NUC: the coefficients'
        NAND store, from ``c.flash``).
    """

    label: str
    exact: Callable[[RunView, Frames], None]
    stage: str = "blocks"
    where: str | None = None
    fast: Callable[[RunView, Frames], None] | None = None
    aggregated: bool = False
    per_exposure: bool = False
    prepare: Callable | None = None
    subtract: Callable | None = None
    pedestal: Callable | None = None
    notes: Callable | None = None
