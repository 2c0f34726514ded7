"""The camera top's register map: its run-time settings and status as registers, stated once.

:func:`register_map` derives the map from a :class:`~tdicam.hdl.chain_top.Pipeline`'s own
ports: every setting (``<stage>_<port>`` ``In`` port of a stage's ``ports`` or ``group``) a
read-write register whose reset value is the scene's value, every status (``Out`` port of a
stage that is not a pin of an external part) a read-only register, a fault counter
(:data:`FAULT_WORDS`, wider than one bit) write-1-to-clear; widths from the ports. The
camera's own registers (:data:`CAMERA_REGISTERS`: identity, version, output frames, start-up,
fault summary, interrupt enable and status) come first. :class:`~tdicam.hdl.csr.CsrTop` is
the AXI4-Lite slave built from the map; :mod:`tdicam.chain.registers` writes it as
SystemRDL 2.0 and the C header, Markdown reference and Python driver made from that.

A block whose settings and status are in another clock domain (the sensor front end's, in
the word clock) states which of them are registers in its ``csr_ports`` ({port: kind}, kind
one of :data:`PORT_KINDS`); those registers carry the domain (:attr:`Register.domain`) and
:class:`~tdicam.hdl.csr.CsrTop` crosses them. Its other ports of that domain (the lanes'
pins, a strobe timed with the sensor such as ``retrain``) stay top-level ports, as do
settings with a per-frame pattern (a tuple value) and ports wider than :data:`DATA_BITS`.
"""

from dataclasses import dataclass

from amaranth.hdl import Shape
from amaranth.lib import wiring

from tdicam.version import __version__

__all__ = ["Register", "RegisterMap", "register_map", "DATA_BITS", "ADDR_BITS", "CAMERA_ID",
           "BLOCK_STRIDE", "FAULT_WORDS", "CAMERA_REGISTERS", "PORT_KINDS", "version_word"]

#: Bus data width (bits) and byte-address width of the control bus.
DATA_BITS, ADDR_BITS = 32, 12
#: Byte offset between the stages' register blocks; stage ``k`` (stream order) is at
#: ``(k + 1) * BLOCK_STRIDE``, the camera's own registers at 0.
BLOCK_STRIDE = 0x100
#: The identity register's value: ASCII "TDIC".
CAMERA_ID = 0x54444943
#: A status port whose name contains one of these words reports a fault: a counter (wider
#: than one bit) is write-1-to-clear, and each such port is one bit of the fault summary and
#: of the interrupt registers.
FAULT_WORDS = ("error", "uncorrectable", "corrected", "bad", "dropped", "overflow", "invalid")
#: The kinds a block's ``csr_ports`` gives its other-domain ports: ``setting`` (read-write),
#: ``status`` (the :data:`FAULT_WORDS` rule), ``mask`` (a per-lane level mask, read-only,
#: not a fault) and ``fault_mask`` (read-only; a fault while any bit is set, a new fault
#: when a bit rises).
PORT_KINDS = ("setting", "status", "mask", "fault_mask")


def version_word(version=__version__):
    """``major << 16 | minor << 8 | patch`` of a tdicam version string."""
    parts = [int("".join(c for c in p if c.isdigit()) or 0) for p in version.split(".")[:3]]
    parts += [0] * (3 - len(parts))
    return (parts[0] & 0xFFFF) << 16 | (parts[1] & 0xFF) << 8 | parts[2] & 0xFF


