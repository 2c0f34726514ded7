"""The argument parsers of tdicam's commands: help shown as plain text, every error one line.

:class:`ArgsParser` parses a command's own trailing arguments (``verilog pipeline --scene
...``) and raises :class:`~tdicam.errors.TdicamError`; the top-level parser prints
``tdicam COMMAND: error: ...`` and exits with status 2.
"""

import argparse
import re

from tdicam.errors import TdicamError

__all__ = ["plain_text", "Parser", "ArgsParser", "add_source", "source_path"]

_ROLE = re.compile(r":[a-z]+:`~?([^`]+)`")
_LITERAL = re.compile(r"``([^`]+)``")


def plain_text(text):
    """``text`` without reST markup: ````x```` -> ``x``, ``:func:`~a.b``` -> ``b``,
    ``:mod:`a.b``` -> ``a.b`` (a ``~`` keeps the last dotted name, as Sphinx shows it)."""
    def role(m):
        target = m.group(0)
        name = m.group(1)
        return name.rsplit(".", 1)[-1] if "`~" in target else name
    return _LITERAL.sub(r"\1", _ROLE.sub(role, text))


class Parser(argparse.ArgumentParser):
    def format_help(self):
        return plain_text(super().format_help())

    def format_usage(self):
        return plain_text(super().format_usage())

    def error(self, message):
        # argparse's own errors are one line too, but print usage first; keep one line.
        self.exit(2, f"{self.prog}: error: {message}\n")


class ArgsParser(Parser):
    """The parser of a command's own trailing arguments (``verilog pipeline --scene ...``):
    an error is a :class:`~tdicam.errors.TdicamError` naming the command, one line."""

    def error(self, message):
        raise TdicamError(f"{self.prog}: {message}")


def add_source(p, kind="scene", *, flag=None, required=True, help=None):
    """Add where a command's scene (or sweep) file comes from: a file, or ``--example NAME``
    (a bundled one, :mod:`tdicam.scene.examples`), one of the two.

    Parameters
    ----------
    p : argparse.ArgumentParser
    kind : {"scene", "sweep"}
    flag : str, optional
        The file's option (``"--scene"``); default a positional argument.
    required : bool
        One of the two must be given.
    help : str, optional
        The file argument's help (default: the scene reference, 'tdicam scenes --reference').

    :func:`source_path` reads the parsed arguments back.
    """
    which = p.add_mutually_exclusive_group(required=required)
    text = help or (f"{kind} TOML file (every scene key: 'tdicam scenes --reference')")
    if flag is None:
        which.add_argument("source", metavar=kind.upper(), nargs="?", help=text)
    else:
        which.add_argument(flag, dest="source", metavar="FILE", help=text)
    which.add_argument("--example", metavar="NAME",
                       help=f"a bundled {kind} by name ('tdicam scenes' lists them)")
    p.set_defaults(source_kind=kind)


def source_path(args):
    """The file :func:`add_source`'s arguments name (``None`` when neither was given);
    an unknown ``--example`` is a :class:`~tdicam.errors.TdicamError` listing the names."""
    from tdicam.scene.examples import example_path, sweep_path
    if getattr(args, "example", None) is None:
        return getattr(args, "source", None)
    return (example_path if args.source_kind == "scene" else sweep_path)(args.example)
