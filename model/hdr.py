"""Golden model of the high/low-gain HDR merge (Ning et al. 2019 §4.4.2).

The sensor gives two channels of the same exposure: high gain HG (x4.9 by default) and low
gain LG (x0.8). Below a threshold ``T`` on HG the output is HG; at or above it the output is
LG rescaled onto the HG scale by a straight line of slope ``s`` (the gain ratio)::

    out = HG                                    if HG < T
    out = H_T + (LG - L_T) * s                  if HG >= T       (then rounded and clamped)

``(L_T, H_T)`` is the junction point, measured on the *previous* frame from its band pixels,
those whose HG fell in ``[T - band, T)``:

* ``L_T`` (the paper's LG_T) = mean LG of the band pixels;
* ``H_T`` = mean HG of the band pixels with ``anchor="band"`` (default), or ``T`` with
  ``anchor="threshold"`` (the paper's literal ``T + (LG - LG_T) * s``). The band mean point
  lies on the HG/LG line, so ``anchor="band"`` continues HG without a jump whatever the band
  width; ``anchor="threshold"`` pairs a mean taken about ``band/2`` below ``T`` with ``T``
  itself and so jumps by about ``band/2`` codes at the threshold (keep its band narrow).
  Equivalently ``anchor="band"`` is ``T + (LG - LG_T') * s`` with ``LG_T' = L_T + (T - H_T)/s``,
  the LG level referred to HG = T.

Fixed point and rounding (all exact integer arithmetic)

* ``s``: unsigned, ``slope_frac_bits`` fraction bits [8]; entry ``k`` of the slope table is
  ``round_half_up(hg_k / lg_k * 2**slope_frac_bits)`` for gain pair ``k`` of ``gain_pairs``
  (default ``"4.9:0.8"``: 6.125 = 1568/256, exact). Ratios must lie in [1, 64).
* ``L_T``, ``H_T``: unsigned, ``lgt_frac_bits`` fraction bits [4]. At a frame start with
  ``n > 0`` band pixels in the previous frame, ``L_T = (sum_LG * 2**f + n // 2) // n``
  (round half up of the mean), likewise ``H_T`` from ``sum_HG``. With ``n == 0`` (empty band)
  both are kept: there is no division by zero.
* merged value: ``acc = H_T * 2**sf + (LG * 2**f - L_T) * s`` then
  ``out = (acc + 2**(f + sf - 1)) >> (f + sf)`` (round half up, flooring shift; no rounding
  when ``f + sf == 0``) clamped to ``0 .. 2**out_bits - 1``.
* output width ``out_bits`` [derived: the bits of ``(2**pixel_bits - 1) * (1 + s_max)``, 15
  for 12-bit pixels and ratio 6.125]; HG below the threshold always fits. The clamp at 0 acts
  when LG < L_T on a pixel whose HG reached T (noise).
* band statistics saturate: only the first ``2**count_bits - 1`` band pixels of a frame
  (raster order) are summed [count_bits 24].

Frame-to-frame state (the gateware's registers, reproduced exactly)

* reset: current gain pair 0, ``L_T = seed(0)``, ``H_T = T * 2**f``, empty statistics, where
  ``seed(k) = round_half_up(T * 2**(f + sf) / s_k)`` is ``T / s_k`` in ``L_T``'s format.
* each frame start, in order: (1) if the previous frame had band pixels, ``L_T``/``H_T``
  take their means; (2) if the frame's ``gain_sel`` differs from the previous frame's (reset
  counts as pair 0), ``L_T = seed(gain_sel)`` and ``H_T = T * 2**f`` instead (a measurement
  made at other gains is meaningless); (3) the statistics restart empty. The frame is then
  merged with these values and slope ``s[gain_sel]``, and its band pixels are counted.
* ``gain_sel`` indexes the table padded to a power of two by repeating its last entry
  (values ``>= len(gain_pairs)`` select the last pair).
"""

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from tdicam.errors import TdicamError, check_choice, check_range
from tdicam.model.cds import check_pixels, pixel_dtype

__all__ = ["HdrConfig", "hdr_config", "hdr", "parse_gain_pairs", "ANCHORS", "DEFAULT_GAINS",
           "MAX_PAIRS", "MAX_RATIO"]

ANCHORS = ("band", "threshold")
DEFAULT_GAINS = "4.9:0.8"
#: Most (high gain, low gain) pairs ``gain_pairs`` may list.
MAX_PAIRS = 16
#: Each pair's high gain over its low gain lies in [1, MAX_RATIO).
MAX_RATIO = 64