@dataclass(frozen=True)
class Register:
    """One register of the map.

    Attributes
    ----------
    block : str
        ``"camera"`` or the stage's name (the register block).
    name : str
        The register's name in its block (the port without the stage prefix; a lane's
        own status keeps its ``_<lane>`` suffix).
    offset : int
        Byte address on the bus.
    width : int
        Bits (the field at bit 0).
    access : {"rw", "ro", "w1c"}
    reset : int
    port : str or None
        The Pipeline's top-level port it stands for (None: the camera's own register).
    fault : bool
        A fault source (one bit of FAULT_SUMMARY, IRQ_ENABLE and IRQ_STATUS).
    desc : str
    domain : str or None
        The clock domain of the block's port when it is not the bus's (``"word"``: the
        sensor front end's); the bus reads and writes it through a crossing.
    mask : bool
        A per-lane level mask (a fault source: any bit set; a new fault: a bit rising).
    hold : str or None
        For a setting of another domain: the block's status port (a top port, that
        domain's) that must be low for the setting to be applied (the front's
        ``releasing``: applied while it holds its frames), from its ``csr_hold``.
    """

    block: str
    name: str
    offset: int
    width: int
    access: str
    reset: int
    port: str | None
    fault: bool
    desc: str
    domain: str | None = None
    mask: bool = False
    hold: str | None = None


@dataclass(frozen=True)
class RegisterMap:
    """The registers of one camera top (``name``: the design's name) and its fault
    sources (the registers with ``fault``, in offset order: bit ``k`` of the fault and
    interrupt registers is ``faults[k]``)."""

    name: str
    registers: tuple

    @property
    def faults(self):
        return tuple(r for r in self.registers if r.fault)

    def get(self, block, name):
        """The register ``name`` of ``block``."""
        return next(r for r in self.registers if (r.block, r.name) == (block, name))

    @property
    def ports(self):
        """The Pipeline ports the map stands for."""
        return {r.port for r in self.registers if r.port is not None}


#: The camera's own registers at offset 0: (name, access, description); widths and
#: values are :func:`register_map`'s.
CAMERA_REGISTERS = (
    ("id", "ro", 'Identity: 0x54444943 (ASCII "TDIC").'),
    ("version", "ro", "tdicam version of the generated top: major << 16 | minor << 8 | patch."),
    ("frame_count", "ro", "Output frames since reset (the output stream's first beats)."),
    ("startup", "ro", "Start-up state: bit 0 set once every holding stage is ready (its "
                      "calibration loaded) and the top takes its input."),
    ("fault_summary", "ro", "Bit k set while fault source k reports a fault (its counter "
                            "non-zero, its flag high)."),
    ("irq_enable", "rw", "Bit k enables the interrupt of fault source k."),
    ("irq_status", "w1c", "Bit k set on a new fault of source k (its counter changed, its "
                          "flag rose); write 1 to clear. irq = any enabled bit set."),
)


def _is_fault(name):
    return any(w in name for w in FAULT_WORDS)


