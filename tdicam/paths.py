"""Where tdicam's data and build folders are, in an installed wheel and in a checkout alike.

The bundled scenes (``scenes/``, with the sweep files in ``scenes/sweeps/``) and the golden
vectors (``golden/`` with ``manifest.json``) are package data: a wheel carries them inside the
package as ``tdicam/scenes`` and ``tdicam/golden``, found with :mod:`importlib.resources`. A
checkout (``pip install -e``) keeps them in the repository's ``scenes/`` and ``golden/``
beside ``tdicam/``, where they are edited. This module is the only place that knows either
layout; everything else asks for :data:`SCENES`, :data:`GOLDEN` and :data:`BUILD`.

Layer: a leaf; imports nothing of tdicam.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

__all__ = ["REPO", "SCENES", "GOLDEN", "BUILD"]

_PACKAGE = Path(str(resources.files("tdicam")))


def _checkout() -> Path | None:
    root = _PACKAGE.resolve().parent
    return root if (root / "pyproject.toml").is_file() and (root / "scenes").is_dir() else None


#: The repository root when tdicam runs from a checkout; None in an installed wheel.
REPO = _checkout()


def _data(name: str) -> Path:
    """The data folder ``name``: the wheel's package data, else the checkout's folder."""
    packaged = _PACKAGE / name
    if packaged.is_dir() or REPO is None:
        return packaged
    return REPO / name


#: Bundled scene files (``*.toml``; sweep files in ``sweeps/``).
SCENES = _data("scenes")
#: Golden vectors: ``<block>/<case>.npz`` and ``manifest.json``.
GOLDEN = _data("golden")
#: Where builds go (co-simulation testbenches, synthesis, formal proofs): ``build/`` in a
#: checkout; in an installed wheel the user's cache, ``$XDG_CACHE_HOME/tdicam`` (default
#: ``~/.cache/tdicam``). ``TDICAM_BUILD`` overrides the co-simulation's
#: (:mod:`tdicam.cosim`).
BUILD = REPO / "build" if REPO is not None else \
    Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "tdicam"