def parse_gain_pairs(gain_pairs):
    """Gain pairs as a tuple of (hg, lg) :class:`~fractions.Fraction` pairs.

    Accepts ``"hg:lg,hg:lg,..."`` (decimal numbers; the CLI form) or a sequence of
    ``(hg, lg)`` numbers. Decimal strings and floats are taken at their decimal value, so
    ``4.9 / 0.8`` is exactly 6.125.
    """
    try:
        if isinstance(gain_pairs, str):
            pairs = [tuple(item.split(":")) for item in gain_pairs.replace(" ", "").split(",")]
        else:
            pairs = [tuple(p) for p in gain_pairs]
        out = []
        for p in pairs:
            if len(p) != 2:
                raise ValueError
            hg, lg = (Fraction(str(v)) for v in p)
            out.append((hg, lg))
    except (TypeError, ValueError, ZeroDivisionError):
        raise TdicamError(f"gain_pairs = {gain_pairs!r} is not valid; expected "
                          f"'hg:lg[,hg:lg...]', e.g. '4.9:0.8'") from None
    if not 1 <= len(out) <= MAX_PAIRS:
        raise TdicamError(f"gain_pairs has {len(out)} pairs; valid: 1..{MAX_PAIRS}")
    for hg, lg in out:
        if lg <= 0 or hg <= 0 or not 1 <= hg / lg < MAX_RATIO:
            raise TdicamError(f"gain pair {float(hg):g}:{float(lg):g} is not valid; the high "
                              f"gain over the low gain must lie in [1, {MAX_RATIO})")
    return tuple(out)


def _round_half_up(frac):
    return math.floor(frac + Fraction(1, 2))


@dataclass(frozen=True)
class HdrConfig:
    """Resolved ``hdr`` parameters and the derived tables (see the module docstring)."""

    pixel_bits: int
    threshold: int
    band: int
    gain_pairs: tuple
    slope_frac_bits: int
    lgt_frac_bits: int
    anchor: str
    count_bits: int
    out_bits: int
    slopes: tuple  # per table entry, padded to 2**sel_bits
    seeds: tuple   # L_T after reset / a gain change, per padded entry

    @property
    def sel_bits(self):
        """Width of the ``gain_sel`` port (0: one pair, no port)."""
        return (len(self.gain_pairs) - 1).bit_length()

    @property
    def slope_bits(self):
        return max(self.slopes).bit_length()

    @property
    def lt_bits(self):
        """Width of ``L_T`` / ``H_T`` (``pixel_bits + lgt_frac_bits``)."""
        return self.pixel_bits + self.lgt_frac_bits

    @property
    def h_seed(self):
        return self.threshold << self.lgt_frac_bits

    @property
    def count_max(self):
        return (1 << self.count_bits) - 1


