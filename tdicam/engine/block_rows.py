"""The pipeline blocks in the scene simulator, from the block registry: one row of the effects
table per :class:`tdicam.blocks.steps.Sim` of a block a scene may list (:data:`ROWS`), when
each runs (:func:`need`), the side inputs they take from the fixed pattern
(:func:`prepare`), and the reset-taking block's golden model on the raw single exposure
(:func:`subtract_reset`).

What a block does to the frame stacks (its scene arrays, channels, resets, side inputs, the
crops kept for RTL co-simulation) is in its registry entry (:attr:`tdicam.blocks.Use.sim`, a
:class:`tdicam.blocks.SceneSim`); its parameters come from the entry's one scene-to-parameters function
(:attr:`tdicam.blocks.Use.step`, the same the scene's gateware chain uses). This module names
no block.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from tdicam import blocks
from tdicam.blocks.steps import Frames, Sim

__all__ = ["Row", "ROWS", "LINES", "STAGES", "need", "timed", "Frames", "prepare", "subtract_reset",
           "takes_resets"]

#: Where a block's row acts, in physical order (:attr:`tdicam.blocks.steps.Sim.stage`).
STAGES = ("blocks", "lines", "output")


@dataclass(frozen=True)
class Row:
    """One block's row of the effects table: its ``name`` (the block's, or
    ``<block>_<where>``), the registry ``block`` and its :class:`~tdicam.blocks.steps.Sim`."""

    name: str
    block: object
    sim: Sim


def _rows():
    out = [Row(b.name if s.where is None else f"{b.name}_{s.where}", b, s)
           for b in blocks.scene_blocks() for s in b.pipeline.sim.steps]
    return tuple(sorted(out, key=lambda r: STAGES.index(r.sim.stage)))   # rank order kept


#: The blocks' rows in physical order: by stage, then by the blocks' ``[pipeline].blocks``
#: rank.
ROWS = _rows()
#: The line-making block's row: the TDI sum itself (never disabled, no impact of its own;
#: charge-domain TDI times its charge sum under this name).
LINES = next(r.name for r in ROWS if r.sim.stage == "lines")


def need(block, where=None):
    """The ``need`` of the engine step of registry block ``block``: listed in
    ``[pipeline].blocks`` (``where``: ``"pre"`` / ``"post"``, for a block that may run before
    or after the line-making block, the one of the two this step is)."""
    use = blocks.get(block).pipeline

    def need_block(c):
        pipe, m = c.scene.pipeline, c.m
        after = pipe.after_lines(block)
        listed = after is not None
        if where is not None and listed:
            listed = (where == "post") == after
        if use.lines and not c.digital:
            return True, (f"charge domain: {m} stages summed as charge before one readout "
                          f"(Zhou et al. 2008); the FPGA accumulator is not used")
        if not listed:
            here = "" if where is None or after is None else \
                (" here (it runs " + ("after" if after else "before") + " TDI)")
            return False, f"not in [pipeline].blocks{here}"
        if use.merge and len(c.sensor.gains) != 2:
            return False, "one-gain sensor: nothing to merge"
        return True, f"in [pipeline].blocks, golden model tdicam.model.{block}"
    return need_block


def timed(name, fn):
    """``fn(c, fr)`` with its time added to the run's timer (``fr.timer``) as ``name``."""
    def step(c, fr):
        t = time.perf_counter()
        fn(c, fr)
        fr.timer.add(name, time.perf_counter() - t)
    step.__name__ = name
    step.__doc__ = fn.__doc__
    return step


def prepare(c, gain_map, dark_map):
    """Side inputs the running blocks of context ``c`` take from the fixed pattern
    (``gain_map`` and ``dark_map`` of the rows each output pixel sums), into
    ``c.prepared`` (scene data fields, e.g. the ideal NUC coefficients)."""
    c.prepared = {}
    for r in ROWS:
        if r.sim.prepare is not None and c.ran(r.name):
            c.prepared.update(r.sim.prepare(c, gain_map, dark_map))


def _reset_taker(scene):
    """The :class:`~tdicam.blocks.steps.Sim` of the first block of ``[pipeline].blocks`` that
    takes reset frames (None: no such block)."""
    for name in scene.pipeline.blocks:
        for s in blocks.get(name).pipeline.sim.steps:
            if s.subtract is not None:
                return s
    return None


def subtract_reset(c, signal, reset, bits):
    """The reset-taking block's golden model on one frame and its reset frame."""
    return _reset_taker(c.scene).subtract(signal, reset, bits)


def pedestal(scene):
    """DN the reset-taking block's reset frames add to the ADC pedestal (0 without one)."""
    s = _reset_taker(scene)
    return s.pedestal(scene) if s is not None and s.pedestal is not None else 0.0


def takes_resets(c):
    """A block that subtracts the reset frames runs in context ``c``."""
    return any(c.ran(r.name) for r in ROWS if r.sim.subtract is not None)
