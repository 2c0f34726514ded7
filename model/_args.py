"""Argument checks of the planning models, on top of :func:`tdicam.errors.check_range`.

The planning functions take scalars or arrays (sweeps); these helpers check every element and
report the first bad one with the project's one message format,
``NAME = V is out of range; valid: lo..hi``, by handing it to ``check_range``. Two cases
``check_range`` does not cover are guarded here with the same format: non-finite values
(``nan``, ``inf``) and open ends (``valid: 0..inf, excluding 0``) — a line period or a
speed must be strictly positive, a velocity mismatch strictly inside (-1, 1).
"""

from __future__ import annotations

import numpy as np

from tdicam.errors import TdicamError, check_range

__all__ = ["real", "count", "show"]


def show(value) -> str:
    """A bound or value as printed in messages: ``5`` for 5.0, ``1e-300``, ``inf``."""
    if value is None:
        return "inf"
    v = float(value)
    if np.isfinite(v) and v.is_integer() and abs(v) < 1e16:
        return str(int(v))
    return repr(v)


def _valid(lo, hi, lo_open, hi_open) -> str:
    if lo is None and hi is None:
        return "any finite number"
    text = f"{'-inf' if lo is None else show(lo)}..{show(hi)}"
    ex = [show(b) for b, o in ((lo, lo_open), (hi, hi_open)) if o and b is not None]
    return text + (", excluding " + " and ".join(ex) if ex else "")


def _number(v):
    """``v`` as a plain int when whole (so check_range prints ``5``, not ``5.0``)."""
    return int(v) if np.isfinite(v) and float(v).is_integer() and abs(v) < 1e16 else v


def real(name, value, *, lo=None, hi=None, lo_open=False, hi_open=False):
    """Return ``value`` as float64 (numpy scalar or array) after a range check on every element.

    ``lo``/``hi`` None means no bound; ``lo_open``/``hi_open`` exclude the bound itself.
    Raises :class:`TdicamError` for non-numbers, empty arrays, non-finite values and values
    out of range (the first one found).
    """
    if isinstance(value, (bool, np.bool_)):
        raise TdicamError(f"{name} must be a number, got {value!r}")
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TdicamError(f"{name} must be a number, got {value!r}") from None
    if arr.size == 0:
        raise TdicamError(f"{name} must not be empty")
    bad = ~np.isfinite(arr)
    if lo is not None:
        bad |= (arr <= lo) if lo_open else (arr < lo)
    if hi is not None:
        bad |= (arr >= hi) if hi_open else (arr > hi)
    if np.any(bad):
        first = float(arr[bad].flat[0])
        if np.isfinite(first) and not lo_open and not hi_open:
            check_range(name, _number(first), None if lo is None else _number(lo),
                        None if hi is None else _number(hi), integer=False)
        # local guard, same format: non-finite values and open ends (check_range has neither)
        raise TdicamError(f"{name} = {show(first)} is out of range; valid: "
                          f"{_valid(lo, hi, lo_open, hi_open)}")
    return arr[()] if arr.ndim == 0 else arr


def count(name, value, *, lo=1, hi=None):
    """Return an integer count (Python int, or an int64 array) checked against ``lo..hi``."""
    if isinstance(value, (bool, np.bool_)):
        raise TdicamError(f"{name} must be an integer, got {value!r}")
    arr = np.asarray(value)
    if arr.size == 0:
        raise TdicamError(f"{name} must not be empty")
    if arr.dtype.kind not in "iu":
        try:
            farr = arr.astype(np.float64)
        except (TypeError, ValueError):
            raise TdicamError(f"{name} must be an integer, got {value!r}") from None
        if not np.all(np.isfinite(farr)) or np.any(farr != np.round(farr)):
            raise TdicamError(f"{name} must be an integer, got {value!r}")
        arr = farr.astype(np.int64)
    bad = arr < lo if lo is not None else np.zeros(arr.shape, bool)
    if hi is not None:
        bad = bad | (arr > hi)
    if np.any(bad):
        check_range(name, int(arr[bad].flat[0]), lo, hi)
    return int(arr) if arr.ndim == 0 else arr.astype(np.int64)
