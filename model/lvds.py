"""Link model and golden training model of the LVDS receiver (Ning et al. 2019 §4.1).

The sensor sends ``word_bits``-bit words per lane at ``bit_rate_mbps`` (300 Mb/s: UI 3.33 ns),
most significant bit first. The receiver delays each lane with a 32-tap input delay
(paper: 5 ns / 32 = 156.25 ps per tap; a 7-series IDELAYE2 at 200 MHz: 78.125 ps), samples
once per UI and deserializes ``word_bits`` samples per word clock; a fabric gearbox selects
the word boundary (the *bitslip*). This module defines, bit for bit, what such a receiver
captures (:class:`Lane`, :class:`Link`, :func:`lane_words`), what the training controller of
:mod:`tdicam.hdl.lvds` decides from it (:func:`decide`, :func:`train_lane`) and what the
whole receiver reports (:func:`run`). Everything is exact integer arithmetic once the per-tap
tables (:func:`lane_tables`) are made from the lane's analogue parameters.

Link (per lane)
---------------
Time unit ps; ``UI = 1e6 / bit_rate_mbps``. Sender bit ``b[n]`` reaches the delay input
during ``[skew + n*UI, skew + (n+1)*UI)``. With tap ``t`` the sample number ``m`` (taken at
``m*UI``) sees bit ``n = m - D[t]`` at phase ``u[t]`` inside that bit, where
``D[t] = m - floor((m*UI - skew - t*tap)/UI)`` (an integer bit delay) and
``u[t] = (-(skew + t*tap)) mod UI``. The *eye* is ``[(UI-eye)/2, (UI+eye)/2)`` of each bit.

* outside the eye the capture is metastable: the sampled bit is random;
* with jitter ``J = jitter_ps > 0`` a capture within ``J`` of an eye edge (inside the eye)
  is random with probability ``1 - d/J`` (``d`` = distance to the edge): captures near the
  eye edges fail at random;
* elsewhere the capture is the sent bit.

This becomes two integer tables per lane: ``delay[t] = D[t]`` and
``thresh[t] = round(65536 * p_random(t))`` (0 = always right, 65536 = always random).
The random draws are a counter-based hash, so the golden model and the HDL testbench get
the same values without sharing state: ``h = mix32(m ^ jkey)``; the sample is random when
``h >> 16 < thresh[t]`` and then equals ``h & 1``. ``mix32`` is the "lowbias32" integer hash
(``x ^= x>>16; x *= 0x7feb352d; x ^= x>>15; x *= 0x846ca68b; x ^= x>>16``, all mod 2**32);
``jkey = mix32(2*seed)``, ``dkey = mix32(2*seed + 1)`` (seed mod 2**32).

A lane may change at raw word ``change_at`` (a skew jump, a dying lane): samples ``m`` with
``m // word_bits >= change_at`` use the tables of ``after`` (its seed is ignored).

A lane may *drift* (temperature): its eye centre moves by ``drift_taps`` taps (signed; +:
to higher delay taps) over the ``drift_words`` raw words from ``drift_from``, in steps of
1/:data:`DRIFT_STEPS` tap: samples of raw word ``q`` use the tables of the skew
``skew - tap * floor(DRIFT_STEPS * drift_taps * clip((q - drift_from) / drift_words, 0, 1))
/ DRIFT_STEPS`` (towards zero for a negative drift), the same eye and jitter.

Sensor (all lanes)
------------------
``schedule`` lists ``(n, mode)`` pairs, sender word ``n`` from which the sensor sends
``"train"`` (the training word, every word), ``"walk"`` (the walking-1/0 patterns of
:func:`walk_words`, word ``n`` of a walk segment starting at ``n0`` being pattern
``(n - n0) % (2 W)``) or ``"data"``; before the first entry (including negative ``n``) it
trains. In a data segment starting at ``n0``, word ``n`` is the sync word
when ``(n - n0) % line_words == 0``, else ``mix32(n ^ dkey) & mask`` with the sync code
avoided (``^ 1`` when equal to it). With a ``payload`` (one int64 array per lane, e.g. the
pixel lines :mod:`tdicam.model.lvds_front` makes of frames) the data segments carry it
instead: data word ``q`` (counted over every data segment in order, sync positions included)
is ``payload[lane][q]`` while ``q`` is inside it; past its end the rule above continues.

One module (past 600 lines) on purpose: the link (skew, eye, jitter, drift), the training
and the locked-lane checks are one bit-exact timing contract, checked together.

Receiver timing (the contract of :class:`tdicam.hdl.lvds.LvdsRx`)
-----------------------------------------------------------------
Port cycle ``k`` = word clocks since reset was released. ``raw(k)`` = samples
``k*W .. k*W+W-1`` (first sample in the MSB). The gearbox output at cycle ``k`` with slip ``s``
is samples ``(k-1)*W + s .. (k-1)*W + s + W - 1``. A training *step* lasts
``P = settle + max(n_check, 1) + 3`` word clocks; a step starting at cycle ``ks`` sets the tap
(pulsing the load strobe) and slip at ``ks`` and checks the words of cycles
``ks + settle .. ks + settle + n_check - 1`` (``settle`` >= 3 covers the 2-word link latency and
the gearbox). Training started at ``k0`` (0 after reset, ``k_r + 1`` after a retrain request
seen at cycle ``k_r``): scan steps for taps 0..31, one decide cycle at ``kd = k0 + 32*P``,
then slip steps 0..W-1 from ``kd + 1``.

* A tap *passes* when every checked word equals the first one and that word is a rotation of
  the training word (a tap passes only if all its checked words match: jitter that makes a
  tap flicker fails it).
* A *run* is a maximal sequence of consecutive passing taps that captured the same word.
  The widest run wins, ties go to the first (lowest tap). A run clipped at tap 0 or 31 is
  taken with its measured length (its true extent is at least that).
* If the widest run has at least ``min_run`` (9) taps the lane samples at its ``pick``-th tap
  (5th): ``tap = start + pick - 1``; otherwise it reports error from ``kd + 1`` (tap and slip
  parked at 0).
* Slip ``s`` passes when all checked words equal the training word. The first passing slip
  locks (``locked`` from the cycle after its step); none of 0..W-1 → error (parked at 0).
* A locked lane checks every word: until the first sync word it must receive the training
  word or the sync word; from then on the sync word exactly every ``line_words`` words and
  never elsewhere. A violation in the word of cycle ``k`` reports error from ``k + 3`` (tap and
  slip kept): a lane that dies after lock is reported, never silently kept.
* With the eye status (``eye=True``, :class:`tdicam.hdl.lvds.LvdsRx` ``eye``) a locked lane
  also accepts the walking-1/0 patterns (:func:`walk_words`) before its first sync word and
  records which it received: bit ``j`` of ``walk`` = the pattern with only bit ``j`` set
  was received, bit ``W + j`` = the pattern with only bit ``j`` clear (words of cycles
  ``k < k_stop - 3`` count, as for the errors). Every bit of the word has then been seen
  as 1 and as 0 at its own position: ``walk`` all ones (``2**(2W) - 1``) is the check
  passed. ``slip_pass`` has bit ``s`` set for the slip that locked (the slips before it
  failed; 0 when none passed).
* A retrain request at cycle ``k_r`` clears every lane's status at ``k_r + 1`` and restarts
  training; words of cycles ``>= k_r - 2`` are no longer judged by the old training.
"""

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from tdicam.errors import TdicamError, check_choice, check_range
from tdicam.model import lvds_track

