"""The one exception type users see.

Every error caused by user input (a bad parameter, a malformed scene, a corrupt golden
file, a lane with no eye, ...) is raised as :class:`TdicamError` with a one-line message
that names the problem. The CLI prints it as ``tdicam: error: <message>`` and exits 2;
it never shows a traceback for these.

Layer: the bottom leaf; imports nothing of tdicam.
"""

__all__ = ["TdicamError", "check_range", "valid_range", "check_choice", "check_multiple",
           "api_arguments", "check_flag", "COMMAND_LINE", "python_names"]

import contextvars


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
    :class:`TdicamError` naming ``fn`` and the argument, not Python's TypeError; an
    argument annotated ``bool`` takes True or False only (:func:`check_flag`: ``'no'`` is
    not False). The signature (``inspect.signature``) and docstring stay ``fn``'s."""
    import functools
    import inspect
    sig = inspect.signature(fn)
    flags = [n for n, p in sig.parameters.items() if p.annotation in (bool, "bool")]
    names = set(sig.parameters)
    rest = any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values())

    @functools.wraps(fn)
    def call(*args, **kwargs):
        try:
            bound = sig.bind(*args, **kwargs)
        except TypeError as exc:
            raise TdicamError(f"{fn.__qualname__}: {exc}") from None
        for name in flags:
            if name in bound.arguments:
                check_flag(f"{fn.__qualname__}: {name}", bound.arguments[name])
        if COMMAND_LINE.get():
            return fn(*args, **kwargs)
        try:
            return fn(*args, **kwargs)
        except TdicamError as exc:
            text = python_names(str(exc), names, rest)
            if text == str(exc):
                raise
            raise TdicamError(text) from None
    return call


#: True while the command line runs (:func:`tdicam.cli.main`): errors name its options;
#: from Python the API's errors name the arguments instead (:func:`python_names`).
COMMAND_LINE = contextvars.ContextVar("tdicam_command_line", default=False)

#: The command line's options whose argument has another name in the Python API.
_RENAMED = {"-o": "out_dir", "--out": "out_dir", "--no-impact": "impact", "--no-rtl": "rtl"}


def python_names(text, names, any_name=False):
    """``text`` with the command-line options that are arguments of an API function
    (``names``; ``any_name``: it takes ``**options`` named as the options) written as those
    arguments: ``--stages = 0 is out of range`` -> ``stages = 0 is out of range``."""
    import re

    def repl(m):
        flag = m.group(1)
        arg = _RENAMED.get(flag, flag.lstrip("-").replace("-", "_"))
        return arg if arg in names or (any_name and flag.startswith("--")) else flag
    return re.sub(r"(?<![\w-])(--?[a-z][a-z0-9-]*)(?![\w-])", repl, text)


def check_flag(name, value) -> bool:
    """``value`` as a bool when it is one (Python's or numpy's), else a one-line
    :class:`TdicamError` ``NAME must be True or False, got V`` (a string such as ``'no'``
    is truthy: taken as a flag it would silently mean True)."""
    if isinstance(value, bool) or (type(value).__module__ == "numpy"
                                   and type(value).__name__ in ("bool_", "bool")):
        return bool(value)
    raise TdicamError(f"{name} must be True or False, got {value!r}")


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
