"""Golden model of the SECDED (72,64) Hsiao code (Ning et al. 2019 §4.3).

The code
--------
A code word is 72 bits: the 64 data bits ``d[63:0]`` in code bits 0..63 and the 8 check
bits ``c[7:0]`` in code bits 64..71 (``code = {c, d}``; on flash: the 8 data bytes,
least significant first, then the check byte). Each code bit ``j`` has an 8-bit column
``COLUMNS[j]`` of the parity-check matrix ``H`` (bit ``r`` of the column = row ``r``).
The encoder chooses ``c`` so that the code word satisfies ``H code = 0`` over GF(2):

    c[r] = XOR of d[j] for every data bit j with bit r set in COLUMNS[j]

The decoder computes the syndrome ``s = c_received XOR c(d_received)`` = the XOR of the
columns of the flipped bits, and:

- ``s == 0``: no error; data passes untouched; both flags low.
- ``s`` equals the column of code bit ``j``: single error at ``j``, corrected (data bit ``j``
  flipped back when ``j < 64``; a flipped check bit leaves the data as received);
  ``corrected`` high.
- otherwise: ``uncorrectable`` high, data returned as received (never "corrected").
  Every double error lands here (see below); so do the odd-weight syndromes that are no
  column (56 of the 128), which only three or more flips can produce.

Construction of H (Hsiao, "A class of optimal minimum odd-weight-column SEC-DED codes",
IBM J. R&D 1970), deterministic:

1. check bits 64..71: the unit columns ``1 << r`` (r = 0..7);
2. data bits 0..55: all 56 eight-bit values of weight 3, in increasing numeric order;
3. data bits 56..63: the weight-5 value ``0b00011111`` rotated left by 0..7.

Every column is odd-weight and the 72 columns are distinct and non-zero, so a single flip
gives an odd-weight syndrome that names it, and a double flip gives the XOR of two
odd-weight columns: even weight and non-zero, hence never zero and never a column -- the
decoder cannot mistake a double error for a single one. Each row holds 21 weight-3 ones,
5 weight-5 ones and 1 unit: 27 ones in every row (26 data bits per check bit), the
balance that keeps each parity tree to the same minimal depth (8 x 26-input XOR in the
encoder). The matrix, row r as 72 characters for code bits 0..71 (left to right):

    r0  111011010011010010001101001000100001101001000100001000001000111110000000
    r1  110110101010101001001010100100010001010100100010000100001100011101000000
    r2  101101100101100100100110010010001000110010010001000010001110001100100000
    r3  011100011100011100010001110001000100001110001000100001001111000100010000
    r4  000011111100000011110000001111000010000001111000010000101111100000001000
    r5  000000000011111111110000000000111110000000000111110000010111110000000100
    r6  000000000000000000001111111111111110000000000000001111110011111000000010
    r7  000000000000000000000000000000000001111111111111111111110001111100000001

All widths are exact: data is uint64, check bits and syndromes uint8, flags bool.
"""

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["DATA_BITS", "CHECK_BITS", "CODE_BITS", "COLUMNS", "H", "ROW_MASKS", "Decoded",
           "encode", "decode", "syndrome", "flip", "pack_code", "unpack_code", "sweep_words",
           "h_matrix_text", "double_flip_pairs"]

DATA_BITS = 64
CHECK_BITS = 8
CODE_BITS = 72


def _columns():
    weight3 = [v for v in range(256) if bin(v).count("1") == 3]
    weight5 = [((0x1F << k) | (0x1F >> (8 - k))) & 0xFF for k in range(8)]
    units = [1 << r for r in range(8)]
    return np.array(weight3 + weight5 + units, dtype=np.uint8)


COLUMNS = _columns()
COLUMNS.setflags(write=False)
#: parity-check matrix, shape (8, 72), row r = syndrome bit r, column j = code bit j
H = ((COLUMNS[None, :] >> np.arange(8, dtype=np.uint8)[:, None]) & 1).astype(np.uint8)
H.setflags(write=False)
#: ROW_MASKS[r]: 64-bit mask of the data bits that check bit r covers
ROW_MASKS = tuple(sum(1 << j for j in range(64) if H[r, j]) for r in range(8))

