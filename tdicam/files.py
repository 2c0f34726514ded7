"""Output files and folders of the commands: checked before the work, written with one-line errors.

A command that writes files checks every output path with :func:`check_file` or
:func:`check_dir` before it computes anything (a 30-minute ``tdicam bench`` must not end in
a traceback because of a typo in ``--json``), then writes with :func:`write_file` or inside
:func:`open_output`. Every failure is one :class:`~tdicam.errors.TdicamError` line,
``PATH: cannot write (REASON)`` (``OPTION: ...`` for an empty name): a directory where a
file is wanted, a missing parent folder (file outputs never create folders; ``-o DIR``
outputs create theirs), a place the user may not write, a full device (``/dev/full`` before
the work; a full file system when written). A file left half written by a failed write is
removed.

Layer: a leaf (imports only :mod:`tdicam.errors`).
"""

from __future__ import annotations

import contextlib
import os
import stat
from pathlib import Path

from tdicam.errors import TdicamError

__all__ = ["check_file", "check_dir", "write_file", "open_output", "named", "writing_in"]


def _fail(path, why):
    raise TdicamError(f"{path}: cannot write ({why})")


def named(path, option="-o") -> Path:
    """``path`` as a Path, or ``OPTION: the output name is empty`` for "" or blanks."""
    if path is None or not str(path).strip():
        raise TdicamError(f"{option}: the output name is empty")
    return Path(path)


def check_file(path, option="-o") -> Path:
    """``path`` as a Path once a file can be written there, else a one-line error.

    Checks without changing anything that exists: the name is not empty, is not a folder,
    its parent folder exists, and a file can be created there (probed by creating it and
    removing it again when it did not exist). A character device (``/dev/full``,
    ``/dev/null``, a terminal) is opened and written zero bytes, which a full device
    refuses; a pipe or socket (``/dev/stdout``) is not probed. A regular file on a full
    file system shows only when written (:func:`open_output` reports it, one line).
    """
    p = named(path, option)
    if p.is_dir():
        _fail(p, "it is a directory")
    parent = p.parent
    if not parent.is_dir():
        _fail(p, f"no folder {str(parent)!r}" if not parent.exists()
              else f"{str(parent)!r} is not a folder")
    existed = p.exists()
    mode = p.stat().st_mode if existed else stat.S_IFREG
    if not (stat.S_ISREG(mode) or stat.S_ISCHR(mode)):
        return p                        # a pipe or a socket (/dev/stdout): no probe
    try:
        fd = os.open(p, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            if stat.S_ISCHR(mode):
                os.write(fd, b"")       # writes nothing; a full device refuses it
        finally:
            os.close(fd)
    except OSError as exc:
        _fail(p, exc.strerror or exc)
    if not existed:
        p.unlink(missing_ok=True)
    return p


def check_dir(path, option="-o") -> Path:
    """``path`` as a Path once it is a folder one can write in (created with its parents)."""
    p = named(path, option)
    if p.exists() and not p.is_dir():
        _fail(p, "it exists and is not a folder")
    try:
        p.mkdir(parents=True, exist_ok=True)
        probe = p / ".tdicam-write-probe"
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT, 0o666))
        probe.unlink()
    except OSError as exc:
        _fail(p, exc.strerror or exc)
    return p


@contextlib.contextmanager
def open_output(path, mode="wb"):
    """``open(path, mode)`` whose OS errors (also at close: a full device) become
    ``PATH: cannot write (REASON)``; a regular file left half written is removed."""
    try:
        with open(path, mode) as fh:
            yield fh
    except OSError as exc:
        p = Path(path)
        with contextlib.suppress(OSError):
            if p.is_file():
                p.unlink()
        _fail(path, exc.strerror or exc)


@contextlib.contextmanager
def writing_in(folder):
    """Around code that writes many files into ``folder`` (images, figures, tables): an OS
    error (a full device, a folder made read-only meanwhile) becomes
    ``FOLDER: cannot write (REASON)``, one line."""
    try:
        yield Path(folder)
    except OSError as exc:
        where = f"{folder}/{Path(exc.filename).name}" if getattr(exc, "filename", None) \
            else folder
        _fail(where, exc.strerror or exc)


def write_file(path, data) -> Path:
    """Write ``data`` (str or bytes) to ``path`` (see :func:`open_output`)."""
    with open_output(path, "w" if isinstance(data, str) else "wb") as fh:
        fh.write(data)
    return Path(path)
