"""Stream beats: the one type every block, golden case and simulator exchanges.

A *beat* is one stream transfer (one AXI4-Stream transfer at the Verilog top): its elements
(pixels or channels), ``first`` (tuser, start of frame), ``last`` (tlast, end of line), the
run-time settings presented with it (``ctrl``) and the resets around it (``rst``, ``seg``).
This module depends on numpy only, so the block registry (:mod:`tdicam.blocks`) and the
simulators (:mod:`tdicam.cosim`, :mod:`tdicam.cosim.streamsim`) both build on it.

Layer: a leaf (imports only :mod:`tdicam.errors`): the beat arrays that the blocks'
registry, the simulators and the exports share.
"""

from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["PPC_CHOICES", "check_ppc", "Beats", "BeatStream", "frames_to_beats",
           "beats_to_frames", "mark_resets", "cut_frames_beats"]

#: Pixels a beat carries (pixels per clock): the one legal set of every stream block, of a
#: chain's top and of the scene key ``[run.rtl].pixels_per_clock``.
PPC_CHOICES = (1, 2, 4, 8)


def check_ppc(ppc, width, label):
    """``ppc`` if it is one of :data:`PPC_CHOICES` dividing ``width`` (None: not checked),
    else the one-line :class:`TdicamError` ``"<label> = P is not valid; valid: 1, 2, 4, 8"``
    or ``"<label> = P: the width W is not a multiple of it"`` (``label`` names the value as
    the user gave it: ``--ppc``, ``pipeline: pixels per clock``)."""
    if ppc not in PPC_CHOICES:
        raise TdicamError(f"{label} = {ppc} is not valid; valid: "
                          f"{', '.join(map(str, PPC_CHOICES))}")
    if width is not None and width % ppc:
        raise TdicamError(f"{label} = {ppc}: the width {width} is not a multiple of it")
    return ppc


@dataclass
class Beats:
    """A sequence of stream beats.

    Attributes
    ----------
    data : ndarray, uint64, shape (n, count)
        Element values (pixels or channels) of each beat, element 0 in the LSBs of tdata.
    first, last : ndarray, bool, shape (n,)
        tuser (start of frame) and tlast (end of line).
    seg : ndarray, uint8, shape (n,)
        Segment (number of testbench resets before the beat).
    ctrl : ndarray, uint64, shape (n,)
        Packed run-time settings presented with the beat (stimulus only).
    rst : ndarray, bool, shape (n,)
        Pulse reset before this beat (stimulus only).
    """

    data: np.ndarray
    first: np.ndarray
    last: np.ndarray
    seg: np.ndarray | None = None
    ctrl: np.ndarray | None = None
    rst: np.ndarray | None = None

    def __len__(self):
        return len(self.first)

    def __post_init__(self):
        n = len(self.first)
        data = np.asarray(self.data, dtype=np.uint64)
        # an empty selection keeps its element count (reshape(0, -1) is ambiguous)
        width = data.shape[-1] if data.ndim > 1 else 1
        self.data = data.reshape(n, -1) if n else data.reshape(0, width)
        self.first = np.asarray(self.first, dtype=bool)
        self.last = np.asarray(self.last, dtype=bool)
        if self.seg is None:
            self.seg = np.zeros(n, np.uint8)
        if self.ctrl is None:
            self.ctrl = np.zeros(n, np.uint64)
        if self.rst is None:
            self.rst = np.zeros(n, bool)

    def select(self, mask):
        return Beats(self.data[mask], self.first[mask], self.last[mask], self.seg[mask],
                     self.ctrl[mask], self.rst[mask])

    @staticmethod
    def concat(parts):
        return Beats(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                       ("data", "first", "last", "seg", "ctrl", "rst")))


@dataclass(frozen=True)
class BeatStream:
    """A golden case too large to hold in memory, made piece by piece.

    Attributes
    ----------
    name : str
        The case's name.
    n_in, n_out : int
        Stimulus and expected beats in all (known before any piece is made).
    pieces : callable() -> iterator of (Beats, Beats)
        Stimulus and expected beats in stream order, a bounded piece at a time (e.g. one
        frame); the pieces' lengths add up to ``n_in`` and ``n_out``.
    """

    name: str
    n_in: int
    n_out: int
    pieces: object


