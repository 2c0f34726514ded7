"""The camera as one design: a scene's ``[pipeline]`` as one gateware top, its golden chain,
and the whole-scene co-simulation of the one against the other.

:mod:`~tdicam.camera.design` turns a scene into a plan of blocks and builds the Verilog top,
the golden chain's output and the stimulus; :mod:`~tdicam.camera.cosim` co-simulates a scene
(or a crop) through that top and names the first block, frame, line and column that differ.

Layer: above the simulation and hardware tools. May import :mod:`tdicam.engine`,
:mod:`tdicam.scene`, the tools, the blocks' registry and everything below them.
"""
