"""Exported self-checking testbench under ``verilator --binary`` (no Python in the loop)
against cocotb fast mode on the same vectors.

    python bench/bench_export.py [BLOCK[:param=value,...] ...] [lvds] [pipeline=SCENE.toml]

Prints, per stream block: input beats, Verilator build seconds and run seconds / input
pixels per second of each way, and the speed-up of the exported testbench. Both ways run
the same HDL engine (tdicam.cosim.tbgen), the same stimulus and 10 % idle / 10 %
backpressure; the exported one compares in HDL, cocotb fast mode writes every output to a
file that Python compares afterwards.

``lvds`` (its link testbench, every golden case) and ``pipeline=SCENE.toml`` (a scene's
whole chain on its raw frames) get a second table: the exported testbench alone under
Icarus (compile + run) and ``verilator --binary`` (build, run), input beats (lvds: word
clocks of every lane group) per second.
"""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tdicam import blocks
from tdicam.bench.util import machine
from tdicam.cosim import compare, run_stream, tool_env
from tdicam.export.block import VERILATOR_BINARY_ARGS, golden_params, select_vectors
from tdicam.export.harness import export_block

DEFAULT = ["cds", "nuc", "hdr", "median3", "tdi:width=1280,stages=96,ppc=1"]


def _parse(arg):
    name, _, rest = arg.partition(":")
    params = dict(kv.split("=") for kv in rest.split(",") if kv)
    return name, params


def bench(name, params, work):
    blk = blocks.get(name)
    params = blk.resolve(params) if params else golden_params(blk)
    ex = export_block(blk, params, work / name, max_beats=None)
    stim, exp, _ = select_vectors(blk, params, max_beats=None)
    px = int(stim.data.shape[0] * stim.data.shape[1])
    tool_env("verilator")
    vec = work / name / "vectors"
    t0 = time.perf_counter()
    subprocess.run(["verilator", *VERILATOR_BINARY_ARGS, "-Mdir", "obj_dir",
                    "../tb/tdicam_tb.v", f"../rtl/{name}.v"], cwd=vec, check=True,
                   capture_output=True)
    build_x = time.perf_counter() - t0
    t0 = time.perf_counter()
    r = subprocess.run(["./obj_dir/Vtdicam_tb"], cwd=vec, capture_output=True, text=True)
    run_x = time.perf_counter() - t0
    ok_x = r.returncode == 0 and "PASS" in r.stdout
    res = run_stream(name, params, stim, n_out=len(exp), sim="verilator", mode="fast",
                     idle=0.1, backpressure=0.1)
    ok_c = compare(res.out, exp).ok and not res.timeout
    return {"block": name, "beats": ex.n_in, "pixels": px,
            "export_build_s": build_x, "export_run_s": run_x, "export_px_s": px / run_x,
            "export_ok": ok_x, "cocotb_build_s": res.build_time, "cocotb_run_s": res.wall,
            "cocotb_px_s": px / res.wall, "cocotb_ok": ok_c}


def _timed(cmd, cwd):
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    return r, time.perf_counter() - t0


def bench_own(arg, work):
    """Export ``lvds`` or ``pipeline=SCENE`` and run it under Icarus and Verilator."""
    from tdicam.export.chain import export_pipeline
    t0 = time.perf_counter()
    if arg == "lvds":
        ex = export_block("lvds", {}, work / "lvds")
    else:
        ex = export_pipeline(arg.partition("=")[2], work / "pipeline")
    export_s = time.perf_counter() - t0
    module = "lvds" if arg == "lvds" else "pipeline"
    vec = ex.path / "vectors"
    b, ic_build = _timed(["iverilog", "-g2005", "-o", "tb.vvp", "../tb/tdicam_tb.v",
                          f"../rtl/{module}.v"], vec)
    r, ic_run = _timed(["vvp", "-n", "tb.vvp"], vec)
    ok_i = b.returncode == 0 and r.returncode == 0 and "PASS" in r.stdout
    tool_env("verilator")
    b, v_build = _timed(["verilator", *VERILATOR_BINARY_ARGS, "-Mdir", "obj_dir",
                         "../tb/tdicam_tb.v", f"../rtl/{module}.v"], vec)
    r, v_run = _timed(["./obj_dir/Vtdicam_tb"], vec)
    ok_v = b.returncode == 0 and r.returncode == 0 and "PASS" in r.stdout
    return {"what": arg, "beats": ex.n_in, "checked": ex.n_out, "export_s": export_s,
            "icarus_s": ic_build + ic_run, "icarus_beats_s": ex.n_in / ic_run,
            "verilator_build_s": v_build, "verilator_run_s": v_run,
            "verilator_beats_s": ex.n_in / v_run, "ok": ok_i and ok_v}


def main(argv):
    own = [a for a in argv if a == "lvds" or a.startswith("pipeline=")]
    argv = [a for a in argv if a not in own]
    targets = [_parse(a) for a in (argv or ([] if own else DEFAULT))]
    print(machine(), f"| load {os.getloadavg()[0]:.1f}")
    if targets:
        print("| block | input beats | export build s | export run s | export px/s | "
              "cocotb fast build s | cocotb fast run s | cocotb fast px/s | speed-up | "
              "bit-exact |")
        print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name, params in targets:
            r = bench(name, params, Path(tmp))
            print(f"| {r['block']} | {r['beats']:,} | {r['export_build_s']:.1f} | "
                  f"{r['export_run_s']:.2f} | {r['export_px_s']:,.0f} | "
                  f"{r['cocotb_build_s']:.1f} | {r['cocotb_run_s']:.2f} | "
                  f"{r['cocotb_px_s']:,.0f} | {r['cocotb_run_s'] / r['export_run_s']:.2f}x | "
                  f"{'yes' if r['export_ok'] and r['cocotb_ok'] else 'NO'} |", flush=True)
        if own:
            print("\n| export | input beats | expected words | export s | Icarus s (compile + "
                  "run) | Icarus beats/s | verilator --binary build s | run s | beats/s | "
                  "PASS both |")
            print("|---|---|---|---|---|---|---|---|---|---|")
        for arg in own:
            r = bench_own(arg, Path(tmp))
            print(f"| {r['what']} | {r['beats']:,} | {r['checked']:,} | {r['export_s']:.1f} | "
                  f"{r['icarus_s']:.1f} | {r['icarus_beats_s']:,.0f} | "
                  f"{r['verilator_build_s']:.1f} | {r['verilator_run_s']:.2f} | "
                  f"{r['verilator_beats_s']:,.0f} | {'yes' if r['ok'] else 'NO'} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
