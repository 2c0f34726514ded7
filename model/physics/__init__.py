"""Planning physics, from the papers the design follows: orbit and line rate (Qu et al. 2010),
MTF (Yuan et al. 2013), SNR (Tao et al. 2012), sensor and optics, memory, targets and image
metrics. Floating-point models of the camera; the bit-exact block models are in
:mod:`tdicam.model`."""
