"""A clock-domain-crossing FIFO whose read side has no adder and no comparator before its
memory's read address.

:class:`amaranth.lib.fifo.AsyncFIFO` steers its memory's read address with
``consume + (r_rdy & r_en)``, ``r_rdy`` the comparison of the read pointer with the
write pointer synchronized into the read domain: on a wide FIFO (the LVDS front end's
803-bit entries over 23 ECP5 DP16KDs) the path from the read pointer through the
comparison, the reader's ``r_en``, the pointer's adder and the address's fan-out to every
block RAM was the whole camera front end's slowest at 8 pixels per clock (8.73 ns).
:class:`RegisteredAsyncFIFO` has the same interface, order and reset rules (the write
domain's reset empties it, the read pointers taking the write pointer through an
:class:`~amaranth.lib.cdc.AsyncFFSynchronizer`; Clifford E. Cummings, "Simulation and
Synthesis Techniques for Asynchronous FIFO Design", SNUG 2002, style 2) and keeps its
pointers' successors and ``r_rdy`` in registers: the read address is a choice of two
registers by ``r_rdy & r_en``, ``r_rdy`` a register computed from both candidates'
comparisons one cycle ahead. ``r_rdy`` therefore sees a write one read-clock cycle later
than the Amaranth FIFO (it compares with the synchronized write pointer of the cycle
before); the read rate is unchanged (a read every cycle while entries remain).
"""

from amaranth.hdl import Cat, Elaboratable, Module, Mux, ResetSignal, Signal
from amaranth.lib.cdc import AsyncFFSynchronizer, FFSynchronizer
from amaranth.lib.memory import Memory

from tdicam.errors import TdicamError

__all__ = ["RegisteredAsyncFIFO"]


def _gray(v):
    """The Gray code of ``v``."""
    return v ^ v[1:]


def _binary(g):
    """The binary value of Gray code ``g``."""
    bits = [g[-1]]
    for k in reversed(range(len(g) - 1)):
        bits.insert(0, bits[0] ^ g[k])
    return Cat(*bits)


class RegisteredAsyncFIFO(Elaboratable):
    """First-in first-out queue of ``depth`` entries of ``width`` bits from ``w_domain``
    into ``r_domain``.

    Parameters
    ----------
    width : int
        Bits an entry, >= 1.
    depth : int
        Entries; a power of two >= 2 (else a one-line :class:`~tdicam.errors.TdicamError`).
    r_domain, w_domain : str
        The read and write clock domains.

    Attributes
    ----------
    w_data, w_en, w_rdy
        Write side (``w_domain``): an entry is written on an edge where ``w_en & w_rdy``;
        ``w_rdy`` is low while the queue is full (as the reader's pointer reaches the
        write domain, two ``w_domain`` cycles late).
    r_data, r_en, r_rdy
        Read side (``r_domain``): ``r_data`` is the head while ``r_rdy``; it leaves on an
        edge where ``r_en & r_rdy``. ``r_rdy`` is a register: an entry written becomes
        readable three ``r_domain`` edges after the write pointer's update (two
        synchronizer stages and ``r_rdy``'s own). ``r_en`` may depend on ``r_rdy``.

    The write domain's reset empties the queue (the read side follows through an
    asynchronous-set, synchronous-release synchronizer); the read domain's own reset keeps
    it (its pointers are reset-less), as in :class:`amaranth.lib.fifo.AsyncFIFO`.
    """

    def __init__(self, *, width, depth, r_domain="read", w_domain="write"):
        if not isinstance(width, int) or width < 1:
            raise TdicamError(f"RegisteredAsyncFIFO: width = {width!r} must be a whole "
                              f"number of bits >= 1")
        if not isinstance(depth, int) or depth < 2 or depth & (depth - 1):
            raise TdicamError(f"RegisteredAsyncFIFO: depth = {depth} must be a power of two "
                              f">= 2")
        self._width, self._depth = width, depth
        self._r_domain, self._w_domain = r_domain, w_domain
        self.w_data = Signal(width)
        self.w_en = Signal()
        self.w_rdy = Signal()
        self.r_data = Signal(width)
        self.r_en = Signal()
        self.r_rdy = Signal()

    width = property(lambda self: self._width)
    depth = property(lambda self: self._depth)

    def elaborate(self, platform):
        m = Module()
        rd, wd = m.d[self._r_domain], m.d[self._w_domain]
        bits = self._depth.bit_length()         # log2(depth) + 1: the wrap bit

        # write side: as amaranth.lib.fifo.AsyncFIFO (the write clock is the slow one)
        do_write = Signal()
        produce_bin, produce_nxt = Signal(bits), Signal(bits)
        produce_gry, consume_w_gry = Signal(bits), Signal(bits)
        cur_gry = Signal(bits, reset_less=True)         # the read pointer's Gray code
        m.submodules.consume_cdc = FFSynchronizer(cur_gry, consume_w_gry,
                                                  o_domain=self._w_domain)
        full = Signal()
        m.d.comb += [
            # (the low bits' equality is 1 when there are none: depth 2)
            full.eq((produce_gry[-1] != consume_w_gry[-1])
                    & (produce_gry[-2] != consume_w_gry[-2])
                    & (produce_gry[:-2] == consume_w_gry[:-2])),
            self.w_rdy.eq(~full),
            do_write.eq(self.w_rdy & self.w_en),
            produce_nxt.eq(produce_bin + do_write),
        ]
        wd += [produce_bin.eq(produce_nxt), produce_gry.eq(_gray(produce_nxt))]

        # read side: the pointer, its successor and both Gray codes in registers
        produce_r_gry = Signal(bits)
        m.submodules.produce_cdc = FFSynchronizer(produce_gry, produce_r_gry,
                                                  o_domain=self._r_domain)
        cur, inc = Signal(bits, reset_less=True), Signal(bits, reset_less=True, init=1)
        inc_gry = Signal(bits, reset_less=True, init=1)
        rdy = Signal(reset_less=True)
        r_rst = Signal()
        m.submodules.rst_cdc = AsyncFFSynchronizer(
            ResetSignal(self._w_domain, allow_reset_less=True), r_rst,
            o_domain=self._r_domain)
        do_read = Signal()
        nxt = Signal(bits)
        m.d.comb += [
            self.r_rdy.eq(rdy & ~r_rst),
            do_read.eq(self.r_rdy & self.r_en),
            nxt.eq(Mux(do_read, inc, cur)),
        ]
        with m.If(r_rst):
            start = _binary(produce_r_gry)
            rd += [cur.eq(start), inc.eq(start + 1), cur_gry.eq(produce_r_gry),
                   inc_gry.eq(_gray((start + 1)[:bits])), rdy.eq(0)]
        with m.Else():
            rd += [
                cur.eq(nxt), inc.eq(nxt + 1),
                cur_gry.eq(Mux(do_read, inc_gry, cur_gry)),
                inc_gry.eq(_gray((nxt + 1)[:bits])),
                # not empty next cycle: the chosen pointer against this cycle's producer
                rdy.eq(Mux(do_read, inc_gry != produce_r_gry, cur_gry != produce_r_gry)),
            ]

        m.submodules.storage = storage = Memory(shape=self._width, depth=self._depth,
                                                init=[])
        w_port = storage.write_port(domain=self._w_domain)
        r_port = storage.read_port(domain=self._r_domain)
        m.d.comb += [
            w_port.addr.eq(produce_bin[:-1]), w_port.data.eq(self.w_data),
            w_port.en.eq(do_write),
            r_port.addr.eq(nxt[:-1]), r_port.en.eq(1), self.r_data.eq(r_port.data),
        ]
        return m
