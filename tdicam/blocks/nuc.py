"""Block ``nuc``: per-pixel gain/offset (non-uniformity) correction (Ning et al. 2019 §4.4.4)."""

from dataclasses import dataclass

import numpy as np

from tdicam.beats import PPC_CHOICES, frames_to_beats, mark_resets
from tdicam.hdl.nuc import Nuc
from tdicam.model.nuc import NucFormat, check_nuc_params, identity_coeffs, nuc
from tdicam.blocks import Bench, Stalls, StreamWork, Suite, SynthRef
from tdicam.blocks._bench import PX, PX_QUICK
from tdicam.blocks import (PPC_PARAM, Block, Case, KeyDoc, Memory, Options, Param, SceneSim,
                           SideInput, Streams, Use, check_width as _check_width)
from tdicam.blocks import _sim
from tdicam.blocks._dsp import model_params, tops
from tdicam.blocks._pipeline import lane_stage
from tdicam.blocks.steps import Frames, RunView, Sim, Step
from tdicam.errors import TdicamError
from tdicam.model import ecc as _ecc, nand_store

__all__ = ["BLOCK", "NucOptions", "cut_frame0", "nand_load_rows"]

# ---- top
_FMT_KEYS = ("gain_int_bits", "gain_frac_bits", "offset_bits", "offset_frac_bits")


_top, _ecp5_top = tops(Nuc)


def _check(params):
    check_nuc_params(**model_params(params))


# ---- cases
def _fmt(params):
    return NucFormat(**{k: params[k] for k in _FMT_KEYS})


def _coeff_dtypes(fmt):
    gdt = np.uint16 if fmt.gain_bits <= 16 else np.uint32
    odt = np.int16 if fmt.offset_bits <= 16 else np.int32
    return gdt, odt


def _arrays(params, x, gain, offset):
    fmt = _fmt(params)
    gdt, odt = _coeff_dtypes(fmt)
    x = np.asarray(x).astype(np.uint16 if params["pixel_bits"] <= 16 else np.uint32)
    gain, offset = np.asarray(gain).astype(gdt), np.asarray(offset).astype(odt)
    return {"x": x, "gain": gain, "offset": offset,
            "out": nuc(x, gain, offset, **model_params(params))}


def _random(frames, rows, cols):
    """Calibration-like coefficients (gain 0.5..2, offset +-1/16 full scale) in most pixels,
    any code at all in every 7th pixel."""
    def make(params, rng):
        fmt, pb = _fmt(params), params["pixel_bits"]
        shape = (frames, rows, cols)
        x = rng.integers(0, 1 << pb, shape)
        gain = fmt.gain_code(rng.uniform(0.5, 2.0, shape))
        span = 1 << (pb - 4)
        offset = fmt.offset_code(rng.uniform(-span, span, shape))
        wild = rng.random(shape) < 1 / 7
        gain = np.where(wild, rng.integers(0, fmt.gain_max + 1, shape), gain)
        offset = np.where(wild, rng.integers(fmt.offset_min, fmt.offset_max + 1, shape), offset)
        return _arrays(params, x, gain, offset)
    return make


def _identity(params, rng):
    """Default coefficients (gain 1.0, offset 0): output equals input exactly, including 0 and
    full scale."""
    pb = params["pixel_bits"]
    x = rng.integers(0, 1 << pb, (2, 8, 16))
    x[0, 0, :4] = [0, 1, (1 << pb) - 2, (1 << pb) - 1]
    gain, offset = identity_coeffs(x.shape, _fmt(params))
    return _arrays(params, x, gain, offset)


