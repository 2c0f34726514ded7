"""Beat packing and the files exchanged with the HDL testbench.

A *beat* is one AXI4-Stream transfer. A stimulus word is ``{rst, ctrl, tuser, tlast,
tdata}`` (header zero-padded to whole nibbles): ``rst`` asks the testbench to pulse the DUT
reset before presenting that beat (a new *segment* starts), ``ctrl`` holds the values of the
DUT's run-time setting ports presented with the beat. :func:`encode_stimulus` writes the
words as fixed-width hex lines (``$readmemh``), :func:`encode_stimulus_bin` as fixed-width
big-endian binary records (``$fread``, the fast-mode stimulus). Output lines are
``SS H DDDD`` = segment, ``{tuser, tlast}``, ``tdata``.
"""

import numpy as np

# re-exported for existing callers: the beat type lives in tdicam.beats
from tdicam.beats import Beats, beats_to_frames, frames_to_beats, mark_resets  # noqa: F401
from tdicam.errors import TdicamError

__all__ = ["encode_stimulus", "encode_stimulus_bin", "stimulus_word_bytes",
           "stimulus_words_bin", "decode_output",
           "header_digits", "output_line_bytes"]

_HEX = np.frombuffer(b"0123456789abcdef", dtype=np.uint8)
_UNHEX = np.full(256, 255, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789abcdef"):
    _UNHEX[_c] = _i
for _i, _c in enumerate(b"ABCDEF"):
    _UNHEX[_c] = 10 + _i


def _nibbles(values, ndigits):
    """(n, ndigits) uint8 nibbles of uint64 values, most significant first."""
    values = np.asarray(values, dtype=np.uint64)
    shifts = np.arange(ndigits - 1, -1, -1, dtype=np.uint64) * np.uint64(4)
    return ((values[:, None] >> shifts[None, :]) & np.uint64(15)).astype(np.uint8)


def _digits(values, ndigits):
    """(n, ndigits) ASCII hex digits of uint64 values, most significant first."""
    return _HEX[_nibbles(values, ndigits)]


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


def _stimulus_nibbles(beats, elem_padded_bits, ctrl_bits):
    """(n, digits) uint8 nibbles of the stimulus words, most significant first; a
    run-time setting wider than the ``ctrl_bits`` of the top's ports is refused (it would
    spill into the reset bit of its record)."""
    check_ctrl(beats.ctrl, ctrl_bits)
    hd = header_digits(ctrl_bits)
    header = (beats.rst.astype(np.uint64) << np.uint64(ctrl_bits + 2)) \
        | (beats.ctrl << np.uint64(2)) | (beats.first.astype(np.uint64) << np.uint64(1)) \
        | beats.last.astype(np.uint64)
    ed = elem_padded_bits // 4
    count = beats.data.shape[1]
    cols = [_nibbles(header, hd)]
    cols += [_nibbles(beats.data[:, k], ed) for k in range(count - 1, -1, -1)]
    return np.concatenate(cols, axis=1)


def check_ctrl(ctrl, ctrl_bits):
    """A one-line :class:`TdicamError` when a beat's run-time settings ``ctrl`` do not fit
    the ``ctrl_bits`` of the top's settings ports (the port would see them truncated)."""
    ctrl = np.asarray(ctrl, np.uint64)
    bad = np.flatnonzero(ctrl >> np.uint64(ctrl_bits)) if ctrl.size else ()
    if len(bad):
        raise TdicamError(f"beat {bad[0]}: run-time settings {int(ctrl[bad[0]])} do not fit "
                          f"the {ctrl_bits} bit(s) of the block's settings ports")


def encode_stimulus(beats, *, elem_padded_bits, ctrl_bits):
    """Fixed-width hex lines of stimulus words, as ``$readmemh`` reads them."""
    nib = _stimulus_nibbles(beats, elem_padded_bits, ctrl_bits)
    nl = np.full((nib.shape[0], 1), ord("\n"), np.uint8)
    return np.concatenate([_HEX[nib], nl], axis=1).tobytes()


def stimulus_word_bytes(*, elem_padded_bits, count, ctrl_bits):
    """Bytes of one binary stimulus record: the word zero-extended to whole bytes."""
    return -(-(header_digits(ctrl_bits) + count * (elem_padded_bits // 4)) // 2)


def encode_stimulus_bin(beats, *, elem_padded_bits, ctrl_bits):
    """Binary stimulus records, as ``$fread(mem, fd)`` reads them into a memory of
    ``8 * stimulus_word_bytes(...)``-bit words: each word zero-extended to whole bytes, most
    significant byte first, records back to back (no separators)."""
    nib = _stimulus_nibbles(beats, elem_padded_bits, ctrl_bits)
    if nib.shape[1] % 2:
        nib = np.concatenate([np.zeros((nib.shape[0], 1), np.uint8), nib], axis=1)
    return ((nib[:, 0::2] << 4) | nib[:, 1::2]).astype(np.uint8).tobytes()


def stimulus_words_bin(data, record_bytes):
    """The stimulus words (Python ints) of binary records, inverse of
    :func:`encode_stimulus_bin`."""
    if len(data) % record_bytes:
        raise TdicamError(f"stimulus file is malformed: {len(data)} bytes is not a multiple "
                          f"of the {record_bytes}-byte record")
    return [int.from_bytes(data[k:k + record_bytes], "big")
            for k in range(0, len(data), record_bytes)]


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
