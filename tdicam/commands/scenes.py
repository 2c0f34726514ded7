"""``tdicam scenes``: the bundled example scenes, one line each.

Each name runs with ``tdicam run --example NAME``; the list is
:func:`tdicam.scene.examples.examples` (the scene files inside the package).
"""

from tdicam.paths import SCENES
from tdicam.scene.examples import examples

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add the ``scenes`` subcommand."""
    p = subparsers.add_parser(
        "scenes", help="list the bundled example scenes",
        description="List the bundled example scenes with a one-line description each; "
                    "'tdicam run --example NAME' runs one.")
    p.set_defaults(func=run)


def run(args) -> int:
    """Print one line per bundled scene, then where the files are."""
    found = examples()
    width = max(map(len, found), default=0)
    for name, text in found.items():
        print(f"{name:{width}s}  {text}")
    print(f"({len(found)} scenes in {SCENES}; run one with 'tdicam run --example NAME')")
    return 0
