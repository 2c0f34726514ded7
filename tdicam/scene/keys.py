"""Scene keys written as ``"section.key"`` paths (``"sensor.read_noise_e"``,
``"run.rtl.pixels_per_clock"``): read and write them in a scene's table of sections (what
:func:`tomllib.load` makes of a scene file). Used by :meth:`tdicam.scene.loader.Scene.replace`
and the sweep files' ``[set]``, ``[axes]`` and ``[zip]`` keys.

Layer: part of the scene reader; imports only the leaves.
"""

from __future__ import annotations

from typing import Any

from tdicam.errors import TdicamError

__all__ = ["check_key", "set_key", "get_key"]


def check_key(key, label) -> str:
    """``key`` if it is a ``section.key`` path, else a one-line :class:`TdicamError` that
    ``label`` starts."""
    if not isinstance(key, str) or "." not in key or not all(key.split(".")):
        raise TdicamError(f"{label}: scene keys are section.key paths, e.g. "
                          f"'sensor.read_noise_e', got {key!r}")
    return key


def set_key(data: dict, key: str, value: Any) -> None:
    """Write ``value`` at ``key`` in ``data``, making the tables on the way; ``None`` removes
    the key (absent: nothing to do)."""
    parts = key.split(".")
    node = data
    for p in parts[:-1]:
        nxt = node.get(p)
        if not isinstance(nxt, dict):
            if value is None:
                return
            nxt = {}
            node[p] = nxt
        node = nxt
    if value is None:
        node.pop(parts[-1], None)
    else:
        node[parts[-1]] = value


def get_key(data: dict, key: str) -> Any:
    """The value at ``key`` in ``data`` (None when absent)."""
    node = data
    for p in key.split("."):
        if not isinstance(node, dict) or p not in node:
            return None
        node = node[p]
    return node
