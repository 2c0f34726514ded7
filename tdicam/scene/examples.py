"""The bundled example scenes and sweeps (``tdicam scenes``, ``--example NAME`` of ``run``,
``plan``, ``sweep`` and the pipeline commands).

A bundled scene is a ``*.toml`` file in :data:`tdicam.paths.SCENES` (package data of the
wheel, the repository's ``scenes/`` in a checkout), a bundled sweep one in its ``sweeps/``
folder; its name is the file's stem and its description the first sentence of the comment
block the file starts with.

Layer: part of the scene reader; imports only the leaves.
"""

from __future__ import annotations

import re
from pathlib import Path

from tdicam.errors import TdicamError, api_arguments
from tdicam.paths import SCENES

__all__ = ["examples", "example_path", "sweeps", "sweep_path", "KINDS"]

#: What a bundled file is -> the folder it lives in.
KINDS = {"scene": SCENES, "sweep": SCENES / "sweeps"}

#: Longest description :func:`examples` gives (longer first sentences are cut at a word).
DESCRIPTION_CHARS = 80


def _description(path: Path) -> str:
    lines = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    text = " ".join(lines)
    first = re.split(r"(?<=[.:])\s+(?=[A-Z])", text, maxsplit=1)[0].rstrip(":")
    if len(first) > DESCRIPTION_CHARS:
        first = first[:DESCRIPTION_CHARS].rsplit(" ", 1)[0].rstrip(",;:") + " ..."
    return first


@api_arguments
def examples() -> dict[str, str]:
    """The bundled scenes, ``{name: one-line description}``, sorted by name.

    Returns
    -------
    dict of str to str
        Each scene's name (its file's stem, what :func:`example_path` takes) and the first
        sentence of its leading comment (at most :data:`DESCRIPTION_CHARS` characters).
    """
    return _listing("scene")


@api_arguments
def sweeps() -> dict[str, str]:
    """The bundled sweeps, ``{name: one-line description}``, sorted by name (what
    :func:`sweep_path` takes)."""
    return _listing("sweep")


def _listing(kind):
    return {p.stem: _description(p) for p in sorted(KINDS[kind].glob("*.toml"))}


def _bundled(name, kind):
    if not isinstance(name, str):
        raise TdicamError(f"bundled {kind}: expected a name, got {type(name).__name__}")
    stem = name[:-5] if name.endswith(".toml") else name
    path = KINDS[kind] / f"{stem}.toml"
    if "/" in stem or not path.is_file():
        raise TdicamError(f"no bundled {kind} {name!r}; valid: " + ", ".join(_listing(kind))
                          + " ('tdicam scenes' lists them)")
    return path


def example_path(name: str) -> Path:
    """The file of the bundled scene ``name``.

    Parameters
    ----------
    name : str
        A name :func:`examples` lists (a trailing ``.toml`` is accepted).

    Returns
    -------
    Path

    Raises
    ------
    TdicamError
        No bundled scene has that name (one line listing the names).
    """
    return _bundled(name, "scene")


def sweep_path(name: str) -> Path:
    """The file of the bundled sweep ``name`` (a name :func:`sweeps` lists; raises
    :class:`~tdicam.errors.TdicamError` as :func:`example_path` does)."""
    return _bundled(name, "sweep")
