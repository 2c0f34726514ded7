"""Benchmark of the LVDS receiver co-simulation: lanes trained per second, words per second.

``python bench/bench_lvds.py [--sim verilator|icarus|both] [--lanes N] [--words N]``

Rows: the golden model (Python), and the generated Verilog (8-lane DUT, lanes simulated in
groups of 8 in one simulator run, link evaluated in the HDL testbench) on each simulator.
"Trained" runs only the training (32 taps + decide + bitslip search, n_check = 16);
"data" runs the training and then ``--words`` words per lane, every output word dumped and
compared with the link model. Simulator build time is excluded (reported separately).
"""

import argparse
import os
import platform
import time

import numpy as np

from tdicam.cosim.lvds import check_run, run_link
from tdicam.model import lvds

__all__ = ["run", "main"]


def _link(n, seed, words, n_check):
    rng = np.random.default_rng(seed)
    lanes = [lvds.random_lane(rng, max_word_delay=1) for _ in range(n)]
    tw = lvds.training_words(10, n_check, 8)
    if words:
        nd = tw + 16
        return lvds.Link(lanes, line_words=64, schedule=((nd, "data"),)), nd + words + 16
    return lvds.Link(lanes), tw + 8


def run(sims=("verilator",), lanes=256, words=20_000, data_lanes=64, n_check=16):
    """Benchmark rows (dicts): what, simulator, lanes, words per lane, wall s, rates."""
    rows = []
    link, cycles = _link(lanes, 1, 0, n_check)
    t0 = time.perf_counter()
    lvds.run(link, cycles=cycles, n_check=n_check)
    wall = time.perf_counter() - t0
    rows.append({"what": "train", "sim": "golden (numpy)", "lanes": lanes, "words": 0,
                 "cycles": 0, "wall_s": wall, "lanes_per_s": lanes / wall,
                 "words_per_s": 0.0, "cycles_per_s": 0.0, "build_s": 0.0, "ok": True})
    for sim in sims:
        for what, n, w in (("train", lanes, 0), ("data", data_lanes, words)):
            link, cycles = _link(n, 2, w, n_check)
            gold = lvds.run(link, cycles=cycles, n_check=n_check)
            res = run_link(link, cycles=cycles, n_check=n_check, sim=sim)
            ok = not check_run(link, res, gold, cycles=cycles)
            delivered = sum(len(o[0]) * int(np.count_nonzero(o[2].any(axis=0)))
                            for o in res.outputs)
            dut_cycles = res.groups * cycles
            rows.append({"what": what, "sim": sim, "lanes": n, "words": w,
                         "cycles": dut_cycles, "wall_s": res.wall,
                         "lanes_per_s": n / res.wall, "words_per_s": delivered / res.wall,
                         "cycles_per_s": dut_cycles / res.wall, "build_s": res.build_time,
                         "ok": ok})
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim", default="verilator", choices=("verilator", "icarus", "both"))
    ap.add_argument("--lanes", type=int, default=256)
    ap.add_argument("--data-lanes", type=int, default=64)
    ap.add_argument("--words", type=int, default=20_000)
    args = ap.parse_args(argv)
    sims = ("verilator", "icarus") if args.sim == "both" else (args.sim,)
    rows = run(sims, lanes=args.lanes, words=args.words, data_lanes=args.data_lanes)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"machine: {platform.machine()} {platform.processor() or ''} "
          f"{os.cpu_count()} cores, Python {platform.python_version()}, "
          f"load average {load:.1f}")
    print(f"{'what':6s} {'simulator':15s} {'lanes':>6s} {'words/lane':>10s} {'DUT cycles':>10s} "
          f"{'wall s':>7s} {'lanes/s':>8s} {'words/s':>10s} {'cycles/s':>9s} {'build s':>7s} "
          f"{'check':>5s}")
    for r in rows:
        print(f"{r['what']:6s} {r['sim']:15s} {r['lanes']:6d} {r['words']:10d} "
              f"{r['cycles']:10d} {r['wall_s']:7.2f} {r['lanes_per_s']:8.1f} "
              f"{r['words_per_s']:10.0f} {r['cycles_per_s']:9.0f} {r['build_s']:7.1f} "
              f"{'ok' if r['ok'] else 'FAIL':>5s}")
    return 0 if all(r["ok"] for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
