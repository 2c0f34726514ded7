"""Golden model of the digital TDI accumulator
(Qu et al. 2010 §3, Yuan et al. 2013 §3.1, Tao et al. 2012 §2.2).

Each line period the sensor delivers one *frame*: the m-row window, rows 1..m in readout
order, W pixels each. ``P_k(t)`` is row k of frame t. The scene moves from row m toward row 1,
so a ground line is seen first by row m and last by row 1 (Qu et al. 2010 eq 3)::

    O(t) = P_m(t-m+1) + P_{m-1}(t-m+2) + ... + P_2(t-1) + P_1(t)

``direction = 1`` (reverse scan) mirrors the rows, k <-> m+1-k::

    O(t) = P_1(t-m+1) + P_2(t-m+2) + ... + P_m(t)

Three bit-exact integer implementations of that formula, tested against each other:

* :func:`tdi_basic` — the basic structure of Qu et al. 2010 Fig. 7: row k delayed by its own
  delay line of (k-1) lines, one adder; m(m-1)/2 line buffers (:class:`BasicTdi`).
* :func:`tdi_optimized` — the optimized structure of Qu et al. 2010 Fig. 8 / Yuan et al. 2013 Table 2:
  m-1 running partial-sum lines, updated in place with a rotating base pointer exactly as
  the gateware does (:class:`OptimizedTdi`).
* :func:`tdi` — the formula evaluated for whole blocks of output lines at once (numpy,
  exact; the fast one, >= 2x the real-time line rate of the paper's camera).

:func:`tdi_stream` models the whole block at beat level — settings latched per frame,
refill after a change, malformed frames, the output beats — and produces the golden
vectors (see its docstring for the contract the gateware ``hdl/tdi.py`` implements);
:func:`tdi_frames` is the frame-level equivalent for well-formed frames.

Reverse scan and memory. The m-1 line saving relies on the row that completes a ground
line (row 1) arriving first in each frame, so its line is free before the row that starts
one (row m) arrives last. In reverse, with rows still read out 1..m, the starting row comes
first: just after it, m independent sums are alive, so the optimized structure needs m
lines (:func:`slots_needed`). A block built with m_max - 1 lines therefore runs reverse
scans up to m_max - 1 stages (:func:`settings_valid`); a camera that reverses the sensor's
window readout order instead can use direction 0 at the full m_max.

Widths. Pixels are ``pixel_bits`` (8..14) unsigned. The partial sums and the full-width
output are ``pixel_bits + ceil(log2(stages))`` bits (:func:`full_bits`; 12-bit pixels and 96
stages: 19 bits), enough for ``stages`` full-scale pixels, so nothing ever wraps. With
``out_bits`` given, the output saturates at ``2**out_bits - 1`` (Tao et al. 2012 eq 12). All sums are
computed in unsigned integers wide enough to be exact (uint32/int64), never in the pixel
dtype.
"""

from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from tdicam.beats import PPC_CHOICES
from tdicam.errors import TdicamError, check_multiple, check_range
from tdicam.threads import threads

from tdicam.model.cds import check_pixels, pixel_dtype

__all__ = ["MAX_STAGES", "MAX_WIDTH", "PIXEL_BITS", "full_bits", "out_width",
           "check_params", "settings_valid", "slots_needed", "BasicTdi", "OptimizedTdi",
           "tdi", "tdi_basic", "tdi_optimized", "tdi_frames", "tdi_stream", "StreamOut",
           "basic_line_buffers", "optimized_line_buffers"]

MAX_STAGES = 128
MAX_WIDTH = 8192
PIXEL_BITS = (8, 14)


def _ceil_log2(n):
    return (int(n) - 1).bit_length()


def full_bits(pixel_bits, stages):
    """Partial-sum and full output width: ``pixel_bits + ceil(log2(stages))``."""
    return int(pixel_bits) + _ceil_log2(stages)


def out_width(pixel_bits, stages, out_bits=None):
    """Output width: ``out_bits`` when given (saturating), else :func:`full_bits`."""
    return full_bits(pixel_bits, stages) if out_bits is None else int(out_bits)


