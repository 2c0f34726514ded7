"""The idle/backpressure generator (tdicam.cosim.pauses): every accepted seed its own pattern.

The HDL engine draws the same pattern (cocotb_tests/test_pauses.py compares the transfer
cycles of every driver for odd and even seeds)."""

import numpy as np
import pytest

from tdicam.cosim.pauses import SEED_MAX, XOR_R, Pauses, start_state


def pattern(seed, n=256, idle=0.5, backpressure=0.5):
    p = Pauses(seed, idle, backpressure)
    out = []
    for _ in range(n):
        out.append((p.offer(), p.ready()))
        p.step()
    return out


@pytest.mark.parametrize("k", [1, 2, 3, 50, 0x12345, SEED_MAX // 2])
def test_seeds_2k_and_2k_plus_1_differ(k):
    """Issue 18: ``(seed & 0x7fffffff) | 1`` gave seeds 2k and 2k + 1 one pattern."""
    assert pattern(2 * k) != pattern(2 * k + 1)


def test_start_state_is_one_to_one_and_never_stuck():
    rng = np.random.default_rng(18)
    seeds = np.concatenate([np.arange(1, 5000), rng.integers(1, SEED_MAX, 20000),
                            [SEED_MAX, SEED_MAX - 1]])
    seeds = np.unique(seeds)
    states = {start_state(int(s)) for s in seeds}
    assert len(states) == len(seeds)
    assert start_state(0) not in states and start_state(0) != 0
    # neither generator may start at 0 (xorshift32's fixed point: the stream would stall
    # for ever); r_0 = v_0 ^ XOR_R is 0 only for v_0 = XOR_R, which no start state is
    for s in (0, 1, 2, SEED_MAX, XOR_R, XOR_R >> 1, 2**31, 2**32):
        v = start_state(s)
        assert v != 0 and v ^ XOR_R != 0, s
    # the odd seeds keep the pattern they always had
    assert all(start_state(s) == (s | 1) for s in (1, 3, 12345, SEED_MAX))


def test_pattern_stalls_at_the_stated_rates():
    offers = np.array(pattern(6, n=20000, idle=0.25, backpressure=0.75))
    assert abs(offers[:, 0].mean() - 0.75) < 0.02 and abs(offers[:, 1].mean() - 0.25) < 0.02
