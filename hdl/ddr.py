"""DDR line/frame buffers behind a MIG-style user interface (SPEC 3.8, seed 002 §4.2).

Golden model, packing and addresses: :mod:`tdicam.model.ddr` (read its module docstring
first: ``app_addr`` counts 32-bit columns, a 256-bit word is 8 address steps; values packed
24 x 10 bit per word as seed 002 Table 2, first value in the most significant used bits);
the Python controller model: :mod:`tdicam.model.dram`.

Components
----------
* :class:`LineWriter` — pixel stream -> packed 256-bit words at ``base + slot * line_stride``.
* :class:`LineReader` — line requests -> read commands -> unpacked pixel stream.
* :class:`DdrFrameBuffer` — writer + reader through one port: a frame buffer of ``rows``
  lines, the output is the input after a trip through DDR.

The other DDR modules: :mod:`tdicam.hdl.interfaces.mig` (the controller's user interface and
:class:`~tdicam.hdl.interfaces.mig.MigPort`), :mod:`tdicam.hdl.simmodels.mig_model` (the simulation-only
controller :class:`~tdicam.hdl.simmodels.mig_model.MigModel` and :class:`~tdicam.hdl.simmodels.mig_model.SimTop`),
:mod:`tdicam.hdl.cds_ddr` (CDS with the reset frame in DDR) and :mod:`tdicam.hdl.tdi_ddr`
(TDI with its partial sums in DDR).
"""

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError, check_range
from tdicam.model.ddr import (ADDR_BITS, ADDR_PER_WORD, CAPACITY_BYTES, WORD_BITS, LineLayout,
                              check_capacity)
from tdicam.hdl.interfaces.mig import MigPort, connect_mig, mig_user_ports
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import equals, mux_select, quiet_reject, saturating_increment

__all__ = ["MAX_WORDS_PER_BEAT", "LineWriter", "LineReader", "DdrFrameBuffer"]


#: Most 256-bit words one beat may fill (``elements / pixels_per_word``): the writer selects
#: a beat's words through a mux chain this long (a longer one is past what Amaranth
#: elaborates: its expression nesting exceeds Python's recursion limit).
MAX_WORDS_PER_BEAT = 256


def _gear(elements, ppw):
    """(beats a word, words a beat) of ``elements`` values a beat into ``ppw``-value words."""
    if ppw % elements == 0:
        return ppw // elements, 1
    if elements % ppw == 0:
        if elements // ppw > MAX_WORDS_PER_BEAT:
            raise TdicamError(f"elements = {elements} per beat and pixels_per_word = {ppw} "
                              f"fill {elements // ppw} words a beat, more than "
                              f"{MAX_WORDS_PER_BEAT}: fewer values a beat (ppc x channels) or "
                              f"more a word")
        return 1, elements // ppw
    raise TdicamError(f"elements = {elements} per beat and pixels_per_word = {ppw}: one "
                      "must divide the other")


def _word_slices(ppw, bits):
    """(lo, hi) bit range of value j in a word (first value most significant)."""
    return [((ppw - 1 - j) * bits, (ppw - j) * bits) for j in range(ppw)]