__all__ = ["PAPER_TAP_PS", "XILINX_TAP_PS", "N_TAPS", "VERDICT_WORDS", "MONITOR_WORDS",
           "DRIFT_STEPS",
           "LINK_LATENCY", "Lane", "Link", "mix32", "rotations", "default_train_word",
           "default_sync_word", "check_train_word", "lane_tables", "sent_words", "raw_words",
           "lane_words", "step_words", "decide", "train_lane", "run", "LaneResult",
           "RunResult", "training_words", "random_lane", "walk_words"]

PAPER_TAP_PS = 5000.0 / 32
XILINX_TAP_PS = 1e6 / (32 * 2 * 200.0)  # 78.125 ps: IDELAYE2 with a 200 MHz reference
N_TAPS = 32
VERDICT_WORDS = 3   # pipeline words between the last checked word and the step's verdict
MONITOR_WORDS = 3   # a bad word at cycle k shows as error from k + 3
LINK_LATENCY = 2    # words from a tap load to the first raw word sampled with that tap
DRIFT_STEPS = 8     # a drifting eye moves in steps of 1/8 tap
_M32 = np.uint64(0xFFFFFFFF)
_THRESH_ONE = 1 << 16


def mix32(x):
    """The lowbias32 integer hash of uint32 values (array in, uint64 array out, < 2**32)."""
    x = np.asarray(x).astype(np.int64).astype(np.uint64) & _M32
    x ^= x >> np.uint64(16)
    x = (x * np.uint64(0x7FEB352D)) & _M32
    x ^= x >> np.uint64(15)
    x = (x * np.uint64(0x846CA68B)) & _M32
    x ^= x >> np.uint64(16)
    return x