def check_params(*, width=None, stages=None, pixel_bits=None, out_bits=None, ppc=1):
    """Check elaboration parameters; raise a one-line :class:`TdicamError` naming the problem.

    ``width`` 2..8192, a multiple of ``ppc`` with at least 2 beats per row; ``stages`` 1..128;
    ``pixel_bits`` 8..14; ``out_bits`` (when given) ``pixel_bits .. full_bits``; ``ppc`` one
    of 1, 2, 4, 8. Parameters passed as None are not checked.
    """
    if ppc not in PPC_CHOICES:
        raise TdicamError(f"ppc = {ppc!r} is not valid; valid: "
                          f"{', '.join(str(c) for c in PPC_CHOICES)}")
    if stages is not None:
        check_range("stages", stages, 1, MAX_STAGES)
    if pixel_bits is not None:
        check_range("pixel_bits", pixel_bits, *PIXEL_BITS)
    if width is not None:
        check_range("width", width, 1, MAX_WIDTH)
        check_multiple(width, ppc)
        if width // ppc < 2:
            raise TdicamError(f"width = {width} with ppc = {ppc} gives {width // ppc} beat per "
                              f"row; need at least 2 (width >= 2 * ppc)")
    if out_bits is not None and pixel_bits is not None and stages is not None:
        hi = full_bits(pixel_bits, stages)
        if isinstance(out_bits, bool) or not isinstance(out_bits, (int, np.integer)) \
                or not pixel_bits <= out_bits <= hi:
            raise TdicamError(f"out_bits = {out_bits!r} is out of range; valid: "
                              f"{pixel_bits}..{hi} (pixel_bits .. pixel_bits + "
                              f"ceil(log2(stages)); omit it for the full width)")


def settings_valid(stages_active, direction, stages):
    """True when the run-time settings are usable with ``stages`` (= m_max) built in.

    ``1 <= stages_active <= stages``, ``direction`` 0 or 1, and — reverse scan only —
    ``stages_active <= stages - 1`` unless ``stages_active == 1``: with rows arriving in readout
    order 1..m, the reverse direction needs one partial-sum line more than the forward one
    (:func:`slots_needed`), and the block has ``stages - 1``.
    """
    m, d = int(stages_active), int(direction)
    if d not in (0, 1) or not 1 <= m <= stages:
        return False
    return slots_needed(m, d) <= stages - 1


def slots_needed(stages_active, direction):
    """Partial-sum lines the optimized structure needs: m-1 forward, m reverse (m >= 2).

    Forward, the row that completes a ground line (row 1) is read first in each frame and
    frees its line before the row that starts one (row m) needs it. Reverse, the starting
    row (row 1) comes first and the completing row (row m) last: just after row 1, m
    independent sums are alive (m-1 old partial sums and the new row), so m lines are
    needed. m = 1 needs none in either direction.
    """
    m = int(stages_active)
    return 0 if m == 1 else m - 1 + int(direction)


def basic_line_buffers(stages_active):
    """Line buffers of the basic structure (Qu et al. 2010 Fig. 7): m(m-1)/2."""
    m = int(stages_active)
    return m * (m - 1) // 2


def optimized_line_buffers(stages_active):
    """Line buffers of the optimized structure (Qu et al. 2010 Fig. 8), forward: m-1."""
    return int(stages_active) - 1


def _check_frames(frames, stages_active, pixel_bits):
    f = np.asarray(frames)
    if f.dtype.kind == "u" and f.size:   # unsigned: one pass (max) instead of two
        if int(f.max()) > (1 << pixel_bits) - 1:
            raise TdicamError(f"frames has values outside 0..{(1 << pixel_bits) - 1} "
                              f"(max {f.max()})")
    else:
        f = check_pixels("frames", f, pixel_bits)
    if f.ndim != 3:
        raise TdicamError(f"frames must have shape (frames, rows, width), got {f.shape}")
    if f.shape[1] != stages_active:
        raise TdicamError(f"frames have {f.shape[1]} rows, stages_active = {stages_active}")
    return f


def _resolve(frames, stages, pixel_bits, out_bits, stages_active, direction):
    check_range("pixel_bits", pixel_bits, *PIXEL_BITS)
    f = np.asarray(frames)
    if f.ndim != 3:
        raise TdicamError(f"frames must have shape (frames, rows, width), got {f.shape}")
    if stages_active is None:
        stages_active = f.shape[1]
    if stages is None:
        stages = stages_active
    check_params(stages=stages, pixel_bits=pixel_bits, out_bits=out_bits)
    check_range("stages_active", stages_active, 1, stages)
    if direction not in (0, 1):
        raise TdicamError(f"direction = {direction!r} is not valid; valid: 0, 1")
    f = _check_frames(f, stages_active, pixel_bits)
    return f, int(stages), int(stages_active), int(direction)


