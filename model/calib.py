"""The ECC-protected calibration store (Ning et al. 2019 §4.3).

Per-pixel ``nuc`` coefficients live in flash as 64-bit words, each protected by the 8 check
bits of the SECDED (72,64) code of :mod:`tdicam.model.ecc`. This module defines the image
format, writes and reads it in software, and is the golden model of the gateware reader
:class:`tdicam.hdl.calib.CalibReader`.

Image format (version 1)
------------------------
The image is a sequence of 9-byte *flash words*: the 64-bit data word, least significant
byte first, then its check byte (``ecc.pack_code``). Every word, header included, is ECC
protected. Words 0..3 are the header (all multi-byte fields little-endian):

=====  ==========================================================================
word   data bytes
=====  ==========================================================================
0      ``b"TDICAL"`` magic, then the version (u16) = 1
1      rows (u32), cols (u32); each 1..65535
2      gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits (u8 each),
       packing (u8) = 1, three zero bytes
3      payload word count (u32) = ceil(rows * cols / 2); CRC-32 (zlib) of the payload
       data words (8 bytes each, before ECC) (u32)
=====  ==========================================================================

then the payload: the coefficients in raster order packed by
:meth:`tdicam.model.nuc.NucFormat.pack_words` (packing 1): word ``k`` holds pixels ``2k``
and ``2k+1`` as four 16-bit slots ``gain[2k], offset[2k], gain[2k+1], offset[2k+1]``
(least significant first): the four coefficients of the paper's 64-bit word. An odd pixel
count is padded with default coefficients. Coefficient codes are those of
:mod:`tdicam.model.nuc` (gain unsigned ``Q<int>.<frac>``, 1.0 = ``1 << gain_frac_bits``;
offset two's complement).

Reading (software, :func:`read_image`, and gateware, :func:`reader_stream`): every word is
decoded; a single flipped bit is corrected (counted as *corrected*); a word with an
uncorrectable error (two flipped bits, or more that the code detects) is counted as
*uncorrectable* and its two pixels get the default coefficients (gain 1.0, offset 0) --
four coefficients. Words with three or more flips may also alias to a wrong correction; the
header CRC lets software (``tdicam calib check``) notice that.
"""

import zlib
from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError, check_range
from tdicam.model import ecc
from tdicam.model.nuc import DEFAULT_FORMAT, NucFormat

__all__ = ["MAGIC", "VERSION", "PACKING", "HEADER_WORDS", "WORD_BYTES", "PIXELS_PER_WORD",
           "payload_words", "header_words", "encode_image", "write_image", "CalibImage",
           "read_image", "load_image", "codes_from_values", "ReaderOutput", "reader_stream",
           "flip_image_bits", "inject_flips", "image_words", "read_file", "DEFAULT_COUNT_BITS",
           "MAX_IMAGE_BYTES"]

MAGIC = b"TDICAL"
VERSION = 1
PACKING = 1
HEADER_WORDS = 4
WORD_BYTES = 9
PIXELS_PER_WORD = 2
MAX_SIDE = 65535
DEFAULT_COUNT_BITS = 32