def rotations(word, word_bits):
    """The ``word_bits`` left rotations of ``word`` (rotation r first, r = 0..W-1)."""
    mask = (1 << word_bits) - 1
    return [((word << r) | (word >> (word_bits - r))) & mask if r else word & mask
            for r in range(word_bits)]


def default_train_word(word_bits):
    """Training word: 0b1011100100 (10 bits) / 0b101110010010 (12 bits), rotation-unique."""
    return {10: 0x2E4, 12: 0xB92}[check_choice("word_bits", word_bits, (10, 12))]


def default_sync_word(word_bits):
    """Sync word (line start): all ones; data never carries it."""
    return (1 << check_choice("word_bits", word_bits, (10, 12))) - 1


def walk_words(word_bits):
    """The ``2 W`` walking-1/0 patterns in the order the sensor sends them: the walking one
    from the MSB (``1 << (W-1)``, ..., ``1``), then the walking zero the same way."""
    mask = (1 << word_bits) - 1
    ones = [1 << (word_bits - 1 - j) for j in range(word_bits)]
    return ones + [mask ^ x for x in ones]


def _walk_bit(words, word_bits):
    """Per word, its bit in the ``walk`` status (see the module docstring), 0 for a word
    that is no walking pattern."""
    mask = (1 << word_bits) - 1
    out = np.zeros(np.shape(words), np.int64)
    for j in range(word_bits):
        out = np.where(words == (1 << j), 1 << j, out)
        out = np.where(words == (mask ^ (1 << j)), 1 << (word_bits + j), out)
    return out


def check_train_word(word, word_bits):
    """Raise unless ``word`` fits and its W rotations are all different (bitslip unique)."""
    check_range("train_word", word, 0, (1 << word_bits) - 1)
    if len(set(rotations(word, word_bits))) != word_bits:
        raise TdicamError(f"train_word = {word:#x} repeats under rotation; word alignment "
                          f"would be ambiguous (use a word whose {word_bits} rotations differ)")
    return word


@dataclass(frozen=True)
class Lane:
    """Analogue parameters of one lane (see the module docstring).

    Attributes
    ----------
    skew_ps : float >= 0
        Arrival delay of the lane's bits (may span several words).
    eye_ps : float in [0, UI]
        Width of the eye (captures inside it are right, outside random).
    jitter_ps : float >= 0
        Width of the random band inside each eye edge (0 = jitter off).
    tap_ps : float > 0
        Delay tap size (paper 156.25 ps, IDELAYE2 at 200 MHz 78.125 ps).
    bit_rate_mbps : float > 0
    seed : int
        Jitter and data keys.
    change_at, after : int, Lane
        From raw word ``change_at`` on, the lane behaves as ``after``.
    drift_taps, drift_from, drift_words : float, int, int
        The eye centre moves by ``drift_taps`` taps over raw words ``drift_from ..
        drift_from + drift_words`` (see the module docstring; 0: no drift).
    """

    skew_ps: float
    eye_ps: float
    jitter_ps: float = 0.0
    tap_ps: float = PAPER_TAP_PS
    bit_rate_mbps: float = 300.0
    seed: int = 0
    change_at: int | None = None
    after: "Lane | None" = None
    drift_taps: float = 0.0
    drift_from: int = 0
    drift_words: int = 0

    def __post_init__(self):
        ui = self.ui_ps
        if not (self.bit_rate_mbps > 0 and self.tap_ps > 0):
            raise TdicamError("lane bit_rate_mbps and tap_ps must be positive")
        if not 0 <= self.eye_ps <= ui:
            raise TdicamError(f"lane eye_ps = {self.eye_ps} is out of range; valid: 0..UI "
                              f"({ui:.2f} ps)")
        if self.skew_ps < 0 or self.jitter_ps < 0:
            raise TdicamError("lane skew_ps and jitter_ps must be >= 0")
        if (self.change_at is None) != (self.after is None):
            raise TdicamError("lane change_at and after go together")
        if self.drift_taps:
            if self.change_at is not None:
                raise TdicamError("a lane drifts (drift_taps) or changes (change_at), not both")
            if self.drift_words < 1 or self.drift_from < 0:
                raise TdicamError(f"lane drift_words = {self.drift_words} must be >= 1 and "
                                  f"drift_from = {self.drift_from} >= 0 with drift_taps")

    @property
    def ui_ps(self):
        return 1e6 / self.bit_rate_mbps


