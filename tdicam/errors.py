"""The one exception type users see.

Every error caused by user input (a bad parameter, a malformed scene, a corrupt golden
file, a lane with no eye, ...) is raised as :class:`TdicamError` with a one-line message
that names the problem. The CLI prints it as ``tdicam: error: <message>`` and exits 2;
it never shows a traceback for these.

Layer: the bottom leaf; imports nothing of tdicam.
"""

__all__ = ["TdicamError", "check_range", "valid_range", "check_choice", "check_multiple"]


class TdicamError(ValueError):
    """A user-facing error with a one-line message."""

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))


def _num(v):
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e16:
        return str(int(v))
    if isinstance(v, float) and 1e-4 <= abs(v) < 1e6:
        return f"{v:.6g}"               # a derived bound: 21.3333, not 21.333333333333336
    return str(v)


def valid_range(lo, hi, *, lo_open=False, hi_open=False):
    """The ``valid:`` text of a range: ``lo..hi`` (inclusive; no bound is ``-inf``/``inf``),
    interval notation when a bound is exclusive (``(0, 1]``, ``> 0``)."""
    if not lo_open and not hi_open:
        return f"{'-inf' if lo is None else _num(lo)}..{'inf' if hi is None else _num(hi)}"
    if lo is not None and hi is not None:
        return f"{'(' if lo_open else '['}{_num(lo)}, {_num(hi)}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {_num(lo)}"
    return f"{'<' if hi_open else '<='} {_num(hi)}"


def api_arguments(fn):
    """Decorator of a public API function: a call with arguments ``fn`` does not take (an
    unknown keyword, one too many, a required one missing) raises a one-line
    :class:`TdicamError` naming ``fn`` and the argument, not Python's TypeError. The
    signature (``inspect.signature``) and docstring stay ``fn``'s."""
    import functools
    import inspect
    sig = inspect.signature(fn)

    @functools.wraps(fn)
    def call(*args, **kwargs):
        try:
            sig.bind(*args, **kwargs)
        except TypeError as exc:
            raise TdicamError(f"{fn.__qualname__}: {exc}") from None
        return fn(*args, **kwargs)
    return call


def check_range(name, value, lo, hi, *, integer=True, lo_open=False, hi_open=False):
    """Return ``value`` if it lies in the range (and is integral when ``integer``), else
    raise ``"NAME = V is out of range; valid: lo..hi"`` (see :func:`valid_range`).

    The project's one range check: block parameters, scene keys, plan options and model
    arguments all go through it. ``lo`` or ``hi`` may be None for an open end;
    ``lo_open``/``hi_open`` make a bound exclusive (floats, e.g. ``(0, 1]``). ``nan`` and
    infinities are never in range.
    """
    shown = value                     # as given: 1e+308, not its 309 integer digits
    if integer and (isinstance(value, bool) or not isinstance(value, int)):
        if isinstance(value, bool):
            raise TdicamError(f"{name} must be an integer, got {value!r}")
        try:
            if int(value) != value:
                raise ValueError
            value = int(value)
        except (TypeError, ValueError, OverflowError):
            raise TdicamError(f"{name} must be an integer, got {value!r}") from None
    if not integer and not isinstance(value, (int, float)):
        try:
            value = float(value)
        except (TypeError, ValueError, OverflowError):
            raise TdicamError(f"{name} must be a number, got {value!r}") from None
    if value != value or value in (float("inf"), float("-inf")):   # nan, inf: never in range
        raise TdicamError(f"{name} = {value} is out of range; valid: "
                          f"{valid_range(lo, hi, lo_open=lo_open, hi_open=hi_open)}")
    below = lo is not None and (value <= lo if lo_open else value < lo)
    above = hi is not None and (value >= hi if hi_open else value > hi)
    if below or above:
        raise TdicamError(f"{name} = {shown} is out of range; valid: "
                          f"{valid_range(lo, hi, lo_open=lo_open, hi_open=hi_open)}")
    return value


def check_multiple(width, ppc):
    """Return ``width`` if it is a multiple of ``ppc`` (pixels per clock), else raise
    ``"width = W is not a multiple of ppc = P"``."""
    if width % ppc:
        raise TdicamError(f"width = {width} is not a multiple of ppc = {ppc}")
    return width


def check_choice(name, value, choices):
    """Return ``value`` if it is one of ``choices``, else raise listing them."""
    if value not in choices:
        valid = ", ".join(str(c) for c in choices)
        raise TdicamError(f"{name} = {value!r} is not valid; valid: {valid}")
    return value
