"""The data of a scene's chain that blocks and tools share: a :class:`Plan` of :class:`Step` s,
the :class:`Context` a block's :attr:`tdicam.blocks.Use.step` plans from, and the raw
:class:`SceneData` the chain runs on.

:mod:`tdicam.camera.design` makes plans from scenes; each block's registry entry
(:mod:`tdicam.blocks`) turns a :class:`Context` into its :class:`Step`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["Step", "Plan", "SceneData", "Context"]


@dataclass(frozen=True)
class Step:
    """One block of a plan: registry ``params``, run-time port values ``ports`` (gateware),
    ``inputs`` (the same settings as the registry's ``run`` side inputs, golden side) and
    ``group`` (incoming frames grouped into one, or None)."""

    block: str
    params: dict
    ports: dict = field(default_factory=dict)
    group: int | None = None
    inputs: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Plan:
    """A scene's chain: ``steps`` in order; input ``lanes`` (channels) of ``lane_elems``
    elements of ``in_bits``; frames of ``rows`` x ``width`` pixels, ``frames`` of them;
    ``ppc`` pixels per beat of every block's stream (``width`` a multiple of it)."""

    steps: tuple
    lanes: int
    lane_elems: int
    in_bits: int
    rows: int
    width: int
    frames: int
    lines: int
    source: str = ""
    ppc: int = 1

    @property
    def input_pixels(self):
        return self.frames * self.rows * self.width * self.lanes


@dataclass
class SceneData:
    """Raw scene data for the chain: per lane (channel) the signal frames and, with CDS,
    the reset frames, ``(frames, rows, width)``; per lane the NUC coefficient codes
    ``(gain, offset)``, ``(rows, width)`` each, or None."""

    signal: list
    reset: list | None = None
    coeffs: list | None = None

    def lane_arrays(self, plan):
        out = []
        for k in range(plan.lanes):
            arrs = [np.asarray(self.signal[k])]
            if plan.lane_elems == 2:
                if self.reset is None:
                    raise TdicamError("pipeline: the chain starts with a two-element block "
                                      "(CDS) but the scene data has no reset frames")
                arrs.append(np.asarray(self.reset[k]))
            out.append(arrs)
        return out

    def crop(self, x0, w, f0, nf):
        """The data of columns ``x0:x0+w`` and frames ``f0:f0+nf``."""
        cut = (lambda a: np.ascontiguousarray(np.asarray(a)[f0:f0 + nf, :, x0:x0 + w]))
        return SceneData([cut(s) for s in self.signal],
                         None if self.reset is None else [cut(r) for r in self.reset],
                         None if self.coeffs is None else
                         [(np.ascontiguousarray(g[:, x0:x0 + w]),
                           np.ascontiguousarray(o[:, x0:x0 + w])) for g, o in self.coeffs])


@dataclass
class Context:
    """What a block's :attr:`tdicam.blocks.Use.step` sees: the ``scene``, TDI stages ``m``,
    frame ``width``, output ``lines``, the chain's pixel width so far (``bits``), whether a
    line-making block came before (``after_lines``), the block being planned and the
    pixels per clock of every block (``ppc``: :func:`tdicam.camera.design.plan` sets it in
    each step's parameters)."""

    scene: object
    m: int
    width: int
    lines: int
    bits: int
    after_lines: bool = False
    block: str = ""
    ppc: int = 1
