"""Shared parts of the entries' scene-simulator steps (:class:`tdicam.blocks.steps.Sim`): a
block's parameters in the engine's run context and its golden model on scene arrays, both
through the block's own entry."""

from tdicam.blocks.steps import RunView, StepContext
from tdicam.errors import TdicamError


def golden(block, arrays, params):
    """Output of ``block``'s (a :class:`tdicam.blocks.Block`) golden function on scene
    ``arrays``."""
    return block.run_golden(arrays, block.resolve(params))["out"]


def step(c: RunView, block, bits, width, *, after_lines=False):
    """``block``'s :class:`~tdicam.blocks.steps.Step` in the engine's run context ``c`` for
    ``bits``-bit input pixels, ``width`` wide: its entry's scene-to-parameters function
    (:attr:`tdicam.blocks.Use.step`)."""
    ctx = StepContext(scene=c.scene, m=c.m, width=width, lines=0, bits=bits,
                      after_lines=after_lines, block=block.name)
    return block.pipeline.step(ctx)[0]


def check_bits(block, bits, lo, hi, key):
    """Refuse ``bits``-bit pixels outside ``lo..hi`` for ``block``'s golden model, naming the
    scene ``key`` that sets them."""
    if not lo <= bits <= hi:
        raise TdicamError(f"{key}: the {block.name} golden model takes {lo}..{hi}-bit pixels, "
                          f"this chain gives it {bits}-bit pixels")
