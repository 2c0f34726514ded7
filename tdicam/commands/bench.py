"""``tdicam bench [BLOCK ...]``: what accuracy costs in time, every fidelity level side by side."""

import json
import sys
import time
from pathlib import Path

from tdicam import cosim
from tdicam.bench import suite
from tdicam.errors import TdicamError, check_range
from tdicam.files import check_dir, check_file, read_bytes, write_file
from tdicam.progress import Progress


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
                   help=f"benchmarks to run (default: all of {', '.join(suite.NAMES)}); "
                   f"also {', '.join(suite.EXTRA)} (pipeline: the orbit scene's whole camera "
                   "pipeline through its generated top, minutes; --quick: 8 lines of the Ning "
                   "et al. 2019 chain; camera: the full-width Ning et al. 2019 camera, 5144 "
                   "columns, through its top on Verilator: two builds of 5-10 min, then 1-2 min a "
                   "cut)")
    p.add_argument("--repeat", type=int, default=None,
                   help=f"runs per level, 1..{suite.MAX_REPEAT} (3; --quick: 1); pipeline "
                        f"runs once")
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
        raw = read_bytes(path, "tdicam bench JSON file", _MAX_JSON_BYTES)
    except TdicamError as exc:
        raise TdicamError(f"--from-json: {exc}") from None
    try:
        doc = json.loads(raw)
    except ValueError as exc:   # JSON errors and bad UTF-8 are ValueErrors
        raise TdicamError(f"--from-json {path}: not a tdicam bench JSON file (not JSON: "
                          f"{str(exc).splitlines()[0]})") from None
    keys = ("rows", "machine", "settings", "wall_s")
    missing = [k for k in keys if not isinstance(doc, dict) or k not in doc]
    if missing:
        got = "a table" if isinstance(doc, dict) else f"a JSON {type(doc).__name__}"
        raise TdicamError(f"--from-json {path}: not a tdicam bench JSON file ({got} "
                          f"without {', '.join(repr(k) for k in missing)}; 'tdicam bench "
                          f"--json FILE' writes one)")
    rows = doc["rows"]
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise TdicamError(f"--from-json {path}: not a tdicam bench JSON file ('rows' is not "
                          f"a list of tables)")
    return rows, doc["machine"], doc["settings"], doc["wall_s"]


#: A bench JSON is a few hundred kB: a larger (or endless) file is not one.
_MAX_JSON_BYTES = 64 << 20


def _outputs(args):
    """Check the PNG and JSON paths before anything runs; returns the PNG path or None."""
    png = None
    if args.png != "none":
        png = check_file(args.png, "--png") if args.png is not None else \
            check_dir(args.out_dir, "-o") / "bench.png"
    if args.json not in (None, "-"):
        check_file(args.json, "--json")
    return png


#: What rendering a foreign document's fields raises (a missing key, a wrong type).
_NOT_BENCH = (KeyError, TypeError, ValueError, AttributeError, IndexError)


def _run(args):
    if args.from_json:
        rows, mline, settings, wall = _load(args.from_json)
        try:                            # rendered once before anything is printed or written
            _legend(settings)
            suite.format_table(rows, markdown=args.markdown)
            f"{mline.split(',')[0]} {float(wall):.0f}"
            [r for r in rows if r["mismatches"] or r["accuracy"] == "error"]
        except _NOT_BENCH as exc:
            raise TdicamError(f"--from-json {args.from_json}: not a tdicam bench JSON file "
                              f"(a field missing or of the wrong type: {exc!r})") from None
        args.png_path = _outputs(args)
        return _report(args, rows, mline, settings, wall)
    # every option checked before the output folder is made
    if args.repeat is not None:
        check_range("--repeat", args.repeat, 1, suite.MAX_REPEAT)
    repeat = args.repeat if args.repeat is not None else (1 if args.quick else 3)
    build = args.build_time or ("cached" if args.quick else "fresh")
    check_range("--stalls", args.stalls, 0, 1, integer=False, hi_open=True)
    suite.expand(args.names)        # unknown names fail before anything runs
    sims = _sims(args.sims)
    if sims:
        cosim.check_build_root()
    args.png_path = _outputs(args)
    t0 = time.perf_counter()
    todo = suite.expand(args.names)
    settings = {"names": list(args.names) or list(suite.NAMES), "sims": list(sims),
                "repeat": repeat, "quick": args.quick, "stalls": args.stalls,
                "build_time": build}
    how = {"quick": args.quick, "sims": sims, "repeat": repeat, "build": build}
    est = suite.estimate(todo, **how)
    print(f"bench: {len(todo)} benchmark(s), " + (
        f"about {est / 60:.1f} min (their last run on this machine)" if est is not None else
        "no estimate yet (the first run of these here; the next one will say)"),
        file=sys.stderr, flush=True)
    timings = {}
    with Progress("bench", len(todo), unit="benchmark", stages=len(todo)) as bar:
        try:
            rows = suite.run(args.names, sims=sims, repeat=repeat, quick=args.quick,
                             stalls=args.stalls, build=build, progress=bar, timings=timings)
        except KeyboardInterrupt as stop:   # report (and write) what finished, then stop
            bar.close()
            suite.remember(timings, **how)
            rows = getattr(stop, "rows", [])
            print(f"bench: interrupted after {bar.done:.0f} of {len(todo)} benchmarks; the "
                  f"table, JSON and figure below hold the finished ones", file=sys.stderr)
            _report(args, rows, suite.describe_machine(), settings,
                    time.perf_counter() - t0)
            return 130
    wall = time.perf_counter() - t0
    suite.remember(timings, **how)
    return _report(args, rows, suite.describe_machine(), settings, wall)


def _legend(settings):
    return suite.legend(repeat=settings["repeat"], stalls=settings["stalls"],
                        build=settings["build_time"], quick=settings["quick"],
                        names=settings.get("names", ()))


def _report(args, rows, mline, settings, wall):
    """Table, legend, PNG and JSON of ``rows``; exit status 1 if any row is not exact."""
    to_stdout = args.json == "-"
    log = sys.stderr if to_stdout else sys.stdout
    legend = _legend(settings)
    print(mline, file=log)
    print(suite.format_table(rows, markdown=args.markdown), file=log)
    print(legend, file=log)
    print(f"wall time {wall:.0f} s", file=log)
    if args.json:
        text = suite.to_json(rows, machine_line=mline, settings=settings, wall_s=wall)
        if to_stdout:
            print(text)
        else:
            write_file(args.json, text + "\n")
            print(f"wrote {args.json}", file=log)
    png = args.png_path
    if png is not None:
        suite.plot(rows, png, title=f"tdicam bench ({mline.split(',')[0]})")
        print(f"wrote {png}", file=log)
    bad = [r for r in rows if r["mismatches"] or r["accuracy"] == "error"]
    if bad:
        print(f"bench: {len(bad)} row(s) not bit-exact or failed: "
              + ", ".join(f"{r['block']} {r['level']}" for r in bad), file=sys.stderr)
    return 1 if bad else 0
