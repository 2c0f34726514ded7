"""The standard co-simulation suite of every block that streams, from the registry.

For every registered block with a stream form (:attr:`tdicam.blocks.Streams.to_beats`) and
each simulator of its :class:`~tdicam.blocks.Suite`: its golden cases per beat (cocotb
drives each cycle, 30 % idle and 40 % backpressure; the ppc 2 and 4 ones of the ``"ppc"``
rule with ``TDICAM_FULL=1``), in fast mode (HDL-side stimulus and stalls), and its extreme
stalls (full rate, a nearly always stalled sink, a nearly always idle source) with the
cycle count at full rate bounded by one beat a clock (:class:`~tdicam.blocks.Stalls`). A
new stream block is in the suite with its entry; what is particular to a block stays in
``cocotb_tests/test_<module>.py``.
"""

import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cosim.testing import FULL, beat_cases, check_case

#: Every block that streams, in name order.
STREAMING = [b for b in blocks.all_blocks() if b.streams.to_beats is not None]
#: Quiet cycles the fast testbench waits after the last output (its drain window).
DRAIN = 2000

_FULL_ONLY = pytest.mark.skip(reason="another simulator build or minutes: set TDICAM_FULL=1")
_LONG = [pytest.mark.slow, pytest.mark.skipif(
    not FULL, reason="per-beat ppc 2/4 cases (fast mode runs them): set TDICAM_FULL=1")]


def _param(blk, case, sim, mode, *extra, marks=()):
    full_only = blk.suite.full_only
    if not FULL and full_only is not None and full_only(case, sim, mode):
        marks = (*marks, _FULL_ONLY)
    return pytest.param(blk.name, case.name, sim, *extra, marks=marks,
                        id="-".join((blk.name, case.name, sim, *map(str, extra))))


def _per_beat(long):
    rows = []
    for blk in STREAMING:
        s = blk.suite
        cases = {c.name: c for c in blk.cases() if "fast-only" not in c.tags}
        if s.per_beat == "ppc":
            names = beat_cases(blk)[1 if long else 0]
        else:
            names = () if long else list(cases) if s.per_beat == "all" else s.per_beat
        rows += [_param(blk, cases[n], sim, "beat", marks=_LONG if long else ())
                 for n in names if n not in s.not_per_beat for sim in s.sims]
    return rows


def _fast():
    return [_param(blk, c, sim, "fast") for blk in STREAMING if blk.suite.fast
            for c in blk.cases() if "fast-only" not in c.tags for sim in blk.suite.sims]


def _stalls():
    rows = []
    for blk in STREAMING:
        st, cases = blk.suite.stalls, {c.name: c for c in blk.cases()}
        if st is None:
            continue
        rows += [_param(blk, cases[st.case], sim, "fast", idle, bp)
                 for idle, bp in st.pairs for sim in blk.suite.sims]
        rows += [_param(blk, cases[n], sim, "fast", 0.0, 0.0) for n in st.full_rate
                 for sim in blk.suite.sims]
    return rows


@pytest.mark.parametrize("block, case, sim", _per_beat(long=False))
def test_golden_per_beat(block, case, sim):
    check_case(block, case, sim=sim, mode="beat", idle=0.3, backpressure=0.4, seed=11)


@pytest.mark.parametrize("block, case, sim", _per_beat(long=True))
def test_golden_per_beat_ppc_long(block, case, sim):
    check_case(block, case, sim=sim, mode="beat", idle=0.3, backpressure=0.4, seed=11)


@pytest.mark.parametrize("block, case, sim", _fast())
def test_golden_fast(block, case, sim):
    p = blocks.get(block).suite.fast_stalls
    check_case(block, case, sim=sim, mode="fast", idle=p, backpressure=p, seed=7)


@pytest.mark.filterwarnings("ignore::amaranth.hdl._ir.UnusedElaboratable")
@pytest.mark.parametrize("block, case, sim, idle, bp", _stalls())
def test_extreme_stalls(block, case, sim, idle, bp):
    """Full rate, a nearly always stalled sink, a nearly always idle source (and the
    block's own pairs); without stalls one beat a clock, plus the latency, the drain window
    and the cycles the block stalls its input on purpose."""
    blk = blocks.get(block)
    st = blk.suite.stalls
    res = check_case(block, case, sim=sim, mode="fast", idle=idle, backpressure=bp,
                     seed=st.seed)
    if idle == bp == 0.0:
        arrays, params = golden.load(blk, case)
        params = blk.resolve(params)
        stim, exp = blk.streams.to_beats(arrays, params)
        top = blk.build(params)
        extra = st.extra_cycles(arrays, params) if st.extra_cycles is not None else 0
        bound = max(len(stim), len(exp)) + top.latency + DRAIN + 2 + extra
        assert res.cycles <= bound, (res.cycles, bound)
