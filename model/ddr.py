"""DDR line/frame buffers behind a MIG-style user interface (Ning et al. 2019 §4.2).

The ``ddr`` block's golden model (the packing) and what every DDR user shares: the
addresses and words, the controller model, the access patterns and their measured
efficiency (:mod:`tdicam.hdl.ddr`, :mod:`tdicam.hdl.simmodels.mig_model`; the users' own golden
models are :mod:`tdicam.model.cds_ddr` and :mod:`tdicam.model.tdi_ddr`).

Interface and addresses
-----------------------
The user interface is AMD MIG's native UI: ``app_cmd`` (0 write, 1 read), ``app_addr``,
``app_en``/``app_rdy``; ``app_wdf_data`` (256 bit), ``app_wdf_wren``, ``app_wdf_end``,
``app_wdf_rdy``; ``app_rd_data`` (256 bit), ``app_rd_data_valid`` (no backpressure).
``app_addr`` counts in the controller's address unit, **one 32-bit column** as in Ning et al. 2019
Table 2 (two x16 DDR3 chips, BL8): a 256-bit UI word spans :data:`ADDR_PER_WORD` = 8
address steps, so word addresses are 0, 8, 16, ... and must be multiples of 8. ``app_addr``
is :data:`ADDR_BITS` = 28 bits wide (2**28 units of 4 bytes = 1 GiB: two 4 Gbit x16 chips,
:data:`CAPACITY_BYTES`).

Packing (Ning et al. 2019 Table 2)
--------------------------
A line holds ``width`` pixels of ``channels`` channels each, ``pixel_bits`` per value. The
values are taken in the order (pixel, channel) — channel 1..C of pixel 1, then of pixel 2,
... — and ``pixels_per_word`` (24) of them fill one 256-bit word, so with the paper's 72
channels word 0 holds channels 1-24 of pixel 1, word 1 channels 25-48, word 2 channels
49-72, word 3 channels 1-24 of pixel 2. Within a word the values are concatenated as the
table writes them, ``{v1, v2, ..., v24}``: the first value in the most significant used
bits, ``v1`` at bits ``[24*10-1 : 23*10]`` = [239:230], ``v24`` at [9:0]; the 16 bits above
the 240 used are zero. A line's last word is zero-padded when ``width * channels`` is not a
multiple of ``pixels_per_word``. Line ``y`` starts at ``base + y * line_stride`` (address
units; Table 2 uses 4096 = 512 words).

On the Amaranth/AXI4-Stream side a beat carries ``elements`` values (element 0 in the least
significant bits of tdata): the channels of one pixel, or several single-channel pixels;
beats follow the same (pixel, channel) order.

Memory model
------------
:class:`MigSim` is the cycle-stepped Python model of the controller (the HDL model is
:class:`tdicam.hdl.simmodels.mig_model.MigModel`; both draw their stalls from the same xorshift32 sequence,
so their ready patterns are identical cycle for cycle): in-order reads with a latency drawn
from ``[lat_lo, lat_hi]`` cycles, a refresh window of ``refresh_cycles`` at the start of
every ``refresh_period`` cycles after the first (the refresh timer starts at reset) with
``app_rdy`` low, random drops of ``app_rdy`` and
``app_wdf_rdy`` (probability ``drop / 256`` each, independent), write data that must be
accepted before its write command (MIG allows data first), capacity and alignment checks.
An address outside the memory or not word aligned raises :class:`TdicamError` naming it.

With ``dram=`` :class:`DramTiming` :class:`MigSim` also charges what the order of accesses
costs on DDR3, as LiteDRAM's controller spends it (read off its command timeline): the
queue drain when a port moves to another bank, read/write turnarounds, opening a row in a
bank (row-bank-column mapping, 8 banks of :data:`ROW_WORDS`-word rows; precharge and
write recovery when another row is open) and a 44-cycle refresh (:data:`DRAM_STALLS`).
It is within +/-3 points of LiteDRAM on every pattern of :data:`PATTERNS` and on every DDR
block's recorded command order (:mod:`tdicam.cosim.litedram` replays the same traces into
LiteDRAM; tests/test_ddrref.py holds the recorded figures); the HDL model with the same
``dram`` is cycle-equal (:func:`tdicam.cosim.litedram.replay_hdl`) and charges it by default in
co-simulation.
:func:`pattern_efficiency` gives a named pattern's efficiency for the planner.

Access patterns
---------------
A :class:`Trace` is the order of a user's commands (``(is_read, word_address)`` per port);
:data:`PATTERNS` names the orders that matter here (single direction, line blocks,
the per-word read-then-write the TDI spill had, its line blocks now, two ports),
:func:`replay_model` runs a trace on :class:`MigSim` with data always available;
:func:`tdi_spill_efficiency` is what ``tdicam plan`` counts on for the spill.

This module holds the packing, the controller model and the access patterns together
(~900 lines, with the planner's figure for the TDI spill) because the three share the
address and word definitions and are used together by every DDR user and by
:mod:`tdicam.cosim.litedram`.
"""

import dataclasses
import functools
from collections import deque
from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError, check_range

__all__ = ["worst_stall", "WORD_BITS", "ADDR_PER_WORD", "ADDR_BITS", "CAPACITY_BYTES", "PIXEL_BITS",
           "PIXELS_PER_WORD", "PAPER_CHANNELS", "PAPER_LINE_STRIDE", "DEFAULT_STALLS",
           "LineLayout", "pack_words", "unpack_words", "pack_lines", "unpack_lines",
           "words_to_ints", "ints_to_words", "psums_per_word", "check_capacity",
           "xorshift32", "stall_pattern", "MigSim",
           "ROW_WORDS", "BANKS", "Trace", "PATTERNS", "pattern_trace", "replay_model",
           "pattern_efficiency", "DramTiming", "DRAM_STALLS", "merged_commands",
           "TraceDriver", "trace_dram", "PLAN_MARGIN", "MEASURED_EFFICIENCY", "BLOCK_TEXT",
           "closest_block", "TREFI", "STARTUP",
           "WINDOW_REFRESHES", "window_cycles", "window_efficiency", "window_words",
           "pattern_lines", "TDI_SPILL_PATTERN", "tdi_spill_efficiency"]

