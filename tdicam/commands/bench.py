"""``tdicam bench [BLOCK ...]``: what accuracy costs in time, every fidelity level side by side."""

import json
import sys
import time
from pathlib import Path

from tdicam import cosim
from tdicam.bench import suite as bench
from tdicam.errors import TdicamError, check_range
from tdicam.files import check_dir, check_file, write_file


def register(sub):
    p = sub.add_parser(
        "bench", help="time and accuracy of every block at every fidelity level",
        description="One table (and one PNG) of time and accuracy per fidelity level on the "
                    "same input: numpy golden model, Amaranth Python simulator, Icarus and "
                    "Verilator per-beat and fast (build time apart), and the scene engine "
                    "fast / auto / exact against real time. Times are medians of --repeat "
                    "runs (pipeline: one run, its own legend); every simulator row is "
                    "compared bit for bit with the golden model. The PNG has two panels: throughput per level, and what accuracy "
                    "costs in time (time per unit against accuracy with the reference: "
                    "bit-exact levels on one line, the scene engine's fast and auto by the "
                    "PSNR of their output against exact, exact's seed-to-seed PSNR as the "
                    "noise floor).")
    p.add_argument("names", nargs="*", metavar="BLOCK",
                   help=f"benchmarks to run (default: all of {', '.join(bench.NAMES)}); "
                   f"also {', '.join(bench.EXTRA)} (the orbit scene's whole camera pipeline "
                   "through its generated top, minutes; --quick: 8 lines of the Ning et al. 2019 "
                   "chain)")
    p.add_argument("--repeat", type=int, default=None,
                   help="runs per level (3; --quick: 1); pipeline runs once")
    p.add_argument("--quick", action="store_true", help="short inputs, one run per level")
    p.add_argument("--sims", default=",".join(cosim.SIMULATORS),
                   help="simulators, comma-separated, or 'none' (icarus,verilator)")
    p.add_argument("--stalls", type=float, default=0.1,
                   help="idle and backpressure probability in simulator rows (0.1)")
    p.add_argument("--build-time", choices=("fresh", "cached"), default=None,
                   help="fresh: time a build from scratch (default); cached: report what "
                        "the first run spent building (--quick default)")
    p.add_argument("-o", "--out-dir", default="out/bench", help="folder for the PNG (out/bench)")
    p.add_argument("--png", help="PNG path (default OUT_DIR/bench.png); 'none' to skip")
    p.add_argument("--json", metavar="FILE",
                   help="write the rows as JSON to FILE; '-': to stdout (the table then goes "
                        "to stderr)")
    p.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    p.add_argument("--from-json", metavar="FILE",
                   help="print the table (and PNG) of an earlier --json FILE; runs nothing")
    p.set_defaults(func=_run)


def _sims(text):
    if not text.strip():                # "" ran with no simulator, silently
        raise TdicamError(f"--sims: empty; give simulators from {', '.join(cosim.SIMULATORS)}"
                          f", or 'none'")
    sims = tuple(s for s in text.split(",") if s and s != "none")
    for s in sims:
        if s not in cosim.SIMULATORS:
            raise TdicamError(f"--sims: unknown simulator {s!r}; valid: "
                              f"{', '.join(cosim.SIMULATORS)}, none")
    return sims


def _load(path):
    try:
        doc = json.loads(Path(path).read_text())
        return doc["rows"], doc["machine"], doc["settings"], doc["wall_s"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise TdicamError(f"--from-json {path}: not a tdicam bench JSON file "
                          f"({type(exc).__name__}: {exc})") from None


def _outputs(args):
    """Check the PNG and JSON paths before anything runs; returns the PNG path or None."""
    png = None
    if args.png != "none":
        png = check_file(args.png, "--png") if args.png is not None else \
            check_dir(args.out_dir, "-o") / "bench.png"
    if args.json not in (None, "-"):
        check_file(args.json, "--json")
    return png


def _run(args):
    args.png_path = _outputs(args)
    if args.from_json:
        rows, mline, settings, wall = _load(args.from_json)
        return _report(args, rows, mline, settings, wall)
    repeat = args.repeat if args.repeat is not None else (1 if args.quick else 3)
    build = args.build_time or ("cached" if args.quick else "fresh")
    check_range("--stalls", args.stalls, 0, 1, integer=False, hi_open=True)
    bench.expand(args.names)        # unknown names fail before anything runs
    sims = _sims(args.sims)
    t0 = time.perf_counter()
    rows = bench.run(args.names, sims=sims, repeat=repeat, quick=args.quick,
                     stalls=args.stalls, build=build,
                     progress=lambda n: print(f"bench: {n} ...", file=sys.stderr, flush=True))
    wall = time.perf_counter() - t0
    settings = {"names": list(args.names) or list(bench.NAMES), "sims": list(sims),
                "repeat": repeat, "quick": args.quick, "stalls": args.stalls,
                "build_time": build}
    return _report(args, rows, bench.describe_machine(), settings, wall)


def _report(args, rows, mline, settings, wall):
    """Table, legend, PNG and JSON of ``rows``; exit status 1 if any row is not exact."""
    to_stdout = args.json == "-"
    log = sys.stderr if to_stdout else sys.stdout
    legend = bench.legend(repeat=settings["repeat"], stalls=settings["stalls"],
                          build=settings["build_time"], quick=settings["quick"],
                          names=settings.get("names", ()))
    print(mline, file=log)
    print(bench.format_table(rows, markdown=args.markdown), file=log)
    print(legend, file=log)
    print(f"wall time {wall:.0f} s", file=log)
    if args.json:
        text = bench.to_json(rows, machine_line=mline, settings=settings, wall_s=wall)
        if to_stdout:
            print(text)
        else:
            write_file(args.json, text + "\n")
            print(f"wrote {args.json}", file=log)
    png = args.png_path
    if png is not None:
        bench.plot(rows, png, title=f"tdicam bench ({mline.split(',')[0]})")
        print(f"wrote {png}", file=log)
    bad = [r for r in rows if r["mismatches"] or r["accuracy"] == "error"]
    if bad:
        print(f"bench: {len(bad)} row(s) not bit-exact or failed: "
              + ", ".join(f"{r['block']} {r['level']}" for r in bad), file=sys.stderr)
    return 1 if bad else 0
