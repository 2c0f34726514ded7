"""Amaranth gateware (installed as ``tdicam.hdl``): one module per block, named as the block.

Besides the blocks (``cds``, ``tdi``, ``median3``, ...): :mod:`tdicam.hdl.interfaces` (the
pixel stream, the AXI4-Stream top, the MIG user interface), :mod:`tdicam.hdl.simmodels`
(simulation-only models: the DDR controller behind the MIG interface),
:mod:`tdicam.hdl.vendor` (vendor primitives: ECP5 DP16KD block RAM), :mod:`tdicam.hdl.util`
(small gateware helpers) and a scene's chain of blocks as one top: :mod:`tdicam.hdl.chain_top`
(the stages and the top), :mod:`tdicam.hdl.chain_links` (the streams between them),
:mod:`tdicam.hdl.calib_rom` (the on-chip calibration ROM), :mod:`tdicam.hdl.chain_board` (the
top with its external parts' simulation models).

Layer: above :mod:`tdicam.model` (the gateware takes its parameter checks and constants from
the golden models) and the leaves; imports nothing else of tdicam.
"""
