"""Registry of gateware blocks: everything the tools know about a block, in one entry.

Every module in this package registers one block with ``BLOCK = Block(...)`` and is
discovered automatically. A :class:`Block` ties together, under one name, the Amaranth
component (``hdl/<name>.py``), the golden model (``model/<name>.py``), the golden cases
(``golden/<name>/``), the co-simulation (``cocotb_tests/test_<name>.py``) and how arrays of a
scene (frame stacks and the block's side inputs) become the block's stream and back.

Two array forms
---------------
*Scene arrays* are what a camera model hands a block: named numpy arrays, frames as
``(..., rows, cols)`` stacks (any leading axes are frames), side inputs beside them
(:attr:`Streams.side_inputs`). :attr:`Streams.golden` runs the golden model on them.

*Case arrays* are what a golden case stores (``golden/<name>/<case>.npz``): the inputs in
whatever form the block's stream needs (e.g. ``tdi`` stores beat arrays), the expected
outputs, and optional reset marks. :attr:`Streams.to_beats` turns them into the stimulus and
expected :class:`~tdicam.beats.Beats`. :meth:`Block.case_arrays` makes case arrays from
scene arrays, so one co-simulation path (:func:`tdicam.cosim.run_case`) serves golden cases
and scenes alike; :meth:`Block.from_beats` turns the output beats back into scene arrays.

In a scene's pipeline (:class:`Use`) an entry also says how a scene sets the block (its one
scene-to-parameters function, its ``[pipeline.<name>]`` options), how the gateware chain builds
it, where its memory lives (:attr:`Use.memory`, a :class:`Memory`), and what it does in the
scene simulator (:attr:`Use.sim`, a :class:`SceneSim`: its steps, which frame stacks are its
scene arrays, its channels, resets and side inputs, the crops kept for RTL co-simulation; the
engine's effect rows for the blocks are generated from them, :mod:`tdicam.engine.block_rows`).

The record in facets
--------------------
A :class:`Block` is read in facets (:mod:`tdicam.blocks.facets`), each a frozen dataclass
documented where it is defined: the block's core on :class:`Block` itself (name, summary,
parameters (:class:`Param`), top, cases (:class:`Case`), check, model version, the tables'
order); :class:`Streams` (:attr:`Block.streams`: the stream adapters between the two array
forms, the golden model on scene arrays, the main input and the side inputs
(:class:`SideInput`), a small example, what ``tdicam export`` may assume); :class:`Use`
(:attr:`Block.pipeline`: its place in a scene's chain, with its :class:`Options`, its
:class:`Memory` and its :class:`SceneSim`); :class:`Bench` (``tdicam bench``), :class:`Suite`
(the standard co-simulation suite) and :class:`SynthRef` (``tdicam synth --reference``).
An entry file (``tdicam/blocks/<b>.py``) keeps its parts in the sections of
:data:`ENTRY_SECTIONS`, in that order.

Layer: above :mod:`tdicam.hdl` and :mod:`tdicam.model`. May import them, :mod:`tdicam.beats`
and the leaves; never a simulator driver, a hardware tool, the camera, a service or a command.
"""

import importlib
import pkgutil
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from tdicam.beats import PPC_CHOICES
from tdicam.blocks.facets import (Bench, Case, KeyDoc, Memory, Options, Param, SceneSim,
                                   SideInput, Stalls, StreamWork, Streams, Suite, SynthRef, Use,
                                   _flag)
from tdicam.errors import TdicamError
from tdicam.model.cds import pixel_dtype

__all__ = ["Param", "Case", "SideInput", "KeyDoc", "Options", "Memory", "SceneSim", "Use",
           "StreamWork", "Bench", "SynthRef", "Stalls", "Suite", "Streams", "Block", "get",
           "names", "all_blocks", "in_order", "frame_stack", "scene_blocks", "PPC_PARAM",
           "check_width", "ENTRY_SECTIONS"]

