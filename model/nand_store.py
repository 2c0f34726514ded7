"""Calibration in NAND flash as the camera stores it (Ning et al. 2019 §4.3).

Ning Yonghui et al. (Optics and Precision Engineering 27(5), 2019) keep the per-pixel
correction coefficients in a 4 Gb NAND flash: at power-up the FPGA builds a bad-block
table, maps logical blocks to good physical blocks, reads the pages through 64/72 ECC and
falls back to default coefficients (gain 1, offset 0; 4 coefficients) for a word with more
than one flipped bit. This module is the numpy model of the device, of the image the
camera stores in it, and the golden model of :class:`tdicam.hdl.nand_store.NandCalibStore`.

Device (:class:`Geometry`, :class:`NandDevice`)
-----------------------------------------------
Default geometry: a 4 Gb x8 part such as the Micron MT29F4G08ABADA: pages of 2,048 data
bytes + 64 spare bytes (2,112), 64 pages per block, 4,096 blocks; row address =
``block * pages_per_block + page``; 5 address cycles (2 column, 3 row). Tests use the same
page/spare layout with fewer blocks and pages per block (both powers of two).

* **Bad-block marker**: a block is bad when byte 0 of the spare area (column 2,048) of its
  first page (page 0) is not ``0xFF``; the factory and this model's writer mark with
  ``0x00``. Block 0 is guaranteed good by the vendor (Micron: "block 0 is guaranteed to be
  valid at shipment"); the model never makes it bad and the image keeps the block map there.
* **Erased state** ``0xFF``; *program* can only clear bits (the stored page becomes
  ``old AND new``); *erase* sets the whole block to ``0xFF`` (a factory marker survives
  erase in this model: factory-bad blocks are never erased by the writer).
* **Status** (70h) after program/erase: bit 0 FAIL, bit 6 RDY, bit 7 not write-protected:
  ``0xC0`` pass, ``0xC1`` fail.
* **Busy times** (MT29F4G08 data sheet): page read ``t_R`` = 25 us, program ``t_PROG`` =
  200 us, block erase ``t_BERS`` = 700 us (typical); :attr:`NandDevice.busy_s` sums them.
* **Faults**: factory bad blocks (:meth:`NandDevice.mark_bad`), blocks that fail every
  program (``fail_program``; the status has FAIL set and the page is left erased; only the
  bad-block marker write, a program touching nothing but spare byte 0 of page 0, succeeds),
  grown bad blocks (the writer marks a block whose program or erase failed), bit flips in
  page data (:meth:`NandDevice.flip_bits`).
* **Sparse**: only programmed pages are stored (a dict row -> 2,112 bytes), so a 4 Gb part
  costs what is written.

The image the camera stores (version 1)
---------------------------------------
The calibration stream is the flash words of :mod:`tdicam.model.calib` (9 bytes each: 8
data bytes and the SECDED check byte; a 4-word header, then the coefficients, 2 pixels per
word). Pages hold :attr:`Geometry.words_per_page` = ``page_bytes // 9`` = 227 words in
their data area (bytes 0..2042; bytes 2043..2047 and the spare area stay ``0xFF``, except
the marker byte). Logical block ``k`` (``k`` = 0, 1, ...) holds stream words
``k * words_per_block ...`` page by page; it is stored in the ``k``-th good block after
block 0 (the writer's rule: erase, program page by page, and on a program or erase failure
mark the block bad and start the logical block over in the next good block). Block 0 is
reserved for the *block map*, in the same 9-byte ECC words, page by page:

=====  ===================================================================================
word   data bytes (little-endian)
=====  ===================================================================================
0      ``b"TDINAND"``, version (u8) = 1
1      page_bytes (u16), spare_bytes (u16), pages_per_block (u16), blocks (u16, 0 = 65536)
2      logical blocks used (u32), stream words (u32)
3..    the logical-to-physical map: 4 physical block numbers (u16) per word, ``0xFFFF``
       padding
=====  ===================================================================================

Bad-block replacement (copying a failing block's pages to a spare block, updating the
map) happens in the writer only: as in the paper, whose FPGA drops the replacement logic
because the calibration is written once, the gateware only builds the bad-block table and
the block map and reads.

Reading (the gateware and :func:`store_stream`): a *power-up scan* reads the marker byte of
every block (blocks 0 .. blocks-1) and lists the good blocks after block 0 in order: that
list is the logical-to-physical map (the writer's rule makes it equal to the stored map,
which :func:`read_store` checks). Then the pages of logical blocks 0, 1, ... are read and
their words streamed, in order, into the calibration reader (:func:`tdicam.model.calib.
reader_stream`, the golden model of :class:`~tdicam.hdl.calib.CalibReader`): same output
contract, same counters (corrected / uncorrectable words), the default coefficients for
the two pixels (4 coefficients) of an uncorrectable word. When the part has fewer good
blocks than the stream needs, the reader stops after the last good block (``error``).

Image file (``tdicam calib write --nand``)
------------------------------------------
A sparse dump of the device: a 24-byte header ``b"TDINANDI"``, version (u16) = 1,
page_bytes (u16), spare_bytes (u16), pages_per_block (u16), blocks (u32), stored pages
(u32); then per stored page its row (u32) and its 2,112 bytes (data then spare), rows in
increasing order. Pages not in the file are erased (all ``0xFF``).

(One module past 600 lines: the device, the layout written on it, the file and the golden
read share the geometry and the layout rules stated above; a split would scatter them.)

One module (~670 lines) on purpose: the device, the stored image and the power-up scan
share the geometry and the spare-area conventions, and each is the other's test oracle.
"""

