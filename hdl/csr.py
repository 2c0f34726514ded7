"""The camera top's control bus: an AXI4-Lite (or a Wishbone B4) slave on the register
map of :mod:`tdicam.hdl.csr_map`, around a :class:`~tdicam.hdl.chain_top.Pipeline` (or
the :class:`~tdicam.hdl.chain_board.Board` around one).

The signature is the contract: ``s_axil_*`` (AXI4-Lite, AMBA AXI4 names, 32-bit data,
:data:`~tdicam.hdl.csr_map.ADDR_BITS`-bit byte address, responses always OKAY) or
``wb_*`` (Wishbone B4, classic or pipelined: :data:`WB_PORTS`) and ``irq`` replace the
ports the map stands for; every other port of the wrapped top keeps its name. An unmapped
address reads 0 and ignores writes.
"""

from functools import reduce
from operator import or_

from amaranth.hdl import Cat, Const, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out
from amaranth.utils import bits_for

from tdicam.errors import TdicamError
from tdicam.hdl.output_links import LINKS_FRAME
from tdicam.hdl.csr_map import ADDR_BITS, BLOCK_STRIDE, DATA_BITS

__all__ = ["CsrTop", "BUSES", "AXIL_PORTS", "WB_PORTS", "BUS_PREFIXES", "bus_names",
           "cross"]

#: The control buses a top can carry, the default first (``--bus``).
BUSES = ("axi4-lite", "wishbone")

