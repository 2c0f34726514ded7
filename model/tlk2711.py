"""Golden model of the camera's output links: the parallel side of one or two TI TLK2711
transceivers (Ning et al. 2019: §3.2, the image leaves over 2 TLK2711 links, 3.2 Gbit/s in
all; §5, "a single channel typically about 100 MHz x 16 bit", full frames reach 5 frame/s).

The TLK2711's transmitter takes a 16-bit word ``TXD[15:0]`` on every rising edge of its
reference clock ``TXCLK`` (the word clock; 1.6 to 2.7 Gbit/s on the line, 20 line bits a word
after 8b/10b: 80 to 135 MHz, :data:`WORD_CLOCK_HZ`), and two flags: ``TKLSB`` says that
``TXD[7:0]`` is a K (control) character, ``TKMSB`` the same of ``TXD[15:8]``. Its receiver
aligns bytes only on the comma ``0011111``, which K28.5 carries with one running disparity
only; two "inverting idles" ``K28.5 D5.6`` back to back give the comma whatever the
disparity, in the low byte, where the receiver maps it.

A word here is one integer: ``TXD | TKLSB << 16 | TKMSB << 17`` (18 bits, :func:`word`).

Framing (what every link sends; the block adds nothing else)
-------------------------------------------------------------
Characters: IDLE = K28.5 (``0xBC``, a K character) in the low byte and D5.6 (``0xC5``, data)
in the high byte; the markers SOF = K27.7 (``0xFB``), SOL = K28.0 (``0x1C``) and EOL = K29.7
(``0xFD``) in the low byte (``TKLSB`` = 1) with the link's index (0 or 1) as a data byte in the
high byte, so a receiver can tell swapped cables. No other K character is sent, none in the
high byte (``TKMSB`` is always 0), and only IDLE carries a comma.

* A frame starts with ``IDLE IDLE SOF FNUM``: FNUM (data) is the frame's number, counting
  from 0 after reset, modulo 2**16.
* Every row of the frame follows as ``IDLE IDLE SOL LNUM payload... EOL CRC``: LNUM (data) is
  the row's number in its frame (0 = top, modulo 2**16); the payload is the link's pixels of
  the row, packed; CRC (data) is CRC-16/CCITT-FALSE (polynomial 0x1021, initial value
  0xFFFF, not reflected, no final XOR; :func:`crc16`) over LNUM and the payload words, each
  word's high byte first. The two IDLEs give the receiver a comma at every row, so a link
  that lost its byte alignment is back at the next row.
* Between these words the transmitter may send any number of IDLEs (the fill when it has
  nothing to send); a receiver drops every IDLE (:func:`decode`).

Pixels to words: the ``width // links`` pixels of a link's row, of ``pixel_bits`` (1..16)
each, are packed densely, least significant bit first: pixel ``k`` holds bits ``k * b .. (k +
1) * b - 1`` of the row's bit string, word ``j`` bits ``16 j .. 16 j + 15`` (bit 0 of the word
= bit ``16 j``); the last word is padded with zeros. So 16-bit pixels (the HDR output) are one
a word, 8-bit pixels two a word (the left one in the low byte), 12-bit pixels four in three
words, 10-bit pixels eight in five; every row starts on a word boundary
(:func:`pack`, :func:`unpack`).

The image across the links: interleaved columns. With two links, link ``L`` carries the
columns ``L, L + 2, L + 4, ...`` of every row (the width must be even). Both links carry
every row, with the same row number, at the same time and at the same length, so the
receiver needs no line buffer to pair them: it puts ``row[0::2] = link 0's pixels`` and
``row[1::2] = link 1's`` as the rows arrive (:func:`decode`); each link alone is the whole
swath at half the horizontal resolution, so a row that fails its CRC on one link (or a link
that fails) loses every other pixel of that row, which its neighbours on the other link can
fill, not a whole row or half the swath. The load is the same on both links for every
image, and the transmitter needs no line buffer either (alternate rows or halves of each
row would need one row, or half a row, stored to keep both links busy).

Words per link: a row ``6 + ceil((width / links) * pixel_bits / 16)`` (:func:`line_words`),
a frame ``4 + rows *`` that (:func:`frame_words`). At the paper's 5144 x 3800 pixels, 16 bits
and 2 links at 100 MHz: 2578 words a row, 9,796,404 a frame, 10.2 frame/s of one image
(:func:`frame_rate_limit`); the paper's 5 frame/s is two such images a frame (both gain
channels).
"""

