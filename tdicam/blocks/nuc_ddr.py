"""Block ``nuc_ddr``: per-pixel NUC with its coefficients in DDR (Ning et al. 2019 §4.2-§4.4.4;
:class:`~tdicam.hdl.nuc_ddr.NucDdr`).

Coefficient frames (``kinds`` 1: the gain and offset codes of every pixel, what the
calibration reader decodes from the NAND at power-up) are stored in DDR and give no output;
each pixel frame (``kinds`` 0) is corrected with the stored coefficients read back (golden
:func:`~tdicam.model.nuc_ddr.nuc_ddr_frames`: :func:`~tdicam.model.nuc.nuc` exactly, the
DDR adds latency and stalls only). ``frame_kind`` rides with each beat. The Verilog top has
the simulation MIG model behind it (:mod:`tdicam.blocks._ddr`).
"""

import numpy as np

from tdicam.errors import TdicamError
from tdicam.blocks.steps import Step

from tdicam.beats import PPC_CHOICES, Beats, frames_to_beats
from tdicam.model.cds import pixel_dtype
from tdicam.model.ddr import ADDR_PER_WORD, check_capacity
from tdicam.model.nuc import NucFormat
from tdicam.model.nuc_ddr import check_image_rows, coeff_layout, nuc_ddr_frames
from tdicam.blocks import (PPC_PARAM, Block, Case, Memory, Param, SideInput, Streams, Suite, Use,
                           check_width)
from tdicam.blocks._ddr import STALL_PARAMS, address_params, check_stalls, sim_top, stalls_of
from tdicam.blocks.nuc import _random as _nuc_random, _saturate_wide
from tdicam.hdl.nuc_ddr import NucDdr

__all__ = ["BLOCK", "nuc_ddr_arrays"]

# ---- top
_FMT_KEYS = ("gain_int_bits", "gain_frac_bits", "offset_bits", "offset_frac_bits")
_MODEL_KEYS = ("pixel_bits", "out_bits", "line_stride", "base", "image_rows") + _FMT_KEYS


def _nuc_params(p):
    """The ``nuc`` block's parameters of ours (its case generators take them)."""
    return {k: p[k] for k in ("pixel_bits", "out_bits", "ppc") + _FMT_KEYS}


def _fmt(p):
    return NucFormat(**{k: p[k] for k in _FMT_KEYS})


def _check(p):
    check_stalls(p)
    check_width(p["width"], p["ppc"])
    _fmt(p)._check_slots()
    check_capacity(coeff_layout(p["width"], line_stride=p["line_stride"], base=p["base"]),
                   _image_rows(p), p["capacity_mib"] << 20, "coefficient image")


def _image_rows(p):
    """Lines of the coefficient image (``image_rows``, default ``rows``), checked."""
    return check_image_rows(p["rows"], p["image_rows"])


def _core(p, dsp="generic"):
    """The block's gateware for resolved parameters ``p`` (``dsp``: :attr:`NucDdr.DSPS`)."""
    return NucDdr(width=p["width"], rows=p["rows"], ppc=p["ppc"],
                  capacity_bytes=p["capacity_mib"] << 20, dsp=dsp,
                  **{k: p[k] for k in _MODEL_KEYS})


