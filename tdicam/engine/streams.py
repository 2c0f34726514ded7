"""Random numbers, worker threads and timing of the scene simulator — in one place.

Every random draw of a run comes from a generator named by its stream: a fixed stream per
effect, so disabling one effect never changes another's random numbers. Whole-pass streams
(:func:`stream`) serve the fixed pattern and the charge-domain loop; the chunk-parallel loops
draw chunk ``j`` of stage ``s`` from :func:`chunk_rng` ``(seed, stream, s, j)``, so their
output does not depend on the thread count or timing (numpy's Generator releases the GIL
while it fills an array, so chunks run on :func:`threads` threads through
:func:`run_chunks`).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from tdicam.threads import threads

__all__ = ["STREAMS", "CHUNK_PIXELS", "stream", "chunk_rng", "threads", "run_chunks", "Timer"]

#: Fixed random stream of each use: disabling one effect never changes another's numbers.
STREAMS = {"fpn_prnu": 1, "fpn_dsnu": 2, "shot": 3, "read": 4, "read_reset": 5, "quant": 6,
           "read_lg": 7, "read_reset_lg": 8}
#: Pixels per random-number chunk of the chunk-parallel loops (rows = this // width).
CHUNK_PIXELS = 1 << 16


def stream(seed, name):
    """The whole-pass generator of stream ``name``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), STREAMS[name]]))


def chunk_rng(seed, name, stage, chunk):
    """The generator of stream ``name`` for chunk ``chunk`` of stage ``stage``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(
        [int(seed), STREAMS[name], int(stage), int(chunk)])))


class Timer:
    """Seconds spent per effect (and ``render``, ``raw_exposure``) in one pass."""

    def __init__(self):
        self.t = {}

    def add(self, name, dt):
        self.t[name] = self.t.get(name, 0.0) + dt

    def merge(self, times):
        for name, v in times.items():
            self.add(name, v)


def run_chunks(fn, args, timer, progress, work_of):
    """``fn(*a)`` for every ``a`` in ``args`` on :func:`threads` threads; each returns
    ``{effect: seconds}``. Timings and progress are collected in order, here."""
    n_thr = min(threads(), len(args))
    pool = ThreadPoolExecutor(n_thr) if n_thr > 1 else None
    try:
        done = pool.map(lambda a: fn(*a), args) if pool is not None \
            else (fn(*a) for a in args)
        for a, dt in zip(args, done):
            timer.merge(dt)
            if progress is not None:
                progress(work_of(*a))
    finally:
        if pool is not None:
            pool.shutdown()