def _saturate(acc, pixel_bits, stages, out_bits):
    ob = out_width(pixel_bits, stages, out_bits)
    if out_bits is not None:
        acc = np.minimum(acc, (1 << ob) - 1)
    return acc.astype(pixel_dtype(ob))


def _row_of(j, m, direction):
    """Readout row (0-based) that contributes to an output ``j`` frames before completion.

    Forward, the frame completing the line (j = 0) contributes row 1, the frame m-1 earlier
    row m; reverse is the mirror.
    """
    return j if direction == 0 else m - 1 - j


def tdi(frames, *, stages=None, pixel_bits=12, out_bits=None, stages_active=None, direction=0):
    """Digital TDI of a stack of frames with one setting (Qu et al. 2010 eq 3), fast and exact.

    Parameters
    ----------
    frames : array_like of int, shape (T, stages_active, W)
        T consecutive frames, rows in readout order, pixels in ``0 .. 2**pixel_bits - 1``.
    stages : int, optional
        m_max of the block (1..128): sets the full output width. Default ``stages_active``.
    pixel_bits : int
        Input width, 8..14.
    out_bits : int, optional
        Saturate the output at ``2**out_bits - 1``; default: full width, never saturates.
    stages_active : int, optional
        m, the number of rows summed (default: the frames' row count).
    direction : 0 or 1
        1 mirrors the rows (reverse scan).

    Returns
    -------
    ndarray, shape (max(T - m + 1, 0), W), dtype :func:`~tdicam.model.cds.pixel_dtype` of the
    output width
        Line i is ``O(i + m - 1)``: the first line needs m frames, then one per frame.

    Notes
    -----
    Sums up to 65535 // (2**pixel_bits - 1) terms in uint16 (exact: they cannot exceed
    65535), then widens to uint32 (the full width is at most 21 bits), in blocks of output
    lines so the working set stays in cache; large inputs spread the blocks over
    ``TDICAM_THREADS`` threads (default: the CPU count, at most 4; the result does not
    depend on it; see :func:`tdicam.threads.threads`).
    """
    f, stages, m, direction = _resolve(frames, stages, pixel_bits, out_bits, stages_active,
                                       direction)
    T, _, W = f.shape
    n = max(T - m + 1, 0)
    total = np.zeros((n, W), np.uint32)
    group = max(1, 0xFFFF // ((1 << pixel_bits) - 1))
    f16 = f.astype(np.uint16, copy=False)
    block = max(1, (1 << 17) // max(W, 1))

    def run(lo_blocks):
        buf = np.empty((min(block, n), W), np.uint16)
        for lo in lo_blocks:
            hi = min(n, lo + block)
            # output i completes in frame i + m - 1; term j comes from frame i + m - 1 - j
            terms = [f16[lo + m - 1 - j:hi + m - 1 - j, _row_of(j, m, direction), :]
                     for j in range(m)]
            for g in range(0, m, group):
                part = terms[g:g + group]
                if len(part) == 1:
                    acc = part[0]
                else:
                    acc = np.add(part[0], part[1], out=buf[:hi - lo])
                    for src in part[2:]:
                        np.add(acc, src, out=acc)
                np.add(total[lo:hi], acc, out=total[lo:hi])

    starts = list(range(0, n, block))
    workers = min(threads(), len(starts)) if n * m * W >= 1 << 24 else 1
    if workers > 1:
        # numpy releases the GIL in these loops; each thread owns whole output blocks
        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(run, [starts[k::workers] for k in range(workers)]))
    else:
        run(starts)
    return _saturate(total, pixel_bits, stages, out_bits)


class BasicTdi:
    """The basic structure (Qu et al. 2010 Fig. 7): per-row delay lines and one adder.

    Readout row r (0-based) is delayed by ``d(r)`` lines — ``r`` forward, ``m-1-r`` reverse —
    in its own FIFO of exactly ``d(r)`` lines; the adder sums the m delayed rows. Total
    storage :attr:`line_buffers` = m(m-1)/2 lines.
    """

    def __init__(self, stages_active, direction=0):
        self.m = int(stages_active)
        self.direction = int(direction)
        self.delay = [_row_delay(r, self.m, self.direction) for r in range(self.m)]
        self.fifos = [deque() for _ in range(self.m)]

    @property
    def line_buffers(self):
        return sum(self.delay)

    def push(self, frame):
        """Feed one frame (m, W); return the completed line (int64) or None while filling."""
        out, ready = np.zeros(frame.shape[1], np.int64), True
        for r in range(self.m):
            line = frame[r].astype(np.int64)
            if self.delay[r]:
                fifo = self.fifos[r]
                fifo.append(line)
                if len(fifo) <= self.delay[r]:
                    ready = False
                    continue
                line = fifo.popleft()
                assert len(fifo) == self.delay[r]
            out += line
        return out if ready else None


def _row_delay(r, m, direction):
    return r if direction == 0 else m - 1 - r


class OptimizedTdi:
    """The optimized structure (Qu et al. 2010 Fig. 8, Yuan et al. 2013 Table 2), as the gateware does it.

    ``slots`` partial-sum lines (:func:`slots_needed`: m-1 forward, m reverse). Every row
    of a frame reads one line and writes its update back to the *same* line (read-modify-
    write at one address); which line each row uses rotates by one per frame (``base``
    pointer) instead of copying lines. Readout row r has *age* a (frames since its ground
    line was first seen: ``m-1-r`` forward, ``r`` reverse): age 0 starts a sum, age m-1
    completes it (the output), others add to the stored sum. A stored sum is used only if
    its ground line was first seen after the last (re)start (``a <= f``, f = frames pushed
    since the start), so stale memory never reaches the output.
    """

    def __init__(self, stages_active, width, direction=0):
        self.m = int(stages_active)
        self.direction = int(direction)
        self.slots = slots_needed(self.m, self.direction)
        self.mem = np.zeros((self.slots, width), np.int64)
        self.base = 0
        self.f = 0

    @property
    def line_buffers(self):
        return self.slots

    def slot(self, r):
        """Line used by readout row r in the current frame."""
        if self.slots == 0:
            return None
        step = r if self.direction == 0 else -r
        return (self.base + step) % self.slots

    def push(self, frame):
        """Feed one frame (m, W); return the completed line (int64) or None while filling."""
        m, out = self.m, None
        for r in range(m):
            age = m - 1 - r if self.direction == 0 else r
            s = self.slot(r)
            val = frame[r].astype(np.int64)
            if 1 <= age <= self.f:
                val = val + self.mem[s]
            if age == m - 1:
                if self.f >= m - 1:
                    out = val
            else:
                self.mem[s] = val
        if self.slots:
            self.base = (self.base + 1) % self.slots
        self.f = min(self.f + 1, m)
        return out


def _run_structure(cls, frames, stages, pixel_bits, out_bits, stages_active, direction):
    f, stages, m, direction = _resolve(frames, stages, pixel_bits, out_bits, stages_active,
                                       direction)
    eng = BasicTdi(m, direction) if cls is BasicTdi else OptimizedTdi(m, f.shape[2], direction)
    lines = [eng.push(fr) for fr in f]
    lines = [x for x in lines if x is not None]
    acc = np.array(lines, np.int64).reshape(len(lines), f.shape[2])
    return _saturate(acc, pixel_bits, stages, out_bits)


def tdi_basic(frames, *, stages=None, pixel_bits=12, out_bits=None, stages_active=None,
              direction=0):
    """:func:`tdi` computed by the basic structure (:class:`BasicTdi`, m(m-1)/2 lines)."""
    return _run_structure(BasicTdi, frames, stages, pixel_bits, out_bits, stages_active,
                          direction)


def tdi_optimized(frames, *, stages=None, pixel_bits=12, out_bits=None, stages_active=None,
                  direction=0):
    """:func:`tdi` computed by the optimized structure (:class:`OptimizedTdi`, m-1 lines)."""
    return _run_structure(OptimizedTdi, frames, stages, pixel_bits, out_bits, stages_active,
                          direction)


def tdi_frames(frames, stages_active, direction=None, *, stages, pixel_bits=12,
               out_bits=None):
    """TDI of a sequence of well-formed frames whose settings may change from frame to frame.

    Parameters
    ----------
    frames : sequence of arrays (m_t, W)
        Frame t has ``stages_active[t]`` rows.
    stages_active, direction : sequences of int, one per frame
        Settings latched with each frame (direction default all 0).

    Returns
    -------
    (lines, frame_index) : ndarray (n, W), ndarray (n,)
        The output lines and the frame each completes. A line is output for frame t when
        the m frames t-m+1..t all have frame t's settings (a change refills the block: no
        line mixes two settings). Frames with invalid settings (:func:`settings_valid`) are
        dropped and break the run.
    """
    n = len(frames)
    direction = [0] * n if direction is None else list(direction)
    stages_active = list(stages_active)
    W = np.asarray(frames[0]).shape[1] if n else 0
    lines, idx = [], []
    t = 0
    while t < n:
        key = (int(stages_active[t]), int(direction[t]))
        u = t
        while u < n and (int(stages_active[u]), int(direction[u])) == key:
            u += 1
        if settings_valid(key[0], key[1], stages):
            run = np.stack([np.asarray(fr) for fr in frames[t:u]])
            out = tdi(run, stages=stages, pixel_bits=pixel_bits, out_bits=out_bits,
                      stages_active=key[0], direction=key[1])
            lines.append(out)
            idx.extend(range(t + key[0] - 1, u))
        t = u
    dt = pixel_dtype(out_width(pixel_bits, stages, out_bits))
    out = np.concatenate(lines) if lines else np.zeros((0, W), dt)
    return out.astype(dt), np.array(idx, np.int64)


@dataclass
class StreamOut:
    """Output of :func:`tdi_stream`: beats and the error count.

    ``data`` (n, ppc) in the output dtype, ``first``/``last`` (n,) bool, ``frame_errors``
    the value of the block's error counter at the end, ``line_frames`` the index (among
    the tuser-started frames) of the frame each output line belongs to.
    """

    data: np.ndarray
    first: np.ndarray
    last: np.ndarray
    frame_errors: int
    line_frames: np.ndarray


def tdi_stream(pixels, first, last, stages_active, direction=0, *, width, stages,
               pixel_bits=12, out_bits=None, ppc=1):
    """Beat-level model of the TDI block: what ``hdl/tdi.py`` emits for an input stream.

    Parameters
    ----------
    pixels : array_like (n, ppc) of int
        Input beats, ``ppc`` pixels each (pixel 0 leftmost).
    first, last : array_like (n,) of bool
        tuser (start of frame) and tlast (end of row) of each beat.
    stages_active, direction : int or array_like (n,)
        Run-time settings presented with each beat; only the values on a tuser beat count.
    width, stages, pixel_bits, out_bits, ppc
        The block's parameters (see :func:`check_params`).

    Returns
    -------
    StreamOut

    Notes
    -----
    Contract (what the gateware implements, beat for beat):

    * A frame starts at each tuser beat and takes the settings presented with it. With
      m = stages_active and WB = width/ppc, a well-formed frame is m rows of WB beats, tlast
      exactly on the last beat of each row, and the next beat is the next frame's tuser.
    * Output: one line of WB beats per well-formed frame once the block holds m consecutive
      well-formed frames with the same settings (the frame itself included); tuser on the
      first beat, tlast on the last. The line is emitted while its *output row* streams in
      (row 1 forward, row m reverse). A frame whose settings differ from the previous frame's
      restarts the count (refill): no line mixes two settings, or frames across a gap.
    * Errors, each counted once in ``frame_errors`` (16-bit, saturating), each restarting
      the count:
      - settings out of range (:func:`settings_valid`): the whole frame is dropped;
      - tlast on a beat that is not the last of a row, or missing on one that is: that beat
        and the rest of the frame are dropped;
      - a tuser before the frame's m*WB beats: the frame is cut there (the tuser beat starts
        the next frame normally);
      - beats after a complete frame, or before the first tuser, with no tuser: dropped up to
        the next tuser.
      If the output line had started (column c > 0 of the output row) when its frame was
      cut or dropped, the line is completed with zero pixels from column c on, so every
      output line has exactly WB beats with tuser and tlast where they belong.
    * At the end of the input an unfinished frame's beats processed so far show (no padding:
      more beats may still come).
    """
    check_params(width=width, stages=stages, pixel_bits=pixel_bits, out_bits=out_bits, ppc=ppc)
    px = np.asarray(pixels)
    if px.dtype.kind != "u" or px.dtype.itemsize > 4:
        px = check_pixels("pixels", px, pixel_bits).astype(np.int64)
    elif px.size and int(px.max()) > (1 << pixel_bits) - 1:
        raise TdicamError(f"pixels has values outside 0..{(1 << pixel_bits) - 1} "
                          f"(max {px.max()})")
    first = np.asarray(first, bool).ravel()
    last = np.asarray(last, bool).ravel()
    n = len(first)
    if px.size != n * ppc or len(last) != n:
        raise TdicamError(f"pixels {px.shape}, first ({n},) and last ({len(last)},) do not "
                          f"describe the same {n} beats of {ppc} pixels")
    px = px.reshape(n, ppc)
    sa = np.asarray(stages_active)
    dr = np.asarray(direction)
    sa = np.broadcast_to(sa, (n,)) if sa.ndim == 0 else sa
    dr = np.broadcast_to(dr, (n,)) if dr.ndim == 0 else dr
    wb = width // ppc
    ob = out_width(pixel_bits, stages, out_bits)
    sat = (1 << ob) - 1
    starts = np.flatnonzero(first)
    errors = 0
    if n and (len(starts) == 0 or starts[0] > 0):
        errors += 1  # beats before the first tuser
    out_data, out_first, out_last, line_frames = [], [], [], []
    hist = []          # previous well-formed frames of the current run, newest last
    key = None         # settings of the current run
    for fi, s in enumerate(starts):
        e = int(starts[fi + 1]) if fi + 1 < len(starts) else n
        cut_by_tuser = fi + 1 < len(starts)
        m, d = int(sa[s]), int(dr[s])
        if not settings_valid(m, d, stages):
            errors += 1
            hist, key = [], None
            continue
        if (m, d) != key:
            hist, key = [], (m, d)
        seg_len = e - s
        frame_len = m * wb
        want_last = (np.arange(min(seg_len, frame_len)) % wb) == wb - 1
        bad = np.flatnonzero(last[s:s + len(want_last)] != want_last)
        if len(bad):
            stop, kind = int(bad[0]), "tlast"          # beats [0, stop) processed
        elif seg_len < frame_len:
            stop, kind = seg_len, ("cut" if cut_by_tuser else "eof")
        elif seg_len > frame_len:
            stop, kind = frame_len, "long"
        else:
            stop, kind = frame_len, "ok"
        rows = px[s:s + stop]
        out_row = 0 if d == 0 else m - 1
        n_ok = min(max(stop - out_row * wb, 0), wb)
        if len(hist) >= m - 1 and n_ok:
            acc = np.zeros((n_ok, ppc), np.int64)
            acc += rows[out_row * wb:out_row * wb + n_ok]
            for j in range(1, m):
                prev = hist[-j]
                r = _row_of(j, m, d)
                acc += prev[r * wb:r * wb + n_ok]
            beats = np.minimum(acc, sat)
            c_first = np.zeros(n_ok, bool)
            c_first[0] = True
            c_last = np.arange(n_ok) == wb - 1
            if n_ok < wb and kind in ("tlast", "cut"):
                beats = np.concatenate([beats, np.zeros((wb - n_ok, ppc), np.int64)])
                c_first = np.concatenate([c_first, np.zeros(wb - n_ok, bool)])
                c_last = np.arange(wb) == wb - 1
            out_data.append(beats)
            out_first.append(c_first)
            out_last.append(c_last)
            line_frames.append(fi)
        if kind == "ok":
            hist.append(rows)
            hist = hist[-max(m - 1, 1):] if m > 1 else []
        elif kind == "eof":
            pass
        else:
            errors += 1
            hist, key = [], None
    dt = pixel_dtype(ob)
    if out_data:
        data = np.concatenate(out_data).astype(dt)
        fst, lst = np.concatenate(out_first), np.concatenate(out_last)
    else:
        data, fst, lst = np.zeros((0, ppc), dt), np.zeros(0, bool), np.zeros(0, bool)
    return StreamOut(data, fst, lst, min(errors, 0xFFFF), np.array(line_frames, np.int64))
