"""The facets of a block's registry record (:class:`tdicam.blocks.Block`), each a frozen
dataclass documented where it is defined: its parameters (:class:`Param`) and golden cases
(:class:`Case`); :class:`Streams` (the stream adapters between scene and case arrays, with
their :class:`SideInput`); :class:`Use` (its place in a scene's chain, with its
:class:`Options` of :class:`KeyDoc`, its :class:`Memory` and its :class:`SceneSim`);
:class:`Bench` (with :class:`StreamWork`), :class:`Suite` (with :class:`Stalls`) and
:class:`SynthRef`. Re-exported by :mod:`tdicam.blocks`, where they are used.

Layer: as :mod:`tdicam.blocks` (imports only the leaves).
"""

from dataclasses import dataclass, field
from typing import Any, Callable

from tdicam.errors import TdicamError, check_range

__all__ = ["Param", "Case", "SideInput", "KeyDoc", "Options", "Memory", "SceneSim", "Use", "StreamWork", "Bench", "SynthRef", "Stalls", "Suite", "Streams"]


def _flag(name):
    return "--" + name.replace("_", "-")


@dataclass(frozen=True)
class Param:
    """One elaboration parameter of a block.

    Attributes
    ----------
    name : str
        Python name (``--name-with-dashes`` on the command line).
    default : object
        Value when not given; ``None`` means optional (the block derives it).
    help : str
        One line for ``tdicam verilog BLOCK --help``.
    lo, hi : int or None
        Inclusive bounds of an integer (``None``: open end).
    choices : tuple or None
        The valid values instead of a range.
    type : type
        ``int``, ``bool`` or ``str``; command-line strings are converted to it.
    implicit_default : bool
        A golden case at the default value does not record it (its ``__params__`` and
        manifest entry leave it out; :func:`tdicam.golden.load` fills the default back in):
        for a parameter added after golden vectors existed, which stay byte-identical (e.g.
        ``ppc`` of ``cds``, ``nuc``, ``hdr``).
    """

    name: str
    default: Any
    help: str
    lo: int | None = None
    hi: int | None = None
    choices: tuple | None = None
    type: type = int
    implicit_default: bool = False

    def describe(self):
        """``--name (range, default D): help`` for the block's help text."""
        if self.choices is not None:
            rng = "{" + ", ".join(str(c) for c in self.choices) + "}"
        elif self.lo is not None or self.hi is not None:
            rng = f"{self.lo if self.lo is not None else ''}..{self.hi if self.hi is not None else ''}"
        else:
            rng = self.type.__name__
        dflt = "derived" if self.default is None else self.default
        return f"--{self.name.replace('_', '-')} ({rng}, default {dflt}): {self.help}"

    def check(self, value):
        """``value`` converted to :attr:`type` and checked, or a :class:`TdicamError`
        naming ``--name`` (ranges through :func:`tdicam.errors.check_range`)."""
        if value is None and self.default is None:
            return None
        flag = _flag(self.name)
        if self.type is int:
            if isinstance(value, str):
                try:
                    value = int(value, 0)
                except ValueError:
                    raise TdicamError(f"{flag} must be an integer, got {value!r}") from None
            value = check_range(flag, value, self.lo, self.hi)
        elif self.type is bool:
            if isinstance(value, str):
                if value.lower() not in ("0", "1", "true", "false", "yes", "no"):
                    raise TdicamError(f"{flag} must be true or false, got {value!r}")
                value = value.lower() in ("1", "true", "yes")
            value = bool(value)
        else:
            value = self.type(value)
        if self.choices is not None and value not in self.choices:
            raise TdicamError(f"{flag} = {value} is not valid; "
                              f"valid: {', '.join(str(c) for c in self.choices)}")
        return value


@dataclass(frozen=True)
class Case:
    """A golden case: parameters + a deterministic generator of its arrays.

    Attributes
    ----------
    name : str
        File name under ``golden/<block>/`` (without ``.npz``).
    params : dict
        Block parameters (resolved against the block's defaults).
    make : callable(params, rng) -> dict of ndarray
        The case arrays: inputs and the expected outputs computed by the golden model.
    seed : int
        Seed of the ``numpy.random.default_rng`` passed to ``make``.
    tags : tuple of str
        What the case exercises (e.g. ``"reset"``, ``"fullscale"``); ``"fast-only"`` marks
        cases too long for per-beat co-simulation.
    """

    name: str
    params: dict
    make: Callable
    seed: int = 1
    tags: tuple = ()


