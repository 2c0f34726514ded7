"""Calibration store in NAND flash (Ning et al. 2019 §4.3): an ONFI-style
controller with a power-up bad-block scan and logical-to-physical map, streaming the stored
calibration through :class:`~tdicam.hdl.calib.CalibReader` (SECDED decoder inside), and a
cycle-level simulation model of the NAND part. Image layout and golden model:
:mod:`tdicam.model.nand_store`.

Bus (simplified ONFI asynchronous interface, x8, one target)
------------------------------------------------------------
Signals, controller side: ``nand_cle``, ``nand_ale`` (latch enables), ``nand_we_n``,
``nand_re_n`` (active-low strobes), ``nand_dq_o`` (command/address byte out),
``nand_dq_i`` (data in), ``nand_rb_n`` (ready/busy, low = busy). CE# is tied low, WP#
high (one target, no writes from the camera). Command subset:

* ``FFh`` RESET, then wait for R/B#;
* ``00h``, 5 address cycles (column low, column high, row bits 7:0, 15:8, 23:16),
  ``30h`` READ PAGE, wait for R/B#, then data-out cycles from the column given.

Timing, in controller clocks: every command/address/data cycle is 2 clocks, its strobe
low for the first (``tWP``/``tREA`` window) and high for the second, so at the stated
50 MHz ``tWC = tRC = 40 ns`` (ONFI timing mode 2 allows 35 ns). After ``30h`` or ``FFh``
the controller ignores R/B# for 2 clocks (``tWB``) and then waits for it to go high; read
data is captured at the end of the strobe-low clock. Cycle counts: :func:`tdicam.model.
nand.timing` (exact, checked against this gateware in tests/test_nand_store.py).

The simulation model of the part (:class:`NandDeviceSim`) is synchronous: it samples a
strobe low for one clock as one bus cycle, drives ``dq`` from a registered memory read
(valid in the strobe-low clock of every other clock), and holds R/B# low for
``busy_cycles`` clocks after ``30h`` and ``FFh`` (t_R; ``busy_cycles >= 3``).
"""

from amaranth.hdl import Cat, Module, Mux, Signal, unsigned
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError, check_range
from tdicam.model import calib, nand_store
from tdicam.hdl.calib import DEBUG_ELEMENTS, CalibReader
from tdicam.hdl.util import equals
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature

__all__ = ["NandCalibStore", "NandDeviceSim", "NandCalibTop", "LOAD_PAGE", "LOAD_SLOT",
           "LOAD_MARKER", "LOAD_GO", "BUS_PORTS", "NandPart", "MAX_SLOTS"]

#: programmed pages :class:`NandDeviceSim` holds at most (a page's slot is one byte)
MAX_SLOTS = 255

#: loader operations of :class:`NandDeviceSim` / :class:`NandCalibTop` (beat bits 31:30)
LOAD_PAGE, LOAD_SLOT, LOAD_MARKER, LOAD_GO = 0, 1, 2, 3
#: controller-side bus ports: (name, width, direction from the controller)
BUS_PORTS = (("nand_cle", 1, "out"), ("nand_ale", 1, "out"), ("nand_we_n", 1, "out"),
             ("nand_re_n", 1, "out"), ("nand_dq_o", 8, "out"), ("nand_dq_i", 8, "in"),
             ("nand_rb_n", 1, "in"))

CMD_READ, CMD_READ_GO, CMD_RESET = 0x00, 0x30, 0xFF


def _geometry(page_bytes, pages_per_block, blocks):
    return nand_store.Geometry(page_bytes=page_bytes, pages_per_block=pages_per_block,
                               blocks=blocks)


