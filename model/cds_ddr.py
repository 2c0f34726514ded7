"""Golden model of ``cds_ddr``: digital CDS with the reset frame kept in DDR (Ning et al. 2019
§4.4.1 and §4.2; the gateware is :class:`tdicam.hdl.cds_ddr.CdsDdr`, its packing
:mod:`tdicam.model.ddr`, the memory model :mod:`tdicam.model.dram`)."""

import numpy as np

from tdicam.model.cds import cds, pixel_dtype

__all__ = ["cds_ddr_frames"]


def cds_ddr_frames(frames, kinds, *, pixel_bits=12):
    """Golden CDS with the reset frame from DDR (see :class:`tdicam.hdl.cds_ddr.CdsDdr`).

    ``frames`` (n, rows, width) with ``kinds[i]`` = 1 for a reset frame (stored, no output)
    and 0 for a signal frame (output ``max(signal - reset, 0)`` against the last stored
    reset frame; before any reset frame the reset level is 0). Returns (k, rows, width).
    """
    out, reset = [], None
    for fr, k in zip(frames, kinds):
        if int(k):
            reset = np.asarray(fr)
        else:
            r = np.zeros_like(fr) if reset is None else reset
            out.append(cds(fr, r, pixel_bits=pixel_bits))
    if not out:
        return np.zeros((0,) + np.asarray(frames).shape[1:], pixel_dtype(pixel_bits))
    return np.stack(out)
