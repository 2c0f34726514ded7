"""The key reader of one scene table: :class:`Section` validates each key as it reads it and
names ``[section].key`` in every error (or a command-line label); :func:`show` and
:func:`hint` word a value and a did-you-mean hint."""

from __future__ import annotations

import difflib
import math
import numbers
from typing import Any, Mapping

from tdicam.errors import TdicamError, check_range
from tdicam.scene.schema import BOUNDS

__all__ = ["Section", "REQUIRED", "show", "hint"]

#: The default of a key that has none: reading it when the table lacks it is an error.
REQUIRED = object()


def show(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "[" + ", ".join(show(v) for v in value) + "]"
    return str(value)



def hint(key, valid) -> str:
    close = difflib.get_close_matches(key, list(valid), n=1, cutoff=0.6)
    if close:
        return f"; did you mean {close[0]!r}?"
    return "; valid: " + ", ".join(valid) if valid else ""


class Section:
    """One TOML table being validated; errors name ``[section].key`` (or a CLI label)."""

    def __init__(self, name: str, data: Any, labels: Mapping[str, str]):
        self.name = name
        self.labels = labels
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise TdicamError(f"{self.section_label()}: must be a table, got {show(data)}")
        self.data = data

    def section_label(self) -> str:
        return self.labels.get(self.name, f"[{self.name}]")

    def label(self, key: str) -> str:
        return self.labels.get(f"{self.name}.{key}", f"[{self.name}].{key}")

    def fail(self, key: str, message: str):
        raise TdicamError(f"{self.label(key)}: {message}")

    def has(self, key: str) -> bool:
        return key in self.data

    def check_keys(self, allowed) -> None:
        for key in self.data:
            if key not in allowed:
                self.fail(key, "unknown key" + hint(key, sorted(allowed)))

    def raw(self, key, default):
        if key in self.data:
            return self.data[key]
        if default is REQUIRED:
            self.fail(key, "missing (required)")
        return default

    def _given(self, key, default, value, what):
        """The value to check (``value`` when given, else the table's, else ``default``) and
        the words naming it in a message (``what``: e.g. an entry of a list)."""
        return (self.raw(key, default) if value is REQUIRED else value,
                f" {what}" if what else "")

    def number(self, key, default=REQUIRED, *, lo=None, hi=None, lo_open=False,
               hi_open=False, value=REQUIRED, what=None):
        v, where = self._given(key, default, value, what)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            self.fail(key, f"must be a number{where}, got {show(v)}")
        if not isinstance(v, (int, float)):         # numpy numbers
            v = int(v) if isinstance(v, numbers.Integral) else float(v)
        raw, shown, v = v, show(v), float(v)
        if not math.isfinite(v):
            self.fail(key, f"must be a finite number{where}, got {shown}")
        bound = BOUNDS.get(f"{self.name}.{key}")
        if bound is not None:           # a physical bound replaces "positive"
            (lo, hi), lo_open, hi_open = bound, False, False
        check_range(f"{self.label(key)}{where}", raw, lo, hi, integer=False,
                    lo_open=lo_open, hi_open=hi_open)
        return v

    def integer(self, key, default=REQUIRED, *, lo=None, hi=None, value=REQUIRED, what=None):
        v, where = self._given(key, default, value, what)
        if v is None:
            return None
        # numpy integers are integers (a Python caller's numpy.int64(16))
        if isinstance(v, bool) or not isinstance(v, numbers.Integral):
            self.fail(key, f"must be an integer{where}, got {show(v)}")
        v = int(v)
        lo, hi = BOUNDS.get(f"{self.name}.{key}", (lo, hi))
        return check_range(f"{self.label(key)}{where}", v, lo, hi)

    def choice(self, key, default, choices):
        v = self.raw(key, default)
        if not isinstance(v, str) or v not in choices:
            hint = ""
            if isinstance(v, str):
                close = difflib.get_close_matches(v, list(choices), n=1, cutoff=0.6)
                hint = f"; did you mean {close[0]!r}?" if close else ""
            self.fail(key, "must be one of " + ", ".join(repr(c) for c in choices)
                      + f", got {show(v)}{hint}")
        return v

    def boolean(self, key, default):
        v = self.raw(key, default)
        if not isinstance(v, bool):
            self.fail(key, f"must be true or false, got {show(v)}")
        return v

    def string(self, key, default=REQUIRED):
        v = self.raw(key, default)
        if v is not None and not isinstance(v, str):
            self.fail(key, f"must be a string, got {show(v)}")
        return v

    def sweep(self, key, default, item):
        """A scalar or a non-empty list; ``item(value, what)`` validates each entry."""
        v = self.raw(key, default)
        if isinstance(v, list):
            if not v:
                self.fail(key, "must not be an empty list")
            out = tuple(item(x, f"(entry {i} of the list)") for i, x in enumerate(v))
            twice = [x for i, x in enumerate(out) if x in out[:i]]
            if twice:
                self.fail(key, f"lists {show(twice[0])} more than once, got {show(v)}; "
                               f"each value of a sweep once")
            return out
        return (item(v, None),)