#: The sections of every block entry file (``tdicam/blocks/<b>.py``), in their order, each
#: opened by a ``# ---- <name>`` line; an entry leaves out those it has no part for
#: (``tests/test_block_entries.py`` checks the order and what each holds).
ENTRY_SECTIONS = {
    "top": "the Verilog top (the component inside AxisTop) and the parameters' check",
    "cases": "the golden cases and the stream adapters they use (golden, beats, example: "
             "the Streams facet's functions)",
    "scene": "the block's scene options ([pipeline.<b>] keys, their KeyDocs)",
    "chain": "its place in a chain (the step, its hardware, its system rows)",
    "simulator": "its steps in the scene simulator (SIM = SceneSim((Sim(...),), ...))",
    "entry": "BLOCK = Block(...), the record in facets (Streams, Use with Memory and SceneSim, "
             "Bench, Suite, SynthRef)",
}



@dataclass(frozen=True)
class Block:
    """A registered gateware block: the contract the tools and the pipeline build on.

    Attributes
    ----------
    name : str
        One name everywhere: ``hdl/<name>.py``, ``model/<name>.py``,
        ``cocotb_tests/test_<name>.py``, ``golden/<name>/`` (the modules' stem is
        :attr:`module` where the block says so; tests/test_block_names.py checks it).
    module : str or None
        The stem of the block's gateware, golden-model and co-simulation modules
        (``hdl/<module>.py``, ``model/<module>.py``, ``cocotb_tests/test_<module>.py``) when
        it is not the block's name: the two halves of the 64/72 ECC, ``secded_enc`` and
        ``secded_dec``, share ``ecc``. None: the block's name. Its golden vectors are
        ``golden/<name>/`` always.
    summary : str
        One line for ``tdicam verilog`` and the docs.
    params : tuple of Param
        Elaboration parameters (the gateware's, with the golden model's names and units).
    top : callable(params as keywords) -> wiring.Component
        The Verilog top: :class:`~tdicam.hdl.interfaces.axis.AxisTop` (AXI4-Stream names) for stream
        blocks, or a plain-port component.
    cases : callable() -> list of Case
        The golden cases (``tdicam golden``).
    check : callable(params) or None
        Cross-parameter checks on a resolved dict, raising :class:`TdicamError` before
        elaboration.
    model_version : str
        Bump when the golden model's definition changes (recorded in the manifest).
    streams : Streams
        How case and scene arrays become the block's stream and back, and what a
        testbench may assume of it (see :class:`Streams`; the defaults: not a video
        stream).
    ecp5_top : callable(params as keywords) -> wiring.Component, or None
        The top ``tdicam synth`` places on the ECP5 when it differs from :attr:`top`
        (vendor primitives the generic description cannot reach: ``tdi``'s DP16KD banks with
        their output register); same ports and behaviour — except for a DDR block, whose
        :attr:`top` holds the simulation MIG model and whose synthesis top is the core with
        the MIG user interface at its ports (``cds_ddr``). ``None``: :attr:`top`.
    harness : str or None
        A block that is not a video stream (:attr:`Streams.to_beats` None) names the self-checking
        harness that verifies it, a name the tools above the registry know it by: ``"link"``,
        the LVDS link testbench (``lvds``), is how ``tdicam export`` writes the block and
        ``tdicam bench`` measures it (:data:`tdicam.export.harness.HARNESSES`,
        :data:`tdicam.bench.suite.HARNESS_RUNNERS`). None: the stream testbench.
    pipeline : Use or None
        Its place in a scene's pipeline (see :class:`Use`); None: a scene never lists it.
    order : int
        Place in the tools' tables (benchmarks, synthesis reference); ties by name.
    bench : Bench or None
        How ``tdicam bench`` measures the block (None: not benchmarked).
    suite : Suite
        A stream block's runs in the standard co-simulation suite (the defaults unless its
        entry says otherwise).
    synth : tuple of SynthRef
        The block's rows of the synthesis reference table.
    """

    name: str
    summary: str
    params: tuple
    top: Callable
    cases: Callable
    check: Callable | None = None
    model_version: str = "1"
    streams: Streams = Streams()
    harness: str | None = None
    pipeline: Use | None = None
    ecp5_top: Callable | None = None
    order: int = 1000
    bench: Bench | None = None
    suite: Suite = Suite()
    synth: tuple = ()
    module: str | None = None

    def resolve(self, given=None):
        """Full, checked parameter dict from ``given`` (unknown names are errors)."""
        given = dict(given or {})
        known = {p.name: p for p in self.params}
        for key in given:
            if key not in known:
                valid = ", ".join(_flag(k) for k in known) or "none"
                raise TdicamError(f"block {self.name} has no parameter {_flag(key)}; "
                                  f"valid: {valid}")
        out = {}
        for p in self.params:
            out[p.name] = p.check(given[p.name]) if p.name in given else p.default
        if self.check is not None:
            self.check(out)
        return out

    def recorded(self, params):
        """Resolved ``params`` as a golden case records them: without the
        :attr:`Param.implicit_default` parameters that hold their default."""
        drop = {p.name for p in self.params
                if p.implicit_default and params.get(p.name) == p.default}
        return {k: v for k, v in params.items() if k not in drop}

    def with_defaults(self, params):
        """Recorded ``params`` (see :meth:`recorded`) with every parameter they leave out
        at its default."""
        return {**{p.name: p.default for p in self.params if p.name not in params},
                **params}

    def describe(self):
        """``tdicam verilog BLOCK --help``: the summary and every parameter."""
        lines = [f"{self.name}: {self.summary}", "parameters:"]
        lines += [f"  {p.describe()}" for p in self.params] or ["  (none)"]
        return "\n".join(lines)

    def build(self, params=None, *, ecp5=False):
        """Elaborable Verilog top for checked ``params`` (``ecp5``: :attr:`ecp5_top` when
        the block has one)."""
        top = self.ecp5_top if ecp5 and self.ecp5_top is not None else self.top
        return top(**self.resolve(params))

    def scene_params(self, arrays, params=None):
        """Resolved parameters for scene ``arrays``: ``params`` over what :attr:`Streams.fit`
        derives from the arrays' shapes."""
        fitted = self.streams.fit(self.inputs(arrays)) if self.streams.fit is not None else {}
        return self.resolve({**fitted, **dict(params or {})})

    def inputs(self, arrays):
        """Scene arrays with every side input present (defaults filled in) and ``pixel``
        side inputs broadcast to the stream's shape, or a :class:`TdicamError` naming the
        missing one."""
        st = self.streams
        if not isinstance(arrays, Mapping):
            raise TdicamError(f"block {self.name}: arrays must be a dict of arrays (its "
                              f"stream input {st.stream!r}), got {type(arrays).__name__}")
        if st.stream not in arrays:
            raise TdicamError(f"block {self.name} needs its stream input {st.stream!r}")
        out = dict(arrays)
        main = np.asarray(out[st.stream])
        shaped = st.fit is not None or any(callable(s.default) for s in st.side_inputs)
        if shaped and main.ndim < 2:        # what fits the parameters reads rows and cols
            raise TdicamError(f"block {self.name}: input {st.stream!r} must be frames "
                              f"(..., rows, cols), got shape {main.shape}")
        for side in st.side_inputs:
            if side.name not in out:
                if side.default is None:
                    raise TdicamError(f"block {self.name} needs input {side.name!r} "
                                      f"({side.what})")
                out[side.name] = side.default(main) if callable(side.default) \
                    else side.default
            if side.per == "pixel" and np.shape(out[side.name]) != main.shape:
                try:
                    out[side.name] = np.broadcast_to(out[side.name], main.shape)
                except ValueError:
                    raise TdicamError(
                        f"block {self.name}: input {side.name!r} has shape "
                        f"{np.shape(out[side.name])}, the stream {st.stream!r} "
                        f"{main.shape}") from None
        return out

    def run_golden(self, arrays, params):
        """:attr:`Streams.golden` on scene arrays (side-input defaults filled in)."""
        if self.streams.golden is None:
            raise TdicamError(f"block {self.name} has no golden function on scene arrays")
        return self.streams.golden(self.inputs(arrays), params)

    def case_arrays(self, arrays, params):
        """Case arrays (inputs + expected outputs, what :attr:`Streams.to_beats` reads) of scene
        ``arrays`` for resolved ``params``: a one-line error for a block without a golden
        function, an empty stream or one that is not integer codes."""
        if self.streams.to_case is None and self.streams.golden is None:
            raise TdicamError(f"block {self.name} has no golden function on scene arrays")
        arrays = self.inputs(arrays)
        main = np.asarray(arrays[self.streams.stream])
        if main.size == 0 or not np.issubdtype(main.dtype, np.integer):
            raise TdicamError(f"block {self.name}: {self.streams.stream} must be a non-empty "
                              f"integer array of pixel codes, got shape {main.shape}, dtype "
                              f"{main.dtype}")
        if self.streams.to_case is not None:
            return self.streams.to_case(arrays, params)
        flat = {}
        for key in self._keys():
            a = np.asarray(arrays[key])
            per = "pixel" if key == self.streams.stream else self._per(key)
            flat[key] = _flat_frames(a) if per == "pixel" and a.ndim >= 2 else \
                (a.ravel() if per == "frame" else a)
        return {**flat, **self.streams.golden(flat, params)}

    def from_beats(self, out, arrays, params):
        """Output beats of a run on scene ``arrays`` -> ``{"out": ndarray}``."""
        if self.streams.unstream is not None:
            return self.streams.unstream(out, arrays, params)
        bits = params.get("out_bits") or params["pixel_bits"]
        return {"out": out.data.reshape(np.shape(arrays[self.streams.stream])).astype(
            pixel_dtype(bits))}

    def golden_model(self, arrays: dict, **params) -> dict:
        """The block's bit-exact golden model (``model/<name>.py``) on scene arrays, with
        its parameters fitted (:attr:`Streams.golden` is the raw function it calls).

        Parameters
        ----------
        arrays : dict of str to ndarray
            The stream input (key :attr:`Streams.stream`, frames ``(..., rows, cols)``) and any
            side inputs (:attr:`Streams.side_inputs`; defaults filled in).
        **params
            Block parameters; the ones the arrays fix (e.g. ``width``) are fitted.

        Returns
        -------
        dict of str to ndarray
            ``{"out": ...}``: the output frames, leading axes kept (``tdi``: one output
            line per frame).

        Raises
        ------
        TdicamError
            A missing input, a bad shape or parameter (one line).
        """
        return self.run_golden(arrays, self.scene_params(arrays, params))

    def _per(self, key):
        return next((s.per for s in self.streams.side_inputs if s.name == key), None)

    def _keys(self):
        return (self.streams.stream, *(s.name for s in self.streams.side_inputs))


