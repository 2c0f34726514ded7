"""Block ``calib``: the ECC-protected calibration store reader (Ning et al. 2019 §4.4.4, §4.3).

``hdl/calib.py`` (:class:`~tdicam.hdl.calib.CalibReader`), ``model/calib.py`` (image format,
golden model :func:`~tdicam.model.calib.reader_stream`), ``cocotb_tests/test_calib.py``,
``golden/calib/``. The stimulus is the image's flash words, one 72-bit word per beat; the
output is one pixel's (gain, offset) per beat (plus counters and flags with ``--debug 1``).
"""

import numpy as np

from tdicam.beats import Beats, mark_resets
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.calib import CalibReader
from tdicam.model import calib, ecc
from tdicam.model.nuc import NucFormat
from tdicam.blocks import SynthRef
from tdicam.blocks import Block, Case, Param, Streams

__all__ = ["BLOCK", "reader_beats", "random_codes", "code_maps"]

# ---- top
_FMT_KEYS = ("gain_int_bits", "gain_frac_bits", "offset_bits", "offset_frac_bits")


def _fmt(params):
    return NucFormat(*(params[k] for k in _FMT_KEYS))


def _check(params):
    _fmt(params)._check_slots()


def _top(**params):
    return AxisTop(CalibReader(**params))


# ---- cases
def random_codes(rng, rows, cols, fmt):
    """Random gain and offset codes over the format's whole range (int64 maps)."""
    g = rng.integers(0, fmt.gain_max + 1, (rows, cols))
    o = rng.integers(fmt.offset_min, fmt.offset_max + 1, (rows, cols))
    return g, o


def _expected(words, params, reset_before):
    """Golden output over the segments cut by ``reset_before`` (stimulus word indices)."""
    fmt = _fmt(params)
    cuts = [0] + [int(x) for x in np.ravel(reset_before if reset_before is not None else [])] \
        + [len(words)]
    parts, starts = [], []
    total = 0
    for a, b in zip(cuts[:-1], cuts[1:]):
        out = calib.reader_stream(words[a:b], rows=params["rows"], cols=params["cols"],
                                  fmt=fmt, count_bits=params["count_bits"])
        starts.append(total)
        total += len(out)
        parts.append(out)
    cat = {f: np.concatenate([getattr(p, f) for p in parts])
           for f in ("gain", "offset", "corrected", "uncorrectable", "defaulted",
                     "header_error", "first", "last")}
    return cat, np.array(starts[1:], np.int64)


def _case(images, reset_before=None):
    """``images(params, rng)`` -> list of (n, 9) uint8 flash images (maybe corrupted), fed
    back to back; arrays = words, expected output, per-word flip counts."""
    def make(params, rng):
        imgs, maps, flips = images(params, rng)
        words = np.concatenate(imgs)
        exp, exp_before = _expected(words, params, reset_before)
        out = {"words": words, "flips": np.concatenate(flips).astype(np.uint8),
               "gain_map": np.stack(maps[0]), "offset_map": np.stack(maps[1])}
        out.update({f"out_{k}": v for k, v in exp.items()})
        if reset_before is not None:
            out["reset_before"] = np.asarray(reset_before, np.int64)
            out["exp_before"] = exp_before
        return out
    return make


def _images(n_images, p_single, p_double, header_flip=False):
    def images(params, rng):
        fmt = _fmt(params)
        imgs, gs, os_, flips = [], [], [], []
        for k in range(n_images):
            g, o = random_codes(rng, params["rows"], params["cols"], fmt)
            img = calib.encode_image(g, o, fmt)
            img, f = calib.inject_flips(rng, img, p_single=p_single, p_double=p_double)
            if header_flip and k == 1:  # a corrected single flip in a header word
                img = calib.flip_image_bits(img, np.where(np.arange(len(img)) == 2, 17, -1))
                f[2] = 1
            imgs.append(img)
            gs.append(g)
            os_.append(o)
            flips.append(f)
        return imgs, (gs, os_), flips
    return images


def _bad_headers(params, rng):
    """Image 0: header word 1 uncorrectable; image 1: a header for other dimensions
    (cols - 1, same word count when possible) -- both defaulted; image 2: good."""
    fmt = _fmt(params)
    rows, cols = params["rows"], params["cols"]
    imgs, gs, os_, flips = [], [], [], []
    for k in range(3):
        g, o = random_codes(rng, rows, cols, fmt)
        img = calib.encode_image(g, o, fmt)
        f = np.zeros(len(img), np.int64)
        if k == 0:
            pos = np.full((len(img), 2), -1)
            pos[1] = (3, 40)  # two flips in header word 1: uncorrectable
            img = calib.flip_image_bits(img, pos)
            f[1] = 2
        if k == 1:
            hdr = calib.header_words(rows, cols, fmt)
            hdr[2] = hdr[2] ^ (1 << 8)  # gain_frac_bits + 1 -> format mismatch
            d, c = ecc.unpack_code(img)
            d[2] = np.uint64(hdr[2])
            c = ecc.encode(d)
            img = ecc.pack_code(d, c)
        imgs.append(img)
        gs.append(g)
        os_.append(o)
        flips.append(f)
    return imgs, (gs, os_), flips