class NandCalibStore(wiring.Component):
    """Power-up scan, block map and calibration read from a NAND part.

    Parameters
    ----------
    rows, cols, gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits, count_bits,
    debug
        As :class:`~tdicam.hdl.calib.CalibReader` (the calibration the store holds).
    page_bytes, pages_per_block, blocks : int
        Geometry of the part (default 4 Gb x8, MT29F4G08: 2,048, 64, 4,096; powers of two
        for the first two).

    Attributes
    ----------
    nand_* : the bus (module docstring).
    start : In(1)
        Level: leave the idle state and run (reset, scan, load) once.
    o_stream : Out(pixel stream)
        Exactly :class:`CalibReader`'s ``o_stream`` (same elements, markers, defaults).
    corrected_count, uncorrectable_count, header_error
        :class:`CalibReader`'s.
    bad_blocks : Out(16)
        Blocks whose marker (spare byte 0 of page 0) is not ``0xFF``, block 0 included
        (saturating at 65535).
    scan_done : Out(1)
        The scan finished (map built); stays high.
    done : Out(1)
        Every word of the calibration stream was read and handed to the reader.
    error : Out(1)
        Fewer good blocks after block 0 than the stream needs: the words of the good blocks
        were read, then the store stops (the stream ends early).

    Notes
    -----
    The scan reads the marker byte of every block (a page read of page 0 at column
    ``page_bytes``, one data-out cycle) and writes the good blocks after block 0 into the
    map memory (``blocks_needed`` entries of ``ceil(log2 blocks)`` bits): logical block k ->
    the k-th good block, the writer's rule (:mod:`tdicam.model.nand_store`), so the map stored
    in block 0 needs no read. The load reads, for each logical block, its pages in order,
    ``words_per_page`` 9-byte words each (2,043 of 2,048 bytes), and hands each word to the
    reader. The reader's ``i_stream.ready`` stalls the data-out cycles; it takes a word
    every other clock, the bus delivers one every 18.

    Cost at the defaults (3800 x 5144, 4 Gb part; ``tdicam synth nand_store``): ECP5-85F
    664 LUT4 + 102 CCU2C, 530 FF, 1 DP16KD (the map), 155-157 MHz over 3 seeds (critical
    path in the reader's header check); xc7 505 LUT, 494 FF, 1 RAMB18.
    """

    def __init__(self, *, rows=3800, cols=5144, gain_int_bits=2, gain_frac_bits=14,
                 offset_bits=16, offset_frac_bits=0, count_bits=calib.DEFAULT_COUNT_BITS,
                 debug=False, page_bytes=2048, pages_per_block=64, blocks=4096):
        try:
            self._geo = _geometry(page_bytes, pages_per_block, blocks)
        except TdicamError:
            self._MustUse__silence = True
            raise
        self._reader = CalibReader(rows=rows, cols=cols, gain_int_bits=gain_int_bits,
                                   gain_frac_bits=gain_frac_bits, offset_bits=offset_bits,
                                   offset_frac_bits=offset_frac_bits, count_bits=count_bits,
                                   debug=debug)
        self._n_words = calib.HEADER_WORDS + calib.payload_words(rows, cols)
        self._need = nand_store.blocks_needed(self._n_words, self._geo)
        members = {name: (Out(w) if d == "out" else In(w)) for name, w, d in BUS_PORTS}
        members.update({
            "start": In(1),
            "o_stream": Out(self._reader.signature.members["o_stream"].signature),
            "corrected_count": Out(count_bits), "uncorrectable_count": Out(count_bits),
            "header_error": Out(1), "bad_blocks": Out(16), "scan_done": Out(1),
            "done": Out(1), "error": Out(1),
        })
        super().__init__(members)

    reader = property(lambda self: self._reader, doc="The CalibReader inside.")
    geometry = property(lambda self: self._geo)
    n_words = property(lambda self: self._n_words, doc="Words of the calibration stream.")
    blocks_needed = property(lambda self: self._need)

    @property
    def latency(self):
        """The reader's latency (cycles from a word handed over to its first pixel)."""
        return self._reader.latency

    def elaborate(self, platform):
        m = Module()
        g = self._geo
        m.submodules.reader = rd = self._reader
        wiring.connect(m, wiring.flipped(self.o_stream), rd.o_stream)
        m.d.comb += [self.corrected_count.eq(rd.corrected_count),
                     self.uncorrectable_count.eq(rd.uncorrectable_count),
                     self.header_error.eq(rd.header_error)]

        ppb_bits = (g.pages_per_block - 1).bit_length()
        need = self._need
        m.submodules.l2p = l2p = Memory(shape=unsigned(max(1, (g.blocks - 1).bit_length())),
                                        depth=need, init=[])
        l2p_w = l2p.write_port()
        l2p_r = l2p.read_port()

        blk = Signal(range(g.blocks + 1))        # physical block (scan) / mapped block (load)
        page = Signal(range(g.pages_per_block + 1))
        n_good = Signal(range(need + 1))         # map entries written (saturates at need)
        lblk = Signal(range(need + 1))
        bad = Signal(16)
        scanning = Signal()
        step = Signal(range(7))
        phase = Signal()
        wcnt = Signal(2)
        nbyte = Signal(range(9))
        word_in_page = Signal(range(g.words_per_page + 1))
        words = Signal(range(self._n_words + 1))
        shift = Signal(72)
        w_valid = Signal()
        scan_done = Signal()

        row = Signal(24)
        col = Signal(16)
        m.d.comb += [row.eq(blk * g.pages_per_block + page) if ppb_bits == 0 else
                     row.eq(Cat(page[:ppb_bits], blk)),
                     col.eq(Mux(scanning, g.page_bytes, 0)),
                     self.bad_blocks.eq(bad)]
        addr_byte = Signal(8)
        with m.Switch(step):
            for k, v in enumerate((CMD_READ, col[:8], col[8:], row[:8], row[8:16], row[16:])):
                with m.Case(k):
                    m.d.comb += addr_byte.eq(v)
            with m.Default():
                m.d.comb += addr_byte.eq(CMD_READ_GO)

        # word hand-over to the reader
        m.d.comb += [rd.i_stream.valid.eq(w_valid), Cat(rd.i_stream.payload.data).eq(shift)]
        with m.If(rd.i_stream.ready):
            m.d.sync += w_valid.eq(0)

        m.d.comb += [self.nand_we_n.eq(1), self.nand_re_n.eq(1),
                     l2p_w.addr.eq(n_good), l2p_w.data.eq(blk), l2p_r.addr.eq(lblk)]
        states = ("IDLE", "RESET", "RESET_WAIT", "ISSUE", "WAIT", "SCAN_READ", "FIND", "MAP",
                  "DATA", "DONE", "ERROR")
        st = {name: k for k, name in enumerate(states)}
        state = Signal(range(len(states)))
        # a state register and an If/Elif chain (no incomplete case statements in the Verilog)
        with m.If(equals(state, st["IDLE"])):
            with m.If(self.start):
                m.d.sync += state.eq(st["RESET"])
        with m.Elif(equals(state, st["RESET"])):
            m.d.comb += [self.nand_cle.eq(1), self.nand_dq_o.eq(CMD_RESET),
                         self.nand_we_n.eq(phase)]
            m.d.sync += phase.eq(~phase)
            with m.If(phase):
                m.d.sync += [wcnt.eq(0), scanning.eq(1), blk.eq(0), page.eq(0)]
                m.d.sync += state.eq(st["RESET_WAIT"])
        with m.Elif(equals(state, st["RESET_WAIT"])):
            with m.If(wcnt != 2):
                m.d.sync += wcnt.eq(wcnt + 1)
            with m.Elif(self.nand_rb_n):
                m.d.sync += state.eq(st["ISSUE"])
        with m.Elif(equals(state, st["ISSUE"])):
            first_last = equals(step, 0) | (step == 6)
            m.d.comb += [self.nand_cle.eq(first_last), self.nand_ale.eq(~first_last),
                         self.nand_dq_o.eq(addr_byte), self.nand_we_n.eq(phase)]
            m.d.sync += phase.eq(~phase)
            with m.If(phase):
                with m.If(step == 6):
                    m.d.sync += [step.eq(0), wcnt.eq(0)]
                    m.d.sync += state.eq(st["WAIT"])
                with m.Else():
                    m.d.sync += step.eq(step + 1)
        with m.Elif(equals(state, st["WAIT"])):
            with m.If(wcnt != 2):
                m.d.sync += wcnt.eq(wcnt + 1)
            with m.Elif(self.nand_rb_n):
                m.d.sync += [nbyte.eq(0), word_in_page.eq(0)]
                with m.If(scanning):
                    m.d.sync += state.eq(st["SCAN_READ"])
                with m.Else():
                    m.d.sync += state.eq(st["DATA"])
        with m.Elif(equals(state, st["SCAN_READ"])):
            m.d.comb += self.nand_re_n.eq(phase)
            m.d.sync += phase.eq(~phase)
            is_bad = Signal()
            with m.If(~phase):
                m.d.sync += is_bad.eq(self.nand_dq_i != nand_store.MARKER_GOOD)
            with m.Else():
                with m.If(is_bad):
                    m.d.sync += bad.eq(Mux(bad == 0xFFFF, bad, bad + 1))
                with m.Elif(blk.any() & (n_good != need)):
                    m.d.comb += l2p_w.en.eq(1)
                    m.d.sync += n_good.eq(n_good + 1)
                with m.If(blk == g.blocks - 1):
                    m.d.sync += [scanning.eq(0), lblk.eq(0), scan_done.eq(1)]
                    m.d.sync += state.eq(st["FIND"])
                with m.Else():
                    m.d.sync += blk.eq(blk + 1)
                    m.d.sync += state.eq(st["ISSUE"])
        with m.Elif(equals(state, st["FIND"])):
            # the map is read one clock after lblk is set; taken in MAP
            with m.If(lblk == n_good):
                m.d.sync += state.eq(st["ERROR"])
            with m.Else():
                m.d.sync += state.eq(st["MAP"])
        with m.Elif(equals(state, st["MAP"])):
            m.d.sync += [blk.eq(l2p_r.data), page.eq(0)]
            m.d.sync += state.eq(st["ISSUE"])
        with m.Elif(equals(state, st["DATA"])):
            stall = w_valid & (nbyte == 8) & phase  # the reader has not taken the last word
            m.d.comb += self.nand_re_n.eq(phase)
            with m.If(~stall):
                m.d.sync += phase.eq(~phase)
            with m.If(~phase):
                m.d.sync += shift.eq(Cat(shift[8:], self.nand_dq_i))
            with m.If(phase & ~stall):
                with m.If(nbyte != 8):
                    m.d.sync += nbyte.eq(nbyte + 1)
                with m.Else():
                    m.d.sync += [nbyte.eq(0), w_valid.eq(1), words.eq(words + 1),
                                 word_in_page.eq(word_in_page + 1)]
                    with m.If(words == self._n_words - 1):
                        m.d.sync += state.eq(st["DONE"])
                    with m.Elif(word_in_page == g.words_per_page - 1):
                        with m.If(equals(page, g.pages_per_block - 1)):
                            m.d.sync += lblk.eq(lblk + 1)
                            m.d.sync += state.eq(st["FIND"])
                        with m.Else():
                            m.d.sync += page.eq(page + 1)
                            m.d.sync += state.eq(st["ISSUE"])
        with m.Elif(equals(state, st["DONE"])):
            m.d.comb += self.done.eq(~w_valid)
        with m.Else():  # ERROR
            m.d.comb += self.error.eq(1)
        m.d.comb += self.scan_done.eq(scan_done)
        return m


