"""The co-simulation's device under test: a pipeline top (:class:`tdicam.hdl.chain_top.Pipeline`)
with the simulation models of its external parts (:class:`Device`: the reset frame's DDR,
the coefficients' NAND, the output links' frame buffer's DDR) wired to its pins."""

from dataclasses import dataclass, field

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import Out

from tdicam.hdl.chain_top import FRAME_BUFFER_STAGE, Pipeline, core_name
from tdicam.hdl.interfaces.mig import MIG_PORT_NAMES

__all__ = ["Device", "Board", "mig_device"]


@dataclass
class Device:
    """The simulation model of an external part on a stage's pins (see :class:`Board`).

    Attributes
    ----------
    model : wiring.Component
        The part's model (e.g. the DDR3 controller and memory, the NAND part).
    pins : dict of str -> str
        The stage's pin (its top-level port name without stage and lane) -> the model's
        port it connects to (the pin's direction decides which drives which).
    status : dict of str -> str
        The model's ``Out`` ports exposed on the board as ``<stage>_<name>[_<lane>]``
        (the name is the key; the model's port the value).
    """

    model: object
    pins: dict
    status: dict = field(default_factory=dict)


def mig_device(words, **stalls):
    """The simulation MIG model (:class:`~tdicam.hdl.simmodels.mig_model.MigModel`) of
    ``words`` 256-bit words (at least 1; ``stalls`` its stall pattern and latency, default
    its own) as a :class:`Device` on a MIG user interface: every pin of
    :data:`~tdicam.hdl.interfaces.mig.MIG_PORT_NAMES` to the model's port of that name, the
    model's ``error``, ``writes``, ``reads`` and ``stalls`` as the status ``ddr_error``,
    ``ddr_writes``, ``ddr_reads``, ``ddr_stalls``."""
    from tdicam.hdl.simmodels.mig_model import MigModel
    return Device(MigModel(depth_words=max(1, words), count_stalls=True, **stalls),
                  {n: n for n in MIG_PORT_NAMES},
                  {"ddr_error": "error", "ddr_writes": "writes", "ddr_reads": "reads",
                   "ddr_stalls": "stalls"})


class Board(wiring.Component):
    """A :class:`Pipeline` top with the simulation models of its external parts beside it:
    the co-simulation's device under test. The top keeps its pins (the synthesized design's
    ports); the board wires each stage's :class:`Device` to them and exposes every other
    port of the top unchanged, plus the models' status outputs.

    Parameters
    ----------
    top : :class:`Pipeline`
    """

    def __init__(self, top):
        from tdicam.model.ddr import ADDR_PER_WORD
        self._top = top
        self._devices = list(top.devices()) + [   # a buffer without a DDR block: its own
            (FRAME_BUFFER_STAGE, j, mig_device(fb.layout.end_addr(fb.rows) // ADDR_PER_WORD))
            for j, fb in top.own_frame_buffers]
        used, extra = set(), {}
        for st, k, dev in self._devices:
            used.update(Pipeline._status(st, pin, k) for pin in dev.pins)
            for name, port in dev.status.items():
                extra[Pipeline._status(st, name, k)] = Out(
                    dev.model.signature.members[port].shape)
        members = {n: mem for n, mem in top.signature.members.items() if n not in used}
        members.update(extra)
        super().__init__(members)

    core = property(lambda self: self._top, doc="The pipeline top.")
    tap_shapes = property(lambda self: self._top.tap_shapes)
    startup_bound = property(lambda self: self._top.startup_bound)
    latency = property(lambda self: self._top.latency)
    links = property(lambda self: self._top.links)

    def elaborate(self, platform):
        m = Module()
        m.submodules.top = top = self._top
        names = set()
        for st, k, dev in self._devices:
            name = f"{core_name(st, k, 2)}_device"
            name += f"{sum(n.startswith(name) for n in names)}" if name in names else ""
            names.add(name)
            m.submodules[name] = dev.model
            for pin, port in dev.pins.items():
                a = getattr(top, Pipeline._status(st, pin, k))
                b = getattr(dev.model, port)
                if top.signature.members[Pipeline._status(st, pin, k)].flow == wiring.Out:
                    m.d.comb += b.eq(a)
                else:
                    m.d.comb += a.eq(b)
            for name, port in dev.status.items():
                m.d.comb += getattr(self, Pipeline._status(st, name, k)).eq(
                    getattr(dev.model, port))
        for name, mem in self.signature.members.items():
            if name in ("i_stream", "o_stream") or not hasattr(top, name) \
                    or name not in top.signature.members:
                continue
            if mem.flow == wiring.In:
                m.d.comb += getattr(top, name).eq(getattr(self, name))
            else:
                m.d.comb += getattr(self, name).eq(getattr(top, name))
        if "i_stream" in self.signature.members:       # (none after a source stage)
            wiring.connect(m, wiring.flipped(self.i_stream), top.i_stream)
        if "o_stream" in self.signature.members:       # (none with the output links)
            wiring.connect(m, top.o_stream, wiring.flipped(self.o_stream))
        return m