import binascii
from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError, check_choice, check_range
from tdicam.model import _args
from tdicam.model.cds import check_pixels, pixel_dtype

__all__ = ["word", "TKLSB", "TKMSB", "K28_5", "D5_6", "K27_7", "K28_0", "K29_7", "IDLE",
           "marker", "LINKS", "PIXEL_BITS", "WORD_CLOCK_HZ", "FRAME_HEADER", "LINE_HEADER",
           "LINE_TRAILER", "CRC_INIT", "crc16", "crc16_update", "pack", "unpack", "tlk2711",
           "line_words", "frame_words", "link_payload_bps", "frame_rate_limit", "Decoded",
           "decode", "check_links"]

#: The flag bits of a word above ``TXD[15:0]``: ``TXD[7:0]`` / ``TXD[15:8]`` is a K character.
TKLSB, TKMSB = 1 << 16, 1 << 17

#: The characters the framing uses (byte values; K28.5, K27.7, K28.0, K29.7 as K characters).
K28_5, D5_6, K27_7, K28_0, K29_7 = 0xBC, 0xC5, 0xFB, 0x1C, 0xFD

#: Links a block drives (one TLK2711 each).
LINKS = (1, 2)

#: Legal pixel widths (bits), inclusive.
PIXEL_BITS = (1, 16)

#: The TLK2711's reference (word) clock, Hz, inclusive: 1.6 to 2.7 Gbit/s on the line, 20
#: line bits a 16-bit word (the space-grade TLK2711-SP stops at 2.5 Gbit/s, 125 MHz).
WORD_CLOCK_HZ = (80e6, 135e6)

#: Words of a frame's header (IDLE IDLE SOF FNUM), of a row's header (IDLE IDLE SOL LNUM) and
#: of a row's trailer (EOL CRC).
FRAME_HEADER, LINE_HEADER, LINE_TRAILER = 4, 4, 2

#: The CRC register's value before a row's first word (LNUM).
CRC_INIT = 0xFFFF


def word(txd, tklsb=0, tkmsb=0):
    """The 18-bit word of ``TXD[15:0]`` and the two K flags: ``txd | tklsb << 16 | tkmsb <<
    17``."""
    return int(txd) | (TKLSB if tklsb else 0) | (TKMSB if tkmsb else 0)


#: The idle word: K28.5 in the low byte (a K character), D5.6 in the high byte.
IDLE = word(D5_6 << 8 | K28_5, tklsb=1)


def marker(k, link):
    """The marker word of K character ``k`` (SOF, SOL or EOL) on link ``link``: the K
    character in the low byte, the link's index as data in the high byte."""
    return word(link << 8 | k, tklsb=1)


def check_links(links):
    """``links`` if it is 1 or 2, else a one-line :class:`TdicamError`."""
    return check_choice("links", links, LINKS)


def crc16_update(crc, w):
    """The CRC register after word ``w`` (16 bits, high byte first) from ``crc``:
    CRC-16/CCITT (polynomial 0x1021, not reflected), :func:`binascii.crc_hqx`'s."""
    return binascii.crc_hqx(int(w).to_bytes(2, "big"), int(crc))


def crc16(words):
    """CRC-16/CCITT-FALSE of 16-bit ``words`` (each high byte first): initial value
    :data:`CRC_INIT`, no final XOR: ``crc16([0x3132, 0x3334, 0x3536, 0x3738])`` (the bytes
    ``"12345678"``) is ``0xA12B``."""
    data = np.asarray(words, dtype=">u2").tobytes()
    return binascii.crc_hqx(data, CRC_INIT)


#: Bit-array elements :func:`pack` and :func:`unpack` hold at a time (rows at a time).
_CHUNK_BITS = 1 << 24