# Byte-wise syndrome tables: _SYN[k][b] = XOR of the columns of the bits set in byte b of
# data byte k, so a word's data syndrome is 8 lookups.
_SYN = np.zeros((8, 256), np.uint8)
for _k in range(8):
    for _b in range(256):
        _acc = 0
        for _i in range(8):
            if _b >> _i & 1:
                _acc ^= int(COLUMNS[8 * _k + _i])
        _SYN[_k, _b] = _acc
# Syndrome -> code bit position (-1: none) and class (0 clean, 1 corrected, 2 uncorrectable)
_POS = np.full(256, -1, np.int16)
_POS[COLUMNS] = np.arange(CODE_BITS, dtype=np.int16)
_CLASS = np.where(_POS >= 0, 1, 2).astype(np.uint8)
_CLASS[0] = 0
# Data mask to XOR for a syndrome: the data bit to flip back (0 for check-bit errors)
_FIX = np.zeros(256, np.uint64)
for _j in range(DATA_BITS):
    _FIX[int(COLUMNS[_j])] = np.uint64(1) << np.uint64(_j)


def h_matrix_text():
    """The 8 rows of :data:`H` as text, as printed in this module's docstring."""
    return "\n".join(f"r{r}  " + "".join(str(int(b)) for b in H[r]) for r in range(8))


def _data(name, data):
    a = np.asarray(data)
    if a.dtype == np.uint64:
        return a
    if not np.issubdtype(a.dtype, np.integer):
        raise TdicamError(f"{name} must be an integer array, got dtype {a.dtype}")
    if a.size and (int(a.min()) < 0 or int(a.max()) > (1 << 64) - 1):
        raise TdicamError(f"{name} has values outside 0..2**64-1")
    return a.astype(np.uint64)


def _check(name, check):
    a = np.asarray(check)
    if a.dtype == np.uint8:
        return a
    if not np.issubdtype(a.dtype, np.integer):
        raise TdicamError(f"{name} must be an integer array, got dtype {a.dtype}")
    if a.size and (int(a.min()) < 0 or int(a.max()) > 255):
        raise TdicamError(f"{name} has values outside 0..255")
    return a.astype(np.uint8)


def _data_syndrome(d):
    acc = np.zeros(d.shape, np.uint8)
    for k in range(8):
        acc ^= _SYN[k][((d >> np.uint64(8 * k)) & np.uint64(0xFF)).astype(np.intp)]
    return acc


def encode(data):
    """Check bits of 64-bit data words.

    Parameters
    ----------
    data : array_like of int (uint64 or any integer dtype with values in 0..2**64-1)

    Returns
    -------
    ndarray of uint8, same shape
        ``c[r] = XOR(d & ROW_MASKS[r])`` for r = 0..7 (bit r of the result).
    """
    return _data_syndrome(_data("data", data))


def syndrome(data, check):
    """8-bit syndrome ``check XOR encode(data)`` of received words (uint8 array)."""
    d, c = _data("data", data), _check("check", check)
    if d.shape != c.shape:
        raise TdicamError(f"data shape {d.shape} differs from check shape {c.shape}")
    return c ^ _data_syndrome(d)


class Decoded:
    """Decoder outputs, arrays of the input shape.

    Attributes
    ----------
    data : ndarray uint64
        Corrected data (as received when uncorrectable).
    corrected : ndarray bool
        A single-bit error was found and corrected (in a data or a check bit).
    uncorrectable : ndarray bool
        The syndrome is non-zero and names no code bit: two (or more) bits flipped.
    syndrome : ndarray uint8
    """

    __slots__ = ("data", "corrected", "uncorrectable", "syndrome")

    def __init__(self, data, corrected, uncorrectable, syndrome):
        self.data, self.corrected = data, corrected
        self.uncorrectable, self.syndrome = uncorrectable, syndrome

    def __iter__(self):
        return iter((self.data, self.corrected, self.uncorrectable, self.syndrome))


