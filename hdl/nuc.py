"""Per-pixel gain/offset correction (Ning et al. 2019 §4.4.4); golden model
:func:`tdicam.model.nuc.nuc`."""

from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_choice
from tdicam.model.nuc import check_nuc_params
from tdicam.beats import PPC_CHOICES
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import quiet_reject
from tdicam.hdl.vendor import ecp5_dsp

__all__ = ["Nuc"]


class Nuc(wiring.Component):
    """``y = clamp(round_half_up(gain * x + offset), 0, 2**out_bits - 1)`` per pixel.

    Parameters
    ----------
    pixel_bits : int
        Input pixel width, 8..16 (default 12).
    gain_int_bits, gain_frac_bits : int
        Unsigned gain format Q<int>.<frac> (default Q2.14; at most 18 bits: one 18x18
        multiplier).
    offset_bits, offset_frac_bits : int
        Signed two's-complement offset width and fraction bits (default 16 and 0).
    out_bits : int or None
        Output width 8..20 (``None``: ``pixel_bits``).
    ppc : int
        Pixels per clock (per beat): 1, 2, 4 or 8 (default 1).
    dsp : str
        ``"generic"`` (default: a ``*`` between fabric registers) or ``"ecp5"`` (the ECP5
        synthesis top: each lane's input registers are a MULT18X18D's own, the product
        register in the fabric beside the adder, :mod:`tdicam.hdl.vendor.ecp5_dsp`; the
        same cycles, a simulator needs :mod:`tdicam.cosim.mult18x18d`).

    Attributes
    ----------
    i_stream : In(pixel stream)
        ``data`` has ``3 * ppc`` elements of :attr:`elem_bits` = max(pixel, gain, offset
        widths) bits, pixel-major (as :func:`tdicam.beats.frames_to_beats` ``(ppc=,
        channels=3)``): for pixel ``k`` of the beat (0 the leftmost) ``data[3k]`` = pixel
        ``x`` (low ``pixel_bits``), ``data[3k + 1]`` = its gain code (low ``gain_bits``),
        ``data[3k + 2]`` = its offset code (low ``offset_bits``, two's complement): each beat
        carries ``ppc`` coefficient pairs beside its ``ppc`` pixels. Bits above those widths
        are ignored (zero or sign extension both work). At the AXI4-Stream top each element
        is padded to whole bytes: with the defaults ``tdata[15:0]`` = x, ``tdata[31:16]`` =
        gain, ``tdata[47:32]`` = offset of pixel 0, ``tdata[63:48]`` = x of pixel 1, ...
    o_stream : Out(pixel stream of ``ppc`` x ``out_bits``)
        ``data[k]`` = corrected pixel ``k`` (a plain value at ppc 1), ``out_bits`` wide,
        saturated (never wraps); ``first``/``last`` pass through (a row is ``width / ppc``
        beats; the width is not a parameter).

    Notes
    -----
    Register stages all advancing together when the output register is empty or taken: at
    ``ppc`` 1 three (inputs, product, rounded and clamped sum), at ``ppc`` 2-8 four (inputs,
    product, rounded sum, clamp): :attr:`latency` = 3, 4, 4, 4 cycles at ``ppc`` 1, 2, 4, 8;
    ``ppc`` pixels/clock while ``o_stream.ready`` is high, no pixel lost or duplicated
    whatever ``ready`` does. Each pixel lane has its own
    multiplier, at most 18 x 16 bits with registered inputs and output (``ppc`` ECP5
    MULT18X18D / 7-series DSP48).

    Raises
    ------
    TdicamError
        Bad parameters, ``ppc`` not one of 1, 2, 4, 8 (one line).
    """

    #: Multiplier descriptions (``dsp=``): ``"generic"`` (``*`` between fabric registers,
    #: mapped by the synthesis tool) or ``"ecp5"`` (MULT18X18D with its input registers,
    #: :func:`tdicam.hdl.vendor.ecp5_dsp.mult`: the same stages and cycles).
    DSPS = ecp5_dsp.DSPS

    @quiet_reject
    def __init__(self, *, pixel_bits=12, gain_int_bits=2, gain_frac_bits=14, offset_bits=16,
                 offset_frac_bits=0, out_bits=None, ppc=1, dsp="generic"):
        self._ppc = check_choice("ppc", ppc, PPC_CHOICES)
        self._dsp = check_choice("dsp", dsp, self.DSPS)
        self._out_bits = check_nuc_params(
            pixel_bits=pixel_bits, gain_int_bits=gain_int_bits,
            gain_frac_bits=gain_frac_bits, offset_bits=offset_bits,
            offset_frac_bits=offset_frac_bits, out_bits=out_bits)
        self._pixel_bits = pixel_bits
        self._gain_int_bits = gain_int_bits
        self._gain_frac_bits = gain_frac_bits
        self._offset_bits = offset_bits
        self._offset_frac_bits = offset_frac_bits
        self._elem_bits = max(pixel_bits, gain_int_bits + gain_frac_bits, offset_bits)
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(self._elem_bits, 3 * ppc))),
            "o_stream": Out(pixel_signature(channels_shape(self._out_bits, ppc))),
        })

    pixel_bits = property(lambda self: self._pixel_bits)
    gain_int_bits = property(lambda self: self._gain_int_bits)
    gain_frac_bits = property(lambda self: self._gain_frac_bits)
    offset_bits = property(lambda self: self._offset_bits)
    offset_frac_bits = property(lambda self: self._offset_frac_bits)
    out_bits = property(lambda self: self._out_bits)
    elem_bits = property(lambda self: self._elem_bits,
                         doc="Width of each input element (x, gain, offset).")

    ppc = property(lambda self: self._ppc, doc="Pixels per clock (per beat).")
    dsp = property(lambda self: self._dsp, doc="Multiplier description, one of :attr:`DSPS`.")

    @property
    def gain_bits(self):
        return self._gain_int_bits + self._gain_frac_bits

    @property
    def latency(self):
        """Cycles from an input transfer to the corresponding output being valid: 3 at
        ``ppc`` 1, 4 at ``ppc`` 2, 4 and 8."""
        return 3 if self._ppc == 1 else 4

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        pb, gb, ob = self._pixel_bits, self.gain_bits, self._offset_bits
        gf, of = self._gain_frac_bits, self._offset_frac_bits
        frac = max(gf, of)
        top = (1 << self._out_bits) - 1

        # global-enable pipeline: every stage moves when the output register can take a pixel
        en = Signal()
        m.d.comb += [en.eq(~o.valid | o.ready), i.ready.eq(en)]

        # lane 0 (the only one at ppc 1) declared as before ppc existed: the generated Verilog
        # at ppc 1 is byte-identical to the earlier single-pixel design's
        v1, x1, g1 = Signal(), Signal(unsigned(pb)), Signal(unsigned(gb))
        off1, f1, l1 = Signal(signed(ob)), Signal(), Signal()
        v2, p2, off2 = Signal(), Signal(unsigned(pb + gb)), Signal(signed(ob))
        f2, l2 = Signal(), Signal()
        x1s, g1s, off1s, p2s, off2s = [x1], [g1], [off1], [p2], [off2]
        for k in range(1, self._ppc):
            x1s.append(Signal(unsigned(pb), name=f"x1_{k}"))
            g1s.append(Signal(unsigned(gb), name=f"g1_{k}"))
            off1s.append(Signal(signed(ob), name=f"off1_{k}"))
            p2s.append(Signal(unsigned(pb + gb), name=f"p2_{k}"))
            off2s.append(Signal(signed(ob), name=f"off2_{k}"))

        # ppc 1: the design of before ppc existed, an unsigned datapath (offset biased by
        # 2**(ob-1), MSB flipped; bias removed after the shift, exact as offset_frac_bits <
        # offset_bits) clamped by compares (a bit clamp made yosys 0.70's ABC9 assert at
        # ppc 1). ppc 2-8: the signed sum (floor shift, round half up with the half added)
        # registered, then clamped by reading its bits (the sign, any bit above out_bits):
        # nothing after the adder's carry chain, a LUT a bit after the register
        ow = self._out_bits
        bias = 1 << (ob - 1 - of)
        sats, sums, v3, f3, l3 = [], [], Signal(), Signal(), Signal()
        for k, (p2, off2) in enumerate(zip(p2s, off2s)):
            if self._ppc == 1:
                acc = (p2 << (frac - gf)) + (Cat(off2[:ob - 1], ~off2[ob - 1]) << (frac - of))
                if frac:
                    acc = (acc + (1 << (frac - 1))) >> frac
                y = Signal(unsigned(acc.shape().width), name="y")
                m.d.comb += y.eq(acc)
                # a narrow sum (top + bias beyond its range) never exceeds the top: no upper
                # compare (a Const of top + bias in y's width would be truncated)
                keep = y - bias
                if top + bias < 1 << len(y):
                    keep = Mux(y > Const(top + bias, y.shape()), Const(top, y.shape()), keep)
                sats.append(Mux(y < Const(bias, y.shape()), Const(0, y.shape()), keep))
                continue
            acc = (p2 << (frac - gf)) + (off2 << (frac - of))
            if frac:
                acc = acc + (1 << (frac - 1))
            y = Signal(signed(acc.shape().width - frac), name=f"y_{k}" if k else "y")
            sums.append(y.eq(acc[frac:]))
            over = y[ow:-1].any() if len(y) - 1 > ow else Const(0)
            sats.append(Mux(y[-1], 0, Mux(over, top, y[:ow])))
        # pixel k of the beat: elements 3k (x), 3k + 1 (gain), 3k + 2 (offset)
        d, rng = i.payload.data, range(self._ppc)
        outs = [o.payload.data] if self._ppc == 1 else [o.payload.data[k] for k in rng]

        # ecp5: x1 and g1 are the DSP blocks' input registers, p2 loads their product
        fabric = self._dsp != "ecp5"
        prods = ([x1s[k] * g1s[k] for k in rng] if fabric else
                 [ecp5_dsp.mult(m, f"mul{k}", d[3 * k][:pb], d[3 * k + 1][:gb], en)
                  for k in rng])
        lanes = rng if fabric else ()
        with m.If(en):
            m.d.sync += [
                v1.eq(i.valid),
                *(x1s[k].eq(d[3 * k][:pb]) for k in lanes),
                *(g1s[k].eq(d[3 * k + 1][:gb]) for k in lanes),
                *(off1s[k].eq(d[3 * k + 2][:ob]) for k in rng),
                f1.eq(i.payload.first),
                l1.eq(i.payload.last),
                v2.eq(v1), *(p2s[k].eq(prods[k]) for k in rng),
                *(off2s[k].eq(off1s[k]) for k in rng), f2.eq(f1), l2.eq(l1),
                # ppc 2-8: the sum stage between the product and the output register
                *((v3.eq(v2), f3.eq(f2), l3.eq(l2), *sums) if sums else ()),
                o.valid.eq(v3 if sums else v2),
                *(outs[k].eq(sats[k]) for k in rng),
                o.payload.first.eq(f3 if sums else f2),
                o.payload.last.eq(l3 if sums else l2),
            ]
        return m
