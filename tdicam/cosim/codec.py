"""Beat packing and the hex files exchanged with the HDL testbench.

A *beat* is one AXI4-Stream transfer. Stimulus lines are fixed-width hex of the word
``{rst, ctrl, tuser, tlast, tdata}`` (header zero-padded to whole nibbles): ``rst`` asks the
testbench to pulse the DUT reset before presenting that beat (a new *segment* starts),
``ctrl`` holds the values of the DUT's run-time setting ports presented with the beat.
Output lines are ``SS H DDDD`` = segment, ``{tuser, tlast}``, ``tdata``.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import TdicamError

__all__ = ["Beats", "encode_stimulus", "decode_output", "frames_to_beats", "beats_to_frames",
           "mark_resets"]

_HEX = np.frombuffer(b"0123456789abcdef", dtype=np.uint8)
_UNHEX = np.full(256, 255, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789abcdef"):
    _UNHEX[_c] = _i
for _i, _c in enumerate(b"ABCDEF"):
    _UNHEX[_c] = 10 + _i


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


def _digits(values, ndigits):
    """(n, ndigits) ASCII hex digits of uint64 values, most significant first."""
    values = np.asarray(values, dtype=np.uint64)
    shifts = np.arange(ndigits - 1, -1, -1, dtype=np.uint64) * np.uint64(4)
    nib = (values[:, None] >> shifts[None, :]) & np.uint64(15)
    return _HEX[nib.astype(np.intp)]


def _undigits(chars):
    nib = _UNHEX[chars]
    if (nib == 255).any():
        row = int(np.nonzero((nib == 255).any(axis=1))[0][0])
        raise TdicamError(f"simulator output has X/Z or garbage in beat {row}: "
                          f"{bytes(chars[row]).decode(errors='replace')!r}")
    out = np.zeros(chars.shape[0], np.uint64)
    for k in range(chars.shape[1]):
        out = (out << np.uint64(4)) | nib[:, k].astype(np.uint64)
    return out


def header_digits(ctrl_bits):
    """Hex digits of the stimulus header ``{rst, ctrl, tuser, tlast}``."""
    return -(-(ctrl_bits + 3) // 4)


def encode_stimulus(beats, *, elem_padded_bits, ctrl_bits):
    """Fixed-width hex lines of stimulus words, as ``$readmemh`` reads them."""
    n, count = beats.data.shape
    hd = header_digits(ctrl_bits)
    header = (beats.rst.astype(np.uint64) << np.uint64(ctrl_bits + 2)) \
        | (beats.ctrl << np.uint64(2)) | (beats.first.astype(np.uint64) << np.uint64(1)) \
        | beats.last.astype(np.uint64)
    ed = elem_padded_bits // 4
    cols = [_digits(header, hd)]
    cols += [_digits(beats.data[:, k], ed) for k in range(count - 1, -1, -1)]
    cols.append(np.full((n, 1), ord("\n"), np.uint8))
    return np.concatenate(cols, axis=1).tobytes()


def output_line_bytes(elem_padded_bits, count):
    return 2 + 1 + 1 + 1 + (elem_padded_bits // 4) * count + 1


def decode_output(text, *, elem_padded_bits, count):
    """Parse testbench output lines into :class:`Beats`."""
    width = output_line_bytes(elem_padded_bits, count)
    raw = np.frombuffer(text, dtype=np.uint8)
    if raw.size % width:
        raise TdicamError(f"simulator output is malformed: {raw.size} bytes is not a "
                          f"multiple of the {width}-byte line")
    lines = raw.reshape(-1, width)
    seg = _undigits(lines[:, 0:2]).astype(np.uint8)
    flags = _undigits(lines[:, 3:4])
    ed = elem_padded_bits // 4
    data = np.zeros((len(lines), count), np.uint64)
    for k in range(count):
        lo = 5 + (count - 1 - k) * ed
        data[:, k] = _undigits(lines[:, lo:lo + ed])
    return Beats(data, (flags >> np.uint64(1)) & np.uint64(1) == 1,
                 flags & np.uint64(1) == 1, seg)


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