def decode(data, check):
    """Decode received code words ``(data, check)``; see the module docstring.

    Returns
    -------
    Decoded
        ``data`` uint64 (single error fixed), ``corrected`` and ``uncorrectable`` bool,
        ``syndrome`` uint8.
    """
    d = _data("data", data)
    s = syndrome(d, check)
    cls = _CLASS[s]
    return Decoded(d ^ _FIX[s], cls == 1, cls == 2, s)


def flip(data, check, positions):
    """Flip code bits of words: ``positions`` is an int array (n_words, k) of code bit
    indices 0..71, -1 for "no flip" (k flips at most per word). Returns (data, check)."""
    d = _data("data", data).copy()
    c = _check("check", check).copy()
    pos = np.asarray(positions, dtype=np.int64)
    if pos.ndim == 1:
        pos = pos[:, None]
    if pos.shape[0] != d.shape[0]:
        raise TdicamError(f"positions has {pos.shape[0]} rows for {d.shape[0]} words")
    if pos.size and (pos.min() < -1 or pos.max() >= CODE_BITS):
        raise TdicamError("flip positions must be -1 (none) or 0..71")
    for k in range(pos.shape[1]):
        p = pos[:, k]
        dm = (p >= 0) & (p < DATA_BITS)
        d[dm] ^= np.uint64(1) << p[dm].astype(np.uint64)
        cm = p >= DATA_BITS
        c[cm] ^= (1 << (p[cm] - DATA_BITS)).astype(np.uint8)
    return d, c


def pack_code(data, check):
    """Code words as bytes, shape (n, 9) uint8: data bytes LSB first, then the check byte."""
    d = _data("data", data).reshape(-1)
    c = _check("check", check).reshape(-1)
    out = np.empty((d.size, 9), np.uint8)
    for k in range(8):
        out[:, k] = (d >> np.uint64(8 * k)) & np.uint64(0xFF)
    out[:, 8] = c
    return out


def unpack_code(code_bytes):
    """Inverse of :func:`pack_code`: (n, 9) uint8 -> (data uint64, check uint8)."""
    b = np.asarray(code_bytes, dtype=np.uint8).reshape(-1, 9)
    d = np.zeros(len(b), np.uint64)
    for k in range(8):
        d |= b[:, k].astype(np.uint64) << np.uint64(8 * k)
    return d, b[:, 8].copy()


def double_flip_pairs():
    """All 2,556 unordered pairs (i < j) of code bit positions, shape (2556, 2) int64."""
    i, j = np.triu_indices(CODE_BITS, k=1)
    return np.stack([i, j], axis=1).astype(np.int64)


def sweep_words(n=64, *, seed=1):
    """``n`` deterministic test data words (uint64): 0, all ones, walking ones and walking
    zeros (every bit position when ``n >= 130``, else evenly spread positions), then
    random words from ``seed``."""
    check_n = int(n)
    if check_n < 2:
        raise TdicamError(f"n = {n} is out of range; valid: 2..")
    ones = np.uint64(0xFFFF_FFFF_FFFF_FFFF)
    if check_n >= 130:
        pos1 = pos0 = np.arange(64)
    else:
        walk = max(0, (check_n - 2) * 2 // 3)  # two thirds walking, one third random
        pos1 = np.linspace(0, 63, (walk + 1) // 2).round().astype(int)
        pos0 = np.linspace(63, 0, walk // 2).round().astype(int)
    one = np.uint64(1)
    words = [np.uint64(0), ones]
    words += [one << np.uint64(k) for k in pos1]
    words += [ones ^ (one << np.uint64(k)) for k in pos0]
    rng = np.random.default_rng(seed)
    rest = check_n - len(words)
    if rest > 0:
        words += list(rng.integers(0, 1 << 63, rest, dtype=np.uint64) * np.uint64(2)
                      + rng.integers(0, 2, rest, dtype=np.uint64))
    return np.array(words[:check_n], dtype=np.uint64)
