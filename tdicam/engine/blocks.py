"""The pipeline blocks in the scene simulator (cds, nuc, hdr, median3, tdi): when a block
runs, which of the engine's frame stacks are its scene arrays (stream and side inputs, as the
block registry :mod:`tdicam.blocks` names them), the ideal NUC coefficients, the ECC round
trip of the coefficients or their store in NAND flash (``[pipeline.nuc] flash = "nand"``),
and the crops kept for RTL co-simulation.

A block's parameters come from its registry entry's one scene-to-parameters function
(:attr:`tdicam.blocks.Use.step`, the same the scene's gateware chain uses), and its golden
model runs through the entry (:func:`golden`), TDI's included. All block knowledge of the
engine is here.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from tdicam import blocks as _registry
from tdicam.blocks.steps import Context
from tdicam.errors import TdicamError
from tdicam.model import ecc as _ecc, nand_store as _nand, hdr as _hdr, nuc as _nuc, tdi as _tdi

__all__ = ["need", "Frames", "golden", "cds", "nuc", "hdr", "median3_pre", "tdi",
           "median3_post", "prepare", "nuc_coeffs", "tdi_bits", "subtract_reset"]

def need(block, where=None):
    """The ``need`` of the engine step of registry block ``block``: listed in
    ``[pipeline].blocks`` (``where``: ``"pre"`` / ``"post"``, for a block that may run before
    or after the line-making block, the one of the two this step is)."""
    use = _registry.get(block).pipeline

    def need_block(c):
        pipe, m = c.scene.pipeline, c.m
        after = pipe.after_lines(block)
        listed = after is not None
        if where is not None and listed:
            listed = (where == "post") == after
        if use.lines and not c.digital:
            return True, (f"charge domain: {m} stages summed as charge before one readout "
                          f"(Zhou et al. 2008); the FPGA accumulator is not used")
        if not listed:
            here = "" if where is None or after is None else \
                (" here (it runs " + ("after" if after else "before") + " TDI)")
            return False, f"not in [pipeline].blocks{here}"
        if use.merge and len(c.sensor.gains) != 2:
            return False, "one-gain sensor: nothing to merge"
        return True, f"in [pipeline].blocks, golden model tdicam.model.{block}"
    return need_block


@dataclass
class Frames:
    """Frame stacks on their way through the blocks.

    ``channels`` holds one stack per ADC channel (HG, LG) until hdr merges them; ``resets``
    the reset frames (with CDS); ``bits`` the pixel width the next block gets; ``keep`` cuts
    the RTL crop out of a stack (None: keep nothing) into ``crop``.
    """

    channels: list
    resets: list | None
    bits: int
    timer: object
    keep: object = None
    crop: dict = field(default_factory=dict)
    out: np.ndarray | None = None        # TDI output
    full_scale: int = 0                  # of ``out``
    keep_out: tuple | None = None        # (y0, h, x0, w) of the output crop


def golden(block, arrays, params):
    """Output of registry block ``block``'s golden function on scene ``arrays``."""
    blk = _registry.get(block)
    return blk.run_golden(arrays, blk.resolve(params))["out"]


def params(c, block, bits, width, *, after_lines=False):
    """Registry block ``block``'s parameters in run context ``c`` for ``bits``-bit input
    pixels, ``width`` wide: its entry's scene-to-parameters function
    (:attr:`tdicam.blocks.Use.step`)."""
    ctx = Context(scene=c.scene, m=c.m, width=width, lines=0, bits=bits,
                  after_lines=after_lines, block=block)
    step, _ = _registry.get(block).pipeline.step(ctx)
    return step


def _check_bits(block, bits, lo, hi, key):
    if not lo <= bits <= hi:
        raise TdicamError(f"{key}: the {block} golden model takes {lo}..{hi}-bit pixels, "
                          f"this chain gives it {bits}-bit pixels")


def _timed(name):
    def wrap(fn):
        def step(c, fr):
            t = time.perf_counter()
            fn(c, fr)
            fr.timer.add(name, time.perf_counter() - t)
        step.__name__ = name
        step.__doc__ = fn.__doc__
        return step
    return wrap


def subtract_reset(signal, reset, bits):
    """The cds block's golden model on one frame and its reset frame."""
    return golden("cds", {"signal": signal, "reset": reset}, {"pixel_bits": bits})