def _top(**p):
    core = _core(p)
    return sim_top(core, core.layout.end_addr(core.image_rows) // ADDR_PER_WORD, stalls_of(p))


def _synth_top(**p):
    """What ``tdicam synth`` places: the core with its MIG user interface at the ports (the
    memory model of :func:`_top` is simulation only), each lane's multiplier a MULT18X18D
    with its own input registers (``dsp="ecp5"``, as ``nuc``'s ECP5 top)."""
    from tdicam.hdl.interfaces.axis import AxisTop
    return AxisTop(_core(p, "ecp5"))


# ---- cases
def _golden(arrays, params):
    return {"out": nuc_ddr_frames(arrays["x"], arrays["gain"], arrays["offset"],
                                  arrays["kinds"], **{k: params[k] for k in _MODEL_KEYS})}


def nuc_ddr_arrays(x, gain, offset, kinds, params):
    """Case arrays (inputs as int64 and the golden ``out``) of frames ``x``, coefficients
    ``gain``/``offset`` (n, rows, width) and ``kinds`` (n,)."""
    a = {"x": np.asarray(x).astype(np.int64), "gain": np.asarray(gain).astype(np.int64),
         "offset": np.asarray(offset).astype(np.int64),
         "kinds": np.asarray(kinds, np.int64)}
    return {**a, **_golden(a, params)}


def _random(kinds):
    """Random pixels; calibration-like coefficients with any code in every 7th pixel
    (``nuc``'s random case) on the coefficient frames (``image_rows`` lines)."""
    def make(params, rng):
        rows, w = params["rows"], params["width"]
        img = check_image_rows(rows, params.get("image_rows"))
        a = _nuc_random(len(kinds), img, w)(_nuc_params(params), rng)
        x = a["x"][:, :rows] if img == rows else \
            _nuc_random(len(kinds), rows, w)(_nuc_params(params), rng)["x"]
        return nuc_ddr_arrays(x, a["gain"], a["offset"], kinds, params)
    return make


def _hard(params, rng):
    """``nuc``'s 175 extreme (x, gain, offset) combinations on 8 x 24 frames (saturation at
    both ends): the pixels before any coefficients (defaults: x out), the coefficients,
    the pixels, full-scale and zero pixels, a second coefficient frame, the pixels again."""
    a = _saturate_wide(_nuc_params(params), rng)
    x, g, o = a["x"][0], a["gain"][0], a["offset"][0]
    full = np.full_like(x, (1 << params["pixel_bits"]) - 1)
    seq = [(x, g, o, 0), (x, g, o, 1), (x, g, o, 0), (full, g, o, 0), (0 * x, g, o, 0),
           (x, g[::-1], o[:, ::-1], 1), (x, g, o, 0)]
    return nuc_ddr_arrays(*(np.stack([s[k] for s in seq]) for k in range(3)),
                          [s[3] for s in seq], params)


def _to_beats(arrays, params):
    """``ppc`` pixels a beat, two elements a pixel: (gain, offset as ``offset_bits``-bit two's
    complement) on a coefficient frame, (x, 0) on a pixel frame; ``frame_kind`` with every
    beat."""
    ppc, fmt = params["ppc"], _fmt(params)
    x, kinds = arrays["x"], np.asarray(arrays["kinds"], np.int64)
    check_width(np.shape(x)[-1], ppc)
    g, o = fmt.check_coeffs(arrays["gain"], arrays["offset"])
    if np.shape(g)[1] != np.shape(x)[1]:          # an image of more lines than a frame
        return _to_beats_image(x, g, o, kinds, ppc, fmt), frames_to_beats(arrays["out"],
                                                                          ppc=ppc)
    k = kinds[:, None, None].astype(bool)
    elems = np.stack([np.where(k, g, x), np.where(k, o & ((1 << fmt.offset_bits) - 1), 0)],
                     axis=-1)
    stim = frames_to_beats(elems, ppc=ppc, channels=2)
    stim.ctrl = np.repeat(kinds.astype(np.uint64), np.shape(x)[1] * np.shape(x)[2] // ppc)
    return stim, frames_to_beats(arrays["out"], ppc=ppc)


def _to_beats_image(x, g, o, kinds, ppc, fmt):
    """:func:`_to_beats`' stimulus when a coefficient frame (``image_rows`` lines) is
    taller than a pixel frame: each frame's beats in turn."""
    parts = []
    for i, k in enumerate(kinds):
        f = (np.stack([g[i], o[i] & ((1 << fmt.offset_bits) - 1)], axis=-1) if k else
             np.stack([x[i], np.zeros_like(x[i])], axis=-1))
        b = frames_to_beats(f[None], ppc=ppc, channels=2)
        b.ctrl = np.full(len(b), k, np.uint64)
        parts.append(b)
    return Beats(*(np.concatenate([getattr(b, n) for b in parts])
                   for n in ("data", "first", "last", "seg", "ctrl", "rst")))


def _unstream(out, arrays, params):
    rows, cols = np.shape(arrays["x"])[-2:]
    ob = params["out_bits"] or params["pixel_bits"]
    return {"out": out.data.reshape(-1, rows, cols).astype(pixel_dtype(ob))}


def _example(rng, n, shape, params):
    """Random frames of ``shape``, the first a coefficient frame (gain ~ N(1, 0.05), offset
    +-300 codes), the rest pixel frames."""
    fmt, b = _fmt(params), params["pixel_bits"]
    return {"x": rng.integers(0, 1 << b, (n, *shape), dtype=pixel_dtype(b)),
            "gain": fmt.gain_code(rng.normal(1.0, 0.05, (n, *shape))),
            "offset": rng.integers(-300, 300, (n, *shape)),
            "kinds": (np.arange(n) == 0).astype(np.int64)}


def _p(width, rows, **kw):
    return {"width": width, "rows": rows, **kw}


_NARROW = {"pixel_bits": 10, "gain_int_bits": 1, "gain_frac_bits": 7, "offset_bits": 10,
           "offset_frac_bits": 3, "out_bits": 8}
_WIDE = {"pixel_bits": 16, "gain_int_bits": 2, "gain_frac_bits": 14, "offset_bits": 16,
         "offset_frac_bits": 8, "out_bits": 20}


def _cases():
    out = [
        Case("random_24x4_12b", _p(24, 4), _random([1, 0, 0, 1, 0]), seed=1),
        Case("no_coeffs_first_24x4_12b", _p(24, 4), _random([0, 1, 0, 0]), seed=2),
        Case("hard_24x8_12b", _p(24, 8), _hard, seed=3, tags=("saturation", "fullscale",
                                                             "zeros")),
        Case("narrow_24x3", _p(24, 3, **_NARROW), _random([1, 0, 1, 0]), seed=4),
        Case("wide_24x3", _p(24, 3, **_WIDE), _random([1, 0, 1, 0]), seed=5),
        Case("layout_40x3_12b", _p(40, 3, line_stride=64, base=4096), _random([1, 0, 0]),
             seed=6, tags=("layout",)),
        Case("random_512x8_12b", _p(512, 8), _random([1, 0, 0]), seed=7, tags=("fast-only",)),
    ]
    for k, ppc in enumerate(PPC_CHOICES[1:]):
        out += [
            Case(f"random_24x4_12b_p{ppc}", _p(24, 4, ppc=ppc), _random([1, 0, 0, 1, 0]),
                 seed=30 + k),
            Case(f"hard_24x8_12b_p{ppc}", _p(24, 8, ppc=ppc), _hard, seed=40 + k,
                 tags=("saturation", "fullscale", "zeros")),
            Case(f"narrow_{ppc}x4_12b_p{ppc}", _p(ppc, 4, ppc=ppc), _random([1, 0, 1, 0]),
                 seed=50 + k, tags=("narrow",)),
        ]
    # an area camera: frames of one sensor row, each against its own coefficient line
    out += [Case("image_rows_24x1_of_4", _p(24, 1, image_rows=4), _random([1] + [0] * 9),
                 seed=70, tags=("image_rows",)),
            Case("image_rows_16x2_of_6_p4", _p(16, 2, image_rows=6, ppc=4),
                 _random([0, 1, 0, 0, 0, 0, 1, 0, 0]), seed=71, tags=("image_rows",))]
    out.append(Case("gmax0504_row_5144x2_10b_p8", _p(5144, 2, pixel_bits=10, ppc=8),
                    _random([1, 0, 0]), seed=60, tags=("fast-only", "wide")))
    return out


# ---- chain
# in a scene's chain: [pipeline.nuc].memory = "ddr"
def _pipeline_step(ctx):
    """``[pipeline.nuc].memory = "ddr"``: ``nuc``'s coefficient format and NAND part
    (its step's ``device``), the frame's size, the coefficient image at ``ctx.ddr_base``
    (above the reset frame when cds keeps it in the same DDR) with the scene's ``[ddr]``
    stall settings; with ``[pipeline.nuc].coefficients = "frame"`` (an area camera) the
    image has a line per sensor row of the run (``image_rows`` = the chain's lines, each a
    frame of one row)."""
    from tdicam.blocks import nuc as _nuc
    step, bits = _nuc._pipeline_step(ctx)
    params = {**step.params, "width": ctx.width, "rows": ctx.m, "base": ctx.ddr_base,
              **dict(ctx.scene.ddr.stalls)}
    if ctx.scene.pipeline.nuc.coefficients == "frame":
        if ctx.m != 1:
            raise TdicamError(f"[pipeline.nuc].coefficients = \"frame\" is an area camera's: "
                              f"[tdi].stages must be 1, got {ctx.m}")
        params["image_rows"] = ctx.lines
    return Step("nuc_ddr", params, device=step.device), bits


def _pipeline_end(step):
    p = BLOCK.resolve(step.params)
    return coeff_layout(p["width"], line_stride=p["line_stride"],
                        base=p["base"]).end_addr(_image_rows(p))


def _pipeline_golden(step, data):
    """Lane ``lane``'s frames corrected as the top does: its coefficients (as loaded from
    the NAND part when there is one: ``image_rows`` lines) written as one coefficient
    frame before the lane's frames, through the block's golden model."""
    from tdicam.blocks import nuc as _nuc
    p = BLOCK.resolve(step.params)

    def fn(arrays, lane):
        x = np.asarray(arrays[0])
        c = _nuc._pipeline_arrays(step, data, lane)
        shape = (len(x) + 1,) + np.shape(c["gain"])
        xs = np.concatenate([np.zeros((1,) + x.shape[1:], x.dtype), x])
        g = np.broadcast_to(c["gain"], shape)
        o = np.broadcast_to(c["offset"], shape)
        return nuc_ddr_frames(xs, g, o, [1] + [0] * len(x), **{k: p[k] for k in _MODEL_KEYS})
    return fn


def _pipeline_hw(step, data, *, ecp5=False):
    """Every lane's :class:`~tdicam.hdl.nuc_ddr.NucDdr` with its MIG user interface as the
    stage's pins and the coefficient load before its frames (the stage's ``load``): with a
    NAND part (``flash = "nand"``) the lane's :class:`~tdicam.hdl.nand_store.NandCalibStore`
    on the NAND bus at the top's ports (``nuc_ddr_nand_*``, as ``nuc``'s; its one pixel's
    coefficients a beat gathered into ``ppc`` pixels' by :func:`~tdicam.hdl.chain_links.
    widen` at ``ppc`` >= 2), else the
    calibration ROM through :class:`~tdicam.hdl.calib.CalibReader`; the coefficient frame
    goes to DDR once, then every pixel frame reads it. ``nuc_ddr_calib_loaded`` (each lane):
    the frame was handed to the block (the top holds its input until then). For
    co-simulation the stage's devices are the MIG model (and the NAND part). At ``ppc`` >= 2
    a register slice follows the stage (``out_slice``), as :mod:`~tdicam.blocks.cds_ddr`'s:
    hdr's input ready (its frame-start decision) reached through both DDR blocks'
    handshakes into ``cds_ddr``'s launch register in one cycle (the whole Ning et al. 2019
    camera at ppc 8: 84.9 MHz, that path 11.8 ns); at ppc 1 the top is as it was. ``ecp5``
    (the synthesis top): each lane's multipliers MULT18X18D with their own input registers
    (``dsp="ecp5"``)."""
    from amaranth.lib.wiring import Out
    from tdicam.blocks import nuc as _nuc
    from tdicam.hdl.chain_board import mig_device
    from tdicam.hdl.chain_top import LaneStage
    from tdicam.hdl.interfaces.mig import MIG_PORT_NAMES
    from tdicam.model import nand_store
    p = BLOCK.resolve(step.params)
    rows, cols, ppc = _image_rows(p), p["width"], p["ppc"]
    dsp = "ecp5" if ecp5 else "generic"

    def mig(lane):
        return mig_device(_pipeline_end(step) // ADDR_PER_WORD, **stalls_of(p))
    loaded = {"calib_loaded": Out(1)}
    common = dict(pins=MIG_PORT_NAMES, ready="calib_loaded", load="frame_kind",
                  load_rows=rows, waits=True, out_slice=ppc > 1)
    if not step.device:
        side = _nuc._pipeline_side(step, data, ecp5)
        return LaneStage(step.block, lambda lane: _core(p, dsp), side=lambda m, lane, io: side(m, lane),
                         io=loaded, device=mig, startup=rows * cols // ppc + 10_000,
                         **common)
    from tdicam.hdl.chain_links import Link, widen
    geo = dict(page_bytes=step.device["page_bytes"],
               pages_per_block=step.device["pages_per_block"], blocks=step.device["blocks"])

    def side(m, lane, io):
        st, status, bus = _nuc.nand_calib_store(m, f"nuc_ddr_nand{lane}", step, rows, cols,
                                                io)
        m.d.comb += [st.start.eq(1), *status, *bus]
        return widen(m, Link.of_output(st.o_stream), ppc, f"nuc_ddr_widen{lane}")

    t = nand_store.timing(rows, cols, nand_store.Geometry(**geo),
                          busy_cycles=step.device["busy_cycles"])
    return LaneStage(step.block, lambda lane: _core(p, dsp), side=side, io=_nuc.nand_io(),
                     device=lambda lane: [_nuc.nand_device(step, data, lane), mig(lane)],
                     startup=t.scan_cycles + t.load_cycles + rows * cols + 10_000, **common)


def _measured(step, status, info):
    """The co-simulation's NAND load (``nuc``'s figures, of this stage's ports) and each
    channel's shared DDR (its users behind one DdrArbiter: the board's ``ddr_*``
    counters): words written and read, the coefficient frame's share, the stalls."""
    from tdicam.blocks import nuc as _nuc
    p = BLOCK.resolve(step.params)
    out = _nuc.measured_load(step, status, {**info, "rows": _image_rows(p)}, "nuc_ddr")
    words = coeff_layout(p["width"]).words_per_line * _image_rows(p)
    read = coeff_layout(p["width"]).words_per_line * p["rows"]
    k = 0
    while f"ddr_writes{'_%d' % k if k else ''}" in status:
        sfx = f"_{k}" if k else ""
        w, r = status[f"ddr_writes{sfx}"], status[f"ddr_reads{sfx}"]
        stalls = status.get(f"ddr_stalls{sfx}")
        out.append({"name": f"shared DDR traffic, channel {k}", "value": w + r,
                    "unit": "words", "stall_cycles": stalls,
                    "text": f"DDR channel {k}, its users behind one arbiter: {w} words "
                            f"written ({words} of them the coefficient frame), {r} read "
                            f"({read} a pixel frame's coefficients) in {info['cycles']} "
                            f"cycles = {(w + r) / max(info['cycles'], 1):.1%} of the "
                            f"interface's cycles"
                            + (f"; {stalls} cycles waited on the MIG model's stalls"
                               if stalls is not None else "")
                            + (", MIG model ERROR" if status[f"ddr_error{sfx}"] else "")})
        k += 1
    return out


def _system(step, ctx):
    """The plan's NAND load (``nuc``'s :func:`~tdicam.blocks.nuc.nand_load_rows`) of the
    whole coefficient image (``image_rows`` lines)."""
    from tdicam.blocks import nuc as _nuc
    return _nuc.nand_load_rows(step, {**ctx, "rows": _image_rows(BLOCK.resolve(step.params))})


def _pipeline_identity(step, shape):
    """Gain 1, offset 0 for every pixel of every lane (``nuc``'s), the image's
    ``image_rows`` lines."""
    from tdicam.blocks import nuc as _nuc
    p = BLOCK.resolve(step.params)
    return _nuc._pipeline_identity(step, (_image_rows(p),) + tuple(shape[1:]))


# ---- entry
BLOCK = Block(
    name="nuc_ddr",
    summary="per-pixel NUC with the coefficients in DDR (Ning et al. 2019 §4.2-§4.4.4)",
    params=(
        Param("width", 512, "pixels per line", lo=1, hi=1 << 16),
        Param("rows", 16, "lines per frame", lo=1, hi=1 << 16),
        Param("image_rows", None, "lines of the coefficient image, a multiple of rows: pixel "
                                  "frame j after a coefficient frame reads rows lines from "
                                  "line (j mod (image_rows / rows)) * rows (an area camera's "
                                  "sensor row r against coefficient line r); default rows",
              lo=1, hi=1 << 16, implicit_default=True),
        Param("pixel_bits", 12, "input pixel width", lo=8, hi=16),
        Param("gain_int_bits", 2, "integer bits of the unsigned gain", lo=1, hi=4),
        Param("gain_frac_bits", 14, "fraction bits of the gain (1.0 = 2**frac; gain at most "
                                    "16 bits: one DDR slot)", lo=4, hi=15),
        Param("offset_bits", 16, "width of the signed two's-complement offset (one 16-bit "
                                 "DDR slot)", lo=2, hi=16),
        Param("offset_frac_bits", 0, "fraction bits of the offset", lo=0, hi=8),
        Param("out_bits", None, "output width (default: pixel_bits)", lo=8, hi=20),
        PPC_PARAM,
    ) + address_params("address of the coefficient image's line 0") + STALL_PARAMS,
    top=_top,
    ecp5_top=_synth_top,
    cases=_cases,
    check=_check,
    model_version="nuc_ddr-1",
    streams=Streams(
        to_beats=_to_beats,
        stream="x",
        side_inputs=(
            SideInput("gain", "image", "per-pixel unsigned gain code, read on coefficient frames "
                                       "(element 2k of each beat for its pixel k; image_rows "
                                       "rows), stored in DDR"),
            SideInput("offset", "image", "per-pixel signed offset code, read on coefficient "
                                         "frames (element 2k + 1), stored in DDR"),
            SideInput("kinds", "frame", "1 = a coefficient frame (stored in DDR, no output), "
                                        "0 = a pixel frame (corrected with the stored "
                                        "coefficients); on the frame_kind port with every beat"),
        ),
        golden=_golden,
        fit=lambda arrays: dict(zip(("rows", "width"), map(int, np.shape(arrays["x"])[-2:]))),
        unstream=_unstream,
        example=_example,
        frame_beats=lambda p: p["width"] * p["rows"] // p["ppc"],
        small=((3, 24), {"width": 24, "rows": 3}),
    ),
    order=81,
    suite=Suite(sims=("icarus",), fast_stalls=0.2,   # Verilator: the block's own tests
                per_beat=("no_coeffs_first_24x4_12b", "random_24x4_12b_p2")),
    pipeline=Use(_pipeline_step, _pipeline_hw, identity=_pipeline_identity, per_frame=True,
                 chain_golden=_pipeline_golden, memory=Memory(ddr_end=_pipeline_end),
                 measured=_measured, system=_system),   # the NAND load, as nuc's
)