import struct
from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError, check_range
from tdicam.files import write_file
from tdicam.model import calib, ecc
from tdicam.model.nuc import DEFAULT_FORMAT

__all__ = ["Geometry", "MT29F4G08", "NandDevice", "STATUS_PASS", "STATUS_FAIL", "MARKER_GOOD",
           "MARKER_BAD", "MAP_MAGIC", "FILE_MAGIC", "write_store", "scan", "ScanResult",
           "stream_words", "store_stream", "read_store", "StoreResult", "relayout",
           "save_image", "load_image", "read_image_bytes", "Timing", "timing",
           "load_coefficients", "store_roundtrip", "store_device", "blocks_needed",
           "programmed_pages",
           "CONTROLLER_CLOCK_HZ"]

MARKER_GOOD = 0xFF
MARKER_BAD = 0x00
STATUS_PASS = 0xC0
STATUS_FAIL = 0xC1
MAP_MAGIC = b"TDINAND"
MAP_VERSION = 1
FILE_MAGIC = calib.NAND_FILE_MAGIC
FILE_VERSION = 1
_FILE_HDR = struct.Struct("<8sHHHHII")
_ROW = struct.Struct("<I")
MAP_HEADER_WORDS = 3
#: controller clock of the stated load times (a bus cycle = 2 clocks: tRC = tWC = 40 ns)
CONTROLLER_CLOCK_HZ = 50e6


def _pow2(name, value, lo, hi):
    check_range(name, value, lo, hi)
    if value & (value - 1):
        raise TdicamError(f"{name} = {value} must be a power of two")
    return value


@dataclass(frozen=True)
class Geometry:
    """NAND geometry. Defaults: 4 Gb x8 (MT29F4G08): 2,048 + 64 bytes per page, 64 pages
    per block, 4,096 blocks; ``t_r_s``/``t_prog_s``/``t_bers_s``: busy times in seconds."""

    page_bytes: int = 2048
    spare_bytes: int = 64
    pages_per_block: int = 64
    blocks: int = 4096
    t_r_s: float = 25e-6
    t_prog_s: float = 200e-6
    t_bers_s: float = 700e-6

    def __post_init__(self):
        _pow2("page_bytes", self.page_bytes, 512, 16384)
        check_range("spare_bytes", self.spare_bytes, 1, 2048)
        _pow2("pages_per_block", self.pages_per_block, 1, 256)
        check_range("blocks", self.blocks, 2, 65536)
        if self.blocks * self.pages_per_block > 1 << 24:
            raise TdicamError(f"{self.blocks} blocks x {self.pages_per_block} pages need more "
                              f"than the 3 row address cycles (2**24 pages)")

    @property
    def page_size(self):
        """Bytes of a page with its spare area."""
        return self.page_bytes + self.spare_bytes

    @property
    def words_per_page(self):
        """9-byte ECC words in a page's data area."""
        return self.page_bytes // calib.WORD_BYTES

    @property
    def words_per_block(self):
        return self.words_per_page * self.pages_per_block

    @property
    def marker_column(self):
        """Column of the bad-block marker: spare byte 0."""
        return self.page_bytes

    @property
    def bits(self):
        """Capacity of the data areas in bits (4 Gb = 2**32 for the default)."""
        return self.page_bytes * 8 * self.pages_per_block * self.blocks


