"""Benchmark: a scene's whole pipeline top in fast-mode co-simulation, input pixels/s.

    python bench/bench_pipeline.py [--scene scenes/orbit_chain.toml] [--sim verilator]
                                   [--ppc N] [--lines N] [--taps]

(``tdicam bench pipeline`` gives the same run at ppc 1 and 8 as rows of the benchmark table.)

The scene's raw frames (an exact run of the scene simulator) go through the generated top
(:mod:`tdicam.chain.design`) without taps unless ``--taps``, at ``--ppc`` pixels per clock
(default: the scene's ``[run.rtl].pixels_per_clock``); the output is compared bit for bit
with the golden chain. Target (issue "the camera at its sensor's rate"): >= 8 M input
pixels per wall second through the whole orbit chain scene (127 frames x 96 x 1280 = 15.6 M
input pixels) at ppc 8 on Verilator, after the build (the build is timed apart; 0 s when
cached under ``build/cosim``).
"""

import argparse
import os
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "orbit_chain.toml"))
    ap.add_argument("--sim", default="verilator", choices=("verilator", "icarus"))
    from tdicam.beats import PPC_CHOICES
    ap.add_argument("--ppc", type=int, choices=PPC_CHOICES,
                    help="pixels per clock (default: the scene's)")
    ap.add_argument("--lines", type=int, help="output lines (default [run].lines)")
    ap.add_argument("--taps", action="store_true", help="write every block's output too")
    args = ap.parse_args(argv)

    from tdicam.bench.chain import TARGET_PX_S, pipeline_run

    r = pipeline_run(args.scene, sim=args.sim, lines=args.lines, taps=args.taps, ppc=args.ppc)
    n_px, bad = r["input_pixels"], r["mismatches"]
    rate = n_px / r["run_s"]
    load = os.getloadavg()[0]
    print(f"scene {Path(args.scene).name}: {' -> '.join(r['chain'])}, {r['frames']} frames "
          f"x {r['rows']} x {r['width']}, {r['lanes']} channel(s) x {r['lane_elems']} "
          f"element(s), {r['ppc']} pixel(s) per clock")
    print(f"{'step':34s} {'seconds':>9s}")
    print(f"{'scene raw data (exact engine)':34s} {r['scene_s']:9.1f}")
    print(f"{'golden chain (numpy)':34s} {r['golden_s']:9.1f}")
    print(f"{args.sim + ' build (0: cached)':34s} {r['build_s']:9.1f}")
    print(f"{args.sim + ' fast-mode run':34s} {r['run_s']:9.1f}")
    print(f"{'  its CPU time (simulator process)':34s} {r['cpu_s']:9.1f}")
    print(f"input pixels {n_px:,}, cycles {r['cycles']:,}, output pixels compared "
          f"{r['compared']:,}, mismatches {bad}")
    print(f"input pixels/s after the build: {rate:,.0f} (target {TARGET_PX_S:,}: "
          f"{'met' if rate >= TARGET_PX_S else 'NOT met'}); per CPU second of the simulator: "
          f"{n_px / max(r['cpu_s'], 1e-9):,.0f}; taps {'on' if args.taps else 'off'}; "
          f"load average {load:.2f} on {os.cpu_count()} CPUs")
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
