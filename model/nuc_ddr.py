"""Golden model of ``nuc_ddr``: per-pixel NUC whose coefficients live in DDR (Ning et al. 2019
§4.2-§4.4.4; the gateware is :class:`tdicam.hdl.nuc_ddr.NucDdr`, the packing and memory model
:mod:`tdicam.model.ddr`, the correction :func:`tdicam.model.nuc.nuc`).

The coefficient image in DDR
----------------------------
A coefficient frame (what :class:`~tdicam.hdl.calib.CalibReader` streams at power-up: gain
and offset codes per pixel, raster order) is stored as lines of a
:class:`~tdicam.model.ddr.LineLayout` with ``channels`` = 2 (gain, offset), ``pixel_bits`` =
:data:`COEFF_BITS` = 16 and ``pixels_per_word`` = :data:`COEFFS_PER_WORD` = 16 values a
256-bit word: 8 pixels' pairs a word, in the layout's (pixel, channel) order with the first
value most significant — ``{g0, o0, g1, o1, ..., g7, o7}``, ``g0`` at bits [255:240]. Each
64-bit quarter of the word so holds 4 coefficients (2 pixels), as the paper's 64-bit flash
words do (Ning et al. 2019: "64 bits = 4 coefficients"; the flash word's own slot order is
:meth:`tdicam.model.nuc.NucFormat.pack_words`'s, least significant first — the DDR image is
its own packing, written from the decoded stream). A gain is stored zero-extended, an offset
as its ``offset_bits``-bit two's complement, zero above (the decoded stream's form). Line
``y`` (image row ``y``) starts at ``base + y * line_stride``.

The image may have more lines (``image_rows``) than a pixel frame (``rows``): the ``j``-th
pixel frame after the coefficient frame reads lines :func:`image_segment` (``rows`` lines
from ``(j mod (image_rows / rows)) * rows``). An area camera streamed a sensor row a frame
so keeps a coefficient line per sensor row (Ning et al. 2019: a gain and an offset per
pixel); with ``image_rows`` = ``rows`` (the default) every frame reads the whole image.

What the DDR adds
-----------------
Nothing to pixels: a coefficient read back equals the one written (:func:`coeff_words`,
:func:`coeff_readback` are exact inverses on legal codes), so the output is
:func:`tdicam.model.nuc.nuc` with the last stored coefficient frame. The trip costs latency
and stalls only (the reads' latency, the controller's refresh and ready drops): they show in
the cycle count, never in a value.
"""

import numpy as np

from tdicam.errors import TdicamError
from tdicam.model.cds import pixel_dtype
from tdicam.model.ddr import WORD_BITS, LineLayout, pack_lines, unpack_lines
from tdicam.model.nuc import NucFormat, check_nuc_params, identity_coeffs, nuc

__all__ = ["COEFF_BITS", "COEFFS_PER_WORD", "check_image_rows", "coeff_layout", "coeff_words",
           "coeff_readback", "image_segment", "nuc_ddr_frames"]

#: Bits of one stored coefficient (a gain or an offset slot), as the flash words' slots.
COEFF_BITS = 16
#: Coefficients a 256-bit DDR word: 8 pixels' (gain, offset), 4 a 64-bit quarter.
COEFFS_PER_WORD = WORD_BITS // COEFF_BITS


def coeff_layout(width, *, line_stride=None, base=0):
    """The :class:`~tdicam.model.ddr.LineLayout` of a ``width``-pixel coefficient row."""
    return LineLayout(width=width, channels=2, pixel_bits=COEFF_BITS,
                      pixels_per_word=COEFFS_PER_WORD, line_stride=line_stride, base=base)


def check_image_rows(rows, image_rows):
    """``image_rows`` (None: ``rows``), refused in one line unless a multiple of ``rows``."""
    if image_rows is None:
        return int(rows)
    if image_rows < rows or image_rows % rows:
        raise TdicamError(f"image_rows = {image_rows} is not a multiple of the frame's rows = "
                          f"{rows}: give a multiple of {rows}")
    return int(image_rows)