def frames_to_beats(frames, *, ppc=1, channels=1):
    """Raster-order beats of a stack of frames.

    Parameters
    ----------
    frames : ndarray, shape (n_frames, rows, cols) or (n_frames, rows, cols, channels)
    ppc : int
        Pixels per beat; ``cols`` must be a multiple of it. Each beat carries ``ppc``
        pixels x ``channels`` elements, pixel-major (pixel 0's channels first).
    """
    frames = np.asarray(frames)
    if channels == 1 and frames.ndim == 3:
        frames = frames[..., None]
    nf, rows, cols, ch = frames.shape
    if ch != channels:
        raise TdicamError(f"frames have {ch} channels, the block takes {channels}")
    if cols % ppc:
        raise TdicamError(f"width {cols} is not a multiple of ppc = {ppc}")
    per_row = cols // ppc
    data = frames.reshape(nf * rows * per_row, ppc * ch)
    n = len(data)
    idx = np.arange(n)
    first = idx % (rows * per_row) == 0
    last = idx % per_row == per_row - 1
    return Beats(data.astype(np.uint64), first, last)


def beats_to_frames(beats, *, rows, cols, ppc=1, channels=1, dtype=np.uint16):
    """Inverse of :func:`frames_to_beats` for whole frames; returns (frames, first, last)."""
    per_frame = rows * (cols // ppc)
    n = len(beats)
    if n % per_frame:
        raise TdicamError(f"{n} beats is not a whole number of {rows}x{cols} frames")
    shape = (n // per_frame, rows, cols) + ((channels,) if channels > 1 else ())
    return beats.data.astype(dtype).reshape(shape), beats.first, beats.last


def mark_resets(stim, exp, reset_before, exp_before=None):
    """Ask for a DUT reset before stimulus beats ``reset_before`` and number the segments.

    Stimulus beat ``k`` of ``reset_before`` gets ``rst``; it and every later beat move to the
    next segment. Expected output beats move at ``exp_before`` (default: the same indices,
    right for a block that emits one output beat per input beat). ``None`` does nothing.
    """
    if reset_before is None:
        return
    reset_before = np.asarray(reset_before).ravel()
    exp_before = reset_before if exp_before is None else np.asarray(exp_before).ravel()
    for k, e in zip(reset_before, exp_before):
        stim.rst[k] = True
        stim.seg[k:] += 1
        exp.seg[e:] += 1


def cut_frames_beats(rows, heights, keep, reset_after, *, ppc, expected, unit=None,
                     ctrl=None):
    """Stimulus and expected Beats of a stream of frames of one width and any heights, some
    cut short by a reset (the golden-case form of blocks whose cases hold such a stream).

    Parameters
    ----------
    rows : ndarray, (total rows, width)
        Every frame's rows, concatenated.
    heights : sequence of int
        Rows of each frame.
    keep : sequence of int
        Pixels of each frame sent (fewer than its own: cut), rounded up to whole ``unit``
        pixels (default ``ppc``).
    reset_after : sequence of int
        1: a reset before the next frame (none after the last).
    ppc : int
        Pixels a beat (element 0 the leftmost).
    expected : callable(frame, first row, height) -> Beats
        The expected output of each frame, whole (a cut frame's output is a prefix of it).
    ctrl : callable(frame, height) -> int, optional
        The run-time setting that rides with every beat of a frame.
    """
    w = rows.shape[1]
    unit = unit or ppc
    stim_parts, exp_parts, resets, exp_resets = [], [], [], []
    row = n_stim = n_exp = 0
    for f, h in enumerate(list(heights)):
        n = h * w // ppc
        idx = np.arange(n)
        k = -(-int(keep[f]) // unit) * unit // ppc
        stim_parts.append(Beats(rows[row:row + h].reshape(n, ppc)[:k], idx[:k] == 0,
                                idx[:k] % (w // ppc) == w // ppc - 1,
                                ctrl=None if ctrl is None else np.full(k, ctrl(f, h),
                                                                       np.uint64)))
        exp = expected(f, row, h)
        exp_parts.append(exp)
        n_stim += k
        n_exp += len(exp)
        row += h
        if reset_after[f] and f + 1 < len(heights):
            resets.append(n_stim)
            exp_resets.append(n_exp)
    stim, exp = Beats.concat(stim_parts), Beats.concat(exp_parts)
    if resets:
        mark_resets(stim, exp, resets, exp_resets)
    return stim, exp
