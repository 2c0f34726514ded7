"""A scene's chain as one design: its ``[pipeline]`` as one gateware top, its golden chain,
and the whole-scene co-simulation of the one against the other.

:mod:`~tdicam.chain.design` turns a scene into a :class:`~tdicam.blocks.steps.ChainPlan` (its
blocks in order) and builds the Verilog top, the golden chain's output and the stimulus;
:mod:`~tdicam.chain.cosim` co-simulates a scene (or a crop) through that top and names the
first block, frame, line and column that differ.

Layer: above the simulation and hardware tools. May import :mod:`tdicam.engine`,
:mod:`tdicam.scene`, the tools, the blocks' registry and everything below them.
"""
