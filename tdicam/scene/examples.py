"""The bundled example scenes (``tdicam scenes``, ``tdicam run --example NAME``).

A bundled scene is a ``*.toml`` file in :data:`tdicam.paths.SCENES` (package data of the
wheel, the repository's ``scenes/`` in a checkout); its name is the file's stem and its
description the first sentence of the comment block the file starts with.

Layer: part of the scene reader; imports only the leaves.
"""

from __future__ import annotations

import re
from pathlib import Path

from tdicam.errors import TdicamError, api_arguments
from tdicam.paths import SCENES

__all__ = ["examples", "example_path"]

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
    return {p.stem: _description(p) for p in sorted(SCENES.glob("*.toml"))}


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
    if not isinstance(name, str):
        raise TdicamError(f"bundled scene: expected a name, got {type(name).__name__}")
    stem = name[:-5] if name.endswith(".toml") else name
    path = SCENES / f"{stem}.toml"
    if "/" in stem or not path.is_file():
        raise TdicamError(f"no bundled scene {name!r}; valid: "
                          + ", ".join(p.stem for p in sorted(SCENES.glob("*.toml"))))
    return path
