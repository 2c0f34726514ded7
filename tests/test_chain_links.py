"""The chain's stream links (:mod:`tdicam.hdl.chain_links`): :func:`widen`, the one-pixel-a-beat
stream (the NAND store's coefficients) gathered into ``ppc`` pixels a beat, in the Amaranth
simulator with random idle cycles and backpressure against a reference."""

import numpy as np
import pytest
from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out
from hypothesis import given, settings, strategies as st

from tdicam.beats import PPC_CHOICES, Beats
from tdicam.cosim.streamsim import run_stream_component
from tdicam.errors import TdicamError
from tdicam.hdl.chain_links import Link, widen
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature


class _Widen(wiring.Component):
    """:func:`widen` between two ports: ``count`` elements of ``bits`` a beat in, ``ppc``
    times as many out."""

    def __init__(self, bits, count, ppc):
        self._bits, self._n, self._ppc = bits, count, ppc
        super().__init__({"i_stream": In(pixel_signature(channels_shape(bits, count))),
                          "o_stream": Out(pixel_signature(channels_shape(bits, count * ppc)))})

    def elaborate(self, platform):
        m = Module()
        out = widen(m, Link.of_output(self.i_stream), self._ppc, "w")
        out.feed(m, self.o_stream, who="widen")
        return m


def _reference(stim, ppc):
    """Output beat ``k``: input beats ``k * ppc`` to ``k * ppc + ppc - 1``'s elements in
    order, ``first`` of the first, ``last`` of the last."""
    d = stim.data.reshape(len(stim) // ppc, -1)
    return [(list(row), bool(stim.first[k * ppc]), bool(stim.last[k * ppc + ppc - 1]))
            for k, row in enumerate(d)]


def _stim(rng, bits, count, rows):
    """Rows of ``rows`` beats each (a frame start on a random row's first beat, the first
    row's always), random elements or all-ones."""
    n = sum(rows)
    data = rng.integers(0, 1 << bits, (n, count), dtype=np.uint64)
    if rng.random() < 0.3:
        data[:] = (1 << bits) - 1
    ends = np.cumsum(rows)
    starts = ends - np.asarray(rows)
    first, last = np.zeros(n, bool), np.zeros(n, bool)
    last[ends - 1] = True
    first[starts[rng.random(len(starts)) < 0.5]] = True
    first[0] = True
    return Beats(data, first, last)


def _run(bits, count, ppc, rows, seed, p_valid=0.7, p_ready=0.6):
    stim = _stim(np.random.default_rng(seed), bits, count, rows)
    exp = _reference(stim, ppc)
    out, lat, _ = run_stream_component(_Widen(bits, count, ppc), stim, len(exp), seed=seed,
                                       p_valid=p_valid, p_ready=p_ready,
                                       latency_from=ppc - 1, status=())
    return [(list(map(int, o[0])), bool(o[1]), bool(o[2])) for o in out], exp, lat


@settings(max_examples=6, deadline=None)
@given(data=st.data())
@pytest.mark.parametrize("ppc", PPC_CHOICES[1:])
def test_widen_equals_reference_property(ppc, data):
    """Element widths 1..16, 1..3 elements a pixel, 1..4 rows of 1..4 output beats, random
    idle and backpressure (including none): every output beat is its ``ppc`` input beats
    gathered, markers as the reference's, none lost or duplicated; latency 1 cycle from the
    beat completing the first output beat."""
    bits = data.draw(st.integers(1, 16), "bits")
    count = data.draw(st.integers(1, 3), "count")
    rows = [ppc * k for k in data.draw(st.lists(st.integers(1, 4), min_size=1, max_size=4),
                                       "row_beats")]
    p_valid = data.draw(st.sampled_from([1.0, 0.7, 0.3]), "p_valid")
    p_ready = data.draw(st.sampled_from([1.0, 0.6, 0.2]), "p_ready")
    seed = data.draw(st.integers(0, 2**16), "seed")
    out, exp, lat = _run(bits, count, ppc, rows, seed, p_valid, p_ready)
    assert out == exp
    assert lat == [1]


def test_widen_gathers_the_nand_coefficients_at_8_pixels_a_clock():
    """The chain's case: (gain, offset) pairs of 16 bits, one a beat, into 8 pixels' a beat;
    two rows of 24 pixels."""
    out, exp, _ = _run(16, 2, 8, [24, 24], seed=3)
    assert out == exp and len(out) == 6
    assert [o[2] for o in out] == [False, False, True] * 2


def _link(user=None):
    return Link(Signal(), Signal(), Signal(), Signal(), [Signal(8), Signal(8)], 8, user)


@pytest.mark.filterwarnings("ignore::amaranth.hdl.UnusedElaboratable")
def test_widen_at_one_pixel_a_clock_is_the_link_itself():
    link = _link()
    assert widen(Module(), link, 1, "w") is link


@pytest.mark.filterwarnings("ignore::amaranth.hdl.UnusedElaboratable")
def test_widen_refuses_a_stream_with_user_fields():
    link = _link({"frame_kind": Signal()})
    with pytest.raises(TdicamError, match=r"pipeline: w: a stream carrying frame_kind "
                                          r"cannot change its pixels per clock"):
        widen(Module(), link, 2, "w")
