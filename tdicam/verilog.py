"""Deterministic Verilog generation for registered blocks."""

from pathlib import Path

from amaranth.back import verilog as _verilog

from . import blocks

__all__ = ["generate", "write", "convert"]


def generate(block, params=None):
    """Verilog text of ``block``'s top with checked ``params``; top module named after it.

    Byte-identical for the same tool versions and parameters: no source locations
    (``emit_src=False``), hence no absolute paths.
    """
    blk = blocks.get(block) if isinstance(block, str) else block
    return convert(blk.build(params), blk.name)


def convert(top, name):
    """Verilog text of an elaboratable ``top`` as module ``name`` (deterministic)."""
    return _verilog.convert(top, name=name, emit_src=False, strip_internal_attrs=True)


def write(block, path, params=None):
    text = generate(block, params)
    Path(path).write_text(text)
    return text
