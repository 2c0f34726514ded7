"""Block ``ddr``: DDR frame buffer round trip (Ning et al. 2019 §4.2; :class:`~tdicam.hdl.ddr.DdrFrameBuffer`).

Output = input after the line writer -> MIG user interface -> line reader; the Verilog top
has the simulation MIG model behind it (:mod:`tdicam.blocks._ddr`). Frames carry
``channels`` values per pixel, packed ``pixels_per_word`` to a 256-bit word (Ning et al. 2019
Table 2).
"""

import numpy as np

from tdicam.beats import frames_to_beats, mark_resets
from tdicam.errors import TdicamError, check_multiple
from tdicam.model.cds import pixel_dtype
from tdicam.hdl.ddr import MAX_WORDS_PER_BEAT
from tdicam.model.ddr import ADDR_PER_WORD, LineLayout, check_capacity, pack_lines, unpack_lines
from tdicam.blocks import Bench, StreamWork, Suite
from tdicam.blocks import Block, Case, Param, Streams
from tdicam.blocks._ddr import STALL_PARAMS, address_params, check_stalls, sim_top, stalls_of

__all__ = ["BLOCK", "ddr_frames", "ddr_to_beats"]


# ---- top
def _layout(p):
    return LineLayout(width=p["width"], channels=p["channels"], pixel_bits=p["pixel_bits"],
                      pixels_per_word=p["pixels_per_word"], line_stride=p["line_stride"],
                      base=p["base"])


def _check(p):
    check_stalls(p)
    lay = _layout(p)
    e = p["ppc"] * p["channels"]
    check_multiple(p["width"], p["ppc"])
    ppw = p["pixels_per_word"]
    if ppw % e and e % ppw:
        raise TdicamError(f"ppc x channels = {e} values per beat and pixels_per_word = {ppw}:"
                          " one must divide the other")
    check_capacity(lay, p["rows"], p["capacity_mib"] << 20, "frame buffer")
    end = lay.end_addr(p["rows"])
    if end // ADDR_PER_WORD > 1 << 22:
        raise TdicamError(f"the simulation model holds at most {1 << 22} words (128 MiB); "
                          f"this buffer needs {end // ADDR_PER_WORD}")


