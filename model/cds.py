"""Golden model of digital correlated double sampling (Ning et al. 2019 §4.4.1)."""

import numpy as np

from tdicam.errors import TdicamError, check_range

__all__ = ["cds", "pixel_dtype", "check_pixels"]


def pixel_dtype(bits):
    """Smallest numpy unsigned dtype holding ``bits``-bit values (uint8/16/32/64)."""
    for dt in (np.uint8, np.uint16, np.uint32, np.uint64):
        if bits <= np.iinfo(dt).bits:
            return np.dtype(dt)
    raise TdicamError(f"{bits}-bit values do not fit in 64 bits")


def check_pixels(name, array, bits):
    """Return ``array`` as a non-negative integer array if every value fits ``bits`` bits."""
    a = np.asarray(array)
    if not np.issubdtype(a.dtype, np.integer):
        raise TdicamError(f"{name} must be an integer array, got dtype {a.dtype}")
    if a.size and (a.min() < 0 or int(a.max()) > (1 << bits) - 1):
        raise TdicamError(f"{name} has values outside 0..{(1 << bits) - 1} "
                          f"(min {a.min()}, max {a.max()})")
    return a


def cds(signal, reset, *, pixel_bits=12):
    """Digital CDS: ``signal - reset`` per pixel, clamped to 0 where ``reset > signal``.

    Parameters
    ----------
    signal, reset : array_like of int, same shape
        Signal-level and reset-level samples of the same pixels, each in
        ``0 .. 2**pixel_bits - 1``.
    pixel_bits : int
        Input and output width, 8..16.

    Returns
    -------
    ndarray of :func:`pixel_dtype` (``pixel_bits``), same shape
        ``max(signal - reset, 0)``. Exact: the difference is taken in int64, so it never
        wraps; the result is in ``0 .. 2**pixel_bits - 1`` by construction.

    Raises
    ------
    TdicamError
        On shape mismatch, non-integer input or values out of range.
    """
    check_range("pixel_bits", pixel_bits, 8, 16)
    s = check_pixels("signal", signal, pixel_bits)
    r = check_pixels("reset", reset, pixel_bits)
    if s.shape != r.shape:
        raise TdicamError(f"signal shape {s.shape} differs from reset shape {r.shape}")
    diff = s.astype(np.int64) - r.astype(np.int64)
    return np.maximum(diff, 0).astype(pixel_dtype(pixel_bits))
