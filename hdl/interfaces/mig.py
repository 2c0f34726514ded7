"""The user side of a MIG-style DDR3 controller native UI, and one in-order port on it.

Addresses and words as :mod:`tdicam.model.ddr` states them (``app_addr`` counts 32-bit
columns, a 256-bit word is 8 address steps).

* :class:`MigSignature` — the UI as an Amaranth :class:`~amaranth.lib.wiring.Signature` (the
  user side; its flip is the controller's). Components carry its members flat
  (:func:`mig_user_ports`, :func:`mig_model_ports`: the Verilog ports stay ``app_*``, not
  ``mig__app_*`` as a nested member would name them); :func:`connect_mig` wires a user to a
  controller, or to a component's own pass-through ports, by the signature's member flows.
* :class:`MigPort` — one user port on the controller: writes and reads enter one in-order
  command queue (so a read issued after a write to the same address sees the new data),
  write data goes to ``app_wdf_*`` ahead of its command (MIG allows data first), read
  data lands in a FIFO whose space is reserved when the read is queued (``app_rd_data``
  has no backpressure).
"""

from amaranth.hdl import Cat, Mux, Module, Signal, unsigned
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.wiring import In, Out

from tdicam.model.ddr import ADDR_BITS, WORD_BITS

__all__ = ["MIG_PORT_NAMES", "MigSignature", "mig_user_ports", "mig_model_ports", "connect_mig", "MigPort"]

MIG_PORT_NAMES = ("app_addr", "app_cmd", "app_en", "app_rdy", "app_wdf_data", "app_wdf_wren",
                  "app_wdf_end", "app_wdf_rdy", "app_rd_data", "app_rd_data_valid")
_TO_MEM = ("app_addr", "app_cmd", "app_en", "app_wdf_data", "app_wdf_wren", "app_wdf_end")


class MigSignature(wiring.Signature):
    """The user (FPGA logic) side of a MIG native UI: ``app_addr`` (``addr_bits`` wide, 32-bit
    column address), ``app_cmd``, ``app_en``, ``app_wdf_data`` (256-bit word),
    ``app_wdf_wren``, ``app_wdf_end`` toward the controller; ``app_rdy``, ``app_wdf_rdy``,
    ``app_rd_data``, ``app_rd_data_valid`` from it (:data:`MIG_PORT_NAMES` order)."""

    def __init__(self, addr_bits=ADDR_BITS):
        self._addr_bits = addr_bits
        shapes = {"app_addr": addr_bits, "app_cmd": 3, "app_en": 1, "app_rdy": 1,
                  "app_wdf_data": WORD_BITS, "app_wdf_wren": 1, "app_wdf_end": 1,
                  "app_wdf_rdy": 1, "app_rd_data": WORD_BITS, "app_rd_data_valid": 1}
        super().__init__({n: (Out if n in _TO_MEM else In)(unsigned(shapes[n]))
                          for n in MIG_PORT_NAMES})

    addr_bits = property(lambda self: self._addr_bits)

    def __eq__(self, other):
        return type(other) is type(self) and other.addr_bits == self.addr_bits

    def __hash__(self):
        return hash((type(self), self._addr_bits))


def mig_user_ports(addr_bits=ADDR_BITS):
    """:class:`MigSignature`'s members, to be a component's own (flat) ports."""
    return dict(MigSignature(addr_bits).members)


def mig_model_ports(addr_bits=ADDR_BITS):
    """Members of the controller side (the flip of :func:`mig_user_ports`)."""
    return dict(MigSignature(addr_bits).flip().members)


def connect_mig(m, user, ctrl):
    """Wire a user's UI ports to a controller's, or to a component's own pass-through UI
    ports (both objects with :class:`MigSignature`'s member names, flat): each member toward
    the controller (``Out`` in the signature) drives ``ctrl``'s, each other one ``user``'s.

    The assignments follow the signature's member order. :func:`amaranth.lib.wiring.connect`
    would connect the same signals in sorted name order, which renumbers the generated
    Verilog's internal wires (e.g. ``\\app_rd_data$17`` becomes ``$7``) and changes which of
    two equal nets (``app_wdf_wren``, ``app_wdf_end``) names a submodule's port, so the
    DDR blocks' Verilog would not stay byte-identical.
    """
    for name, member in MigSignature(len(user.app_addr)).members.items():
        if member.flow == Out:
            m.d.comb += getattr(ctrl, name).eq(getattr(user, name))
        else:
            m.d.comb += getattr(user, name).eq(getattr(ctrl, name))


