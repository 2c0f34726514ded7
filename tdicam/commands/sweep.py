"""``tdicam sweep SWEEP.toml [-o DIR]``: a trade study over scene keys, run on Dask.

The sweep file names a base scene, the scene keys to vary (lists or ranges, products and a
zip group) and the Monte-Carlo repeats (:mod:`tdicam.sweeps.runner`). Every run is stored as it
finishes, so a rerun computes only what is missing. Writes DIR/results.parquet, results.csv,
sweep.nc, summary.json, plots and DIR/points/<hash>.json (each run's report). Exit status 0
when every run succeeded, 1 when some failed (listed), 2 for a bad sweep file or an
unreachable scheduler. The command calls :func:`tdicam.api.sweep`.
"""

from __future__ import annotations

import sys

from tdicam.commands._parsing import add_source, source_path
from tdicam.files import named

__all__ = ["register", "sweep"]


def register(subparsers) -> None:
    """Add the ``sweep`` subcommand."""
    p = subparsers.add_parser(
        "sweep", help="trade study: simulate a scene over axes of scene keys on Dask",
        description=__doc__.split("\n\n")[0].replace("``", ""))
    add_source(p, "sweep", help="sweep TOML file ('tdicam scenes' lists the bundled ones; "
                                "--example NAME runs one)")
    p.add_argument("-o", "--out", metavar="DIR", default=None,
                   help="results directory (default out/sweeps/<sweep name>)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=None, metavar="N",
                       help="processes of the local Dask cluster (default: the CPU count)")
    where.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="use a running Dask scheduler, e.g. tcp://host:8786")
    where.add_argument("--serial", action="store_true",
                       help="run every point in this process, in order (debugging)")
    p.add_argument("--connect-timeout", type=float, default=10.0, metavar="S",
                   help="seconds to wait for --scheduler, in (0, 3600] (default 10)")
    p.add_argument("--force", action="store_true",
                   help="accept more runs (points x repeats) than the limit")
    p.add_argument("--limit", type=int, default=None, metavar="N",
                   help="stop after computing N runs (a rerun finishes the sweep)")
    p.add_argument("--impact", action="store_true",
                   help="measure every effect's impact in each run (one crop run per effect)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=sweep)


def sweep(args):
    from tdicam.api import sweep as run_study
    out = named(args.out) if args.out is not None else None
    try:
        ds = run_study(source_path(args), out, workers=args.workers, scheduler=args.scheduler,
                       serial=args.serial, impact=args.impact, force=args.force,
                       limit=args.limit, connect_timeout=args.connect_timeout,
                       progress=not args.no_progress)
    except KeyboardInterrupt as stop:
        print(f"tdicam: interrupted; the finished runs are kept in {stop.out_dir}/points: "
              f"run the same command again to finish", file=sys.stderr)
        return 130
    print(ds.attrs["summary"])
    return 1 if ds.attrs["failed"] else 0
