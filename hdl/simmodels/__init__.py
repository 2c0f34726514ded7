"""Gateware that exists only in simulation: the DDR3 controller model behind the MIG user
interface (:mod:`~tdicam.hdl.simmodels.mig_model`). Never part of a synthesized design."""
