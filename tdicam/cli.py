"""Command-line entry point ``tdicam``.

Subcommands are discovered from the modules of :mod:`tdicam.commands`; each module
defines ``register(subparsers)`` which adds its parser and sets ``func`` (called with the
parsed namespace, returns an exit code). A :class:`~tdicam.errors.TdicamError` raised
anywhere is printed as one line and exits with status 2; Ctrl-C ends with
``tdicam: interrupted`` and status 130; a reader that closes the output pipe (``| head``)
ends the command quietly with status 141 (128 + SIGPIPE). Help texts are shown as plain text
(:func:`plain_text`): descriptions taken from docstrings lose their reST markup.
"""

import importlib
import os
import pkgutil
import sys

from tdicam import commands
from tdicam.commands._parsing import ArgsParser, Parser, plain_text
from tdicam.errors import TdicamError

__all__ = ["main", "build_parser", "plain_text", "ArgsParser"]


#: What ``tdicam --help`` says first.
DESCRIPTION = ("tdicam: the HDL-ready dataflow model of a digital-TDI push-broom camera and its "
               "co-simulation harness. 'tdicam COMMAND --help' for each command; the README "
               "explains every output.")

def build_parser():
    parser = Parser(prog="tdicam", description=DESCRIPTION)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
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
    except BrokenPipeError:             # the reader left (| head): stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())   # so the interpreter's final flush is quiet
        return 141
    return 0 if code is None else int(code)


if __name__ == "__main__":
    sys.exit(main())
