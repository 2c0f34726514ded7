"""Block ``cds_ddr``: digital CDS with the reset frame in DDR (Ning et al. 2019 §4.4.1, §4.2;
:class:`~tdicam.hdl.cds_ddr.CdsDdr`).

Reset frames (``kinds`` 1) are stored in DDR and give no output; each signal frame
(``kinds`` 0) is output as signal - stored reset, clamped at 0 (golden
:func:`~tdicam.model.cds_ddr.cds_ddr_frames`). ``frame_kind`` rides with each beat. The
Verilog top has the simulation MIG model behind it (:mod:`tdicam.blocks._ddr`).
"""

import numpy as np

from tdicam.beats import PPC_CHOICES, Beats, frames_to_beats, mark_resets
from tdicam.model.cds import pixel_dtype
from tdicam.errors import TdicamError
from tdicam.model.cds_ddr import cds_ddr_frames
from tdicam.model.ddr import ADDR_PER_WORD, LineLayout, check_capacity
from tdicam.blocks import (PPC_PARAM, Bench, Block, Case, Memory, Param, SideInput, StreamWork,
                           Streams, Suite, Use, check_width)
from tdicam.blocks.steps import Step
from tdicam.hdl.cds_ddr import CdsDdr, default_pixels_per_word
from tdicam.blocks._ddr import (STALL_PARAMS, address_params, check_base, check_stalls, sim_top,
                                stalls_of)

__all__ = ["BLOCK", "cds_arrays", "cds_to_beats"]


# ---- top
def _layout(p):
    ppw = default_pixels_per_word(p["pixel_bits"], p["ppc"], p["pixels_per_word"])
    return LineLayout(width=p["width"], pixel_bits=p["pixel_bits"], pixels_per_word=ppw,
                      line_stride=p["line_stride"], base=p["base"])


def _check(p):
    check_stalls(p)
    check_width(p["width"], p["ppc"])
    check_capacity(_layout(p), p["rows"], p["capacity_mib"] << 20, "reset frame")


def _core(p):
    return CdsDdr(width=p["width"], rows=p["rows"], pixel_bits=p["pixel_bits"],
                  pixels_per_word=p["pixels_per_word"], line_stride=p["line_stride"],
                  base=p["base"], capacity_bytes=p["capacity_mib"] << 20, ppc=p["ppc"])