@dataclass(frozen=True)
class Link:
    """The sensor side of a set of lanes: word format, training/sync words, schedule."""

    lanes: tuple
    word_bits: int = 10
    train_word: int | None = None
    sync_word: int | None = None
    line_words: int = 64
    schedule: tuple = ()
    payload: tuple = ()

    def __post_init__(self):
        w = check_choice("word_bits", self.word_bits, (10, 12))
        object.__setattr__(self, "lanes", tuple(self.lanes))
        if self.train_word is None:
            object.__setattr__(self, "train_word", default_train_word(w))
        if self.sync_word is None:
            object.__setattr__(self, "sync_word", default_sync_word(w))
        check_train_word(self.train_word, w)
        check_range("sync_word", self.sync_word, 0, (1 << w) - 1)
        if self.sync_word in rotations(self.train_word, w):
            raise TdicamError("sync_word must not be a rotation of train_word")
        check_range("line_words", self.line_words, 2, 65535)
        sched = tuple((int(n), str(mode)) for n, mode in self.schedule)
        for n, mode in sched:
            check_choice("schedule mode", mode, ("train", "data", "walk"))
            check_range("schedule word", n, 0, (1 << 31) - 1)
        if list(sched) != sorted(sched, key=lambda e: e[0]) or \
                len({n for n, _ in sched}) != len(sched):
            raise TdicamError("schedule words must be strictly increasing")
        object.__setattr__(self, "schedule", sched)
        pay = tuple(np.asarray(p, dtype=np.int64) for p in self.payload)
        if pay and len(pay) != len(self.lanes):
            raise TdicamError(f"payload has {len(pay)} lanes, the link {len(self.lanes)}")
        object.__setattr__(self, "payload", pay)


@lru_cache(maxsize=4096)
def _tables(skew, eye, jitter, tap, rate, n_taps):
    ui = 1e6 / rate
    t = np.arange(n_taps, dtype=np.float64)
    delay_ps = skew + t * tap
    n_off = np.floor(-delay_ps / ui)        # n = m + n_off
    u = -delay_ps - n_off * ui              # phase inside the bit, [0, ui)
    u = np.where(u >= ui, u - ui, u)
    lo = (ui - eye) / 2
    hi = (ui + eye) / 2
    inside = (u >= lo) & (u < hi)
    dist = np.minimum(u - lo, hi - u)
    if jitter > 0:
        p = np.clip(1.0 - dist / jitter, 0.0, 1.0)
    else:
        p = np.zeros(n_taps)
    p = np.where(inside, p, 1.0)
    thresh = np.rint(p * _THRESH_ONE).astype(np.int64)
    return (-n_off).astype(np.int64), thresh


def lane_tables(lane, n_taps=N_TAPS):
    """(``delay``, ``thresh``) int64 arrays of shape (2, n_taps): epoch 0 and epoch 1 (=0 when
    the lane never changes). ``delay`` in bits, ``thresh`` in 0..65536 (see module doc)."""
    eps = [lane, lane.after if lane.after is not None else lane]
    d, r = zip(*(_tables(float(e.skew_ps), float(e.eye_ps), float(e.jitter_ps),
                         float(e.tap_ps), float(e.bit_rate_mbps), n_taps) for e in eps))
    return np.stack(d), np.stack(r)


