"""Golden model of the 3x3 median filter with optional edge enhancement
(Ning et al. 2019 §4.4.3).

Everything is integer numpy computed in int64 (no unsigned wrap), with the exact widths,
rounding and saturation stated in :func:`median3`. The gateware (``tdicam.hdl.median3``)
equals this model bit for bit.
"""

import numpy as np

from tdicam.errors import TdicamError, check_range

from tdicam.model.cds import check_pixels, pixel_dtype

__all__ = ["median3", "enhance_parts", "default_enhance_shift", "MAX_WIDTH", "MAX_HEIGHT",
           "MAX_GAIN", "MAX_SHIFT"]

MAX_WIDTH = 8192
MAX_HEIGHT = 65535
MAX_GAIN = 255
MAX_SHIFT = 48


def default_enhance_shift(pixel_bits):
    """``enhance_shift`` used when none is given: ``pixel_bits + 2``.

    With it a full-scale step edge gets a detail of about 0.4 of full scale next to the
    edge (Laplacian ~ F times a smoothed gradient of ~ 1.6 F, divided by 4 F), a 1/8-scale
    step about 1/20 of its height, flat noise almost nothing.
    """
    return pixel_bits + 2


def _frames(frames, pixel_bits, width, height):
    a = check_pixels("frames", frames, pixel_bits)
    if a.ndim not in (2, 3):
        raise TdicamError(f"frames must be one image (rows, cols) or a stack "
                          f"(frames, rows, cols), got {a.ndim} dimensions")
    rows, cols = a.shape[-2:]
    if rows < 1 or cols < 3:
        raise TdicamError(f"a frame must have at least 1 row and 3 columns, got {rows}x{cols}")
    if width is not None and cols != width:
        raise TdicamError(f"frames are {cols} pixels wide, width = {width}")
    if height is not None and rows != height:
        raise TdicamError(f"frames are {rows} rows high, height = {height}")
    check_range("width", cols, 3, MAX_WIDTH)
    check_range("height", rows, 1, MAX_HEIGHT)
    return a.astype(np.int64)


def _pad(a, r):
    """Replicate the border by ``r`` pixels on the last two axes (``mode="nearest"``)."""
    widths = [(0, 0)] * (a.ndim - 2) + [(r, r), (r, r)]
    return np.pad(a, widths, mode="edge")


def _shifted(p, r, dy, dx):
    """View of padded ``p`` (padding ``r``) shifted by (dy, dx): element [y, x] = I(y+dy, x+dx)."""
    rows, cols = p.shape[-2] - 2 * r, p.shape[-1] - 2 * r
    return p[..., r + dy:r + dy + rows, r + dx:r + dx + cols]


