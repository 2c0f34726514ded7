"""Interfaces the blocks share: the pixel stream (:mod:`~tdicam.hdl.interfaces.stream`), the
AXI4-Stream Verilog top (:mod:`~tdicam.hdl.interfaces.axis`) and the MIG user interface
(:mod:`~tdicam.hdl.interfaces.mig`: its :class:`~tdicam.hdl.interfaces.mig.MigSignature`, whose
members the DDR blocks carry flat so their Verilog ports stay ``app_*``)."""
