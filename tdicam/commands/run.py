"""``tdicam run SCENE [-o DIR]``: the main job — a scene file in, the camera's images, figures
and a report out.

This module parses the arguments and calls the API: ``simulate(scene, ...).save(DIR)``
(:func:`tdicam.api.simulate`; what it writes is listed in :mod:`tdicam.run.runner`). Exit
status: 0; 1 when the ``[run.rtl]`` co-simulation could not run or found mismatches (the
report says which); 2 for bad input.
"""

from __future__ import annotations

from pathlib import Path

from tdicam.api import simulate
from tdicam.commands._parsing import add_source, source_path
from tdicam.files import named
from tdicam.scene.schema import FIDELITIES
from tdicam.run.runner import check_output, run_scene

__all__ = ["register", "run", "run_scene", "rtl_failed", "dry_run"]


def register(subparsers) -> None:
    """Add the ``run`` subcommand."""
    p = subparsers.add_parser(
        "run", help="simulate a scene: images, figures and a report (the main job)",
        description=__doc__.split("\n\n")[0].replace("``", "") + " report.md starts with the "
        "configuration and explains every output; every scene key: 'tdicam scenes "
        "--reference'. Exit status 0; 1 when the "
        "[run.rtl] co-simulation could not run or found mismatches; 2 for bad input.")
    add_source(p)
    p.add_argument("-o", "--out", metavar="DIR", default=None,
                   help="output directory (default out/<scene name>)")
    p.add_argument("--fidelity", choices=FIDELITIES, default=None,
                   help="override [run].fidelity")
    p.add_argument("--lines", type=int, default=None, metavar="N",
                   help="override [run].lines")
    p.add_argument("--force", action="append", default=[], metavar="EFFECT",
                   help="run EFFECT even where the scene does not need it (zero strength)")
    p.add_argument("--no-impact", action="store_true",
                   help="skip the per-effect impact measurement (one crop run per effect)")
    p.add_argument("--no-rtl", action="store_true", help="skip [run.rtl] co-simulation")
    p.add_argument("--dry-run", action="store_true",
                   help="check the scene, print its configuration and the estimated peak "
                        "memory against the memory available, write nothing")
    p.set_defaults(func=run)


def run(args):
    from tdicam.scene.loader import load_scene
    path = source_path(args)
    # --lines is validated as [run].lines is (range, memory, bar periods), named --lines
    over, labels = ({}, {}) if args.lines is None else \
        ({"run": {"lines": args.lines}}, {"run.lines": "--lines"})
    scene = load_scene(path, overrides=over, labels=labels)
    out = named(args.out) if args.out is not None else Path("out") / Path(path).stem
    if args.dry_run:
        return dry_run(scene, out, args, labels)
    check_output(out)                   # before the work
    report = simulate(scene, fidelity=args.fidelity, force=tuple(args.force),
                      impact=not args.no_impact, rtl=not args.no_rtl, progress=True,
                      labels=labels).save(out)
    print(report["summary"])
    print(f"wrote {out}/report.md, report.json and {len(report['files'])} files")
    return 1 if rtl_failed(report["rtl"]) else 0


def dry_run(scene, out, args, labels):
    """``--dry-run``: the configuration report.md would start with, and the memory
    estimate; exit status 2 (one line) when the run would be refused, else 0."""
    from tdicam.run import report
    from tdicam.run.runner import memory_check
    from tdicam.threads import threads
    threads()
    check_output(out)                   # a run into ``out`` would be refused: so is this
    est = memory_check(scene, fidelity=args.fidelity, force=args.force,
                       impact=not args.no_impact, rtl=not args.no_rtl, labels=labels)
    conf = report.configuration(scene, None, None, args.fidelity or scene.run.fidelity,
                                None, memory=est)
    print(f"{scene.source}: dry run, nothing written (the run would write into {out})")
    print("\n".join(line.replace("**", "").replace(", used ", ", will use ")
                    for line in report.config_lines(conf)[2:] if line))
    if scene.run.rtl is not None and not args.no_rtl:
        print("* [run.rtl]: the RTL co-simulation's simulator runs in processes of its own "
              "(not in the estimate; its input is)")
    return 0


def rtl_failed(rtl) -> bool:
    """True when a ``[run.rtl]`` co-simulation ran into an error or found a mismatch, the
    lanes from serial bits (``[run.rtl].phy``) included: a check that could not run or
    found what its prediction does not say (a lane in error as predicted is not a
    failure: :mod:`tdicam.chain.phy_check`)."""
    return rtl is not None and (
        any(b.get("status") != "ran" or b.get("mismatches") for b in rtl["blocks"])
        or any(r.get("status") != "ran" or r.get("problems") or r.get("mismatches")
               for r in rtl.get("phy_checks") or []))
