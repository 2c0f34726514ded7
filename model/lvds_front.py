"""Golden model of the camera's front end: sensor frames -> serial lanes -> pixel frames.

The sensor side (Ning et al. 2019 §4.1, the GMAX0504: 40 lanes per gain channel, 12-bit
words, 300 Mbit/s) and the receiver side of :class:`tdicam.hdl.lvds_front.LvdsFront`, bit
for bit, in plain integer numpy. The serial link itself (eye, skew, jitter, training) is
:mod:`tdicam.model.lvds`; this module says what the lanes carry and what pixels and
invalid-column mask the front makes of them.

Lane-to-column convention (interleaved)
---------------------------------------
``L = lanes_per_gain`` lanes per gain channel; lane ``g*L + k`` (``g`` = 0 high gain, 1 low
gain; ``k`` = 0..L-1) carries the columns ``k, k+L, k+2L, ...`` of channel ``g``: word ``j``
of a line on lane ``k`` is column ``j*L + k``. One word clock therefore brings ``L``
adjacent columns per channel, which the front splits into beats of ``ppc`` pixels without a
line buffer. Every lane sends ``P = ceil(columns / L)`` pixel words a line: when ``L`` does
not divide ``columns`` (the GMAX0504's 5144 columns on 40 lanes: 128 words and 24
columns over) the last word clock of a line carries ``columns - (P - 1) L`` columns, on
lanes ``0 ..``, and the lanes above send a *padded slot* (the value 0, never a column):
:func:`padded_slots`. The front drops the padded slots (its last entry of a line gives
fewer beats).

Line format (every lane, in the link model's data segments)
-----------------------------------------------------------
``[sync, header, pixel word 0, ..., pixel word P-1]`` with ``P = ceil(columns / L)``:
``line_words = P + 2``. ``sync`` is the link's sync word (all ones); ``header`` is the row
index inside the frame (0 = the frame's first line) in its low ``word_bits - 1`` bits and the
frame's *kind* in its top bit (1: a reset frame, the sensor's reset level read for off-chip
CDS; 0: a signal frame), the same on every lane, so the front finds frame starts and tells
the CDS stage which frame is which (:func:`header_word`); rows must therefore be
< ``2**(word_bits - 1) - 2``. A sensor read for CDS sends each reset frame before its signal
frame; the front passes the kind on with every beat. Frames follow each other without gaps; a data segment carries whole frames and ends with a *blank line* (header
``2**word_bits - 2``, pixel words 0: :func:`blank_line`), so the last frame's words have left
the receiver before the sensor goes back to training.

The all-ones code is reserved for sync (the link's monitor checks that it appears only at
line starts): a pixel equal to it is sent as ``2**word_bits - 2`` (:func:`wire_code`); only
a sensor whose ADC has as many bits as the word can produce it (its full-scale code).
"""

import numpy as np

from tdicam.errors import TdicamError, check_range
from tdicam.model import lvds

__all__ = ["GMAX0504", "scene_untrained_lanes", "line_words", "padded_slots",
           "last_word_columns", "check_geometry", "header_word", "wire_code", "lane_payload",
           "blank_line", "segment_payload", "column_lane", "invalid_columns", "receive",
           "data_words", "frames_from_lanes", "min_proc_mhz", "fifo_depth", "eye_lane",
           "scene_lanes", "untrained_lanes", "lane_mask", "cut_frame", "lane_death"]

#: The GMAX0504 front of Ning et al. 2019: lanes per gain channel, word bits, bit rate.
GMAX0504 = {"lanes_per_gain": 40, "word_bits": 12, "bit_rate_mbps": 300.0}


