"""Block ``tdi_ddr``: the ``tdi`` accumulator with its m_max-1 partial-sum lines in DDR
(Qu et al. 2010; Tao et al. 2012; Ning et al. 2019 §4.2; :class:`~tdicam.hdl.tdi_ddr.TdiDdr`).

Same stream, run-time ports and golden model as block ``tdi``
(:func:`~tdicam.model.tdi.tdi_stream`; scene arrays per :data:`tdicam.blocks.tdi.SCENE`);
the Verilog top has the simulation MIG model behind it (:mod:`tdicam.blocks._ddr`).
"""

from dataclasses import replace

from tdicam.model.ddr import ADDR_PER_WORD
from tdicam.model.tdi_ddr import tdi_ddr_check
from tdicam.model.tdi import check_params as tdi_check_params
from tdicam.blocks import Bench, StreamWork, Suite
from tdicam.blocks._bench import TDI, TDI_QUICK
from tdicam.blocks import Block, Case, Param, Streams, Use, tdi as _tdi
from tdicam.blocks._ddr import STALL_PARAMS, check_base, check_stalls, sim_top, stalls_of

__all__ = ["BLOCK"]


# ---- top
def _check(p):
    tdi_check_params(width=p["width"], stages=p["stages"], pixel_bits=p["pixel_bits"],
                     out_bits=p["out_bits"], ppc=p["ppc"])
    check_stalls(p)
    from tdicam.hdl.tdi_ddr import TdiDdr
    lp = None if p["line_period_ns"] is None else p["line_period_ns"] * 1e-9
    tdi_ddr_check(width=p["width"], stages=p["stages"], pixel_bits=p["pixel_bits"],
                  ppc=p["ppc"], line_period_s=lp, clock_hz=p["clock_mhz"] * 1e6,
                  lookahead=TdiDdr.LOOKAHEAD + 4)


def _top(**p):
    from tdicam.hdl.tdi_ddr import TdiDdr
    lp = p["line_period_ns"]
    core = TdiDdr(width=p["width"], stages=p["stages"], pixel_bits=p["pixel_bits"],
                  out_bits=p["out_bits"], ppc=p["ppc"], base=p["base"],
                  line_period_s=None if lp is None else lp * 1e-9,
                  clock_hz=p["clock_mhz"] * 1e6)
    return sim_top(core, p["base"] // ADDR_PER_WORD + core.ddr_words, stalls_of(p))


# ---- cases
def _gen(name, *args):
    """One of the ``tdi`` block's case generators (:func:`tdicam.blocks.tdi.case_makers`),
    looked up when the case is made."""
    def make(params, rng):
        g = _tdi.case_makers()[name]
        return g(*args)(params, rng) if args else g(params, rng)
    return make


def _p(width, stages, ppc=1, out_bits=None, pixel_bits=12, **kw):
    return {"width": width, "stages": stages, "pixel_bits": pixel_bits, "out_bits": out_bits,
            "ppc": ppc, **kw}


_A = _p(256, 4, base=1 << 16)
_B = _p(320, 5, ppc=2, out_bits=14)
_C = _p(512, 16)
_D = _p(1024, 8, ppc=4, pixel_bits=10)
_CHANGES = [(4, 0, 6), (2, 0, 4), (3, 1, 5), (1, 0, 2), (1, 1, 2), (2, 1, 3), (4, 0, 5),
            (3, 1, 4)]


def _cases():
    return [
        Case("random_256x4_p1", _A, _gen("random", 8), seed=1),
        Case("stages_256x4_p1", _A, _gen("stages", _CHANGES), seed=2,
             tags=("stages", "direction")),
        Case("errors_256x4_p1", _A, _gen("errors"), seed=3, tags=("errors", "direction")),
        Case("reset_256x4_p1", _A, _gen("reset"), seed=4, tags=("reset",)),
        Case("fullscale_320x5_p2_sat", _B, _gen("fullscale"), seed=5,
             tags=("fullscale", "saturate", "fast-only")),
        Case("stages_320x5_p2_sat", _B,
             _gen("stages", [(5, 0, 7), (2, 1, 4), (4, 1, 6), (3, 0, 4)]),
             seed=6, tags=("stages", "direction", "saturate", "fast-only")),
        Case("random_512x16_p1", _C, _gen("random", 18), seed=7, tags=("fast-only", "paper")),
        Case("stages_512x16_p1", _C, _gen("stages", [(16, 0, 17), (9, 1, 11), (16, 0, 17)]),
             seed=8, tags=("fast-only", "paper", "stages", "direction")),
        Case("mixed_1024x8_p4_10b", _D, _gen("stages", [(8, 0, 10), (7, 1, 9), (1, 0, 2)]),
             seed=9, tags=("fast-only", "stages", "direction")),
    ]


# ---- chain
def _pipeline_step(ctx):
    """``tdi``'s step, its partial sums at the scene's ``[ddr].base`` (refused in one line
    naming the key when they do not fit above it)."""
    from dataclasses import replace
    from tdicam.hdl.tdi_ddr import TdiDdr
    step, out_bits = _tdi.PIPELINE["step"](ctx)
    p = BLOCK.resolve({**step.params, "base": 0})
    at0 = TdiDdr(width=p["width"], stages=p["stages"], pixel_bits=p["pixel_bits"],
                 out_bits=p["out_bits"], ppc=p["ppc"]).layout
    lines = max(p["stages"] - 1, 0)
    check_base(ctx.scene.ddr.base, at0.end_addr(lines),
               f"partial-sum buffer ({lines} lines x stride {at0.line_stride})")
    return replace(step, params={**step.params, "base": ctx.scene.ddr.base,
                                 **dict(ctx.scene.ddr.stalls)}), out_bits


# ---- entry
BLOCK = Block(
    name="tdi_ddr",
    summary="TDI accumulator with its m_max-1 partial-sum lines in DDR (Qu et al. 2010; Tao et al. 2012; Ning et al. 2019 §4.2)",
    params=tuple(replace(p, default={"width": 512, "stages": 16}.get(p.name, p.default))
                 for p in _tdi.PARAMS) + (
        Param("base", 0, "DDR address of partial-sum line 0 (a multiple of 8)", lo=0,
              hi=(1 << 28) - 8),
        Param("line_period_ns", None, "line period the design must sustain (checks the DDR "
                                      "bandwidth and the clock); default: not checked",
              lo=1, hi=10 ** 9),
        Param("clock_mhz", 100, "user-interface clock for the bandwidth check, MHz", lo=1,
              hi=1000),
    ) + STALL_PARAMS,
    top=_top,
    cases=_cases,
    check=_check,
    model_version="tdi_ddr-1",
    streams=Streams(
        **_tdi.SCENE,
        to_beats=_tdi.to_beats,
        frame_beats=lambda p: p["stages"] * p["width"] // p["ppc"],
        streamed_case=_tdi.streamed_case,
        small=((), {"width": 256, "stages": 4}),
    ),
    pipeline=Use(**{**_tdi.PIPELINE, "step": _pipeline_step}),
    order=80,
    bench=Bench("ddr", StreamWork("tdi_ddr", "tdi_ddr", {"width": 256, "stages": 4}, "pixel",
                                  "TDI partial sums in DDR, the tdi row's input", (4, 256), TDI,
                                  TDI_QUICK)),
    suite=Suite(sims=("icarus",), fast_stalls=0.2,   # Verilator: the block's own tests
                per_beat=("stages_256x4_p1",)),
)
