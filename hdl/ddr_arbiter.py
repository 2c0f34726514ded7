"""Several DDR users' MIG user interfaces on one controller (Ning et al. 2019 §4.2: every DDR
consumer of the camera — the NUC coefficient read, the CDS reset frame's write and read —
shares one MIG user interface per DDR interface).

:class:`DdrArbiter` — ``n_ports`` controller-side MIG native UIs (``p<k>_app_*``, what each
user's :class:`~tdicam.hdl.interfaces.mig.MigPort` drives) onto one user-side UI (``app_*``,
to the controller). Golden model of its grant order: :func:`tdicam.model.ddr_arbiter.grants`.
"""

from types import SimpleNamespace

from amaranth.hdl import Array, Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.wiring import Out

from tdicam.errors import check_range
from tdicam.model.ddr import ADDR_BITS, WORD_BITS
from tdicam.model.ddr_arbiter import MAX_BURST, MAX_PORTS
from tdicam.hdl.interfaces.mig import (MIG_PORT_NAMES, MigPort, connect_mig, mig_model_ports,
                                       mig_user_ports)
from tdicam.hdl.util import quiet_reject

__all__ = ["DdrArbiter"]


class DdrArbiter(wiring.Component):
    """Round-robin arbiter of ``n_ports`` MIG user interfaces onto one.

    Policy (the golden model :func:`tdicam.model.ddr_arbiter.grants`, cycle for cycle): one
    port holds the grant; its command (``p<k>_app_en``) is taken when the arbiter has room
    (its command and write-data queues, its read-data reservation; a write also needs its
    data word, which MIG sends first, already captured). The grant moves on after ``burst``
    commands taken, or at once when the granted port presents no command, to the next port
    in round-robin order (``k + 1``, ``k + 2``, ...) that presents one this cycle; none: it
    stays. The other ports see ``app_rdy`` low. Read data return to the port that asked, in
    the order asked (the controller returns reads in order; a tag FIFO names the port of
    each read taken). Write data are captured per port (``wdata_depth`` words, data before
    command as MIG allows) and forwarded in the order of the write commands taken, so every
    word meets its own command. Data pass bit for bit.

    Parameters
    ----------
    n_ports : int
        Users, 2 .. :data:`~tdicam.model.ddr_arbiter.MAX_PORTS`.
    burst : int
        Most commands a grant, 1 .. :data:`~tdicam.model.ddr_arbiter.MAX_BURST` (a line's
        words in one block keeps the DRAM's read/write turnarounds rare).
    addr_bits : int
        ``app_addr`` width.
    rd_depth : int
        Reads in flight through the arbiter (its read-data FIFO, a
        :class:`~tdicam.hdl.interfaces.mig.MigPort`'s).
    wdata_depth : int
        Write words captured per port ahead of their commands.

    Attributes
    ----------
    p<k>_app_* : the controller side of MIG's native UI for user ``k``
    app_* : the user side, to the controller
    grant : Out(range(n_ports))
        The port holding the grant this cycle.
    take : Out(1)
        The granted port's command is taken this cycle.

    Notes
    -----
    Every command passes through a :class:`~tdicam.hdl.interfaces.mig.MigPort` toward the
    controller (its in-order queue, data ahead of commands, read-data FIFO): a command taken
    in cycle t reaches ``app_en`` two cycles later at the earliest; a read's data reach the
    user two cycles after the controller returns them. One command a cycle through it.
    """

    @quiet_reject
    def __init__(self, *, n_ports, burst=64, addr_bits=ADDR_BITS, rd_depth=64, wdata_depth=4):
        self._n = check_range("n_ports", n_ports, 2, MAX_PORTS)
        self._b = check_range("burst", burst, 1, MAX_BURST)
        self._aw, self._rd = addr_bits, check_range("rd_depth", rd_depth, 2, 1024)
        self._wd = check_range("wdata_depth", wdata_depth, 2, 64)
        members = {}
        for k in range(n_ports):
            members.update({f"p{k}_{n}": v for n, v in mig_model_ports(addr_bits).items()})
        members.update(mig_user_ports(addr_bits))
        members.update({"grant": Out(range(n_ports)), "take": Out(1)})
        super().__init__(members)

    n_ports = property(lambda self: self._n)
    burst = property(lambda self: self._b)

    def port(self, k):
        """User ``k``'s UI as an object with the ``app_*`` names (for
        :func:`~tdicam.hdl.interfaces.mig.connect_mig`)."""
        return SimpleNamespace(**{n: getattr(self, f"p{k}_{n}") for n in MIG_PORT_NAMES})

    def elaborate(self, platform):
        m = Module()
        n, B, AW = self._n, self._b, self._aw
        ports = [self.port(k) for k in range(n)]
        m.submodules.out = out = MigPort(addr_bits=AW, rd_depth=self._rd)
        connect_mig(m, out, self)
        # write data captured per port, data before command (MIG's rule at each user)
        caps = []
        for k, p in enumerate(ports):
            cap = SyncFIFOBuffered(width=WORD_BITS, depth=self._wd)
            m.submodules[f"wcap{k}"] = cap
            m.d.comb += [cap.w_en.eq(p.app_wdf_wren), cap.w_data.eq(p.app_wdf_data),
                         p.app_wdf_rdy.eq(cap.w_rdy)]
            caps.append(cap)
        m.submodules.tags = tags = SyncFIFOBuffered(width=max(1, (n - 1).bit_length()),
                                                    depth=self._rd + 1)
        g = Signal(range(n))
        c = Signal(range(B))
        req = Cat(p.app_en for p in ports)
        is_read = Array(p.app_cmd[0] for p in ports)[g]
        addr = Array(p.app_addr for p in ports)[g]
        data_ok = Array(cap.r_rdy for cap in caps)[g]
        wdata = Array(cap.r_data for cap in caps)[g]
        ok = Mux(is_read, out.rd_ready & tags.w_rdy, out.wr_ready & data_ok)
        take = Signal()
        m.d.comb += [take.eq(req.bit_select(g, 1) & ok), self.take.eq(take), self.grant.eq(g)]
        for k, p in enumerate(ports):
            m.d.comb += [p.app_rdy.eq((g == k) & ok), caps[k].r_en.eq(take & (g == k) & ~is_read)]
        m.d.comb += [out.wr_valid.eq(req.bit_select(g, 1) & ~is_read & data_ok),
                     out.wr_addr.eq(addr), out.wr_data.eq(wdata),
                     out.rd_valid.eq(req.bit_select(g, 1) & is_read & tags.w_rdy),
                     out.rd_addr.eq(addr),
                     tags.w_en.eq(take & is_read), tags.w_data.eq(g)]
        # reads return in order: each to the port its tag names, no backpressure (each user
        # reserved room for its reads)
        m.d.comb += [out.rdata_ready.eq(1), tags.r_en.eq(out.rdata_valid)]
        for k, p in enumerate(ports):
            m.d.comb += [p.app_rd_data.eq(out.rdata),
                         p.app_rd_data_valid.eq(out.rdata_valid & (tags.r_data == k))]
        # the next requesting port after g, round robin (g itself last; none: g)
        nexts = []
        for j in range(n):
            nj = j
            for off in reversed(range(1, n + 1)):
                k = (j + off) % n
                nj = Mux(req[k], k, nj)
            nexts.append(nj)
        nxt = Array(nexts)[g]
        burst_end = take & (c == B - 1)
        with m.If(burst_end | ~req.bit_select(g, 1)):
            m.d.sync += [g.eq(nxt), c.eq(0)]
        with m.Elif(take):
            m.d.sync += c.eq(c + 1)
        return m
