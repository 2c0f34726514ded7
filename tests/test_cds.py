"""Golden model and Amaranth simulation of the digital CDS block."""

import numpy as np
import pytest
from amaranth.hdl import Fragment

from tdicam.cosim.codec import Beats
from tdicam.errors import TdicamError
from tdicam.hdl.cds import Cds
from tdicam.model.cds import cds
from tdicam.cosim.streamsim import run_stream_component


def test_model_matches_definition():
    rng = np.random.default_rng(0)
    s = rng.integers(0, 4096, 10000).astype(np.uint16)
    r = rng.integers(0, 4096, 10000).astype(np.uint16)
    out = cds(s, r, pixel_bits=12)
    assert out.dtype == np.uint16
    ref = np.array([max(int(a) - int(b), 0) for a, b in zip(s, r)], dtype=np.uint16)
    np.testing.assert_array_equal(out, ref)


def test_model_no_uint_wrap():
    out = cds(np.array([100], np.uint16), np.array([200], np.uint16), pixel_bits=12)
    assert out.tolist() == [0]  # not 65436


@pytest.mark.parametrize("bits,dtype", [(8, np.uint8), (12, np.uint16), (16, np.uint16)])
def test_model_full_scale(bits, dtype):
    full = (1 << bits) - 1
    out = cds(np.array([full, full, 0]), np.array([0, full, full]), pixel_bits=bits)
    assert out.dtype == dtype
    assert out.tolist() == [full, 0, 0]


@pytest.mark.parametrize("kwargs,match", [
    ({"pixel_bits": 7}, "pixel_bits = 7 is out of range; valid: 8..16"),
    ({"pixel_bits": 17}, "pixel_bits = 17"),
])
def test_model_bad_params(kwargs, match):
    with pytest.raises(TdicamError, match=match):
        cds(np.zeros(2, int), np.zeros(2, int), **kwargs)


def test_model_bad_input():
    with pytest.raises(TdicamError, match="signal has values outside 0..4095"):
        cds(np.array([4096]), np.array([0]), pixel_bits=12)
    with pytest.raises(TdicamError, match="shape"):
        cds(np.zeros(3, int), np.zeros(4, int))
    with pytest.raises(TdicamError, match="integer"):
        cds(np.zeros(3), np.zeros(3))


def test_component_params():
    dut = Cds(pixel_bits=10)
    assert dut.pixel_bits == 10
    assert dut.latency == 1
    Fragment.get(dut, None)  # elaborates; also marks the component used
    with pytest.raises(TdicamError, match="pixel_bits"):
        Cds(pixel_bits=20)


def test_amaranth_sim_matches_model_with_stalls():
    """Python simulation of the component, random valid/ready, latency asserted."""
    dut = Cds(pixel_bits=12)
    rng = np.random.default_rng(1)
    n = 300
    sig = rng.integers(0, 4096, n)
    rst = rng.integers(0, 4096, n)
    want = cds(sig, rst, pixel_bits=12).tolist()
    k = np.arange(n)
    stim = Beats(np.stack([sig, rst], axis=1), k == 0, k % 10 == 9)
    got, lat, _ = run_stream_component(dut, stim, n, seed=1)
    assert [g[0][0] for g in got] == want
    assert [g[1] for g in got] == (k == 0).tolist()
    assert [g[2] for g in got] == (k % 10 == 9).tolist()
    assert lat == [dut.latency] == [1]


def test_amaranth_pysim_of_verilog_top_matches_golden_cases():
    """The AXI4-Stream top in Amaranth's simulator, with stalls and a mid-frame reset."""
    from tdicam import blocks
    from tdicam.cosim import vectors as golden, compare
    from tdicam.cosim.pysim import run_pysim
    blk = blocks.get("cds")
    for case in ("hard_12b", "reset_mid_frame_12b"):
        arrays, params = golden.load(blk, case)
        stim, exp = blk.to_beats(arrays, params)
        got, cycles, _ = run_pysim("cds", params, stim, idle=0.3, backpressure=0.3, seed=2)
        cmp = compare(got, exp)
        assert cmp.ok, cmp.message
        assert cycles > len(stim)
