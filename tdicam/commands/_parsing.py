"""The argument parsers of tdicam's commands: help shown as plain text, every error one line.

:class:`ArgsParser` parses a command's own trailing arguments (``verilog pipeline --scene
...``) and raises :class:`~tdicam.errors.TdicamError`; the top-level parser prints
``tdicam COMMAND: error: ...`` and exits with status 2.
"""

import argparse
import re

from tdicam.errors import TdicamError

__all__ = ["plain_text", "Parser", "ArgsParser"]

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