def _fullscale(params, rng):
    """Extreme codes: gain 0 / max / 1.0, offset min / max / -1 / 0, in one image."""
    fmt = _fmt(params)
    rows, cols = params["rows"], params["cols"]
    gvals = np.array([0, fmt.gain_max, fmt.gain_one, 1])
    ovals = np.array([fmt.offset_min, fmt.offset_max, -1, 0, 1])
    idx = np.arange(rows * cols)
    g = gvals[idx % len(gvals)].reshape(rows, cols)
    o = ovals[idx % len(ovals)].reshape(rows, cols)
    img = calib.encode_image(g, o, fmt)
    img2, f = calib.inject_flips(rng, img, p_single=0.3, p_double=0.3)
    return [img, img2], ([g, g], [o, o]), [np.zeros(len(img), np.int64), f]


def reader_beats(arrays, params):
    """(stimulus, expected) beats of a case: one flash word per input beat (``first`` on
    each image's word 0, ``last`` on its last word; the reader ignores both)."""
    words = arrays["words"].astype(np.uint64)
    n = len(words)
    per = calib.HEADER_WORDS + calib.payload_words(params["rows"], params["cols"])
    idx = np.arange(n)
    stim = Beats(words, idx % per == 0, (idx % per == per - 1) | (idx == n - 1))
    cols = [arrays["out_gain"], arrays["out_offset"]]
    if params["debug"]:
        flags = arrays["out_defaulted"].astype(np.uint64) \
            | (arrays["out_header_error"].astype(np.uint64) << 1)
        cols += [arrays["out_corrected"], arrays["out_uncorrectable"], flags]
    exp = Beats(np.stack([np.asarray(c, np.uint64) for c in cols], axis=1),
                arrays["out_first"], arrays["out_last"])
    mark_resets(stim, exp, arrays.get("reset_before"), arrays.get("exp_before"))
    return stim, exp


def _to_case(arrays, params):
    words = np.asarray(arrays["words"])
    exp, _ = _expected(words, params, None)
    return {"words": words, **{f"out_{k}": v for k, v in exp.items()}}


def code_maps(gain, offset, params):
    """``{"gain", "offset"}``: coefficient code streams as ``(n, rows, cols)`` maps."""
    shape = (-1, params["rows"], params["cols"])
    return {"gain": np.asarray(gain).reshape(shape), "offset": np.asarray(offset).reshape(shape)}


def _golden(arrays, params):
    """The reader's (gain, offset) code maps (uint64; the offset as its ``offset_bits``
    two's-complement code), one (rows, cols) map per image in ``words``."""
    case = _to_case(arrays, params)
    return code_maps(case["out_gain"], case["out_offset"], params)


def _unstream(out, arrays, params):
    return code_maps(out.data[:, 0], out.data[:, 1], params)


def _example(rng, n, shape, params):
    """``n`` clean flash images of random codes for the block's rows x cols."""
    fmt = _fmt(params)
    return {"words": np.concatenate([calib.encode_image(*random_codes(
        rng, params["rows"], params["cols"], fmt), fmt) for _ in range(n)])}


_DBG = {"rows": 7, "cols": 9, "debug": True}
_PLAIN = {"rows": 6, "cols": 10}


def _cases():
    return [
        Case("flips_7x9", _DBG, _case(_images(3, 0.3, 0.25, header_flip=True)), seed=1,
             tags=("single", "double")),
        Case("clean_7x9", _DBG, _case(_images(1, 0.0, 0.0)), seed=2),
        Case("bad_header_7x9", _DBG, _case(_bad_headers), seed=3, tags=("header",)),
        Case("fullscale_7x9", _DBG, _case(_fullscale), seed=4, tags=("fullscale",)),
        Case("reset_mid_image_7x9", _DBG, _case(_images(2, 0.2, 0.2), reset_before=[20]),
             seed=5, tags=("reset",)),
        Case("flips_6x10_plain", _PLAIN, _case(_images(2, 0.3, 0.3)), seed=6,
             tags=("single", "double")),
    ]


# ---- entry
BLOCK = Block(
    name="calib",
    summary="calibration store reader: SECDED-protected flash words -> nuc coefficients "
            "in raster order, defaults on uncorrectable words (Ning et al. 2019 §4.4.4, §4.3)",
    params=(
        Param("rows", 3800, "image rows the reader is built for", lo=1, hi=calib.MAX_SIDE),
        Param("cols", 5144, "image columns", lo=1, hi=calib.MAX_SIDE),
        Param("gain_int_bits", 2, "integer bits of the unsigned gain (nuc format)", lo=1,
              hi=4),
        Param("gain_frac_bits", 14, "fraction bits of the gain (1.0 = 2**frac)", lo=4, hi=16),
        Param("offset_bits", 16, "width of the signed offset", lo=2, hi=16),
        Param("offset_frac_bits", 0, "fraction bits of the offset", lo=0, hi=8),
        Param("count_bits", calib.DEFAULT_COUNT_BITS, "width of the saturating word counters",
              lo=8, hi=32),
        Param("debug", False, "carry counters and flags on every output pixel", type=bool),
    ),
    top=_top,
    cases=_cases,
    check=_check,
    model_version="calib-1",
    streams=Streams(
        to_beats=reader_beats,
        stream="words",
        golden=_golden,
        to_case=_to_case,
        unstream=_unstream,
        example=_example,
        frame_beats=lambda p: calib.HEADER_WORDS + calib.payload_words(p["rows"], p["cols"]),
        small=((), {"rows": 3, "cols": 5}),
    ),
    order=90,
    synth=(SynthRef("calib", note="defaults (not among the reference targets): 3800 x 5144, "
                                       "SECDED decoder inside"),),
)