@_timed("cds")
def cds(c, fr):
    """Digital CDS of every channel: signal minus reset frame."""
    bits = c.sensor.bits
    for ch, x in enumerate(fr.channels):
        p = params(c, "cds", bits, x.shape[-1]).params
        y = golden("cds", {"signal": x, "reset": fr.resets[ch]}, p)
        if fr.keep is not None and ch == 0:
            fr.crop["cds"] = {"signal": fr.keep(x), "reset": fr.keep(fr.resets[ch]),
                              "out": fr.keep(y), "params": p}
        fr.channels[ch] = y


def _nuc_params(c):
    return params(c, "nuc", c.sensor.bits, c.sensor.columns).params


def _nuc_format(c):
    p = _nuc_params(c)
    return _nuc.NucFormat(**{k: p[k] for k in ("gain_int_bits", "gain_frac_bits",
                                               "offset_bits", "offset_frac_bits")})


@_timed("nuc")
def nuc(c, fr):
    """Golden nuc of every channel with the ideal coefficients (``c.nuc_coeffs``)."""
    fmt = _nuc_format(c)
    bits = c.sensor.bits
    for ch, x in enumerate(fr.channels):
        gain_c, off_c = c.nuc_coeffs[ch]
        if c.scene.pipeline.nuc.flash == "nand":
            gain_c, off_c = _nand_roundtrip(c, ch, fmt, gain_c, off_c)
        elif c.scene.pipeline.nuc.ecc:
            gain_c, off_c = _ecc_roundtrip(fmt, gain_c, off_c)
        g = np.broadcast_to(gain_c, x.shape)
        o = np.broadcast_to(off_c, x.shape)
        p = params(c, "nuc", bits, x.shape[-1]).params
        y = golden("nuc", {"x": x, "gain": g, "offset": o}, p)
        if fr.keep is not None and ch == 0:
            fr.crop["nuc"] = {"x": fr.keep(x), "gain": fr.keep(np.ascontiguousarray(g)),
                              "offset": fr.keep(np.ascontiguousarray(o)), "out": fr.keep(y),
                              "params": p}
        fr.channels[ch] = y


def _ecc_roundtrip(fmt, gain, offset):
    """Store the coefficients as 64/72 SECDED words and read them back (no flips injected)."""
    data = np.asarray(fmt.pack_words(gain, offset), np.uint64)
    dec = _ecc.decode(data, _ecc.encode(data))
    if np.any(dec.uncorrectable):
        raise TdicamError("nuc coefficients: ECC round trip reported an uncorrectable word")
    g, o = fmt.unpack_words(np.asarray(dec.data, np.uint64))
    n = np.size(gain)
    return g[:n].reshape(np.shape(gain)), o[:n].reshape(np.shape(offset))


def _nand_roundtrip(c, ch, fmt, gain, offset):
    """Store channel ``ch``'s coefficient codes in NAND flash with the ``[pipeline.nuc]``
    faults and load them back as the camera does (:func:`tdicam.model.nand_store.store_roundtrip`:
    bad-block scan, block map, ECC, defaults gain 1 / offset 0 for an uncorrectable word).

    The first store of each channel in a run (the output's coefficients) is counted in
    ``c.flash[ch]``: corrected and uncorrectable words, defaulted pixels, bad blocks found.
    """
    o = c.scene.pipeline.nuc
    shape = np.shape(gain)
    g2 = np.asarray(gain, np.int64).reshape(-1, shape[-1])
    o2 = np.asarray(offset, np.int64).reshape(-1, shape[-1])
    g, off, res = _nand.store_roundtrip(g2, o2, fmt, bad_blocks=o.bad_blocks,
                                        p_single=o.flip_single, p_double=o.flip_double,
                                        seed=o.seed + ch)
    if ch not in c.flash:
        img = res.image
        c.flash[ch] = {"channel": ch, "pixels": int(g2.size), "words": int(res.words),
                       "pages": int(res.pages), "bad_blocks": int(res.scan.bad_count),
                       "corrected_words": int(img.corrected),
                       "uncorrectable_words": int(img.uncorrectable),
                       "defaulted_pixels": int(np.count_nonzero(img.defaulted))}
    return g.reshape(shape), off.reshape(shape)


def prepare(c, gain_map, dark_map):
    """Side inputs the blocks of context ``c`` take from the fixed pattern (``gain_map`` and
    ``dark_map`` of the rows each output pixel sums): the ideal NUC coefficients."""
    c.nuc_coeffs = nuc_coeffs(c, gain_map, dark_map) if c.ran("nuc") else None