@dataclass(frozen=True)
class SideInput:
    """An input of a block besides its main pixel stream.

    Attributes
    ----------
    name : str
        Key of the array in the block's scene arrays.
    per : {"pixel", "frame", "run"}
        ``pixel``: same shape as the main stream's frames (e.g. the CDS reset frame, the NUC
        coefficients, HDR's low-gain channel); ``frame``: one value per frame (HDR's
        ``gain_sel``); ``run``: one scalar for the whole run (TDI's ``stages``).
    what : str
        What it is and how the gateware receives it (stream channel, run-time port, DDR).
    default : object
        Value used when the scene arrays leave it out (``None``: required).
    """

    name: str
    per: str
    what: str
    default: Any = None


@dataclass(frozen=True)
class KeyDoc:
    """What a scene reader cannot say about a key (``docs/scene-format.md``): its unit and
    meaning, and — only where the reader computes them from other keys or checks them by
    hand — the written ``type``, ``default`` or ``range``."""

    unit: str
    meaning: str
    type: str | None = None
    default: str | None = None
    range: str | None = None


@dataclass(frozen=True)
class Options:
    """A block's ``[pipeline.<name>]`` section of a scene file.

    Attributes
    ----------
    type : type
        The frozen dataclass a scene holds as ``scene.pipeline.<name>``.
    read : callable(section, sensor) -> ``type``
        Reads the section: ``section`` is the scene reader's section (its ``number``,
        ``integer``, ``boolean``, ``choice``, ``has`` and ``fail`` check each key's type and
        range and name it as the user wrote it; unknown keys are refused before ``read`` is
        called), ``sensor`` the scene's ``[sensor]``. An absent section reads as its defaults.
    doc : str
        What the section is for (``docs/scene-format.md``).
    keys : dict of str -> KeyDoc
        The section's keys, in page order.
    probe : dict
        A section that reaches every key reader (the scene docs run the reader on it).
    """

    type: type
    read: Callable
    doc: str
    keys: dict
    probe: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Memory:
    """Where a block's memory lives in a scene's chain (:attr:`Use.memory`): how much it
    needs, who places it on chip or in DDR, the block that keeps it in DDR instead, and a DDR
    block's region. Read by the chain's planner (:mod:`tdicam.chain.design`), the camera plan
    (:mod:`tdicam.planning.camera`) and the scene reader's check of a DDR placement
    (:mod:`tdicam.scene.loader`).

    Attributes
    ----------
    bits : callable(step) -> int, or None
        On-chip memory the block needs (``holds`` says what it holds); None: placed by the
        scene only, never by size.
    holds : str
        What that memory holds, for messages ("partial sums").
    placement : callable(scene) -> {"auto", "chip", "ddr"}, or None
        Where the scene puts that memory (``auto``: DDR when it exceeds the device's block
        RAM; None: always ``auto``).
    spill : str or None
        The registered block that keeps that memory in DDR instead (same stream, ports and
        golden model), used when the plan says it must spill; its ``step`` takes the DDR
        interface from the scene's ``[ddr]`` section (the plan refuses a spill without one).
    caller_places : bool
        The caller's placement (``--memory``, the plan's ``spill``) applies to this block's
        memory; False: only the scene's :attr:`placement` does (CDS's reset frame: the
        ``--memory`` flag is about TDI's partial sums).
    ddr_end : callable(step) -> int, or None
        A DDR block: the address unit above its region (the next DDR block of the chain
        puts its region there, ``StepContext.ddr_base``).
    """

    bits: Callable | None = None
    holds: str = "memory"
    placement: Callable | None = None
    spill: str | None = None
    caller_places: bool = True
    ddr_end: Callable | None = None


@dataclass(frozen=True)
class SceneSim:
    """What a block does in the scene simulator (:attr:`Use.sim`, :mod:`tdicam.engine`):
    its steps, the memory its golden model holds there, and what the run's measurements
    (:mod:`tdicam.run.measure`) must know of its effect on the image.

    Attributes
    ----------
    steps : tuple of tdicam.blocks.steps.Sim
        Its steps, each a row of the simulator's effects table (two for a block that may
        run on either side of the line-making block; :mod:`tdicam.engine.block_rows`);
        empty for a block a scene does not list.
    scratch_bytes : float
        Bytes per frame-stack element the block's golden model holds at its peak beyond its
        input and output, on single exposures (the scene engine's memory estimate,
        :mod:`tdicam.engine.budget`).
    post_bytes : float
        Bytes per output pixel at its peak when it runs on the TDI output.
    trim : int
        Pixels at each image edge whose statistics the block changes (its replicated
        borders), left out of flat-field measurements.
    sharpens : callable(options) -> bool, or None
        Whether the block, set by its scene ``options``, can lift a modulation above 1 (an
        edge enhancement), said when a measured MTF exceeds 1.
    """

    steps: tuple = ()
    scratch_bytes: float = 0.0
    post_bytes: float = 0.0
    trim: int = 0
    sharpens: Callable | None = None


