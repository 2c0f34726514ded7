"""One gateware top for a camera pipeline: the blocks' stream components chained in order.

The top knows no block by name. It is built from a list of *stage* objects (see
:class:`LaneStage` and :class:`MergeStage`), each of which makes the block's component
and wires its side inputs; the table that turns a scene's ``[pipeline]`` into stages lives
in :mod:`tdicam.chain.design`. The streams between the stages and what the top does with
them (fork, join, re-framing, register slices, width converters) are
:mod:`tdicam.hdl.chain_links`; the on-chip calibration ROM is :mod:`tdicam.hdl.calib_rom`;
the top with its external parts' simulation models, :mod:`tdicam.hdl.chain_board`.
"""

from dataclasses import dataclass, field, replace
from types import SimpleNamespace
from typing import Callable

from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError
from tdicam.hdl.chain_links import (Link, eager_fork, fork, frame_group, join, narrow,
                                    prepend, register_slice)
from tdicam.hdl.interfaces.mig import MIG_PORT_NAMES, connect_mig, mig_user_ports
from tdicam.hdl.output_links import FRAME_BUFFER, buffer_port, lane_port
from tdicam.hdl.interfaces.stream import Narrower, channels_shape, element_bits, pixel_signature

__all__ = ["LaneStage", "MergeStage", "SourceStage", "Pipeline", "core_name", "SHARED_DDR",
           "FRAME_BUFFER_STAGE"]


@dataclass
class LaneStage:
    """A block that runs on every channel lane on its own (one component per lane).

    Attributes
    ----------
    name : str
        Stage name: prefixes its top-level ports (``<name>_<port>``) and taps.
    make : callable(lane) -> wiring.Component
        The block's stream component (``i_stream``/``o_stream``) for lane ``lane``.
    elems : int
        Input elements the block takes from each lane beat (e.g. signal and reset).
    ports : tuple of str
        Plain ``In`` ports of the component driven from one top-level port shared by the
        lanes (run-time settings).
    side : callable(m, lane) -> Link or None
        A stream joined after the lane's elements on every beat (NUC coefficients).
    group : str or None
        A top-level port (of this stage) giving the number of incoming frames grouped into
        one frame before the block (see :func:`frame_group`).
    out_slice : bool
        The block's output is not registered (e.g. read straight from a memory), or the
        next block's ready would run on through its handshake (a DDR block's read launch): a
        :func:`register_slice` follows it when another stage takes its output.
    pins : tuple of str
        Ports of the component (either direction) that are each lane's own top-level ports
        ``<name>_<port>`` (lane 0) and ``<name>_<port>_<lane>``: an external part's
        interface (the DDR controller's MIG user interface).
    io : dict of str -> wiring member
        Top-level ports of each lane made for ``side`` (named as ``pins``): ``side`` is
        then called as ``side(m, lane, ports)`` with ``ports`` = {name: the lane's top-level
        signal} (the NAND bus and the calibration status of NUC's coefficient store).
    ready : str or None
        An ``Out`` port of each lane (a status of the component or of ``io``) that must be
        high on every lane before the top accepts its first input beat: the stage's
        start-up (the calibration load). The top holds its input until then.
    device : callable(lane) -> :class:`Device`, or None
        The simulation model of the external part on the lane's pins, placed beside the
        top by :class:`Board` (co-simulation only; the top itself has the pins).
    startup : int
        Cycles after reset the stage may hold the input at most (bounds a simulation).
    waits : bool
        The block's input ``ready`` waits for ``valid`` (a DDR block starts its reads on a
        presented frame start): the lanes are forked to it by :func:`eager_fork`.
    load : str or None
        ``side`` is not joined beat by beat but sent before the lane's frames as one frame
        of ``load_rows`` lines (:func:`~tdicam.hdl.chain_links.prepend`: NUC's coefficient
        frame, stored in DDR); the component's ``In`` port ``load`` is 1 on it, 0 on the
        lane's frames, and the ``ready`` port (of ``io``) says the frame was taken.
    load_rows : int
        Lines of the ``load`` frame.

    A stage whose ``pins`` are a MIG user interface (:data:`MIG_PORT_NAMES`) shares the
    lane's DDR interface with every other such stage of the lane: the top puts them behind
    one :class:`~tdicam.hdl.ddr_arbiter.DdrArbiter` whose controller side is the lane's
    ``ddr_app_*`` ports (``ddr_app_*_<lane>``), and :meth:`Pipeline.devices` gives one MIG
    model there (the deepest of the stages' own, named ``ddr``). A stage alone on its lane's
    DDR keeps its own ``<stage>_app_*`` pins.
    """

    name: str
    make: Callable
    elems: int = 1
    ports: tuple = ()
    side: Callable | None = None
    group: str | None = None
    out_slice: bool = False
    pins: tuple = ()
    io: dict = field(default_factory=dict)
    ready: str | None = None
    device: Callable | None = None
    startup: int = 0
    waits: bool = False
    load: str | None = None
    load_rows: int = 0
    merge: bool = field(default=False, init=False)
    source: bool = field(default=False, init=False)