class LineWriter(wiring.Component):
    """Pixel stream -> packed 256-bit words, one line every ``width`` beats.

    Line k of the stream goes to slot ``k mod rows`` at ``base + slot * line_stride`` (a
    beat with ``first`` at the start of a line restarts at slot 0). Beats carry
    ``elements`` values, in the layout's (pixel, channel) order. ``wr_eol`` marks a line's
    last word, ``wr_first`` its frame-start flag (``first`` on the line's first beat).
    ``line_ok`` low holds the first beat of a new line (the user's line-lead limit).
    Lines are cut by count; a ``last`` that disagrees counts in ``line_errors``.

    ``early_sums``: the next word's address added from registers only (line 0's base, the
    line's base and the current address, each plus the step), the beat's markers selecting
    among the sums, instead of the markers selecting the address before one adder (the
    whole Ning et al. 2019 camera at ppc 8: ``nuc_ddr``'s coefficient writer, the beat's
    ``first`` into the 24-bit increment, 9.43 ns); the same addresses. With it, when a beat
    fills less than a word or exactly one (``elements`` divides ``pixels_per_word``), the
    word's registers load whenever the output is free and the gathered values every
    cycle, so the beat's ``valid`` reaches no wide enable; the same words.
    """

    @quiet_reject
    def __init__(self, *, layout, elements, rows, addr_bits=ADDR_BITS, early_sums=False):
        self._lay, self._e, self._rows, self._aw = layout, elements, rows, addr_bits
        self._early = early_sums
        if layout.values_per_line % elements:
            raise TdicamError(f"a line of {layout.values_per_line} values is not a whole "
                              f"number of {elements}-value beats")
        self._g, self._r = _gear(elements, layout.pixels_per_word)
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(layout.pixel_bits, elements))),
            "wr_valid": Out(1), "wr_ready": In(1), "wr_addr": Out(addr_bits),
            "wr_data": Out(WORD_BITS), "wr_eol": Out(1), "wr_first": Out(1),
            "line_ok": In(1), "line_start": Out(1), "busy": Out(1),
            "line_errors": Out(16)})

    def elaborate(self, platform):
        m = Module()
        lay, E, G, R = self._lay, self._e, self._g, self._r
        P, B = lay.pixels_per_word, lay.pixel_bits
        W = lay.values_per_line // E           # beats per line
        i = self.i_stream
        col = Signal(range(W))
        line_base = Signal(self._aw, init=lay.base)
        waddr = Signal(self._aw, init=lay.base)
        first_flag = Signal()
        errs = Signal(16)
        m.d.comb += self.line_errors.eq(errs)
        # col == 0 and col == W - 1 kept as registers (set a beat ahead), off the ready path
        line_start = Signal(init=1)
        last_col = Signal(init=int(W == 1))
        restart = i.payload.first & line_start
        fire = Signal()
        m.d.comb += [fire.eq(i.valid & i.ready), self.line_start.eq(fire & line_start)]
        with m.If(fire):
            m.d.sync += [line_start.eq(last_col),
                         last_col.eq(Mux(last_col, W == 1, col == W - 2))]
        beat = [i.payload.data[k] if E > 1 else i.payload.data for k in range(E)]
        end_base = lay.base + (self._rows - 1) * lay.line_stride
        next_base = Mux(restart, Const(lay.base, self._aw), line_base)
        # the slot after next_base; the compare and the add read registers only (a restart
        # selects a constant), off the path from the beat's markers
        after_base = lay.base if lay.base == end_base else lay.base + lay.line_stride
        after_line = Mux(line_base == end_base, lay.base, line_base + lay.line_stride)
        next_line = Mux(restart, Const(after_base, self._aw), after_line)

        with m.If(fire):
            with m.If(i.payload.last != last_col):
                saturating_increment(m, errs)
            with m.If(line_start):
                m.d.sync += first_flag.eq(i.payload.first)

        o_valid = Signal()
        o_data = Signal(WORD_BITS)
        o_addr = Signal(self._aw)
        o_eol, o_first = Signal(), Signal()
        m.d.comb += [self.wr_valid.eq(o_valid), self.wr_data.eq(o_data),
                     self.wr_addr.eq(o_addr), self.wr_eol.eq(o_eol),
                     self.wr_first.eq(o_first)]
        ofire = o_valid & self.wr_ready
        cur_addr = Mux(line_start, next_base, waddr)

        def after(step):
            """``cur_addr + step`` (the address ``step`` units on)."""
            if not self._early:
                return cur_addr + step
            return Mux(line_start, Mux(restart, Const(lay.base + step), line_base + step),
                       waddr + step)
        cur_first = Mux(line_start, i.payload.first, first_flag)
        if R == 1:
            k = Signal(range(max(G, 2)))
            vals = [Signal(B, name=f"v{j}") for j in range(P)]
            completes = (k == G - 1) | last_col
            m.d.comb += [
                i.ready.eq(~(completes & o_valid & ~self.wr_ready) & (~line_start | self.line_ok)),
                self.busy.eq(o_valid | k.any()),
            ]
            new_vals = []
            for j in range(P):
                g, e = divmod(j, E)
                nv = Mux(equals(k, g), beat[e], Mux(~k.any(), 0, vals[j])) if G > 1 else beat[e]
                new_vals.append(nv)
            word = Cat(*[new_vals[j] for j in reversed(range(P))], Const(0, WORD_BITS - P * B))
            held = [o_data.eq(word), o_addr.eq(cur_addr), o_eol.eq(last_col),
                    o_first.eq(cur_first)]
            if self._early:
                # the word's registers load whenever the output is free (a beat or not:
                # o_valid says which), the values every cycle (k moves on a beat only):
                # the beat's valid (the frame kind before it) reaches no wide enable
                m.d.sync += [v.eq(nv) for v, nv in zip(vals, new_vals)]
                with m.If(~o_valid | self.wr_ready):
                    m.d.sync += held
            with m.If(fire):
                if not self._early:
                    m.d.sync += [v.eq(nv) for v, nv in zip(vals, new_vals)]
                with m.If(completes):
                    m.d.sync += [o_valid.eq(1), *(() if self._early else held), k.eq(0)]
                    with m.If(last_col):
                        m.d.sync += [col.eq(0), line_base.eq(next_line), waddr.eq(next_line)]
                    with m.Else():
                        m.d.sync += [col.eq(col + 1), waddr.eq(after(ADDR_PER_WORD))]
                        with m.If(line_start):
                            m.d.sync += line_base.eq(next_base)
                with m.Else():
                    m.d.sync += [k.eq(k + 1), col.eq(col + 1), waddr.eq(cur_addr)]
                    with m.If(line_start):
                        m.d.sync += line_base.eq(next_base)
                with m.If(ofire & ~completes):
                    m.d.sync += o_valid.eq(0)
            with m.Elif(ofire):
                m.d.sync += o_valid.eq(0)
        else:
            # one beat -> R words, sent one per cycle from the held beat
            r = Signal(range(R))
            held = Signal(E * B)
            h_eol, h_first = Signal(), Signal()
            m.d.comb += self.busy.eq(o_valid)
            last_sub = r == R - 1
            m.d.comb += i.ready.eq((~o_valid | (self.wr_ready & last_sub))
                                   & (~line_start | self.line_ok))
            words = []
            for w in range(R):
                vals = [held[(w * P + j) * B:(w * P + j + 1) * B] for j in range(P)]
                words.append(Cat(*[vals[j] for j in reversed(range(P))],
                                 Const(0, WORD_BITS - P * B)))
            m.d.comb += [self.wr_data.eq(mux_select(words, r)),
                         self.wr_eol.eq(h_eol & last_sub), self.wr_first.eq(h_first)]
            with m.If(fire):
                m.d.sync += [o_valid.eq(1), held.eq(Cat(*beat)), r.eq(0),
                             o_addr.eq(cur_addr), h_eol.eq(last_col), h_first.eq(cur_first)]
                with m.If(last_col):
                    m.d.sync += [col.eq(0), line_base.eq(next_line), waddr.eq(next_line)]
                with m.Else():
                    m.d.sync += [col.eq(col + 1), waddr.eq(after(R * ADDR_PER_WORD))]
                    with m.If(line_start):
                        m.d.sync += line_base.eq(next_base)
            with m.Elif(ofire):
                with m.If(last_sub):
                    m.d.sync += o_valid.eq(0)
                with m.Else():
                    m.d.sync += [r.eq(r + 1), o_addr.eq(o_addr + ADDR_PER_WORD)]
        return m


