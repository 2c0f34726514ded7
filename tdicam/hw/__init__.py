"""Hardware tools: Verilog generation, lint, synthesis, formal proofs, and the simulators'
setup.

:mod:`~tdicam.hw.verilog` (deterministic Verilog and RTLIL), :mod:`~tdicam.hw.lint`
(Verilator ``-Wall`` with its waivers), :mod:`~tdicam.hw.synth` (ECP5-85F with yosys and
nextpnr, xc7 cell counts), :mod:`~tdicam.hw.formal` and :mod:`tdicam.hw.proofs` (formal
proofs with SymbiYosys), :mod:`~tdicam.hw.tools` (Icarus and Verilator on ``PATH``).

Layer: above the blocks' registry. May import :mod:`tdicam.blocks`, :mod:`tdicam.hdl`,
:mod:`tdicam.model` and the leaves; imported by the co-simulation and everything above it.
"""