class MigPort(wiring.Component):
    """One in-order user port on a MIG native UI.

    ``wr_*`` (address + 256-bit word) and ``rd_*`` (address) requests enter one command
    queue in the order accepted (a write offered in the same cycle as a read goes first),
    so every read sees every write queued before it. Write data is sent on ``app_wdf_*``
    as soon as the controller takes it and its command follows once the data was
    accepted in an earlier cycle. A read is queued only while the read-data FIFO has room
    for it (``rd_depth`` words reserved from queueing until the word is taken from
    ``rdata``), because ``app_rd_data_valid`` cannot be stalled. Commands, data and read
    data each move one per cycle: ``app_en`` and ``app_wdf_wren`` never depend on the
    ready signals.

    ``early_count``: the count of reserved read words steps by selecting ``count + 1`` or
    ``count - 1`` (summed from the register) with the cycle's queue and take, instead of
    adding them (``rdata_ready`` then drives a select, not a carry chain: the whole
    Ning et al. 2019 camera's slowest path at ppc 8); the same counts every cycle.
    """

    def __init__(self, *, addr_bits=ADDR_BITS, cmd_depth=16, wdata_depth=16, rd_depth=64,
                 early_count=False):
        self._aw, self._cq, self._wq, self._rd = addr_bits, cmd_depth, wdata_depth, rd_depth
        self._early = bool(early_count)
        super().__init__({
            "wr_valid": In(1), "wr_ready": Out(1), "wr_addr": In(addr_bits),
            "wr_data": In(WORD_BITS),
            "rd_valid": In(1), "rd_ready": Out(1), "rd_addr": In(addr_bits),
            "rdata_valid": Out(1), "rdata_ready": In(1), "rdata": Out(WORD_BITS),
            "idle": Out(1),
            **mig_user_ports(addr_bits)})

    rd_depth = property(lambda self: self._rd)

    def elaborate(self, platform):
        m = Module()
        AW = self._aw
        m.submodules.cmdq = cmdq = SyncFIFOBuffered(width=AW + 1, depth=self._cq)
        m.submodules.wq = wq = SyncFIFOBuffered(width=WORD_BITS, depth=self._wq)
        m.submodules.rq = rq = SyncFIFOBuffered(width=WORD_BITS, depth=self._rd)
        out_n = Signal(range(self._rd + 1))
        m.d.comb += [
            self.wr_ready.eq(cmdq.w_rdy & wq.w_rdy),
            self.rd_ready.eq(cmdq.w_rdy & ~self.wr_valid & (out_n < self._rd)),
        ]
        push_w = self.wr_valid & self.wr_ready
        push_r = self.rd_valid & self.rd_ready
        m.d.comb += [
            cmdq.w_en.eq(push_w | push_r),
            cmdq.w_data.eq(Cat(Mux(push_w, self.wr_addr, self.rd_addr), ~push_w)),
            wq.w_en.eq(push_w), wq.w_data.eq(self.wr_data),
        ]
        ahead = Signal(range(self._wq + 2))
        head_read = cmdq.r_data[AW]
        m.d.comb += [
            self.app_wdf_data.eq(wq.r_data), self.app_wdf_wren.eq(wq.r_rdy),
            self.app_wdf_end.eq(wq.r_rdy), wq.r_en.eq(self.app_wdf_rdy),
            self.app_en.eq(cmdq.r_rdy & (head_read | ahead.any())),
            self.app_cmd.eq(head_read), self.app_addr.eq(cmdq.r_data[:AW]),
            cmdq.r_en.eq(self.app_en & self.app_rdy),
        ]
        dfire = wq.r_rdy & self.app_wdf_rdy
        wcfire = self.app_en & self.app_rdy & ~head_read
        m.d.sync += ahead.eq(ahead + dfire - wcfire)
        m.d.comb += [rq.w_en.eq(self.app_rd_data_valid), rq.w_data.eq(self.app_rd_data),
                     self.rdata.eq(rq.r_data), self.rdata_valid.eq(rq.r_rdy),
                     rq.r_en.eq(self.rdata_ready)]
        pop = rq.r_rdy & self.rdata_ready
        if self._early:
            up, down = Signal.like(out_n), Signal.like(out_n)
            m.d.comb += [up.eq(out_n + 1), down.eq(out_n - 1)]
            with m.If(push_r & ~pop):
                m.d.sync += out_n.eq(up)
            with m.Elif(pop & ~push_r):
                m.d.sync += out_n.eq(down)
        else:
            m.d.sync += out_n.eq(out_n + push_r - pop)
        m.d.comb += self.idle.eq(~cmdq.r_rdy & ~cmdq.level.any() & ~wq.r_rdy)
        return m
