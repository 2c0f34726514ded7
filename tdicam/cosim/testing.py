"""Helpers for pytest co-simulation tests: run a golden case, assert bit-exact output.

A mismatch fails with the first differing pixel (frame, line, column, or segment and beat),
its expected and received values and the path of the waveform around it (under
:data:`tdicam.cosim.WAVE_DIR`, or ``wave_dir``).
"""

import os

import pytest

from tdicam import blocks
from tdicam.cosim.build import WAVE_DIR
from tdicam.cosim.run import run_beats, run_golden_case

__all__ = ["check_beats", "check_case", "beat_cases", "case_names", "FULL", "WIDE_PPC"]

#: ``TDICAM_FULL=1``: the long forms of the co-simulation sweeps.
FULL = os.environ.get("TDICAM_FULL") == "1"

#: ``ppc`` values of the widest-row tests: 8 in every run; 1, 2 and 4 with ``TDICAM_FULL=1``.
WIDE_PPC = [pytest.param(p, marks=[pytest.mark.slow, pytest.mark.skipif(
    not FULL, reason="8192-wide rows at ppc 1, 2, 4: set TDICAM_FULL=1")]) for p in (1, 2, 4)] \
    + [8]


def beat_cases(block, *, full=None):
    """Names of ``block``'s golden cases co-simulated per beat: ``(short, long)``.

    ``short`` (the default run): every case at ppc 1 and at ppc 8, and the reset cases at
    every ppc; ``long`` (with ``TDICAM_FULL=1``, ``full``): the other ppc 2 and 4 cases,
    which fast mode checks in every run. ``fast-only`` cases are in neither."""
    blk = blocks.get(block) if isinstance(block, str) else block
    short, long = [], []
    for case in blk.cases():
        if "fast-only" in case.tags:
            continue
        ppc = blk.resolve(case.params).get("ppc", 1)
        (short if ppc in (1, 8) or "reset" in case.tags else long).append(case.name)
    return short, long


def case_names(block, *, fast_only=False):
    """Names of ``block``'s golden cases tagged ``fast-only`` (``fast_only``: the large ones,
    co-simulated in fast mode only) or not (the default: the small ones)."""
    return [c.name for c in blocks.get(block).cases() if ("fast-only" in c.tags) == fast_only]


def _check(run):
    assert run.ok, run.message()
    return run.result


def check_beats(block, params, stim, exp, *, sim, mode, idle=0.3, backpressure=0.3, seed=1,
                wave_dir=WAVE_DIR, **kw):
    """Co-simulate and assert the output equals ``exp`` beat for beat (and every input beat
    was accepted, no time-out); returns the :class:`~tdicam.cosim.SimResult`."""
    return _check(run_beats(block, params, stim, exp, sim=sim, mode=mode, idle=idle,
                            backpressure=backpressure, seed=seed, wave_dir=wave_dir, **kw))


def check_case(block, case, *, sim, mode, idle=0.3, backpressure=0.3, seed=1,
               wave_dir=WAVE_DIR, **kw):
    """Load golden ``case`` of ``block`` and :func:`check_beats` it."""
    return _check(run_golden_case(block, case, sim=sim, mode=mode, idle=idle,
                                  backpressure=backpressure, seed=seed, wave_dir=wave_dir,
                                  **kw))
