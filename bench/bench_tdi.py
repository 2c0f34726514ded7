"""Benchmark: TDI accumulator, golden model against real time, and co-simulation speed.

For the paper's camera (Qu et al. 2010: 1280 wide, 96 stages, 12-bit, 1 m GSD from 600 km, i.e.
6,908 lines/s): golden-model lines/s of the three structures and of the beat-level model
(target: the fast model >= 2x real time), and co-simulation input pixels/s of the generated
Verilog on Icarus and Verilator, per-beat (a third of a frame) and fast (98 frames, the
fewest that give output), at 1, 2, 4 and 8 pixels per clock (targets: fast Verilator >=
1.0 M pixels/s at ppc = 1 and >= 3.5 M at ppc = 8). Every co-simulation row is compared bit
for bit with the golden model (10 % idle, 10 % backpressure).

    python bench/bench_tdi.py [--frames 1000] [--repeat 3] [--sims icarus,verilator]
                              [--ppc 1,2,4,8] [--icarus-fast-ppc 4,8]
"""

import argparse
import time

import numpy as np

from tdicam import blocks, cosim
from tdicam.bench.util import machine, median_time, print_table
from tdicam.blocks.tdi import pack_ctrl, stream_arrays
from tdicam.cosim.codec import Beats
from tdicam.model.physics.plan import orbit_line_period
from tdicam.model.tdi import tdi, tdi_basic, tdi_optimized, tdi_stream


W, M, BITS = 1280, 96, 12
#: Fast-mode Verilator input pixels/s each ppc must reach (10 % idle, 10 % backpressure).
FAST_TARGETS = {1: 1_000_000, 8: 3_500_000}


def real_time_lines_s(altitude_m=600e3, gsd_m=1.0):
    """Line rate a push-broom camera needs: 1 / T1 (Qu et al. 2010 eqs 4-5)."""
    return 1.0 / float(orbit_line_period(altitude_m, gsd_m))


def _frames(n, seed=1):
    rng = np.random.default_rng(seed)
    return rng.integers(0, 1 << BITS, (n, M, W), dtype=np.uint16)


def golden_rows(frames=1000, repeat=3):
    """Golden-model rows: lines/s of each implementation."""
    rows = []
    f = _frames(frames)
    rt = real_time_lines_s()

    def row(name, fn, nf):
        sub = f[:nf]
        t, out = median_time(lambda: fn(sub), repeat)
        n = nf - M + 1
        assert len(out) == n
        # lines/s counts output lines only (the first m-1 frames give none): conservative;
        # frames/s is the steady-state line rate of the frame-recursive structures
        rows.append({"engine": name, "mode": f"{nf} frames", "lines": n, "seconds": t,
                     "lines_s": n / t, "frames_s": nf / t, "x_real_time": n / t / rt,
                     "pixels_s": nf * M * W / t})

    row("numpy tdi (eq 3, blocks)", lambda x: tdi(x, pixel_bits=BITS), frames)
    row("optimized m-1 lines", lambda x: tdi_optimized(x, pixel_bits=BITS), min(frames, 160))
    row("basic m(m-1)/2 lines", lambda x: tdi_basic(x, pixel_bits=BITS), min(frames, 160))
    nf = min(frames, 200)
    a = stream_arrays(list(f[:nf]), [(M, 0)] * nf, {"width": W, "ppc": 1, "pixel_bits": BITS})
    row("beat-level tdi_stream",
        lambda x: tdi_stream(a["pixels"], a["first"], a["last"], M, 0, width=W, stages=M,
                             pixel_bits=BITS).data.reshape(-1, W), nf)
    return rows


def _stream(ppc, n_frames, seed=2):
    """Stimulus and expected beats: ``n_frames`` random frames (whole or fractional)."""
    whole = int(np.ceil(n_frames))
    f = list(_frames(whole, seed))
    a = stream_arrays(f, [(M, 0)] * whole, {"width": W, "ppc": ppc, "pixel_bits": BITS})
    n = int(round(n_frames * M * W / ppc))
    a = {k: v[:n] for k, v in a.items()}
    res = tdi_stream(a["pixels"], a["first"], a["last"], M, 0, width=W, stages=M,
                     pixel_bits=BITS, ppc=ppc)
    stim = Beats(a["pixels"], a["first"], a["last"],
                 ctrl=pack_ctrl(a["stages_active"], a["direction"]))
    return stim, Beats(res.data, res.first, res.last)


