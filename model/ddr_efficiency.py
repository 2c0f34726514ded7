"""The DDR efficiencies the planner counts on: the memory model's and LiteDRAM's figures on
each DDR block's own command order (:data:`MEASURED_EFFICIENCY`), the block closest to a
planned share, and the TDI spill's own plan (:func:`tdi_spill_efficiency`: its pattern on
the memory model less :data:`PLAN_MARGIN`).
"""

import functools

from tdicam.model.ddr import psums_per_word
from tdicam.model.dram import window_words
from tdicam.model.ddr_traces import pattern_efficiency

__all__ = ["PLAN_MARGIN", "MEASURED_EFFICIENCY", "SHARED_EFFICIENCY", "BLOCK_TEXT", "closest_block",
           "TDI_SPILL_PATTERN", "tdi_spill_efficiency"]

#: share the planner takes off the memory model's figure for the TDI spill: the band the
#: model is held to against LiteDRAM (+/-3 points on every pattern of PATTERNS and every
#: DDR block's recorded order, tests/test_ddrref.py; on TdiDdr's own orders the model is
#: within a point or two of LiteDRAM,
#: TdiDdr's own orders, all over the steady-state window of 4 refresh intervals).
PLAN_MARGIN = 0.03
#: ``(memory model %, LiteDRAM % or None: not measured)`` on each DDR block's own command
#: order, over the steady-state window of :data:`WINDOW_REFRESHES` refresh intervals
#: (``window_cycles()`` = 3128 cycles; LiteDRAM's figures are tests/ddr_litedram.json's,
#: which ``python bench/bench_ddr.py --litedram --fixture`` writes, and tests/test_ddrref.py
#: holds both columns to the fixture and the model re-measured). The blocks other than the
#: TDI spill are planned at :data:`tdicam.model.physics.memory.DDR_EFFICIENCY` (80 %).
MEASURED_EFFICIENCY = {'writer': (87.2, 86.2),
                       'reader': (87.2, 87.5),
                       'ddr': (81.4, 81.0),
                       'cds_ddr': (87.0, 86.7),
                       'cds_ddr_wide': (84.9, 84.8),
                       'tdi_ddr': (83.3, 82.1),
                       'tdi_ddr_wide': (86.9, 86.3)}
#: ``(memory model %, LiteDRAM %)`` on the camera's shared DDR order: nuc_ddr's coefficient
#: reads beside cds_ddr's reset frame writes and reads (both saturated) and the output
#: links' frame buffer's image line writes and reads (third port, at the plan's share of
#: the interface) behind one DdrArbiter, as the whole camera's top has them
#: (:data:`tdicam.cosim.shared_ddr.CAMERA_TRACE`, recorded behind the HDL), over the same
#: window; tests/ddr_arbiter_litedram.json's figures, which ``python bench/bench_ddr.py
#: --arbiter --fixture`` writes and tests/test_ddr_arbiter.py holds this to. The camera
#: plan counts on it for an interface that carries these users
#: (:func:`tdicam.model.physics.camera.ddr_efficiency`).
SHARED_EFFICIENCY = (72.1, 73.4)
#: what the blocks of :data:`MEASURED_EFFICIENCY` are
BLOCK_TEXT = {"writer": "the frame buffer's line writer", "reader": "its line reader",
              "ddr": "the frame buffer", "cds_ddr": "CDS with its reset frame in DDR",
              "cds_ddr_wide": "CDS with its reset frame in DDR, 4096 columns",
              "tdi_ddr": "the TDI spill", "tdi_ddr_wide": "the TDI spill, 4096 columns"}


def closest_block(planned):
    """``(name, efficiency %, source)`` of the DDR block, other than the TDI spill (which
    has its own plan, :func:`tdi_spill_efficiency`), whose figure in
    :data:`MEASURED_EFFICIENCY` comes closest to ``planned`` (a share, 0..1): the lower of
    the model's and LiteDRAM's where both are measured; ``source`` names the one taken."""
    rows = []
    for n, (model, lite) in MEASURED_EFFICIENCY.items():
        if not n.startswith("tdi"):
            e, src = (model, "memory model") if lite is None or model <= lite \
                else (lite, "LiteDRAM")
            rows.append((e - 100 * planned, n, e, src))
    _, name, eff, src = min(rows)
    return name, eff, src
#: the access pattern of TDI partial sums in DDR (:class:`tdicam.hdl.tdi_ddr.TdiDdr`)
TDI_SPILL_PATTERN = "row_blocks"


@functools.lru_cache(maxsize=256)
def tdi_spill_efficiency(width, stages, pixel_bits, ppc=1):
    """``(pattern, efficiency)`` the planner counts on for TDI partial sums in DDR.

    The pattern is :class:`tdicam.hdl.tdi_ddr.TdiDdr`'s order (:data:`TDI_SPILL_PATTERN`: a
    row's stored sums read as one block of a line, then the line written back) with that
    configuration's words per line (:func:`psums_per_word` sums per word), its efficiency
    on the memory model with DRAM timing (:func:`pattern_efficiency`, over its steady-state
    window of :data:`WINDOW_REFRESHES` refresh intervals) less :data:`PLAN_MARGIN`, so
    LiteDRAM's DDR3 controller, measured on the block's own order over the same window,
    still meets the plan."""
    from tdicam.model.tdi import full_bits
    k = psums_per_word(full_bits(pixel_bits, stages), ppc)
    wpl = -(-(int(width) // int(ppc)) // (k // int(ppc)))
    e = pattern_efficiency(TDI_SPILL_PATTERN, lines=-(-window_words() // (2 * wpl)) + 1,
                           words=wpl, stride=wpl)
    return TDI_SPILL_PATTERN, e - PLAN_MARGIN