def line_words(columns, lanes_per_gain):
    """Words of one line on every lane: sync, header, ``ceil(columns / lanes_per_gain)``
    pixel words (a lane with a column fewer pads its last slot)."""
    return -(-int(columns) // int(lanes_per_gain)) + 2


def padded_slots(columns, lanes_per_gain):
    """Padded slots a line of a gain channel: ``P L - columns`` (``P`` pixel words a lane:
    :func:`line_words` - 2), on lanes ``L - slots .. L - 1`` in their last word."""
    return (line_words(columns, lanes_per_gain) - 2) * lanes_per_gain - int(columns)


def last_word_columns(columns, lanes_per_gain):
    """Columns the last word clock of a line carries (of a gain channel): ``columns - (P -
    1) L``, 1..L (``L`` when ``L`` divides ``columns``: no padded slot)."""
    return int(columns) - (line_words(columns, lanes_per_gain) - 3) * int(lanes_per_gain)


def _padded(a, lanes_per_gain):
    """``a`` (``(..., C)``) with :func:`padded_slots` zero columns on the right."""
    a = np.asarray(a)
    pad = padded_slots(a.shape[-1], lanes_per_gain)
    return np.pad(a, [(0, 0)] * (a.ndim - 1) + [(0, pad)]) if pad else a


def check_geometry(columns, rows, lanes_per_gain, word_bits, bits, *, key="lanes_per_gain"):
    """One-line :class:`TdicamError` unless the frame fits the line format (``key`` names
    the lane count as the caller's user wrote it)."""
    check_range(key, lanes_per_gain, 1, 128)
    if columns < lanes_per_gain:
        raise TdicamError(f"{key} = {lanes_per_gain} is more lanes than the {columns} columns "
                          f"(lane k carries columns k, k+L, ...: every lane at least one)")
    if bits > word_bits:
        raise TdicamError(f"word_bits = {word_bits} is narrower than the {bits}-bit pixels")
    if rows >= (1 << (word_bits - 1)) - 2:
        raise TdicamError(f"{rows} rows a frame: the row header of a {word_bits}-bit word "
                          f"(its top bit the frame kind) counts to "
                          f"{(1 << (word_bits - 1)) - 3}")


def header_word(row, kind, word_bits):
    """The header word of line ``row`` of a frame of ``kind`` (1 reset, 0 signal): the row
    in the low ``word_bits - 1`` bits, the kind in the top bit."""
    return np.asarray(row, np.int64) | (np.asarray(kind, np.int64) << (word_bits - 1))


def wire_code(frames, word_bits):
    """Pixel codes as the sensor sends them: the all-ones sync code becomes all ones - 1."""
    a = np.asarray(frames, dtype=np.int64)
    sync = (1 << word_bits) - 1
    return np.where(a == sync, sync - 1, a)


def lane_payload(frames, lanes_per_gain, word_bits, kinds=None):
    """The data-segment words of every lane for ``frames`` (one ``(F, R, C)`` stack per gain
    channel) of ``kinds`` (``F`` values, 1 a reset frame, 0 a signal frame; None: all
    signal frames): a tuple of ``G * L`` int64 arrays of ``F * R * line_words`` words (for
    :class:`tdicam.model.lvds.Link` ``payload``)."""
    L = lanes_per_gain
    out = []
    for stack in frames:
        a = wire_code(stack, word_bits)
        nf, nr, nc = a.shape
        check_geometry(nc, nr, L, word_bits, word_bits)
        kind = np.zeros(nf, np.int64) if kinds is None else np.asarray(kinds, np.int64)
        a = _padded(a, L)
        p = line_words(nc, L) - 2
        words = np.empty((L, nf, nr, p + 2), np.int64)
        words[:, :, :, 0] = (1 << word_bits) - 1
        words[:, :, :, 1] = header_word(np.arange(nr)[None, :], kind[:, None],
                                        word_bits)[None]
        words[:, :, :, 2:] = a.reshape(nf, nr, p, L).transpose(3, 0, 1, 2)
        out.extend(words.reshape(L, -1))
    return tuple(out)


def blank_line(columns, lanes_per_gain, word_bits):
    """The words of a blank line (the same on every lane): sync, header ``2**W - 2``, 0s."""
    words = np.zeros(line_words(columns, lanes_per_gain), np.int64)
    words[:2] = (1 << word_bits) - 1, (1 << word_bits) - 2
    return words


def segment_payload(segments, lanes_per_gain, word_bits, kinds=None):
    """:func:`lane_payload` of several data segments (each a list of per-gain frame
    stacks), each followed by a :func:`blank_line`; ``kinds``: the frames' kinds, all
    segments' in order (None: signal frames)."""
    parts, f0 = [], 0
    for frames in segments:
        nf = len(frames[0])
        pay = lane_payload(frames, lanes_per_gain, word_bits,
                           None if kinds is None else np.asarray(kinds)[f0:f0 + nf])
        f0 += nf
        blank = blank_line(np.asarray(frames[0]).shape[-1], lanes_per_gain, word_bits)
        parts.append([np.concatenate([p, blank]) for p in pay])
    return tuple(np.concatenate(lane) for lane in zip(*parts))


def column_lane(columns, lanes_per_gain):
    """Lane (within its gain channel) of each column: ``c % lanes_per_gain``."""
    return np.arange(columns) % lanes_per_gain


def invalid_columns(bad_lanes, columns, lanes_per_gain, gains):
    """Invalid-column mask ``(gains, columns)`` bool of a set of lane numbers (0-based,
    high-gain lanes first)."""
    L = lanes_per_gain
    bad = np.zeros(gains * L, bool)
    bad[list(bad_lanes)] = True
    lane = column_lane(columns, L)
    return np.stack([bad[g * L + lane] for g in range(gains)])


def receive(frames, bad_lanes, lanes_per_gain, word_bits):
    """What the front delivers of ``frames`` (one ``(F, R, C)`` stack per gain) whose lanes
    ``bad_lanes`` did not train: the wire codes, 0 in the invalid columns, and the
    invalid-column mask ``(G, C)``. Returns ``(pixels (G, F, R, C) int64, invalid)``."""
    px = np.stack([wire_code(f, word_bits) for f in frames])
    inv = invalid_columns(bad_lanes, px.shape[-1], lanes_per_gain, len(frames))
    px = np.where(inv[:, None, None, :], 0, px)
    return px, inv


def data_words(link, lane_index):
    """The words lane ``lane_index`` of ``link`` sends in its data segments, in order (its
    :class:`tdicam.model.lvds.Link` payload's extent of them: what the receiver gets once
    trained)."""
    starts = [n for n, _ in link.schedule] + [None]
    out, left = [], len(link.payload[lane_index]) if link.payload else 0
    for (n0, mode), n1 in zip(link.schedule, starts[1:]):
        if mode != "data" or left <= 0:
            continue
        k = left if n1 is None else min(left, n1 - n0)
        out.append(lvds.sent_words(link, lane_index, np.arange(n0, n0 + k)))
        left -= k
    return np.concatenate(out) if out else np.zeros(0, np.int64)


def frames_from_lanes(words, lanes_per_gain, rows, word_bits, bad_lanes=(), columns=None):
    """The golden front on the lanes' words: ``words`` one int64 array per lane (high-gain
    lanes first; each its data-segment words, e.g. :func:`data_words`), cut into lines
    ``[sync, header, P pixels]``; a frame is ``rows`` lines from a header-0 line (blank
    lines and lines outside a frame are skipped); the pixels of lane ``g L + k`` go to
    columns ``k, k+L, ...`` of channel ``g``, the first ``columns`` kept (None: ``P L``;
    the rest are padded slots). Lanes ``bad_lanes`` (not trained) read 0.

    Returns ``(pixels (G, F, R, C) int64, invalid (G, C) bool)``; a line format violation
    (no sync where a line starts, lanes disagreeing on a header) is a :class:`TdicamError`.
    """
    L = lanes_per_gain
    words = [np.asarray(x, np.int64) for x in words]
    n, g = len(words), len(words) // L
    sync = (1 << word_bits) - 1
    good = [i for i in range(n) if i not in set(bad_lanes)]
    if not good:
        raise TdicamError("no lane trained: no frames")
    total = len(words[good[0]])
    lines = []
    pos = 0
    lw = None
    while pos < total:
        if words[good[0]][pos] != sync:
            raise TdicamError(f"lane {good[0]}: word {pos} is not a sync word")
        if lw is None:
            nxt = np.flatnonzero(words[good[0]][pos + 1:] == sync)
            lw = int(nxt[0]) + 1 if len(nxt) else total - pos
        heads = {int(words[i][pos + 1]) for i in good}
        if len(heads) != 1:
            raise TdicamError(f"lanes disagree on the header of the line at word {pos}")
        lines.append((heads.pop(), pos))
        pos += lw
    p = lw - 2
    frames, kinds, k = [], [], 0
    top = 1 << (word_bits - 1)
    while k < len(lines):
        kind = lines[k][0] // top
        want = list(header_word(np.arange(rows), kind, word_bits))
        if lines[k][0] % top == 0 and k + rows <= len(lines) and \
                [h for h, _ in lines[k:k + rows]] == want:
            f = np.zeros((g, rows, p * L), np.int64)
            for r, (_, at) in enumerate(lines[k:k + rows]):
                for i in good:
                    f[i // L, r, i % L::L] = words[i][at + 2:at + 2 + p]
            frames.append(f)
            kinds.append(kind)
            k += rows
        else:
            k += 1
    c = p * L if columns is None else int(columns)
    if not (p - 1) * L < c <= p * L:
        raise TdicamError(f"lines of {p} pixel words on {L} lanes carry {(p - 1) * L + 1} to "
                          f"{p * L} columns, not {c}")
    px = np.stack(frames, axis=1)[..., :c] if frames else np.zeros((g, 0, rows, c), np.int64)
    return px, invalid_columns(bad_lanes, c, L, g), np.asarray(kinds, np.int64)


def min_proc_mhz(lanes_per_gain, ppc, columns, word_mhz):
    """The slowest processing clock (MHz) that takes a line of ``columns`` at ``ppc`` from
    the lanes' ``word_mhz`` word clock: its ``columns / ppc`` beats in the line's ``P + 2``
    word clocks (:func:`line_words`), ``word_mhz columns / ((P + 2) ppc)``."""
    L, p = lanes_per_gain, line_words(columns, lanes_per_gain) - 2
    if L * p == columns:        # written as ever: the FIFO depths of lanes that divide
        return word_mhz * L * p / ((p + 2) * ppc)
    return word_mhz * columns / ((p + 2) * ppc)


def fifo_depth(lanes_per_gain, ppc, columns, word_mhz, proc_mhz, *, slack=8,
               stall_cycles=0):
    """Words of the front's clock-domain-crossing FIFO (a power of two, >= 8).

    A FIFO entry is one word clock's words of every lane (``L`` columns per channel); the
    processing clock takes ``L / ppc`` clocks to send an entry on (a line's last entry with
    padded slots fewer). Entries arrive in bursts of ``P = ceil(columns / L)`` words a line
    (then 2 words of sync and header), at the word rate ``f_w``; they leave at ``r = f_p ppc
    / L`` entries a second. The front keeps up when its ``columns / ppc`` clocks a line take
    no longer than the line's ``P + 2`` word clocks, ``f_p ppc (P + 2) >= f_w columns``
    (else a one-line :class:`TdicamError`); during a line's burst the FIFO grows by at most
    ``P (1 - r / f_w)`` entries.

    The front has no backpressure (the sensor sets the pace): a block behind it that
    holds the stream -- ``stall_cycles`` processing clocks at once, the DDR model's worst
    stall (:func:`tdicam.model.dram.worst_stall`: refresh cycles + the longest read latency,
    104 by default; cds_ddr waits for each signal frame's first reset line) -- lets
    ``stall_cycles f_w / f_p`` more entries pile up. So::

        depth = 2**ceil(log2(ceil(P max(0, 1 - r / f_w)) + ceil(stall_cycles f_w / f_p)
                              + slack))

    with ``slack`` for the crossing's synchronizer latency and the read side's pipeline.
    The depth covers one worst stall; the processing side drains it with what it has to
    spare, ``(P + 2) r / f_w - P`` entries a line, so a stall once a frame pair (cds_ddr's,
    at each signal frame) is drained before the next when the ``2 R`` lines of a
    reset/signal pair spare the stall's entries (e.g. ``r = f_w``: 2 entries a line, a
    104-clock stall at ``f_p = 4 f_w`` is 26 entries: ``R >= 7`` rows).
    """
    L, p = lanes_per_gain, line_words(columns, lanes_per_gain) - 2
    ratio = proc_mhz * ppc / (L * word_mhz)
    slowest = min_proc_mhz(L, ppc, columns, word_mhz)
    if proc_mhz < slowest * (1 - 1e-9):
        raise TdicamError(f"the processing clock ({proc_mhz:g} MHz x {ppc} pixels) cannot take "
                          f"{L} lanes at {word_mhz:g} M words/s: needs >= {slowest:.4g} MHz")
    need = int(np.ceil(p * max(0.0, 1.0 - ratio))) + slack \
        + int(np.ceil(stall_cycles * word_mhz / proc_mhz - 1e-9))
    return max(8, 1 << (need - 1).bit_length())


def eye_lane(centre_taps, width_taps, *, tap_ps=lvds.PAPER_TAP_PS, jitter_ps=0.0,
             bit_rate_mbps=300.0, word_delay=0, word_bits=12, seed=0, change_at=None,
             after=None, bit_delay=0):
    """A :class:`tdicam.model.lvds.Lane` whose eye is ``width_taps`` taps wide and centred
    on delay tap ``centre_taps`` (the phase ``u = UI/2`` falls on that tap), delayed by a
    further ``word_delay`` whole words and ``bit_delay`` whole bits."""
    ui = 1e6 / bit_rate_mbps
    eye = min(width_taps * tap_ps, ui)
    skew = ((-ui / 2 - centre_taps * tap_ps) % ui + word_delay * word_bits * ui
            + bit_delay * ui)
    return lvds.Lane(skew_ps=skew, eye_ps=eye, jitter_ps=jitter_ps, tap_ps=tap_ps,
                     bit_rate_mbps=bit_rate_mbps, seed=seed, change_at=change_at,
                     after=after)


def scene_lanes(spec, gains, seed=0):
    """The :class:`tdicam.model.lvds.Lane` of every lane of a scene's ``[sensor.lvds]``
    (:class:`tdicam.scene.schema.Lvds`): eye centre, width and whole-bit skew per lane, its
    jitter."""
    n = spec.lanes_per_gain * gains
    skew = spec.skew_bits or (0,) * n
    return [eye_lane(spec.eye_centre_taps[i], spec.eye_width_taps[i], tap_ps=spec.tap_ps,
                     jitter_ps=spec.jitter_ps, bit_rate_mbps=spec.bit_rate_mbps,
                     word_bits=spec.word_bits, seed=seed * 65536 + i, bit_delay=skew[i])
            for i in range(n)]


def scene_untrained_lanes(spec, gains, seed=0, *, n_check=16, settle=8):
    """Lane numbers of a scene's ``[sensor.lvds]`` (``spec``) whose golden training fails
    (:func:`untrained_lanes` of :func:`scene_lanes`); empty when the link is ideal."""
    if not spec.simulate:
        return []
    return untrained_lanes(scene_lanes(spec, gains, seed), spec.word_bits, spec.train_word,
                           n_check=n_check, settle=settle)


def untrained_lanes(lanes, word_bits, train_word=None, *, n_check=16, settle=8):
    """Lane numbers whose golden training (:func:`tdicam.model.lvds.train_lane`) fails: no
    run of 9 passing taps, or no bitslip matched."""
    link = lvds.Link(lanes, word_bits=word_bits, train_word=train_word)
    return [i for i in range(len(lanes))
            if lvds.train_lane(link, i, 0, n_check=n_check, settle=settle).error]


def lane_mask(lanes):
    """The frame-status word of a set of lane numbers (bit ``i`` = lane ``i`` invalid)."""
    return sum(1 << int(i) for i in set(lanes))


def cut_frame(healthy, observed, lanes_per_gain, lane, died):
    """The frame a lane's death cut, as the front delivers it: ``(frame (G, R, C), fill)``.

    ``healthy``: the frame as the front would deliver it with the lane alive (wire codes,
    untrained lanes 0); ``observed``: what it delivered; ``lane`` died at pixel word
    ``died`` (``r P + j``: row ``r``, word ``j`` of the ``P = ceil(C / L)`` a line). Up to the
    death every word is the healthy one; from the death until the front sees the loss (its
    lane monitor, at a line's sync word) the dead lane's words are what its deserializer
    made of a dead line (taken from ``observed``: invalid, and the frame is flagged); from
    ``fill`` -- the first word from which every lane reads 0 to the frame's end, measured
    on ``observed``, never before the death -- the front fills the frame with 0s.
    """
    L = lanes_per_gain
    g_n, r_n, c_n = np.shape(healthy)
    p = line_words(c_n, L) - 2

    def words(a):           # (R P, G, L): word r P + j of every lane of every gain
        return _padded(np.asarray(a, np.int64), L).reshape(g_n, r_n, p, L) \
            .transpose(1, 2, 0, 3).reshape(r_n * p, g_n, L)
    obs, exp = words(observed), words(healthy).copy()
    nz = np.flatnonzero(obs.reshape(r_n * p, -1).any(axis=1))
    fill = max(int(nz[-1]) + 1 if len(nz) else 0, int(died))
    g, k = divmod(int(lane), L)
    exp[died:fill, g, k] = obs[died:fill, g, k]
    exp[fill:] = 0
    return exp.reshape(r_n, p, g_n, L).transpose(2, 0, 1, 3).reshape(g_n, r_n, p * L)[
        ..., :c_n], fill


def lane_death(frames, lanes_per_gain, word_bits, *, bad_lanes, lane, frame, cut, kinds=None,
               held=2, pairs=False):
    """What the front delivers of ``frames`` (one ``(F, R, C)`` stack per gain, as the sensor
    sends them) when lanes ``bad_lanes`` did not train and lane ``lane`` dies in ``frame``:
    the frames before it as :func:`receive` gives them; ``cut`` (:func:`cut_frame`: the cut
    frame as delivered); ``held`` frames dropped while the lanes wait for the retrain; from
    the retrain on (with ``pairs``: from the next reset frame, ``kinds`` 1) the frames with
    ``lane`` invalid too.

    Returns ``(pixels (G, F', R, C), kinds (F',) or None, frame status [F' words], dropped)``
    with the frame status as the front publishes it (:func:`lane_mask`: the untrained lanes,
    every lane for the cut frame, the dead lane after) and the frames not released.
    """
    bad = sorted(set(bad_lanes))
    n = len(frames) * lanes_per_gain
    before, _ = receive(frames, bad, lanes_per_gain, word_bits)
    after, _ = receive(frames, sorted(set(bad) | {lane}), lanes_per_gain, word_bits)
    nf = before.shape[1]
    start = frame + 1 + held
    if pairs and kinds is not None:
        while start < nf and kinds[start] != 1:
            start += 1
    keep = list(range(frame)) + [frame] + list(range(start, nf))
    px = np.concatenate([before[:, :frame], np.asarray(cut, np.int64)[:, None],
                         after[:, start:]], axis=1)
    status = [lane_mask(bad)] * frame + [(1 << n) - 1] + \
        [lane_mask(bad + [lane])] * (nf - start)
    return px, None if kinds is None else np.asarray(kinds)[keep], status, start - frame - 1
