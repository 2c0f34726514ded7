"""Benchmark: digital CDS throughput in the golden model and in co-simulation.

Prints pixels/s for the numpy golden model and for the generated Verilog co-simulated
per-beat and fast on Icarus and Verilator (1280-wide frames, 20 % idle and 20 %
backpressure in co-simulation; bit-exact comparison included in every row). Target on a
2-core machine: fast Verilator >= 500 k pixels/s and >= 10x per-beat Verilator.

    python bench/bench_cds.py [--rows 64] [--frames 8] [--repeat 3]
"""

import argparse

import numpy as np

from tdicam import blocks, cosim
from tdicam.benchutil import machine, median_time, print_table
from tdicam.cosim.codec import frames_to_beats
from tdicam.model.cds import cds


def _data(frames, rows, cols, bits=12, seed=1):
    rng = np.random.default_rng(seed)
    sig = rng.integers(0, 1 << bits, (frames, rows, cols), dtype=np.uint16)
    rst = rng.integers(0, 1 << bits, (frames, rows, cols), dtype=np.uint16)
    return sig, rst


def run(rows=64, cols=1280, frames=32, repeat=3, beat_frames=1, sims=cosim.SIMULATORS):
    """Rows of {engine, mode, pixels, seconds, pixels_s, mismatches}."""
    out = []
    sig, rst = _data(frames, rows, cols)
    t, ref = median_time(lambda: cds(sig, rst, pixel_bits=12), repeat)
    out.append({"engine": "numpy golden", "mode": "-", "pixels": sig.size, "seconds": t,
                "pixels_s": sig.size / t, "mismatches": 0, "build_s": None})
    params = blocks.get("cds").resolve({"pixel_bits": 12})
    for sim in sims:
        for mode, nf in (("beat", beat_frames), ("fast", frames)):
            stim = frames_to_beats(np.stack([sig[:nf], rst[:nf]], -1), channels=2)
            exp = frames_to_beats(ref[:nf])
            runs = []
            for k in range(repeat):
                res = cosim.run_stream("cds", params, stim, n_out=len(exp), sim=sim,
                                       mode=mode, idle=0.2, backpressure=0.2, seed=k + 1)
                runs.append(res)
            cmp = cosim.compare(runs[-1].out, exp)
            t = float(np.median([r.wall for r in runs]))
            out.append({"engine": sim, "mode": mode, "pixels": len(exp), "seconds": t,
                        "pixels_s": len(exp) / t, "mismatches": cmp.mismatches,
                        "build_s": max(r.build_time for r in runs),
                        "cycles": runs[-1].cycles})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=64)
    ap.add_argument("--frames", type=int, default=32)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    rows = run(rows=a.rows, frames=a.frames, repeat=a.repeat)
    print(machine())
    print_table(rows, [("engine", "engine", "s"), ("mode", "mode", "s"),
                       ("pixels", "pixels", "d"), ("seconds", "median s", ".3f"),
                       ("pixels_s", "pixels/s", ",.0f"), ("mismatches", "mismatches", "d"),
                       ("build_s", "build s", ".1f")],
                title=f"CDS, 1280 x {a.rows}, 12-bit; co-simulation with 20 % idle and "
                      f"20 % backpressure, medians of {a.repeat} runs (sim wall time incl. "
                      f"simulator start-up)")
    by = {(r["engine"], r["mode"]): r["pixels_s"] for r in rows}
    fv, bv = by[("verilator", "fast")], by[("verilator", "beat")]
    print(f"fast Verilator: {fv:,.0f} pixels/s (target >= 500,000: "
          f"{'met' if fv >= 5e5 else 'NOT met'}); {fv / bv:.1f}x per-beat Verilator "
          f"(target >= 10x: {'met' if fv >= 10 * bv else 'NOT met'})")


if __name__ == "__main__":
    main()