@dataclass(frozen=True)
class Use:
    """How a block takes part in a scene's pipeline (:mod:`tdicam.chain.design`).

    The golden side comes from the rest of the block's entry (:attr:`Streams.golden` on scene
    arrays: a lane's elements are the block's stream and its ``pixel`` side inputs in
    registry order, ``run`` side inputs are the step's ``inputs``); this says how a scene
    sets the block and where the gateware's side inputs come from. Two facets hold the rest:
    :attr:`memory` (a :class:`Memory`: where the block's memory lives) and :attr:`sim` (a
    :class:`SceneSim`: its steps in the scene simulator).

    Attributes
    ----------
    step : callable(ctx) -> (tdicam.blocks.steps.Step, out_bits)
        The block's parameters from the :class:`tdicam.blocks.steps.StepContext` ``ctx`` of
        the chain being planned (scene, stages, width, lines, the chain's pixel width so far
        in ``ctx.bits``).
    hw : callable(step, data) -> stage
        Its :mod:`tdicam.hdl.chain_top` stage (``data``: :class:`tdicam.blocks.steps.SceneData`,
        for side inputs built into the top such as NUC's calibration image).
    side : callable(step, data, lane) -> dict, or None
        Scene arrays of ``pixel`` side inputs that do not ride in the lane (NUC's
        coefficients).
    identity : callable(step, shape) -> dict, or None
        One lane's :class:`tdicam.blocks.steps.SceneData` fields that make the block a no-op
        when no scene data is given (NUC's identity coefficients), ``shape`` = (rows,
        width).
    merge : bool
        Takes every lane (channel) and makes one.
    elems : int
        Input elements per lane (CDS: signal and reset).
    lines : bool
        Its output frames are single lines (one per input frame, after a fill of
        ``params["stages"] - 1`` frames).
    per_frame : bool
        Acts on each exposure frame (must come before a ``lines`` block).
    reset_frames : bool
        The block takes each reset frame as a frame of its own in its stream, before its
        signal frame (and stores it), with its ``ports`` saying which is which; the chain's
        input then carries the reset frames so (:attr:`tdicam.blocks.steps.ChainPlan.reset_frames`).
    rank : int or None
        Where the block stands in ``[pipeline].blocks`` order rules and listings (per-exposure
        blocks in rising rank before the ``lines`` block); None: not listed in a scene (a
        spill variant, chosen by the plan).
    options : Options or None
        The block's ``[pipeline.<name>]`` section, when it has one.
    system : callable(step, ctx) -> list of dict, or None
        The block's figures in ``tdicam plan``'s system section (an external part's load
        before the first frame, its memory bandwidth): ``ctx`` = {``line_period_s``,
        ``ddr_bits``, ``ddr_clock_hz``, ``lanes``, ``rows``, ``width``, ``scene``}; each dict has
        ``name``, ``value``, ``unit``, ``text`` (one line) and ``ok`` (True/False, or None:
        no verdict).
    measured : callable(step, status, info) -> list of dict, or None
        The same figures as a co-simulation measured them, from the top's status outputs
        ``status`` ({port: value}) and ``info`` ({``cycles``, ``rows``, ``width``}), each
        dict with ``name``, ``value``, ``unit``, ``text`` (the run report's system section).
    source : callable(scene) -> bool, or None
        The block is the chain's *source* when this says so for a scene: the first stage,
        fed by the top's own ports (the sensor's lanes) instead of pixels, its ``hw`` a
        :class:`~tdicam.hdl.chain_top.SourceStage` (the ``lvds`` front end with a
        ``[sensor.lvds]`` section). Its ``step`` sees ``ctx.lanes``, the chain's channels.
    chain_golden : callable(step, data) -> callable(arrays, lane) -> ndarray, or None
        Its golden stage in the chain when it is not the registry's golden model on scene
        arrays (a source: what the front delivers of the sensor's frames; ``nuc_ddr``: the
        coefficient frame its load writes before the lane's frames).
    memory : Memory
        Where its memory lives: its size, its placement, its DDR spill variant, a DDR
        block's region (see :class:`Memory`).
    sim : SceneSim
        Its steps in the scene simulator and their memory and measurement figures (see
        :class:`SceneSim`).
    """

    step: Callable
    hw: Callable
    side: Callable | None = None
    identity: Callable | None = None
    merge: bool = False
    elems: int = 1
    lines: bool = False
    per_frame: bool = False
    reset_frames: bool = False
    rank: int | None = None
    options: Options | None = None
    system: Callable | None = None
    measured: Callable | None = None
    source: Callable | None = None
    chain_golden: Callable | None = None
    memory: Memory = Memory()
    sim: SceneSim = SceneSim()