class NandDeviceSim(wiring.Component):
    """Cycle-level simulation model of a NAND part (not for synthesis): the command subset
    and timing of the module docstring, a small part's contents in memories.

    Parameters
    ----------
    page_bytes, pages_per_block, blocks : int
        Geometry (:class:`tdicam.model.nand_store.Geometry`).
    slots : int
        Programmed pages it can hold, 1..:data:`MAX_SLOTS` (data areas in one memory).
    busy_cycles : int
        R/B# low time after ``30h`` and ``FFh`` (t_R in clocks), 3..65535.

    Attributes
    ----------
    cle, ale, we_n, re_n : In(1); dq_in : In(8); dq_out : Out(8); rb_n : Out(1)
        The bus, device side.
    ld_valid : In(1); ld_word : In(32)
        Loader (before the controller starts; one write per clock): bits 31:30 the
        operation, 29:8 the address, 7:0 the byte. :data:`LOAD_PAGE`: data-area byte at
        ``(slot - 1) * page_bytes + column``; :data:`LOAD_SLOT`: row ``addr`` is held in
        slot ``byte`` (1..slots; 0 = erased, the reset state); :data:`LOAD_MARKER`: spare
        byte 0 of page 0 of block ``addr`` (reset ``0xFF``).

    image : tdicam.model.nand_store.NandDevice or None
        A part programmed at elaboration instead (the co-simulation of a camera's power-up:
        :class:`NandPart`): its pages and bad-block markers are the memories' initial
        contents and the row-to-slot look-up a comparison with its programmed rows (a
        register, as the memory's read), so the Verilog does not hold a slot entry for each
        of the part's rows; ``slots`` is then the number of programmed pages. The loader
        still writes the page and marker memories.

    Notes
    -----
    Reads of an erased page, of spare bytes other than the marker and of columns past the
    spare area return ``0xFF``. The memories keep their contents through reset.
    """

    def __init__(self, *, page_bytes=2048, pages_per_block=64, blocks=4096, slots=8,
                 busy_cycles=16, image=None):
        self._geo = _geometry(page_bytes, pages_per_block, blocks)
        self._image = None
        if image is not None:
            g = self._geo
            rows = [r for r in sorted(image.pages) if (image.pages[r][:g.page_bytes] != 0xFF).any()]
            self._image = (rows, image)
            slots = max(1, len(rows))
        else:
            check_range("slots", slots, 1, MAX_SLOTS)
        self._slots = slots
        self._busy = check_range("busy_cycles", busy_cycles, 3, 65535)
        super().__init__({
            "cle": In(1), "ale": In(1), "we_n": In(1), "re_n": In(1), "dq_in": In(8),
            "dq_out": Out(8), "rb_n": Out(1), "ld_valid": In(1), "ld_word": In(32),
        })

    geometry = property(lambda self: self._geo)
    slots = property(lambda self: self._slots)
    busy_cycles = property(lambda self: self._busy)

    def elaborate(self, platform):
        g = self._geo
        pb_bits = (g.page_bytes - 1).bit_length()
        ppb_bits = (g.pages_per_block - 1).bit_length()
        n_rows = g.blocks * g.pages_per_block
        img = self._image
        if img is not None:
            if self._slots > MAX_SLOTS:     # before the Module: nothing left unused
                raise TdicamError(
                    f"NAND part: its image programs {self._slots} pages, the simulation "
                    f"model holds at most {MAX_SLOTS}; simulate a cut of fewer rows "
                    f"(the Verilog of the camera top does not hold the part)")
            rows, image = img
            img = (rows, [int(b) for r in rows for b in image.pages[r][:g.page_bytes]],
                   [int(image.marker(b)) for b in range(g.blocks)])
        m = Module()
        m.submodules.pages = pages = Memory(shape=unsigned(8), depth=self._slots * g.page_bytes,
                                            init=[0xFF] * (self._slots * g.page_bytes)
                                            if img is None else img[1])
        mems = [("pages", pages, LOAD_PAGE)]
        if img is None:
            m.submodules.slot = slot = Memory(shape=unsigned(8), depth=n_rows, init=[])
            mems.append(("slot", slot, LOAD_SLOT))
        m.submodules.marker = marker = Memory(shape=unsigned(8), depth=g.blocks,
                                              init=[0xFF] * g.blocks if img is None else img[2])
        mems.append(("marker", marker, LOAD_MARKER))
        ops = {}
        for name, mem, op in mems:
            wp = mem.write_port()
            m.d.comb += [wp.addr.eq(self.ld_word[8:30]), wp.data.eq(self.ld_word[:8]),
                         wp.en.eq(self.ld_valid & equals(self.ld_word[30:], op))]
            ops[name] = mem.read_port()

        row = Signal(24)
        col = Signal(16)
        nadr = Signal(3)
        busy = Signal(range(self._busy + 1))
        m.d.comb += self.rb_n.eq(~busy.any())
        with m.If(busy.any()):
            m.d.sync += busy.eq(busy - 1)
        write = ~self.we_n
        with m.If(write & self.cle):
            with m.If(equals(self.dq_in, CMD_READ)):
                m.d.sync += nadr.eq(0)
            with m.Elif((self.dq_in == CMD_READ_GO) | (self.dq_in == CMD_RESET)):
                m.d.sync += busy.eq(self._busy)
        with m.If(write & self.ale):
            m.d.sync += nadr.eq(nadr + 1)
            # address cycles 1..5: column 7:0, 15:8, row 7:0, 15:8, 23:16 (If, not Switch:
            # no incomplete case statement in the Verilog)
            for k, sl in enumerate((col[:8], col[8:], row[:8], row[8:16], row[16:])):
                with m.If(equals(nadr, k)):
                    m.d.sync += sl.eq(self.dq_in)
        with m.If(~self.re_n):
            m.d.sync += col.eq(col + 1)

        if img is None:
            s = ops["slot"].data
            m.d.comb += ops["slot"].addr.eq(row)
        else:                                   # the programmed rows, compared (registered)
            s = Signal(8)
            m.d.sync += s.eq(0)
            for k, r in enumerate(img[0]):
                with m.If(row == r):
                    m.d.sync += s.eq(k + 1)
        m.d.comb += [
            ops["marker"].addr.eq(row[ppb_bits:]),
            ops["pages"].addr.eq(Cat(col[:pb_bits], (s - 1)[:8])),
        ]
        with m.If((col < g.page_bytes) & s.any()):
            m.d.comb += self.dq_out.eq(ops["pages"].data)
        with m.Elif((col == g.page_bytes) & ~row[:ppb_bits].any() if ppb_bits
                    else (col == g.page_bytes)):
            m.d.comb += self.dq_out.eq(ops["marker"].data)
        with m.Else():
            m.d.comb += self.dq_out.eq(0xFF)
        return m


