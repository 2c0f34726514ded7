"""numpy models (installed as ``tdicam.model``).

The block models, one module per block named as the block (``cds``, ``tdi``, ``median3``,
...), are bit-exact integer golden models: every width, rounding and saturation is stated in
their docstrings, and the gateware equals them bit for bit. :mod:`tdicam.model.chain` runs a
scene's chain of them. :mod:`tdicam.model.physics` holds the planning physics (orbit, optics,
sensor, SNR, MTF, memory, targets), which are floating-point models of the camera, not of
the gateware.

Layer: above the leaves (:mod:`tdicam.errors`, :mod:`tdicam.files`, :mod:`tdicam.threads`);
imports nothing else of tdicam.
"""
