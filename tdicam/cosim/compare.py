"""Simulated output beats against the golden model's, segment by segment: the count of
mismatches and where the first one is (frame, line, column from the frame markers).

Layer: part of :mod:`tdicam.cosim`; numpy only.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["Comparison", "compare", "locate"]


@dataclass
class Comparison:
    """Result of comparing simulated output with the golden beats.

    ``first`` (None when they match) locates the first mismatch: ``segment``, ``beat`` (in
    the segment), ``index`` (output transfer of the whole run), ``element`` (in the beat),
    ``expected`` and ``received`` (None for a missing or extra beat) and, when the expected
    beats are image frames (``tuser`` marks), ``frame`` (in the segment), ``line`` and
    ``column``.
    """

    checked: int
    mismatches: int
    message: str
    first: dict | None = None

    @property
    def ok(self):
        return self.mismatches == 0


def locate(exp, beat, element=0):
    """Frame, line and column of element ``element`` of expected beat ``beat`` of one
    segment's beats ``exp``, from the frame markers (``first`` starts a frame, ``last`` ends
    a line), or {} when ``exp`` carries no frame (a block whose output is not an image)."""
    if not len(exp) or not exp.first.any() or beat >= len(exp):
        return {}
    frame = int(np.cumsum(exp.first[:beat + 1])[-1]) - 1
    start = int(np.flatnonzero(exp.first[:beat + 1])[-1]) if frame >= 0 else 0
    line_ends = np.flatnonzero(exp.last[start:beat])
    line_start = start + (int(line_ends[-1]) + 1 if len(line_ends) else 0)
    return {"frame": max(frame, 0), "line": len(line_ends),
            "column": (beat - line_start) * exp.data.shape[1] + element}


def _where(first):
    """``frame F line L column C (segment S beat B)`` or ``segment S beat B``."""
    at = f"segment {first['segment']} beat {first['beat']}"
    if "frame" in first:
        return f"frame {first['frame']} line {first['line']} column {first['column']} ({at})"
    return at


def compare(got, exp):
    """Compare output beats with expected beats, segment by segment.

    The last segment must match exactly (data of every element, tuser, tlast, count).
    An earlier segment was cut by a reset: its output must be a prefix of what the golden
    model expects for it (data in flight when reset hit may be dropped, nothing may be
    invented).
    """
    segs = sorted(set(np.unique(exp.seg).tolist()) | set(np.unique(got.seg).tolist()))
    last = max(segs) if segs else 0
    checked = mismatches = 0
    first_msg, first = "", None
    for s in segs:
        g, e = got.select(got.seg == s), exp.select(exp.seg == s)
        n = min(len(g), len(e))
        bad = (g.data[:n] != e.data[:n]).any(axis=1) | (g.first[:n] != e.first[:n]) \
            | (g.last[:n] != e.last[:n])
        extra = len(g) - len(e)
        count_bad = extra if s == last and extra != 0 else max(extra, 0)
        checked += n
        mismatches += int(bad.sum()) + abs(count_bad)
        if first is None and (bad.any() or count_bad):
            k = int(np.argmax(bad)) if bad.any() else n
            el = int(np.argmax(g.data[k] != e.data[k])) if bad.any() else 0
            first = {"segment": int(s), "beat": k, "index": int((got.seg < s).sum()) + k,
                     "element": el,
                     "expected": int(e.data[k, el]) if k < len(e) else None,
                     "received": int(g.data[k, el]) if k < len(g) else None,
                     **locate(e, k, el)}
            if bad.any():
                first_msg = (f"first at {_where(first)}: expected {first['expected']}, "
                             f"received {first['received']} (beat: got data "
                             f"{g.data[k].tolist()} tuser {int(g.first[k])} tlast "
                             f"{int(g.last[k])}, expected {e.data[k].tolist()} tuser "
                             f"{int(e.first[k])} tlast {int(e.last[k])})")
            else:
                first_msg = f"segment {s}: {len(g)} beats out, expected {len(e)}"
    return Comparison(checked, mismatches, first_msg or "match", first)
