"""The one exception type users see.

Every error caused by user input (a bad parameter, a malformed scene, a corrupt golden
file, a lane with no eye, ...) is raised as :class:`TdicamError` with a one-line message
that names the problem. The CLI prints it as ``tdicam: error: <message>`` and exits 2;
it never shows a traceback for these.
"""

__all__ = ["TdicamError", "check_range", "check_choice"]


class TdicamError(ValueError):
    """A user-facing error with a one-line message."""

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))


def check_range(name, value, lo, hi, *, integer=True):
    """Return ``value`` if ``lo <= value <= hi`` (and integral when ``integer``), else raise.

    ``lo`` or ``hi`` may be None for an open end.
    """
    if integer and (isinstance(value, bool) or not isinstance(value, int)):
        try:
            if int(value) != value:
                raise ValueError
            value = int(value)
        except (TypeError, ValueError):
            raise TdicamError(f"{name} must be an integer, got {value!r}") from None
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        lo_s = "-inf" if lo is None else lo
        hi_s = "inf" if hi is None else hi
        raise TdicamError(f"{name} = {value} is out of range; valid: {lo_s}..{hi_s}")
    return value


def check_choice(name, value, choices):
    """Return ``value`` if it is one of ``choices``, else raise listing them."""
    if value not in choices:
        valid = ", ".join(str(c) for c in choices)
        raise TdicamError(f"{name} = {value!r} is not valid; valid: {valid}")
    return value