class LineReader(wiring.Component):
    """Line requests (first address, frame-start flag) -> unpacked pixel stream.

    Each request reads the layout's words of one line through ``rd_*`` and emits its
    ``width * channels / elements`` beats on ``o_stream``, ``first`` on beat 0 when the
    request's flag is set, ``last`` on the final beat. ``line_issued`` pulses when a line's
    last read was queued.

    ``early_last``: ``col == W - 1`` kept as a register (set a beat ahead) and, when a word
    is one beat, no beat counter: the read-data ``ready`` a LUT of registers, not the
    column compare into the read FIFO's enable over its 256-bit word (the whole Ning et
    al. 2019 camera at ppc 8: ``nuc_ddr``'s coefficient reader, 8.59 ns); the same beats.
    """

    @quiet_reject
    def __init__(self, *, layout, elements, addr_bits=ADDR_BITS, max_lines=66,
                 early_last=False):
        self._lay, self._e, self._aw, self._fl = layout, elements, addr_bits, max_lines
        self._early = early_last
        self._g, self._r = _gear(elements, layout.pixels_per_word)
        super().__init__({
            "req_valid": In(1), "req_ready": Out(1), "req_addr": In(addr_bits),
            "req_first": In(1),
            "rd_valid": Out(1), "rd_ready": In(1), "rd_addr": Out(addr_bits),
            "rdata_valid": In(1), "rdata_ready": Out(1), "rdata": In(WORD_BITS),
            "line_issued": Out(1),
            "o_stream": Out(pixel_signature(channels_shape(layout.pixel_bits, elements)))})

    def elaborate(self, platform):
        m = Module()
        lay, E, G, R = self._lay, self._e, self._g, self._r
        P, B = lay.pixels_per_word, lay.pixel_bits
        W = lay.values_per_line // E
        WPL = lay.words_per_line
        m.submodules.flight = flight = SyncFIFOBuffered(width=1, depth=self._fl)
        cur_valid = Signal()
        cur_addr = Signal(self._aw)
        w = Signal(range(WPL))
        m.d.comb += [self.req_ready.eq(~cur_valid & flight.w_rdy),
                     flight.w_en.eq(self.req_valid & self.req_ready),
                     flight.w_data.eq(self.req_first),
                     self.rd_valid.eq(cur_valid), self.rd_addr.eq(cur_addr)]
        rfire = cur_valid & self.rd_ready
        m.d.comb += self.line_issued.eq(rfire & (w == WPL - 1))
        with m.If(self.req_valid & self.req_ready):
            m.d.sync += [cur_valid.eq(1), cur_addr.eq(self.req_addr), w.eq(0)]
        with m.Elif(rfire):
            m.d.sync += [cur_addr.eq(cur_addr + ADDR_PER_WORD), w.eq(w + 1)]
            with m.If(w == WPL - 1):
                m.d.sync += cur_valid.eq(0)

        o = self.o_stream
        col = Signal(range(W))
        ofire = o.valid & o.ready
        if self._early:
            last_col = Signal(init=int(W == 1), name="last_col")
            with m.If(ofire):
                m.d.sync += last_col.eq(Mux(last_col, W == 1, col == W - 2))
        else:
            last_col = col == W - 1
        m.d.comb += [o.payload.first.eq(flight.r_data & ~col.any()),
                     o.payload.last.eq(last_col),
                     flight.r_en.eq(ofire & last_col)]
        with m.If(ofire):
            m.d.sync += col.eq(Mux(last_col, 0, col + 1))
        sl = _word_slices(P, B)
        if R == 1:
            k = Signal(range(max(G, 2)))
            wv = Signal()
            word = Signal(WORD_BITS)
            done = Const(1) if self._early and G == 1 else (k == G - 1) | last_col
            m.d.comb += [o.valid.eq(wv),
                         self.rdata_ready.eq(~wv | (ofire & done))]
            vals = [word[lo:hi] for lo, hi in sl]
            for e in range(E):
                opts = [vals[g * E + e] for g in range(G)]
                v = opts[0] if G == 1 else mux_select(opts, k)
                m.d.comb += (o.payload.data[e] if E > 1 else o.payload.data).eq(v)
            with m.If(ofire):
                m.d.sync += k.eq(Mux(done, 0, k + 1))
                with m.If(done):
                    m.d.sync += wv.eq(0)
            with m.If(self.rdata_valid & self.rdata_ready):
                m.d.sync += [wv.eq(1), word.eq(self.rdata)]
        else:
            r = Signal(range(R))
            buf = [Signal(WORD_BITS, name=f"buf{x}") for x in range(R - 1)]
            bv = Signal()
            beat = Signal(E * B)
            m.d.comb += [o.valid.eq(bv), Value.cast(o.payload.data).eq(beat),
                         self.rdata_ready.eq((r != R - 1) | ~bv | o.ready)]
            words = buf + [self.rdata]
            new_beat = Cat(*[words[x][sl[j][0]:sl[j][1]] for x in range(R) for j in range(P)])
            rdfire = self.rdata_valid & self.rdata_ready
            with m.If(rdfire):
                with m.If(r == R - 1):
                    m.d.sync += [beat.eq(new_beat), bv.eq(1), r.eq(0)]
                with m.Else():
                    m.d.sync += r.eq(r + 1)
                    for x in range(R - 1):
                        with m.If(equals(r, x)):
                            m.d.sync += buf[x].eq(self.rdata)
            with m.If(ofire & ~(rdfire & (r == R - 1))):
                m.d.sync += bv.eq(0)
        return m


