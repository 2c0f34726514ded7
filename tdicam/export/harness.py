"""A block's export folder (``tdicam export BLOCK``) with the harness that checks it: the
stream testbench of :mod:`tdicam.export.block` for a video-stream block, or a harness of the
block's own (:attr:`tdicam.blocks.Block.harness`, :data:`HARNESSES`: the LVDS receiver's link
testbench, :mod:`tdicam.export.lvds`).
"""

from __future__ import annotations

from pathlib import Path

from tdicam import blocks
from tdicam.export.block import (MAX_BEATS, Export, check_target, content_size, design_files,
                                 golden_params, stream_export, write_design)
from tdicam.export.lvds import lvds_export

__all__ = ["HARNESSES", "export_block"]

#: How a block with a harness of its own (:attr:`tdicam.blocks.Block.harness`) is exported,
#: by that harness: ``make(blk, params, *, seed, idle, backpressure, max_beats)`` -> (Design,
#: case names, stimulus count, expected count). ``"link"``: the LVDS link testbench.
HARNESSES = {"link": lvds_export}


def export_block(block, params, out_dir, *, force=False, seed=1, idle=0.1, backpressure=0.1,
                 max_beats=MAX_BEATS, say=None):
    """Write the export folder of ``block`` at ``params`` (raw values, checked here; none:
    :func:`golden_params`).

    Stream blocks get the fast-mode testbench of :mod:`tdicam.cosim.tbgen`; a block with
    its own harness (:data:`HARNESSES`) gets that harness's self-checking form.

    ``say(text)``, when given, is told the export's size (beats, files, bytes) before
    anything is written.

    Raises :class:`TdicamError` for an unknown block or parameter, parameters without
    golden vectors, an output folder that cannot be written, or one that already holds a
    different export (unless ``force``).
    """
    blk = blocks.get(block) if isinstance(block, str) else block
    params = blk.resolve(params) if params else golden_params(blk)
    out = Path(out_dir)
    check_target(out, blk.name, params, force)
    make = stream_export if blk.harness is None else HARNESSES[blk.harness]
    extra = {"say": say} if make is stream_export else {}
    d, cases, n_in, n_out = make(blk, params, seed=seed, idle=idle, backpressure=backpressure,
                                 max_beats=max_beats, **extra)
    if say is not None:
        size = sum(content_size(t) for t in design_files(d).values())
        say(f"export: {n_in:,} input beats, {n_out:,} expected beats, "
            f"{len(d.vectors)} vector file(s), {size / 1e6:.1f} MB in all")
    files = write_design(d, out, force=force)
    return Export(out, blk.name, params, cases, n_in, n_out, files)
