"""cocotb test modules the package runs inside the simulator (not pytest tests).

:func:`tdicam.cosim.run_cocotb` names them by their dotted path (``tdicam.simtb.<name>``):
``stream_tb`` (every stream block, per-beat and fast mode), ``ddr_tb`` (the bare DDR user
interface against :class:`~tdicam.model.dram.MigSim`), ``lvds_tb`` (the LVDS link testbench).
A package of its own, outside :mod:`tdicam.cosim`, so that the simulator's Python imports
only what a test module needs (fast mode: cocotb alone, no numpy or Amaranth).

Layer: above :mod:`tdicam.cosim` (it reads the stimulus codec and the idle/backpressure
generator); nothing in tdicam imports it.
"""