def _top(**p):
    core = _core(p)
    return sim_top(core, core.layout.end_addr(p["rows"]) // ADDR_PER_WORD, stalls_of(p))


def _synth_top(**p):
    """What ``tdicam synth`` places: the core with its MIG user interface at the ports (the
    DDR3 controller's side; the memory model of :func:`_top` is simulation only)."""
    from tdicam.hdl.interfaces.axis import AxisTop
    return AxisTop(_core(p))


# ---- cases
def cds_arrays(frames, kinds, params):
    frames = np.asarray(frames)
    kinds = np.asarray(kinds, np.int64)
    return {"frames": frames, "kinds": kinds,
            "out": cds_ddr_frames(frames, kinds, pixel_bits=params["pixel_bits"])}


def _random(kinds):
    def make(params, rng):
        b = params["pixel_bits"]
        fr = rng.integers(0, 1 << b, (len(kinds), params["rows"], params["width"]))
        return cds_arrays(fr.astype(pixel_dtype(b)), kinds, params)
    return make


def _hard(params, rng):
    """Zeros, full scale, reset > signal everywhere, reset == signal, then a random reset."""
    b = params["pixel_bits"]
    full = (1 << b) - 1
    shape = (params["rows"], params["width"])
    r = rng.integers(1, full + 1, shape)
    seq = [(np.zeros(shape), 1), (np.full(shape, full), 0), (np.full(shape, full), 1),
           (np.zeros(shape), 0), (np.full(shape, full), 0), (r, 1), (r - 1, 0), (r, 0),
           (np.zeros(shape), 1), (np.zeros(shape), 0)]
    fr = np.stack([s for s, _ in seq]).astype(pixel_dtype(b))
    return cds_arrays(fr, [k for _, k in seq], params)


def _reset(params, rng):
    out = _random([1, 0, 0, 1, 0])(params, rng)
    per = params["rows"] * params["width"] // params["ppc"]      # beats per frame
    out["reset_before"] = np.array([2 * per + per // 2], np.int64)   # inside signal frame 2
    return out


def cds_to_beats(arrays, params):
    """``ppc`` pixels per beat (element 0 the leftmost); ``frame_kind`` with every beat; a
    ``reset_before`` beat index cuts the stream there (reset mid-frame)."""
    fr, kinds = arrays["frames"], arrays["kinds"]
    ppc = params["ppc"]
    stim = frames_to_beats(fr, ppc=ppc)
    per = fr.shape[1] * fr.shape[2] // ppc
    stim.ctrl = np.repeat(kinds.astype(np.uint64), per)
    if "reset_before" not in arrays:
        return stim, frames_to_beats(arrays["out"], ppc=ppc)
    # a reset forgets the stored reset frame: recompute the golden after it
    k = int(arrays["reset_before"][0])
    fi = k // per
    nxt = fi + 1
    before = cds_ddr_frames(fr[:nxt], kinds[:nxt], pixel_bits=params["pixel_bits"])
    after = cds_ddr_frames(fr[nxt:], kinds[nxt:], pixel_bits=params["pixel_bits"])
    exp0 = frames_to_beats(before, ppc=ppc) if len(before) else \
        Beats(np.zeros((0, ppc)), [], [])
    exp1 = frames_to_beats(after, ppc=ppc)
    exp = Beats.concat([exp0, exp1])
    # the cut frame's tail (no tuser) is dropped by the stream contract: feed it with rst
    keep = np.ones(len(stim), bool)
    keep[k:nxt * per] = False
    stim = stim.select(keep)
    mark_resets(stim, exp, [k], [len(exp0)])
    return stim, exp


def _golden(arrays, params):
    return {"out": cds_ddr_frames(arrays["frames"], arrays["kinds"],
                                  pixel_bits=params["pixel_bits"])}


def _unstream(out, arrays, params):
    rows, cols = np.shape(arrays["frames"])[-2:]
    return {"out": out.data.reshape(-1, rows, cols).astype(pixel_dtype(params["pixel_bits"]))}


def _example(rng, n, shape, params):
    """Random frames of ``shape``, every 4th a reset frame (stored in DDR, no output)."""
    b = params["pixel_bits"]
    return {"frames": rng.integers(0, 1 << b, (n, *shape), dtype=pixel_dtype(b)),
            "kinds": (np.arange(n) % 4 == 0).astype(np.int64)}


def _p(width, rows, pixel_bits=12, ppw=None, stride=None, **kw):
    return {"width": width, "rows": rows, "pixel_bits": pixel_bits, "pixels_per_word": ppw,
            "line_stride": stride, **kw}


def _ppc_cases():
    """At ppc 2, 4 and 8: random frames with a reset frame mid-stream, hard values (zeros,
    full scale, reset > signal), a reset mid-frame, the smallest width (one beat per row),
    and at ppc 8 16-bit pixels, 10-bit Table 2 words (24 values: 3 beats a word) and the
    widest frame (65,536 columns)."""
    out = []
    for k, ppc in enumerate(PPC_CHOICES[1:]):
        p = _p(24, 4, ppc=ppc)
        out += [
            Case(f"random_24x4_12b_p{ppc}", p, _random([1, 0, 0, 1, 0]), seed=30 + k),
            Case(f"hard_24x3_12b_p{ppc}", _p(24, 3, ppc=ppc), _hard, seed=40 + k,
                 tags=("fullscale", "zeros")),
            Case(f"reset_mid_frame_24x4_12b_p{ppc}", p, _reset, seed=50 + k,
                 tags=("reset",)),
            Case(f"narrow_{ppc}x4_12b_p{ppc}", _p(ppc, 4, ppc=ppc), _random([1, 0, 0, 1, 0]),
                 seed=60 + k, tags=("narrow",)),
        ]
    out += [
        Case("hard_32x3_16b_p8", _p(32, 3, pixel_bits=16, ppc=8), _hard, seed=70,
             tags=("fullscale",)),
        Case("paper_10b_48x4_p8", _p(48, 4, pixel_bits=10, ppc=8), _random([1, 0, 1, 0]),
             seed=71, tags=("layout",)),
        Case("widest_65536x1_12b_p8", _p(1 << 16, 1, ppc=8), _random([1, 0, 0]), seed=72,
             tags=("fast-only", "wide")),
    ]
    return out


def _cases():
    return [
        Case("random_24x4_12b", _p(24, 4), _random([1, 0, 0, 1, 0]), seed=1),
        Case("no_reset_first_24x4_12b", _p(24, 4), _random([0, 1, 0, 0]), seed=2),
        Case("hard_30x3_12b", _p(30, 3), _hard, seed=3, tags=("fullscale", "zeros")),
        Case("paper_10b_50x4", _p(50, 4, pixel_bits=10, stride=4096, base=4096),
             _random([1, 0, 1, 0]), seed=4, tags=("layout",)),
        Case("hard_16x2_16b", _p(16, 2, pixel_bits=16), _hard, seed=5,
             tags=("fullscale",)),
        Case("reset_mid_frame_24x4_12b", _p(24, 4), _reset, seed=6, tags=("reset",)),
        Case("random_512x16_10b", _p(512, 16, pixel_bits=10), _random([1, 0, 0]),
             seed=7, tags=("fast-only",)),
    ] + _ppc_cases()


# ---- chain
def _pipeline_step(ctx):
    """``[pipeline.cds].memory = "ddr"``: the frame's size, the reset frame at the scene's
    ``[ddr].base`` (the MIG model's stall settings the scene's ``[ddr]`` gives); ``frame_kind`` 1 on the reset frame, 0 on its signal frame, in turn."""
    params = {"width": ctx.width, "rows": ctx.m, "pixel_bits": ctx.bits,
              "base": ctx.scene.ddr.base, **dict(ctx.scene.ddr.stalls)}
    _check_base(params)
    return Step("cds_ddr", params, ports={"frame_kind": (1, 0)}), ctx.bits


def _check_base(params):
    """The scene's reset frame fits above ``[ddr].base`` (:func:`tdicam.blocks._ddr.check_base`)."""
    p = BLOCK.resolve({**params, "base": 0})
    check_base(params["base"], _layout(p).end_addr(p["rows"]),
               f"reset frame ({p['rows']} lines x stride {_layout(p).line_stride})",
               p["capacity_mib"] << 20)


def _pipeline_hw(step, data, *, ecp5=False):
    """Every lane's :class:`~tdicam.hdl.cds_ddr.CdsDdr` with its MIG user interface at the
    top's ports (``cds_ddr_app_*``, ``cds_ddr_app_*_1``: a DDR3 part per channel, as the
    paper's two) and, for co-simulation, the simulation MIG model (DRAM timing and the
    block's stall pattern) beside the top on them. At ``ppc`` >= 2 a register slice follows
    the stage (``out_slice``): without it the next block's ready reached the launch of the
    reset frame's reads in one cycle (the whole Ning et al. 2019 camera at ppc 8: 84.9 MHz,
    hdr's input ready through ``nuc_ddr`` into ``cds_ddr``'s launch register, 11.8 ns);
    at ppc 1 the top is as it was."""
    from tdicam.hdl.chain_board import mig_device
    from tdicam.hdl.chain_top import LaneStage
    from tdicam.hdl.interfaces.mig import MIG_PORT_NAMES
    p = BLOCK.resolve(step.params)

    def device(lane):
        words = _layout(p).end_addr(p["rows"]) // ADDR_PER_WORD
        return mig_device(words, **stalls_of(p))
    return LaneStage(step.block, lambda lane: _core(p), ports=tuple(step.ports),
                     pins=MIG_PORT_NAMES, device=device, waits=True,
                     out_slice=p["ppc"] > 1)


def _frame_words(params):
    """256-bit DDR words of one reset frame."""
    return _layout(BLOCK.resolve(params)).words_per_line * params["rows"]


def _system(step, ctx):
    """The plan: each channel's reset frame written and read back once a line period, on
    its own DDR part, against the interface at the efficiency measured on cds_ddr's
    command order (the lower of the memory model's and LiteDRAM's, less the plan margin)."""
    from tdicam.model.ddr import WORD_BITS
    from tdicam.model.ddr_efficiency import MEASURED_EFFICIENCY, PLAN_MARGIN
    words = _frame_words(step.params)
    t = ctx["line_period_s"]
    need = 2 * words * WORD_BITS / 8 / t
    model, lite = MEASURED_EFFICIENCY["cds_ddr"]
    eff = min(model, lite if lite is not None else model) / 100 - PLAN_MARGIN
    avail = ctx["ddr_bits"] / 8 * ctx["ddr_clock_hz"] * eff
    ok = need <= avail
    return [{"name": "CDS DDR bandwidth", "value": need, "unit": "B/s", "ok": ok,
             "available": avail, "efficiency": eff, "words_per_frame": words,
             "text": f"CDS reset frame in DDR (cds_ddr): {words} words of {WORD_BITS} bit "
                     f"written and read back each line period ({t * 1e6:.1f} us) = "
                     f"{need / 1e6:.1f} MB/s per DDR part ({ctx['lanes']} part(s), one a "
                     f"channel); available {avail / 1e6:.0f} MB/s ({ctx['ddr_bits']} bit x "
                     f"{ctx['ddr_clock_hz'] / 1e6:g} MHz x {eff:.1%}: cds_ddr's measured "
                     f"efficiency {min(model, lite or model):g} % less the "
                     f"{PLAN_MARGIN:.0%} plan margin): {'OK' if ok else 'NO'}"}]


def _measured(step, status, info):
    """The co-simulation's DDR traffic per channel: words written and read back (one reset
    frame's words per frame each way), the cycles cds_ddr waited on the MIG model's stalls
    (its refresh and stall settings, ``[ddr]``), and the model's error flag."""
    out, q = [], BLOCK.resolve(step.params)
    for k in sorted(int(n.rsplit("_", 1)[1]) if n[-1].isdigit() else 0
                    for n in status if n.startswith("cds_ddr_ddr_writes")):
        sfx = f"_{k}" if k else ""
        w, r = status[f"cds_ddr_ddr_writes{sfx}"], status[f"cds_ddr_ddr_reads{sfx}"]
        err = status[f"cds_ddr_ddr_error{sfx}"]
        stalls = status.get(f"cds_ddr_ddr_stalls{sfx}")
        out.append({"name": f"CDS DDR traffic, channel {k}", "value": w + r, "unit": "words",
                    "stall_cycles": stalls,
                    "text": f"CDS DDR channel {k}: {w} words written, {r} read back "
                            f"({_frame_words(step.params)} a reset frame), "
                            f"{w + r} in {info['cycles']} cycles = "
                            f"{(w + r) / max(info['cycles'], 1):.1%} of the interface's cycles"
                            + (f"; {stalls} cycles waited on the MIG model's stalls "
                               f"(refresh {q['refresh_cycles']} of every "
                               f"{q['refresh_period']} cycles)"
                               if stalls is not None else "")
                            + (", MIG model ERROR" if err else "")})
    return out


def _pipeline_kinds(step, data, lane):
    """The golden side's ``kinds``: reset, signal, reset, ... for the lane's frames."""
    n = len(data.signal[lane])
    return {"kinds": np.tile(np.array([1, 0], np.int64), n)}


# ---- entry
BLOCK = Block(
    name="cds_ddr",
    summary="digital CDS with the reset frame in DDR (Ning et al. 2019 §4.4.1, §4.2)",
    params=(
        Param("width", 512, "pixels per line", lo=1, hi=1 << 16),
        Param("rows", 16, "lines per frame", lo=1, hi=1 << 16),
        Param("pixel_bits", 12, "pixel width", lo=8, hi=16),
        Param("pixels_per_word", None, "values per 256-bit word; default 24 for 10 bit, "
                                       "else 256 // pixel_bits (a multiple of ppc)",
              lo=1, hi=32),
        PPC_PARAM,
    ) + address_params("address of the reset frame's line 0") + STALL_PARAMS,
    top=_top,
    ecp5_top=_synth_top,
    cases=_cases,
    check=_check,
    model_version="cds_ddr-1",
    streams=Streams(
        to_beats=cds_to_beats,
        stream="frames",
        side_inputs=(SideInput("kinds", "frame", "1 = a reset frame (stored in DDR, no output), "
                               "0 = a signal frame (output minus the stored reset); on the "
                               "frame_kind port with every beat"),),
        golden=_golden,
        fit=lambda arrays: dict(zip(("rows", "width"), map(int, np.shape(arrays["frames"])[-2:]))),
        unstream=_unstream,
        example=_example,
        frame_beats=lambda p: p["width"] * p["rows"] // p["ppc"],
        small=((3, 24), {"width": 24, "rows": 3}),
    ),
    pipeline=Use(_pipeline_step, _pipeline_hw, side=_pipeline_kinds, per_frame=True,
                 reset_frames=True, system=_system, measured=_measured,
                 memory=Memory(ddr_end=lambda step: _layout(BLOCK.resolve(
                     step.params)).end_addr(step.params["rows"]))),
    order=80,
    bench=Bench("ddr", StreamWork("cds_ddr", "cds_ddr",
                                  {"width": 512, "rows": 8, "pixel_bits": 10}, "pixel", 
                                  "CDS with the reset frame in DDR, frames of 512 x 8, 10-bit", (8, 512),
                                  {"pysim": 2, "beat": 4, "fast": 64, "icarus fast": 16},
                                  {"pysim": 2, "beat": 2, "fast": 4})),
    suite=Suite(sims=("icarus",), fast_stalls=0.2,   # Verilator: the block's own tests
                per_beat=("random_24x4_12b", "reset_mid_frame_24x4_12b", "random_24x4_12b_p2",
                          "reset_mid_frame_24x4_12b_p8")),
)