#: The AXI4-Lite slave's ports: (name without ``s_axil_``, width, direction from the slave).
AXIL_PORTS = (
    ("awaddr", ADDR_BITS, "in"), ("awprot", 3, "in"), ("awvalid", 1, "in"),
    ("awready", 1, "out"),
    ("wdata", DATA_BITS, "in"), ("wstrb", DATA_BITS // 8, "in"), ("wvalid", 1, "in"),
    ("wready", 1, "out"),
    ("bresp", 2, "out"), ("bvalid", 1, "out"), ("bready", 1, "in"),
    ("araddr", ADDR_BITS, "in"), ("arprot", 3, "in"), ("arvalid", 1, "in"),
    ("arready", 1, "out"),
    ("rdata", DATA_BITS, "out"), ("rresp", 2, "out"), ("rvalid", 1, "out"), ("rready", 1, "in"),
)

#: The Wishbone B4 slave's ports (name without ``wb_``, width, direction from the slave):
#: a word address (the byte address over 4), 32-bit data, a byte select. One access at a
#: time, acknowledged the cycle after it is taken; ``stall`` is high that cycle, so a
#: classic master (strobe held until ``ack``) and a pipelined one (a strobe taken while
#: ``stall`` is low) both work.
WB_PORTS = (
    ("adr", ADDR_BITS - 2, "in"), ("dat_w", DATA_BITS, "in"), ("dat_r", DATA_BITS, "out"),
    ("sel", DATA_BITS // 8, "in"), ("cyc", 1, "in"), ("stb", 1, "in"), ("we", 1, "in"),
    ("ack", 1, "out"), ("stall", 1, "out"),
)

#: Each bus's ports and their prefix.
_PORTS = {"axi4-lite": ("s_axil_", AXIL_PORTS), "wishbone": ("wb_", WB_PORTS)}

#: The prefixes of every bus's ports (a top's bus ports are neither settings nor status).
BUS_PREFIXES = tuple(prefix for prefix, _ in _PORTS.values())


def bus_names(bus):
    """(the bus's name, the slave's port prefix, the write task, the read task) of ``bus``
    and its testbench master (:mod:`tdicam.cosim.tbbus`), for the text that names them."""
    name, task = {"axi4-lite": ("AXI4-Lite", "axil"), "wishbone": ("Wishbone", "wb")}[bus]
    return name, _PORTS[bus][0], f"{task}_write", f"{task}_read"


class CsrTop(wiring.Component):
    """``core`` with its settings and status behind an AXI4-Lite (or Wishbone) slave.

    Parameters
    ----------
    core : wiring.Component
        A Pipeline (or a Board around one) with the ports ``regmap`` stands for.
    regmap : :class:`~tdicam.hdl.csr_map.RegisterMap`
    bus : str
        One of :data:`BUSES`.

    Attributes
    ----------
    s_axil_* : AXI4-Lite slave (see :data:`AXIL_PORTS`), with ``bus="axi4-lite"``.
        One write (address and data taken in the same cycle) and one read outstanding;
        a read returns the value of the cycle its address was taken.
    wb_* : Wishbone B4 slave (see :data:`WB_PORTS`), with ``bus="wishbone"``.
        A read returns the value of the cycle its strobe was taken.
    irq : Out(1)
        High while a bit of ``irq_status & irq_enable`` is set.

    Notes
    -----
    Settings are registers driving the block's inputs (reset: the map's value); a block
    samples them where its contract says (TDI's ``stages_active`` with a frame's first
    beat). A fault counter reads as the block's count less the count at its last clear:
    writing 1s clears those bits of the value read (write all ones to clear it). A fault
    source's interrupt bit is set on the cycle its counter changes (or its flag rises).

    A register of another clock domain (:attr:`Register.domain`, the sensor front end's word
    clock) crosses: a one-bit status through a 2-FF synchronizer, the multi-bit ones of a
    domain together through :func:`cross` (held in their domain, taken on the bus's side
    when the acknowledgement arrives: a coherent snapshot every few clocks); the settings
    of a domain the other way through :func:`cross`, applied while the block's
    :attr:`Register.hold` status is low.
    """

    def __init__(self, core, regmap, bus="axi4-lite"):
        if bus not in BUSES:
            raise TdicamError(f"csr: bus {bus!r}; give one of {', '.join(BUSES)}")
        self._core, self._map, self._bus = core, regmap, bus
        covered = regmap.ports
        missing = sorted(covered - set(core.signature.members))
        if missing:
            raise TdicamError(f"csr: the register map names port(s) {', '.join(missing)} "
                              f"the top does not have; make the map from this top")
        members = {n: m for n, m in core.signature.members.items()
                   if n not in covered and n != LINKS_FRAME}
        prefix, ports = _PORTS[bus]
        for name, width, d in ports:
            members[f"{prefix}{name}"] = (In if d == "in" else Out)(width)
        members["irq"] = Out(1)
        super().__init__(members)

    core = property(lambda self: self._core, doc="The wrapped top.")
    regmap = property(lambda self: self._map, doc="The register map.")
    bus = property(lambda self: self._bus, doc="The control bus, one of :data:`BUSES`.")
    latency = property(lambda self: self._core.latency)
    tap_shapes = property(lambda self: self._core.tap_shapes)
    startup_bound = property(lambda self: self._core.startup_bound)
    port_domains = property(lambda self: dict(getattr(self._core, "port_domains", {}) or {}))
    pin_ports = property(lambda self: dict(getattr(self._core, "pin_ports", {}) or {}))

    def elaborate(self, platform):
        m = Module()
        m.submodules.core = core = self._core
        for name, mem in self.signature.members.items():
            if name in ("i_stream", "o_stream") or name not in core.signature.members:
                continue
            if mem.flow == wiring.In:
                m.d.comb += getattr(core, name).eq(getattr(self, name))
            else:
                m.d.comb += getattr(self, name).eq(getattr(core, name))
        if "i_stream" in self.signature.members:
            wiring.connect(m, wiring.flipped(self.i_stream), core.i_stream)
        if "o_stream" in self.signature.members:      # (none: the output links' top)
            wiring.connect(m, core.o_stream, wiring.flipped(self.o_stream))

        faults = self._map.faults
        nf = len(faults)
        frames = Signal(32, name="csr_frame_count")
        if "o_stream" in core.signature.members:
            o = core.o_stream
            start = o.valid & o.ready & o.payload.first
        else:                           # the frames sent on the output links
            start = getattr(core, LINKS_FRAME)
        with m.If(start):
            m.d.sync += frames.eq(frames + 1)
        released = Cat(*(getattr(core, f"{st.name}_{st.ready}" + (f"_{k}" if k else ""))
                         for st, n in core_holds(core) for k in range(n))).all() \
            if core_holds(core) else Const(1, 1)
        irq_enable = Signal(max(nf, 1), name="csr_irq_enable")
        irq_status = Signal(max(nf, 1), name="csr_irq_status")
        m.d.comb += self.irq.eq((irq_enable & irq_status).any())

        # a register's value read, and what a write does: {offset: (read value, write fn)}
        regs = {}
        axil = self._bus == "axi4-lite"
        wmask = Signal(DATA_BITS, name="csr_wmask")     # the write's data bits under wstrb
        strobe = self.s_axil_wstrb if axil else self.wb_sel
        m.d.comb += wmask.eq(Cat(*(strobe[b].replicate(8) for b in range(DATA_BITS // 8))))
        wdata = self.s_axil_wdata if axil else self.wb_dat_w
        events, summary = [], []
        crossed = self._cross_status(m, core)
        settings = {}
        for r in self._map.registers:
            if r.port is None and r.block == "camera":
                continue
            live = crossed.get(r.port, getattr(core, r.port))
            if r.access == "rw":
                reg = Signal(r.width, init=r.reset, name=f"csr_{r.port}")
                if r.domain is None:
                    m.d.comb += getattr(core, r.port).eq(reg)
                else:
                    settings.setdefault((r.domain, r.hold), []).append((r, reg))
                regs[r.offset] = (reg, _rw(reg, wdata, strobe))
            elif r.access == "w1c":
                base = Signal(r.width, name=f"csr_{r.port}_base")
                shown = Signal(r.width, name=f"csr_{r.port}_shown")
                m.d.comb += shown.eq(live - base)
                regs[r.offset] = (shown, _w1c(base, shown, live, wdata & wmask))
            else:
                regs[r.offset] = (live, None)
            if r.fault:
                prev = Signal(r.width, name=f"csr_{r.port}_prev")
                m.d.sync += prev.eq(live)
                events.append((live & ~prev).any() if r.mask else
                              live != prev if r.width > 1 else live & ~prev)
                summary.append(regs[r.offset][0].any())
        for (domain, hold), rs in settings.items():
            gate = getattr(core, hold) if hold is not None else None
            out = cross(m, Cat(*(reg for _, reg in rs)), "sync", domain,
                        f"csr_{domain}_settings", init=_packed(rs),
                        hold=gate)
            m.d.comb += Cat(*(getattr(core, r.port) for r, _ in rs)).eq(out)
        own = {"id": None, "version": None, "frame_count": frames, "startup": released,
               "fault_summary": Cat(*summary) if summary else Const(0, 1),
               "irq_enable": irq_enable, "irq_status": irq_status}
        for r in self._map.registers:
            if r.block == "camera" and r.port is None:
                value = own[r.name]
                # irq_status's clear is below (a new fault wins over it)
                regs[r.offset] = (Const(r.reset, 32), None) if value is None else \
                    (value, _rw(value, wdata, strobe) if r.name == "irq_enable" else None)
        status_off = self._map.get("camera", "irq_status").offset

        take_w, waddr = self._axil_write(m) if axil else self._wishbone(m, regs)
        hits = _hits(waddr, [off for off, (_, write) in regs.items() if write is not None]
                     + [status_off])
        for off, (_, write) in regs.items():
            if write is not None:
                with m.If(take_w & hits[off]):
                    write(m)
        cleared = Signal(len(irq_status), name="csr_irq_cleared")
        with m.If(take_w & hits[status_off]):
            m.d.comb += cleared.eq((wdata & wmask)[:len(irq_status)])
        m.d.sync += irq_status.eq((irq_status & ~cleared) | (Cat(*events) if events else 0))
        if axil:
            self._axil_read(m, regs)
        return m

    def _axil_write(self, m):
        """The AXI4-Lite write channels: (the write's take, its word address). A write
        takes address and data together, then responds."""
        bvalid = Signal(name="csr_bvalid")
        take_w = Signal(name="csr_take_w")
        m.d.comb += [take_w.eq(self.s_axil_awvalid & self.s_axil_wvalid & ~bvalid),
                     self.s_axil_awready.eq(take_w), self.s_axil_wready.eq(take_w),
                     self.s_axil_bvalid.eq(bvalid), self.s_axil_bresp.eq(0)]
        with m.If(take_w):
            m.d.sync += bvalid.eq(1)
        with m.Elif(bvalid & self.s_axil_bready):
            m.d.sync += bvalid.eq(0)
        return take_w, self.s_axil_awaddr[2:]

    def _axil_read(self, m, regs):
        """The AXI4-Lite read channels on ``regs`` ({offset: (value read, write)}): a read
        returns the value of the cycle its address is taken."""
        rvalid = Signal(name="csr_rvalid")
        rdata = Signal(DATA_BITS, name="csr_rdata", reset_less=True)
        m.d.comb += [self.s_axil_arready.eq(~rvalid), self.s_axil_rvalid.eq(rvalid),
                     self.s_axil_rdata.eq(rdata), self.s_axil_rresp.eq(0)]
        take = Signal(name="csr_take_r")
        m.d.comb += take.eq(self.s_axil_arvalid & ~rvalid)
        with m.If(take):
            m.d.sync += rvalid.eq(1)
        with m.Elif(rvalid & self.s_axil_rready):
            m.d.sync += rvalid.eq(0)
        _read(m, regs, self.s_axil_araddr[2:], rdata, take)

    def _wishbone(self, m, regs):
        """The Wishbone B4 slave on ``regs``: (the write's take, its word address). An
        access (``cyc & stb``) is taken when no acknowledgement is out and acknowledged the
        next cycle (``stall`` high then)."""
        ack = Signal(name="csr_wb_ack")
        take = Signal(name="csr_wb_take")
        rdata = Signal(DATA_BITS, name="csr_rdata", reset_less=True)
        m.d.comb += [take.eq(self.wb_cyc & self.wb_stb & ~ack), self.wb_ack.eq(ack),
                     self.wb_stall.eq(ack), self.wb_dat_r.eq(rdata)]
        m.d.sync += ack.eq(take)
        _read(m, regs, self.wb_adr, rdata, take & ~self.wb_we)
        take_w = Signal(name="csr_take_w")
        m.d.comb += take_w.eq(take & self.wb_we)
        return take_w, self.wb_adr

    def _cross_status(self, m, core):
        """{port: its value in the bus's clock} of the map's status registers of another
        domain: a bit through a 2-FF synchronizer, the wider ones of a domain through
        :func:`cross` together."""
        out, wide = {}, {}
        for r in self._map.registers:
            if r.domain is None or r.access == "rw":
                continue
            if r.width == 1:
                out[r.port] = Signal(name=f"csr_{r.port}_sync")
                m.submodules[f"csr_{r.port}_sync"] = FFSynchronizer(
                    getattr(core, r.port), out[r.port], o_domain="sync")
            else:
                wide.setdefault(r.domain, []).append(r)
        for domain, rs in wide.items():
            got = cross(m, Cat(*(getattr(core, r.port) for r in rs)), domain, "sync",
                        f"csr_{domain}_status")
            at = 0
            for r in rs:
                out[r.port] = got[at:at + r.width]
                at += r.width
        return out


def cross(m, value, src, dst, name, *, init=0, hold=None):
    """``value`` (a ``src``-domain signal) as a ``dst``-domain register, coherent across
    its bits: a request/acknowledge toggle handshake through 2-FF synchronizers. ``dst``
    toggles its request; ``src``, seeing it, holds ``value`` and toggles its acknowledge;
    ``dst``, seeing that, takes the held word (stable since the acknowledge) and requests
    again: a new snapshot every ~3 clocks of each side. ``hold`` (a ``dst`` signal): while
    high the held word is not taken (nor a new one requested). ``init``: the register's
    and the held word's reset value."""
    n = len(value)
    req, req_s = Signal(name=f"{name}_req"), Signal(name=f"{name}_req_s")   # dst, src
    ack, ack_d = Signal(name=f"{name}_ack"), Signal(name=f"{name}_ack_d")   # src, dst
    held = Signal(n, init=init, name=f"{name}_held")                        # src
    out = Signal(n, init=init, name=f"{name}_out")                          # dst
    m.submodules[f"{name}_req_sync"] = FFSynchronizer(req, req_s, o_domain=src)
    m.submodules[f"{name}_ack_sync"] = FFSynchronizer(ack, ack_d, o_domain=dst)
    with m.If(req_s != ack):
        m.d[src] += [held.eq(value), ack.eq(req_s)]
    take = (ack_d == req) if hold is None else (ack_d == req) & ~hold
    with m.If(take):
        m.d[dst] += [out.eq(held), req.eq(~req)]
    return out


def _read(m, regs, word, rdata, take):
    """``rdata`` takes, when ``take``, the value of the register at word address ``word``
    (0 unmapped): a multiplexer tree on the address bits that tell the mapped words apart
    (:func:`_select`; an unmapped word's bits are not decoded there), and the register's
    synchronous reset when the address is none of them (the registers' :func:`_hits`
    ORed). ``rdata`` has no other reset (``reset_less``: it is only looked at with its
    response)."""
    hits = _hits(word, list(regs))
    with m.If(take):
        with m.If(reduce(or_, hits.values())):
            m.d.sync += rdata.eq(_select(word, {off >> 2: v for off, (v, _) in regs.items()}))
        with m.Else():
            m.d.sync += rdata.eq(0)


def _select(word, values):
    """The value of ``values`` ({word address: value}) at word address ``word`` when it is
    one of them (otherwise any): a tree of 2-way multiplexers, each on the address bit that
    splits its words most evenly (the lowest such bit)."""
    if len(values) == 1:
        return next(iter(values.values()))
    n = len(values)

    def balance(b):
        ones = sum(w >> b & 1 for w in values)
        return (abs(2 * ones - n) if 0 < ones < n else 2 * n, b)
    b = min(range(len(word)), key=balance)
    return Mux(word[b], _select(word, {w: v for w, v in values.items() if w >> b & 1}),
               _select(word, {w: v for w, v in values.items() if not w >> b & 1}))


def _pages(word, offsets):
    """{register block: (the low word-address bits that tell its registers apart, its
    registers' word indices in it, whether word address ``word`` is in it)}: a block
    (:data:`~tdicam.hdl.csr_map.BLOCK_STRIDE`) matches when the other bits are its page and
    zeros, one compare per block instead of a whole-address one per register."""
    pages = {}
    for off in offsets:
        pages.setdefault(off // BLOCK_STRIDE, []).append(off % BLOCK_STRIDE >> 2)
    out = {}
    for page, words in sorted(pages.items()):
        nb = bits_for(max(words))
        out[page] = (nb, words, word[nb:] == (page * BLOCK_STRIDE >> 2) >> nb)
    return out


def _hits(word, offsets):
    """{offset: whether word address ``word`` is its} (its block's :func:`_pages` match
    and the low bits)."""
    return {page * BLOCK_STRIDE + 4 * w: hit & (word[:nb] == w)
            for page, (nb, words, hit) in _pages(word, offsets).items() for w in words}


def _packed(rs):
    """The reset values of ``rs`` ([(register, signal)]) packed as :func:`Cat` packs them."""
    out, at = 0, 0
    for r, _ in rs:
        out |= r.reset << at
        at += r.width
    return out


def _rw(reg, wdata, strobe):
    """The write of a read-write register (a function of the module): the strobed bytes
    of the data, each byte's strobe its flip-flops' enable."""
    n = len(reg)

    def write(m):
        for b in range(0, n, 8):
            with m.If(strobe[b // 8]):
                m.d.sync += reg[b:b + 8].eq(wdata[b:min(n, b + 8)])
    return write


def _w1c(base, shown, live, data):
    """The write of a fault counter (a function of the module): its base moves so that
    ``shown`` (``live - base``) loses the bits ``data`` (the strobed data) sets."""
    def write(m):
        m.d.sync += base.eq(live - (shown & ~data[:len(shown)]))
    return write


def core_holds(core):
    """(stage, lanes) of the Pipeline's stages that hold its input at start-up."""
    pl = getattr(core, "core", core)        # a Board's pipeline
    holds = getattr(pl, "_holds", None) or getattr(core, "_holds", None)
    return holds() if holds is not None else []
