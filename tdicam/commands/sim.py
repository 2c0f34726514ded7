"""``tdicam sim BLOCK [--sim auto|icarus|verilator] [--fast]``: the block's golden cases
co-simulated (:func:`tdicam.cosimulate`), one printed row per case; ``auto`` (the default)
runs each case on the simulator that suits its size (:func:`tdicam.cosim.cases.
pick_simulators`), and the cases a per-beat run leaves out are named with how to run
them."""

import time

from tdicam import blocks, cosim
from tdicam.api import cosimulate
from tdicam.errors import check_range
from tdicam.files import check_dir
from tdicam.cosim.cases import AUTO_ICARUS_VALUES, pick_simulators, skipped
from tdicam.cosim.pauses import SEED_MAX, check_seed


def register(sub):
    p = sub.add_parser("sim", help="co-simulate a block's Verilog against its golden vectors",
                       description="Run the block's cocotb co-simulation on every golden case "
                                   "and compare bit for bit.")
    p.add_argument("block", help=f"one of: {', '.join(blocks.names())}")
    p.add_argument("--sim", default="auto", choices=(*cosim.SIMULATORS, "auto"),
                   help="the simulator that runs the Verilog; auto (the default): Icarus for "
                        f"a case of at most {AUTO_ICARUS_VALUES} input values (no build to "
                        "wait for), Verilator for larger ones (a build of about a minute, then "
                        "much faster)")
    p.add_argument("--fast", action="store_true",
                   help="HDL-side stimulus, clock and random stalls (default: per-beat cocotb)")
    p.add_argument("--idle", type=float, default=0.2, help="idle-cycle probability (0.2)")
    p.add_argument("--backpressure", type=float, default=0.2,
                   help="tready-low probability (0.2)")
    p.add_argument("--seed", type=int, default=1,
                   help=f"seed of the random idle cycles and backpressure, 1..{SEED_MAX} (1)")
    p.add_argument("--case", action="append", help="only these cases (repeatable)")
    p.add_argument("--wave-dir", default=str(cosim.WAVE_DIR),
                   help="where the waveform (FST) around a case's first mismatch is written "
                        "(default: %(default)s)")
    p.set_defaults(func=_run)


def _run(args):
    mode = "fast" if args.fast else "beat"
    check_seed("--seed", args.seed)
    cosim.check_build_root()
    check_dir(args.wave_dir, "--wave-dir", create=False)
    for opt in ("idle", "backpressure"):
        check_range(f"--{opt}", getattr(args, opt), 0, 1, integer=False, hi_open=True)
    header = [f"{'case':28s} {'pixels':>9s} {'mismatch':>8s} {'cycles':>9s} {'wall s':>7s} "
              f"{'pixels/s':>10s}"]

    def report(r):
        while header:           # printed with the first case: a refused --case prints none
            print(header.pop())
        rate = r["pixels"] / r["wall_s"] if r["wall_s"] else 0.0
        print(f"{r['case']:28s} {r['pixels']:9d} {r['mismatches']:8d} {r['cycles']:9d} "
              f"{r['wall_s']:7.2f} {rate:10.0f}" + ("" if not r["mismatches"] else
                                                     f"  {r['message']}"))

    t0 = time.perf_counter()
    # an unknown block: its one line, before the plan; a block that is not a stream has no
    # golden cases to plan or skip (cosimulate says how it is tested)
    streams = blocks.get(args.block).streams.to_beats is not None
    if args.sim == "auto":
        plan = pick_simulators(args.block, mode, args.case) if streams else {"icarus": None}
    else:
        plan = {args.sim: args.case}
    rows, used = [], []
    for sim, cases in plan.items():
        got = cosimulate(args.block, sim=sim, mode=mode, idle=args.idle,
                         backpressure=args.backpressure, seed=args.seed, cases=cases,
                         wave_dir=args.wave_dir, on_case=report)
        rows += got
        used.append(f"{len(got)} on {sim}")
    pixels = sum(r["pixels"] for r in rows)
    bad = sum(r["mismatches"] for r in rows)
    wall = sum(r["wall_s"] for r in rows)
    where = (f"on {args.sim}" if args.sim != "auto" else
             f"(auto: {', '.join(used)}; --sim to choose)")
    print(f"{args.block} {where} ({mode}): {len(rows)} cases, {pixels} pixels checked, "
          f"{bad} mismatches, {sum(r['cycles'] for r in rows)} cycles, "
          f"{wall:.2f} s simulated wall, {pixels / wall if wall else 0:.0f} pixels/s "
          f"({time.perf_counter() - t0:.1f} s total)")
    left = skipped(args.block, mode, args.case) if streams else []
    if left:
        print(f"not run per beat: {len(left)} fast-only case(s) ({', '.join(left)}): per beat "
              f"they take minutes; run them with --fast")
    return 1 if bad or any(r["timeout"] for r in rows) else 0
