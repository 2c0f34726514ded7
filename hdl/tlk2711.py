"""The camera's output links: the parallel side of one or two TI TLK2711 transmitters.

The framing, the packing of pixels into 16-bit words and the split of the image across the
links (interleaved columns) are :mod:`tdicam.model.tlk2711`'s, which is also the golden
model; the word values (IDLE, the markers, the CRC) are imported from it.

Structure::

    processing clock ("sync")                    | link clock (LINK_DOMAIN, with crossing)
                                                 |
    i_stream: ppc pixels a beat                  |
      -> Widener (when a beat gives a link fewer |
         than 16 bits: beats gathered into one   |
         entry, closed early at a row's end)     |
      -> AsyncFIFO write ===== crossing ======> AsyncFIFO read (``crossing``; in one
                                                 |    clock a SyncFIFO, the same depth)
                                                 |  -> Tlk2711Framer: header, gearbox (each
                                                 |     link's pixels packed into 16-bit
                                                 |     words), CRC, trailer; one word a link
                                                 |     a clock, the links in lockstep
                                                 |  -> o_stream (the words), or with ``pins``
                                                 |     each link's TXD/TKLSB/TKMSB registers,
                                                 |     IDLE whenever there is no word
"""

from amaranth.hdl import Cat, Const, DomainRenamer, Module, Mux, Signal, Value
from amaranth.lib import data, fifo, stream, wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError, check_choice, check_range
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import equals, quiet_reject
from tdicam.model import tlk2711
from tdicam.beats import PPC_CHOICES

__all__ = ["Tlk2711", "Tlk2711Framer", "Widener", "entry_pixels", "entry_layout",
           "LINK_DOMAIN", "WORD_BITS", "pin_names", "crc16_matrix"]

#: The clock domain of the links' reference clock (ports ``link_clk``/``link_rst`` of a top
#: with ``crossing``).
LINK_DOMAIN = "link"

#: Bits of a word on ``o_stream``: ``TXD[15:0]``, ``TKLSB`` (bit 16), ``TKMSB`` (bit 17).
WORD_BITS = 18

_WAIT, _HDR, _PAY, _TRL = range(4)


def pin_names(link):
    """The top's ports of link ``link``: (TXD[15:0], TKLSB, TKMSB)."""
    return f"link{link}_txd", f"link{link}_tklsb", f"link{link}_tkmsb"


def crc16_matrix():
    """The CRC register after a word as XOR masks: ``(from_crc, from_word)``, 16 masks each;
    bit ``o`` of the new register is the parity of ``crc & from_crc[o]`` and ``word &
    from_word[o]`` (the CRC is linear in both; evaluated on unit vectors with
    :func:`tdicam.model.tlk2711.crc16_update`)."""
    cols_c = [tlk2711.crc16_update(1 << k, 0) for k in range(16)]
    cols_w = [tlk2711.crc16_update(0, 1 << k) for k in range(16)]
    from_crc = [sum(1 << k for k in range(16) if cols_c[k] >> o & 1) for o in range(16)]
    from_word = [sum(1 << k for k in range(16) if cols_w[k] >> o & 1) for o in range(16)]
    return from_crc, from_word


def _crc_step(crc, w):
    from_crc, from_word = crc16_matrix()
    return Cat(*(((crc & fc) ^ (w & fw)).xor() for fc, fw in zip(from_crc, from_word)))


def _unpack(payload_data, count):
    """The elements of a pixel stream's ``data`` as a list (one for a plain value)."""
    return [payload_data] if count == 1 else [payload_data[k] for k in range(count)]


def entry_pixels(ppc, links, pixel_bits):
    """Pixels of an entry the framer takes: the least ``ppc * 2**k`` that gives every link at
    least one pixel and 16 bits (so the framer, one entry a clock, can send a word a link
    a clock and catch up after a row's header and trailer)."""
    p = ppc
    while p < links or p // links * pixel_bits < 16:
        p *= 2
    return p


