"""DDR line/frame buffers behind a MIG-style user interface (Ning et al. 2019 §4.2).

The ``ddr`` block's golden model (the packing, :mod:`tdicam.hdl.ddr`) and the addresses and
words every DDR user shares (the users' own golden models are :mod:`tdicam.model.cds_ddr`
and :mod:`tdicam.model.tdi_ddr`).

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

The controller model (:class:`tdicam.model.dram.MigSim`, the DRAM timing and the
efficiency window) is :mod:`tdicam.model.dram`; access patterns, traces and their replay
:mod:`tdicam.model.ddr_traces`; the efficiencies the planner counts on
:mod:`tdicam.model.ddr_efficiency`.
"""

from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError, check_range

__all__ = ["WORD_BITS", "ADDR_PER_WORD", "ADDR_BITS", "CAPACITY_BYTES", "PIXEL_BITS",
           "PIXELS_PER_WORD", "PAPER_CHANNELS", "PAPER_LINE_STRIDE", "LineLayout",
           "pack_words", "unpack_words", "pack_lines", "unpack_lines", "words_to_ints",
           "ints_to_words", "psums_per_word", "check_capacity"]

WORD_BITS = 256
ADDR_PER_WORD = 8           # 32-bit address unit (Ning et al. 2019 Table 2: 0~7, 8~15, ...)
ADDR_BITS = 28
CAPACITY_BYTES = 1 << 30    # 1 GiB
PIXEL_BITS = 10
PIXELS_PER_WORD = 24
PAPER_CHANNELS = 72
PAPER_LINE_STRIDE = 4096
_LIMBS = WORD_BITS // 64



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