def _saturate(params, rng):
    """Every combination of extreme x (0, 1, mid, full-1, full), gain (0, 1 LSB, 1.0, max-1,
    max) and offset (min, min+1, -1, 0, 1, max-1, max): saturates at both ends, never wraps."""
    fmt, pb = _fmt(params), params["pixel_bits"]
    full = (1 << pb) - 1
    xs = [0, 1, full // 2, full - 1, full]
    gs = [0, 1, fmt.gain_one, fmt.gain_max - 1, fmt.gain_max]
    os_ = [fmt.offset_min, fmt.offset_min + 1, -1, 0, 1, fmt.offset_max - 1, fmt.offset_max]
    grid = np.array(np.meshgrid(xs, gs, os_, indexing="ij")).reshape(3, -1)  # 175 pixels
    n = grid.shape[1]
    cols = 25
    rows = -(-n // cols)
    pad = rows * cols - n
    x, g, o = (np.concatenate([grid[k], np.full(pad, v)]).reshape(1, rows, cols)
               for k, v in ((0, full), (1, fmt.gain_max), (2, fmt.offset_max)))
    return _arrays(params, x, g, o)


def cut_frame0(stim, exp, frame_beats, cut):
    """Keep beats ``[0, cut)`` of frame 0, drop the rest of it, reset before the next frame.

    ``stim``/``exp`` hold whole frames of ``frame_beats`` beats each (one output beat per input
    beat); the result models a reset mid-frame followed by clean frames.
    """
    keep = np.ones(len(stim), bool)
    keep[cut:frame_beats] = False
    stim, exp = stim.select(keep), exp.select(keep)
    mark_resets(stim, exp, [cut])
    return stim, exp


def _reset_mid_frame(params, rng):
    """Frame 0 is cut by a reset after ``cut`` pixels; frames 1 and 2 follow clean."""
    out = _random(3, 10, 16)(params, rng)
    out["reset_before"] = np.array([77], np.int64)
    return out


def _golden(arrays, params):
    return {"out": nuc(arrays["x"], arrays["gain"], arrays["offset"], **model_params(params))}


def _example(rng, n, shape, params):
    """Sensor-like input: gain ~ N(1, 0.05), offset +-300 codes."""
    fmt, full = _fmt(params), (1 << params["pixel_bits"]) - 1
    shape = (n, *shape)
    gdt, odt = _coeff_dtypes(fmt)
    return {"x": rng.integers(0, full + 1, shape, dtype=np.uint16),
            "gain": fmt.gain_code(rng.normal(1.0, 0.05, shape)).astype(gdt),
            "offset": rng.integers(-300, 300, shape).astype(odt)}


def _to_beats(arrays, params):
    """``ppc`` pixels per beat, pixel-major (x, gain, offset) triples; ``reset_before``
    counts stimulus beats of frame 0. The frame width must be a multiple of ``ppc``."""
    ppc = params["ppc"]
    _check_width(np.shape(arrays["x"])[-1], ppc)
    elems = _fmt(params).stream_elements(arrays["x"], arrays["gain"], arrays["offset"])
    stim = frames_to_beats(elems, ppc=ppc, channels=3)
    exp = frames_to_beats(arrays["out"], ppc=ppc)
    if "reset_before" in arrays:
        frame_beats = arrays["x"][0].size // ppc
        stim, exp = cut_frame0(stim, exp, frame_beats, int(arrays["reset_before"][0]))
    return stim, exp


def _reset_beats(params, rng):
    """Frame 0 (10 x 16) is cut by a reset in the middle of a row, after beat ``cut`` =
    4 rows and a half of ``16 / ppc`` beats (rounded up); frames 1 and 2 follow clean."""
    out = _random(3, 10, 16)(params, rng)
    wb = 16 // params["ppc"]
    out["reset_before"] = np.array([4 * wb + (wb + 1) // 2], np.int64)
    return out


def _saturate_wide(params, rng):
    """:func:`_saturate`'s 175 extreme combinations on 8 x 24 frames (a width every ``ppc``
    divides; the rest of the last row repeats the largest codes)."""
    a = _saturate(params, rng)
    n = 175
    rows = -(-n // 24)
    def pad(v, fill):
        flat = np.concatenate([v.ravel()[:n], np.full(rows * 24 - n, fill, v.dtype)])
        return flat.reshape(1, rows, 24)
    fmt, full = _fmt(params), (1 << params["pixel_bits"]) - 1
    return _arrays(params, pad(a["x"], full), pad(a["gain"], fmt.gain_max),
                   pad(a["offset"], fmt.offset_max))


def _ppc_cases():
    """The cases at ppc 2, 4 and 8: random, identity (16-bit at ppc 8), saturation, a reset
    mid-row, the smallest width (one beat per row); the wide and narrow formats at ppc 8."""
    out = []
    for k, ppc in enumerate(PPC_CHOICES[1:]):
        p = {"ppc": ppc}
        bits = 16 if ppc == 8 else 12      # (one parameter set, one build, at ppc 2 and 4)
        out += [
            Case(f"random_12b_p{ppc}", p, _random(3, 16, 24), seed=20 + k),
            Case(f"identity_{bits}b_p{ppc}", {"pixel_bits": bits, "ppc": ppc}, _identity,
                 seed=30 + k, tags=("identity", "zeros", "fullscale")),
            Case(f"saturate_12b_p{ppc}", p, _saturate_wide, seed=40 + k,
                 tags=("saturation", "fullscale", "zeros")),
            Case(f"reset_mid_frame_12b_p{ppc}", p, _reset_beats, seed=50 + k,
                 tags=("reset",)),
            Case(f"narrow_12b_p{ppc}", p, _random(3, 5, ppc), seed=60 + k,
                 tags=("narrow",)),
        ]
    out += [
        Case("saturate_wide_p8", {**_WIDE, "ppc": 8}, _saturate_wide, seed=70,
             tags=("saturation", "fullscale")),
        Case("random_narrow_p8", {**_NARROW, "ppc": 8}, _random(2, 12, 24), seed=71),
    ]
    return out


# ---- scene
_WIDE = {"pixel_bits": 16, "gain_int_bits": 2, "gain_frac_bits": 16, "offset_bits": 18,
         "offset_frac_bits": 8, "out_bits": 20}
_NARROW = {"pixel_bits": 10, "gain_int_bits": 1, "gain_frac_bits": 7, "offset_bits": 10,
           "offset_frac_bits": 2, "out_bits": 8}


@dataclass(frozen=True)
class NucOptions:
    """``[pipeline.nuc]``: fractional bits of the fixed-point gain, the 64/72 ECC path,
    where the coefficients are stored (``flash``: ``none`` or ``nand``, with its faults) and
    where the gateware keeps them while it runs (``memory``: :data:`NUC_MEMORY`)."""

    gain_frac_bits: int = 12
    ecc: bool = True
    flash: str = "none"
    bad_blocks: int = 0
    flip_single: float = 0.0
    flip_double: float = 0.0
    seed: int = 1
    memory: str = "chip"


#: ``[pipeline.nuc].memory``: where the gateware keeps the coefficients while it runs.
NUC_MEMORY = ("chip", "ddr")

#: ``[pipeline.nuc]`` keys of the NAND flash store (only with ``flash = "nand"``).
_NAND_KEYS = ("bad_blocks", "flip_single", "flip_double", "seed")


def _read_options(sec, sensor):
    frac = sec.integer("gain_frac_bits", 12, lo=4, hi=16)
    ecc = sec.boolean("ecc", True)
    flash = sec.choice("flash", "none", ("none", "nand"))
    memory = sec.choice("memory", "chip", NUC_MEMORY)
    if memory == "ddr" and frac > 14:
        sec.fail("gain_frac_bits", f"must be <= 14 with memory = \"ddr\" (2 + {frac} bits "
                                   "do not fit a 16-bit DDR slot)")
    if flash == "none":
        for k in _NAND_KEYS:
            if sec.has(k):
                sec.fail(k, "is a NAND flash fault: set flash = \"nand\" to use it")
        return NucOptions(gain_frac_bits=frac, ecc=ecc, memory=memory)
    if not ecc:
        sec.fail("ecc", "must be true with flash = \"nand\" (the flash words are 64/72 ECC)")
    if frac > 14:
        sec.fail("gain_frac_bits", f"must be <= 14 with flash = \"nand\" (2 + {frac} bits "
                                   "do not fit the 16-bit gain of a flash word)")
    single = sec.number("flip_single", 0.0, lo=0.0, hi=1.0)
    double = sec.number("flip_double", 0.0, lo=0.0, hi=1.0)
    if single + double > 1.0:
        sec.fail("flip_double", f"flip_single + flip_double must be <= 1 (probabilities of "
                                f"one word), got {single:g} + {double:g}")
    return NucOptions(gain_frac_bits=frac, ecc=ecc, flash=flash,
                      bad_blocks=sec.integer("bad_blocks", 0, lo=0, hi=4095),
                      flip_single=single, flip_double=double,
                      seed=sec.integer("seed", 1, lo=0), memory=memory)


OPTIONS = Options(
    NucOptions, _read_options,
    "Per-pixel gain/offset (non-uniformity) correction. The NAND keys (bad_blocks, "
    "flip_single, flip_double, seed) only with flash = \"nand\", which also needs ecc = true "
    "and gain_frac_bits <= 14 (16-bit gain words).",
    {"gain_frac_bits": KeyDoc("bit", "fractional bits of the fixed-point gain"),
     "ecc": KeyDoc("", "the coefficients pass a 64/72 SECDED round trip"),
     "flash": KeyDoc("", "none, or nand: store the coefficients in a 4 Gb NAND flash "
                         "(bad-block scan, block map, 64/72 ECC pages) and load them back "
                         "as the camera does at power-up; an uncorrectable word gets the "
                         "default coefficients (gain 1, offset 0)"),
     "bad_blocks": KeyDoc("", "nand: random factory bad blocks (never block 0)"),
     "flip_single": KeyDoc("probability", "nand: that a coefficient word has one flipped "
                                          "bit (corrected)"),
     "flip_double": KeyDoc("probability", "nand: that a coefficient word has two flipped "
                                          "bits (uncorrectable); flip_single + "
                                          "flip_double <= 1"),
     "seed": KeyDoc("", "nand: seed of the faults' random numbers (channel k of a "
                        "dual-gain sensor uses seed + k)"),
     "memory": KeyDoc("", "chip: the gateware keeps the coefficients on chip (a ROM, or "
                          "with flash = nand the buffer the power-up load fills); ddr: the "
                          "power-up load writes them to the DDR of [ddr] as one coefficient "
                          "frame and every pixel frame reads them back line by line (block "
                          "nuc_ddr, Ning et al. 2019 §4.2-§4.4.4: a full frame's "
                          "coefficients do not fit on chip); gain_frac_bits <= 14 (a 16-bit "
                          "slot)")},
    probe={"flash": "nand"})


# ---- chain
#: The NAND part's R/B# busy time after a page read in co-simulation, clocks (the
#: ``nand_store`` block's simulation default; the real t_R, 25 us, is 2,500 clocks at
#: 100 MHz: :func:`tdicam.model.nand_store.timing` gives the load time at it).
NAND_SIM_BUSY = 16


def _pipeline_step(ctx):
    """``[pipeline.nuc]``: the coefficient format; with ``flash = "nand"`` the part's
    geometry (the 4 Gb MT29F4G08), faults and seed in the step's ``device``."""
    opt = ctx.scene.pipeline.nuc
    device = {}
    if opt.flash == "nand":
        g = nand_store.MT29F4G08
        device = {"bad_blocks": opt.bad_blocks, "flip_single": opt.flip_single,
                  "flip_double": opt.flip_double, "seed": opt.seed, "blocks": g.blocks,
                  "pages_per_block": g.pages_per_block, "page_bytes": g.page_bytes,
                  "busy_cycles": NAND_SIM_BUSY}
    return Step("nuc", {"pixel_bits": ctx.bits, "gain_int_bits": 2,
                        "gain_frac_bits": opt.gain_frac_bits, "offset_bits": 16,
                        "offset_frac_bits": 0}, device=device), ctx.bits


def nand_geometry(device):
    """The :class:`~tdicam.model.nand_store.Geometry` of a step's ``device`` settings."""
    return nand_store.Geometry(page_bytes=device["page_bytes"],
                               pages_per_block=device["pages_per_block"], blocks=device["blocks"])


def nand_part(step, gain, offset, lane):
    """The NAND part holding lane ``lane``'s coefficient codes as the step's ``device``
    says (faults seeded ``seed + lane``, as the scene simulator's channel ``lane``):
    (:class:`~tdicam.model.nand_store.NandDevice`, what the camera loads from it,
    :class:`~tdicam.model.nand_store.StoreResult`)."""
    d = step.device
    fmt = _fmt(step.params)
    g2, o2 = (np.asarray(a, np.int64).reshape(-1, np.shape(a)[-1]) for a in (gain, offset))
    try:
        dev = nand_store.store_device(g2, o2, fmt, geometry=nand_geometry(d),
                                      bad_blocks=d["bad_blocks"], p_single=d["flip_single"],
                                      p_double=d["flip_double"], seed=d["seed"] + lane)
    except TdicamError as exc:
        raise TdicamError(f"[pipeline.nuc] flash = 'nand', bad_blocks = {d['bad_blocks']}: "
                          f"{exc}") from None
    return dev, nand_store.read_store(dev)


def _pipeline_side(step, data, ecp5=False):
    """Per lane: the lane's calibration image in a ROM, read through CalibReader (``ppc``
    coefficient pairs a beat, the ROM ``ppc / 2`` flash words a beat); ``ecp5``: the ROM's
    banks as DP16KD primitives with their output register (the ECP5 synthesis top)."""
    from tdicam.hdl.calib import CalibReader
    from tdicam.hdl.calib_rom import CalibRom
    from tdicam.hdl.chain_links import Link
    from tdicam.model.calib import encode_image
    fmt = _fmt(step.params)
    ppc = step.params.get("ppc", 1)

    def side(m, lane):
        gain, offset = data.coeffs[lane]
        rd = CalibReader(rows=gain.shape[0], cols=gain.shape[1], ppc=ppc, **fmt.params())
        rom = CalibRom(encode_image(gain, offset, fmt), per_beat=rd.words_per_beat,
                       bram="ecp5" if ecp5 else "generic")
        m.submodules[f"nuc_calib_rom{lane}"] = rom
        m.submodules[f"nuc_calib{lane}"] = rd
        m.d.comb += [rd.i_stream.valid.eq(rom.o_stream.valid),
                     rom.o_stream.ready.eq(rd.i_stream.ready),
                     rd.i_stream.payload.eq(rom.o_stream.payload)]
        return Link.of_output(rd.o_stream)
    return side


def _pipeline_arrays(step, data, lane):
    """The lane's coefficients; with a NAND part, as the camera loads them from it
    (defaults where a word is uncorrectable)."""
    gain, offset = data.coeffs[lane]
    if step.device:
        res = nand_part(step, gain, offset, lane)[1]
        gain = res.image.gain.reshape(np.shape(gain))
        offset = res.image.offset.reshape(np.shape(offset))
    return {"gain": gain, "offset": offset}


def nand_load_rows(step, ctx):
    """The plan: the calibration load before the first frame, each channel's part loaded
    in parallel (:func:`tdicam.model.nand_store.timing` at the part's t_R and the
    controller's clock: the bad-block scan of every block, then the image's pages)."""
    if not step.device:
        return []
    t = nand_store.timing(ctx["rows"], ctx["width"], nand_geometry(step.device))
    total = t.scan_s + t.load_s
    return [{"name": "calibration load", "value": total, "unit": "s", "ok": None,
             "scan_s": t.scan_s, "load_s": t.load_s, "pages": t.pages,
             "text": f"NUC calibration from NAND before the first frame: {total * 1e3:.1f} ms "
                     f"= bad-block scan {t.scan_s * 1e3:.1f} ms ({nand_geometry(step.device).blocks} "
                     f"blocks, t_R {nand_geometry(step.device).t_r_s * 1e6:g} us) + load "
                     f"{t.load_s * 1e3:.2f} ms ({t.pages} page(s) of the {ctx['rows']} x "
                     f"{ctx['width']} image) at the controller's {t.clock_hz / 1e6:g} MHz; "
                     f"{ctx['lanes']} part(s), one a channel, in parallel"}]


def measured_load(step, status, info, stage="nuc"):
    """The co-simulation's calibration load: per channel the bad blocks the scan found, the
    corrected and uncorrectable words, the load's state; the cycles the top held the frames
    (``startup_cycles``: the scan and the read at the simulation's t_R of ``busy_cycles``
    clocks) beside the model's cycles (``info``: ``rows`` and ``width`` of the image);
    ``stage``: the stage whose status ports they are (``nuc_ddr``'s load, the same)."""
    if not step.device:
        return []
    out = []
    k = 0
    while f"{stage}_calib_loaded{'_%d' % k if k else ''}" in status:
        sfx = f"_{k}" if k else ""
        out.append({"name": f"calibration load, channel {k}",
                    "value": status[f"{stage}_bad_blocks{sfx}"], "unit": "bad blocks",
                    "text": f"NUC calibration channel {k}: "
                            f"{'loaded' if status[f'{stage}_calib_loaded{sfx}'] else 'NOT loaded'}"
                            f"{', store ERROR' if status[f'{stage}_calib_error{sfx}'] else ''}; "
                            f"{status[f'{stage}_bad_blocks{sfx}']} bad blocks, "
                            f"{status[f'{stage}_corrected_words{sfx}']} corrected and "
                            f"{status[f'{stage}_uncorrectable_words{sfx}']} uncorrectable words"})
        k += 1
    if "startup_cycles" in status:
        busy = step.device["busy_cycles"]
        t = nand_store.timing(info["rows"], info["width"], nand_geometry(step.device),
                              busy_cycles=busy)
        out.append({"name": "start-up cycles", "value": status["startup_cycles"],
                    "unit": "cycles", "model_cycles": t.scan_cycles + t.load_cycles,
                    "text": f"frames held {status['startup_cycles']} cycles after reset until "
                            f"the calibration was loaded (the bad-block scan and the read: "
                            f"{t.scan_cycles} + {t.load_cycles} cycles by the model at the "
                            f"simulation's t_R of {busy} clocks; tdicam plan gives the time at "
                            f"the part's real t_R)"})
    return out


def _measured(step, status, info):
    return measured_load(step, status, info)


#: The NAND bus pins at the top (the controller's side, :data:`tdicam.hdl.nand_store.BUS_PORTS`)
#: and the calibration status outputs, per lane.
def nand_io(count_bits=None):
    from amaranth.lib.wiring import In, Out
    from tdicam.model import calib as _calib
    count_bits = _calib.DEFAULT_COUNT_BITS if count_bits is None else count_bits
    from tdicam.hdl.nand_store import BUS_PORTS
    io = {name: (Out(w) if d == "out" else In(w)) for name, w, d in BUS_PORTS}
    io.update({"calib_loaded": Out(1), "bad_blocks": Out(16),
               "corrected_words": Out(count_bits), "uncorrectable_words": Out(count_bits),
               "calib_error": Out(1)})
    return io


def _pipeline_hw(step, data, *, ecp5=False):
    """The ROM stage (:func:`_pipeline_side`), or with a NAND part (``flash = "nand"``)
    the camera's power-up load: per lane a :class:`~tdicam.hdl.nand_store.NandCalibStore`
    (bad-block scan, block map, pages through :class:`~tdicam.hdl.calib.CalibReader`)
    on the NAND bus at the top's ports (``nuc_nand_*``), its coefficients kept in a
    :class:`~tdicam.hdl.calib.CoeffBuffer` and replayed every frame. The top holds its
    input until every lane's ``nuc_calib_loaded``; ``nuc_bad_blocks``,
    ``nuc_corrected_words``, ``nuc_uncorrectable_words`` and ``nuc_calib_error`` (the
    store ran out of good blocks, or the image's header is bad) say what the load saw.
    For co-simulation the part itself (:class:`~tdicam.hdl.nand_store.NandPart`, the
    lane's image with its faults) is the stage's device, outside the top.

    At ``ppc`` >= 2 a register slice follows the stage (``out_slice``): without it the
    next block's ready reached the coefficient reader's clock enables through the join of
    pixels and coefficients in one cycle (the orbit chain at ppc 8: 128.8 MHz, that path
    7.8 ns); at ppc 1 the top is as it always was."""
    from dataclasses import replace
    cut = step.params.get("ppc", 1) > 1
    if not step.device:
        return lane_stage(side=lambda s, dt: _pipeline_side(s, dt, ecp5),
                          out_slice=cut)(step, data, ecp5=ecp5)
    from tdicam.hdl.calib import CoeffBuffer
    from tdicam.hdl.chain_links import Link
    d = step.device
    ppc = step.params.get("ppc", 1)
    rows, cols = np.shape(data.coeffs[0][0])
    geo = dict(page_bytes=d["page_bytes"], pages_per_block=d["pages_per_block"],
               blocks=d["blocks"])

    def side(m, lane, io):
        st, status, bus = nand_calib_store(m, f"nuc_nand{lane}", step, rows, cols, io)
        buf = CoeffBuffer(rows=rows, cols=cols, elem_bits=st.reader.elem_bits, ppc=ppc)
        m.submodules[f"nuc_coeffs{lane}"] = buf
        m.d.comb += [st.start.eq(1), buf.i_stream.valid.eq(st.o_stream.valid),
                     st.o_stream.ready.eq(buf.i_stream.ready),
                     buf.i_stream.payload.eq(st.o_stream.payload),
                     io["calib_loaded"].eq(buf.loaded), *status]
        m.d.comb += bus
        return Link.of_output(buf.o_stream)

    t = nand_store.timing(rows, cols, nand_store.Geometry(**geo), busy_cycles=d["busy_cycles"])
    bound = t.scan_cycles + t.load_cycles + 10_000
    stage = lane_stage(side=lambda s, dt: side, out_slice=cut)(step, data, ecp5=ecp5)
    return replace(stage, io=nand_io(), ready="calib_loaded",
                   device=lambda lane: nand_device(step, data, lane), startup=bound)


def nand_calib_store(m, name, step, rows, cols, io):
    """A :class:`~tdicam.hdl.nand_store.NandCalibStore` (submodule ``name``) of the step's
    part and format for a ``rows`` x ``cols`` image, and the statements that wire it to a
    lane's load status ports and NAND bus ``io`` (:func:`nand_io`, all but
    ``calib_loaded``): ``(store, status, bus)``; the caller starts it."""
    from tdicam.hdl.nand_store import BUS_PORTS, NandCalibStore
    d = step.device
    st = NandCalibStore(rows=rows, cols=cols, **_fmt(step.params).params(),
                        page_bytes=d["page_bytes"], pages_per_block=d["pages_per_block"],
                        blocks=d["blocks"])
    m.submodules[name] = st
    status = [io["bad_blocks"].eq(st.bad_blocks),
              io["corrected_words"].eq(st.corrected_count),
              io["uncorrectable_words"].eq(st.uncorrectable_count),
              io["calib_error"].eq(st.error | st.header_error)]
    bus = [io[pin].eq(getattr(st, pin)) if dr == "out" else getattr(st, pin).eq(io[pin])
           for pin, _, dr in BUS_PORTS]
    return st, status, bus


def nand_device(step, data, lane):
    """The co-simulation's NAND part of lane ``lane`` (its image with the step's faults) on
    the stage's NAND bus pins (``nand_*``, :func:`nand_io`)."""
    from tdicam.hdl.chain_board import Device
    from tdicam.hdl.nand_store import NandPart
    d = step.device
    part, _ = nand_part(step, *data.coeffs[lane], lane)
    model = NandPart(part, busy_cycles=d["busy_cycles"], page_bytes=d["page_bytes"],
                     pages_per_block=d["pages_per_block"], blocks=d["blocks"])
    pins = {"nand_cle": "cle", "nand_ale": "ale", "nand_we_n": "we_n", "nand_re_n": "re_n",
            "nand_dq_o": "dq_in", "nand_dq_i": "dq_out", "nand_rb_n": "rb_n"}
    return Device(model, pins)


def _pipeline_identity(step, shape):
    """Gain 1, offset 0 for every pixel of every lane."""
    return {"coeffs": identity_coeffs(shape, _fmt(step.params))}


# ---- simulator
def _sim_format(c: RunView):
    """The coefficients' :class:`~tdicam.model.nuc.NucFormat` in run context ``c``."""
    return _fmt(_sim.step(c, BLOCK, c.sensor.bits, c.sensor.columns).params)


def _sim_step(c: RunView, fr: Frames):
    """Golden nuc of every channel with the ideal coefficients (``c.prepared["coeffs"]``),
    through the ECC round trip or the NAND store when ``[pipeline.nuc]`` says so."""
    fmt = _sim_format(c)
    bits = c.sensor.bits
    for ch, x in enumerate(fr.channels):
        gain_c, off_c = c.prepared["coeffs"][ch]
        if c.scene.pipeline.nuc.flash == "nand":
            gain_c, off_c = _nand_roundtrip(c, ch, fmt, gain_c, off_c)
        elif c.scene.pipeline.nuc.ecc:
            gain_c, off_c = _ecc_roundtrip(fmt, gain_c, off_c)
        g = np.broadcast_to(gain_c, x.shape)
        o = np.broadcast_to(off_c, x.shape)
        p = _sim.step(c, BLOCK, bits, x.shape[-1]).params
        y = _sim.golden(BLOCK, {"x": x, "gain": g, "offset": o}, p)
        if fr.keep is not None and ch == 0:
            fr.crop[BLOCK.name] = {"x": fr.keep(x), "gain": fr.keep(np.ascontiguousarray(g)),
                                   "offset": fr.keep(np.ascontiguousarray(o)),
                                   "out": fr.keep(y), "params": p}
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
    try:
        g, off, res = nand_store.store_roundtrip(g2, o2, fmt, bad_blocks=o.bad_blocks,
                                                 p_single=o.flip_single, p_double=o.flip_double,
                                                 seed=o.seed + ch)
    except TdicamError as exc:
        raise TdicamError(f"[pipeline.nuc] flash = 'nand', bad_blocks = {o.bad_blocks}: "
                          f"{exc}") from None
    if ch not in c.flash:
        img = res.image
        c.flash[ch] = {"channel": ch, "pixels": int(g2.size), "words": int(res.words),
                       "pages": int(res.pages), "bad_blocks": int(res.scan.bad_count),
                       "corrected_words": int(img.corrected),
                       "uncorrectable_words": int(img.uncorrectable),
                       "defaulted_pixels": int(np.count_nonzero(img.defaulted))}
    return g.reshape(shape), off.reshape(shape)


def _sim_coeffs(c: RunView, gain_map, dark_map):
    """Per-channel (gain, offset) codes that map each pixel onto the mean response, as the
    scene data's ``coeffs``.

    Pixel response (DN, before quantization): ``y = a/c (S (1+P) + d) + B``; the corrected
    target is ``a/c (S + mean d) + B``. Least squares over signal levels gives exactly
    ``gain = 1/(1+P)`` and ``offset = B + a/c mean(d) - gain (B + a/c d)``.
    """
    fmt = _sim_format(c)
    out = []
    base = c.zero_dn
    for g in c.gains:
        k = g / c.sensor.conversion_gain_e_per_dn
        gr = 1.0 / np.maximum(gain_map, 1e-6)
        off = base + k * dark_map.mean() - gr * (base + k * dark_map)
        out.append((fmt.gain_code(gr), fmt.offset_code(off)))
    return {"coeffs": out}


def _sim_notes(c: RunView):
    """The run's notes on the coefficients loaded from NAND flash (``c.flash``)."""
    return [f"nuc coefficients of channel {f['channel']} loaded from NAND flash: "
            f"{f['bad_blocks']} bad blocks, {f['corrected_words']} corrected and "
            f"{f['uncorrectable_words']} uncorrectable words of {f['words']}, "
            f"{f['defaulted_pixels']} of {f['pixels']} pixels on the default "
            f"coefficients (gain 1, offset 0)" for f in (c.flash[k] for k in sorted(c.flash))]


#: The block in the scene simulator.
SIM = SceneSim((Sim("block nuc (golden model)", _sim_step, per_exposure=True,
                    prepare=_sim_coeffs, notes=_sim_notes),),
               scratch_bytes=38.0)


# ---- entry
BLOCK = Block(
    name="nuc",
    summary="per-pixel correction y = gain*x + offset, round half up, saturated (Ning et al. 2019 §4.4.4)",
    params=(
        Param("pixel_bits", 12, "input pixel width", lo=8, hi=16),
        Param("gain_int_bits", 2, "integer bits of the unsigned gain", lo=1, hi=4),
        Param("gain_frac_bits", 14, "fraction bits of the gain (1.0 = 2**frac)", lo=4, hi=16),
        Param("offset_bits", 16, "width of the signed two's-complement offset", lo=2, hi=18),
        Param("offset_frac_bits", 0, "fraction bits of the offset", lo=0, hi=8),
        Param("out_bits", None, "output width (default: pixel_bits)", lo=8, hi=20),
        PPC_PARAM,
    ),
    top=_top,
    ecp5_top=_ecp5_top,
    cases=lambda: [
        Case("random_12b", {}, _random(3, 16, 24), seed=1),
        Case("identity_12b", {}, _identity, seed=2, tags=("identity", "zeros", "fullscale")),
        Case("identity_16b", {"pixel_bits": 16}, _identity, seed=3,
             tags=("identity", "zeros", "fullscale")),
        Case("saturate_12b", {}, _saturate, seed=4, tags=("saturation", "fullscale", "zeros")),
        Case("saturate_wide", _WIDE, _saturate, seed=5, tags=("saturation", "fullscale")),
        Case("saturate_narrow", _NARROW, _saturate, seed=6, tags=("saturation", "fullscale")),
        Case("random_wide", _WIDE, _random(2, 12, 20), seed=7),
        Case("random_narrow", _NARROW, _random(2, 12, 20), seed=8),
        Case("reset_mid_frame_12b", {}, _reset_mid_frame, seed=10, tags=("reset",)),
        *_ppc_cases(),
    ],
    check=_check,
    model_version="nuc-1",
    streams=Streams(
        to_beats=_to_beats,
        stream="x",
        side_inputs=(
            SideInput("gain", "pixel", "per-pixel unsigned gain code (gain_int_bits."
                      "gain_frac_bits), element 3k + 1 of each input beat for its pixel k (x: 3k); "
                      "in the camera read from "
                      "the ECC-protected calibration image (block calib)"),
            SideInput("offset", "pixel", "per-pixel signed offset code (offset_bits, "
                      "offset_frac_bits), element 3k + 2 of each input beat"),
        ),
        golden=_golden,
        example=_example,
        small=((4, 40), {}),
    ),
    pipeline=Use(_pipeline_step, _pipeline_hw, side=_pipeline_arrays, system=nand_load_rows,
                 measured=_measured,
                 identity=_pipeline_identity, per_frame=True, rank=2, options=OPTIONS,
                 memory=Memory(holds="coefficients",
                               placement=lambda scene: scene.pipeline.nuc.memory,
                               spill="nuc_ddr", caller_places=False),
                 sim=SIM),
    order=30,
    bench=Bench("nuc", StreamWork("nuc", "nuc", {}, "pixel",
                                  "frames of 1280 x 4, 12-bit, gain Q2.14", (4, 1280), PX,
                                  PX_QUICK)),
    synth=(SynthRef("nuc", {"pixel_bits": 12}, note="12 bit, gain u2.14, offset s16"),),
    suite=Suite(stalls=Stalls("random_12b", full_rate=("random_12b_p2", "random_12b_p4",
                                                      "random_12b_p8"))),
)