class NandCalibTop(wiring.Component):
    """The ``nand`` block's top: :class:`NandCalibStore`, with :class:`NandDeviceSim`
    attached (``device=True``, co-simulation) or its bus as ports (``device=False``).

    ``i_stream``: loader beats of 4 bytes (:class:`NandDeviceSim`'s ``ld_word``, byte 0
    least significant), then one
    :data:`LOAD_GO` beat, which starts the store and is accepted once it is ``done`` (or
    in ``error``); loader beats are ignored without the device. ``o_stream``: the store's
    coefficients; with ``debug`` one more element, ``data[5]`` = ``bad_blocks``.
    """

    def __init__(self, *, device=False, slots=8, busy_cycles=16, **params):
        try:
            self._store = NandCalibStore(**params)
        except TdicamError:
            self._MustUse__silence = True
            raise
        self._device = bool(device)
        self._dev = NandDeviceSim(page_bytes=params.get("page_bytes", 2048),
                                  pages_per_block=params.get("pages_per_block", 64),
                                  blocks=params.get("blocks", 4096), slots=slots,
                                  busy_cycles=busy_cycles) if device else None
        rd = self._store.reader
        n_el = DEBUG_ELEMENTS + 1 if rd.debug else 2
        self._n_el = n_el
        members = {
            "i_stream": In(pixel_signature(channels_shape(8, 4))),
            "o_stream": Out(pixel_signature(channels_shape(rd.elem_bits, n_el))),
            "corrected_count": Out(rd.count_bits), "uncorrectable_count": Out(rd.count_bits),
            "header_error": Out(1), "bad_blocks": Out(16), "done": Out(1), "error": Out(1),
        }
        if not device:
            members.update({name: (Out(w) if d == "out" else In(w)) for name, w, d in BUS_PORTS})
        super().__init__(members)

    store = property(lambda self: self._store)
    device = property(lambda self: self._device)

    @property
    def latency(self):
        return self._store.latency

    def elaborate(self, platform):
        m = Module()
        m.submodules.store = st = self._store
        i, o = self.i_stream, self.o_stream
        word = Cat(i.payload.data)
        go = word[30:] == LOAD_GO
        m.d.comb += [st.start.eq(i.valid & go),
                     i.ready.eq(~go | st.done | st.error)]
        if self._device:
            m.submodules.nand = dev = self._dev
            m.d.comb += [dev.cle.eq(st.nand_cle), dev.ale.eq(st.nand_ale),
                         dev.we_n.eq(st.nand_we_n), dev.re_n.eq(st.nand_re_n),
                         dev.dq_in.eq(st.nand_dq_o), st.nand_dq_i.eq(dev.dq_out),
                         st.nand_rb_n.eq(dev.rb_n),
                         dev.ld_valid.eq(i.valid & ~go), dev.ld_word.eq(word)]
        else:
            for name, _, d in BUS_PORTS:
                if d == "out":
                    m.d.comb += getattr(self, name).eq(getattr(st, name))
                else:
                    m.d.comb += getattr(st, name).eq(getattr(self, name))
        so = st.o_stream
        data = Cat(so.payload.data)
        if self._n_el > 2:
            bb = Signal(self._store.reader.elem_bits)
            m.d.comb += bb.eq(st.bad_blocks)  # low elem_bits bits
            data = Cat(data, bb)
        m.d.comb += [o.valid.eq(so.valid), so.ready.eq(o.ready),
                     o.payload.first.eq(so.payload.first), o.payload.last.eq(so.payload.last),
                     Cat(o.payload.data).eq(data)]
        for name in ("corrected_count", "uncorrectable_count", "header_error", "bad_blocks",
                     "done", "error"):
            m.d.comb += getattr(self, name).eq(getattr(st, name))
        return m