def _row_chunks(rows, per_row):
    """Slices of ``rows`` rows of ``per_row`` bits each, ~:data:`_CHUNK_BITS` at a time."""
    step = max(1, _CHUNK_BITS // max(per_row, 1))
    return [slice(k, k + step) for k in range(0, rows, step)]


def pack(pixels, pixel_bits):
    """Pixels ``(..., n)`` of ``pixel_bits`` bits -> words ``(..., ceil(n b / 16))``, uint16:
    least significant bit first, pixel ``k`` at bits ``k b ..``, the last word zero-padded
    (see the module notes). Values must fit ``pixel_bits``."""
    b = check_range("pixel_bits", pixel_bits, *PIXEL_BITS)
    p = np.asarray(pixels)
    lead, n = p.shape[:-1], p.shape[-1]
    if b == 16:
        return p.astype(np.uint16)
    nw = -(-n * b // 16)
    flat = np.ascontiguousarray(p.reshape(-1, n), dtype="<u2")
    out = np.empty((flat.shape[0], nw), np.uint16)
    for sl in _row_chunks(flat.shape[0], n * 16):
        part = flat[sl]
        bits = np.unpackbits(part.view(np.uint8).reshape(len(part), n, 2), axis=-1,
                             bitorder="little")[..., :b].reshape(len(part), n * b)
        bits = np.concatenate([bits, np.zeros((len(part), nw * 16 - n * b), np.uint8)],
                              axis=-1)
        out[sl] = np.packbits(bits, axis=-1, bitorder="little").view("<u2")
    return out.reshape(*lead, nw)


def unpack(words, pixel_bits, n):
    """Inverse of :func:`pack`: the first ``n`` pixels of words ``(..., nw)``, as the
    :func:`~tdicam.model.cds.pixel_dtype` of ``pixel_bits`` (a pixel of at most 16 bits
    lies in two neighbouring words: each one a gather, a shift and a mask)."""
    b = check_range("pixel_bits", pixel_bits, *PIXEL_BITS)
    w = np.asarray(words)
    lead, nw = w.shape[:-1], w.shape[-1]
    if b == 16:
        return w[..., :n].astype(np.uint16)
    flat = w.reshape(-1, nw)
    start = np.arange(n, dtype=np.int64) * b
    j, o = start >> 4, (start & 15).astype(np.uint32)
    out = np.empty((flat.shape[0], n), pixel_dtype(b))
    for sl in _row_chunks(flat.shape[0], n * 16):
        w32 = np.zeros((len(flat[sl]), nw + 1), np.uint32)
        w32[:, :nw] = flat[sl]
        out[sl] = ((w32[:, j] | (w32[:, j + 1] << 16)) >> o) & ((1 << b) - 1)
    return out.reshape(*lead, n)


def _frames(frames, pixel_bits, links):
    """The frames as a list of 2-D int64 arrays of one width, checked."""
    if isinstance(frames, (list, tuple)):
        fl = [check_pixels("frames", f, pixel_bits) for f in frames]
    else:
        a = check_pixels("frames", frames, pixel_bits)
        if a.ndim < 2:
            raise TdicamError(f"frames must be (..., rows, cols), got shape {a.shape}")
        fl = list(a.reshape((-1,) + a.shape[-2:]))
    widths = {f.shape[-1] for f in fl}
    for f in fl:
        if f.ndim != 2 or f.shape[0] < 1:
            raise TdicamError(f"every frame must be 2-D with at least one row, got shape "
                              f"{f.shape}")
    if len(widths) > 1:
        raise TdicamError(f"frames of different widths: {sorted(widths)}")
    if widths:
        w = widths.pop()
        if w < links or w % links:
            raise TdicamError(f"frames are {w} pixels wide: the width must be a positive "
                              f"multiple of links = {links} (each link carries every "
                              f"{links}th column)")
    return [f.astype(np.int64) for f in fl]


def _encode_frame(frame, number, pixel_bits, links):
    """The words of one frame, ``(links, frame_words)`` uint32 (frame number ``number``)."""
    rows = frame.shape[0]
    nw = line_words(frame.shape[1], pixel_bits=pixel_bits, links=links)
    out = np.empty((links, FRAME_HEADER + rows * nw), np.uint32)
    lnum = np.arange(rows, dtype=np.uint32) & 0xFFFF
    for link in range(links):
        o = out[link]
        o[:FRAME_HEADER] = (IDLE, IDLE, marker(K27_7, link), number & 0xFFFF)
        body = o[FRAME_HEADER:].reshape(rows, nw)
        body[:, 0:2] = IDLE
        body[:, 2] = marker(K28_0, link)
        body[:, 3] = lnum
        body[:, 4:-2] = pack(frame[:, link::links], pixel_bits)
        body[:, -2] = marker(K29_7, link)
        crc_in = body[:, 3:-2].astype(">u2")
        body[:, -1] = [binascii.crc_hqx(r.tobytes(), CRC_INIT) for r in crc_in]
    return out


def tlk2711(frames, *, pixel_bits=16, links=1):
    """Golden model: the words every link sends for ``frames`` (see the module notes).

    Parameters
    ----------
    frames : array_like of int, (..., rows, cols), or a list of 2-D arrays
        The frames in order (a list may hold frames of different heights), every pixel in
        ``0 .. 2**pixel_bits - 1``; the width a positive multiple of ``links``.
    pixel_bits : int
        Pixel width, 1..16 (:data:`PIXEL_BITS`).
    links : {1, 2}
        Links (TLK2711s); with 2, link ``L`` carries the columns ``L::2``.

    Returns
    -------
    ndarray, uint32, (links, n)
        Link ``L``'s words in order, each ``TXD | TKLSB << 16 | TKMSB << 17``: for each frame
        ``k`` (frame number ``k mod 2**16``) its header and its rows, without fill IDLEs.
        Every link sends the same number of words.

    Raises
    ------
    TdicamError
        A parameter out of range, a pixel out of range, frames that are not 2-D, of
        different widths, or a width not a multiple of ``links`` (one line each).
    """
    check_range("pixel_bits", pixel_bits, *PIXEL_BITS)
    check_links(links)
    fl = _frames(frames, pixel_bits, links)
    parts = [_encode_frame(f, k, pixel_bits, links) for k, f in enumerate(fl)]
    return np.concatenate(parts, axis=1) if parts else np.zeros((links, 0), np.uint32)


def line_words(width, *, pixel_bits=16, links=1):
    """Words a link sends for one row of ``width`` pixels: ``4 + ceil((width / links) *
    pixel_bits / 16) + 2`` (header, packed pixels, trailer). Scalars or arrays."""
    b = _args.count("pixel_bits", pixel_bits, lo=PIXEL_BITS[0], hi=PIXEL_BITS[1])
    n = _args.count("width", width, lo=1)
    check_links(links)
    return LINE_HEADER + -(-(n // links) * b // 16) + LINE_TRAILER


def frame_words(rows, width, *, pixel_bits=16, links=1):
    """Words a link sends for one frame of ``rows`` x ``width`` pixels: ``4 + rows *``
    :func:`line_words`. Scalars or arrays."""
    r = _args.count("rows", rows, lo=1)
    return FRAME_HEADER + r * line_words(width, pixel_bits=pixel_bits, links=links)


def link_payload_bps(*, links=2, word_clock_hz=100e6):
    """The links' parallel-side capacity, bit/s: ``16 * links * word_clock_hz`` (every word
    of every link a data word; 3.2e9 for the paper's 2 links at 100 MHz).

    Parameters
    ----------
    links : {1, 2}
    word_clock_hz : float or ndarray
        The TLK2711's reference clock, :data:`WORD_CLOCK_HZ` (80..135 MHz).

    Raises
    ------
    TdicamError
        ``links`` not 1 or 2, a clock out of the TLK2711's range (one line).
    """
    check_links(links)
    f = _args.real("word_clock_hz", word_clock_hz, lo=WORD_CLOCK_HZ[0], hi=WORD_CLOCK_HZ[1])
    return 16.0 * links * f


def frame_rate_limit(rows, width, *, pixel_bits=16, links=2, word_clock_hz=100e6, images=1):
    """The highest frame rate the links carry, frame/s: ``word_clock_hz / (images *``
    :func:`frame_words` ``)``, the framing (markers, row numbers, CRCs, the two IDLEs of
    every header) included; every link sends a word on every clock, in parallel.

    For a plan: compare it with the camera's frame rate (the links' margin), or compare the
    image's own rate ``rows * width * pixel_bits * images * fps`` with
    :func:`link_payload_bps` times the framing's efficiency ``rows * width * pixel_bits /
    (16 * links * frame_words)``.

    Parameters
    ----------
    rows, width : int or ndarray
        The image sent each frame (``width`` a multiple of ``links``).
    pixel_bits : int
        1..16 (packed densely: 12-bit pixels cost 12 bits, not 16).
    links : {1, 2}
    word_clock_hz : float or ndarray
        80..135 MHz (:data:`WORD_CLOCK_HZ`).
    images : int
        Images sent per frame through the block, one after the other (2: both gain
        channels of a camera that sends them unmerged).

    Returns
    -------
    float or ndarray
        frame/s. The paper's camera (5144 x 3800, 16 bits, 2 links at 100 MHz): 10.21 with
        one image a frame, 5.10 with both gain channels.

    Raises
    ------
    TdicamError
        A value out of range (one line).
    """
    n = _args.count("images", images, lo=1)
    f = link_payload_bps(links=links, word_clock_hz=word_clock_hz) / (16.0 * links)
    w = _args.count("width", width, lo=1)
    if np.any(np.asarray(w) % links):
        raise TdicamError(f"width = {width} is not a multiple of links = {links}")
    return f / (n * frame_words(rows, width, pixel_bits=pixel_bits, links=links))


# ------------------------------------------------------------------------------- decoder


@dataclass
class Decoded:
    """What :func:`decode` read: the frames in order, each ``(rows, width)`` of the
    :func:`~tdicam.model.cds.pixel_dtype` of the pixel width, and each frame's number."""

    frames: list
    numbers: list

    def stack(self):
        """The frames as one ``(n, rows, width)`` array (they must be of one height)."""
        heights = {f.shape[0] for f in self.frames}
        if len(heights) > 1:
            raise TdicamError(f"frames of different heights {sorted(heights)} do not stack")
        if not self.frames:
            raise TdicamError("no frame was decoded")
        return np.stack(self.frames)


def _where(link, pos, frame, line):
    at = f"link {link} word {pos}"
    if frame is not None:
        at += f" (frame {frame}" + (f" line {line})" if line is not None else ")")
    return at


def _is_k(w):
    return (w & (TKLSB | TKMSB)) != 0


def _describe(w):
    lo, hi = w & 0xFF, (w >> 8) & 0xFF
    parts = [f"{'K' if w & TKLSB else 'D'}{lo & 31}.{lo >> 5} in the low byte",
             f"{'K' if w & TKMSB else 'D'}{hi & 31}.{hi >> 5} in the high byte"]
    return f"0x{w & 0xFFFF:04X} ({', '.join(parts)})"


def _decode_link(words, link, n_words, pixel_bits, per_link):
    """One link's stream -> [(frame number, [rows of packed words])], or a one-line error."""
    w = np.asarray(words, dtype=np.int64).ravel()
    pos = np.flatnonzero(w != IDLE)              # every IDLE is fill or a comma
    w = w[pos]
    isk = _is_k(w)
    sof, sol, eol = marker(K27_7, link), marker(K28_0, link), marker(K29_7, link)
    frames, frame, line = [], None, None
    i, n = 0, len(w)

    def where(j):
        return _where(link, int(pos[min(j, n - 1)]) if n else 0, frame, line)

    def unexpected(j):
        """The error for the K character at ``j`` where the framing has none."""
        own = {sof: "SOF", sol: "SOL", eol: "EOL"}
        theirs = {marker(k, 1 - link): name for k, name in
                  ((K27_7, "SOF"), (K28_0, "SOL"), (K29_7, "EOL"))}
        x = int(w[j])
        if x in theirs:
            return TdicamError(f"{where(j)}: the {theirs[x]} of link {1 - link} (are the "
                               f"links swapped?)")
        if x in own:
            return TdicamError(f"{where(j)}: {own[x]} where the framing has none")
        return TdicamError(f"{where(j)}: unexpected K character {_describe(x)}; the "
                           f"framing sends only IDLE, SOF, SOL and EOL")

    def need(j, what):
        if j >= n:
            raise TdicamError(f"{where(n)}: the stream ends before the {what}")
        if isk[j]:
            if w[j] in (sof, sol, eol):
                raise TdicamError(f"{where(j)}: {what} expected (a data word), found the "
                                  f"K character {_describe(int(w[j]))}")
            raise unexpected(j)
        return int(w[j])

    while i < n:
        if w[i] == sof:
            frame, line = need(i + 1, "frame number"), None
            frames.append((frame, []))
            i += 2
        elif w[i] == sol:
            if not frames:
                raise TdicamError(f"{where(i)}: a row before the first SOF (start of "
                                  f"frame)")
            rows = frames[-1][1]
            line = len(rows) & 0xFFFF
            got = need(i + 1, "row number")
            if got != line:
                raise TdicamError(f"{where(i + 1)}: row number {got}, expected {line} (a row "
                                  f"lost or repeated)")
            j, end = i + 2, i + 2 + n_words
            k = np.flatnonzero(isk[j:end + 1])
            if not len(k) and end >= n:
                raise TdicamError(f"{where(n)}: the stream ends inside the row")
            if len(k) and j + k[0] < end:
                if w[j + k[0]] != eol:
                    raise unexpected(j + k[0])
                raise TdicamError(f"{where(j + k[0])}: the row has {k[0]} payload words, "
                                  f"expected {n_words} ({per_link} pixels of {pixel_bits} "
                                  f"bits)")
            if w[end] != eol:
                more = (f"a data word (the row is longer than {n_words} payload words, "
                        f"{per_link} pixels of {pixel_bits} bits)" if not isk[end]
                        else _describe(int(w[end])))
                raise TdicamError(f"{where(end)}: EOL (end of row) expected, found {more}")
            crc, want = need(end + 1, "CRC"), crc16(w[i + 1:end])
            if crc != want:
                raise TdicamError(f"{where(end + 1)}: CRC 0x{crc:04X} received, 0x{want:04X} "
                                  f"computed over the row (a corrupted word)")
            rows.append(w[j:end])
            i = end + 2
        elif isk[i] and w[i] != eol:
            raise unexpected(i)
        else:
            what = ("EOL (end of row) outside a row" if w[i] == eol else
                    f"data word 0x{int(w[i]) & 0xFFFF:04X} outside a row")
            raise TdicamError(f"{where(i)}: {what}")
    return frames


def decode(words, *, width, pixel_bits=16, links=1):
    """The frames in the links' words: the inverse of :func:`tlk2711` (a ground station's
    reference decoder).

    Drops every IDLE (fill and commas) wherever it is, reads each link's frames and rows,
    checks every row's number, length and CRC, then puts the links' columns back
    together (link ``L``'s pixels in columns ``L::links``).

    Parameters
    ----------
    words : array_like (links, n), or a sequence of one 1-D array a link
        Each link's words (``TXD | TKLSB << 16 | TKMSB << 17``), as captured (the links
        may hold different numbers of fill IDLEs).
    width : int
        Pixels a row (what the camera is configured for; the packing alone cannot tell 3
        pixels of 8 bits from 4).
    pixel_bits : int
    links : {1, 2}

    Returns
    -------
    Decoded

    Raises
    ------
    TdicamError
        One line naming the link, the word's position in its stream (fill IDLEs
        counted), the frame and row, and what is wrong: an unknown K character (or the
        other link's markers: swapped cables), a row before any SOF, a row number out of
        sequence, a row too short or too long, a CRC that does not match, a stream that
        ends inside a row, the links disagreeing on frames or rows.
    """
    check_range("pixel_bits", pixel_bits, *PIXEL_BITS)
    check_links(links)
    check_range("width", width, links, None)
    if width % links:
        raise TdicamError(f"width = {width} is not a multiple of links = {links}")
    per_link = width // links
    n_words = -(-per_link * pixel_bits // 16)
    streams = list(words) if not isinstance(words, np.ndarray) or words.ndim == 2 else [words]
    if len(streams) != links:
        raise TdicamError(f"words of {len(streams)} link(s) given, links = {links}")
    per = [_decode_link(s, k, n_words, pixel_bits, per_link) for k, s in enumerate(streams)]
    counts = [len(p) for p in per]
    if len(set(counts)) > 1:
        raise TdicamError(f"the links carry different numbers of frames: {counts}")
    dt = pixel_dtype(pixel_bits)
    out, numbers = [], []
    for f, parts in enumerate(zip(*per)):
        nums = {p[0] for p in parts}
        heights = [len(p[1]) for p in parts]
        if len(nums) > 1 or len(set(heights)) > 1:
            raise TdicamError(f"frame {f}: the links disagree (frame numbers "
                              f"{[p[0] for p in parts]}, rows {heights})")
        img = np.zeros((heights[0], width), dt)
        for k, (_, rows) in enumerate(parts):
            if rows:
                img[:, k::links] = unpack(np.array(rows), pixel_bits, per_link)
        out.append(img)
        numbers.append(parts[0][0])
    return Decoded(out, numbers)
