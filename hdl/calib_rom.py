"""The calibration-image ROM of a pipeline top: the flash words a NUC stage's
:class:`~tdicam.hdl.calib.CalibReader` reads, when the coefficients sit on chip (no NAND part
on the top's pins)."""

from amaranth.hdl import Const, Module, Signal, Value
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import Out

from tdicam.errors import TdicamError
from tdicam.hdl.interfaces.stream import StreamRegister, channels_shape, pixel_signature
from tdicam.hdl.vendor import ecp5_bram

__all__ = ["CalibRom"]


class CalibRom(wiring.Component):
    """The flash words of a calibration image (``(n, 9)`` bytes, as
    :func:`tdicam.model.calib.encode_image` writes them) streamed again and again, one beat
    of ``per_beat`` words per clock while ``o_stream.ready`` is high: the simulation
    stand-in for the flash (``n`` a multiple of ``per_beat``).

    ``o_stream.data`` = 9 bytes a word, element ``9 j + k`` = byte ``k`` of the beat's word
    ``j`` (the input of :class:`~tdicam.hdl.calib.CalibReader` with as many words per
    beat); ``first``/``last`` are 0.

    Notes
    -----
    The beats are held in banks of :attr:`BANK` beats (one block RAM deep: 2048 x 9 on an
    ECP5), each a memory of its own with its read data registered right after it (the block
    RAM's clock-to-out and the route to one flip-flop, no logic); the bank select follows
    these registers (with the bank number delayed alike) and a register slice
    (:class:`~tdicam.hdl.interfaces.stream.StreamRegister`) takes the selected beat. Every
    stage moves on one enable, the slice's registered ``i_stream.ready`` (or an empty last
    stage; the generic banks read, and their registers load, only for a beat of their
    own): no combinational path from ``o_stream.ready`` reaches the memories. A beat
    is valid :attr:`latency` = 3 clock edges after its address (read port, bank register,
    slice); one beat a clock sustained.

    ``bram="ecp5"`` (the ECP5 synthesis top, as
    :class:`~tdicam.hdl.tdi.TdiAccumulator`'s): each bank is DP16KD primitives with their
    output register (:func:`tdicam.hdl.vendor.ecp5_bram.rom`, the contents as ``INITVAL``;
    yosys' own mapping of a memory leaves the output register unused, and a read's 4.1 ns
    clock-to-out plus the route to the bank register was the orbit chain's critical
    path), the output register moving on the same enable as the read: one stage more,
    a beat valid 4 edges after its address, the same beats in the same order.
    """

    #: Beats per bank (the depth of one ECP5 DP16KD at 9 bits).
    BANK = 2048

    #: Bank descriptions (``bram=``): read stages each adds to the generic memory's.
    BRAMS = {"generic": 0, "ecp5": 1}

    def __init__(self, words, per_beat=1, bram="generic"):
        if bram not in self.BRAMS:
            raise TdicamError(f"bram = {bram!r} is not valid; valid: {', '.join(self.BRAMS)}")
        self._bram = bram
        words = [bytes(bytearray(w)) for w in words]
        if len(words) % per_beat:
            raise TdicamError(f"calibration ROM: {len(words)} words is not a whole number "
                              f"of beats of {per_beat}")
        self._words = [int.from_bytes(b"".join(words[k:k + per_beat]), "little")
                       for k in range(0, len(words), per_beat)]
        self._bits = 72 * per_beat
        super().__init__({"o_stream": Out(pixel_signature(channels_shape(8, 9 * per_beat)))})

    @property
    def depth(self):
        return len(self._words)

    @property
    def latency(self):
        """Clock edges from a beat's address to the beat at ``o_stream`` (3, ``bram="ecp5"``
        4), when nothing stalls."""
        return 3 + self.BRAMS[self._bram]

    def elaborate(self, platform):
        m = Module()
        n, bank = len(self._words), self.BANK
        nb = -(-n // bank)
        words = self._words + [0] * (nb * bank - n) if nb > 1 else self._words
        m.submodules.out = out = StreamRegister(self._bits)
        addr = Signal(range(max(n, 2)))
        at_end = Signal(init=n == 1)   # addr == n - 1
        extra = self.BRAMS[self._bram]
        # valid / bank number of the beat in each read stage (the read port's output, the
        # block RAM's output register with ecp5, the bank registers)
        # (the names the generic ROM's Verilog always had: the last is v2)
        vs = [Signal() for _ in range(1 + extra)] + [Signal(name="v2")]
        adv = Signal()
        m.d.comb += adv.eq(~vs[-1] | out.i_stream.ready)
        lb = (bank - 1).bit_length() if nb > 1 else len(addr)
        sels = [Signal(range(max(nb, 2)), name=f"sel{k}") for k in range(1, 3 + extra)]
        qs = []
        for b in range(nb):
            chunk = words[b * bank:(b + 1) * bank]
            if self._bram == "ecp5":
                data = ecp5_bram.rom(m, f"bank{b}", words=chunk, bits=self._bits,
                                     addr=addr[:lb], en=adv)
            else:
                m.submodules[f"bank{b}"] = mem = Memory(
                    shape=self._bits, depth=max(len(chunk), 2),
                    init=chunk + [0] * (max(len(chunk), 2) - len(chunk)))
                rd = mem.read_port()
                # only the addressed bank reads and only its bank register loads (the
                # others' data is never selected; a simulator copies one bank a clock)
                hit = (addr[lb:] == b) if nb > 1 else Const(1)
                m.d.comb += [rd.en.eq(adv & hit), rd.addr.eq(addr[:lb])]
                data = rd.data
            q = Signal(self._bits, name=f"bank{b}_q")
            load = adv & (sels[0] == b) if nb > 1 and self._bram == "generic" else adv
            with m.If(load):
                m.d.sync += q.eq(data)
            qs.append(q)
        sel1, sel2 = sels[0], sels[-1]
        with m.If(adv):
            m.d.sync += [vs[0].eq(1)] + [vs[k].eq(vs[k - 1]) for k in range(1, len(vs))]
            m.d.sync += [sels[k].eq(sels[k - 1]) for k in range(1, len(sels))]
            if nb > 1:
                m.d.sync += sel1.eq(addr[lb:])
            with m.If(at_end):
                m.d.sync += [addr.eq(0), at_end.eq(n == 1)]
            with m.Else():
                m.d.sync += [addr.eq(addr + 1), at_end.eq(addr == n - 2)]
        sel = Signal(self._bits)
        with m.Switch(sel2):
            for b, q in enumerate(qs):
                with m.Case(b):
                    m.d.comb += sel.eq(q)
            if nb < 2 ** len(sel2):                  # values no bank has (never taken)
                with m.Default():
                    m.d.comb += sel.eq(qs[-1])
        o = self.o_stream
        m.d.comb += [out.i_stream.valid.eq(vs[-1]), out.i_stream.payload.eq(sel),
                     o.valid.eq(out.o_stream.valid), out.o_stream.ready.eq(o.ready),
                     Value.cast(o.payload.data).eq(out.o_stream.payload)]
        return m
