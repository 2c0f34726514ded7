"""tdicam: dataflow model and co-simulation harness of a digital-TDI push-broom camera.

The Python API in five lines::

    import tdicam
    scene = tdicam.Scene.example("orbit_600km_1m_96")      # or tdicam.Scene.load("my.toml")
    sim = tdicam.simulate(scene, lines=64, seed=1)
    sim.dataset["tdi"]                                     # xarray: line x pixel, in DN
    sim.save("out/orbit")                                  # what `tdicam run` writes

Public
------
The names in ``__all__`` are the public API, with the signatures and the return types their
docstrings state: :class:`Scene` (``load``, ``from_dict``, ``example``, ``replace``,
``with_run``), :func:`simulate` and its :class:`Simulation` (``dataset``, ``figures``, ``save``), :func:`plan` and its
:class:`Plan` (``to_dict``, ``text``, ``figures``), :func:`sweep`, :func:`examples`,
:mod:`blocks` (``blocks.get(name)``, ``blocks.names()`` and a block's ``golden_model``),
:func:`verilog` and :func:`cosimulate` (a block's Verilog and its co-simulation against the golden
model, by block name), :class:`TdicamError`, and ``__version__``. Within a minor
version (0.x) they change only compatibly: new optional parameters, new dataset variables or
attributes, new report keys. The files ``tdicam run``, ``tdicam sweep`` and the exports
write follow docs/guide/. Everything else (the subpackages' modules, their functions and
classes, a report's key order, a dataset variable's dtype) is internal and may change in any
release.

Importing :mod:`tdicam` is light: the API's modules load on first use of a name
(:pep:`562`).
"""

from __future__ import annotations

import importlib
from typing import Any

from tdicam.errors import TdicamError
from tdicam.version import __version__

__all__ = ["Scene", "Simulation", "simulate", "Plan", "plan", "sweep", "examples", "blocks",
           "verilog", "cosimulate", "TdicamError"]

#: Public names loaded on first use, and the module each comes from.
_LAZY = {name: "tdicam.api" for name in
         ("Scene", "Simulation", "simulate", "Plan", "plan", "sweep", "examples", "verilog",
          "cosimulate")}


def __getattr__(name: str) -> Any:
    if name == "blocks":
        return importlib.import_module("tdicam.blocks")
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'tdicam' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