def _drift_tables(lane, q):
    """(delay, thresh) of every drift step of ``lane`` (shape (steps + 1, N_TAPS)) and the
    step of each raw word ``q``."""
    top = int(np.floor(DRIFT_STEPS * abs(lane.drift_taps)))
    frac = np.clip((np.asarray(q, np.float64) - lane.drift_from) / lane.drift_words, 0.0, 1.0)
    ep = np.minimum(np.floor(DRIFT_STEPS * abs(lane.drift_taps) * frac).astype(np.int64), top)
    sign = 1.0 if lane.drift_taps > 0 else -1.0
    tabs = [_tables(float(lane.skew_ps) - sign * e * lane.tap_ps / DRIFT_STEPS,
                    float(lane.eye_ps), float(lane.jitter_ps), float(lane.tap_ps),
                    float(lane.bit_rate_mbps), N_TAPS) for e in range(top + 1)]
    return np.stack([t[0] for t in tabs]), np.stack([t[1] for t in tabs]), ep


def _keys(lane):
    s = int(lane.seed) & 0xFFFFFFFF
    return int(mix32(2 * s)), int(mix32((2 * s + 1) & 0xFFFFFFFF))


def sent_words(link, lane_index, n):
    """Words the sensor sends on lane ``lane_index`` at sender word indices ``n`` (int64)."""
    n = np.asarray(n, dtype=np.int64)
    w = link.word_bits
    mask = (1 << w) - 1
    _, dkey = _keys(link.lanes[lane_index])
    out = np.full(n.shape, link.train_word, dtype=np.int64)
    if not link.schedule:
        return out
    starts = np.array([s for s, _ in link.schedule], dtype=np.int64)
    is_data = np.array([m == "data" for _, m in link.schedule])
    idx = np.searchsorted(starts, n, side="right") - 1
    seg_data = (idx >= 0) & is_data[np.maximum(idx, 0)]
    is_walk = np.array([m == "walk" for _, m in link.schedule])
    seg_walk = (idx >= 0) & is_walk[np.maximum(idx, 0)]
    if seg_walk.any():
        pats = np.array(walk_words(w), np.int64)
        out[seg_walk] = pats[(n[seg_walk] - starts[idx[seg_walk]]) % (2 * w)]
    if seg_data.any():
        nn = n[seg_data]
        p = nn - starts[idx[seg_data]]
        d = (mix32(nn.astype(np.uint64) ^ np.uint64(dkey)) & np.uint64(mask)).astype(np.int64)
        d = np.where(d == link.sync_word, d ^ 1, d)
        out[seg_data] = np.where(p % link.line_words == 0, link.sync_word, d)
        if link.payload:
            pay = link.payload[lane_index]
            seg_len = np.diff(np.append(starts, np.iinfo(np.int64).max // 4))
            before = np.concatenate([[0], np.cumsum(np.where(is_data, seg_len, 0))[:-1]])
            q = before[idx[seg_data]] + p
            inside = q < len(pay)
            sel = np.flatnonzero(seg_data)[inside]
            out.reshape(-1)[sel] = pay[q[inside]]
    return out


def _sample_bits(link, lane_index, taps, m):
    """Bits captured at sample indices ``m`` with delay taps ``taps`` (broadcast)."""
    lane = link.lanes[lane_index]
    w = link.word_bits
    m = np.asarray(m, dtype=np.int64)
    taps = np.broadcast_to(np.asarray(taps, dtype=np.int64), m.shape)
    if lane.drift_taps:
        delay, thresh, ep = _drift_tables(lane, np.floor_divide(m, w))
    else:
        delay, thresh = lane_tables(lane)
        ep = np.zeros(m.shape, dtype=np.int64)
        if lane.change_at is not None:
            ep = (np.floor_divide(m, w) >= lane.change_at).astype(np.int64)
    d = delay[ep, taps]
    r = thresh[ep, taps]
    jkey, _ = _keys(lane)
    h = mix32(m.astype(np.uint64) ^ np.uint64(jkey))
    rnd = (h >> np.uint64(16)).astype(np.int64) < r
    nb = m - d
    word = sent_words(link, lane_index, np.floor_divide(nb, w))
    bit = (word >> (w - 1 - np.mod(nb, w))) & 1
    return np.where(rnd, (h & np.uint64(1)).astype(np.int64), bit)


def _pack(bits):
    w = bits.shape[-1]
    weights = np.int64(1) << np.arange(w - 1, -1, -1, dtype=np.int64)
    return (bits * weights).sum(axis=-1)


def raw_words(link, lane_index, taps, k):
    """Raw deserializer words ``raw(k)`` (samples ``k*W..k*W+W-1``, first in the MSB) with a
    steady tap ``taps`` (broadcast against ``k``)."""
    k = np.asarray(k, dtype=np.int64)
    w = link.word_bits
    m = k[..., None] * w + np.arange(w, dtype=np.int64)
    return _pack(_sample_bits(link, lane_index, np.asarray(taps)[..., None], m))


def lane_words(link, lane_index, taps, slips, k):
    """Gearbox output at port cycle ``k``: samples ``(k-1)*W + s ..`` with steady tap and slip."""
    k = np.asarray(k, dtype=np.int64)
    w = link.word_bits
    base = (k - 1) * w + np.asarray(slips, dtype=np.int64)
    m = base[..., None] + np.arange(w, dtype=np.int64)
    return _pack(_sample_bits(link, lane_index, np.asarray(taps)[..., None], m))


def _tap_words(link, lane_index, raw_taps, slip, ks):
    """Gearbox outputs at cycles ``ks`` when raw word ``j`` was sampled with tap
    ``raw_taps(j)`` (a function of an int64 array): the words of a lane whose tap moves."""
    ks = np.asarray(ks, np.int64)
    w = link.word_bits
    m = ((ks - 1) * w + slip)[:, None] + np.arange(w, dtype=np.int64)
    return _pack(_sample_bits(link, lane_index, raw_taps(np.floor_divide(m, w)), m))


def step_words(n_check, settle):
    """Word clocks of one training step."""
    return settle + max(int(n_check), 1) + VERDICT_WORDS


def training_words(word_bits, n_check, settle):
    """Upper bound of a training run: scan, decide, all slip steps (word clocks)."""
    return (N_TAPS + word_bits) * step_words(n_check, settle) + 1


def decide(passes, words, *, min_run=9, pick=5):
    """Golden training decision from a per-tap scan.

    Parameters
    ----------
    passes : sequence of bool, one per tap
    words : sequence of int, the word each tap captured (its first checked word)

    Returns
    -------
    (run_start, run_len, tap) : tap is ``run_start + pick - 1`` or None when the widest run
    (consecutive passing taps with equal words; ties to the first) is shorter than
    ``min_run``. ``run_len`` is 0 when no tap passed.
    """
    cur_start = cur_len = best_start = best_len = 0
    prev = False
    cur_word = None
    for t, (ok, word) in enumerate(zip(passes, words)):
        if ok:
            if prev and word == cur_word:
                cur_len += 1
            else:
                cur_start, cur_len = t, 1
            if cur_len > best_len:
                best_start, best_len = cur_start, cur_len
        else:
            cur_len = 0
        prev = bool(ok)
        cur_word = word
    tap = best_start + pick - 1 if best_len >= min_run else None
    return best_start, best_len, tap


@dataclass
class LaneResult:
    """Golden outcome of one training of one lane."""

    passes: np.ndarray
    words: np.ndarray
    run_start: int
    run_len: int
    tap: int
    slip: int
    locked: bool
    error: bool
    events: list = field(default_factory=list)
    scan_mask: int = 0
    lock_k: int | None = None
    word_delay: int | None = None
    slip_pass: int = 0
    walk: int = 0
    corrections: list = field(default_factory=list)
    count: int = 0


def train_lane(link, lane_index, k0, *, n_check=16, settle=8, min_run=9, pick=5, k_stop=None,
               eye=False, track=0):
    """Golden training of one lane started at cycle ``k0``; the lane is judged until ``k_stop``
    (the next retrain's first cycle, or the end of the run; None: training only).

    Returns a :class:`LaneResult` whose ``events`` are ``(k, locked, error, tap, slip, run)``
    status changes (``k`` = first cycle showing the new status) before ``k_stop``. Training
    must end (lock or error) before ``k_stop``. ``eye``: the receiver with the eye status
    (walking patterns accepted before the first sync word, ``walk`` recorded). ``track`` > 0:
    the receiver tracks the eye with that probe margin (:mod:`tdicam.model.lvds_track`):
    ``corrections`` lists ``(decision cycle, new tap, effect word)``, ``count`` the
    tracker's counter, ``tap`` the tap at the end.
    """
    w = link.word_bits
    nc = max(int(n_check), 1)
    p = step_words(nc, settle)
    judge = k_stop is not None
    k_stop = np.iinfo(np.int64).max if k_stop is None else int(k_stop)
    if k0 + training_words(w, nc, settle) >= k_stop:
        raise TdicamError(f"training from cycle {k0} cannot end before cycle {k_stop}; "
                          f"it needs {training_words(w, nc, settle) + 1} word clocks")
    taps = np.arange(N_TAPS)
    ks = k0 + taps[:, None] * p + settle + np.arange(nc)[None, :]
    words = lane_words(link, lane_index, taps[:, None], 0, ks)
    rots = np.array(rotations(link.train_word, w))
    passes = (words == words[:, :1]).all(axis=1) & np.isin(words[:, 0], rots)
    run_start, run_len, tap = decide(passes, words[:, 0], min_run=min_run, pick=pick)
    res = LaneResult(passes, words[:, 0], run_start, run_len, 0, 0, False, False)
    res.scan_mask = sum(1 << t for t in range(N_TAPS) if passes[t])
    kd = k0 + N_TAPS * p
    if tap is None:
        res.error = True
        res.events.append((kd + 1, 0, 1, 0, 0, run_len))
        return res
    slips = np.arange(w)
    ks = kd + 1 + slips[:, None] * p + settle + np.arange(nc)[None, :]
    sw = lane_words(link, lane_index, tap, slips[:, None], ks)
    ok = (sw == link.train_word).all(axis=1)
    if not ok.any():
        res.error = True
        res.events.append((kd + 1 + w * p, 0, 1, 0, 0, run_len))
        return res
    s = int(np.argmax(ok))
    k_lock = kd + 1 + (s + 1) * p
    res.tap, res.slip = tap, s
    res.locked, res.lock_k = True, k_lock
    res.slip_pass = 1 << s
    res.events.append((k_lock, 1, 0, tap, s, run_len))
    # integer word delay: the port word of cycle k carries sender word k - word_delay
    lane = link.lanes[lane_index]
    ep = int(lane.change_at is not None and k_lock - 1 >= lane.change_at)
    d_bits = int(lane_tables(lane)[0][ep, tap])
    res.word_delay = 1 - (s - d_bits) // w
    words = None
    if track and judge:
        corr = lvds_track.track(lambda t, ks: lane_words(link, lane_index, t, s, ks), tap,
                                k_lock, k_stop, n_check=nc, settle=settle, margin=track,
                                n_taps=N_TAPS)
        raw_tap = lvds_track.raw_tap_of(tap, corr, LINK_LATENCY)
        words = lambda ks: _tap_words(link, lane_index, raw_tap, s, ks)  # noqa: E731
    k_bad, res.walk = _monitor(link, lane_index, tap, s, k_lock, k_stop, eye=eye,
                               words=words) if judge else (None, 0)
    if words is not None:
        end = np.iinfo(np.int64).max if k_bad is None else k_bad
        res.corrections = [(kc, t, kc + 1 + LINK_LATENCY) for kc, t in corr if kc < end + 2]
        res.count = sum(1 for kc, _ in corr if kc < end + 3) % 256
        if res.corrections:
            res.tap = res.corrections[-1][1]
    if k_bad is not None:
        res.locked, res.error = False, True
        res.events.append((k_bad + MONITOR_WORDS, 0, 1, res.tap, s, run_len))
    return res


def _monitor(link, lane_index, tap, slip, k_lock, k_stop, chunk=1 << 16, eye=False, words=None):
    """(first cycle >= k_lock whose word breaks the locked-lane rules and whose error shows
    before ``k_stop``, else None; the ``walk`` status, 0 without ``eye``). ``words``: the
    lane's words at cycles ``ks`` (default: sampled at the steady ``tap``)."""
    last = k_stop - MONITOR_WORDS  # words k < last can raise an error that shows < k_stop
    sync, train, w = link.sync_word, link.train_word, link.word_bits
    phase_sync_k = None
    walk = 0
    k = k_lock
    while k < last:
        ks = np.arange(k, min(k + chunk, last), dtype=np.int64)
        wds = lane_words(link, lane_index, tap, slip, ks) if words is None else words(ks)
        is_sync = wds == sync
        if phase_sync_k is None:
            wbit = _walk_bit(wds, w) if eye else np.zeros(len(ks), np.int64)
            bad_a = ~(is_sync | (wds == train) | (wbit != 0))
            first_sync = int(np.argmax(is_sync)) if is_sync.any() else len(ks)
            first_bad = int(np.argmax(bad_a)) if bad_a.any() else len(ks)
            walk |= int(np.bitwise_or.reduce(wbit[:min(first_sync, first_bad)], initial=0))
            if first_bad < first_sync:
                return int(ks[first_bad]), walk
            if first_sync == len(ks):
                k += len(ks)
                continue
            phase_sync_k = int(ks[first_sync])
        pos = (ks - phase_sync_k) % link.line_words
        bad = (is_sync != (pos == 0)) & (ks >= phase_sync_k)
        if bad.any():
            return int(ks[int(np.argmax(bad))]), walk
        k += len(ks)
    return None, walk


@dataclass
class RunResult:
    """Golden outcome of a receiver run (all lanes).

    ``events``: (k, lane, locked, error, tap, slip, run) status changes sorted by (k, lane);
    ``final``: per lane, dict of tap, slip, locked, error, run, scan at the end of the run;
    ``trainings``: per training (reset, then each retrain), the per-lane :class:`LaneResult`;
    ``starts``: first cycle of each training.
    """

    events: list
    final: list
    trainings: list
    starts: list


def run(link, *, cycles, retrains=(), n_check=16, settle=8, min_run=9, pick=5, eye=False,
        track=0):
    """Golden model of the whole receiver over ``cycles`` word clocks after reset.

    ``retrains`` are port cycles where the retrain request is high (each restarts training
    at the next cycle); every training must end before the next one starts. ``eye``: the
    receiver with the eye status (``final`` gains ``slip_pass`` and ``walk``); ``track``: with
    eye tracking of that margin (``final`` gains ``corrections``, the tracker's count, and
    ``tap`` is the tap at the end).
    """
    check_range("settle", settle, LINK_LATENCY + 2, 64)
    check_range("n_check", n_check, 0, 255)
    check_range("min_run", min_run, 1, N_TAPS)
    check_range("pick", pick, 1, min_run)
    starts = [0] + [int(k) + 1 for k in sorted(retrains)]
    stops = starts[1:] + [int(cycles)]
    events, trainings = [], []
    final = [{"tap": 0, "slip": 0, "locked": 0, "error": 0, "run": 0, "scan": 0,
              **({"slip_pass": 0, "walk": 0} if eye else {}),
              **({"corrections": 0} if track else {})} for _ in link.lanes]
    for k0, k1 in zip(starts, stops):
        results = []
        for li in range(len(link.lanes)):
            if final[li]["locked"] or final[li]["error"]:
                events.append((k0, li, 0, 0, 0, 0, 0))
            res = train_lane(link, li, k0, n_check=n_check, settle=settle, min_run=min_run,
                             pick=pick, k_stop=k1, eye=eye, track=track)
            results.append(res)
            locked, error, _, slip, run_len = res.events[-1][1:]
            tap = res.tap
            for ev in res.events:
                events.append((ev[0], li) + ev[1:])
            final[li] = {"tap": tap, "slip": slip, "locked": locked, "error": error,
                         "run": run_len, "scan": res.scan_mask,
                         **({"slip_pass": res.slip_pass, "walk": res.walk} if eye else {}),
                         **({"corrections": res.count} if track else {})}
        trainings.append(results)
    events.sort(key=lambda ev: (ev[0], ev[1]))
    return RunResult(events, final, trainings, starts)


def random_lane(rng, *, tap_ps=None, jitter=None, max_word_delay=0, word_bits=10, seed=None):
    """A lane drawn like the co-simulation's random lanes.

    Skew uniform over the delay range (``max(32 taps, 1 UI)``) plus 0..``max_word_delay``
    whole words; eye 3..20 taps; jitter off, or 0.5..4 taps (at most 4 taps, so that the
    5th tap of a 9-tap run is always clear of the random band); tap size paper or 7-series.
    """
    tap = float(rng.choice([PAPER_TAP_PS, XILINX_TAP_PS])) if tap_ps is None else tap_ps
    ui = 1e6 / 300.0
    span = max(N_TAPS * tap, ui)
    skew = float(rng.uniform(0, span)) + int(rng.integers(0, max_word_delay + 1)) * word_bits * ui
    eye = float(rng.uniform(3, 20)) * tap
    eye = min(eye, ui)
    if jitter is None:
        jitter = bool(rng.integers(0, 2))
    jit = float(rng.uniform(0.5, 4.0)) * tap if jitter else 0.0
    return Lane(skew_ps=skew, eye_ps=eye, jitter_ps=jit, tap_ps=tap,
                seed=int(rng.integers(0, 1 << 31)) if seed is None else seed)

