"""Golden model of per-pixel gain/offset correction (Ning et al. 2019 §4.4.4).

Each pixel is corrected with its own least-squares radiometric coefficients::

    y = clamp(round_half_up(gain * x + offset), 0, 2**out_bits - 1)

Coefficient format (:class:`NucFormat`, defaults in brackets)

* ``gain``: unsigned fixed point Q\\ ``gain_int_bits``.\\ ``gain_frac_bits`` [Q2.14, 16 bits]:
  code ``g`` means ``g / 2**gain_frac_bits`` (0 .. 3.99994 by default, step 2**-14).
  Gain 1.0 is ``1 << gain_frac_bits`` (16384).
* ``offset``: signed two's-complement fixed point of ``offset_bits`` bits with
  ``offset_frac_bits`` fraction bits [16 bits, 0 fraction bits: an integer -32768 .. 32767
  in output LSBs]. Code ``o`` means ``o / 2**offset_frac_bits``.
* the default coefficients (flash word with an uncorrectable error, Ning et al. 2019 §4.4.4) are gain 1.0 and
  offset 0, which give ``y = x`` exactly whenever ``out_bits >= pixel_bits``.

With the defaults two pixels' coefficients fill one 64-bit flash word, four 16-bit
coefficients ("64 bits = 4 coefficients" in the paper); see :meth:`NucFormat.pack_words`.

Arithmetic (exact, int64): with ``F = max(gain_frac_bits, offset_frac_bits)``::

    acc = (gain * x) << (F - gain_frac_bits) + offset << (F - offset_frac_bits)
    y   = (acc + (1 << (F - 1))) >> F           # F > 0: round half up (towards +inf)
    y   = acc                                   # F == 0
    y   = min(max(y, 0), 2**out_bits - 1)       # saturate, never wrap

``>>`` is an arithmetic (flooring) shift, so negative sums round half up too and then clamp
to 0.
"""

from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError, check_range
from tdicam.model.cds import check_pixels, pixel_dtype

__all__ = ["NucFormat", "DEFAULT_FORMAT", "nuc", "check_nuc_params", "identity_coeffs",
           "WORD_BITS"]

WORD_BITS = 64
_SLOT_BITS = 16


def check_nuc_params(*, pixel_bits, gain_int_bits, gain_frac_bits, offset_bits,
                     offset_frac_bits, out_bits):
    """Validate the ``nuc`` parameters (one-line :class:`TdicamError`); returns ``out_bits``
    resolved (``None`` -> ``pixel_bits``)."""
    check_range("pixel_bits", pixel_bits, 8, 16)
    check_range("gain_int_bits", gain_int_bits, 1, 4)
    check_range("gain_frac_bits", gain_frac_bits, 4, 16)
    if gain_int_bits + gain_frac_bits > 18:
        raise TdicamError(f"gain_int_bits + gain_frac_bits = {gain_int_bits + gain_frac_bits} "
                          f"is too wide; valid: at most 18 (one 18x18 multiplier)")
    check_range("offset_bits", offset_bits, 2, 18)
    check_range("offset_frac_bits", offset_frac_bits, 0, min(8, offset_bits - 1))
    if out_bits is None:
        out_bits = pixel_bits
    check_range("out_bits", out_bits, 8, 20)
    return out_bits