def register_map(pipeline, resets, *, name="pipeline"):
    """The :class:`RegisterMap` of ``pipeline`` (a :class:`Pipeline`).

    ``resets``: {setting port: value} (the scene's run-time values, e.g. ``tdi_stages_active``);
    a setting without one, or with a per-frame pattern (a tuple), stays a port."""
    members = pipeline.signature.members
    domains = pipeline.port_domains
    pins = set()
    for st, cores in zip(pipeline.stages, pipeline.cores):
        pins.update(f"{st.name}_{p}" for p in st.pins)
        if st.device is not None:
            for k in range(len(cores)):
                devs = st.device(k)
                for dev in devs if isinstance(devs, (list, tuple)) else [devs]:
                    _quiet(dev.model)                       # asked for its pins only
                    pins.update(pipeline._status(st, p, k) for p in dev.pins)
    regs = []
    for k, st in enumerate(pipeline.stages):
        base, own = (k + 1) * BLOCK_STRIDE, []
        settings = [f"{st.name}_{p}" for p in st.ports] + (
            [f"{st.name}_{st.group}"] if st.group is not None else [])
        front = pipeline.cores[k][0]
        kinds = getattr(front, "csr_ports", None) or {}
        hold = getattr(front, "csr_hold", None)
        for port, mem in members.items():
            if not port.startswith(st.name + "_") or port in pins \
                    or port.startswith("tap") or not mem.is_port:
                continue
            pname = port.removeprefix(st.name + "_")
            kind = kinds.get(pname) if port in domains else None
            if port in domains and kind is None:
                continue
            width = Shape.cast(mem.shape).width
            if width > DATA_BITS or not _owned(pipeline, st, port):
                continue
            dom = domains.get(port)
            if mem.flow == wiring.In:
                value = resets.get(port)
                if port not in settings or value is None or isinstance(value, tuple):
                    continue
                own.append((port, width, "rw", int(value) & ((1 << width) - 1), False, dom,
                            False))
            elif kind in ("mask", "fault_mask"):
                own.append((port, width, "ro", 0, kind == "fault_mask", dom, True))
            else:
                fault = _is_fault(pname)
                own.append((port, width, "w1c" if fault and width > 1 else "ro", 0, fault, dom,
                            False))
        for j, (port, width, access, reset, fault, dom, mask) in enumerate(own):
            regs.append(Register(st.name, port.removeprefix(st.name + "_"), base + 4 * j,
                                 width, access, reset, port, fault,
                                 _desc(st.name, port, access, dom, mask), dom, mask,
                                 f"{st.name}_{hold}" if dom and hold and access == "rw"
                                 else None))
    if "startup_cycles" in members:
        regs.append(Register("camera", "startup_cycles", 4 * len(CAMERA_REGISTERS), 32, "ro", 0,
                             "startup_cycles", False, "Cycles the top held its input at "
                             "start-up (saturates at 2**32 - 1)."))
    nfault = sum(r.fault for r in regs)
    if nfault > DATA_BITS:
        from tdicam.errors import TdicamError
        raise TdicamError(f"csr: {nfault} fault sources, the interrupt registers hold "
                          f"{DATA_BITS}; leave the bus out (--no-csr)")
    values = {"id": CAMERA_ID, "version": version_word()}
    widths = {"id": 32, "version": 32, "frame_count": 32, "startup": 1,
              "fault_summary": max(nfault, 1), "irq_enable": max(nfault, 1),
              "irq_status": max(nfault, 1)}
    own = [Register("camera", n, 4 * j, widths[n], acc, values.get(n, 0), None, False, d)
           for j, (n, acc, d) in enumerate(CAMERA_REGISTERS)]
    return RegisterMap(name, tuple(sorted(own + regs, key=lambda r: r.offset)))


def _quiet(model, depth=2):
    """Mark a model made only for its pins, and the parts it made, as not to be used."""
    from amaranth.hdl import Elaboratable
    model._MustUse__silence = True
    if depth:
        for part in vars(model).values():
            if isinstance(part, Elaboratable):
                _quiet(part, depth - 1)


def _owned(pipeline, st, port):
    """Whether top port ``port`` is stage ``st``'s (not a later stage's whose name starts
    with ``st``'s, e.g. ``cds`` and ``cds_ddr``)."""
    longer = [s.name for s in pipeline.stages if s.name != st.name
              and s.name.startswith(st.name + "_")]
    return not any(port.startswith(n + "_") for n in longer)


def _desc(stage, port, access, domain=None, mask=False):
    name = port.removeprefix(stage + "_")
    if access == "rw":
        if domain is not None:
            return (f"{stage}'s run-time setting {name} (its {domain}-clock {name} input, "
                    f"through a handshake crossing; applied while the block holds its "
                    f"frames: at start-up, a retrain).")
        return (f"{stage}'s run-time setting {name} (the block's {name} input; it takes "
                f"effect where the block samples it, e.g. with a frame's first beat).")
    what = "fault counter; write 1s to clear" if access == "w1c" else \
        "per-lane mask, lane 0 in bit 0" if mask else "status"
    if domain is not None:
        what += f"; from the {domain} clock through a crossing, a few clocks late"
    return f"{stage}'s {name} ({what})."