def _median(a):
    p = _pad(a, 1)
    stack = np.stack([_shifted(p, 1, dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
    return np.partition(stack, 4, axis=0)[4]


def enhance_parts(frames, *, pixel_bits=12, enhance_gain=1, enhance_shift=None):
    """Every intermediate of the enhanced median, as int64 arrays (see :func:`median3`).

    Returns
    -------
    dict
        ``median``, ``lap``, ``gx``, ``gy``, ``grad``, ``box`` (5x5 sum of ``grad``),
        ``gmean``, ``prod``, ``detail`` and ``out`` (all int64, shape of ``frames``).
    """
    check_range("pixel_bits", pixel_bits, 8, 16)
    check_range("enhance_gain", enhance_gain, 0, MAX_GAIN)
    shift = default_enhance_shift(pixel_bits) if enhance_shift is None else enhance_shift
    check_range("enhance_shift", shift, 0, MAX_SHIFT)
    a = _frames(frames, pixel_bits, None, None)
    full = (1 << pixel_bits) - 1
    med = _median(a)
    p = _pad(a, 1)

    def s(dy, dx):
        return _shifted(p, 1, dy, dx)

    lap = 4 * s(0, 0) - s(-1, 0) - s(1, 0) - s(0, -1) - s(0, 1)
    gx = (s(-1, 1) + 2 * s(0, 1) + s(1, 1)) - (s(-1, -1) + 2 * s(0, -1) + s(1, -1))
    gy = (s(1, -1) + 2 * s(1, 0) + s(1, 1)) - (s(-1, -1) + 2 * s(-1, 0) + s(-1, 1))
    grad = np.abs(gx) + np.abs(gy)
    pg = _pad(grad, 2)
    box = sum(_shifted(pg, 2, dy, dx) for dy in range(-2, 3) for dx in range(-2, 3))
    gmean = (box + 12) // 25
    prod = lap * gmean
    scaled = prod * enhance_gain
    detail = (scaled + (1 << (shift - 1))) >> shift if shift else scaled
    out = np.clip(med + detail, 0, full)
    return {"median": med, "lap": lap, "gx": gx, "gy": gy, "grad": grad, "box": box,
            "gmean": gmean, "prod": prod, "detail": detail, "out": out}


def median3(frames, *, width=None, height=None, pixel_bits=12, enhance=False, enhance_gain=1,
            enhance_shift=None):
    """3x3 median with replicated borders, optionally edge-enhanced (Ning et al. 2019 §4.4.3).

    Parameters
    ----------
    frames : array_like of int, shape (rows, cols) or (n_frames, rows, cols)
        Pixels in ``0 .. F`` with ``F = 2**pixel_bits - 1``; each frame is filtered on its
        own (no row of one frame influences another). ``rows >= 1``, ``3 <= cols <= 8192``.
    width, height : int, optional
        When given they must equal ``cols`` / ``rows`` (the gateware's elaboration
        parameter ``width`` and run-time port ``height``).
    pixel_bits : int
        Input and output width, 8..16.
    enhance : bool
        Add the edge-enhancement detail to the median (Ning et al. 2019 §4.4.3 steps 2-3).
    enhance_gain : int
        0..255, multiplies the mask.
    enhance_shift : int or None
        0..48, right shift of the scaled mask; ``None`` = :func:`default_enhance_shift`.

    Returns
    -------
    ndarray of :func:`~tdicam.model.cds.pixel_dtype` (``pixel_bits``), shape of ``frames``

    Notes
    -----
    ``P`` is the frame with its border replicated (``scipy.ndimage`` ``mode="nearest"``:
    ``P(y, x) = I(clamp(y, 0, rows-1), clamp(x, 0, cols-1))``). Without ``enhance``::

        out(y, x) = median(y, x) = 5th smallest of P(y+i, x+j), i, j in {-1, 0, 1}

    i.e. exactly ``scipy.ndimage.median_filter(frame, size=3, mode="nearest")``.

    With ``enhance`` (all integers, no intermediate is ever rounded or clipped except
    where stated; ranges are reached)::

        lap(y, x)   = 4 P(y,x) - P(y-1,x) - P(y+1,x) - P(y,x-1) - P(y,x+1)    in [-4F, 4F]
        gx(y, x)    = [P(y-1,x+1) + 2 P(y,x+1) + P(y+1,x+1)]
                    - [P(y-1,x-1) + 2 P(y,x-1) + P(y+1,x-1)]                 (Sobel)
        gy(y, x)    = [P(y+1,x-1) + 2 P(y+1,x) + P(y+1,x+1)]
                    - [P(y-1,x-1) + 2 P(y-1,x) + P(y-1,x+1)]
        grad(y, x)  = |gx| + |gy|                                             in [0, 8F]
        box(y, x)   = sum of G(y+i, x+j), i, j in -2..2, G = grad with its border
                      replicated the same way (grad is replicated, not recomputed)
                                                                              in [0, 200F]
        gmean(y, x) = floor((box + 12) / 25)   (5x5 mean, rounded to nearest;
                                                25 is odd, so there are no ties)  [0, 8F]
        prod        = lap * gmean                                     |prod| <= 32 F^2
        detail      = floor((prod * enhance_gain + 2**(s-1)) / 2**s)   for s >= 1
                      prod * enhance_gain                              for s = 0
                      (s = enhance_shift; floor = arithmetic shift right, so halves
                      round toward +infinity)
        out(y, x)   = clamp(median(y, x) + detail, 0, F)

    The Laplacian and the gradient come from the original frame (Ning et al. 2019: "extract the
    enhancement mask from the original image"); the detail is added to the median output.
    In flat regions ``gmean`` is small and the (noisy) Laplacian is suppressed; along edges
    it is kept (the Gonzalez & Woods mask construction the paper cites as "mature").

    Raises
    ------
    TdicamError
        Parameters out of range, non-integer pixels or pixels outside ``0..F``, frames
        with fewer than 3 columns or 1 row, ``width``/``height`` not matching the array.
    """
    check_range("pixel_bits", pixel_bits, 8, 16)
    if width is not None:
        check_range("width", width, 3, MAX_WIDTH)
    if height is not None:
        check_range("height", height, 1, MAX_HEIGHT)
    a = _frames(frames, pixel_bits, width, height)
    if enhance:
        out = enhance_parts(a, pixel_bits=pixel_bits, enhance_gain=enhance_gain,
                            enhance_shift=enhance_shift)["out"]
    else:
        check_range("enhance_gain", enhance_gain, 0, MAX_GAIN)
        if enhance_shift is not None:
            check_range("enhance_shift", enhance_shift, 0, MAX_SHIFT)
        out = _median(a)
    return out.astype(pixel_dtype(pixel_bits))