def payload_words(rows, cols):
    """Payload flash words of a ``rows x cols`` image: ``ceil(rows * cols / 2)``."""
    return -(-rows * cols // PIXELS_PER_WORD)


def _u64(data):
    return int.from_bytes(bytes(data), "little")


def header_words(rows, cols, fmt=DEFAULT_FORMAT, crc=0):
    """The 4 header data words (Python ints) for an image."""
    check_range("rows", rows, 1, MAX_SIDE)
    check_range("cols", cols, 1, MAX_SIDE)
    fmt._check_slots()
    w0 = _u64(MAGIC + VERSION.to_bytes(2, "little"))
    w1 = rows | cols << 32
    w2 = _u64(bytes([fmt.gain_int_bits, fmt.gain_frac_bits, fmt.offset_bits,
                     fmt.offset_frac_bits, PACKING, 0, 0, 0]))
    w3 = payload_words(rows, cols) | (crc & 0xFFFF_FFFF) << 32
    return [w0, w1, w2, w3]


def _crc(words):
    return zlib.crc32(np.asarray(words, "<u8").tobytes())


def encode_image(gain, offset, fmt=DEFAULT_FORMAT):
    """Flash image of coefficient codes.

    Parameters
    ----------
    gain, offset : array_like of int, shape (rows, cols)
        Gain and offset codes in ``fmt`` (see :class:`tdicam.model.nuc.NucFormat`).
    fmt : NucFormat
        Coefficient format; gain and offset at most 16 bits each.

    Returns
    -------
    ndarray of uint8, shape (4 + ceil(rows*cols/2), 9)
        The image's flash words (data bytes, check byte).
    """
    g, o = np.asarray(gain), np.asarray(offset)
    if g.ndim != 2 or g.shape != o.shape:
        raise TdicamError(f"gain and offset must be 2-D maps of one shape; got {g.shape} and "
                          f"{o.shape}")
    rows, cols = g.shape
    payload = fmt.pack_words(g, o)
    words = np.concatenate([np.array(header_words(rows, cols, fmt, _crc(payload)), np.uint64),
                            payload])
    return ecc.pack_code(words, ecc.encode(words))


def write_image(path, gain, offset, fmt=DEFAULT_FORMAT):
    """Write :func:`encode_image` to ``path``; returns the byte count."""
    data = encode_image(gain, offset, fmt).tobytes()
    with open(path, "wb") as fh:
        fh.write(data)
    return len(data)


def codes_from_values(gain, offset, fmt=DEFAULT_FORMAT):
    """Gain/offset codes of real-valued maps (round half up), refusing values the format
    cannot hold instead of saturating them.

    Parameters
    ----------
    gain : array_like of float
        Gains (1.0 = no change), in ``0 .. fmt.gain_max / 2**gain_frac_bits``.
    offset : array_like of float
        Offsets in output LSBs, within the signed offset range.
    """
    out = []
    for name, a, scale, lo, hi in (
            ("gain", gain, fmt.gain_one, 0, fmt.gain_max),
            ("offset", offset, 1 << fmt.offset_frac_bits, fmt.offset_min, fmt.offset_max)):
        try:
            v = np.asarray(a, np.float64)
        except (TypeError, ValueError):
            raise TdicamError(f"{name} map must be numeric") from None
        if not np.all(np.isfinite(v)):
            raise TdicamError(f"{name} map has {int((~np.isfinite(v)).sum())} NaN or "
                              f"infinite values")
        code = np.floor(v * scale + 0.5)
        bad = (code < lo) | (code > hi)
        if bad.any():
            k = np.unravel_index(int(np.argmax(bad)), v.shape)
            raise TdicamError(f"{name} map has {int(bad.sum())} values outside the format's "
                              f"range {lo / scale:g}..{hi / scale:g} (first at {tuple(map(int, k))}: "
                              f"{v[k]:g})")
        out.append(code.astype(np.int64))
    return tuple(out)


@dataclass
class CalibImage:
    """A decoded calibration image (software reader).

    Attributes
    ----------
    gain, offset : ndarray int64, shape (rows, cols)
        Codes; default coefficients where the word was uncorrectable.
    fmt : NucFormat
    corrected, uncorrectable : int
        Words (header and payload) with a corrected single error / an uncorrectable error.
    defaulted : ndarray bool, shape (rows, cols)
        Pixels that got the default coefficients.
    crc_ok : bool
        The decoded payload matches the header's CRC-32 (False after an uncorrectable word
        or a miscorrected >= 3-bit error).
    """

    gain: np.ndarray
    offset: np.ndarray
    fmt: NucFormat
    corrected: int
    uncorrectable: int
    defaulted: np.ndarray
    crc_ok: bool

    @property
    def shape(self):
        return self.gain.shape


def image_words(image, name="image"):
    """The (n, 9) uint8 flash words of an image given as bytes or an array; raises when it
    is not a whole number of words or shorter than the header."""
    raw = np.frombuffer(image, np.uint8) if isinstance(image, (bytes, bytearray, memoryview)) \
        else np.asarray(image, np.uint8).ravel()
    if raw.size % WORD_BYTES:
        raise TdicamError(f"{name}: {raw.size} bytes is not a whole number of {WORD_BYTES}-byte "
                          f"flash words (truncated or not a calibration image)")
    if raw.size < HEADER_WORDS * WORD_BYTES:
        raise TdicamError(f"{name}: truncated: {raw.size} bytes, the header alone is "
                          f"{HEADER_WORDS * WORD_BYTES}")
    return raw.reshape(-1, WORD_BYTES)


def _parse_header(hdr, name):
    """(rows, cols, fmt, n_payload, crc) from 4 decoded header data words, or raise."""
    b = [int(w).to_bytes(8, "little") for w in hdr]
    if b[0][:6] != MAGIC:
        raise TdicamError(f"{name}: not a tdicam calibration image (magic {b[0][:6]!r}, "
                          f"expected {MAGIC!r})")
    version = int.from_bytes(b[0][6:8], "little")
    if version != VERSION:
        raise TdicamError(f"{name}: unsupported image version {version}; this reader knows "
                          f"{VERSION}")
    rows, cols = int.from_bytes(b[1][:4], "little"), int.from_bytes(b[1][4:], "little")
    if not (1 <= rows <= MAX_SIDE and 1 <= cols <= MAX_SIDE):
        raise TdicamError(f"{name}: malformed header: {rows} x {cols} pixels; valid: 1..{MAX_SIDE} "
                          f"each")
    gi, gf, ob, of, packing = b[2][:5]
    if packing != PACKING or any(b[2][5:]):
        raise TdicamError(f"{name}: malformed header: packing {packing} (reserved bytes "
                          f"{b[2][5:].hex()}); this reader knows packing {PACKING}")
    try:
        fmt = NucFormat(gi, gf, ob, of)
        fmt._check_slots()
    except TdicamError as exc:
        raise TdicamError(f"{name}: malformed header: coefficient format: {exc}") from None
    n = int.from_bytes(b[3][:4], "little")
    if n != payload_words(rows, cols):
        raise TdicamError(f"{name}: malformed header: {n} payload words for {rows} x {cols} "
                          f"pixels, which need {payload_words(rows, cols)}")
    return rows, cols, fmt, n, int.from_bytes(b[3][4:], "little")


def _decoded_header(dec, name):
    """(rows, cols, fmt, n_payload, crc) of decoded words ``dec`` (an ``ecc.decode``
    result starting with the header), or raise naming a header word that is uncorrectable."""
    for k in range(HEADER_WORDS):
        if dec.uncorrectable[k]:
            raise TdicamError(f"{name}: header word {k} has an uncorrectable error")
    return _parse_header(dec.data[:HEADER_WORDS], name)


def read_image(image, *, name="image"):
    """Decode a calibration image (bytes or (n, 9) uint8); see the module docstring.

    Raises
    ------
    TdicamError
        One line naming the problem: size not a whole number of words, truncated header or
        payload, trailing data, a header word with an uncorrectable error, bad magic,
        version, dimensions, format or word count.
    """
    words = image_words(image, name)
    data, check = ecc.unpack_code(words)
    dec = ecc.decode(data, check)
    rows, cols, fmt, n, crc = _decoded_header(dec, name)
    have = len(words) - HEADER_WORDS
    if have < n:
        raise TdicamError(f"{name}: truncated: the header says {n} payload words, the file "
                          f"has {have}")
    if have > n:
        raise TdicamError(f"{name}: {have - n} words of trailing data after the {n} payload "
                          f"words")
    pay = dec.data[HEADER_WORDS:]
    bad = dec.uncorrectable[HEADER_WORDS:]
    g, o = fmt.unpack_words(pay)
    bad_px = np.repeat(bad, PIXELS_PER_WORD)
    g = np.where(bad_px, fmt.gain_one, g)[:rows * cols].reshape(rows, cols)
    o = np.where(bad_px, 0, o)[:rows * cols].reshape(rows, cols)
    return CalibImage(g, o, fmt, int(dec.corrected.sum()), int(dec.uncorrectable.sum()),
                      bad_px[:rows * cols].reshape(rows, cols), _crc(pay) == crc)


def load_image(path):
    """:func:`read_image` of a file; errors name the file."""
    return read_image(read_file(path), name=str(path))


def inject_flips(rng, image, *, p_single, p_double, skip_header=True):
    """Copy of ``image`` ((n, 9) uint8) with random bit flips: each word independently gets
    one flipped bit with probability ``p_single``, two distinct flipped bits with
    ``p_double`` (header words untouched when ``skip_header``). Returns (image, flips per
    word as an int array)."""
    n = len(image)
    u = rng.random(n)
    k = np.where(u < p_single, 1, np.where(u < p_single + p_double, 2, 0))
    if skip_header:
        k[:HEADER_WORDS] = 0
    pos = np.full((n, 2), -1)
    for w in np.nonzero(k)[0]:
        pos[w, :k[w]] = rng.choice(ecc.CODE_BITS, k[w], replace=False)
    return flip_image_bits(image, pos), k


#: Largest calibration image read (a 4 Gb NAND part with its spare areas is 528 MiB).
MAX_IMAGE_BYTES = 1 << 30
#: First bytes of a NAND image file (:mod:`tdicam.model.nand_store` writes them; here so that
#: the reader can tell the two forms apart without importing the NAND model).
NAND_FILE_MAGIC = b"TDINANDI"


def _image_size(head, name):
    """The most bytes a file starting with ``head`` may hold: a plain image's header words
    say its length (one word more is let through, so that :func:`read_image` names trailing
    data); a NAND image (:data:`NAND_FILE_MAGIC`) may hold :data:`MAX_IMAGE_BYTES`; raises
    when the header is not a calibration image's."""
    if head.startswith(NAND_FILE_MAGIC) or len(head) < HEADER_WORDS * WORD_BYTES:
        return MAX_IMAGE_BYTES          # a NAND image, or short: read_image names it
    data, check = ecc.unpack_code(image_words(head, name))
    dec = ecc.decode(data, check)
    n = _decoded_header(dec, name)[3]
    return (HEADER_WORDS + n + 1) * WORD_BYTES


def read_file(path):
    """Bytes of a calibration image file (at most :data:`MAX_IMAGE_BYTES`, or what its
    header says), or a one-line error naming it (:func:`tdicam.files.read_bytes`): an
    endless file such as ``/dev/zero`` is refused after its header's bytes."""
    from tdicam.files import read_bytes
    return read_bytes(path, "calibration image", MAX_IMAGE_BYTES,
                      head=(HEADER_WORDS * WORD_BYTES,
                            lambda head: _image_size(head, str(path))))


def flip_image_bits(image, positions):
    """Copy of ``image`` ((n, 9) uint8) with code bits flipped: ``positions`` (n, k) of code
    bit indices 0..71 per word, -1 for none (see :func:`tdicam.model.ecc.flip`)."""
    d, c = ecc.unpack_code(image)
    d, c = ecc.flip(d, c, positions)
    return ecc.pack_code(d, c)


@dataclass
class ReaderOutput:
    """Golden output of :class:`~tdicam.hdl.calib.CalibReader`, one row per output pixel.

    Attributes
    ----------
    gain : ndarray uint64
        Gain code (low ``gain_bits``).
    offset : ndarray uint64
        Offset code, two's complement in the low ``offset_bits`` (upper bits 0).
    corrected, uncorrectable : ndarray uint64
        Saturating counts of words (header and payload, since reset) up to and including the
        word that carried this pixel.
    defaulted : ndarray bool
        Default coefficients were substituted (uncorrectable word or bad header).
    header_error : ndarray bool
        The image's header was bad (then every pixel of that image is defaulted).
    first, last : ndarray bool
        Start of frame (pixel 0 of an image) and end of line (last pixel of each row).
    """

    gain: np.ndarray
    offset: np.ndarray
    corrected: np.ndarray
    uncorrectable: np.ndarray
    defaulted: np.ndarray
    header_error: np.ndarray
    first: np.ndarray
    last: np.ndarray

    def __len__(self):
        return len(self.first)


def _expected_header(rows, cols, fmt):
    return np.array(header_words(rows, cols, fmt), np.uint64)


def reader_stream(words, *, rows, cols, fmt=DEFAULT_FORMAT, count_bits=DEFAULT_COUNT_BITS):
    """Golden model of the gateware reader over a stream of flash words.

    The reader is built for one geometry and format (its parameters). From reset it takes
    4 header words, then ``ceil(rows*cols/2)`` payload words, emits the ``rows x cols``
    coefficient pixels, and starts over with the next image. A header is bad when a header
    word is uncorrectable or its (decoded) data differs from the parameters' header in
    magic, version, rows, cols, format, packing or word count (the CRC field is not
    checked); the image's pixels then all get default coefficients.

    Parameters
    ----------
    words : array_like uint8, shape (n, 9)
        Flash words as read (data bytes, check byte). A trailing partial image produces the
        pixels of the payload words it has (2 per word).
    rows, cols : int
    fmt : NucFormat
    count_bits : int
        Width of the saturating counters, 8..32.

    Returns
    -------
    ReaderOutput
    """
    check_range("count_bits", count_bits, 8, 32)
    fmt._check_slots()
    w = np.asarray(words, np.uint8).reshape(-1, WORD_BYTES)
    data, check = ecc.unpack_code(w)
    dec = ecc.decode(data, check)
    top = (1 << count_bits) - 1
    cor = np.minimum(np.cumsum(dec.corrected, dtype=np.int64), top).astype(np.uint64)
    unc = np.minimum(np.cumsum(dec.uncorrectable, dtype=np.int64), top).astype(np.uint64)
    n_pay = payload_words(rows, cols)
    per_image = HEADER_WORDS + n_pay
    n_px = rows * cols
    expect = _expected_header(rows, cols, fmt)
    crc_mask = np.uint64(0xFFFF_FFFF)
    parts = []
    for start in range(0, len(w), per_image):
        hdr = slice(start, min(start + HEADER_WORDS, len(w)))
        got = dec.data[hdr].copy()
        if len(got) < HEADER_WORDS:
            break
        got[3] &= crc_mask
        hbad = bool(dec.uncorrectable[hdr].any() or (got != expect).any())
        k = np.arange(start + HEADER_WORDS, min(start + per_image, len(w)))
        if not len(k):
            continue
        g, o = fmt.unpack_words(dec.data[k])
        px_word = np.repeat(k, PIXELS_PER_WORD)
        bad = np.repeat(dec.uncorrectable[k], PIXELS_PER_WORD) | hbad
        keep = min(len(px_word), n_px)
        g, o, px_word, bad = g[:keep], o[:keep], px_word[:keep], bad[:keep]
        g = np.where(bad, fmt.gain_one, g).astype(np.uint64)
        o = np.where(bad, 0, o) & ((1 << fmt.offset_bits) - 1)
        idx = np.arange(keep)
        parts.append(ReaderOutput(
            g, o.astype(np.uint64), cor[px_word], unc[px_word], bad,
            np.full(keep, hbad), idx == 0, idx % cols == cols - 1))
    if not parts:
        z = np.zeros(0, np.uint64)
        b = np.zeros(0, bool)
        return ReaderOutput(z, z, z, z, b, b, b, b)
    return ReaderOutput(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                          ("gain", "offset", "corrected", "uncorrectable", "defaulted",
                           "header_error", "first", "last")))