def entry_layout(pixel_bits, pixels, links):
    """An entry: ``data`` (``pixels`` pixels, element 0 the leftmost), ``first``, ``last``
    and ``count``, the valid pixels a link (``pixels / links``, fewer in a row's last entry
    when the row is not a whole number of entries; the pixels past them are 0)."""
    return data.StructLayout({"data": channels_shape(pixel_bits, pixels), "first": 1,
                              "last": 1, "count": range(pixels // links + 1)})


class Widener(wiring.Component):
    """``beats`` beats of ``ppc`` pixels in, one entry of ``beats * ppc`` pixels out
    (:func:`entry_layout`; pixel 0 the first beat's), closed early by a row's last beat:
    the entry then holds the row's remaining beats, zeros after them, and their count.

    ``first`` from the entry's first beat, ``last`` from its last. The beats before the last
    wait in registers, the last passes through (combinational ``valid``/``ready``):
    :attr:`latency` 0 from the beat that closes the entry. With two links every row must
    have an even number of pixels (an entry's pixels alternate between the links).
    """

    def __init__(self, *, pixel_bits, ppc, beats, links):
        self._bits, self._ppc, self._n, self._links = pixel_bits, ppc, beats, links
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, ppc))),
            "o_stream": Out(stream.Signature(entry_layout(pixel_bits, beats * ppc, links)))})

    latency = property(lambda self: 0, doc="Cycles from the beat that closes an entry to "
                                           "the entry.")

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        n, w = self._n, self._bits * self._ppc
        k = Signal(range(n), name="beats_held")
        held = [Signal(w, name=f"held{j}") for j in range(n - 1)]
        first = Signal()
        close = (k == n - 1) | i.payload.last
        beat = Value.cast(i.payload.data)
        slots = [Mux(k > j, held[j], Mux(equals(k, j), beat, 0)) for j in range(n - 1)]
        slots.append(Mux(equals(k, n - 1), beat, 0))
        m.d.comb += [
            o.valid.eq(i.valid & close), i.ready.eq(~close | o.ready),
            Value.cast(o.payload.data).eq(Cat(*slots)),
            o.payload.first.eq(Mux(equals(k, 0), i.payload.first, first)),
            o.payload.last.eq(i.payload.last),
            # (k + 1) beats of ppc pixels, split over the links (powers of two: shifts)
            o.payload.count.eq(((k + 1) * self._ppc) >> (self._links - 1)),
        ]
        with m.If(i.valid & i.ready):
            with m.If(close):
                m.d.sync += k.eq(0)
            with m.Else():
                m.d.sync += k.eq(k + 1)
                with m.If(equals(k, 0)):
                    m.d.sync += first.eq(i.payload.first)
                for j in range(n - 1):
                    with m.If(equals(k, j)):
                        m.d.sync += held[j].eq(beat)
        return m