MT29F4G08 = Geometry()


class NandDevice:
    """Sparse numpy model of one NAND part (see the module docstring).

    Parameters
    ----------
    geometry : Geometry
    fail_program : iterable of int
        Blocks whose programs fail (status FAIL, page left unprogrammed).
    """

    def __init__(self, geometry=MT29F4G08, *, fail_program=()):
        self.geometry = geometry
        self.pages = {}
        self.fail_program = set(int(b) for b in fail_program)
        self.busy_s = 0.0
        self.reads = self.programs = self.erases = 0

    def _row(self, block, page):
        g = self.geometry
        check_range("block", block, 0, g.blocks - 1)
        check_range("page", page, 0, g.pages_per_block - 1)
        return block * g.pages_per_block + page

    def read_page(self, block, page):
        """The page's 2,112 bytes (a copy; ``0xFF`` when never programmed); adds t_R."""
        self.reads += 1
        self.busy_s += self.geometry.t_r_s
        p = self.pages.get(self._row(block, page))
        return np.full(self.geometry.page_size, 0xFF, np.uint8) if p is None else p.copy()

    def marker(self, block):
        """Spare byte 0 of page 0 of ``block`` (no busy time: for inspection)."""
        p = self.pages.get(self._row(block, 0))
        return MARKER_GOOD if p is None else int(p[self.geometry.marker_column])

    def is_bad(self, block):
        return self.marker(block) != MARKER_GOOD

    def program_page(self, block, page, data):
        """Program ``data`` (page_size bytes, ``0xFF`` = leave) into a page: bits can only be
        cleared. Returns the status byte (:data:`STATUS_PASS` / :data:`STATUS_FAIL`)."""
        g = self.geometry
        data = np.asarray(data, np.uint8)
        if data.shape != (g.page_size,):
            raise TdicamError(f"program: {data.size} bytes, a page is {g.page_size}")
        row = self._row(block, page)
        self.programs += 1
        self.busy_s += g.t_prog_s
        marker_only = page == 0 and (np.delete(data, g.marker_column) == 0xFF).all()
        if block in self.fail_program and not marker_only:
            return STATUS_FAIL
        old = self.pages.get(row)
        self.pages[row] = data.copy() if old is None else old & data
        return STATUS_PASS

    def erase_block(self, block):
        """Erase a block (all pages ``0xFF``); returns the status byte."""
        g = self.geometry
        self._row(block, 0)
        self.erases += 1
        self.busy_s += g.t_bers_s
        for p in range(g.pages_per_block):
            self.pages.pop(block * g.pages_per_block + p, None)
        return STATUS_PASS

    def mark_bad(self, block):
        """Write the bad-block marker (``0x00`` at spare byte 0 of page 0)."""
        page = np.full(self.geometry.page_size, 0xFF, np.uint8)
        page[self.geometry.marker_column] = MARKER_BAD
        return self.program_page(block, 0, page)

    def flip_bits(self, block, page, bits):
        """Flip data-area bits (bit index = 8 * column + bit) of a stored page, in place."""
        row = self._row(block, page)
        if row not in self.pages:
            raise TdicamError(f"block {block} page {page} is erased: nothing to flip")
        for b in np.atleast_1d(bits):
            check_range("bit", int(b), 0, 8 * self.geometry.page_bytes - 1)
            self.pages[row][int(b) // 8] ^= np.uint8(1 << (int(b) % 8))

    def bad_blocks(self):
        """Sorted list of the blocks whose marker is not 0xFF (inspection, no busy time)."""
        ppb = self.geometry.pages_per_block
        mc = self.geometry.marker_column
        return sorted(r // ppb for r, p in self.pages.items()
                      if r % ppb == 0 and p[mc] != MARKER_GOOD)


def blocks_needed(n_words, geometry):
    """Logical blocks a stream of ``n_words`` flash words occupies."""
    return -(-int(n_words) // geometry.words_per_block)


def programmed_pages(n_words, geometry):
    """Pages :func:`write_store` programs with data for a stream of ``n_words`` flash words on
    a part without faults: the words' pages (``words_per_page`` a page, the last one
    partial) and the block map's in block 0 (3 header words and a 16-bit entry per logical
    block, four a word)."""
    wpp = geometry.words_per_page
    map_words = 3 + -(-blocks_needed(n_words, geometry) // 4)
    return -(-int(n_words) // wpp) + -(-map_words // wpp)


def _page_bytes(words, geometry):
    """A page's bytes holding up to ``words_per_page`` 9-byte words."""
    page = np.full(geometry.page_size, 0xFF, np.uint8)
    raw = np.asarray(words, np.uint8).reshape(-1)
    page[:raw.size] = raw
    return page


def _u64(b):
    return int.from_bytes(bytes(b), "little")


def _map_words(geometry, l2p, n_words):
    g = geometry
    hdr = [_u64(MAP_MAGIC + bytes([MAP_VERSION])),
           g.page_bytes | g.spare_bytes << 16 | g.pages_per_block << 32
           | (g.blocks & 0xFFFF) << 48,
           len(l2p) | int(n_words) << 32]
    ent = list(l2p) + [0xFFFF] * (-len(l2p) % 4)
    body = [sum(ent[4 * i + j] << (16 * j) for j in range(4)) for i in range(len(ent) // 4)]
    words = np.array(hdr + body, np.uint64)
    return ecc.pack_code(words, ecc.encode(words))


def _program_block(dev, block, pages):
    """Erase ``block`` and program ``pages`` (list of page arrays); False on any failure."""
    if dev.erase_block(block) != STATUS_PASS:
        return False
    return all(dev.program_page(block, p, data) == STATUS_PASS for p, data in enumerate(pages))


def write_store(words, geometry=MT29F4G08, *, bad_blocks=(), fail_program=(), device=None):
    """Program a calibration stream into a part, as the camera's writer does.

    Parameters
    ----------
    words : array_like uint8, shape (n, 9)
        The flash words (:func:`tdicam.model.calib.encode_image`, maybe with flipped bits:
        they are stored as given).
    geometry : Geometry
    bad_blocks : iterable of int
        Factory bad blocks to mark first (never block 0).
    fail_program : iterable of int
        Blocks whose programs fail: the writer marks them bad (grown bad blocks) and moves
        the logical block to the next good block.
    device : NandDevice, optional
        Program into this (empty or pre-marked) device instead of a new one.

    Returns
    -------
    NandDevice

    Raises
    ------
    TdicamError
        Block 0 listed as bad, or fewer good blocks after block 0 than the stream needs.
    """
    w = np.asarray(words, np.uint8).reshape(-1, calib.WORD_BYTES)
    dev = device if device is not None else NandDevice(geometry, fail_program=fail_program)
    g = dev.geometry
    for b in sorted(set(int(b) for b in bad_blocks)):
        if b == 0:
            raise TdicamError("block 0 is guaranteed good (it holds the block map); a bad "
                              "block 0 cannot be injected")
        check_range("bad block", b, 1, g.blocks - 1)
        dev.mark_bad(b)
    need = blocks_needed(len(w), g)
    wpp = g.words_per_page
    l2p, grown = [], []
    block = 1
    for k in range(need):
        chunk = w[k * g.words_per_block:(k + 1) * g.words_per_block]
        pages = [_page_bytes(chunk[p * wpp:(p + 1) * wpp], g)
                 for p in range(-(-len(chunk) // wpp))]
        while True:
            while block < g.blocks and dev.is_bad(block):
                block += 1
            if block >= g.blocks:
                nbad = len(dev.bad_blocks())
                raise TdicamError(
                    f"nand: too many bad blocks: {nbad} of {g.blocks} ({g.blocks - 1 - nbad} "
                    f"good after block 0), the calibration needs {need} blocks of "
                    f"{g.pages_per_block} pages (logical block {k} found no good block)")
            if _program_block(dev, block, pages):
                break
            dev.mark_bad(block)
            grown.append(block)
            block += 1
        l2p.append(block)
        block += 1
    mw = _map_words(g, l2p, len(w))
    map_pages = [_page_bytes(mw[p * wpp:(p + 1) * wpp], g) for p in range(-(-len(mw) // wpp))]
    if len(map_pages) > g.pages_per_block:
        raise TdicamError(f"nand: the block map ({len(mw)} words) does not fit in block 0")
    if not _program_block(dev, 0, map_pages):
        raise TdicamError("nand: programming the block map into block 0 failed")
    dev.grown = grown
    return dev


@dataclass
class ScanResult:
    """Power-up scan: ``bad`` (bool per block), ``l2p`` (good blocks after block 0, in
    order: logical block k -> physical ``l2p[k]``), ``bad_count``."""

    bad: np.ndarray
    l2p: np.ndarray

    @property
    def bad_count(self):
        return int(self.bad.sum())


def scan(device):
    """The power-up scan: one marker read (spare byte 0 of page 0) per block."""
    g = device.geometry
    bad = np.array([device.read_page(b, 0)[g.marker_column] != MARKER_GOOD
                    for b in range(g.blocks)], bool)
    return ScanResult(bad, np.nonzero(~bad[1:])[0].astype(np.int64) + 1)


def stream_words(device, n_words, scan_result=None):
    """The first ``n_words`` flash words (raw, (n, 9) uint8) in logical order, read page by
    page through the scan's map; fewer when the good blocks run out. Returns
    ``(words, complete)``."""
    g = device.geometry
    sr = scan_result if scan_result is not None else scan(device)
    need = blocks_needed(n_words, g)
    wpp = g.words_per_page
    out = []
    left = int(n_words)
    for k in range(min(need, len(sr.l2p))):
        for p in range(g.pages_per_block):
            if left <= 0:
                break
            take = min(wpp, left)
            page = device.read_page(int(sr.l2p[k]), p)
            out.append(page[:take * calib.WORD_BYTES].reshape(take, calib.WORD_BYTES))
            left -= take
    words = np.concatenate(out) if out else np.zeros((0, calib.WORD_BYTES), np.uint8)
    return words, left <= 0


def store_stream(device, *, rows, cols, fmt=DEFAULT_FORMAT, count_bits=calib.DEFAULT_COUNT_BITS):
    """Golden model of :class:`tdicam.hdl.nand_store.NandCalibStore` on ``device``.

    Returns
    -------
    (ReaderOutput, ScanResult, complete)
        The coefficient stream (:func:`tdicam.model.calib.reader_stream` of the words read:
        4 header + ``ceil(rows*cols/2)`` payload words), the scan, and whether every word
        was found (False: the gateware's ``error`` output is set and the stream ends early).
    """
    sr = scan(device)
    n = calib.HEADER_WORDS + calib.payload_words(rows, cols)
    words, complete = stream_words(device, n, sr)
    out = calib.reader_stream(words, rows=rows, cols=cols, fmt=fmt, count_bits=count_bits)
    return out, sr, complete


def _read_map(device, name="nand"):
    """(l2p list, stream words) from the block map in block 0, or raise."""
    g = device.geometry
    wpp = g.words_per_page

    def words_of(page):
        return device.read_page(0, page)[:wpp * calib.WORD_BYTES].reshape(wpp, 9)

    first = ecc.decode(*ecc.unpack_code(words_of(0)))
    if first.uncorrectable[:MAP_HEADER_WORDS].any():
        raise TdicamError(f"{name}: the block map header in block 0 has an uncorrectable error")
    h = [int(x).to_bytes(8, "little") for x in first.data[:MAP_HEADER_WORDS]]
    if h[0][:7] != MAP_MAGIC or h[0][7] != MAP_VERSION:
        raise TdicamError(f"{name}: block 0 holds no block map (magic {h[0][:7]!r}, expected "
                          f"{MAP_MAGIC!r} version {MAP_VERSION})")
    pb, sb, ppb, nb = struct.unpack("<HHHH", h[1])
    if (pb, sb, ppb, nb or 65536) != (g.page_bytes, g.spare_bytes, g.pages_per_block,
                                      g.blocks):
        raise TdicamError(f"{name}: the block map was written for pages of {pb}+{sb} bytes, "
                          f"{ppb} pages/block, {nb or 65536} blocks; the part is {g.page_bytes}"
                          f"+{g.spare_bytes}, {g.pages_per_block}, {g.blocks}")
    n_log, n_words = struct.unpack("<II", h[2])
    n_map = MAP_HEADER_WORDS + -(-n_log // 4)
    if n_map > wpp * g.pages_per_block:
        raise TdicamError(f"{name}: malformed block map: {n_log} logical blocks")
    pages = [words_of(p) for p in range(-(-n_map // wpp))]
    dec = ecc.decode(*ecc.unpack_code(np.concatenate(pages)[:n_map]))
    if dec.uncorrectable.any():
        raise TdicamError(f"{name}: the block map has an uncorrectable error in word "
                          f"{int(np.argmax(dec.uncorrectable))}")
    ent = [(int(x) >> (16 * j)) & 0xFFFF for x in dec.data[MAP_HEADER_WORDS:] for j in range(4)]
    return ent[:n_log], n_words


@dataclass
class StoreResult:
    """:func:`read_store`: the decoded image (with its corrected / uncorrectable word
    counts), the scan, and the calibration stream's words and pages."""

    image: calib.CalibImage
    scan: ScanResult
    words: int = 0
    pages: int = 0


def read_store(device, *, name="nand"):
    """Software read of a stored calibration: scan, check the stored block map against it,
    read the stream and decode it (:func:`tdicam.model.calib.read_image`).

    Raises
    ------
    TdicamError
        One line: no or damaged block map, map disagreeing with the scan, too few good
        blocks for the stream, or any error of :func:`tdicam.model.calib.read_image`.
    """
    sr = scan(device)
    l2p, n_words = _read_map(device, name)
    g = device.geometry
    need = blocks_needed(n_words, g)
    if len(l2p) != need:
        raise TdicamError(f"{name}: the block map lists {len(l2p)} blocks for {n_words} words, "
                          f"which need {need}")
    if len(sr.l2p) < need:
        raise TdicamError(f"{name}: too many bad blocks: {sr.bad_count} of {g.blocks}, the "
                          f"calibration needs {need} good blocks after block 0, the part has "
                          f"{len(sr.l2p)}")
    diff = [k for k in range(need) if l2p[k] != sr.l2p[k]]
    if diff:
        k = diff[0]
        raise TdicamError(f"{name}: the stored block map disagrees with the bad-block scan at "
                          f"logical block {k} (map: {l2p[k]}, scan: {int(sr.l2p[k])})")
    words, _ = stream_words(device, n_words, sr)
    img = calib.read_image(words, name=name)
    return StoreResult(img, sr, words=len(words),
                       pages=-(-len(words) // g.words_per_page))


def relayout(device, *, bad_blocks=(), fail_program=(), flips=None, rng=None, name="nand"):
    """A new device holding ``device``'s calibration stream (raw words, flips included),
    with its bad blocks plus ``bad_blocks`` marked and ``fail_program`` blocks failing;
    ``flips = (p_single, p_double)`` flips random bits in payload words first
    (:func:`tdicam.model.calib.inject_flips`). Returns ``(device, flips per word)``;
    errors name the image ``name``: a damaged block map, an incomplete stream, or a stream
    :func:`tdicam.model.calib.read_image` refuses (e.g. an uncorrectable header word) --
    nothing is re-laid out from an image the camera could not load."""
    _, n_words = _read_map(device, name)
    words, complete = stream_words(device, n_words)
    if not complete:
        raise TdicamError(f"{name}: the image's calibration stream is incomplete")
    calib.read_image(words, name=name)
    k = np.zeros(len(words), np.int64)
    if flips is not None:
        words, k = calib.inject_flips(rng, words, p_single=flips[0], p_double=flips[1])
    bad = set(device.bad_blocks()) | set(int(b) for b in bad_blocks)
    bad.discard(0)
    new = write_store(words, device.geometry, bad_blocks=sorted(bad),
                      fail_program=fail_program)
    return new, k


# ---------------------------------------------------------------- image file
def save_image(device, path):
    """Write the sparse image file (module docstring); returns the byte count.

    Written with :func:`tdicam.files.write_file`: an unwritable ``path`` or a full device
    is a one-line ``PATH: cannot write (REASON)`` and leaves no half-written file."""
    g = device.geometry
    rows = sorted(device.pages)
    parts = [_FILE_HDR.pack(FILE_MAGIC, FILE_VERSION, g.page_bytes, g.spare_bytes,
                            g.pages_per_block, g.blocks, len(rows))]
    for r in rows:
        parts += [_ROW.pack(r), device.pages[r].tobytes()]
    data = b"".join(parts)
    write_file(path, data)       # one-line errors; a half-written file is removed
    return len(data)


def read_image_bytes(raw, *, name="image"):
    """A :class:`NandDevice` from image file bytes, or a one-line error."""
    if len(raw) < _FILE_HDR.size:
        raise TdicamError(f"{name}: truncated: {len(raw)} bytes, the NAND image header alone "
                          f"is {_FILE_HDR.size}")
    magic, ver, pb, sb, ppb, nb, n = _FILE_HDR.unpack_from(raw)
    if magic != FILE_MAGIC:
        raise TdicamError(f"{name}: not a tdicam NAND image (magic {magic!r}, expected "
                          f"{FILE_MAGIC!r})")
    if ver != FILE_VERSION:
        raise TdicamError(f"{name}: unsupported NAND image version {ver}; this reader knows "
                          f"{FILE_VERSION}")
    try:
        g = Geometry(pb, sb, ppb, nb)
    except TdicamError as exc:
        raise TdicamError(f"{name}: malformed NAND image header: {exc}") from None
    rec = _ROW.size + g.page_size
    want = _FILE_HDR.size + n * rec
    if len(raw) != want:
        kind = "truncated" if len(raw) < want else "wrong size"
        raise TdicamError(f"{name}: {kind}: {len(raw)} bytes, the header says {n} pages of "
                          f"{g.page_size} bytes ({want} bytes)")
    dev = NandDevice(g)
    body = np.frombuffer(raw, np.uint8, offset=_FILE_HDR.size).reshape(n, rec)
    rows = body[:, :4].copy().view("<u4").ravel()
    if n and ((np.diff(rows.astype(np.int64)) <= 0).any()
              or int(rows.max()) >= g.blocks * g.pages_per_block):
        raise TdicamError(f"{name}: malformed NAND image: page rows not increasing or beyond "
                          f"the part's {g.blocks * g.pages_per_block} pages")
    for r, page in zip(rows, body[:, 4:]):
        dev.pages[int(r)] = page.copy()
    return dev


def load_image(path):
    """:func:`read_image_bytes` of a file; errors name the file."""
    return read_image_bytes(calib.read_file(path), name=str(path))


def load_coefficients(image_path, *, rows=None, cols=None):
    """Gain and offset maps (float64: gain 1.0 = unity, offset in output LSBs) of a NAND
    calibration image as the camera would load them: scan, map, ECC, defaults on
    uncorrectable words. ``rows``/``cols``, when given, must match the image.

    Returns
    -------
    (gain, offset, StoreResult)
    """
    res = read_store(load_image(image_path), name=str(image_path))
    img = res.image
    if (rows is not None and rows != img.shape[0]) or (cols is not None and cols != img.shape[1]):
        raise TdicamError(f"{image_path}: calibration is {img.shape[0]} x {img.shape[1]} "
                          f"pixels, the sensor is {rows} x {cols}")
    f = img.fmt
    return img.gain / f.gain_one, img.offset / (1 << f.offset_frac_bits), res


def store_roundtrip(gain, offset, fmt=DEFAULT_FORMAT, *, geometry=MT29F4G08, bad_blocks=0,
                    p_single=0.0, p_double=0.0, seed=1):
    """Coefficient codes as the camera loads them after storing them in NAND with faults:
    the calibration image of ``gain``/``offset`` (codes of ``fmt``), random bit flips in its
    payload words (:func:`tdicam.model.calib.inject_flips`), ``bad_blocks`` random factory
    bad blocks (never block 0), the writer, the power-up scan and the read.

    Returns
    -------
    (gain, offset, StoreResult)
        int64 code maps (defaults where a word was uncorrectable) and the counters.
    """
    dev = store_device(gain, offset, fmt, geometry=geometry, bad_blocks=bad_blocks,
                       p_single=p_single, p_double=p_double, seed=seed)
    res = read_store(dev)
    return res.image.gain, res.image.offset, res


def store_device(gain, offset, fmt=DEFAULT_FORMAT, *, geometry=MT29F4G08, bad_blocks=0,
                 p_single=0.0, p_double=0.0, seed=1):
    """The NAND part of :func:`store_roundtrip` (same arguments, same random numbers):
    the calibration image written with its bit flips on a part with ``bad_blocks`` random
    factory bad blocks -- what the camera's flash holds at power-up."""
    rng = np.random.default_rng(seed)
    words = calib.encode_image(gain, offset, fmt)
    if p_single or p_double:
        words, _ = calib.inject_flips(rng, words, p_single=p_single, p_double=p_double)
    check_range("bad_blocks", bad_blocks, 0, geometry.blocks - 1)
    bad = rng.choice(np.arange(1, geometry.blocks), int(bad_blocks), replace=False)
    return write_store(words, geometry, bad_blocks=bad)


# ---------------------------------------------------------------- timing
@dataclass
class Timing:
    """Cycle counts of :class:`~tdicam.hdl.nand_store.NandCalibStore` and the times they take at
    ``clock_hz`` (see :func:`timing`)."""

    clock_hz: float
    busy_cycles: int
    scan_cycles: int
    load_cycles: int
    pages: int
    blocks: int

    @property
    def scan_s(self):
        return self.scan_cycles / self.clock_hz

    @property
    def load_s(self):
        return self.load_cycles / self.clock_hz


#: clocks of the controller steps (hdl/nand.py): a bus cycle (command, address or data) is
#: 2 clocks; a page read = 7 command/address cycles, then R/B# low for the busy time
RESET_CLOCKS = 3
CMD_ADDR_CLOCKS = 7 * 2
MAP_CLOCKS = 2
DONE_CLOCKS = 1


def timing(rows, cols, geometry=MT29F4G08, *, clock_hz=CONTROLLER_CLOCK_HZ, busy_cycles=None):
    """Power-up scan and calibration load time of the gateware, from its cycle model.

    ``scan_cycles``: from the clock ``start`` is seen to ``scan_done``: ``FFh`` and its busy
    time, then per block a page read of page 0 at the marker column (7 bus cycles of 2
    clocks, the busy time) and one data-out cycle (2 clocks). ``load_cycles``: from
    ``scan_done`` to ``done``: per logical block 2 clocks of map look-up, per page the read
    command (14 clocks + busy), per word 9 data-out cycles (18 clocks; the calibration
    reader takes a word every other clock, so it never stalls the bus), and 1 clock. Bad
    blocks cost nothing beyond their scan read: the map is built during the scan.
    ``busy_cycles`` defaults to ``ceil(t_R * clock_hz)``. Exact: equality with the
    Amaranth simulation is asserted in tests/test_nand_store.py.
    """
    g = geometry
    busy = int(np.ceil(g.t_r_s * clock_hz - 1e-9)) if busy_cycles is None else int(busy_cycles)
    scan_cycles = RESET_CLOCKS + busy + g.blocks * (CMD_ADDR_CLOCKS + busy + 2)
    n = calib.HEADER_WORDS + calib.payload_words(rows, cols)
    pages = -(-n // g.words_per_page)
    nblk = blocks_needed(n, g)
    load = pages * (CMD_ADDR_CLOCKS + busy) + n * 9 * 2 + nblk * MAP_CLOCKS + DONE_CLOCKS
    return Timing(clock_hz, busy, scan_cycles, load, pages, nblk)
