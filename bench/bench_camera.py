"""Benchmark: the whole camera of Ning et al. 2019 at full width through its generated top.

    python bench/bench_camera.py [--lines 8] [--columns N] [--lanes-per-gain L]
                                 [--sim verilator]

(``tdicam bench camera`` gives the 8- and 16-line cuts and the whole frame pair extrapolated
as rows of the benchmark table.)

The first ``--lines`` lines of scenes/ning2019_gmax0504_full.toml (all 5144 columns unless
``--columns``, both gains, each line a reset frame and a signal frame, the NAND scan and
coefficient load into DDR at power-up: :mod:`tdicam.bench.camera`) sent on the sensor's 80
lanes (``--lanes-per-gain`` for a narrower cut: the scene's 40 need >= 40 columns) through
the top on Verilator, every block's output compared bit for bit with the golden chain.
Target (issue 45): a full-width 8-line pair in <= 2 minutes wall after the build. (The
NAND simulation model holds 255 programmed pages: at most 22 lines of 5144 columns.)
"""

import argparse
import os
import time


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=8, help="lines of the cut (8)")
    ap.add_argument("--columns", type=int, help="a narrower sensor (default: the scene's)")
    ap.add_argument("--lanes-per-gain", type=int,
                    help="the sensor's lanes a gain for a narrower cut (default: the scene's)")
    ap.add_argument("--sim", default="verilator", choices=("verilator", "icarus"))
    args = ap.parse_args(argv)

    from tdicam.bench.camera import camera_run

    t0 = time.perf_counter()
    r = camera_run(args.lines, args.sim, columns=args.columns,
                   lanes_per_gain=args.lanes_per_gain)
    wall = time.perf_counter() - t0
    p, bad = r["plan"], r["mismatches"] + r["tap_mismatches"]
    print(f"{' -> '.join(r['blocks'])}: {p.width} columns x {args.lines} lines x {p.lanes} "
          f"gains (a reset and a signal frame a line), ppc {p.ppc}, {args.sim}")
    print(f"{'step':40s} {'seconds':>9s}")
    print(f"{args.sim + ' build (0: cached)':40s} {r['build_seconds']:9.1f}")
    print(f"{args.sim + ' run (simulator wall)':40s} {r['run_seconds']:9.1f}")
    print(f"{'the whole call, build excluded':40s} {wall - r['build_seconds']:9.1f}")
    print(f"cycles {r['cycles']:,} ({r['startup_cycles']:,} the NAND scan and load), "
          f"{r['cycles'] / r['run_seconds']:,.0f} cycles/s, input pixels {r['input_pixels']:,}, "
          f"output pixels compared {r['pixels_compared']:,}, taps {len(r['taps'])}, "
          f"mismatching beats {bad}: {r['message']}")
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