@dataclass(frozen=True)
class NucFormat:
    """Fixed-point format of the ``nuc`` coefficients (see the module docstring).

    Attributes
    ----------
    gain_int_bits, gain_frac_bits : int
        Unsigned gain ``Q<int>.<frac>``; defaults 2 and 14 (16-bit codes, 1.0 = 16384).
    offset_bits, offset_frac_bits : int
        Signed two's-complement offset width and its fraction bits; defaults 16 and 0.
    """

    gain_int_bits: int = 2
    gain_frac_bits: int = 14
    offset_bits: int = 16
    offset_frac_bits: int = 0

    def __post_init__(self):
        check_nuc_params(pixel_bits=12, gain_int_bits=self.gain_int_bits,
                         gain_frac_bits=self.gain_frac_bits, offset_bits=self.offset_bits,
                         offset_frac_bits=self.offset_frac_bits, out_bits=None)

    @property
    def gain_bits(self):
        return self.gain_int_bits + self.gain_frac_bits

    @property
    def gain_one(self):
        """Code of gain 1.0 (the default coefficient)."""
        return 1 << self.gain_frac_bits

    @property
    def gain_max(self):
        return (1 << self.gain_bits) - 1

    @property
    def offset_min(self):
        return -(1 << (self.offset_bits - 1))

    @property
    def offset_max(self):
        return (1 << (self.offset_bits - 1)) - 1

    @property
    def pixels_per_word(self):
        """Pixels whose (gain, offset) pairs fit one 64-bit flash word (16-bit slots)."""
        return WORD_BITS // (2 * _SLOT_BITS)

    def params(self):
        """The format as ``nuc`` keyword parameters."""
        return {"gain_int_bits": self.gain_int_bits, "gain_frac_bits": self.gain_frac_bits,
                "offset_bits": self.offset_bits, "offset_frac_bits": self.offset_frac_bits}

    def gain_code(self, value):
        """Nearest gain code of real ``value`` (round half up), saturated to the format."""
        code = np.floor(np.asarray(value, np.float64) * self.gain_one + 0.5)
        return np.clip(code, 0, self.gain_max).astype(np.int64)

    def offset_code(self, value):
        """Nearest offset code of real ``value`` (round half up), saturated to the format."""
        code = np.floor(np.asarray(value, np.float64) * (1 << self.offset_frac_bits) + 0.5)
        return np.clip(code, self.offset_min, self.offset_max).astype(np.int64)

    def check_coeffs(self, gain, offset):
        """Return (gain, offset) as int64 arrays if every code fits the format, else raise."""
        g, o = np.asarray(gain), np.asarray(offset)
        for name, a in (("gain", g), ("offset", o)):
            if not np.issubdtype(a.dtype, np.integer):
                raise TdicamError(f"{name} must be an integer array of codes, got dtype "
                                  f"{a.dtype}")
        g, o = g.astype(np.int64), o.astype(np.int64)
        if g.size and (g.min() < 0 or g.max() > self.gain_max):
            raise TdicamError(f"gain has codes outside 0..{self.gain_max} (min {g.min()}, "
                              f"max {g.max()})")
        if o.size and (o.min() < self.offset_min or o.max() > self.offset_max):
            raise TdicamError(f"offset has codes outside {self.offset_min}..{self.offset_max} "
                              f"(min {o.min()}, max {o.max()})")
        return g, o

    def pack_words(self, gain, offset):
        """Pack per-pixel coefficients (raster order) into 64-bit flash words.

        Word ``k`` holds pixels ``2k`` and ``2k+1`` as four 16-bit slots, least significant
        first: ``gain[2k], offset[2k], gain[2k+1], offset[2k+1]``. Gains are zero-extended,
        offsets sign-extended to 16 bits (two's complement). An odd pixel count is padded with
        the default coefficients. Needs ``gain_bits <= 16`` and ``offset_bits <= 16``.

        Returns
        -------
        ndarray of uint64, shape (ceil(n / 2),)
        """
        self._check_slots()
        g, o = self.check_coeffs(np.ravel(gain), np.ravel(offset))
        if g.shape != o.shape:
            raise TdicamError(f"gain has {g.size} codes but offset has {o.size}")
        if g.size % 2:
            g = np.append(g, self.gain_one)
            o = np.append(o, 0)
        slots = np.stack([g[0::2], o[0::2], g[1::2], o[1::2]], axis=1).astype(np.uint64)
        slots &= np.uint64(0xFFFF)  # offsets: two's complement in 16 bits
        shifts = np.arange(4, dtype=np.uint64) * np.uint64(_SLOT_BITS)
        return np.bitwise_or.reduce(slots << shifts[None, :], axis=1)

    def unpack_words(self, words):
        """Inverse of :meth:`pack_words`: (gain, offset) int64 arrays of ``2 * len(words)``
        pixels. Gain bits above ``gain_bits`` and offset bits above ``offset_bits`` in a slot
        are ignored (the offset is sign-extended from bit ``offset_bits - 1``)."""
        self._check_slots()
        w = np.asarray(words, dtype=np.uint64).ravel()
        shifts = np.arange(4, dtype=np.uint64) * np.uint64(_SLOT_BITS)
        slots = ((w[:, None] >> shifts[None, :]) & np.uint64(0xFFFF)).astype(np.int64)
        g = slots[:, 0::2].ravel() & self.gain_max
        o = slots[:, 1::2].ravel() & ((1 << self.offset_bits) - 1)
        o = np.where(o >> (self.offset_bits - 1), o - (1 << self.offset_bits), o)
        return g, o

    def stream_elements(self, x, gain, offset):
        """The ``nuc`` input stream's three elements per pixel, ``(..., 3)`` int64:
        ``[x, gain, offset as offset_bits-bit two's complement]`` (what ``tdata`` carries,
        element 0 in the least significant bits)."""
        g, o = self.check_coeffs(gain, offset)
        xa = np.asarray(x).astype(np.int64)
        return np.stack([xa, g, o & ((1 << self.offset_bits) - 1)], axis=-1)

    def default_word(self):
        """The flash word holding default coefficients (gain 1.0, offset 0) for 2 pixels."""
        return int(self.pack_words([self.gain_one] * 2, [0, 0])[0])

    def _check_slots(self):
        if self.gain_bits > _SLOT_BITS or self.offset_bits > _SLOT_BITS:
            raise TdicamError(f"flash packing needs coefficients of at most {_SLOT_BITS} bits; "
                              f"this format has gain {self.gain_bits} and offset "
                              f"{self.offset_bits} bits")