def nuc_coeffs(c, gain_map, dark_map):
    """Per-channel (gain, offset) codes that map each pixel onto the mean response.

    Pixel response (DN, before quantization): ``y = a/c (S (1+P) + d) + B``; the corrected
    target is ``a/c (S + mean d) + B``. Least squares over signal levels gives exactly
    ``gain = 1/(1+P)`` and ``offset = B + a/c mean(d) - gain (B + a/c d)``.
    """
    fmt = _nuc_format(c)
    out = []
    base = c.zero_dn
    for g in c.gains:
        k = g / c.sensor.conversion_gain_e_per_dn
        gr = 1.0 / np.maximum(gain_map, 1e-6)
        off = base + k * dark_map.mean() - gr * (base + k * dark_map)
        out.append((fmt.gain_code(gr), fmt.offset_code(off)))
    return out


@_timed("hdr")
def hdr(c, fr):
    """Golden HDR merge of the HG and LG channels into one."""
    if len(fr.channels) != 2:
        return
    p = params(c, "hdr", fr.bits, fr.channels[0].shape[-1]).params
    merged = golden("hdr", {"hg": fr.channels[0], "lg": fr.channels[1]}, p)
    if fr.keep is not None:
        fr.crop["hdr"] = {"hg": fr.keep(fr.channels[0]), "lg": fr.keep(fr.channels[1]),
                          "out": fr.keep(merged), "params": p}
    fr.bits = _hdr.hdr_config(**p).out_bits
    fr.channels = [merged]


@_timed("median3_pre")
def median3_pre(c, fr):
    """Golden 3x3 median on single exposures (before TDI)."""
    x = fr.channels[0]
    _check_bits("median3", fr.bits, 8, 16, "[sensor].bits")
    p = params(c, "median3", fr.bits, x.shape[-1]).params
    y = golden("median3", {"frames": x}, p)
    if fr.keep is not None:
        fr.crop["median3"] = {"frames": fr.keep(x), "out": None, "params": {
            k: v for k, v in p.items() if k != "width"}}
    fr.channels = [y]


def tdi_bits(bits, m):
    """Full TDI output width of ``m`` stages of ``bits``-bit pixels."""
    return _tdi.full_bits(bits, m)


@_timed("tdi")
def tdi(c, fr):
    """Golden digital TDI of the frame stack (saturating when ``[tdi].output`` says so)."""
    m, pb, x = c.m, fr.bits, fr.channels[0]
    _check_bits("tdi", pb, *_tdi.PIXEL_BITS,
                "[sensor].bits" if pb == c.sensor.bits else "[pipeline].blocks (hdr output)")
    full = _tdi.full_bits(pb, m)
    step = params(c, "tdi", pb, x.shape[-1])
    out_bits, direction = step.params["out_bits"], step.inputs["direction"]
    if out_bits is not None and not pb <= out_bits <= full:
        raise TdicamError(f"[tdi].output_bits: must be in {pb}..{full} for {pb}-bit pixels "
                          f"and {m} stages, got {out_bits}")
    # the golden model's own limits, not the gateware's (a scene may be wider than 8192)
    out = _registry.get("tdi").run_golden({"frames": x, **step.inputs}, step.params)["out"]
    out = out.astype(np.int64)
    if fr.keep is not None:
        y0, h, x0, w = fr.keep_out
        fr.crop["tdi"] = {"frames": fr.keep(x), "params": dict(
            width=None, stages=m, pixel_bits=pb, out_bits=None if out_bits == full else out_bits,
            direction=direction), "out": out[y0:y0 + h, x0:x0 + w].copy()}
    fr.out = out
    fr.full_scale = (1 << (out_bits if out_bits is not None else full)) - 1


@_timed("median3_post")
def median3_post(c, fr):
    """Golden 3x3 median on the TDI output."""
    pb = max(1, int(fr.full_scale).bit_length())
    if pb > 16:
        raise TdicamError(f"[tdi].output: median3 after TDI takes at most 16-bit pixels; "
                          f"the TDI output is {pb} bits: set output = 'saturate' with "
                          f"output_bits <= 16")
    p = params(c, "median3", pb, fr.out.shape[-1], after_lines=True).params
    y = golden("median3", {"frames": fr.out}, p).astype(np.int64)
    if fr.keep_out is not None:
        y0, h, x0, w = fr.keep_out
        fr.crop["median3"] = {"frames": fr.out[y0:y0 + h, x0:x0 + w].copy(), "out": None,
                              "params": {k: v for k, v in p.items() if k != "width"}}
    fr.out = y
