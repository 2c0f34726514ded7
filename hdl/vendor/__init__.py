"""Vendor primitives the generic description cannot reach: the ECP5 DP16KD block RAM with its
output register (:mod:`~tdicam.hdl.vendor.ecp5_bram`), used by ``tdicam synth``'s ECP5 tops."""
