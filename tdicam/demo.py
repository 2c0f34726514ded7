"""The end-to-end path on one block (``tdicam demo``): a smoke run of the whole tool."""

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cosim.cases import run_cases
from tdicam.hw.lint import lint
from tdicam.files import check_dir
from tdicam.hw.verilog import write
from tdicam.progress import Progress

__all__ = ["demo", "RUNS"]


#: What the demo co-simulates, in order: (simulator, mode).
RUNS = (("icarus", "beat"), ("icarus", "fast"), ("verilator", "beat"), ("verilator", "fast"))


def demo(block="cds", outdir="out", *, progress=True):
    """Generate ``block``'s Verilog into ``outdir``, lint it, check its golden vectors and
    co-simulate every golden case on Icarus and Verilator, per-beat and fast, printing a
    line per step as it finishes; returns the exit code (0 = everything passed).
    ``progress``: each step's start on stderr (a bar on a terminal) with ``[k/n]`` and the
    time left, from the golden cases co-simulated so far."""
    blk = blocks.get(block)
    out = check_dir(outdir)
    with Progress(f"demo {blk.name}", len(RUNS) * len(golden.case_names(blk.name)), unit="case",
                  enabled=progress, stages=2 + len(RUNS)) as bar:
        return _steps(blk, out, bar)


def _steps(blk, out, bar):
    bar.stage("Verilog and lint")
    vpath = out / f"{blk.name}.v"
    write(blk, vpath)
    findings = lint(vpath)
    print(f"verilog: {vpath} ({len(vpath.read_text().splitlines())} lines), "
          f"verilator -Wall: {'clean' if not findings else f'{len(findings)} findings'}")
    bar.stage("golden vectors")
    results = golden.check([blk.name])
    bad = [r for r in results if not r.ok]
    print(f"golden: {len(results) - len(bad)} of {len(results)} cases match the model")
    for r in bad:
        print(f"  FAIL {r.message}")
    code = 1 if bad or findings else 0
    print(f"{'simulator':10s} {'mode':5s} {'cases':>5s} {'pixels':>8s} {'mismatch':>8s} "
          f"{'cycles':>9s} {'sim s':>6s} {'build s':>7s} {'pixels/s':>9s}")
    for sim, mode in RUNS:
        bar.stage(f"{sim} {mode}")
        rows = run_cases(blk.name, sim=sim, mode=mode, idle=0.2, backpressure=0.2,
                         seed=1, report=lambda r: bar.update(1))
        px = sum(r["pixels"] for r in rows)
        bad = sum(r["mismatches"] for r in rows) + sum(r["timeout"] for r in rows)
        wall = sum(r["wall_s"] for r in rows)
        build = sum(r["build_s"] for r in rows)
        print(f"{sim:10s} {mode:5s} {len(rows):5d} {px:8d} {bad:8d} "
              f"{sum(r['cycles'] for r in rows):9d} {wall:6.2f} {build:7.1f} "
              f"{px / wall if wall else 0:9.0f}", flush=True)
        code |= 1 if bad else 0
    print("result:", "PASS" if code == 0 else "FAIL")
    return code