def _top(**p):
    from tdicam.hdl.ddr import DdrFrameBuffer
    core = DdrFrameBuffer(width=p["width"], rows=p["rows"], channels=p["channels"],
                          elements=p["ppc"] * p["channels"], pixel_bits=p["pixel_bits"],
                          pixels_per_word=p["pixels_per_word"], line_stride=p["line_stride"],
                          base=p["base"], capacity_bytes=p["capacity_mib"] << 20)
    return sim_top(core, core.layout.end_addr(p["rows"]) // ADDR_PER_WORD, stalls_of(p))


# ---- cases
def ddr_frames(rng, params, n, kind="random"):
    """(n, rows, width, channels) frames for the ``ddr`` block."""
    b = params["pixel_bits"]
    shape = (n, params["rows"], params["width"], params["channels"])
    if kind == "random":
        return rng.integers(0, 1 << b, shape).astype(pixel_dtype(b))
    full = (1 << b) - 1
    f = np.zeros(shape, pixel_dtype(b))
    f[1::2] = full
    return f


def _random(n, kind="random"):
    def make(params, rng):
        return {"frames": ddr_frames(rng, params, n, kind)}
    return make


def _reset(params, rng):
    """Reset at a line boundary in the middle of frame 1: the buffer passes every beat."""
    out = {"frames": ddr_frames(rng, params, 3)}
    line = params["width"] // params["ppc"]
    per = params["rows"] * line
    out["reset_before"] = np.array([per + (params["rows"] // 2) * line], np.int64)
    return out


def ddr_to_beats(arrays, params):
    """Stimulus ``frames`` and expected ``out`` (default: the frames, the buffer's golden
    output) as beats of ``ppc`` pixels x ``channels`` values."""
    kw = {"ppc": params["ppc"], "channels": params["channels"]}
    stim = frames_to_beats(arrays["frames"], **kw)
    exp = frames_to_beats(arrays.get("out", arrays["frames"]), **kw)
    mark_resets(stim, exp, arrays.get("reset_before"))
    return stim, exp


def _frames4(a, params):
    """Scene frames as (n, rows, width, channels)."""
    a = np.asarray(a)
    ch = params["channels"]
    if ch == 1 and a.shape[-1] != 1:
        a = a[..., None]
    return a.reshape((-1,) + a.shape[-3:])


def _golden(arrays, params):
    """The line packing round trip: Table 2 words and back (the buffer's output)."""
    lay = LineLayout(width=params["width"], channels=params["channels"],
                     pixel_bits=params["pixel_bits"], pixels_per_word=params["pixels_per_word"])
    f = np.asarray(arrays["frames"])
    lines = f.reshape(-1, lay.values_per_line)
    out = unpack_lines(pack_lines(lines, lay), lay).reshape(f.shape)
    return {"out": out.astype(pixel_dtype(params["pixel_bits"]))}


def _to_case(arrays, params):
    f = _frames4(arrays["frames"], params)
    return {"frames": f, **_golden({"frames": f}, params)}


def _unstream(out, arrays, params):
    f = np.asarray(arrays["frames"])
    return {"out": out.data.reshape(f.shape).astype(pixel_dtype(params["pixel_bits"]))}


def _fit(arrays):
    f = np.asarray(arrays["frames"])
    return {"rows": int(f.shape[-3]), "width": int(f.shape[-2]), "channels": int(f.shape[-1])}


def _example(rng, n, shape, params):
    b = params["pixel_bits"]
    return {"frames": rng.integers(0, 1 << b, (n, params["rows"], params["width"],
                                               params["channels"]), dtype=pixel_dtype(b))}


def _p(width, rows, channels=1, ppc=1, pixel_bits=10, ppw=24, stride=None, **kw):
    return {"width": width, "rows": rows, "channels": channels, "ppc": ppc,
            "pixel_bits": pixel_bits, "pixels_per_word": ppw, "line_stride": stride, **kw}


def _cases():
    return [
        Case("paper_72ch_4x6", _p(4, 6, channels=72), _random(3), seed=1,
             tags=("layout",)),
        Case("paper_72ch_table2", _p(170, 2, channels=72, stride=4096, base=8192),
             _random(2), seed=2, tags=("layout", "table2")),
        Case("mono_48x6_p8", _p(48, 6, ppc=8), _random(3), seed=3),
        Case("mono_50x4_p1", _p(50, 4), _random(3), seed=4, tags=("partial-word",)),
        Case("mono_96x4_p24", _p(96, 4, ppc=24), _random(3), seed=5),
        Case("fullscale_48x4_p2_12b", _p(48, 4, ppc=2, pixel_bits=12, ppw=20),
             _random(4, "fullscale"), seed=6, tags=("fullscale", "zeros")),
        Case("reset_mid_frame_48x6_p8", _p(48, 6, ppc=8), _reset, seed=8,
             tags=("reset",)),
        Case("mono_12x3_p2_nostall",
             _p(12, 3, ppc=2, drop=0, refresh_cycles=0, lat_lo=2, lat_hi=2),
             _random(3), seed=7),
    ]


def _full_only(case, sim, mode):
    """The 72-channel Table 2 case takes ~80 s on Icarus (the UI test runs it on Verilator)."""
    return case.name == "paper_72ch_table2"


# ---- entry
BLOCK = Block(
    name="ddr",
    summary="DDR frame buffer round trip: line writer -> MIG UI -> line reader "
            "(Ning et al. 2019 Table 2 packing)",
    params=(
        Param("width", 1280, "pixels per line", lo=1, hi=1 << 16),
        Param("rows", 16, "lines in the buffer (a frame's height)", lo=1, hi=1 << 16),
        Param("channels", 1, "values per pixel (72 in Ning et al. 2019)", lo=1, hi=256),
        Param("ppc", 8, "pixels per beat (ppc x channels divides or is a multiple of "
                        f"pixels_per_word, at most {MAX_WORDS_PER_BEAT} words a beat)",
              lo=1, hi=256),
        Param("pixel_bits", 10, "bits per value", lo=1, hi=32),
        Param("pixels_per_word", 24, "values per 256-bit word", lo=1, hi=256),
    ) + address_params("address of line 0 (a multiple of 8)") + STALL_PARAMS,
    top=_top,
    cases=_cases,
    check=_check,
    model_version="ddr-1",
    streams=Streams(
        to_beats=ddr_to_beats,
        stream="frames",
        golden=_golden,
        to_case=_to_case,
        fit=_fit,
        unstream=_unstream,
        example=_example,
        small=((), {"width": 48, "rows": 4, "ppc": 8}),
    ),
    order=80,
    bench=Bench("ddr", StreamWork("ddr", "ddr",
                                  {"width": 1280, "rows": 4, "ppc": 8, "pixel_bits": 10},
                                  "pixel", 
                              "frame buffer round trip, frames of 1280 x 4, 10-bit, 8 px/beat", (4, 1280),
                              {"pysim": 1, "beat": 1, "fast": 16, "icarus beat": 1, "icarus fast": 2},
                              {"pysim": 1, "beat": 1, "fast": 2})),
    suite=Suite(sims=("icarus",), fast_stalls=0.2,   # Verilator: the block's own tests
                per_beat=("paper_72ch_4x6", "mono_50x4_p1"),
                full_only=_full_only),
)