#: The pixels-per-clock parameter of the stream blocks that gained it after their golden
#: vectors existed (``cds``, ``nuc``, ``hdr``): not recorded at its default.
PPC_PARAM = Param("ppc", 1, "pixels per clock", choices=PPC_CHOICES, implicit_default=True)


def check_width(width, ppc):
    """``width`` if it is a multiple of ``ppc``, else the one-line :class:`TdicamError`
    ``"--width W is not a multiple of --ppc P"``."""
    if width % ppc:
        raise TdicamError(f"--width {width} is not a multiple of --ppc {ppc}")
    return width


def frame_stack(a):
    """``a`` as ``(n, rows, cols)``: every leading axis is a frame axis."""
    return _flat_frames(a)


def _flat_frames(a):
    a = np.asarray(a)
    if a.ndim < 2:
        raise TdicamError(f"frames must have at least 2 axes (rows, cols), got shape {a.shape}")
    return a.reshape((-1,) + a.shape[-2:])


_REGISTRY = None


def _load():
    global _REGISTRY
    if _REGISTRY is None:
        reg = {}
        for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
            if info.name.startswith("_"):
                continue
            mod = importlib.import_module(f"{__name__}.{info.name}")
            blk = getattr(mod, "BLOCK", None)
            if blk is not None:
                reg[blk.name] = blk
        _REGISTRY = reg
    return _REGISTRY


def names():
    """Names of the registered blocks, sorted."""
    return sorted(_load())


def all_blocks():
    """The registered :class:`Block` entries, by name."""
    return [_load()[n] for n in names()]


def in_order():
    """The registered :class:`Block` entries in table order (:attr:`Block.order`, then name)."""
    return sorted(all_blocks(), key=lambda b: (b.order, b.name))


def get(name):
    """The block called ``name``, or a :class:`TdicamError` listing the valid names."""
    reg = _load()
    if not isinstance(name, str) or name not in reg:
        raise TdicamError(f"unknown block {name!r}; valid: {', '.join(sorted(reg))}")
    return reg[name]


def scene_blocks():
    """The blocks a scene may list in ``[pipeline].blocks``, in rank order."""
    listed = [b for b in all_blocks() if b.pipeline is not None and b.pipeline.rank is not None]
    return sorted(listed, key=lambda b: b.pipeline.rank)