def cosim_rows(sims=cosim.SIMULATORS, ppcs=(1, 2, 4, 8), icarus_fast_ppc=(4, 8),
               beat_frames=1 / 3, fast_frames=98, repeat=1):
    rows = []
    for ppc in ppcs:
        params = blocks.get("tdi").resolve({"width": W, "stages": M, "pixel_bits": BITS,
                                            "ppc": ppc})
        for sim in sims:
            modes = [("beat", beat_frames)] if ppc == 1 else []
            if sim == "verilator" or ppc in icarus_fast_ppc:
                modes.append(("fast", fast_frames))
            for mode, nf in modes:
                stim, exp = _stream(ppc, nf)
                runs = []
                for k in range(repeat):
                    t0 = time.perf_counter()
                    res = cosim.run_stream("tdi", params, stim, n_out=len(exp), sim=sim,
                                           mode=mode, idle=0.1, backpressure=0.1, seed=k + 1)
                    res.total = time.perf_counter() - t0
                    runs.append(res)
                cmp = cosim.compare(runs[-1].out, exp)
                wall = float(np.median([r.wall for r in runs]))
                pixels = len(stim) * ppc
                rows.append({"engine": sim, "mode": mode, "ppc": ppc, "pixels": pixels,
                             "beats": len(stim), "out_lines": len(exp) * ppc // W,
                             "seconds": wall, "pixels_s": pixels / wall,
                             "beats_s": len(stim) / wall, "mismatches": cmp.mismatches,
                             "build_s": max(r.build_time for r in runs),
                             "total_s": float(np.median([r.total for r in runs])),
                             "cycles": runs[-1].cycles})
    return rows


def run(frames=1000, repeat=3, sims=cosim.SIMULATORS, ppcs=(1, 2, 4, 8),
        icarus_fast_ppc=(4, 8)):
    """All rows: golden model then co-simulation."""
    return golden_rows(frames, repeat) + cosim_rows(sims, ppcs, icarus_fast_ppc)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sims", default=",".join(cosim.SIMULATORS))
    ap.add_argument("--ppc", default="1,2,4,8")
    ap.add_argument("--icarus-fast-ppc", default="4,8",
                    help="ppc values run fast on Icarus (ppc 1 takes minutes)")
    a = ap.parse_args(argv)
    ppcs = tuple(int(x) for x in a.ppc.split(",") if x)
    ifp = tuple(int(x) for x in a.icarus_fast_ppc.split(",") if x)
    sims = tuple(s for s in a.sims.split(",") if s)
    rt = real_time_lines_s()
    g = golden_rows(a.frames, a.repeat)
    print(machine())
    print_table(g, [("engine", "golden model", "s"), ("mode", "input", "s"),
                    ("lines", "lines", "d"), ("seconds", "median s", ".3f"),
                    ("lines_s", "lines/s", ",.0f"), ("x_real_time", "x real time", ".2f"),
                    ("frames_s", "frames/s", ",.0f"), ("pixels_s", "input pixels/s", ",.0f")],
                title=f"TDI golden model, {W} x {M} stages, {BITS}-bit; real time = "
                      f"{rt:,.0f} lines/s (1 m GSD, 600 km); medians of {a.repeat} runs; "
                      f"lines/s = output lines (the first {M - 1} frames give none) / s")
    fast = g[0]["lines_s"]
    print(f"golden model: {fast:,.0f} lines/s = {fast / rt:.2f}x real time (target >= 2x: "
          f"{'met' if fast >= 2 * rt else 'NOT met'})")
    print()
    c = cosim_rows(sims, ppcs, ifp)
    print_table(c, [("engine", "simulator", "s"), ("mode", "mode", "s"), ("ppc", "ppc", "d"),
                    ("pixels", "input pixels", ",d"), ("out_lines", "lines out", "d"),
                    ("seconds", "sim s", ".2f"), ("pixels_s", "pixels/s", ",.0f"),
                    ("beats_s", "beats/s", ",.0f"), ("mismatches", "mismatches", "d"),
                    ("build_s", "build s", ".1f"), ("total_s", "total s", ".1f")],
                title=f"TDI co-simulation, {W} x {M} stages, {BITS}-bit, 10 % idle and "
                      f"10 % backpressure; per-beat: 1/3 frame, fast: 98 frames; sim s = "
                      f"simulator wall time incl. start-up and stimulus load; total s adds "
                      f"Verilog generation, stimulus encoding and build")
    by = {(r["engine"], r["mode"], r["ppc"]): r["pixels_s"] for r in c}
    for ppc, target in FAST_TARGETS.items():
        v = by.get(("verilator", "fast", ppc))
        if v is not None:
            print(f"fast Verilator at ppc = {ppc}: {v:,.0f} pixels/s (target >= {target:,}: "
                  f"{'met' if v >= target else 'NOT met'})")
    fv = by.get(("verilator", "fast", 1))
    if fv is not None:
        scal = [f"ppc {p}: {by[('verilator', 'fast', p)] / fv:.2f}x" for p in ppcs
                if ("verilator", "fast", p) in by]
        print("fast Verilator scaling with ppc: " + ", ".join(scal))


if __name__ == "__main__":
    main()
