"""Build times of the benchmarks: a co-simulation build timed from scratch in a folder of
its own (``tdicam bench --build fresh``), beside the cached builds the runs use."""

import shutil
import time

from tdicam import cosim

__all__ = ["fresh_build", "build_seconds"]


def fresh_build(name, params, sim, sources):
    """Seconds to build ``sources`` from scratch, in a folder of its own (not the cache)."""
    bdir = cosim.build_dir_for(f"{name}.bench", params, sim)
    shutil.rmtree(bdir / "sim", ignore_errors=True)
    (bdir / "stamp").unlink(missing_ok=True)
    t0 = time.perf_counter()
    cosim.build_sources(f"{name}.bench", params, sim, sources)
    return time.perf_counter() - t0


def build_seconds(first_build, build, name, params, sim, sources):
    """Build seconds to report: the first run's own build, else a fresh timed build."""
    if first_build > 0 or build != "fresh":
        return first_build
    return fresh_build(name, params, sim, sources())