def _layout(width, channels, pixel_bits, pixels_per_word, line_stride, base):
    return LineLayout(width=width, channels=channels, pixel_bits=pixel_bits,
                      pixels_per_word=pixels_per_word, line_stride=line_stride, base=base)


class DdrFrameBuffer(wiring.Component):
    """A frame buffer in DDR: every line written, read back, and streamed out unchanged.

    Parameters
    ----------
    width : int
        Pixels per line.
    rows : int
        Lines the buffer holds (a frame's height): line y of a frame is stored at
        ``base + y * line_stride``; the writer never gets more than ``rows`` lines ahead of
        the reads, so no line is overwritten before it was read.
    channels : int
        Values per pixel (72 in seed 002).
    elements : int
        Values per beat (divides or is a multiple of ``pixels_per_word``; default
        ``channels``).
    pixel_bits, pixels_per_word, line_stride, base
        The packing and addresses (:class:`tdicam.model.ddr.LineLayout`).
    capacity_bytes : int
        DDR size for the address check.
    early : bool
        The writer's ``early_sums`` and the reader's ``early_last`` (:class:`LineWriter`,
        :class:`LineReader`: fewer logic levels behind the beat's handshake, the same words
        and beats): the output links' buffer in the whole camera's top.
    paced : bool
        The output is drained slower than lines come in (the output links): a line's reads
        start only when the read-data FIFO has room for all of them (``rd_depth`` raised to
        a power of two of at least a line's words), so a line's reads never wait on the
        sink while the writes wait behind them; and writes go before a line's reads from
        when the write-behind FIFO is half full until it is empty (a registered flag), so
        the input does not stall while a line's reads go out, reads and writes in blocks of
        16 words or more (DRAM turnarounds). Without it a slow sink holds the port with
        a half-queued line and the input stalls (the whole camera's links: a line drains in
        5,000 cycles, the write-behind FIFO holds 32 words).

    Attributes
    ----------
    i_stream, o_stream : pixel streams of ``elements`` x ``pixel_bits``
        Output = input (values, ``first``, ``last`` on every ``width * channels / elements``
        beats), after the round trip.
    hold_reads : In(1)
        While high no read is queued (to measure writes alone).
    line_errors : Out(16)
        Input lines whose ``last`` was misplaced (lines are cut by count).

    Notes
    -----
    Latency: at least one line plus the DDR read latency. Throughput: one word per
    cycle at best, shared by reads and writes. DRAM order: a line's reads are queued as
    one block; written words wait meanwhile in a :attr:`WRITE_BEHIND`-word FIFO (32 x 286
    bit = 9.2 kbit: address, line-end and frame-start flags, word), so the controller sees
    reads and writes in blocks of about a line, not interleaved word by word (a read/write
    turnaround costs 6-8 controller cycles; :mod:`tdicam.cosim.litedram` measures it: 84 % on
    LiteDRAM for a 1280-pixel frame, 26 % by the DRAM model when interleaved). The input
    stalls when that FIFO fills.
    """

    WRITE_BEHIND = 32

    @quiet_reject
    def __init__(self, *, width, rows, channels=1, elements=None, pixel_bits=10,
                 pixels_per_word=24, line_stride=None, base=0, capacity_bytes=CAPACITY_BYTES,
                 rd_depth=64, early=False, paced=False):
        self.layout = _layout(width, channels, pixel_bits, pixels_per_word, line_stride, base)
        self._early, self._paced = bool(early), bool(paced)
        if paced:
            rd_depth = max(rd_depth, 1 << (self.layout.words_per_line - 1).bit_length())
        check_range("rows", rows, 1, 1 << 16)
        self._e = channels if elements is None else elements
        _gear(self._e, pixels_per_word)
        check_capacity(self.layout, rows, capacity_bytes, "frame buffer")
        self._rows, self._rd = rows, rd_depth
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, self._e))),
            "o_stream": Out(pixel_signature(channels_shape(pixel_bits, self._e))),
            "hold_reads": In(1), "line_errors": Out(16), **mig_user_ports()})

    elements = property(lambda self: self._e)
    rows = property(lambda self: self._rows)
    early = property(lambda self: self._early)
    paced = property(lambda self: self._paced)
    rd_depth = property(lambda self: self._rd, doc="Words of the port's read-data FIFO.")

    def elaborate(self, platform):
        m = Module()
        lay = self.layout
        m.submodules.port = port = MigPort(rd_depth=self._rd)
        m.submodules.writer = wr = LineWriter(layout=lay, elements=self._e, rows=self._rows,
                                              early_sums=self._early)
        fl = self._rd // lay.words_per_line + 3
        m.submodules.reader = rd = LineReader(layout=lay, elements=self._e, max_lines=fl,
                                              early_last=self._early)
        m.submodules.desc = desc = SyncFIFOBuffered(width=ADDR_BITS + 1, depth=self._rows + 1)
        wiring.connect(m, wiring.flipped(self.i_stream), wr.i_stream)
        wiring.connect(m, rd.o_stream, wiring.flipped(self.o_stream))
        connect_mig(m, port, self)
        m.d.comb += self.line_errors.eq(wr.line_errors)
        # writer -> write-behind FIFO -> port (+ a line descriptor with each line's last
        # word); no write enters the port while the reader issues a line's reads, so the
        # controller sees reads and writes in blocks of a line (DRAM turnarounds)
        AW = ADDR_BITS
        m.submodules.wfifo = wf = SyncFIFOBuffered(width=AW + 2 + WORD_BITS,
                                                   depth=self.WRITE_BEHIND)
        m.d.comb += [wf.w_en.eq(wr.wr_valid), wr.wr_ready.eq(wf.w_rdy),
                     wf.w_data.eq(Cat(wr.wr_addr, wr.wr_eol, wr.wr_first, wr.wr_data))]
        w_addr, w_eol = wf.r_data[:AW], wf.r_data[AW]
        w_go = Signal()
        reads_first = rd.rd_valid
        if self._paced:     # from half full until empty the writes go first (a register)
            urgent = Signal()
            with m.If(wf.level >= self.WRITE_BEHIND // 2):
                m.d.sync += urgent.eq(1)
            with m.Elif(wf.level == 0):
                m.d.sync += urgent.eq(0)
            reads_first = rd.rd_valid & ~urgent
        m.d.comb += [w_go.eq(wf.r_rdy & ~reads_first & (~w_eol | desc.w_rdy)),
                     port.wr_valid.eq(w_go), wf.r_en.eq(w_go & port.wr_ready),
                     port.wr_addr.eq(w_addr), port.wr_data.eq(wf.r_data[AW + 2:]),
                     desc.w_en.eq(w_go & w_eol & port.wr_ready),
                     desc.w_data.eq(Cat((w_addr - (lay.words_per_line - 1) * ADDR_PER_WORD)[:AW],
                                        wf.r_data[AW + 1]))]
        # descriptors -> reader -> port (paced: a line only when its words have room)
        hold = self.hold_reads
        if self._paced:
            WPL = lay.words_per_line
            pending = Signal(range(self._rd + 1))       # words queued, not yet taken
            room = Signal()
            up = port.rd_valid & port.rd_ready
            down = port.rdata_valid & port.rdata_ready
            m.d.sync += pending.eq(pending + up - down)
            m.d.comb += room.eq(pending <= self._rd - WPL)
            hold = hold | ~room
        m.d.comb += [rd.req_valid.eq(desc.r_rdy & ~hold),
                     desc.r_en.eq(rd.req_ready & ~hold),
                     rd.req_addr.eq(desc.r_data[:ADDR_BITS]),
                     rd.req_first.eq(desc.r_data[ADDR_BITS]),
                     port.rd_valid.eq(rd.rd_valid), rd.rd_ready.eq(port.rd_ready),
                     port.rd_addr.eq(rd.rd_addr),
                     rd.rdata_valid.eq(port.rdata_valid), port.rdata_ready.eq(rd.rdata_ready),
                     rd.rdata.eq(port.rdata)]
        # line lead: lines started by the writer minus lines fully queued by the reader
        lead = Signal(range(self._rows + 2))
        m.d.sync += lead.eq(lead + wr.line_start - rd.line_issued)
        m.d.comb += wr.line_ok.eq(lead < self._rows)
        return m
