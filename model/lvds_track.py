"""Golden model of the eye tracking of :mod:`tdicam.hdl.lvds_track` (issue 46 step 5).

Per locked lane the tracker (:class:`tdicam.hdl.lvds_track.LaneTracker`) runs *probes* of
``Q = settle + 3 + max(n_check, 1)`` word clocks back to back from the lock cycle
``k_lock`` (the first cycle showing ``locked``): probe ``i`` starts at ``ks = k_lock + i Q``,
loads the monitor tap ``tap - margin`` (even ``i``) or ``tap + margin`` (odd ``i``; both
clamped to 0..31) at ``ks`` and compares, at the cycles ``k = ks + settle + 2 ..
ks + settle + 1 + n_check``, the data word with the monitor's word, both the gearbox outputs
of cycle ``k - 2`` with the lane's slip (data sampled at the data tap, monitor at the
monitor tap; with ``settle >= 4`` both taps have reached every sample compared). A probe
*fails* when any compared word differs. At the last cycle ``kc = ks + Q - 1`` of an odd
probe: low failed and high passed -> *up* (the data tap + 1, unless 31); high failed and low
passed -> *down* (- 1, unless 0). The trainer loads the new tap at ``kc + 1``: raw words from
``kc + 1 + LINK_LATENCY`` on are sampled with it (the correction's *effect word*; the next
probe, from ``kc + 1``, is taken around the new tap). A correction decided at a cycle where
the lane's error already shows (``>= k_bad + 3``, :mod:`tdicam.model.lvds`) is not made; one
decided at ``k_bad + 2`` is counted but not applied (the error takes precedence in the
trainer). The lane's words and its locked-lane checks follow the tap as it moves.

The probes must fit in the eye: with an eye narrower than ``2 margin + 1`` taps one probe
always fails and the tap dithers by one tap every probe pair (no word is lost: both taps are
inside the eye; the counter grows). A scene's margin is ``pick - 1 = 4``
(:data:`tdicam.blocks.lvds.TRACK_MARGIN`), within every eye that trains (``min_run = 9``).
"""

import numpy as np

__all__ = ["COUNT_BITS", "probe_words", "track", "raw_tap_of", "shown"]

#: Bits of each lane's correction counter (wraps).
COUNT_BITS = 8


def probe_words(settle, n_check):
    """Word clocks of one probe."""
    return settle + 3 + max(int(n_check), 1)


def track(words, tap, k_lock, k_stop, *, n_check, settle, margin, n_taps):
    """The corrections of a lane locked at ``k_lock`` with ``tap`` up to ``k_stop``, before
    any lane error is taken into account: a list of ``(kc, new tap)`` (decision cycle; the
    tap the trainer loads at ``kc + 1``). ``words(tap, ks)``: the lane's gearbox outputs at
    cycles ``ks`` sampled with a steady ``tap`` (its slip;
    :func:`tdicam.model.lvds.lane_words`)."""
    q = probe_words(settle, n_check)
    nc = max(int(n_check), 1)
    first = settle + 2
    out, i, fail_lo = [], 0, False
    while k_lock + (i + 1) * q - 1 < k_stop:
        ks = k_lock + i * q
        mt = max(tap - margin, 0) if i % 2 == 0 else min(tap + margin, n_taps - 1)
        kk = ks + first + np.arange(nc) - 2
        data, mon = words(tap, kk), words(mt, kk)
        fail = bool((data != mon).any())
        if i % 2 == 0:
            fail_lo = fail
        else:
            kc = ks + q - 1
            if fail_lo and not fail and tap != n_taps - 1:
                tap += 1
                out.append((kc, tap))
            elif fail and not fail_lo and tap != 0:
                tap -= 1
                out.append((kc, tap))
        i += 1
    return out


def shown(corrections, cycles, latency):
    """The ``(effect word, ...)`` corrections whose new tap shows at a port cycle before
    ``cycles`` (the end of a run): decided at ``kc <= cycles - 2``, the effect word
    ``kc + 1 + latency``."""
    return [c for c in corrections if c[0] - latency < cycles]


def raw_tap_of(tap0, corrections, latency):
    """The tap of each raw word (a function of an int64 array): ``tap0``, then each
    correction's from its effect word ``kc + 1 + latency``."""
    eff = np.array([kc + 1 + latency for kc, _ in corrections], np.int64)
    taps = np.array([tap0] + [t for _, t in corrections], np.int64)
    return lambda j: taps[np.searchsorted(eff, j, side="right")]
