"""``tdicam export``: a block, the LVDS link or a scene's whole chain for the user's own flow.

:mod:`~tdicam.export.harness` writes a block's export folder with its harness:
:mod:`~tdicam.export.block` a block's Verilog, a self-checking Verilog-2005 testbench
with its golden vectors, a FuseSoC core and a README; :mod:`~tdicam.export.lvds` the link
testbench of the LVDS receiver; :mod:`~tdicam.export.chain` a scene's pipeline top with the
scene's raw frames in and the golden chain's output expected.

Layer: a service. May import :mod:`tdicam.chain`, the simulation and hardware tools and
everything below them; imported by the commands and the benchmarks.
"""
