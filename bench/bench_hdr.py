"""Benchmark: HG/LG HDR merge throughput, golden model and co-simulation.

Prints pixels/s for the numpy golden model and for the generated Verilog co-simulated fast
(and per-beat) on Verilator and Icarus: 1280-wide frames of a noisy light ramp (so every
frame has band pixels and the next frame starts with a division), 12-bit HG/LG, default
parameters, 20 % idle and 20 % backpressure; every co-simulation row is compared bit for
bit with the golden model.

    python bench/bench_hdr.py [--rows 64] [--frames 4] [--repeat 3] [--sims verilator,icarus]
"""

import argparse
import os

import numpy as np

from tdicam import blocks, cosim
from tdicam.benchutil import machine, median_time, print_table
from tdicam.blocks.hdr import scene_frames
from tdicam.cosim.codec import frames_to_beats
from tdicam.model.hdr import hdr, hdr_config


def run(rows=64, cols=1280, frames=4, repeat=3, beat_frames=1, sims=cosim.SIMULATORS,
        beat=True):
    """Rows of {engine, mode, pixels, seconds, pixels_s, mismatches, build_s, cycles}."""
    out = []
    hg, lg = scene_frames(hdr_config(), np.random.default_rng(1), frames, rows, cols)
    hg, lg = hg.astype(np.uint16), lg.astype(np.uint16)
    t, ref = median_time(lambda: hdr(hg, lg), repeat)
    out.append({"engine": "numpy golden", "mode": "-", "pixels": hg.size, "seconds": t,
                "pixels_s": hg.size / t, "mismatches": 0, "build_s": None})
    params = blocks.get("hdr").resolve({})
    modes = (("fast", frames),) + ((("beat", beat_frames),) if beat else ())
    for sim in sims:
        for mode, nf in modes:
            stim = frames_to_beats(np.stack([hg[:nf], lg[:nf]], -1), channels=2)
            exp = frames_to_beats(ref[:nf])
            runs = [cosim.run_stream("hdr", params, stim, n_out=len(exp), sim=sim, mode=mode,
                                     idle=0.2, backpressure=0.2, seed=k + 1)
                    for k in range(repeat)]
            cmp = cosim.compare(runs[-1].out, exp)
            t = float(np.median([r.wall for r in runs]))
            out.append({"engine": sim, "mode": mode, "pixels": len(exp), "seconds": t,
                        "pixels_s": len(exp) / t, "mismatches": cmp.mismatches,
                        "build_s": max(r.build_time for r in runs), "cycles": runs[-1].cycles})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=64)
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sims", default=",".join(cosim.SIMULATORS))
    ap.add_argument("--no-beat", action="store_true", help="skip the per-beat rows")
    a = ap.parse_args(argv)
    rows = run(rows=a.rows, frames=a.frames, repeat=a.repeat, sims=a.sims.split(","),
               beat=not a.no_beat)
    print(machine())
    print("load average (1/5/15 min) at the end: %.1f %.1f %.1f" % os.getloadavg())
    print_table(rows, [("engine", "engine", "s"), ("mode", "mode", "s"),
                       ("pixels", "pixels", "d"), ("seconds", "median s", ".3f"),
                       ("pixels_s", "pixels/s", ",.0f"), ("mismatches", "mismatches", "d"),
                       ("build_s", "build s", ".1f")],
                title=f"hdr, 1280 x {a.rows} x {a.frames} frames, 12-bit HG/LG, default "
                      f"parameters; co-simulation with 20 % idle and 20 % backpressure, "
                      f"medians of {a.repeat} runs (sim wall time incl. simulator start-up)")


if __name__ == "__main__":
    main()
