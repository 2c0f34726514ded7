"""How many worker threads tdicam's numpy loops use (a leaf: imports only :mod:`tdicam.errors`).

The scene engine's block-parallel loops and the golden TDI model share one setting,
``TDICAM_THREADS``; no result depends on it.
"""

import os

from tdicam.errors import TdicamError

__all__ = ["threads"]


def threads():
    """Worker threads of the block-parallel loops: ``TDICAM_THREADS`` or the CPU count (<= 4).

    The result never depends on it: every block of rows draws from its own generator.

    Raises
    ------
    TdicamError
        ``TDICAM_THREADS`` is not an integer >= 1.
    """
    v = os.environ.get("TDICAM_THREADS")
    if v:
        try:
            return max(1, int(v))
        except ValueError:
            raise TdicamError(f"TDICAM_THREADS = {v!r}: must be an integer >= 1") from None
    return max(1, min(os.cpu_count() or 1, 4))
