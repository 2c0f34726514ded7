"""The stream infrastructure shared by the blocks (:mod:`tdicam.hdl.interfaces.stream`)."""

import numpy as np
import pytest

from tdicam.beats import Beats
from tdicam.cosim.streamsim import run_stream_component
from tdicam.hdl.interfaces.stream import StreamRegister, channels_shape, pixel_layout


@pytest.mark.parametrize("count,seed,p_valid,p_ready", [
    (1, 1, 0.7, 0.6), (4, 2, 1.0, 1.0), (8, 3, 0.3, 0.9), (2, 4, 0.9, 0.2)])
def test_stream_register_passes_every_beat_once(count, seed, p_valid, p_ready):
    """Random idle cycles and backpressure (and none): every beat out once, in order, with
    its markers; latency 1 cycle."""
    rng = np.random.default_rng(seed)
    n = 400
    data = rng.integers(0, 1 << 12, (n, count))
    k = np.arange(n)
    stim = Beats(data, k % 100 == 0, k % 10 == 9)
    dut = StreamRegister(pixel_layout(channels_shape(12, count)))
    assert dut.latency == 1
    got, lat, _ = run_stream_component(dut, stim, n, seed=seed, p_valid=p_valid,
                                       p_ready=p_ready, drain=20)
    assert len(got) == n
    np.testing.assert_array_equal(np.array([g[0] for g in got]).reshape(n, count), data)
    assert [g[1] for g in got] == stim.first.tolist()
    assert [g[2] for g in got] == stim.last.tolist()
    assert lat == [1]


def test_stream_register_full_throughput():
    """Always offered, always accepted: one beat per clock (n beats in n + latency cycles)."""
    n = 200
    k = np.arange(n)
    stim = Beats(k[:, None] % 4096, k == 0, k % 20 == 19)
    trace = []
    got, _, _ = run_stream_component(StreamRegister(pixel_layout(channels_shape(12, 1))),
                                     stim, n, p_valid=1.0, p_ready=1.0, latency_from=None,
                                     trace=trace)
    outs = [c for d, c in trace if d == "o"]
    assert len(got) == n and outs == list(range(outs[0], outs[0] + n))
