"""How many worker threads tdicam's numpy loops use (a leaf: imports only :mod:`tdicam.errors`).

The scene engine's block-parallel loops and the golden TDI model share one setting,
``TDICAM_THREADS``; no result depends on it.
"""

import os

from tdicam.errors import TdicamError

__all__ = ["threads", "MAX_THREADS"]

#: Most threads ``TDICAM_THREADS`` may ask for.
MAX_THREADS = 1024


def threads():
    """Worker threads of the block-parallel loops: ``TDICAM_THREADS`` or the CPU count (<= 4).

    The result never depends on it: every block of rows draws from its own generator.

    Raises
    ------
    TdicamError
        ``TDICAM_THREADS`` is not an integer in 1..:data:`MAX_THREADS`.
    """
    v = os.environ.get("TDICAM_THREADS")
    if v:
        try:
            n = int(v)
        except ValueError:
            n = 0
        if not 1 <= n <= MAX_THREADS:      # 0 or -3 used to run on 1 thread silently
            raise TdicamError(f"TDICAM_THREADS = {v!r}: must be an integer in "
                              f"1..{MAX_THREADS}")
        return n
    return max(1, min(os.cpu_count() or 1, 4))