@dataclass
class MergeStage(LaneStage):
    """A block that takes the elements of every lane in one beat (the HDR merge)."""

    merge: bool = field(default=True, init=False)


@dataclass
class SourceStage(LaneStage):
    """The chain's first block when it makes the pixel stream itself (the sensor's front
    end, :class:`~tdicam.hdl.lvds_front.LvdsFront`): no ``i_stream``; every ``In`` port
    (listed in ``ports``) is a top port ``<name>_<port>``; its ``o_stream`` carries every
    channel lane's elements, pixel-major, as the top's ``i_stream`` would. The top then has
    no ``i_stream``.

    ``carries``: ``Out`` ports of the component valid with each output beat that travel with
    the beat (:attr:`Link.user`) and drive the ``In`` port of the same name of every later
    stage's component, instead of a top port (the front's ``frame_kind`` -> the CDS stage's
    ``frame_kind``, which says which frame is the reset frame to keep).

    ``gate``: an ``In`` port of the component the top drives (instead of a top port) with
    its ``released`` signal: high once every holding stage is ready (its start-up done, e.g.
    the calibration loaded), always high without one. A source with no backpressure (the
    sensor) then drops whole frames until the top can take them, instead of filling its
    buffer."""

    carries: tuple = ()
    gate: str | None = None
    source: bool = field(default=True, init=False)


#: The name (``.name``) that prefixes a lane's shared DDR interface at the top (``ddr_app_*``)
#: and its MIG model's status in a :class:`~tdicam.hdl.chain_board.Board` (``ddr_writes``).
SHARED_DDR = SimpleNamespace(name="ddr")

#: The same for the output links' frame buffer (``frame_buffer_app_*``, ``frame_buffer_ddr_writes``).
FRAME_BUFFER_STAGE = SimpleNamespace(name=FRAME_BUFFER)