class NandPart(wiring.Component):
    """Simulation: a NAND part holding a given image, on the controller's bus pins (the
    co-simulation's part outside the camera top, :class:`tdicam.hdl.chain_board.Board`):
    :class:`NandDeviceSim` programmed at elaboration (``image``), ready at power-up.

    Attributes
    ----------
    cle, ale, we_n, re_n, dq_in : In; dq_out, rb_n : Out
        The bus, device side (:class:`NandDeviceSim`'s).
    """

    def __init__(self, image, *, page_bytes=2048, pages_per_block=64, blocks=4096,
                 busy_cycles=16):
        self._dev = NandDeviceSim(page_bytes=page_bytes, pages_per_block=pages_per_block,
                                  blocks=blocks, busy_cycles=busy_cycles, image=image)
        super().__init__({
            "cle": In(1), "ale": In(1), "we_n": In(1), "re_n": In(1), "dq_in": In(8),
            "dq_out": Out(8), "rb_n": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.part = dev = self._dev
        m.d.comb += [dev.ld_valid.eq(0), dev.ld_word.eq(0),
                     dev.cle.eq(self.cle), dev.ale.eq(self.ale), dev.we_n.eq(self.we_n),
                     dev.re_n.eq(self.re_n), dev.dq_in.eq(self.dq_in),
                     self.dq_out.eq(dev.dq_out), self.rb_n.eq(dev.rb_n)]
        return m
