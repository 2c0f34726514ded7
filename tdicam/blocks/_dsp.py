"""Shared parts of the entries of the lane-parallel multiplier blocks (``nuc``, ``hdr``): their
Verilog top and ECP5 synthesis top from one core class, and their golden model's parameters.
"""

from tdicam.hdl.interfaces.axis import AxisTop


def tops(core):
    """``(top, ecp5_top)`` of a block whose gateware is ``core(**params)``: the AXI4-Stream
    top of the generic description, and the ECP5 synthesis top, each lane's multiplier a
    MULT18X18D with its own input registers and the product register in the fabric
    (``core(**params, dsp="ecp5")``; the same ports, latency and cycles)."""
    def top(**params):
        return AxisTop(core(**params))

    def ecp5_top(**params):
        return AxisTop(core(**params, dsp="ecp5"))
    return top, ecp5_top


def model_params(params):
    """The golden model's parameters: the block's without ``ppc`` (the model does not know
    how many pixels a beat carries)."""
    return {k: v for k, v in params.items() if k != "ppc"}