WORD_BITS = 256
ADDR_PER_WORD = 8           # 32-bit address unit (Ning et al. 2019 Table 2: 0~7, 8~15, ...)
ADDR_BITS = 28
CAPACITY_BYTES = 1 << 30    # 1 GiB
PIXEL_BITS = 10
PIXELS_PER_WORD = 24
PAPER_CHANNELS = 72
PAPER_LINE_STRIDE = 4096
_LIMBS = WORD_BITS // 64

#: DRAM geometry behind the UI (two MT41K256M16, BL8, row-bank-column mapping): 256-bit
#: words per row (1024 columns / 8) and banks
ROW_WORDS = 128
BANKS = 8

#: Default stall pattern of the memory model: read latency 20..60 cycles, a 44-cycle refresh
#: every 780 cycles (tREFI 7.8 us) at 100 MHz — what LiteDRAM's DDR3 controller spends per
#: refresh (precharge all, tRP, tRFC 350 ns, rows opened again), as in :data:`DRAM_STALLS` —
#: each ready dropped with probability 16/256 per cycle.
DEFAULT_STALLS = {"lat_lo": 20, "lat_hi": 60, "refresh_period": 780, "refresh_cycles": 44,
                  "drop": 16, "seed": 1}


@dataclass(frozen=True)
class LineLayout:
    """Packing and addressing of one kind of line (see the module docstring).

    Parameters
    ----------
    width : int
        Pixels per line, >= 1.
    channels : int
        Values per pixel, >= 1 (72 in Ning et al. 2019).
    pixel_bits : int
        Bits per value, 1..32.
    pixels_per_word : int
        Values per 256-bit word, 1 .. 256 // pixel_bits.
    line_stride : int or None
        Address units between line starts, a multiple of 8 and >= the line's words x 8;
        None: the line's words x 8 rounded up to a power of two.
    base : int
        Address of line 0, a multiple of 8.
    """

    width: int
    channels: int = 1
    pixel_bits: int = PIXEL_BITS
    pixels_per_word: int = PIXELS_PER_WORD
    line_stride: int | None = None
    base: int = 0

    def __post_init__(self):
        check_range("width", self.width, 1, None)
        check_range("channels", self.channels, 1, None)
        check_range("pixel_bits", self.pixel_bits, 1, 32)
        check_range("pixels_per_word", self.pixels_per_word, 1, WORD_BITS // self.pixel_bits)
        check_range("base", self.base, 0, None)
        if self.base % ADDR_PER_WORD:
            raise TdicamError(f"base = {self.base} is not a multiple of {ADDR_PER_WORD} "
                              f"(one 256-bit word = {ADDR_PER_WORD} address units)")
        need = self.words_per_line * ADDR_PER_WORD
        if self.line_stride is None:
            object.__setattr__(self, "line_stride", 1 << (need - 1).bit_length())
        stride = check_range("line_stride", self.line_stride, 1, None)
        if stride < need:
            raise TdicamError(f"line_stride = {stride} is smaller than a line: "
                              f"{self.words_per_line} words = {need} address units")
        if stride % ADDR_PER_WORD:
            raise TdicamError(f"line_stride = {stride} is not a multiple of {ADDR_PER_WORD} "
                              f"(one 256-bit word = {ADDR_PER_WORD} address units)")

    @property
    def values_per_line(self):
        return self.width * self.channels

    @property
    def words_per_line(self):
        return -(-self.values_per_line // self.pixels_per_word)

    def line_addr(self, y):
        """Address of line ``y``'s first word."""
        return self.base + int(y) * self.line_stride

    def end_addr(self, lines):
        """First address past ``lines`` lines (the last one counted to its last word)."""
        if lines <= 0:
            return self.base
        return self.line_addr(lines - 1) + self.words_per_line * ADDR_PER_WORD


def check_capacity(layout, lines, capacity_bytes=CAPACITY_BYTES, what="buffer"):
    """Raise a one-line :class:`TdicamError` when ``lines`` lines do not fit the memory."""
    units = capacity_bytes * 8 // (WORD_BITS // ADDR_PER_WORD)
    end = layout.end_addr(lines)
    if end > units or end > 1 << ADDR_BITS:
        lim = min(units, 1 << ADDR_BITS)
        raise TdicamError(f"address space too small: the {what} needs addresses up to "
                          f"{end - 1} ({lines} lines x stride {layout.line_stride} from "
                          f"{layout.base}), the memory has {lim} address units "
                          f"({lim * 4 // (1 << 20)} MiB)")
    return end


def _bit_offsets(pixels_per_word, pixel_bits):
    """Bit offset of value j of a word: ``(P - 1 - j) * B`` (first value most significant)."""
    return [(pixels_per_word - 1 - j) * pixel_bits for j in range(pixels_per_word)]


def pack_words(values, *, pixel_bits=PIXEL_BITS, pixels_per_word=PIXELS_PER_WORD):
    """Pack a flat sequence of values into 256-bit words (zero-padded at the end).

    Returns
    -------
    ndarray uint64, shape (n_words, 4)
        Little-endian 64-bit limbs of each word (limb 0 = bits [63:0]).
    """
    v = np.asarray(values)
    if v.size and (v.min() < 0 or int(v.max()) >> pixel_bits):
        raise TdicamError(f"values outside 0..{(1 << pixel_bits) - 1}")
    v = v.astype(np.uint64).ravel()
    n = -(-v.size // pixels_per_word)
    pad = np.zeros(n * pixels_per_word, np.uint64)
    pad[:v.size] = v
    pad = pad.reshape(n, pixels_per_word)
    out = np.zeros((n, _LIMBS), np.uint64)
    for j, off in enumerate(_bit_offsets(pixels_per_word, pixel_bits)):
        limb, sh = divmod(off, 64)
        out[:, limb] |= pad[:, j] << np.uint64(sh)
        if sh + pixel_bits > 64:
            out[:, limb + 1] |= pad[:, j] >> np.uint64(64 - sh)
    return out


def unpack_words(words, count=None, *, pixel_bits=PIXEL_BITS, pixels_per_word=PIXELS_PER_WORD):
    """Inverse of :func:`pack_words`: the first ``count`` values (default all), uint64."""
    w = np.asarray(words, np.uint64).reshape(-1, _LIMBS)
    mask = np.uint64((1 << pixel_bits) - 1)
    out = np.zeros((len(w), pixels_per_word), np.uint64)
    for j, off in enumerate(_bit_offsets(pixels_per_word, pixel_bits)):
        limb, sh = divmod(off, 64)
        val = w[:, limb] >> np.uint64(sh)
        if sh + pixel_bits > 64:
            val |= w[:, limb + 1] << np.uint64(64 - sh)
        out[:, j] = val & mask
    out = out.ravel()
    return out if count is None else out[:count]


def pack_lines(frame, layout):
    """Words of every line of ``frame`` (rows, width[, channels]): (rows, words_per_line, 4)."""
    f = np.asarray(frame)
    rows = f.shape[0]
    flat = f.reshape(rows, -1)
    if flat.shape[1] != layout.values_per_line:
        raise TdicamError(f"frame lines have {flat.shape[1]} values, the layout "
                          f"{layout.values_per_line}")
    return np.stack([pack_words(line, pixel_bits=layout.pixel_bits,
                                pixels_per_word=layout.pixels_per_word) for line in flat]) \
        if rows else np.zeros((0, layout.words_per_line, _LIMBS), np.uint64)


def unpack_lines(words, layout):
    """Inverse of :func:`pack_lines`: (rows, width * channels) uint64."""
    w = np.asarray(words, np.uint64)
    return np.stack([unpack_words(line, layout.values_per_line, pixel_bits=layout.pixel_bits,
                                  pixels_per_word=layout.pixels_per_word) for line in w]) \
        if len(w) else np.zeros((0, layout.values_per_line), np.uint64)


def words_to_ints(words):
    """(n, 4) limbs -> list of Python ints (256-bit words)."""
    w = np.asarray(words, np.uint64).reshape(-1, _LIMBS)
    return [sum(int(x) << (64 * k) for k, x in enumerate(row)) for row in w]


def ints_to_words(ints):
    """List of 256-bit Python ints -> (n, 4) uint64 limbs."""
    m = (1 << 64) - 1
    return np.array([[(int(v) >> (64 * k)) & m for k in range(_LIMBS)] for v in ints],
                    np.uint64).reshape(-1, _LIMBS)


def psums_per_word(psum_bits, ppc=1):
    """Partial sums per 256-bit word for TDI in DDR: ``floor(256 / psum_bits)`` rounded down
    to a multiple of ``ppc`` (so a beat's pixels never straddle two words)."""
    k = WORD_BITS // int(psum_bits)
    k -= k % int(ppc)
    if k < 1:
        raise TdicamError(f"{psum_bits}-bit partial sums x ppc = {ppc} do not fit one "
                          f"{WORD_BITS}-bit word")
    return k


# ---------------------------------------------------------------------------------------
# memory model
# ---------------------------------------------------------------------------------------

def xorshift32(s):
    """One step of the xorshift32 generator shared by :class:`MigSim` and the HDL model."""
    s ^= (s << 13) & 0xFFFFFFFF
    s ^= s >> 17
    s ^= (s << 5) & 0xFFFFFFFF
    return s


def _check_stalls(lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed):
    check_range("lat_lo", lat_lo, 2, 1000)
    check_range("lat_hi", lat_hi, lat_lo, 1000)
    check_range("refresh_period", refresh_period, 1, 1 << 20)
    check_range("refresh_cycles", refresh_cycles, 0, refresh_period - 1)
    check_range("drop", drop, 0, 255)
    check_range("seed", seed, 1, 0xFFFFFFFF)


def worst_stall(params):
    """Processing clocks the simulation MIG model can keep a DDR user waiting at once
    (:class:`tdicam.hdl.simmodels.mig_model.MigModel`, parameters ``params`` as a DDR
    block's stall parameters): a read issued as a refresh begins waits ``refresh_cycles``
    for the command and ``lat_hi`` for its data, ``refresh_cycles + lat_hi`` (104 with
    :data:`DEFAULT_STALLS`). A DDR block at the head of a chain (cds_ddr reads each signal
    frame's first reset line when the frame is presented) holds the stream that long."""
    p = {**DEFAULT_STALLS, **{k: v for k, v in params.items() if k in DEFAULT_STALLS}}
    return int(p["refresh_cycles"]) + int(p["lat_hi"])


def _refreshing(t, period, cycles):
    """Refresh at cycle ``t``: the first ``cycles`` of every ``period`` after the first (a
    refresh timer that starts at reset, as LiteDRAM's)."""
    return t >= period and t % period < cycles


def stall_pattern(cycles, *, lat_lo=20, lat_hi=60, refresh_period=780, refresh_cycles=44,
                  drop=16, seed=1):
    """Per-cycle (app_rdy allowed, app_wdf_rdy allowed, read latency) of the stall pattern.

    ``app_rdy`` is further low while the model's return queue is full and ``app_wdf_rdy``
    while its write-data FIFO is full (not included here). Identical to the HDL model.
    """
    _check_stalls(lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed)
    s = seed   # xorshift32 state: every seed its own pattern
    a = np.zeros(cycles, bool)
    w = np.zeros(cycles, bool)
    lat = np.zeros(cycles, np.int64)
    span = lat_hi - lat_lo + 1
    for t in range(cycles):
        refresh = _refreshing(t, refresh_period, refresh_cycles)
        a[t] = not refresh and (s & 0xFF) >= drop
        w[t] = ((s >> 8) & 0xFF) >= drop
        lat[t] = lat_lo + ((((s >> 16) & 0xFFFF) * span) >> 16)
        s = xorshift32(s)
    return a, w, lat


class MigSim:
    """Cycle-stepped model of a MIG-style DDR3 controller's user interface.

    Call :meth:`outputs` for the values the controller drives in the current cycle (they
    depend on its state only), then :meth:`step` with what the user drove in that cycle.
    Memory is a dict of 256-bit Python ints keyed by word address; unwritten words read 0.

    Parameters
    ----------
    capacity_bytes : int
        Memory size; addresses ``>= capacity_bytes / 4`` are out of range.
    lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed
        The stall pattern (:data:`DEFAULT_STALLS`).
    wdf_depth, ret_depth : int
        Write-data FIFO and read-return queue depths (``app_wdf_rdy``/``app_rdy`` low when
        full).

    Raises
    ------
    TdicamError
        From :meth:`step`: an out-of-range or unaligned address, a write command without
        write data accepted before it, ``app_wdf_end`` missing on a data beat.
    """

    WDF_DEPTH = 16
    RET_DEPTH = 128

    def __init__(self, *, capacity_bytes=CAPACITY_BYTES, lat_lo=20, lat_hi=60,
                 refresh_period=780, refresh_cycles=44, drop=16, seed=1, dram=None):
        _check_stalls(lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed)
        self.dram = dram
        self.busy_until = 0         # DRAM timing: app_rdy low before this cycle
        self.last_dir = self.last_bank = None
        self.open_rows = {}
        self.units = min(capacity_bytes // 4, 1 << ADDR_BITS)
        self.lat_lo, self.lat_hi = lat_lo, lat_hi
        self.refresh_period, self.refresh_cycles = refresh_period, refresh_cycles
        self.drop = drop
        self.s = seed   # xorshift32 state: every seed its own pattern
        self.t = 0
        self.mem = {}
        self.wdf = deque()
        self.ret = deque()          # (due cycle, data)
        self.last_due = -1
        self.stats = {"writes": 0, "reads": 0, "cycles": 0}

    def outputs(self):
        """dict: app_rdy, app_wdf_rdy, app_rd_data_valid, app_rd_data for this cycle."""
        refresh = _refreshing(self.t, self.refresh_period, self.refresh_cycles)
        rdy = (not refresh and (self.s & 0xFF) >= self.drop
               and len(self.ret) < self.RET_DEPTH - 2 and self.t >= self.busy_until)
        wrdy = ((self.s >> 8) & 0xFF) >= self.drop and len(self.wdf) < self.WDF_DEPTH
        valid = bool(self.ret) and self.ret[0][0] <= self.t
        return {"app_rdy": rdy, "app_wdf_rdy": wrdy, "app_rd_data_valid": valid,
                "app_rd_data": self.ret[0][1] if valid else 0}

    def _addr(self, addr):
        if addr % ADDR_PER_WORD or addr >= self.units:
            raise TdicamError(f"DDR address {addr} is out of range or not word aligned "
                              f"(valid: multiples of {ADDR_PER_WORD} below {self.units})")
        return addr

    def step(self, *, app_en=0, app_cmd=0, app_addr=0, app_wdf_wren=0, app_wdf_data=0,
             app_wdf_end=1):
        """Advance one clock edge with the user's signals of this cycle; returns the read
        data delivered in this cycle (int) or None."""
        o = self.outputs()
        if _refreshing(self.t, self.refresh_period, self.refresh_cycles):
            self.open_rows.clear()          # a refresh precharges every bank
        span = self.lat_hi - self.lat_lo + 1
        lat = self.lat_lo + ((((self.s >> 16) & 0xFFFF) * span) >> 16)
        out = None
        if o["app_rd_data_valid"]:
            out = self.ret.popleft()[1]
        if app_en and o["app_rdy"]:
            a = self._addr(int(app_addr))
            if self.dram is not None:
                self._dram_cost(int(app_cmd) == 1, a // ADDR_PER_WORD)
            if int(app_cmd) == 0:
                if not self.wdf:
                    raise TdicamError(f"DDR write command to {a} without write data "
                                      "accepted before it")
                self.mem[a] = self.wdf.popleft()
                self.stats["writes"] += 1
            elif int(app_cmd) == 1:
                due = max(self.t + lat, self.last_due + 1)
                self.last_due = due
                self.ret.append((due, self.mem.get(a, 0)))
                self.stats["reads"] += 1
            else:
                raise TdicamError(f"app_cmd = {int(app_cmd)} is not valid; valid: 0 (write), "
                                  "1 (read)")
        if app_wdf_wren and o["app_wdf_rdy"]:
            if not app_wdf_end:
                raise TdicamError("app_wdf_end low on a 256-bit data beat (one beat per "
                                  "burst: it must be high with every app_wdf_wren)")
            self.wdf.append(int(app_wdf_data))
        self.s = xorshift32(self.s)
        self.t += 1
        self.stats["cycles"] += 1
        return out

    def read_word(self, addr):
        return self.mem.get(self._addr(addr), 0)

    def _dram_cost(self, read, word):
        """Hold ``app_rdy`` low after a command for what it cost on DRAM
        (:meth:`DramTiming.cost`, from the previous command's direction and bank and the
        rows open in the banks)."""
        bank, row = (word // ROW_WORDS) % BANKS, word // (ROW_WORDS * BANKS)
        cost = self.dram.cost(self.last_bank, self.last_dir, bank, read,
                              self.open_rows.get(bank), row)
        self.open_rows[bank] = row
        self.last_dir, self.last_bank = read, bank
        self.busy_until = self.t + 1 + cost


@dataclass(frozen=True)
class DramTiming:
    """DRAM costs of :class:`MigSim` with ``dram=`` given, in controller cycles (100 MHz,
    DDR3-800 behind a 1:4 controller), read off LiteDRAM's command timeline
    (:mod:`tdicam.cosim.litedram`; its bank machines, crossbar and multiplexer, one port).

    The gap a command costs (:meth:`cost`; the model holds ``app_rdy`` low for it after the
    command) is built as LiteDRAM's controller spends it:

    * ``vis``: cycles until the command reaches its bank's queue — ``first`` for the first
      command (the pipeline fills), ``bank`` when the previous command went to another bank
      (the crossbar lets a port into a new bank only when the old one's queue is empty),
      else 0;
    * the turnaround: read->write ``vis + rd_to_wr`` (the controller leaves its read state
      only once it sees the write, then waits out the read latency), write->read
      ``max(wr_to_rd, vis + 3)`` (tWTR counts from the last write while the read comes
      in), same direction ``vis``; the controller idles in its read state, so the first
      command, a write, pays the read->write turnaround;
    * plus ``activate`` when the command's bank has no row open or another row (row-bank-
      column mapping, :data:`ROW_WORDS`-word rows, :data:`BANKS` banks; a refresh closes
      every row), ``precharge`` more when another row was open; when the previous command
      wrote to that bank, the precharge waits ``write_recovery`` (tWR) after it, which runs
      during the turnaround: the turnaround counts as ``max(turn, write_recovery)``
      (charging both one after the other made the model 3.8 points pessimistic on
      ``write_read_lag16``: 74.2 % against LiteDRAM's 78.0 %; now 75.7 %).

    Use it with :data:`DRAM_STALLS` (refresh 44 cycles every 782, no random drops). The HDL
    model (:class:`tdicam.hdl.simmodels.mig_model.MigModel`) with the same ``dram`` is cycle-equal."""

    rd_to_wr: int = 8
    wr_to_rd: int = 5
    activate: int = 5
    precharge: int = 3
    write_recovery: int = 10
    bank: int = 3
    first: int = 6

    def cost(self, last_bank, last_read, bank, read, open_row, row):
        """Cycles the command (``bank``, ``read``, ``row``; its bank's ``open_row`` or None)
        costs after one to ``last_bank`` (None: the first command) in direction
        ``last_read``."""
        vis = self.first if last_bank is None else (self.bank if bank != last_bank else 0)
        was_read = True if last_bank is None else last_read
        if read == was_read:
            turn = vis
        elif read:
            turn = max(self.wr_to_rd, vis + 3)
        else:
            turn = vis + self.rd_to_wr
        act = 0 if open_row == row else self.activate
        if open_row is not None and open_row != row:
            act += self.precharge
            if bank == last_bank and not last_read:
                turn = max(turn, self.write_recovery)     # tWR runs during the turnaround
        return turn + act


#: stall pattern to use with :class:`DramTiming`: refresh 44 cycles (precharge all, tRFC,
#: rows opened again), read data 9 cycles after the read's turn (LiteDRAM's read latency 8
#: plus one; the gaps :class:`DramTiming` charges already hold the commands back)
DRAM_STALLS = {"lat_lo": 9, "lat_hi": 9, "refresh_period": 782, "refresh_cycles": 44,
               "drop": 0, "seed": 1}

#: the refresh interval tREFI in controller cycles (7.8 us at 100 MHz; :data:`DRAM_STALLS`)
TREFI = DRAM_STALLS["refresh_period"]
#: cycles after the first command that an efficiency window skips (the controller's
#: pipeline fill, the first row activations and read latency)
STARTUP = 100
#: refresh intervals an efficiency window spans: every DDR efficiency figure is words moved
#: in ``WINDOW_REFRESHES * TREFI`` cycles of steady state (so it pays its refreshes)
WINDOW_REFRESHES = 4


def window_cycles(refreshes=WINDOW_REFRESHES):
    """Length (cycles) of an efficiency window of ``refreshes`` refresh intervals."""
    return int(refreshes) * TREFI


def window_efficiency(beats, first, end, *, refreshes=WINDOW_REFRESHES, name="trace"):
    """``(words, cycles, efficiency)`` over the steady-state window of a replay.

    ``beats`` are the cycles of the data beats (a write's word taken, a read's word
    returned), ``first`` the cycle of the first command, ``end`` the cycle the replay had
    reached when it stopped, ``end`` of a replay that ran out of commands = its last beat
    + 1. The window opens :data:`STARTUP` cycles after ``first`` and lasts
    :func:`window_cycles` (``refreshes``) cycles; the efficiency is the beats inside it /
    its length. Raises :class:`TdicamError` when the replay ends before the window closes
    (the trace is too short to measure)."""
    lo = first + STARTUP
    hi = lo + window_cycles(refreshes)
    if end < hi:
        raise TdicamError(f"trace {name}: its replay ends {end - first} cycles after the "
                          f"first command, before the {refreshes}-refresh window "
                          f"({STARTUP}..{hi - first} cycles) closes: make the trace longer")
    words = sum(1 for t in beats if lo <= t < hi)
    return words, hi - lo, words / (hi - lo)


def window_words(refreshes=WINDOW_REFRESHES):
    """Commands a trace needs at least to cover the start-up and the window (a command
    takes at least one cycle, so this many always do at any efficiency)."""
    return STARTUP + window_cycles(refreshes) + 64


@dataclass
class Trace:
    """Command order of one user: ``ports[p]`` = list of ``(is_read, word_addr)``.

    ``order`` (optional, two ports): the global order as ``(port, index)`` pairs, used for
    the read-after-write dependencies between ports. ``planned`` (optional): the efficiency
    the planner counts on for the block that issued it."""

    name: str
    ports: list
    order: list = None
    note: str = ""
    planned: float = None

    @property
    def words(self):
        return sum(len(p) for p in self.ports)


# ---------------------------------------------------------------------------------------
# access patterns (command orders) and their efficiency on the memory model
# ---------------------------------------------------------------------------------------

def _line(y, words, stride, base=0):
    return [base + y * stride + w for w in range(words)]


def pattern_trace(name, *, lines=32, words=54, stride=64):
    """The command order of a named access pattern (:data:`PATTERNS`), ``lines`` lines of
    ``words`` words at a ``stride``-word pitch (a 1280 x 10-bit line = 54 words at 64)."""
    if name not in PATTERNS:
        raise TdicamError(f"unknown DDR access pattern {name!r}; valid: {', '.join(PATTERNS)}")
    return PATTERNS[name][0](lines=lines, words=words, stride=stride)


def _write_only(*, lines, words, stride):
    return Trace("write_only", [[(0, a) for y in range(lines) for a in _line(y, words, stride)]])


def _read_only(*, lines, words, stride):
    return Trace("read_only", [[(1, a) for y in range(lines) for a in _line(y, words, stride)]])


def _table2(kind):
    def make(*, lines, words, stride):
        rd = int(kind == "read")
        return Trace(f"table2_{kind}", [[(rd, a) for y in range(lines)
                                         for a in _line(y, 510, 512)]])
    return make


def _line_pairs(lag):
    def make(*, lines, words, stride):
        cmds = []
        for y in range(lines + lag):
            if y < lines:
                cmds += [(0, a) for a in _line(y, words, stride)]
            if y >= lag:
                cmds += [(1, a) for a in _line(y - lag, words, stride)]
        return Trace(f"write_read_lag{lag}", [cmds])
    return make


def _blocks(block):
    def make(*, lines, words, stride):
        wr = [a for y in range(lines) for a in _line(y, words, stride)]
        # reads of the same lines, a line behind (reads of data written earlier)
        lag = words
        n, cmds, i, j = len(wr), [], 0, 0
        while i < n or j < n:
            for _ in range(min(block, n - i)):
                cmds.append((0, wr[i]))
                i += 1
            for _ in range(block):
                if j < n and (j + lag <= i or i == n):
                    cmds.append((1, wr[j]))
                    j += 1
        return Trace(f"blocks_{block}", [cmds])
    return make


def _per_word(*, lines, words, stride):
    # TdiDdr's order: for each word, read the stored sum, then write the new one
    cmds = []
    for y in range(lines):
        for a in _line(y, words, stride):
            cmds += [(1, a), (0, a)]
    return Trace("per_word_rw", [cmds])


def _row_blocks(*, lines, words, stride):
    # TdiDdr's order: a row's stored sums read as one block, then its new sums written
    cmds = []
    for y in range(lines):
        cmds += [(1, a) for a in _line(y, words, stride)]
        cmds += [(0, a) for a in _line(y, words, stride)]
    return Trace("row_blocks", [cmds])


def _two_ports(*, lines, words, stride):
    wr = [(0, a) for y in range(lines) for a in _line(y, words, stride)]
    rd = [(1, a) for y in range(lines - 1) for a in _line(y, words, stride)]
    order, i = [], 0
    for y in range(lines):
        order += [(0, i + w) for w in range(words)]
        i += words
        if y >= 1:
            order += [(1, (y - 1) * words + w) for w in range(words)]
    return Trace("two_ports", [wr, rd], order)


#: name -> (trace maker, description, controller windows (read_time, write_time) or None)
PATTERNS = {
    "write_only": (_write_only, "write only", None),
    "read_only": (_read_only, "read only", None),
    "table2_write": (_table2("write"), "Table 2 layout (510-word lines) write", None),
    "table2_read": (_table2("read"), "Table 2 layout (510-word lines) read", None),
    "write_read_lag1": (_line_pairs(1), "one port, write line n then read line n-1", None),
    "write_read_lag16": (_line_pairs(16), "one port, write line n then read line n-16", None),
    "blocks_27": (_blocks(27), "one port, reads and writes in blocks of 27 words", None),
    "blocks_18": (_blocks(18), "one port, reads and writes in blocks of 18 words", None),
    "blocks_8": (_blocks(8), "one port, reads and writes in blocks of 8 words", None),
    "per_word_rw": (_per_word, "one port, one read then one write per word (the old TdiDdr)",
                    None),
    "row_blocks": (_row_blocks, "one port, a line read as one block then written back "
                                "(TdiDdr)", None),
    "two_ports": (_two_ports, "two ports (writer + reader), controller defaults", None),
    "two_ports_64": (_two_ports, "two ports, 64-cycle read and write windows", (64, 64)),
}


#: LiteDRAM's controller defaults (``ControllerSettings``): read window 32 cycles, write
#: window 16 cycles
_DEFAULT_WINDOWS = (32, 16)
#: commands a turn carries beyond its window's cycles: LiteDRAM leaves a direction only when
#: the other one has a command queued, and the bank machines' command queues
#: (``cmd_buffer_depth`` 8) plus the command in flight are issued in the turn. Read off
#: LiteDRAM over the steady-state window (tests/ddr_litedram.json): ``two_ports`` (32/16)
#: 73.2 % (this rule 73.4 %; counting the window's cycles alone, 65.7 %), ``two_ports_64``
#: 82.2 % (84.1 %)
TURN_QUEUED = 9


def _windows(trace, order, read_time, write_time):
    """Merge a writer port and a reader port as a controller with read and write windows
    of ``read_time`` and ``write_time`` cycles does: up to ``write_time + TURN_QUEUED``
    writes, then up to ``read_time + TURN_QUEUED`` reads whose words were written
    (``order`` gives the dependencies), and so on."""
    rank = {pk: n for n, pk in enumerate(order)}
    w = [pk for pk in order if not trace.ports[pk[0]][pk[1]][0]]
    r = [pk for pk in order if trace.ports[pk[0]][pk[1]][0]]
    last_w = {}
    for n, pk in enumerate(order):
        if not trace.ports[pk[0]][pk[1]][0]:
            last_w[trace.ports[pk[0]][pk[1]][1]] = n
    out, i, j = [], 0, 0
    while i < len(w) or j < len(r):
        for _ in range(write_time + TURN_QUEUED):
            if i < len(w):
                out.append(w[i])
                i += 1
        done = rank[w[i - 1]] if i else -1
        for _ in range(read_time + TURN_QUEUED):
            if j < len(r) and (i == len(w) or last_w.get(trace.ports[r[j][0]][r[j][1]][1],
                                                         -1) <= done):
                out.append(r[j])
                j += 1
    return out


def merged_commands(trace, dram=None, windows=None):
    """The one-port command order :func:`replay_model` issues for ``trace``: a two-port
    trace merged in ``trace.order`` (with ``dram``: in the controller's read and write
    windows, ``windows`` or LiteDRAM's defaults (32, 16) cycles)."""
    order = trace.order or [(0, k) for k in range(len(trace.ports[0]))]
    if len(trace.ports) == 2 and dram is not None:
        order = _windows(trace, order, *(windows or _DEFAULT_WINDOWS))
    return [trace.ports[p][k] for p, k in order]


def trace_dram(trace, dram):
    """The DRAM timing a replay of ``trace`` charges: ``dram``, except for a two-port trace,
    whose ports each keep their own queue in their bank (LiteDRAM's crossbar holds a port,
    not the controller, to one bank at a time), so the merged stream pays no queue drain
    when it changes bank (``bank`` = 0)."""
    if dram is None or len(trace.ports) < 2:
        return dram
    return dataclasses.replace(dram, bank=0)


class TraceDriver:
    """The user side of a replay: issues ``cmds`` (``(is_read, word_addr)``) back to back
    on a MIG UI, write data offered as early as the controller takes it (data first), each
    command as soon as it may go. Each cycle: :meth:`drive` (the UI inputs of this cycle),
    then :meth:`update` with the controller's ``app_rdy``, ``app_wdf_rdy`` and
    ``app_rd_data_valid`` of the same cycle. Drives any controller model the same way
    (:class:`MigSim`, :class:`tdicam.hdl.simmodels.mig_model.MigModel`)."""

    def __init__(self, cmds):
        self.cmds = list(cmds)
        self.writes = [a for rd, a in self.cmds if not rd]
        self.nreads = len(self.cmds) - len(self.writes)
        self.ci = self.wi = self.wc = self.got = self.t = self.last = 0
        self.beats = []         # cycle of each data beat (see :attr:`result`)

    @property
    def done(self):
        return self.ci >= len(self.cmds) and self.got >= self.nreads

    def drive(self):
        """dict of app_en, app_cmd, app_addr, app_wdf_wren, app_wdf_data for this cycle."""
        rd, a = self.cmds[self.ci] if self.ci < len(self.cmds) else (0, 0)
        self._en = self.ci < len(self.cmds) and bool(rd or self.wi > self.wc)
        self._wren = self.wi < len(self.writes)
        self._rd = rd
        return {"app_en": int(self._en), "app_cmd": int(rd), "app_addr": a * ADDR_PER_WORD,
                "app_wdf_wren": int(self._wren), "app_wdf_data": 0}

    def update(self, app_rdy, app_wdf_rdy, app_rd_data_valid):
        if self._wren and app_wdf_rdy:
            self.wi += 1
        if self._en and app_rdy:
            self.ci += 1
            if not self._rd:
                self.wc += 1
                self.last = self.t
                self.beats.append(self.t)
        if app_rd_data_valid:
            self.got += 1
            self.last = self.t
            self.beats.append(self.t)
        self.t += 1

    @property
    def result(self):
        """``(words, cycles, efficiency)``: cycles from the first command offered to the
        last data beat (a write's command accepted, a read's data returned)."""
        return len(self.cmds), self.last + 1, len(self.cmds) / (self.last + 1)


def replay_model(trace, dram=None, windows=None, *, steady=False, **stalls):
    """Replay ``trace`` (:class:`Trace`) through :class:`MigSim` with data always available
    (:class:`TraceDriver`; a two-port trace merged by :func:`merged_commands`). Stalls:
    :data:`DEFAULT_STALLS` without ``dram``, :data:`DRAM_STALLS` with it, updated by
    ``stalls``. Returns ``(words, cycles, efficiency)``: over the whole trace
    (:attr:`TraceDriver.result`), or with ``steady`` over the steady-state window
    (:func:`window_efficiency`; the replay stops when it closes)."""
    cmds = merged_commands(trace, dram, windows)
    base = DEFAULT_STALLS if dram is None else DRAM_STALLS
    sim = MigSim(dram=trace_dram(trace, dram), **{**base, **stalls})
    drv = TraceDriver(cmds)
    stop = STARTUP + window_cycles() if steady else None
    while not drv.done and (stop is None or drv.t < stop):
        o = sim.outputs()
        sim.step(**drv.drive())
        drv.update(o["app_rdy"], o["app_wdf_rdy"], o["app_rd_data_valid"])
        if drv.t > 100 * len(cmds) + 10000:
            raise TdicamError(f"trace {trace.name}: the memory model did not finish")
    if steady:
        return window_efficiency(drv.beats, 0, drv.last + 1 if drv.done else drv.t,
                                 name=trace.name)
    return drv.result


def pattern_lines(name, *, words=54):
    """Lines of ``words`` words the pattern ``name`` needs to cover the start-up and the
    steady-state window (:func:`window_words`; the line-lag patterns at least their lag + 1)."""
    lag = 17 if name == "write_read_lag16" else 2
    per_line = pattern_trace(name, lines=lag, words=words).words / lag
    return max(lag, -(-window_words() // int(per_line)) + 1)


def pattern_efficiency(name, *, lines=None, words=54, stride=64, dram=DramTiming(),
                       **stalls):
    """Steady-state efficiency (words moved / cycles, 0..1, over :func:`window_efficiency`'s
    window of :data:`WINDOW_REFRESHES` refresh intervals) of the named access pattern
    (:data:`PATTERNS`) on the memory model :class:`MigSim` with DRAM timing ``dram`` (default
    :class:`DramTiming`, stalls :data:`DRAM_STALLS`; ``dram=None``: the plain stall pattern
    :data:`DEFAULT_STALLS`, which ignores the order of accesses), ``lines`` lines (default
    :func:`pattern_lines`) of ``words`` words at a ``stride``-word pitch. For the planner:
    the DDR share a design can count on for that order of accesses."""
    lines = pattern_lines(name, words=words) if lines is None else lines
    tr = pattern_trace(name, lines=lines, words=words, stride=stride)
    return replay_model(tr, dram, PATTERNS[name][2], steady=True, **stalls)[2]


#: share the planner takes off the memory model's figure for the TDI spill: the band the
#: model is held to against LiteDRAM (+/-3 points on every pattern of PATTERNS and every
#: DDR block's recorded order, tests/test_ddrref.py; on TdiDdr's own orders the model is
#: within a point or two of LiteDRAM,
#: TdiDdr's own orders, all over the steady-state window of 4 refresh intervals).
PLAN_MARGIN = 0.03
#: ``(memory model %, LiteDRAM % or None: not measured)`` on each DDR block's own command
#: order, over the steady-state window of :data:`WINDOW_REFRESHES` refresh intervals
#: (``window_cycles()`` = 3128 cycles; LiteDRAM's figures are tests/ddr_litedram.json's,
#: which ``python bench/bench_ddr.py --litedram --fixture`` writes, and tests/test_ddrref.py
#: holds both columns to the fixture and the model re-measured). The blocks other than the
#: TDI spill are planned at :data:`tdicam.model.physics.memory.DDR_EFFICIENCY` (80 %).
MEASURED_EFFICIENCY = {'writer': (87.2, 86.2),
                       'reader': (87.2, 87.5),
                       'ddr': (81.4, 81.0),
                       'cds_ddr': (87.0, 86.7),
                       'cds_ddr_wide': (84.9, 84.8),
                       'tdi_ddr': (83.3, 82.1),
                       'tdi_ddr_wide': (86.9, 86.3)}
#: what the blocks of :data:`MEASURED_EFFICIENCY` are
BLOCK_TEXT = {"writer": "the frame buffer's line writer", "reader": "its line reader",
              "ddr": "the frame buffer", "cds_ddr": "CDS with its reset frame in DDR",
              "cds_ddr_wide": "CDS with its reset frame in DDR, 4096 columns",
              "tdi_ddr": "the TDI spill", "tdi_ddr_wide": "the TDI spill, 4096 columns"}


def closest_block(planned):
    """``(name, efficiency %, source)`` of the DDR block, other than the TDI spill (which
    has its own plan, :func:`tdi_spill_efficiency`), whose figure in
    :data:`MEASURED_EFFICIENCY` comes closest to ``planned`` (a share, 0..1): the lower of
    the model's and LiteDRAM's where both are measured; ``source`` names the one taken."""
    rows = []
    for n, (model, lite) in MEASURED_EFFICIENCY.items():
        if not n.startswith("tdi"):
            e, src = (model, "memory model") if lite is None or model <= lite \
                else (lite, "LiteDRAM")
            rows.append((e - 100 * planned, n, e, src))
    _, name, eff, src = min(rows)
    return name, eff, src
#: the access pattern of TDI partial sums in DDR (:class:`tdicam.hdl.tdi_ddr.TdiDdr`)
TDI_SPILL_PATTERN = "row_blocks"


@functools.lru_cache(maxsize=256)
def tdi_spill_efficiency(width, stages, pixel_bits, ppc=1):
    """``(pattern, efficiency)`` the planner counts on for TDI partial sums in DDR.

    The pattern is :class:`tdicam.hdl.tdi_ddr.TdiDdr`'s order (:data:`TDI_SPILL_PATTERN`: a
    row's stored sums read as one block of a line, then the line written back) with that
    configuration's words per line (:func:`psums_per_word` sums per word), its efficiency
    on the memory model with DRAM timing (:func:`pattern_efficiency`, over its steady-state
    window of :data:`WINDOW_REFRESHES` refresh intervals) less :data:`PLAN_MARGIN`, so
    LiteDRAM's DDR3 controller, measured on the block's own order over the same window,
    still meets the plan."""
    from tdicam.model.tdi import full_bits
    k = psums_per_word(full_bits(pixel_bits, stages), ppc)
    wpl = -(-(int(width) // int(ppc)) // (k // int(ppc)))
    e = pattern_efficiency(TDI_SPILL_PATTERN, lines=-(-window_words() // (2 * wpl)) + 1,
                           words=wpl, stride=wpl)
    return TDI_SPILL_PATTERN, e - PLAN_MARGIN
