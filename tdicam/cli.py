"""Command-line entry point ``tdicam``.

Subcommands are discovered from the modules of :mod:`tdicam.commands`; each module
defines ``register(subparsers)`` which adds its parser and sets ``func`` (called with the
parsed namespace, returns an exit code). A :class:`~tdicam.errors.TdicamError` raised
anywhere is printed as one line and exits with status 2.
"""

import argparse
import importlib
import pkgutil
import sys

from . import commands
from .errors import TdicamError

__all__ = ["main", "build_parser"]


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        # argparse's own errors are one line too, but print usage first; keep one line.
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser():
    parser = _Parser(prog="tdicam", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        parser = build_parser()
        args, extra = parser.parse_known_args(argv)
        if extra and not getattr(args, "_raw", False):
            raise TdicamError(f"unrecognized arguments: {' '.join(extra)}")
        args.extra = extra
        code = args.func(args)
    except TdicamError as exc:
        print(f"tdicam: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("tdicam: interrupted", file=sys.stderr)
        return 130
    return 0 if code is None else int(code)


if __name__ == "__main__":
    sys.exit(main())
