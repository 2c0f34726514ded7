"""Small helpers shared by the benchmarks in ``bench/`` and ``tdicam bench``."""

import os
import platform
import statistics
import time

from tdicam.paths import SCENES

__all__ = ["SCENE", "UNIT_ABBR", "machine", "median_time", "print_table", "row", "na_row",
           "scene_line_period"]

#: The scene of the scene-engine rows and of the real-time line (the orbit design point).
SCENE = SCENES / "orbit_600km_1m_96.toml"
#: Short unit names for tables and figures.
UNIT_ABBR = {"pixel": "px", "word": "word", "lane": "lane", "line": "line", "beat": "beat"}


def machine():
    """One line describing this machine and the tool versions."""
    import amaranth
    import cocotb
    import numpy
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, "
            f"numpy {numpy.__version__}, amaranth {amaranth.__version__}, "
            f"cocotb {cocotb.__version__}")


def median_time(fn, repeat=3):
    """Median wall time of ``fn()`` over ``repeat`` runs, and its last return value."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def print_table(rows, columns, title=None):
    """Print ``rows`` (dicts) as an aligned table of ``columns`` [(key, header, fmt)]."""
    if title:
        print(title)
    cells = [[h for _, h, _ in columns]]
    for r in rows:
        cells.append([("" if r.get(k) is None else format(r[k], f)) for k, _, f in columns])
    widths = [max(len(c[i]) for c in cells) for i in range(len(columns))]
    for n, c in enumerate(cells):
        print("  ".join(v.rjust(w) if i else v.ljust(w) for i, (v, w) in
                        enumerate(zip(c, widths))))
        if n == 0:
            print("  ".join("-" * w for w in widths))


def row(name, level, unit, units, seconds, **kw):
    """One row of a benchmark table: ``units`` of ``unit`` done in ``seconds`` by block
    ``name`` at ``level``; per-unit time and rate derived, other columns from ``kw``."""
    r = {"block": name, "level": level, "unit": unit, "units": int(units),
         "seconds": seconds, "per_unit_s": seconds / units if units and seconds else None,
         "rate": units / seconds if units and seconds else None, "x_ref": None,
         "x_beat": None, "accuracy": None, "mismatches": None, "build_s": None,
         "input": "", "note": ""}
    r.update(kw)
    return r


def na_row(name, level, unit, why):
    """A row that measured nothing: accuracy ``n/a``, ``why`` in its note."""
    return row(name, level, unit, 0, None, accuracy="n/a", note=why)


def scene_line_period():
    """Line period (s) of :data:`SCENE`: what real time means in the tables."""
    # (late: the scene reader is needed only by the figure and the scene rows)
    from tdicam.scene.loader import load_scene
    return load_scene(SCENE).line_period_s