@dataclass(frozen=True)
class StreamWork:
    """A stream block's benchmark input (``tdicam bench``); the registry does the rest.

    The input is ``n`` items (frames or words) of the block's :attr:`Streams.example` for frame
    ``shape``; the golden row times :meth:`Block.case_arrays` (the golden model plus the case
    form) and every simulator row runs through :func:`tdicam.cosim.run_beats`. Units are the
    elements of the block's main stream input. ``sizes`` / ``quick`` give the items per level
    kind (``fast`` = the whole input, also the golden model's; ``beat`` and ``pysim`` = the
    prefix those levels run; a key ``"<sim> <mode>"`` overrides the size for one simulator,
    e.g. ``"icarus fast"``). ``corrupt(case arrays)``, when set, alters the expected arrays
    before the comparison (to show that a wrong golden model is counted).
    """

    name: str
    block: str
    params: dict
    unit: str
    what: str
    shape: tuple
    sizes: dict
    quick: dict
    corrupt: Callable | None = None


@dataclass(frozen=True)
class Bench:
    """A block's place in ``tdicam bench``.

    ``group`` is the benchmark name that runs the block (several blocks may share one:
    ``secded`` runs the encoder and the decoder, ``ddr`` every DDR buffer); the block's own
    name runs it alone. ``work`` is its stream workload; a block that is not a video stream
    has none and is measured through its :attr:`Block.harness`, or listed with a "no
    benchmark workload" row.
    """

    group: str
    work: StreamWork | None = None


@dataclass(frozen=True)
class SynthRef:
    """One row of the synthesis reference table (``tdicam synth --reference``): the block
    at ``params``, with ``target_mhz`` the Fmax it must reach (also nextpnr's ``--freq``).
    ``sum_with``: the label of another row whose resources this one's add to in a summed row
    called ``sum_label`` (a decoder is deployed with its encoder)."""

    label: str
    params: dict = field(default_factory=dict)
    target_mhz: float = 150.0
    note: str = ""
    sum_with: str | None = None
    sum_label: str | None = None


@dataclass(frozen=True)
class Stalls:
    """The extreme-stall runs of a stream block's co-simulation suite (:class:`Suite`).

    Golden ``case`` in fast mode at each ``(idle, backpressure)`` of ``pairs`` (seed
    ``seed``); at ``(0, 0)``, and on every case of ``full_rate`` (no idle cycle, no
    backpressure), the run must take at most one cycle a beat: the input or output beats,
    whichever are more, plus the top's latency, the 2000-cycle drain window and two, plus
    ``extra_cycles(case arrays, params)`` where the block stalls its input on purpose
    (``hdr``'s frame-start divisions).
    """

    case: str
    pairs: tuple = ((0.0, 0.0), (0.0, 0.9), (0.9, 0.0))
    seed: int = 3
    full_rate: tuple = ()
    extra_cycles: Callable | None = None


@dataclass(frozen=True)
class Suite:
    """A stream block's place in the standard co-simulation suite
    (``cocotb_tests/test_streams.py``, for every block with :attr:`Streams.to_beats`): its
    golden cases per beat (cocotb drives each cycle, 30 % idle, 40 % backpressure, seed 11)
    and in fast mode (HDL-side stimulus and stalls, seed 7) on each simulator, and its
    extreme stalls. What is particular to a block stays in its own
    ``cocotb_tests/test_<module>.py``.

    Attributes
    ----------
    sims : tuple of str
        The simulators of the suite's runs (the DDR blocks: Icarus; their Verilator runs are
        particular to them).
    per_beat : "ppc", "all" or tuple of str
        ``"ppc"``: the cases at ppc 1 and 8 and the reset cases in every run, the other
        ppc 2 and 4 cases with ``TDICAM_FULL=1`` (fast mode runs them in every run;
        :func:`tdicam.cosim.testing.beat_cases`); ``"all"``: every case in every run; a
        tuple: those cases. Never a case tagged ``fast-only``, nor one in ``not_per_beat``.
    not_per_beat : tuple of str
        Cases left out of the per-beat runs (fast mode runs them).
    fast : bool
        Every case not tagged ``fast-only`` in fast mode, one run each. False: the block's
        own file streams its cases its own way (``median3``, ``tlk2711``: every case of a
        parameter set as one stream).
    fast_stalls : float
        Idle and backpressure probability of the fast-mode runs.
    full_only : callable(Case, sim, mode) -> bool, or None
        The runs that take another simulator build or minutes, co-simulated only with
        ``TDICAM_FULL=1`` (skipped otherwise, saying so).
    stalls : Stalls or None
        The extreme-stall and full-rate runs (None: none, or the block's own file has them).
    """

    sims: tuple = ("icarus", "verilator")
    per_beat: Any = "ppc"
    not_per_beat: tuple = ()
    fast: bool = True
    fast_stalls: float = 0.25
    full_only: Callable | None = None
    stalls: Stalls | None = None


