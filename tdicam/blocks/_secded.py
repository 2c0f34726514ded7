"""What the SECDED blocks (``secded_enc``, ``secded_dec``) share: the ``registered`` and
``stream`` parameters and the byte-lane beats of 64-bit words (Ning et al. 2019 §4.3).

Both blocks are plain-port components (``data``/``code``/flags) for ``tdicam verilog``;
with ``--stream 1`` the same core is wrapped on AXI4-Stream byte lanes, which is what the
golden cases and the co-simulation use.
"""

import numpy as np

from tdicam.blocks import Param

__all__ = ["PARAMS", "markers", "word_bytes"]

PARAMS = (
    Param("registered", False, "add one output register to the core (latency +1)", type=bool),
    Param("stream", False, "wrap the core on AXI4-Stream byte lanes (co-simulation, stream "
                           "designs) instead of plain data/code/flag ports", type=bool),
)


def markers(n, line=16):
    """(first, last) of ``n`` word beats: ``first`` on word 0, ``last`` every ``line``
    words and on the final one."""
    idx = np.arange(n)
    return idx == 0, (idx % line == line - 1) | (idx == n - 1)


def word_bytes(words, nbytes):
    """(n, nbytes) bytes of ``words``, least significant first."""
    w = np.asarray(words, np.uint64)
    return np.stack([(w >> np.uint64(8 * k)) & np.uint64(0xFF) for k in range(nbytes)], axis=1)
