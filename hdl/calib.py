"""Calibration store reader: ECC-protected flash words in, ``nuc`` coefficients out
(Ning et al. 2019 §4.3). Image format and golden model:
:mod:`tdicam.model.calib`."""

from amaranth.hdl import Cat, Const, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.beats import PPC_CHOICES
from tdicam.errors import TdicamError, check_choice, check_range
from tdicam.model.calib import (DEFAULT_COUNT_BITS, HEADER_WORDS, MAX_SIDE, header_words,
                                payload_words)
from tdicam.model.nuc import NucFormat
from tdicam.hdl.ecc import correct, syndrome
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import quiet_reject

__all__ = ["CalibReader", "CoeffBuffer", "DEBUG_ELEMENTS"]

#: output elements with ``debug``: gain, offset, corrected count, uncorrectable count, flags
DEBUG_ELEMENTS = 5


class CalibReader(wiring.Component):
    """Read a calibration image from a stream of flash words; stream the decoded
    coefficients in raster order to the ``nuc`` block.

    Parameters
    ----------
    rows, cols : int
        Image size the reader is built for, 1..65535 each (default 3800 x 5144, the
        GMAX0504 of Ning et al. 2019).
    gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits : int
        Coefficient format, the ``nuc`` block's parameters (:class:`~tdicam.model.nuc.
        NucFormat`; gain and offset at most 16 bits each for the flash packing).
    count_bits : int
        Width of the saturating word counters, 8..32 (default 32).
    debug : bool
        Also carry, on every output pixel, the counters and flags (see ``o_stream``): the
        co-simulation checks them pixel by pixel. Only at ``ppc`` 1.
    ppc : int
        Pixels per output beat, 1, 2, 4 or 8 (``cols`` a multiple of it): at ``ppc`` >= 2
        every input beat carries ``ppc / 2`` flash words (the pixels of one output beat)
        and every output beat ``ppc`` pixels' coefficients (the ``nuc`` block's side input
        at the same ppc).

    Attributes
    ----------
    i_stream : In(pixel stream)
        One flash word per transfer (``max(1, ppc / 2)`` words, the first in the least
        significant bytes): ``data`` = 9 bytes a word, element ``k < 8`` = data byte ``k``
        (least significant first), element 8 = the check byte (the image file's bytes in
        order; AXI ``tdata[71:0]`` = the 72-bit code word ``{check, data}``). ``first`` and
        ``last`` are ignored: the reader counts words from reset -- 4 header words, then
        ``ceil(rows*cols/2)`` payload words, then the next image's header.
    o_stream : Out(pixel stream)
        One pixel's coefficients per transfer (``ppc`` pixels', pixel-major: gain then
        offset of the leftmost pixel first), raster order; ``first`` on pixel 0 of an
        image, ``last`` on the last pixel of each row. ``data`` elements of
        ``max(gain_bits, offset_bits)`` bits (``count_bits`` with ``debug``):
        ``data[0]`` = gain code, ``data[1]`` = offset code (two's complement in the low
        ``offset_bits``, zero above): the ``nuc`` input's gain and offset elements. With
        ``debug``: ``data[2]``/``data[3]`` = corrected/uncorrectable counts up to and
        including this pixel's word, ``data[4]`` bit 0 = default coefficients substituted,
        bit 1 = the image's header was bad.
    corrected_count, uncorrectable_count : Out(count_bits)
        Words (header and payload) decoded with a corrected single error / with an
        uncorrectable error since reset; saturating.
    header_error : Out(1)
        The last header read was bad: a header word uncorrectable or its decoded contents
        differing from this reader's parameters (magic, version, size, format, packing,
        word count; the CRC field is not checked). Every pixel of that image then gets the
        default coefficients.

    Notes
    -----
    An uncorrectable payload word gives its two pixels (four coefficients) the defaults,
    gain 1.0 (``1 << gain_frac_bits``) and offset 0. The decoder runs over two register
    stages (each word's syndrome beside its data, then the corrected word: the decoded word
    register the header check and counters work from); a pending and a current word
    register follow: :attr:`latency` = 4 cycles from the
    transfer of a payload word to its first pixel being valid. One pixel per clock
    while the source delivers a word every other clock and ``o_stream.ready`` is high (at
    ``ppc`` >= 2: one beat of ``ppc`` pixels per clock while it delivers a beat of words
    per clock);
    ``i_stream.ready`` depends only on registers (at ``ppc`` >= 2 also on
    ``o_stream.ready``); no word or pixel is lost or duplicated whatever ``ready`` does.
    """

    @quiet_reject
    def __init__(self, *, rows=3800, cols=5144, gain_int_bits=2, gain_frac_bits=14,
                 offset_bits=16, offset_frac_bits=0, count_bits=DEFAULT_COUNT_BITS,
                 debug=False, ppc=1):
        self._rows = check_range("rows", rows, 1, MAX_SIDE)
        self._cols = check_range("cols", cols, 1, MAX_SIDE)
        check_choice("ppc", ppc, PPC_CHOICES)
        if cols % ppc:
            raise TdicamError(f"cols = {cols} is not a multiple of ppc = {ppc}")
        if debug and ppc > 1:
            raise TdicamError(f"debug needs ppc = 1 (per-pixel counters), got ppc = {ppc}")
        self._ppc = ppc
        self._words = max(1, ppc // 2)
        self._fmt = NucFormat(gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits)
        self._fmt._check_slots()
        self._count_bits = check_range("count_bits", count_bits, 8, 32)
        self._debug = bool(debug)
        fmt = self._fmt
        ebits = max(fmt.gain_bits, fmt.offset_bits, self._count_bits if debug else 0)
        self._elem_bits = ebits
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(8, 9 * self._words))),
            "o_stream": Out(pixel_signature(channels_shape(
                ebits, DEBUG_ELEMENTS if debug else 2 * ppc))),
            "corrected_count": Out(self._count_bits),
            "uncorrectable_count": Out(self._count_bits),
            "header_error": Out(1),
        })

    rows = property(lambda self: self._rows)
    cols = property(lambda self: self._cols)
    fmt = property(lambda self: self._fmt, doc="The coefficient format (NucFormat).")
    count_bits = property(lambda self: self._count_bits)
    debug = property(lambda self: self._debug)
    ppc = property(lambda self: self._ppc)
    words_per_beat = property(lambda self: self._words,
                              doc="Flash words in each input beat: max(1, ppc / 2).")
    elem_bits = property(lambda self: self._elem_bits)

    @property
    def latency(self):
        """Cycles from a payload word's transfer to its first pixel being valid."""
        return 4

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        fmt, cb = self._fmt, self._count_bits
        rows, cols = self._rows, self._cols
        ppc, k = self._ppc, self._words          # pixels per output beat, words per beat
        n_pay = payload_words(rows, cols) // k   # payload beats
        odd = (rows * cols) % 2 == 1
        cols = cols // ppc                       # beats per row

        # ---- decode, over two stages (the syndromes registered beside the data, then the
        # correction; the decode in one cycle from the flash's register was the slowest path
        # of both chains at ppc 8, 6.2-7.4 ns): E holds syndromes and data, D the decoded
        # words (the header check and counters work from them)
        codes = [Cat(i.payload.data)] if k == 1 else \
            [Cat(i.payload.data[9 * j + b] for b in range(9)) for j in range(k)]
        e_valid = Signal(name="e_valid")
        e_syn = [Signal(8, name=f"e_syn{j}") for j in range(k)]
        e_dat = [Signal(64, name=f"e_data{j}") for j in range(k)]
        fixed = [correct(m, s, d) for s, d in zip(e_syn, e_dat)]
        d_valid, d_data = Signal(name="d_valid"), Signal(64 * k, name="d_data")
        d_cor, d_unc = Signal(k, name="d_cor"), Signal(k, name="d_unc")
        d_go = Signal()  # the decoded word is consumed this cycle
        d_adv, e_adv = Signal(name="d_adv"), Signal(name="e_adv")  # D, E take a word

        # ---- input side: header check, counters, pending word
        in_header = Signal(init=1)
        hidx = Signal(range(HEADER_WORDS // k))
        widx = Signal(range(max(n_pay, 2)))
        hdr_bad = Signal()        # hdr_acc | hdr_last: the header read so far was bad
        hdr_acc = Signal()        # its words before the last consumed one
        hdr_last = Signal()       # the last consumed header word (registered compare)
        cor = Signal(cb)
        unc = Signal(cb)
        top = (1 << cb) - 1
        cor_next = Signal(cb)
        unc_next = Signal(cb)
        if k == 1:
            m.d.comb += [cor_next.eq(Mux(d_cor & (cor != top), cor + 1, cor)),
                         unc_next.eq(Mux(d_unc & (unc != top), unc + 1, unc))]
        else:                                    # several words a beat: add, saturate
            for nxt, cnt, flags in ((cor_next, cor, d_cor), (unc_next, unc, d_unc)):
                total = cnt + sum(flags[j] for j in range(k))
                m.d.comb += nxt.eq(Mux(total > top, top, total))
        m.d.comb += [
            self.corrected_count.eq(cor), self.uncorrectable_count.eq(unc),
            self.header_error.eq(hdr_bad), hdr_bad.eq(hdr_acc | hdr_last),
        ]

        p_valid, p_data, p_bad, p_hbad = Signal(), Signal(64 * k), Signal(k), Signal()
        p_cor, p_unc, p_single = Signal(cb), Signal(cb), Signal()
        # at ppc >= 2 a payload beat is one output beat: the pending word moves on in the
        # cycle the next one arrives (one beat a clock; i.ready then follows o.ready)
        load_cur = Signal()
        free = ~p_valid if ppc == 1 else ~p_valid | load_cur
        m.d.comb += [
            d_go.eq(d_valid & (in_header | free)),
            d_adv.eq(~d_valid | d_go),
            e_adv.eq(~e_valid | d_adv),
            i.ready.eq(e_adv),
        ]
        with m.If(e_adv):
            m.d.sync += e_valid.eq(i.valid)
            for j, code in enumerate(codes):
                syn, dat = syndrome(code)
                m.d.sync += [e_syn[j].eq(syn), e_dat[j].eq(dat)]
        with m.If(d_adv):
            m.d.sync += [d_valid.eq(e_valid), d_data.eq(Cat(f[0] for f in fixed)),
                         d_cor.eq(Cat(f[1] for f in fixed)),
                         d_unc.eq(Cat(f[2] for f in fixed))]

        def word(j, what=d_data, bits=64):       # word j of a beat (the whole at k = 1)
            return what if k == 1 else what[bits * j:bits * (j + 1)]

        expect = header_words(self._rows, self._cols, fmt)
        mismatch = Signal()
        with m.Switch(hidx):
            for h in range(HEADER_WORDS // k):
                bad = []
                for j in range(k):
                    n = h * k + j
                    mask = 0xFFFF_FFFF if n == 3 else (1 << 64) - 1  # word 3: CRC not checked
                    bad.append(word(j, d_unc, 1) | ((word(j) & mask) != (expect[n] & mask)))
                with m.Case(h):
                    m.d.comb += mismatch.eq(Cat(bad).any() if k > 1 else bad[0])

        # ---- output side: current word, pixel position
        c_valid, c_data, c_bad, c_hbad = Signal(), Signal(64 * k), Signal(k), Signal()
        c_cor, c_unc, c_single, c_idx = Signal(cb), Signal(cb), Signal(), Signal()
        row = Signal(range(max(rows, 2)))  # >= 1 bit: no zero-width vectors in Verilog
        col = Signal(range(max(cols, 2)))
        take = Signal()
        cur_done = Signal()
        m.d.comb += [
            take.eq(o.valid & o.ready),
            cur_done.eq(take & (c_idx | c_single) if ppc == 1 else take),
            load_cur.eq(p_valid & (~c_valid | cur_done)),
        ]

        with m.If(load_cur):
            m.d.sync += p_valid.eq(0)
        with m.If(d_go):
            m.d.sync += [cor.eq(cor_next), unc.eq(unc_next)]
            with m.If(in_header):
                m.d.sync += [hdr_last.eq(mismatch), hdr_acc.eq(hidx.any() & hdr_bad)]
                with m.If(hidx == HEADER_WORDS // k - 1):
                    m.d.sync += [hidx.eq(0), in_header.eq(0), widx.eq(0)]
                with m.Else():
                    m.d.sync += hidx.eq(hidx + 1)
            with m.Else():
                m.d.sync += [p_valid.eq(1), p_data.eq(d_data),
                             p_bad.eq(d_unc | hdr_bad if k == 1 else
                                      Mux(hdr_bad, Const(-1, k), d_unc)),
                             p_hbad.eq(hdr_bad),
                             p_cor.eq(cor_next), p_unc.eq(unc_next),
                             p_single.eq(int(odd) & (widx == n_pay - 1))]
                with m.If(widx == n_pay - 1):
                    m.d.sync += [widx.eq(0), in_header.eq(1)]
                with m.Else():
                    m.d.sync += widx.eq(widx + 1)

        with m.If(load_cur):
            m.d.sync += [c_valid.eq(1), c_data.eq(p_data), c_bad.eq(p_bad), c_hbad.eq(p_hbad),
                         c_cor.eq(p_cor), c_unc.eq(p_unc), c_single.eq(p_single),
                         c_idx.eq(0)]
        with m.Elif(cur_done):
            m.d.sync += c_valid.eq(0)
        with m.Elif(take):
            m.d.sync += c_idx.eq(1)

        with m.If(take):
            with m.If(col == cols - 1):
                m.d.sync += col.eq(0)
                m.d.sync += row.eq(Mux(row == rows - 1, 0, row + 1))
            with m.Else():
                m.d.sync += col.eq(col + 1)

        # slots of a word: gain0, offset0, gain1, offset1 (16 bits each)
        if ppc == 1:
            halves = [(Mux(c_idx, c_data[32:], c_data[:32]), c_bad)]
        else:                                    # every pixel of the beat's words
            halves = [(c_data[32 * p:32 * (p + 1)], word(p // 2, c_bad, 1))
                      for p in range(ppc)]
        elems = []
        for half, bad in halves:
            elems += [Mux(bad, fmt.gain_one, half[:fmt.gain_bits]),
                      Mux(bad, 0, half[16:16 + fmt.offset_bits])]
        if self._debug:
            elems += [c_cor, c_unc, Cat(c_bad, c_hbad)]
        slots = []
        for e in elems:
            sig = Signal(self._elem_bits)
            m.d.comb += sig.eq(e)  # unsigned: zero-extended
            slots.append(sig)
        m.d.comb += [
            o.valid.eq(c_valid),
            o.payload.first.eq(~row.any() & ~col.any()),
            o.payload.last.eq(col == cols - 1),
            Cat(o.payload.data).eq(Cat(slots)),
        ]
        return m


class CoeffBuffer(wiring.Component):
    """The decoded calibration kept on chip: ``rows`` x ``cols`` coefficient pairs written
    once (the power-up load from flash), then streamed again and again, one frame of
    coefficients after another, to the ``nuc`` block.

    Parameters
    ----------
    rows, cols : int
        The image (``cols`` a multiple of ``ppc``).
    elem_bits : int
        Width of each coefficient element (:attr:`CalibReader.elem_bits`).
    ppc : int
        Pixels per output beat, 1, 2, 4 or 8.

    Attributes
    ----------
    i_stream : In(pixel stream of 2 elements)
        The load: one pixel's (gain, offset) a beat in raster order, as
        :class:`CalibReader`'s ``o_stream`` at ``ppc`` 1 (markers ignored); taken one a
        clock until ``rows * cols`` pixels have been written, refused after.
    o_stream : Out(pixel stream of ``2 * ppc`` elements)
        Once loaded: the image in raster order, ``ppc`` pixels' (gain, offset) a beat
        (pixel-major, as :class:`CalibReader`'s ``o_stream`` at ``ppc``), ``first`` on
        pixel 0, ``last`` on each row's last beat, again and again; nothing before.
    loaded : Out(1)
        Every pixel has been written (stays high until reset).

    Notes
    -----
    One memory of ``rows * cols / ppc`` words of ``2 * elem_bits * ppc`` bits; ``ppc``
    loaded pixels are gathered in a register before each write. The output goes through
    the memory's read port and an output register (two stages, as :class:`~tdicam.hdl.
    calib_rom.CalibRom`): one beat a clock while ``o_stream.ready`` is high.
    """

    @quiet_reject
    def __init__(self, *, rows, cols, elem_bits, ppc=1):
        self._rows = check_range("rows", rows, 1, MAX_SIDE)
        self._cols = check_range("cols", cols, 1, MAX_SIDE)
        if ppc not in PPC_CHOICES or cols % ppc:
            raise TdicamError(f"coefficient buffer: ppc = {ppc} must be "
                              f"{', '.join(map(str, PPC_CHOICES[:-1]))} or {PPC_CHOICES[-1]} "
                              f"and divide cols = {cols}")
        self._ppc, self._ebits = ppc, elem_bits
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(elem_bits, 2))),
            "o_stream": Out(pixel_signature(channels_shape(elem_bits, 2 * ppc))),
            "loaded": Out(1),
        })

    def elaborate(self, platform):
        from amaranth.lib.memory import Memory
        m = Module()
        ppc, eb = self._ppc, self._ebits
        per_row = self._cols // ppc
        n = self._rows * per_row
        wbits = 2 * eb * ppc
        m.submodules.mem = mem = Memory(shape=wbits, depth=max(n, 2), init=[])
        wr, rd = mem.write_port(), mem.read_port()
        i, o = self.i_stream, self.o_stream
        # load: gather ppc pixels, write one word
        waddr = Signal(range(n + 1))
        gather = Signal(wbits)
        k = Signal(range(ppc + 1))
        m.d.comb += [i.ready.eq(~self.loaded), wr.addr.eq(waddr)]
        pix = Cat(i.payload.data)
        nxt = Cat(gather[2 * eb:], pix) if ppc > 1 else pix
        with m.If(i.valid & i.ready):
            m.d.sync += gather.eq(nxt)
            if ppc > 1:
                m.d.sync += k.eq(Mux(k == ppc - 1, 0, k + 1))
            with m.If(k == ppc - 1 if ppc > 1 else 1):
                m.d.comb += [wr.en.eq(1), wr.data.eq(nxt)]
                m.d.sync += waddr.eq(waddr + 1)
                with m.If(waddr == n - 1):
                    m.d.sync += self.loaded.eq(1)
        # replay: read port, then an output register
        addr = Signal(range(max(n, 2)))
        col = Signal(range(per_row))
        v1, f1, l1 = Signal(), Signal(), Signal()
        adv1, adv2 = Signal(), Signal()
        m.d.comb += [adv2.eq(~o.valid | o.ready), adv1.eq(~v1 | adv2),
                     rd.en.eq(adv1), rd.addr.eq(addr)]
        with m.If(adv1):
            m.d.sync += v1.eq(self.loaded)
            with m.If(self.loaded):
                m.d.sync += [f1.eq(addr == 0), l1.eq(col == per_row - 1),
                             addr.eq(Mux(addr == n - 1, 0, addr + 1)),
                             col.eq(Mux(col == per_row - 1, 0, col + 1))]
        with m.If(adv2):
            m.d.sync += [o.valid.eq(v1), Cat(o.payload.data).eq(rd.data),
                         o.payload.first.eq(f1), o.payload.last.eq(l1)]
        return m
