"""Per-pixel gain/offset correction (Ning et al. 2019 §4.4.4); golden model
:func:`tdicam.model.nuc.nuc`."""

from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.model.nuc import check_nuc_params
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import quiet_reject

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

    Attributes
    ----------
    i_stream : In(pixel stream)
        ``data`` has three elements of :attr:`elem_bits` = max(pixel, gain, offset widths)
        bits: ``data[0]`` = pixel ``x`` (low ``pixel_bits``), ``data[1]`` = gain code (low
        ``gain_bits``), ``data[2]`` = offset code (low ``offset_bits``, two's complement).
        Bits above those widths are ignored (zero or sign extension both work). At the
        AXI4-Stream top each element is padded to whole bytes: with the defaults
        ``tdata[15:0]`` = x, ``tdata[31:16]`` = gain, ``tdata[47:32]`` = offset.
    o_stream : Out(pixel stream)
        ``data`` = corrected pixel, ``out_bits`` wide, saturated (never wraps);
        ``first``/``last`` pass through.

    Notes
    -----
    Three register stages (inputs, product, rounded and clamped sum), all advancing together
    when the output register is empty or taken: :attr:`latency` = 3 cycles, 1 pixel/clock
    while ``o_stream.ready`` is high, no pixel lost or duplicated whatever ``ready`` does.
    The multiplier is at most 18 x 16 bits with registered inputs and output (one ECP5
    MULT18X18D / 7-series DSP48).
    """

    @quiet_reject
    def __init__(self, *, pixel_bits=12, gain_int_bits=2, gain_frac_bits=14, offset_bits=16,
                 offset_frac_bits=0, out_bits=None):
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
            "i_stream": In(pixel_signature(channels_shape(self._elem_bits, 3))),
            "o_stream": Out(pixel_signature(unsigned(self._out_bits))),
        })

    pixel_bits = property(lambda self: self._pixel_bits)
    gain_int_bits = property(lambda self: self._gain_int_bits)
    gain_frac_bits = property(lambda self: self._gain_frac_bits)
    offset_bits = property(lambda self: self._offset_bits)
    offset_frac_bits = property(lambda self: self._offset_frac_bits)
    out_bits = property(lambda self: self._out_bits)
    elem_bits = property(lambda self: self._elem_bits,
                         doc="Width of each input element (x, gain, offset).")

    @property
    def gain_bits(self):
        return self._gain_int_bits + self._gain_frac_bits

    @property
    def latency(self):
        """Cycles from an input transfer to the corresponding output being valid."""
        return 3

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

        v1, x1, g1 = Signal(), Signal(unsigned(pb)), Signal(unsigned(gb))
        off1, f1, l1 = Signal(signed(ob)), Signal(), Signal()
        v2, p2, off2 = Signal(), Signal(unsigned(pb + gb)), Signal(signed(ob))
        f2, l2 = Signal(), Signal()

        # unsigned datapath: offset biased by 2**(ob-1) (MSB flipped), bias removed after the
        # shift; exact because offset_frac_bits < offset_bits
        bias = 1 << (ob - 1 - of)
        acc = (p2 << (frac - gf)) + (Cat(off2[:ob - 1], ~off2[ob - 1]) << (frac - of))
        if frac:
            acc = (acc + (1 << (frac - 1))) >> frac
        y = Signal(unsigned(acc.shape().width))
        m.d.comb += y.eq(acc)
        sat = Mux(y < Const(bias, y.shape()), Const(0, y.shape()),
                  Mux(y > Const(top + bias, y.shape()), Const(top, y.shape()), y - bias))

        with m.If(en):
            m.d.sync += [
                v1.eq(i.valid),
                x1.eq(i.payload.data[0][:pb]),
                g1.eq(i.payload.data[1][:gb]),
                off1.eq(i.payload.data[2][:ob]),
                f1.eq(i.payload.first),
                l1.eq(i.payload.last),
                v2.eq(v1), p2.eq(x1 * g1), off2.eq(off1), f2.eq(f1), l2.eq(l1),
                o.valid.eq(v2),
                o.payload.data.eq(sat),
                o.payload.first.eq(f2),
                o.payload.last.eq(l2),
            ]
        return m
