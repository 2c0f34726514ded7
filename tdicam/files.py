"""Input and output files of the commands: inputs read with a size limit, outputs checked
before the work and written, all with one-line errors.

A scene, a sweep file, a calibration image or a golden file is read with
:func:`read_bytes`, never with an unbounded ``read()``: an endless or huge file given by
mistake (``/dev/zero``, a disk image, a video) is refused as "not a scene file" (or
calibration image, ...) after at most ``limit`` bytes instead of filling the memory; a named
pipe without a writer reads as empty instead of blocking.

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
import shutil
import stat
from pathlib import Path

from tdicam.errors import TdicamError

__all__ = ["check_file", "check_dir", "write_file", "open_output", "named", "writing_in",
           "staged_dir",
           "read_bytes", "MAX_TOML_BYTES", "size_text"]


def _fail(path, why):
    raise TdicamError(f"{path}: cannot write ({why})")


def named(path, option="-o") -> Path:
    """``path`` as a Path, or ``OPTION: the output name is empty`` for "" or blanks (and
    the errors of :func:`input_path` for what is no name)."""
    if path is None or (isinstance(path, str) and not path.strip()):
        raise TdicamError(f"{option}: the output name is empty")
    p = input_path(path, option)
    if not str(p).strip():
        raise TdicamError(f"{option}: the output name is empty")
    return p


def input_path(path, what) -> Path:
    """``path`` (a str or os.PathLike) as a Path, else ``WHAT: expected a file name, got
    TYPE`` (the Python API's callers pass anything); a name holding a NUL character (no
    file system takes one) is ``WHAT: a file name cannot hold a NUL character``."""
    if not isinstance(path, (str, os.PathLike)):
        raise TdicamError(f"{what}: expected a file name, got {type(path).__name__}")
    try:
        p = Path(path)
    except TypeError:               # an os.PathLike giving bytes
        raise TdicamError(f"{what}: expected a file name, got {path!r}") from None
    if "\0" in str(p):
        raise TdicamError(f"{what}: a file name cannot hold a NUL character, got {str(p)!r}")
    return p


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


def check_dir(path, option="-o", *, create=True) -> Path:
    """``path`` as a Path once it is a folder one can write in (created with its parents).

    With ``create=False`` (a folder written only sometimes, such as the waveform of a
    mismatch) nothing is made: a missing folder is accepted when its nearest existing
    ancestor is a folder one can write in.
    """
    p = named(path, option)
    if p.exists() and not p.is_dir():
        _fail(p, "it exists and is not a folder")
    if not create and not p.exists():
        above = next(a for a in p.absolute().parents if a.exists())
        if not above.is_dir():
            _fail(p, f"{str(above)!r} is not a folder")
        if not os.access(above, os.W_OK | os.X_OK):
            _fail(p, f"{str(above)!r}: permission denied")
        return p
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


@contextlib.contextmanager
def staged_dir(path, option="-o"):
    """Write a command's files into a hidden staging folder and move them into ``path`` only
    when the body finishes: after a refusal, an error or Ctrl-C nothing is left at ``path``
    that was not there before.

    Yields the staging folder. When ``path`` exists it is checked to be a writable folder
    and the staging folder is made inside it (files then move up with :func:`os.replace`,
    each atomically, replacing files of the same name); otherwise it is made beside it
    (missing parent folders are created, and removed again on failure) and renamed to
    ``path``. Errors are one line, ``PATH: cannot write (REASON)``.
    """
    p = named(path, option)
    if p.exists() and not p.is_dir():
        _fail(p, "it exists and is not a folder")
    created = []                       # parents made here, innermost last
    try:
        if p.is_dir():
            stage = p / f".tdicam-staging-{os.getpid()}-{os.urandom(4).hex()}"
        else:
            for parent in reversed(p.absolute().parents):
                if not parent.exists():
                    parent.mkdir()
                    created.append(parent)
            stage = p.parent / f".{p.name}.tdicam-staging-{os.getpid()}-{os.urandom(4).hex()}"
        stage.mkdir()
    except OSError as exc:
        _remove_made(created)
        _fail(p, exc.strerror or exc)
    try:
        yield stage
        with writing_in(p):
            if stage.parent == p:
                names = sorted(stage.iterdir())
                for f in names:             # check all first: move all or none
                    if (p / f.name).is_dir():
                        _fail(p / f.name, "it is a directory")
                for f in names:
                    os.replace(f, p / f.name)
                stage.rmdir()
            else:
                os.replace(stage, p)
    except BaseException as exc:
        shutil.rmtree(stage, ignore_errors=True)
        _remove_made(created)
        if isinstance(exc, TdicamError) and str(stage) in str(exc):
            raise TdicamError(str(exc).replace(str(stage), str(p))) from None   # the user's name
        raise


def _remove_made(folders):
    for d in reversed(folders):
        with contextlib.suppress(OSError):
            d.rmdir()

#: Largest scene or sweep file (TOML) read: hand-written text is kilobytes.
MAX_TOML_BYTES = 4 << 20


def size_text(n):
    """``n`` bytes in words: ``4 MiB``, ``1 GiB``."""
    for unit, shift in (("GiB", 30), ("MiB", 20), ("KiB", 10)):
        if n >= 1 << shift:
            return f"{n / (1 << shift):g} {unit}"
    return f"{n} bytes"


def read_bytes(path, what, limit, head=None):
    """The bytes of ``path``, or a one-line error naming ``what`` (``"scene file"``) and the
    problem. A regular file larger than ``limit`` bytes is refused from its size; a device or
    a pipe is read up to ``limit`` bytes and refused when it has more (``/dev/zero``).

    ``head``: ``(n, size_of)`` for a format whose first ``n`` bytes say how long the file
    is: those bytes are read first and ``size_of(first_bytes)`` returns the most the file
    may hold (or raises :class:`TdicamError`: not that format), so an endless file is
    refused after ``n`` bytes."""
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
            data = b""
            if head is not None:
                data = fh.read(head[0])
                limit = min(limit, head[1](data))
                if st.st_size > limit:
                    raise TdicamError(f"{p}: not a {what}: {size_text(st.st_size)}, more "
                                      f"than the {size_text(limit)} its header allows")
            data += fh.read(limit + 1 - len(data))
    except FileNotFoundError:
        raise TdicamError(f"{what} not found: {str(p)!r}") from None
    except IsADirectoryError:
        raise TdicamError(f"{what} is a directory: {str(p)!r}") from None
    except OSError as exc:
        raise TdicamError(f"cannot read {what} {str(p)!r}: {exc.strerror or exc}") from None
    if len(data) > limit:
        raise TdicamError(f"{p}: not a {what}: it goes on past {size_text(limit)} (an "
                          f"endless or huge file)")
    if not data:
        pipe = stat.S_ISFIFO(st.st_mode)
        raise TdicamError(f"{p}: not a {what}: it is empty (0 bytes"
                          + ("; a named pipe with no writer reads as empty)" if pipe else ")"))
    return data
