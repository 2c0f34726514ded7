"""Command-line entry point ``tdicam``.

Subcommands are discovered from the modules of :mod:`tdicam.commands`; each module
defines ``register(subparsers)`` which adds its parser and sets ``func`` (called with the
parsed namespace, returns an exit code). A :class:`~tdicam.errors.TdicamError` raised
anywhere is printed as one line and exits with status 2; Ctrl-C ends with
``tdicam: interrupted`` and status 130; a reader that closes the output pipe (``| head``)
ends the command quietly with status 141 (128 + SIGPIPE); a stdout that is closed
(``>&-``) or cannot take the output (``> /dev/full``) is one error line on stderr and
status 2; a stderr that is closed or full (``2>&-``, ``2> /dev/full``) drops the error
line (never onto stdout), the status tells. Help texts are shown as plain text
(:func:`plain_text`): descriptions taken from docstrings lose their reST markup.
"""

import importlib
import io
import os
import pkgutil
import sys

from tdicam import commands
from tdicam.commands._parsing import ArgsParser, Parser, plain_text
from tdicam.errors import COMMAND_LINE, TdicamError
from tdicam.version import __version__

__all__ = ["main", "build_parser", "plain_text", "ArgsParser"]


#: What ``tdicam --help`` says first.
DESCRIPTION = ("tdicam: the HDL-ready dataflow model of a digital-TDI push-broom camera and its "
               "co-simulation harness. 'tdicam COMMAND --help' for each command; 'tdicam "
               "scenes' lists the bundled scenes and sweeps ('--show NAME' prints one, "
               "'--reference' every scene key); every report.md explains its outputs; "
               "'python -m pydoc tdicam' the Python API.")

def build_parser():
    parser = Parser(prog="tdicam", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"tdicam {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def _quiet_stdout() -> None:
    """Point fd 1 at /dev/null, so the interpreter's final flush of a stdout that failed
    (a closed pipe, a full device) says nothing more."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())


def _say(text):
    """``text`` as one line on stderr; nothing when stderr is closed (``2>&-``: Python's
    ``sys.stderr`` is None, and ``print(file=None)`` would write to stdout) or cannot take
    it (``2> /dev/full``: fd 2 is then pointed at /dev/null, so the interpreter's final
    flush says nothing more). The exit status still tells."""
    err = sys.stderr
    if err is None:
        return
    try:
        print(text, file=err)
        err.flush()
    except (OSError, ValueError):
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, err.fileno())
        except (OSError, ValueError, io.UnsupportedOperation):
            pass


def _flush_stdout():
    """Flush stdout and probe it with a write of zero bytes (which a full device refuses, as
    it refuses the output argparse's ``--help`` drops silently): the OSError of a stdout that
    cannot take the output, None when it can."""
    try:
        sys.stdout.flush()
        try:
            fd = sys.stdout.fileno()
        except io.UnsupportedOperation:     # an in-memory stdout (tests): nothing to probe
            return None
        os.write(fd, b"")
    except BrokenPipeError:
        raise
    except OSError as exc:
        return exc
    return None


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if sys.stdout is None:              # started with stdout closed (>&-)
        _say("tdicam: error: standard output is closed; redirect it to a file or "
             "/dev/null instead")
        return 2
    try:
        try:
            parser = build_parser()
            args, extra = parser.parse_known_args(argv)
            if extra and not getattr(args, "_raw", False):
                raise TdicamError(f"unrecognized arguments: {' '.join(extra)}")
            args.extra = extra
            failed = _flush_stdout()    # a full stdout found before a long run, not after it
            if failed is not None:
                raise _StdoutError(failed)
            token = COMMAND_LINE.set(True)      # errors name the options, not arguments
            try:
                code = args.func(args)
            finally:
                COMMAND_LINE.reset(token)
        except SystemExit as exc:       # --help, argparse's own errors
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
            if code:
                return code             # its one line is on stderr; stdout got nothing
        except OSError as exc:
            if isinstance(exc, BrokenPipeError) or _flush_stdout() is None:
                raise                   # not stdout's: a real error
            raise _StdoutError(exc) from None
        failed = _flush_stdout()        # output still buffered: a full device shows here
        if failed is not None:
            raise _StdoutError(failed)
    except _StdoutError as exc:
        _quiet_stdout()
        _say(f"tdicam: error: cannot write to standard output ({exc})")
        return 2
    except TdicamError as exc:
        _say(f"tdicam: error: {exc}")
        return 2
    except KeyboardInterrupt:
        _say("tdicam: interrupted")
        return 130
    except BrokenPipeError:             # the reader left (| head): stop quietly
        _quiet_stdout()
        return 141
    return 0 if code is None else int(code)


class _StdoutError(Exception):
    """stdout refused the output (a full device, an I/O error)."""

    def __init__(self, exc: OSError):
        super().__init__(exc.strerror or str(exc))


if __name__ == "__main__":
    sys.exit(main())