class Tlk2711Framer(wiring.Component):
    """Entries of ``pixels`` pixels in, every link's framed words out, one word a link a
    clock, the links in lockstep (:mod:`tdicam.model.tlk2711`'s framing, bit-exact).

    Parameters
    ----------
    pixel_bits : int
        1..16.
    pixels : int
        Pixels an input entry; a multiple of ``links``: entry pixel ``j`` goes to link ``j
        mod links`` (a row's entries start at an even column).
    links : {1, 2}

    Attributes
    ----------
    i_stream : In(stream of :func:`entry_layout`)
        A row's entries in order; ``last`` on the row's last entry; ``first`` (read at a
        row's first entry only) starts a frame; ``count`` valid pixels a link (the pixels
        past them 0).
    o_stream : Out(pixel stream of ``links`` x 18 bits)
        Beat ``k`` holds word ``k`` of every link (``TXD | TKLSB << 16 | TKMSB << 17``):
        exactly :func:`tdicam.model.tlk2711.tlk2711`'s columns, without fill. ``first`` on a
        frame's first word (the IDLE before SOF), ``last`` on each row's CRC word.

    Notes
    -----
    A row's header words (IDLE IDLE [SOF FNUM IDLE IDLE] SOL LNUM) come from a counter, its
    payload from a gearbox per link: the link's ``count * pixel_bits`` bits of an entry (at
    most ``C = pixels / links * pixel_bits``) are appended to an accumulator of ``fill``
    bits at bit ``fill`` (a shift by 0..15), a word leaves from its bottom 16 bits whenever
    ``fill >= 16``, and an entry is taken while fewer than 16 bits remain after this
    cycle's word; the row's last entry rounds ``fill`` up to a whole word (zero padding).
    With ``C >= 16`` (:func:`entry_pixels`) the framer takes entries as fast as the links
    send their bits. The CRC register moves with each LNUM and payload word (16 bits a
    clock, :func:`crc16_matrix`), the trailer (EOL CRC) follows the last payload word
    directly. So a link sends a word on every clock as long as the input keeps up, and
    exactly :func:`~tdicam.model.tlk2711.frame_words` words a frame.

    Backpressure: ``o_stream`` is an output register; the framer moves when it is empty or
    taken. ``i_stream.ready`` (which does not depend on ``valid``) is high while the gearbox
    has room and the row has not ended. :attr:`latency` = 1 cycle from a row's first entry
    taken (the framer idle, the sink ready) to the row's first word (an IDLE) valid.
    """

    @quiet_reject
    def __init__(self, *, pixel_bits=16, pixels=1, links=1):
        self._bits = check_range("pixel_bits", pixel_bits, *tlk2711.PIXEL_BITS)
        self._links = tlk2711.check_links(links)
        self._pixels = check_range("pixels", pixels, links, None)
        if pixels % links:
            raise TdicamError(f"pixels = {pixels} an entry is not a multiple of links = "
                              f"{links}")
        super().__init__({
            "i_stream": In(stream.Signature(entry_layout(pixel_bits, pixels, links))),
            "o_stream": Out(pixel_signature(channels_shape(WORD_BITS, links))),
        })

    pixel_bits = property(lambda self: self._bits)
    pixels = property(lambda self: self._pixels, doc="Pixels an input entry.")
    links = property(lambda self: self._links)
    chunk_bits = property(lambda self: self._pixels // self._links * self._bits,
                          doc="Bits a link takes from an entry.")
    acc_bits = property(lambda self: 16 * -(-(15 + self.chunk_bits) // 16),
                        doc="Bits of a link's accumulator: at most 15 left plus an entry, "
                            "rounded up to whole words.")
    #: Cycles from a row's first entry taken (the framer idle, the sink ready) to the row's
    #: first word valid.
    LATENCY = 1
    latency = property(lambda self: self.LATENCY, doc="See :attr:`LATENCY`.")

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        L, AW = self._links, self.acc_bits
        elems = _unpack(i.payload.data, self._pixels)
        chunks = [Cat(*elems[k::L]) for k in range(L)]

        state = Signal(2, init=_WAIT)
        seq = Signal(3)                 # header word 0..7 (HDR) or trailer word 0..1 (TRL)
        fill = Signal(range(AW + 1))
        done = Signal()                 # the row's last entry is in the gearbox
        fnum, lnum = Signal(16), Signal(16)
        accs = [Signal(AW, name=f"acc{k}") for k in range(L)]
        crcs = [Signal(16, name=f"crc{k}") for k in range(L)]
        words = _unpack(o.payload.data, L)

        go = ~o.valid | o.ready
        in_wait, in_hdr = equals(state, _WAIT), state == _HDR
        in_pay, in_trl = state == _PAY, state == _TRL
        has16 = fill >= 16
        emit_pay = go & in_pay & has16
        emit = go & ((in_wait & i.valid) | in_hdr | (in_pay & has16) | in_trl)
        room = Mux(emit_pay, fill < 32, fill < 16)
        m.d.comb += i.ready.eq(~done & room & (in_hdr | in_pay | (in_wait & go)))
        take = i.valid & i.ready

        # the gearbox: a word leaves the bottom, an entry lands at bit fill (mod 16: a word
        # leaving the same cycle lowers fill by 16 and keeps its low bits)
        fill_after = Mux(emit_pay, fill - 16, fill)
        with m.If(take):
            grown = fill_after + i.payload.count * self._bits
            whole = Cat(Const(0, 4), (grown + 15)[4:])      # rounded up to a word
            m.d.sync += [fill.eq(Mux(i.payload.last, whole, grown)),
                         done.eq(i.payload.last)]
        with m.Else():
            m.d.sync += fill.eq(fill_after)
        for acc, chunk in zip(accs, chunks):
            kept = Mux(emit_pay, acc >> 16, acc)
            m.d.sync += acc.eq(Mux(take, kept | (chunk << fill[:4]), kept))

        # the word every link sends this cycle, by state
        def header(k):
            seqw = [tlk2711.IDLE, tlk2711.IDLE, tlk2711.marker(tlk2711.K27_7, k), fnum,
                    tlk2711.IDLE, tlk2711.IDLE, tlk2711.marker(tlk2711.K28_0, k), lnum]
            v = Const(tlk2711.IDLE, WORD_BITS)
            for s, x in enumerate(seqw):
                v = Mux(equals(seq, s), x, v)
            return v
        outs = []
        for k in range(L):
            trailer = Mux(seq[0], crcs[k], tlk2711.marker(tlk2711.K29_7, k))
            outs.append(Mux(in_wait, tlk2711.IDLE,
                            Mux(in_hdr, header(k), Mux(in_pay, accs[k][:16], trailer))))
        with m.If(go):
            m.d.sync += [o.valid.eq(emit), o.payload.first.eq(in_wait & i.payload.first),
                         o.payload.last.eq(in_trl & seq[0])]
            m.d.sync += [w.eq(x) for w, x in zip(words, outs)]

        with m.If(emit & in_wait):      # the row's first IDLE; with first, the frame's
            m.d.sync += [state.eq(_HDR), seq.eq(Mux(i.payload.first, 1, 5))]
        with m.Elif(emit & in_hdr):
            m.d.sync += seq.eq(seq + 1)
            with m.If(equals(seq, 2)):
                m.d.sync += lnum.eq(0)
            with m.If(equals(seq, 3)):
                m.d.sync += fnum.eq(fnum + 1)
            with m.If(equals(seq, 7)):
                m.d.sync += state.eq(_PAY)
                m.d.sync += [c.eq(_crc_step(Const(tlk2711.CRC_INIT, 16), lnum)) for c in crcs]
        with m.Elif(emit & in_pay):
            m.d.sync += [c.eq(_crc_step(c, a[:16])) for c, a in zip(crcs, accs)]
            with m.If(done & (fill == 16)):
                m.d.sync += [state.eq(_TRL), seq.eq(0)]
        with m.Elif(emit & in_trl):
            m.d.sync += seq.eq(1)
            with m.If(seq[0]):
                m.d.sync += [state.eq(_WAIT), done.eq(0), lnum.eq(lnum + 1)]
        return m


class Tlk2711(wiring.Component):
    """The output links: a pixel stream in, one or two TLK2711s' parallel words out.

    Parameters
    ----------
    pixel_bits : int
        1..16; packed densely (:mod:`tdicam.model.tlk2711`).
    ppc : int
        Pixels an input beat (1, 2, 4, 8).
    links : {1, 2}
        With 2, link ``L`` carries the columns ``L::2`` (rows of an even width).
    pins : bool
        False: the words on ``o_stream`` (a stream with backpressure, the form the golden
        cases co-simulate; ``ready`` low = the link sends fill IDLEs). True: each link's
        ``TXD[15:0]``, ``TKLSB``, ``TKMSB`` (:func:`pin_names`) from registers, IDLE
        whenever the framer has no word (and in reset).
    crossing : bool
        With ``pins``: the framer and the pins in the link clock's domain
        (:data:`LINK_DOMAIN`; ports ``link_clk``/``link_rst``), the entries crossing from
        the processing clock through an ``amaranth.lib.fifo.AsyncFIFO``, as the front
        end's lanes cross into it. False: one clock, a ``SyncFIFO``.
    fifo_depth : int
        Entries (of :func:`entry_pixels` pixels) of the input FIFO, a power of two >= 4.
        Besides the crossing it holds the input while a row's header and trailer leave (6
        word slots a row, 4 more a frame; the framer's gearbox takes one entry ahead), so
        an input slower than the links keeps its rate.

    Attributes
    ----------
    i_stream : In(pixel stream of ``ppc`` x ``pixel_bits``), processing clock
        Raster order; ``first`` on a frame's first beat, ``last`` on each row's last beat;
        rows of a multiple of ``max(ppc, links)`` pixels. ``ready`` (from registers: the
        input FIFO's room, the Widener's beat count) is low while the links are behind: the
        links' rate limits the stream's, never a pixel is lost.
    o_stream : Out(pixel stream of ``links`` x 18 bits)
        Without ``pins``: see :class:`Tlk2711Framer`.
    link{L}_txd, link{L}_tklsb, link{L}_tkmsb : Out(16), Out(1), Out(1)
        With ``pins``: link ``L``'s parallel port, one word a link clock.

    Notes
    -----
    Reset: ``rst`` (and with ``crossing`` also ``link_rst``, both asserted together) clears
    everything; the next frame's number is 0. :attr:`latency`: cycles from a frame's first
    entry (its first :func:`entry_pixels` pixels) taken, the links idle, to its first word:
    2 on ``o_stream`` (the FIFO, the framer), 3 on the pins; None with ``crossing`` (it
    depends on the two clocks' phases).
    """

    @quiet_reject
    def __init__(self, *, pixel_bits=16, ppc=1, links=1, pins=False, crossing=False,
                 fifo_depth=16):
        self._bits = check_range("pixel_bits", pixel_bits, *tlk2711.PIXEL_BITS)
        self._ppc = check_choice("ppc", ppc, PPC_CHOICES)
        self._links = tlk2711.check_links(links)
        self._pins, self._crossing = bool(pins), bool(crossing)
        if self._crossing and not self._pins:
            raise TdicamError("crossing needs pins: the word stream (pins off) has one clock")
        if fifo_depth < 4 or fifo_depth & (fifo_depth - 1):
            raise TdicamError(f"fifo_depth = {fifo_depth} must be a power of two >= 4")
        self._depth = fifo_depth
        ports = {"i_stream": In(pixel_signature(channels_shape(pixel_bits, ppc)))}
        if self._pins:
            for k in range(links):
                txd, lsb, msb = pin_names(k)
                ports.update({txd: Out(16, init=tlk2711.IDLE & 0xFFFF),
                              lsb: Out(1, init=1), msb: Out(1, init=0)})
        else:
            ports["o_stream"] = Out(pixel_signature(channels_shape(WORD_BITS, links)))
        super().__init__(ports)

    pixel_bits = property(lambda self: self._bits)
    ppc = property(lambda self: self._ppc)
    links = property(lambda self: self._links)
    pins = property(lambda self: self._pins)
    crossing = property(lambda self: self._crossing)
    fifo_depth = property(lambda self: self._depth)
    entry_pixels = property(lambda self: entry_pixels(self._ppc, self._links, self._bits),
                            doc="Pixels an entry of the framer (:func:`entry_pixels`).")

    @property
    def latency(self):
        """Cycles from a frame's first entry taken (the links idle) to its first word: 2 on
        ``o_stream``, 3 on the pins, None with ``crossing``."""
        if self._crossing:
            return None
        return Tlk2711Framer.LATENCY + 1 + self._pins

    @property
    def port_domains(self):
        """{port: clock domain} of the ports outside the processing clock: with
        ``crossing``, the pins in :data:`LINK_DOMAIN`."""
        if not self._crossing:
            return {}
        return {name: LINK_DOMAIN for k in range(self._links) for name in pin_names(k)}

    def elaborate(self, platform):
        m = Module()
        bits, P = self._bits, self.entry_pixels
        link = LINK_DOMAIN if self._crossing else "sync"
        framer = Tlk2711Framer(pixel_bits=bits, pixels=P, links=self._links)
        m.submodules.framer = DomainRenamer({"sync": link})(framer)
        src = self.i_stream
        count = P // self._links
        if P != self._ppc:                      # a beat gives a link fewer than 16 bits
            m.submodules.widener = wide = Widener(pixel_bits=bits, ppc=self._ppc,
                                                  beats=P // self._ppc, links=self._links)
            wiring.connect(m, wiring.flipped(self.i_stream), wide.i_stream)
            src, count = wide.o_stream, wide.o_stream.payload.count
        # the input FIFO: across the clocks with crossing; in one clock it holds the input
        # while a row's header and trailer leave (the gearbox takes one entry ahead)
        cw = len(framer.i_stream.payload.count)
        width = P * bits + 2 + cw
        if self._crossing:
            q = fifo.AsyncFIFO(width=width, depth=self._depth, w_domain="sync", r_domain=link)
        else:
            q = fifo.SyncFIFO(width=width, depth=self._depth)
        m.submodules.fifo = q
        m.d.comb += [q.w_en.eq(src.valid), src.ready.eq(q.w_rdy),
                     q.w_data.eq(Cat(Value.cast(src.payload.data), src.payload.first,
                                     src.payload.last, Const(count, cw) if isinstance(
                                         count, int) else count))]
        fi, d = framer.i_stream, q.r_data
        m.d.comb += [fi.valid.eq(q.r_rdy), q.r_en.eq(fi.ready & q.r_rdy),
                     Value.cast(fi.payload.data).eq(d[:P * bits]),
                     fi.payload.first.eq(d[P * bits]), fi.payload.last.eq(d[P * bits + 1]),
                     fi.payload.count.eq(d[P * bits + 2:])]
        fo = framer.o_stream
        if not self._pins:
            wiring.connect(m, fo, wiring.flipped(self.o_stream))
            return m
        words = _unpack(fo.payload.data, self._links)
        m.d.comb += fo.ready.eq(1)
        for k, w in enumerate(words):
            txd, lsb, msb = (getattr(self, n) for n in pin_names(k))
            sent = Mux(fo.valid, w, tlk2711.IDLE)
            m.d[link] += [txd.eq(sent[:16]), lsb.eq(sent[16]), msb.eq(sent[17])]
        return m