class Pipeline(wiring.Component):
    """The camera's blocks chained in order, their side inputs wired, taps exposed.

    Parameters
    ----------
    stages : list of :class:`LaneStage` / :class:`MergeStage`
        In stream order.
    in_bits : int
        Width of each input element.
    lanes : int
        Channel lanes of the input (2 with HDR's high- and low-gain channels).
    lane_elems : int
        Input elements per lane (2 when the first stage is CDS: signal, reset).
    taps : bool
        Expose every stage's output stream as ports (simulation).
    ppc : int
        Pixels per beat (1, 2, 4, 8) of the input stream (pixel-major, element 0 the
        leftmost). A stage's component may take fewer (its ``ppc``, 1 without one: a block
        after TDI, whose output is ``stages`` times slower than its input): a
        :func:`narrow` before it converts the beats, its FIFO one row (``width / ppc``
        beats) deep. A stage never takes more pixels a beat than the one before gives.
    width : int or None
        Pixels a row; needed when a stage takes fewer pixels a beat than its input.
    bram : {"generic", "ecp5"}
        The width converters' FIFO memories (:class:`Narrower`): ``"ecp5"`` in the ECP5
        synthesis top.
    links : :class:`~tdicam.blocks.steps.LinkPlan` or None
        The top ends in the camera's output links instead of ``o_stream``: the last
        stage's output into an :class:`~tdicam.hdl.output_links.OutputLinks` (the frame
        selector, one image of ``image_rows`` rows in ``keep``, and the TLK2711 framers in
        the link clock's domain, ports ``link_clk``/``link_rst``). With
        ``links.buffer_rows``, a DDR frame buffer before the links on each lane's DDR
        interface (the lanes with a DDR block; one of its own, ``frame_buffer_app_*``,
        when none has), behind the lane's :class:`~tdicam.hdl.ddr_arbiter.DdrArbiter`
        as its last port, line y of an image on lane ``y mod lanes``.

    Attributes
    ----------
    i_stream : In(pixel stream)
        ``ppc * lanes * lane_elems`` elements of ``in_bits``, pixel-major: pixel 0's lane
        0 elements first, then its lane 1 elements, then pixel 1's.
    o_stream : Out(pixel stream)
        The last stage's output (not with ``links``).
    link{L}_txd, link{L}_tklsb, link{L}_tkmsb : Out(16), Out(1), Out(1)
        With ``links``: link ``L``'s TLK2711 parallel port, one word a link clock
        (:func:`~tdicam.hdl.tlk2711.pin_names`).
    links_frame : Out(1)
        With ``links``: :data:`~tdicam.hdl.output_links.LINKS_FRAME`.
    <stage>_<port> : In
        The stages' run-time settings (e.g. TDI's stages and direction, the median's frame
        height), presented to every lane's component.
    <stage>_<port> : Out
        The stages' status outputs (lane 0's, and ``<stage>_<port>_<lane>`` for others).
    tap<k>_<stage>[_<lane>]_{valid,ready,first,last,data} : Out (with ``taps``)
        Stage ``k``'s output stream, seen where it is handed on.

    Notes
    -----
    Every block keeps its own handshake; the top adds no register on the pixel path but a
    :func:`register_slice` after a stage whose ``out_slice`` says its output is not
    registered, when another stage follows: forks and joins are combinational, a beat moves
    through a fork when every branch takes it.

    Start-up: the top holds its input until every holding stage (``ready``) is ready, e.g.
    every channel's NUC calibration loaded from NAND (``startup_cycles`` counts the held
    cycles). A source stage cannot be held (the sensor sets the pace): its ``gate`` port
    gets the same signal, and the sensor's front end drops whole frames until then and
    counts them (``lvds_frames_dropped``), releasing from the first whole frame (with reset
    frames: the first reset frame) after it. So the sensor may start at power-up, before
    the calibration load: it need not wait for ``nuc_calib_loaded``. :attr:`latency` is the sum of the blocks'
    ``latency`` figures, each as its block defines it (a 2-D block's counts from the input
    pixel its output needs last), plus 1 per register slice and 5 per width converter
    (:func:`narrow`); None when one varies (DDR).
    """

    def __init__(self, stages, *, in_bits, lanes=1, lane_elems=1, taps=False, ppc=1,
                 width=None, bram="generic", links=None):
        self._stages = list(stages)
        self._in_bits, self._lanes, self._lane_elems = in_bits, lanes, lane_elems
        self._taps, self._ppc, self._width, self._bram = taps, ppc, width, bram
        self._cores = self._plan()
        self._links = links
        self._fb_lanes = self._frame_buffer_lanes()
        self._shared = self._shared_ddr()
        self._source = bool(self._stages) and self._stages[0].source
        carried = set(self._stages[0].carries) if self._source else set()
        if self._source and self._stages[0].gate is not None:
            carried.add(self._stages[0].gate)
        members = {} if self._source else {"i_stream": In(pixel_signature(channels_shape(
            in_bits, ppc * lanes * lane_elems)))}
        if links is None:
            members["o_stream"] = Out(pixel_signature(channels_shape(*self._out_shape)))
        else:
            from tdicam.hdl.output_links import OutputLinks
            self._out_links = OutputLinks(links, bits=self._out_shape[0],
                                          count=self._out_shape[1], width=width,
                                          buffers=max(1, self._fb_lanes))
            # (elaborated with the top; a top made for its ports only must not warn of it)
            self._out_links._MustUse__silence = True
            fb_pins = {buffer_port(n, j) for j in self._shared_buffers() for n in MIG_PORT_NAMES}
            members.update({n: mem for n, mem in self._out_links.signature.members.items()
                            if n != "i_stream" and n not in fb_pins})
        for st, cores in zip(self._stages, self._cores):
            for pname, member in cores[0].signature.members.items():
                if pname in ("i_stream", "o_stream") or pname in carried or pname == st.load:
                    continue
                if pname in st.pins:
                    for k in range(len(cores)):
                        if not self._shares(st, pname, k):
                            members[self._status(st, pname, k)] = member.flow(member.shape)
                elif member.flow == wiring.In:
                    if pname not in st.ports:
                        raise TdicamError(f"pipeline: block {st.name}'s input port {pname} "
                                          f"has no source")
                    members[f"{st.name}_{pname}"] = In(member.shape)
                else:
                    for k in range(len(cores)):
                        members[self._status(st, pname, k)] = Out(member.shape)
            for pname, member in st.io.items():
                for k in range(len(cores)):
                    members[self._status(st, pname, k)] = member
            if st.group is not None and f"{st.name}_{st.group}" not in members:
                members[f"{st.name}_{st.group}"] = In(16)
        for k in self._shared:
            members.update({self._status(SHARED_DDR, n, k): v
                            for n, v in mig_user_ports().items()})
        if self._holds():
            members["startup_cycles"] = Out(32)
        if taps:
            for k, (name, bits, count) in enumerate(self._tap_shapes):
                for s in ("valid", "ready", "first", "last"):
                    members[f"tap{k}_{name}_{s}"] = Out(1)
                members[f"tap{k}_{name}_data"] = Out(bits * count)
        super().__init__(members)

    @property
    def links(self):
        """The output links' :class:`~tdicam.blocks.steps.LinkPlan`, or None."""
        return self._links

    @property
    def frame_buffers(self):
        """The output links' :class:`~tdicam.hdl.ddr.DdrFrameBuffer` s (buffer j on lane j's
        DDR interface, or on its own ``frame_buffer_app_*`` without DDR blocks), or []."""
        return [] if self._links is None else self._out_links.frame_buffers

    @property
    def own_frame_buffers(self):
        """[(j, buffer)] of the frame buffers on a MIG user interface of their own (ports
        ``frame_buffer_app_*[_j]``: a top without DDR blocks), not behind a lane's
        arbiter (those share its MIG model in :meth:`devices`)."""
        shared = self._shared_buffers()
        return [(j, fb) for j, fb in enumerate(self.frame_buffers) if j not in shared]

    def _ddr_users(self):
        """Indices of the stages with a MIG user interface on their pins."""
        return [i for i, st in enumerate(self._stages) if set(MIG_PORT_NAMES) <= set(st.pins)]

    def _frame_buffer_lanes(self):
        """The lanes with a DDR block, when the links have a frame buffer (it goes on each
        of their interfaces), else 0."""
        if self._links is None or not self._links.buffer_rows:
            return 0
        return max([len(self._cores[i]) for i in self._ddr_users()] or [0])

    def _shared_buffers(self):
        """The frame buffers (their index = the lane) on a lane's shared DDR interface."""
        from tdicam.hdl.output_links import buffer_share
        if not self._fb_lanes:
            return []
        return list(range(len(buffer_share(self._links, self._fb_lanes))))

    def _shared_ddr(self):
        """{lane: [stage index, ...]} of the lanes whose DDR interface two or more users
        share (the stages with a MIG user interface on their pins, in stream order, and
        the lane's frame buffer after them: :meth:`_shared_buffers`)."""
        users = self._ddr_users()
        lanes = max([len(self._cores[i]) for i in users] or [0])
        out = {k: [i for i in users if k < len(self._cores[i])] for k in range(lanes)}
        fb = self._shared_buffers()
        return {k: v for k, v in out.items() if len(v) + (k in fb) > 1}

    @property
    def shared_ddr(self):
        """{lane: [user name, ...]} of the lanes whose DDR interface users share (the
        stages', then ``frame_buffer`` for the lane's frame buffer)."""
        fb = self._shared_buffers()
        return {k: [self._stages[i].name for i in v] + ([FRAME_BUFFER] if k in fb else [])
                for k, v in self._shared.items()}

    def _shares(self, st, pname, k):
        """Whether stage ``st``'s pin ``pname`` of lane ``k`` goes to the lane's shared DDR."""
        return pname in MIG_PORT_NAMES and any(self._stages[i] is st
                                               for i in self._shared.get(k, ()))

    def _holds(self):
        """(stage, lanes) of the stages whose ``ready`` port holds the input."""
        return [(st, len(cs)) for st, cs in zip(self._stages, self._cores)
                if st.ready is not None]

    @property
    def port_domains(self):
        """{top port: clock domain} of the ports its components have outside the processing
        clock (their ``port_domains``; e.g. the sensor front end's word-clock ports, the
        output links' pins)."""
        out = self._top_names("port_domains")
        if self._links is not None:
            out.update(self._out_links.port_domains)
        return out

    @property
    def pin_ports(self):
        """{top port: I/O attributes} of its components' ports that are device pins (their
        ``pin_ports``; e.g. the ECP5 PHY's LVDS lanes)."""
        return self._top_names("pin_ports")

    def _top_names(self, what):
        """The components' ``what`` ({port: value}) under the top's port names."""
        out = {}
        for st, cores in zip(self._stages, self._cores):
            for k, core in enumerate(cores):
                for pname, val in (getattr(core, what, None) or {}).items():
                    flow = core.signature.members[pname].flow
                    out[f"{st.name}_{pname}" if flow == wiring.In and pname not in st.pins
                        else self._status(st, pname, k)] = val
        return out

    @property
    def startup_bound(self):
        """Cycles after reset the top may hold its input at most (the stages' ``startup``)."""
        return max([st.startup for st in self._stages] or [0])

    def has_devices(self):
        """Whether a stage or the links' frame buffer has an external part
        (:class:`Device`) on its pins."""
        return any(st.device is not None for st in self._stages) or bool(self.frame_buffers)

    def devices(self):
        """[(stage, lane, :class:`Device`)] of the stages' external parts (simulation; made
        once, for the :class:`Board` around this top; a lane's shared DDR model deep enough
        for the lane's frame buffer too; :attr:`own_frame_buffers` the Board's)."""
        if not hasattr(self, "_devices"):
            out, shared = [], {k: [] for k in self._shared}
            for st, cs in zip(self._stages, self._cores):
                for k in range(len(cs) if st.device is not None else 0):
                    devs = st.device(k)
                    for dev in devs if isinstance(devs, (list, tuple)) else [devs]:
                        if self._shares(st, next(iter(dev.pins)), k):
                            dev.model._MustUse__silence = True    # one of them is used
                            shared[k].append(dev)
                        else:
                            out.append((st, k, dev))
            from tdicam.model.ddr import ADDR_PER_WORD
            ends = [fb.layout.end_addr(fb.rows) // ADDR_PER_WORD for fb in self.frame_buffers]
            shared_fb = self._shared_buffers()
            for k, devs in shared.items():
                deep = max(devs, key=lambda d: d.model.depth_words)
                if k in shared_fb and ends[k] > deep.model.depth_words:
                    # (the buffer's region above the blocks': the same model, deeper)
                    deep = replace(deep, model=deep.model.with_depth(ends[k]))
                out.append((SHARED_DDR, k, replace(
                    deep, pins={n: n for n in MIG_PORT_NAMES},
                    status={n.removeprefix("ddr_"): port for n, port in deep.status.items()})))
            self._devices = out
        return self._devices

    @staticmethod
    def _status(st, pname, lane):
        return f"{st.name}_{lane_port(pname, lane)}"

    def _plan(self):
        """Make every component once; check lane counts and widths (one-line errors)."""
        cores, lanes, bits, ppc = [], self._lanes, self._in_bits, self._ppc
        self._tap_shapes, self._narrows, self._ppcs = [], [], []
        for st in self._stages:
            if st.merge:
                cs = [st.make(0)]
                lanes = 1
            elif st.source:
                cs = [st.make(0)]
            else:
                cs = [st.make(k) for k in range(lanes)]
            ib = bits if st.source else element_bits(_data_shape(cs[0], "i_stream"))[0]
            ob, oc = element_bits(_data_shape(cs[0], "o_stream"))
            if bits > ib:
                names = [s.name for s in self._stages]
                prev = names[names.index(st.name) - 1] if names.index(st.name) else "input"
                raise TdicamError(f"pipeline: {prev} gives {bits}-bit pixels, {st.name} "
                                  f"takes {ib}-bit pixels")
            bits = ob
            sp = ppc if st.source else getattr(cs[0], "ppc", 1)     # a source gives ppc
            if sp > ppc or (sp < ppc and (self._width is None or self._width % ppc)):
                raise TdicamError(
                    f"pipeline: {st.name} takes {sp} pixel(s) a beat after {ppc}: a stage "
                    f"takes at most as many as the one before" if sp > ppc else
                    f"pipeline: {st.name} takes {sp} pixel(s) a beat after {ppc}: the row "
                    f"width (a multiple of {ppc}) is needed for the converter's FIFO")
            self._narrows.append(sp < ppc)
            ppc = sp
            cores.append(cs)
            self._ppcs.append(sp)
            for k in range(len(cs)):
                self._tap_shapes.append((st.name + (f"_{k}" if len(cs) > 1 else ""), ob, oc))
        self._out_shape = (bits, oc if self._stages else 1)
        if not self._stages:
            self._out_shape = (self._in_bits, self._ppc * self._lanes * self._lane_elems)
        return cores

    stages = property(lambda self: list(self._stages))
    cores = property(lambda self: [list(c) for c in self._cores],
                     doc="The blocks' components, per stage and lane.")
    tap_shapes = property(lambda self: list(self._tap_shapes),
                          doc="(name, element bits, element count) of each tap.")
    stage_ppc = property(lambda self: list(self._ppcs),
                         doc="Pixels a beat each stage's component takes, in stage order.")

    @property
    def latency(self):
        """Sum of the blocks' latencies (cycles, no stall; see the class notes), or None
        when a block's latency varies (a block with its memory in DDR) or the top ends in
        the output links (their clock crossing)."""
        lats = [getattr(cs[0], "latency", 0) for cs in self._cores]
        if self._links is not None:     # the links' clock crossing: no fixed latency
            return None
        return None if None in lats else \
            sum(lats) + len(self._slices) + (Narrower.LATENCY + 1) * sum(self._narrows)

    @property
    def _slices(self):
        """Indices of the stages followed by a register slice."""
        return [k for k, st in enumerate(self._stages[:-1]) if st.out_slice]

    def elaborate(self, platform):
        m = Module()
        ppc = self._ppc         # pixels a beat of the streams reaching the next stage
        tap = 0
        self._arbiters = {}
        fb = self._shared_buffers()
        for k, users in self._shared.items():
            from tdicam.hdl.ddr_arbiter import DdrArbiter
            m.submodules[core_name(SHARED_DDR, k, 2) + "_arbiter"] = arb = DdrArbiter(
                n_ports=len(users) + (k in fb))
            connect_mig(m, arb, SimpleNamespace(**{
                n: getattr(self, self._status(SHARED_DDR, n, k)) for n in MIG_PORT_NAMES}))
            self._arbiters[k] = arb
        if self._source:
            # the source's output stands where the top's input would
            st, core = self._stages[0], self._cores[0][0]
            m.submodules[core_name(st, 0, 1)] = core
            self._wire_ports(m, st, core, 0)
            whole = Link.of_output(core.o_stream)
            whole.user = {name: getattr(core, name) for name in st.carries}
            tap = self._tap(m, 0, whole)
            if 0 in self._slices:
                whole = register_slice(m, whole, f"{core_name(st, 0, 1)}_slice", ppc)
        else:
            i = self.i_stream
            n_in = ppc * self._lanes * self._lane_elems
            d = i.payload.data
            src_ready = Signal(name="in_ready")
            m.d.comb += i.ready.eq(src_ready)
            whole = Link(i.valid, src_ready, i.payload.first, i.payload.last,
                         [d[k] for k in range(n_in)] if n_in > 1 else [d], self._in_bits)
        holds = self._holds()
        if holds:
            # the input is held until every holding stage is ready (its start-up is done)
            go = Signal(name="released")
            m.d.comb += go.eq(Cat(*(getattr(self, self._status(st, st.ready, k))
                                    for st, n in holds for k in range(n))).all())
            with m.If(~go & (self.startup_cycles != 0xFFFFFFFF)):
                m.d.sync += self.startup_cycles.eq(self.startup_cycles + 1)
            held_ready = Signal(name="held_ready")
            m.d.comb += whole.ready.eq(held_ready & go)
            whole = Link(whole.valid & go, held_ready, whole.first, whole.last, whole.elems,
                         whole.bits, whole.user)
        if self._source and self._stages[0].gate is not None:
            m.d.comb += getattr(self._cores[0][0], self._stages[0].gate).eq(go if holds else 1)
        # lanes stay one stream until a per-lane block needs them apart
        lanes = [whole]
        per = [self._lane_elems] * self._lanes
        split = self._lanes == 1
        for n_st, (st, cores) in enumerate(zip(self._stages, self._cores)):
            if st.source:
                continue
            if st.merge:
                if not split:
                    lanes = [whole]
                else:
                    link = lanes[0]
                    for k, other in enumerate(lanes[1:]):
                        link = join(m, link, other, f"{st.name}_join{k}", ppc)
                    lanes = [link]
                split, per = True, [sum(per)]
            elif not split:
                lo, parts = 0, []
                for n in per:
                    parts.append((lo, lo + n))
                    lo += n
                lanes = (eager_fork if st.waits else fork)(m, whole, parts,
                                                           f"{st.name}_fork", ppc)
                split = True
            outs, sp = [], self._ppcs[n_st]
            for k, (core, link) in enumerate(zip(cores, lanes)):
                m.submodules[core_name(st, k, len(cores))] = core
                if self._narrows[n_st]:
                    link = narrow(m, link, ppc, sp, self._width // ppc,
                                  f"{core_name(st, k, len(cores))}_narrow", self._bram)
                if st.group is not None:
                    link = frame_group(m, link, getattr(self, f"{st.name}_{st.group}"),
                                       f"{st.name}_group{k}")
                if st.side is not None:
                    args = (m, k) if not st.io else (m, k, {
                        p: getattr(self, self._status(st, p, k)) for p in st.io})
                    side = st.side(*args)
                    if st.load is not None:
                        link, loaded = prepend(m, side, link, st.load_rows, st.load,
                                               f"{st.name}_load{k}", sp)
                        m.d.comb += getattr(self, self._status(st, st.ready, k)).eq(loaded)
                    elif sp > 1:
                        # the join's ready (the block's input ready and the pixels' valid)
                        # stops at the slice, not in the side stream's source (at ppc 8 the
                        # orbit chain's slowest path ran on into NUC's coefficient reader
                        # and calibration ROM, 7.58 ns)
                        side = register_slice(m, side, f"{st.name}_side{k}_slice", sp)
                    if st.load is None:
                        link = join(m, link, side, f"{st.name}_side{k}", sp)
                link.feed(m, core.i_stream, who=st.name)
                self._wire_ports(m, st, core, k, link.user)
                out = Link.of_output(core.o_stream)
                tap = self._tap(m, tap, out)
                if n_st in self._slices:
                    out = register_slice(m, out, f"{core_name(st, k, len(cores))}_slice",
                                         sp)
                outs.append(out)
            ppc = sp
            lanes, per = outs, [len(o.elems) // ppc for o in outs]
        if len(lanes) != 1 and self._stages:
            raise TdicamError(f"pipeline: {len(lanes)} channel lanes reach the output; a "
                              f"merging block (hdr) must join them")
        last = lanes[0] if self._stages else whole
        if self._links is not None:
            m.submodules.output_links = ol = self._out_links
            last.feed(m, ol.i_stream, who="the output links")
            for k in self._shared_buffers():      # buffer k: lane k's arbiter's last port
                arb = self._arbiters[k].port(len(self._shared[k]))
                connect_mig(m, SimpleNamespace(**{
                    n: getattr(ol, buffer_port(n, k)) for n in MIG_PORT_NAMES}), arb)
            for n, mem in ol.signature.members.items():
                if n == "i_stream" or n not in self.signature.members:
                    continue
                if mem.flow == wiring.Out:
                    m.d.comb += getattr(self, n).eq(getattr(ol, n))
                else:                       # (the frame buffer's MIG inputs)
                    m.d.comb += getattr(ol, n).eq(getattr(self, n))
        else:
            last.feed(m, self.o_stream, who="pipeline output")
        return m

    def _wire_ports(self, m, st, core, k, user=None):
        """Stage ``st``'s component ``core`` (lane ``k``): run-time inputs from the top's
        ports (or from the values ``user`` its input stream carries), status outputs to
        them."""
        for pname, member in core.signature.members.items():
            if pname in ("i_stream", "o_stream") or (st.source and pname in st.carries) \
                    or (st.source and pname == st.gate):
                continue
            if user and pname in user and member.flow == wiring.In:
                m.d.comb += getattr(core, pname).eq(user[pname])
                continue
            if self._shares(st, pname, k):
                # the lane's shared DDR: this stage's port of the lane's arbiter
                users = self._shared[k]
                j = next(n for n, i in enumerate(users) if self._stages[i] is st)
                arb = getattr(self._arbiters[k], f"p{j}_{pname}")
                if member.flow == wiring.In:
                    m.d.comb += getattr(core, pname).eq(arb)
                else:
                    m.d.comb += arb.eq(getattr(core, pname))
                continue
            if pname in st.pins and member.flow == wiring.In:
                m.d.comb += getattr(core, pname).eq(getattr(self, self._status(st, pname, k)))
            elif member.flow == wiring.In:
                m.d.comb += getattr(core, pname).eq(getattr(self, f"{st.name}_{pname}"))
            else:
                m.d.comb += getattr(self, self._status(st, pname, k)).eq(getattr(core, pname))

    def _tap(self, m, tap, out):
        """Expose ``out`` as tap ``tap`` (with ``taps``); the next tap's number."""
        if self._taps:
            name = self._tap_shapes[tap][0]
            m.d.comb += [
                getattr(self, f"tap{tap}_{name}_valid").eq(out.valid),
                getattr(self, f"tap{tap}_{name}_ready").eq(out.ready),
                getattr(self, f"tap{tap}_{name}_first").eq(out.first),
                getattr(self, f"tap{tap}_{name}_last").eq(out.last),
                getattr(self, f"tap{tap}_{name}_data").eq(Cat(*out.elems)),
            ]
        return tap + 1


def core_name(st, lane, lanes):
    """The submodule name of stage ``st``'s component of ``lane`` (of ``lanes``)."""
    return st.name + (f"_{lane}" if lanes > 1 else "")


def _data_shape(component, port):
    return component.signature.members[port].signature.members["payload"].shape["data"].shape
