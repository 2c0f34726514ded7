"""``tdicam scenes``: the bundled example scenes and sweeps, one line each; ``--show NAME``
prints one (to start a scene of your own: ``tdicam scenes --show NAME > my.toml``);
``--reference`` prints every scene key with its type, unit, default and range.

Each scene name runs with ``tdicam run --example NAME`` (and ``plan``, ``verilog|export
pipeline`` take ``--example`` too), each sweep with ``tdicam sweep --example NAME``; the lists
are :func:`tdicam.scene.examples.examples` and :func:`~tdicam.scene.examples.sweeps` (files
inside the package).
"""

import sys

from tdicam.errors import TdicamError
from tdicam.paths import SCENES
from tdicam.scene.examples import example_path, examples, sweep_path, sweeps

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add the ``scenes`` subcommand."""
    p = subparsers.add_parser(
        "scenes", help="list, show and explain the bundled scenes and sweeps",
        description="List the bundled example scenes and sweeps with a one-line description "
                    "each; 'tdicam run --example NAME' runs a scene, 'tdicam sweep --example "
                    "NAME' a sweep.")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--show", metavar="NAME",
                      help="print the bundled scene or sweep NAME (start your own: "
                           "'tdicam scenes --show NAME > my.toml')")
    what.add_argument("--reference", action="store_true",
                      help="print the scene file reference: every section and key with its "
                           "type, unit, default, range and meaning (Markdown)")
    p.set_defaults(func=run)


def _show(name) -> str:
    """The text of the bundled scene or sweep ``name`` (a scene first)."""
    try:
        return example_path(name).read_text(encoding="utf-8")
    except TdicamError as scene_error:
        try:
            return sweep_path(name).read_text(encoding="utf-8")
        except TdicamError:
            raise TdicamError(f"{scene_error} (bundled sweeps: {', '.join(sweeps())})") from None


def run(args) -> int:
    """Print the lists, one file (``--show``) or the scene reference (``--reference``)."""
    if args.show is not None:
        sys.stdout.write(_show(args.show))
        return 0
    if args.reference:
        from tdicam.scene.docs import render
        sys.stdout.write(render() + "\n")
        return 0
    for kind, found in (("scene", examples()), ("sweep", sweeps())):
        print(f"{kind}s:")
        width = max(map(len, found), default=0)
        for name, text in found.items():
            print(f"  {name:{width}s}  {text}")
    print(f"(in {SCENES}; 'tdicam run --example NAME' runs a scene, 'tdicam sweep --example "
          f"NAME' a sweep, 'tdicam scenes --show NAME > my.toml' starts your own, "
          f"'tdicam scenes --reference' lists every key)")
    return 0