@dataclass(frozen=True)
class Streams:
    """How a block's arrays become its stream and back (:attr:`Block.streams`): the stream
    adapters between scene arrays, case arrays and :class:`~tdicam.beats.Beats`, the golden
    model on scene arrays, a typical input, and what ``tdicam export`` and the testbenches
    may assume of the stream. Read by the co-simulation (:func:`tdicam.cosim.run_case`,
    ``cocotb_tests/test_streams.py``), ``tdicam export``, ``tdicam bench`` and the chain's
    golden model (:func:`tdicam.chain.design.golden`). The defaults: not a video stream
    (:attr:`Block.harness` names what verifies it).

    Attributes
    ----------
    to_beats : callable(case arrays, params) -> (stim Beats, expected Beats) or None
        Stream blocks: the stimulus (pixels, run-time settings in ``ctrl``, resets) and the
        expected output of case arrays. ``None``: not a video stream (co-simulated by its
        own cocotb test).
    stream : str or None
        Key of the main stream input in the scene arrays (e.g. ``"signal"``, ``"x"``).
    side_inputs : tuple of SideInput
        The block's other inputs, by scene-array key (see :class:`SideInput`).
    golden : callable(scene arrays, params) -> dict or None
        The golden model on scene arrays (frames ``(..., rows, cols)``, side inputs per
        :attr:`side_inputs`): ``{"out": ndarray}`` with the output frames, leading axes
        kept (``tdi``: one output line per frame).
    to_case : callable(scene arrays, params) -> case arrays, or None
        Scene arrays -> the case form :attr:`to_beats` reads, expected outputs included.
        ``None``: the case form is the scene arrays with the frames flattened to
        ``(n, rows, cols)`` plus :attr:`golden`'s output (see :meth:`Block.case_arrays`).
    fit : callable(scene arrays) -> dict, or None
        Parameters a scene's arrays fix (e.g. ``width`` from the frames' last axis);
        :meth:`Block.scene_params` lays them under the given ones.
    unstream : callable(out Beats, scene arrays, params) -> dict, or None
        Output beats -> ``{"out": ndarray}`` shaped like :attr:`golden`'s output. ``None``:
        one output element per input pixel, reshaped like the main stream (see
        :meth:`Block.from_beats`).
    example : callable(rng, n, shape, params) -> scene arrays, or None
        ``n`` frames (or words) of typical random input for benchmarks: ``shape`` is the
        frame shape ``(rows, cols)`` the caller wants (blocks whose parameters fix it
        ignore it).
    frame_beats : callable, optional
        ``frame_beats(params)``: input beats of one frame, the least a golden case streams
        (``tdicam export`` refuses parameters whose one frame is over its beat limit before
        generating any case, or exports :attr:`streamed_case`; None: unknown).
    streamed_case : callable(params) -> tdicam.beats.BeatStream, or None
        The case ``tdicam export`` writes, piece by piece, when no golden case at
        ``params`` fits its beat limit (one frame over it, say: the cases would not fit in
        memory); None: such parameters are refused.
    small : tuple or None
        ``(frame shape, parameters)`` of a small :attr:`example` input (a few frames run in
        milliseconds) for quick checks of the block's adapters; every stream block has one.
    reset_clears_state : bool
        A testbench reset returns the whole design to its power-up state, so golden cases
        can run back to back in one simulation with a reset between them (``tdicam
        export``). False when a simulation model keeps contents across reset (nand_store's
        part).
    """

    to_beats: Callable | None = None
    stream: str | None = None
    side_inputs: tuple = ()
    golden: Callable | None = None
    to_case: Callable | None = None
    fit: Callable | None = None
    unstream: Callable | None = None
    example: Callable | None = None
    frame_beats: Callable | None = None
    streamed_case: Callable | None = None
    small: tuple | None = None
    reset_clears_state: bool = True
