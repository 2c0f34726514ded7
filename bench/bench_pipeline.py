"""Benchmark: a scene's whole pipeline top in fast-mode co-simulation, input pixels/s.

    python bench/bench_pipeline.py [--scene scenes/orbit_600km_1m_96.toml] [--sim verilator]
                                   [--lines N] [--taps]

The scene's raw frames (an exact run of the scene simulator) go through the generated top
(:mod:`tdicam.pipeline`) without taps unless ``--taps``; the output is compared bit for bit
with the golden chain. Target (issue "the camera as one design"): >= 0.5 M input pixels/s
through the whole chain of the orbit scene (351 frames x 96 x 1280 = 43 M input pixels),
after the build (the build is timed apart; 0 s when cached under ``build/cosim``).
"""

import argparse
import os
import sys
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "orbit_600km_1m_96.toml"))
    ap.add_argument("--sim", default="verilator", choices=("verilator", "icarus"))
    ap.add_argument("--lines", type=int, help="output lines (default [run].lines)")
    ap.add_argument("--taps", action="store_true", help="write every block's output too")
    args = ap.parse_args(argv)

    from tdicam import pipeline as pl
    from tdicam.beats import frames_to_beats
    from tdicam.rtl import run_top, scene_data
    from tdicam.scene import load_scene

    sc = load_scene(args.scene)
    m = int(sc.tdi.stages[0])
    lines = int(args.lines or sc.run.lines)
    p = pl.plan(sc, stages=m, lines=lines)
    t = time.perf_counter()
    data, res = scene_data(sc, stages=m, dv_over_v=float(sc.motion.dv_over_v[0]),
                           lines=lines)
    t_scene = time.perf_counter() - t
    t = time.perf_counter()
    gold = pl.golden(p, data)
    t_gold = time.perf_counter() - t
    n_px = p.input_pixels * p.lane_elems
    c0 = os.times()
    got, info = run_top(p, data, args.sim, taps=args.taps)
    c1 = os.times()
    cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system)
    exp = frames_to_beats(gold[-1][2])
    out = got["out"]
    n = min(len(out), len(exp))
    bad = int((out.data[:n] != exp.data[:n]).any(axis=1).sum()) + abs(len(out) - len(exp))
    rate = n_px / info["run_seconds"]
    load = os.getloadavg()[0]
    chain = " -> ".join(s.block for s in p.steps)
    print(f"scene {Path(args.scene).name}: {chain}, {p.frames} frames x {p.rows} x "
          f"{p.width}, {p.lanes} channel(s) x {p.lane_elems} element(s)")
    print(f"{'step':34s} {'seconds':>9s}")
    print(f"{'scene raw data (exact engine)':34s} {t_scene:9.1f}")
    print(f"{'golden chain (numpy)':34s} {t_gold:9.1f}")
    print(f"{args.sim + ' build (0: cached)':34s} {info['build_seconds']:9.1f}")
    print(f"{args.sim + ' fast-mode run':34s} {info['run_seconds']:9.1f}")
    print(f"{'  its CPU time (simulator process)':34s} {cpu:9.1f}")
    print(f"input pixels {n_px:,}, cycles {info['cycles']:,}, output pixels compared "
          f"{n * out.data.shape[1]:,}, mismatches {bad}")
    print(f"input pixels/s after the build: {rate:,.0f} (target 500,000: "
          f"{'met' if rate >= 5e5 else 'NOT met'}); per CPU second of the simulator: "
          f"{n_px / max(cpu, 1e-9):,.0f}; taps {'on' if args.taps else 'off'}; "
          f"load average {load:.2f} on {os.cpu_count()} CPUs")
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
