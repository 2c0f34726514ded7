"""Scene simulator speed: fast vs exact vs auto on the bundled orbit scene (W = 1280, m = 96).

Prints lines/s against the 6,908 lines/s real time of a 600 km / 1 m orbit, exposure-pixels/s
(m x W per output line), and the error of fast against exact (relative difference of the
output mean and standard deviation on the same scene and seed).

    python bench/bench_scene.py [--lines N]
"""

import argparse
from pathlib import Path

import numpy as np

from tdicam.bench.util import machine, print_table
from tdicam.engine import simulate
from tdicam.scene.loader import load_scene

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "orbit_600km_1m_96.toml"


def run(lines_fast=4096, lines_exact=64, repeat=3):
    """Rows: fidelity, lines, seconds, lines/s, x real time, exposure-pixels/s, error."""
    sc = load_scene(SCENE)
    real = 1.0 / sc.line_period_s
    rows = []
    outs = {}
    for fid, n in (("fast", lines_fast), ("auto", lines_fast), ("exact", lines_exact)):
        best = None
        for _ in range(repeat if fid != "exact" else 1):
            r = simulate(sc, fidelity=fid, lines=n, impact=False)
            if best is None or r.seconds < best.seconds:
                best = r
        outs[fid] = best
        rows.append({"fidelity": f"{fid} -> {best.fidelity}", "lines": n,
                     "seconds": best.seconds, "lines_s": best.lines_per_s,
                     "x_rt": best.lines_per_s / real,
                     "mexp_s": best.exposure_pixels_per_s / 1e6})
    # fast vs exact error on the same lines
    n = lines_exact
    ex = outs["exact"].output.astype(np.float64)
    fa = simulate(sc, fidelity="fast", lines=n, impact=False).output.astype(np.float64)
    for r in rows:
        if r["fidelity"].startswith("fast"):
            r["err_mean"] = abs(fa.mean() / ex.mean() - 1)
            r["err_std"] = abs(fa.std() / ex.std() - 1)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=4096)
    ap.add_argument("--exact-lines", type=int, default=64)
    a = ap.parse_args()
    print(machine())
    rows = run(a.lines, a.exact_lines)
    print_table(rows, [("fidelity", "fidelity", "s"), ("lines", "lines", "d"),
                       ("seconds", "s", ".3f"), ("lines_s", "lines/s", ".0f"),
                       ("x_rt", "x real time (6908/s)", ".2f"),
                       ("mexp_s", "M exposure-px/s", ".1f"),
                       ("err_mean", "fast-exact mean", ".2e"),
                       ("err_std", "fast-exact std", ".2e")],
                title=f"scene simulator, {SCENE.name}: W=1280, m=96")


if __name__ == "__main__":
    main()
