"""Input files of the commands: read whole with a size limit and one-line errors.

A scene, a sweep file, a calibration image or a golden file is read with
:func:`read_bytes`, never with an unbounded ``read()``: an endless or huge file given by
mistake (``/dev/zero``, a disk image, a video) is refused as "not a scene" (or calibration
image, ...) after at most ``limit`` bytes, instead of filling the memory. Every failure is one
:class:`~tdicam.errors.TdicamError` line naming what the file was meant to be and its path:
missing, a folder, unreadable, too large.
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import TdicamError

__all__ = ["read_bytes", "MAX_TOML_BYTES", "size_text"]

#: Largest scene or sweep file (TOML) read: hand-written text is kilobytes.
MAX_TOML_BYTES = 4 << 20


def size_text(n):
    """``n`` bytes in words: ``4 MiB``, ``1 GiB``."""
    for unit, shift in (("GiB", 30), ("MiB", 20), ("KiB", 10)):
        if n >= 1 << shift:
            return f"{n / (1 << shift):g} {unit}"
    return f"{n} bytes"


def read_bytes(path, what, limit):
    """The bytes of ``path``, or a one-line error naming ``what`` (``"scene file"``) and the
    problem. A regular file larger than ``limit`` bytes is refused from its size; a device or
    a pipe is read up to ``limit`` bytes and refused when it has more (``/dev/zero``)."""
    p = Path(path)
    try:
        # a named pipe without a writer would block open() for ever: open it without
        # blocking, then read normally (no writer: end of file at once)
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        with os.fdopen(fd, "rb") as fh:
            st = os.fstat(fh.fileno())
            if st.st_size > limit:
                raise TdicamError(f"{p}: not a {what}: {size_text(st.st_size)}, more than "
                                  f"the {size_text(limit)} a {what} may have")
            data = fh.read(limit + 1)
    except FileNotFoundError:
        raise TdicamError(f"{what} not found: {str(p)!r}") from None
    except IsADirectoryError:
        raise TdicamError(f"{what} is a directory: {str(p)!r}") from None
    except OSError as exc:
        raise TdicamError(f"cannot read {what} {str(p)!r}: {exc.strerror or exc}") from None
    if len(data) > limit:
        raise TdicamError(f"{p}: not a {what}: it goes on past {size_text(limit)} (an "
                          f"endless or huge file)")
    return data