def hdr_config(*, pixel_bits=12, threshold=None, band=None, gain_pairs=DEFAULT_GAINS,
               slope_frac_bits=8, lgt_frac_bits=4, anchor="band", count_bits=24,
               out_bits=None):
    """Check the ``hdr`` parameters (one-line :class:`TdicamError`) and derive the tables."""
    check_range("pixel_bits", pixel_bits, 8, 16)
    full = (1 << pixel_bits) - 1
    if threshold is None:
        threshold = 3 << (pixel_bits - 2)
    check_range("threshold", threshold, 1, full)
    if band is None:
        band = min(1 << (pixel_bits - 5), threshold)
    check_range("band", band, 1, threshold)
    pairs = parse_gain_pairs(gain_pairs)
    check_range("slope_frac_bits", slope_frac_bits, 0, 12)
    check_range("lgt_frac_bits", lgt_frac_bits, 0, 8)
    check_choice("anchor", anchor, ANCHORS)
    check_range("count_bits", count_bits, 4, 32)
    slopes = [_round_half_up(hg / lg * (1 << slope_frac_bits)) for hg, lg in pairs]
    sel_bits = (len(pairs) - 1).bit_length()
    slopes += [slopes[-1]] * ((1 << sel_bits) - len(slopes))
    scale = 1 << (lgt_frac_bits + slope_frac_bits)
    seeds = [min(_round_half_up(Fraction(threshold * scale, s)), full << lgt_frac_bits)
             for s in slopes]
    max_out = full + -(-full * max(slopes) // (1 << slope_frac_bits))
    if out_bits is None:
        out_bits = min(max_out.bit_length(), 24)
    check_range("out_bits", out_bits, pixel_bits, 24)
    return HdrConfig(pixel_bits, threshold, band, pairs, slope_frac_bits, lgt_frac_bits,
                     anchor, count_bits, out_bits, tuple(slopes), tuple(seeds))


def hdr(hg, lg, *, pixel_bits=12, threshold=None, band=None, gain_pairs=DEFAULT_GAINS,
        slope_frac_bits=8, lgt_frac_bits=4, anchor="band", count_bits=24, out_bits=None,
        gain_sel=None, return_state=False):
    """Merge high- and low-gain frames, frame by frame from reset.

    Parameters
    ----------
    hg, lg : array_like of int, shape (n_frames, rows, cols) or (rows, cols)
        High- and low-gain pixels of the same exposures, ``0 .. 2**pixel_bits - 1``, frames in
        time order; the first frame is the first after reset.
    pixel_bits : int
        Input width, 8..16 [12].
    threshold : int or None
        ``T`` on HG, 1 .. 2**pixel_bits - 1 [3/4 of full scale: 3072 for 12 bits].
    band : int or None
        Band width below ``T``, 1..T [2**(pixel_bits - 5): 128 for 12 bits].
    gain_pairs : str or sequence of (hg, lg)
        The slope table, one entry per programmed gain pair, 1..16 entries ["4.9:0.8"].
    slope_frac_bits, lgt_frac_bits : int
        Fraction bits of the slope (0..12) [8] and of ``L_T``/``H_T`` (0..8) [4].
    anchor : {"band", "threshold"}
        HG level of the junction point: band mean ["band"] or ``T`` (the paper's form).
    count_bits : int
        Width of the band pixel counter, 4..32 [24].
    out_bits : int or None
        Output width, pixel_bits..24 [derived, see the module docstring].
    gain_sel : None, int or sequence of int (one per frame)
        Gain pair of each frame (the run-time ``gain_sel`` port, sampled with each frame's
        first pixel) [0]; ``0 .. 2**sel_bits - 1``.
    return_state : bool
        Also return a dict of per-frame int64 arrays ``L_T``, ``H_T`` (values used for the
        frame), ``slope`` and ``band_count`` (band pixels counted in the frame).

    Returns
    -------
    ndarray of :func:`~tdicam.model.cds.pixel_dtype` (``out_bits``), shape of ``hg``
        (and the state dict when ``return_state``).

    Raises
    ------
    TdicamError
        On a bad parameter, shape mismatch, non-integer input or values out of range.
    """
    cfg = hdr_config(pixel_bits=pixel_bits, threshold=threshold, band=band,
                     gain_pairs=gain_pairs, slope_frac_bits=slope_frac_bits,
                     lgt_frac_bits=lgt_frac_bits, anchor=anchor, count_bits=count_bits,
                     out_bits=out_bits)
    h = check_pixels("hg", hg, pixel_bits)
    lo = check_pixels("lg", lg, pixel_bits)
    if h.shape != lo.shape:
        raise TdicamError(f"hg shape {h.shape} differs from lg shape {lo.shape}")
    if h.ndim not in (2, 3):
        raise TdicamError(f"hg and lg must be (rows, cols) or (frames, rows, cols), got "
                          f"shape {h.shape}")
    h3 = h.reshape((-1,) + h.shape[-2:]).astype(np.int64)
    l3 = lo.reshape(h3.shape).astype(np.int64)
    nf = h3.shape[0]
    sels = _frame_sels(gain_sel, nf, cfg)

    t, f, sf = cfg.threshold, cfg.lgt_frac_bits, cfg.slope_frac_bits
    top = (1 << cfg.out_bits) - 1
    out = np.empty(h3.shape, np.int64)
    state = {k: np.zeros(nf, np.int64) for k in ("L_T", "H_T", "slope", "band_count")}
    cur, lt, ht = 0, cfg.seeds[0], cfg.h_seed
    sum_l = sum_h = n = 0
    for k in range(nf):
        if n:
            lt = ((sum_l << f) + (n >> 1)) // n
            ht = ((sum_h << f) + (n >> 1)) // n if cfg.anchor == "band" else cfg.h_seed
        sel = int(sels[k])
        if sel != cur:
            lt, ht = cfg.seeds[sel], cfg.h_seed
        cur = sel
        s = cfg.slopes[sel]
        hk, lk = h3[k], l3[k]
        acc = (ht << sf) + ((lk << f) - lt) * s
        if f + sf:
            acc = (acc + (1 << (f + sf - 1))) >> (f + sf)
        out[k] = np.where(hk < t, hk, np.clip(acc, 0, top))
        idx = np.flatnonzero((hk >= t - cfg.band) & (hk < t))[:cfg.count_max]
        n = int(idx.size)
        sum_l = int(lk.ravel()[idx].sum())
        sum_h = int(hk.ravel()[idx].sum())
        for key, val in (("L_T", lt), ("H_T", ht), ("slope", s), ("band_count", n)):
            state[key][k] = val
    out = out.astype(pixel_dtype(cfg.out_bits)).reshape(h.shape)
    return (out, state) if return_state else out


def _frame_sels(gain_sel, nf, cfg):
    limit = (1 << cfg.sel_bits) - 1
    sels = np.zeros(nf, np.int64) if gain_sel is None else np.asarray(gain_sel)
    if sels.ndim == 0:
        sels = np.full(nf, sels)
    if sels.shape != (nf,) or not np.issubdtype(sels.dtype, np.integer):
        raise TdicamError(f"gain_sel must be an integer or one integer per frame ({nf}), got "
                          f"{np.asarray(gain_sel).tolist()!r}")
    if sels.size and (sels.min() < 0 or sels.max() > limit):
        raise TdicamError(f"gain_sel has values outside 0..{limit} (the table has "
                          f"{len(cfg.gain_pairs)} gain pairs)")
    return sels
