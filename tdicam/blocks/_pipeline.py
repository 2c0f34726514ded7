"""What the pipeline entries of the blocks (:class:`tdicam.blocks.Use`) share: the
pipeline-top stage of a block's registered component."""

__all__ = ["lane_stage"]


def lane_stage(kind="lane", elems=1, side=None, out_slice=False):
    """``Use.hw`` of a block: a :class:`~tdicam.hdl.chain_top.LaneStage` (``kind="merge"``:
    :class:`~tdicam.hdl.chain_top.MergeStage`) of the core of the block's registered Verilog
    top (``ecp5``: of its ECP5 synthesis top, :attr:`tdicam.blocks.Block.ecp5_top`, when it
    has one); ``side(step, data)`` gives its joined side stream; ``out_slice``: its output
    is not registered, a register slice follows it in the chain."""
    def make(step, data, *, ecp5=False):
        from tdicam.hdl.chain_top import LaneStage, MergeStage
        comp = _component(step, ecp5)
        stage = MergeStage if kind == "merge" else LaneStage
        return stage(step.block, lambda lane: comp(),
                     elems=elems, ports=tuple(step.ports),
                     side=None if side is None else side(step, data),
                     group="height" if step.group is not None else None,
                     out_slice=out_slice)
    return make


def _component(step, ecp5=False):
    """The core (behind AxisTop) of the block's registered Verilog top (``ecp5``: its ECP5
    synthesis top when it has one)."""
    from tdicam.blocks import get
    blk = get(step.block)
    blk.resolve(step.params)    # checked now, not when the stage is elaborated

    def make():
        wrapper = blk.build(step.params, ecp5=ecp5)
        wrapper._MustUse__silence = True   # only its core is used
        wrapper.core._MustUse__silence = True   # elaborated with the pipeline, if it is
        return wrapper.core
    return make