def image_segment(j, rows, image_rows):
    """The coefficient image's lines pixel frame ``j`` (0 the first after the coefficient
    frame) is corrected with: ``rows`` lines from line ``(j mod (image_rows / rows)) * rows``.
    With ``image_rows`` = ``rows`` every frame reads the whole image (a line scanner's
    window); an area camera whose frames are single lines (tdicam's chain: a frame is the
    TDI stages' rows, one) stores its sensor's ``image_rows`` rows and sensor row ``r`` of
    the frame is read against coefficient line ``r``."""
    a = (j % (image_rows // rows)) * rows
    return slice(a, a + rows)


def coeff_words(gain, offset, fmt, layout):
    """The DDR words of a coefficient frame: ``gain``, ``offset`` (rows, width) codes ->
    (rows, words_per_line, 4) uint64 limbs (:func:`tdicam.model.ddr.pack_lines`)."""
    g, o = fmt.check_coeffs(gain, offset)
    if g.shape != o.shape or g.ndim != 2:
        raise TdicamError(f"gain {g.shape} and offset {o.shape} must be one (rows, width) "
                          f"shape")
    pairs = np.stack([g, o & ((1 << fmt.offset_bits) - 1)], axis=-1)
    return pack_lines(pairs, layout)


def coeff_readback(words, fmt, layout):
    """Inverse of :func:`coeff_words`: (gain, offset) int64 (rows, width), the offset
    sign-extended from bit ``offset_bits - 1``."""
    v = unpack_lines(words, layout).astype(np.int64).reshape(len(words), layout.width, 2)
    g = v[..., 0] & fmt.gain_max
    o = v[..., 1] & ((1 << fmt.offset_bits) - 1)
    return g, np.where(o >> (fmt.offset_bits - 1), o - (1 << fmt.offset_bits), o)


def nuc_ddr_frames(x, gain, offset, kinds, *, pixel_bits=12, gain_int_bits=2,
                   gain_frac_bits=14, offset_bits=16, offset_frac_bits=0, out_bits=None,
                   line_stride=None, base=0, image_rows=None):
    """Golden NUC with the coefficients from DDR (see :class:`tdicam.hdl.nuc_ddr.NucDdr`).

    Parameters
    ----------
    x : array_like of int, (n, rows, width)
        Frame ``i``'s pixels (read when ``kinds[i]`` is 0).
    gain, offset : array_like of int, (n, image_rows, width)
        Frame ``i``'s coefficient codes (read when ``kinds[i]`` is 1), in
        :func:`tdicam.model.nuc.nuc`'s formats.
    kinds : array_like of int, (n,)
        1: a coefficient frame — written to DDR (:func:`coeff_words`), no output; 0: a pixel
        frame — corrected with the coefficients read back (:func:`coeff_readback`) of the
        last coefficient frame, the defaults (gain 1.0, offset 0) before any.
    pixel_bits, gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits, out_bits
        :func:`tdicam.model.nuc.nuc`'s (gain and offset at most 16 bits: one slot).
    line_stride, base
        Where the coefficient image lives (:func:`coeff_layout`; the values do not depend
        on it).
    image_rows : int or None
        Lines of the coefficient image, a multiple of ``rows`` (:func:`image_segment`); None:
        ``rows`` (every pixel frame reads the whole image).

    Returns
    -------
    ndarray of :func:`~tdicam.model.cds.pixel_dtype` (``out_bits``), (pixel frames, rows, width)
        Each ``nuc(x, gain, offset)`` exactly: rounded half up, saturated to ``out_bits``;
        the ``j``-th pixel frame after a coefficient frame with the image's lines
        :func:`image_segment` ``(j, rows, image_rows)``.
    """
    out_bits = check_nuc_params(pixel_bits=pixel_bits, gain_int_bits=gain_int_bits,
                                gain_frac_bits=gain_frac_bits, offset_bits=offset_bits,
                                offset_frac_bits=offset_frac_bits, out_bits=out_bits)
    fmt = NucFormat(gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits)
    fmt._check_slots()
    x = np.asarray(x)
    n, rows, width = x.shape
    image_rows = check_image_rows(rows, image_rows)
    layout = coeff_layout(width, line_stride=line_stride, base=base)
    kw = dict(pixel_bits=pixel_bits, out_bits=out_bits, **fmt.params())
    stored, out, j = None, [], 0
    for i, k in enumerate(np.asarray(kinds, np.int64)):
        if k:
            stored = coeff_words(np.asarray(gain)[i], np.asarray(offset)[i], fmt, layout)
            if len(stored) != image_rows:
                raise TdicamError(f"coefficient frame {i} has {len(stored)} lines, the image "
                                  f"{image_rows}: give image_rows = {len(stored)}")
            j = 0
            continue
        if stored is None:
            g, o = identity_coeffs((rows, width), fmt)
        else:
            g, o = coeff_readback(stored[image_segment(j, rows, image_rows)], fmt, layout)
            j += 1
        out.append(nuc(x[i], g, o, **kw))
    if not out:
        return np.zeros((0, rows, width), pixel_dtype(out_bits))
    return np.stack(out)
