"""Golden chain of a camera pipeline: the blocks' golden models run in order on arrays.

:func:`chain` knows no block by name: each :class:`GoldenStage` carries its block's golden
function with the block's parameters and side inputs already bound (the table that makes
them from a scene is :mod:`tdicam.chain.design`). It returns every stage's output, the values
the gateware top's taps must show, bit for bit.
"""

from dataclasses import dataclass
from typing import Callable

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["GoldenStage", "chain"]


@dataclass(frozen=True)
class GoldenStage:
    """One block of the chain.

    Attributes
    ----------
    name : str
        Stage name (the tap's name).
    fn : callable(arrays, lane) -> ndarray
        The block's golden model: ``arrays`` is the list of the lane's input element arrays
        (e.g. ``[signal, reset]``), or of every lane's for a merging stage, each of shape
        ``(frames, rows, cols)``; returns ``(frames', rows', cols)`` (a block that makes one
        line per frame returns ``rows' = 1``).
    merge : bool
        Takes the elements of every lane (one output lane).
    group : int or None
        Group this many incoming frames into one frame first (TDI's one-line frames into
        one image of ``group`` lines); the frame count must be a multiple of it.
    """

    name: str
    fn: Callable
    merge: bool = False
    group: int | None = None


def chain(lanes, stages):
    """Run ``stages`` on ``lanes``.

    Parameters
    ----------
    lanes : list of list of ndarray
        Per channel lane, its input element arrays, each ``(frames, rows, cols)`` of
        integers (e.g. ``[[hg_signal, hg_reset], [lg_signal, lg_reset]]``).
    stages : list of :class:`GoldenStage`

    Returns
    -------
    list of (str, list of ndarray)
        Per stage, its name and its output per lane (``(frames, rows, cols)`` each, the
        block's own dtype), in stream order: tap ``k`` of the gateware top is entry ``k``,
        lane by lane.

    Raises
    ------
    TdicamError
        When a grouped stage's frames are not a whole number of groups.
    """
    cur = [list(l) for l in lanes]
    out = []
    for st in stages:
        if st.merge:
            cur = [[a for lane in cur for a in lane]]
        res = []
        for k, arrays in enumerate(cur):
            if st.group is not None:
                arrays = [_group(a, st.group, st.name) for a in arrays]
            res.append(np.asarray(st.fn(arrays, k)))
        out.append((st.name, res))
        cur = [[r] for r in res]
    return out


def _group(a, n, name):
    a = np.asarray(a)
    if a.shape[0] % n:
        raise TdicamError(f"{name}: {a.shape[0]} frames is not a whole number of groups of "
                          f"{n}")
    return a.reshape(a.shape[0] // n, n * a.shape[1], a.shape[2])