DEFAULT_FORMAT = NucFormat()


def identity_coeffs(shape, fmt=DEFAULT_FORMAT):
    """(gain, offset) int64 arrays of the default coefficients: gain 1.0, offset 0."""
    return (np.full(shape, fmt.gain_one, np.int64), np.zeros(shape, np.int64))


def nuc(x, gain, offset, *, pixel_bits=12, gain_int_bits=2, gain_frac_bits=14, offset_bits=16,
        offset_frac_bits=0, out_bits=None):
    """Per-pixel correction ``y = gain * x + offset``, rounded half up and saturated.

    Parameters
    ----------
    x : array_like of int
        Pixels in ``0 .. 2**pixel_bits - 1``.
    gain : array_like of int, same shape
        Unsigned gain codes, ``0 .. 2**(gain_int_bits + gain_frac_bits) - 1``; value
        ``gain / 2**gain_frac_bits``.
    offset : array_like of int, same shape
        Signed offset codes, ``-2**(offset_bits-1) .. 2**(offset_bits-1) - 1``; value
        ``offset / 2**offset_frac_bits`` output LSBs.
    pixel_bits : int
        Input width, 8..16.
    gain_int_bits, gain_frac_bits : int
        Gain format, 1..4 and 4..16 integer and fraction bits, at most 18 bits together.
    offset_bits, offset_frac_bits : int
        Offset width 2..18 and its fraction bits 0..min(8, offset_bits - 1).
    out_bits : int or None
        Output width 8..20; ``None`` means ``pixel_bits``.

    Returns
    -------
    ndarray of :func:`~tdicam.model.cds.pixel_dtype` (``out_bits``), same shape
        See the module docstring for the exact integer arithmetic. Identity coefficients
        (:func:`identity_coeffs`) return ``x`` unchanged when ``out_bits >= pixel_bits``.

    Raises
    ------
    TdicamError
        On a bad parameter, shape mismatch, non-integer input or codes out of range.
    """
    out_bits = check_nuc_params(pixel_bits=pixel_bits, gain_int_bits=gain_int_bits,
                                gain_frac_bits=gain_frac_bits, offset_bits=offset_bits,
                                offset_frac_bits=offset_frac_bits, out_bits=out_bits)
    fmt = NucFormat(gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits)
    xa = check_pixels("x", x, pixel_bits).astype(np.int64)
    g, o = fmt.check_coeffs(gain, offset)
    if not xa.shape == g.shape == o.shape:
        raise TdicamError(f"x shape {xa.shape}, gain shape {g.shape} and offset shape "
                          f"{o.shape} differ")
    frac = max(gain_frac_bits, offset_frac_bits)
    acc = ((g * xa) << (frac - gain_frac_bits)) + (o << (frac - offset_frac_bits))
    if frac:
        acc = (acc + (1 << (frac - 1))) >> frac
    return np.clip(acc, 0, (1 << out_bits) - 1).astype(pixel_dtype(out_bits))
