"""Helpers for pytest co-simulation tests: run a golden case, assert bit-exact output."""

from .. import blocks, golden
from . import compare, run_stream

__all__ = ["check_beats", "check_case"]


def check_beats(block, params, stim, exp, *, sim, mode, idle=0.3, backpressure=0.3, seed=1,
                **kw):
    """Co-simulate and assert the output equals ``exp`` beat for beat; returns the result."""
    res = run_stream(block, params, stim, n_out=len(exp), sim=sim, mode=mode, idle=idle,
                     backpressure=backpressure, seed=seed, **kw)
    assert not res.timeout, f"{block} {sim} {mode}: timed out after {res.cycles} cycles"
    cmp = compare(res.out, exp)
    assert cmp.ok, f"{block} {sim} {mode}: {cmp.mismatches} mismatches; {cmp.message}"
    assert res.accepted == len(stim), f"accepted {res.accepted} of {len(stim)} input beats"
    return res


def check_case(block, case, *, sim, mode, **kw):
    """Load golden ``case`` of ``block`` and :func:`check_beats` it."""
    blk = blocks.get(block)
    arrays, params = golden.load(blk, case)
    stim, exp = blk.to_beats(arrays, params)
    return check_beats(block, params, stim, exp, sim=sim, mode=mode, **kw)
