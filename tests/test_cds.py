"""Golden model and Amaranth simulation of the digital CDS block."""

import numpy as np
import pytest
from amaranth.hdl import Fragment

from tdicam import blocks
from tdicam.beats import frames_to_beats
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
    from tdicam.cosim import golden, compare
    from tdicam.cosim.pysim import run_pysim
    blk = blocks.get("cds")
    for case in ("hard_12b", "reset_mid_frame_12b"):
        arrays, params = golden.load(blk, case)
        stim, exp = blk.streams.to_beats(arrays, params)
        got, cycles, _, timeout = run_pysim("cds", params, stim, idle=0.3, backpressure=0.3, seed=2)
        cmp = compare(got, exp)
        assert cmp.ok and not timeout, cmp.message
        assert cycles > len(stim)


# ---- pixels per clock

@pytest.mark.parametrize("ppc", [1, 2, 4, 8])
def test_ppc_latency_is_one_cycle(ppc):
    """Latency 1 at every ppc: one beat offered, its output valid one edge later, for one
    cycle, lane k = signal k - reset k (pixel-major pairs)."""
    from tdicam.cosim.streamsim import probe_latency
    dut = Cds(pixel_bits=12, ppc=ppc)
    assert dut.ppc == ppc and dut.latency == 1
    data = [v for k in range(ppc) for v in (1000 + 7 * k, 10 * k)]
    seen = probe_latency(dut, data, cycles=3)
    assert [v for v, _ in seen] == [1, 0, 0]
    assert seen[0][1] == 1000


@pytest.mark.parametrize("ppc", [2, 4, 8])
def test_amaranth_sim_ppc_matches_model_with_stalls(ppc):
    """ppc pixels per beat in the Amaranth simulator, random valid/ready: every lane equals
    the golden model, markers per beat, latency 1."""
    rng = np.random.default_rng(ppc)
    sig = rng.integers(0, 4096, (2, 5, 3 * ppc))
    rst = rng.integers(0, 4096, (2, 5, 3 * ppc))
    sig[0, 0, :ppc] = rst[0, 0, :ppc]                     # equal: 0
    stim = frames_to_beats(np.stack([sig, rst], -1), ppc=ppc, channels=2)
    exp = frames_to_beats(cds(sig, rst, pixel_bits=12), ppc=ppc)
    got, lat, _ = run_stream_component(Cds(pixel_bits=12, ppc=ppc), stim, len(stim), seed=3)
    np.testing.assert_array_equal(np.array([g[0] for g in got]), exp.data)
    assert [g[1] for g in got] == exp.first.tolist()
    assert [g[2] for g in got] == exp.last.tolist()
    assert lat == [1]


def test_ppc_errors_are_one_line():
    blk = blocks.get("cds")
    with pytest.raises(TdicamError, match=r"^ppc = 3 is not valid; valid: 1, 2, 4, 8$"):
        Cds(ppc=3)
    with pytest.raises(TdicamError, match=r"^--ppc = 3 is not valid; valid: 1, 2, 4, 8$"):
        blk.resolve({"ppc": 3})
    p = blk.resolve({"ppc": 8})
    a = {"signal": np.zeros((1, 2, 20), np.uint16), "reset": np.zeros((1, 2, 20), np.uint16)}
    with pytest.raises(TdicamError, match=r"^--width 20 is not a multiple of --ppc 8$"):
        blk.streams.to_beats({**a, "out": a["signal"]}, p)


@pytest.mark.parametrize("ppc", [1, 4, 8])
def test_scene_arrays_round_trip_at_ppc(ppc):
    """Scene arrays -> case arrays -> ppc-wide beats -> scene arrays (what ``tdicam run``
    and the pipeline do with a block's output beats)."""
    blk = blocks.get("cds")
    rng = np.random.default_rng(1)
    arrays = {"signal": rng.integers(0, 4096, (2, 3, 16), dtype=np.uint16),
              "reset": rng.integers(0, 4096, (2, 3, 16), dtype=np.uint16)}
    p = blk.scene_params(arrays, {"ppc": ppc})
    stim, exp = blk.streams.to_beats(blk.case_arrays(arrays, p), p)
    assert stim.data.shape == (2 * 3 * 16 // ppc, 2 * ppc)
    np.testing.assert_array_equal(stim.data[0, :2], [arrays["signal"][0, 0, 0],
                                                     arrays["reset"][0, 0, 0]])
    out = blk.from_beats(exp, arrays, p)["out"]
    np.testing.assert_array_equal(out, cds(arrays["signal"], arrays["reset"]))


def test_ppc_default_is_not_recorded():
    """Golden vectors and Verilog from before ``ppc`` existed stay byte-identical: a case
    or a design at ppc 1 does not name it; ppc 8 does."""
    import json
    from tdicam.cosim import golden
    from tdicam.hw import verilog
    from tdicam.paths import GOLDEN
    with np.load(GOLDEN / "cds" / "random_12b.npz") as z:
        assert json.loads(str(z["__params__"])) == {"pixel_bits": 12}
    with np.load(GOLDEN / "cds" / "random_12b_p8.npz") as z:
        assert json.loads(str(z["__params__"])) == {"pixel_bits": 12, "ppc": 8}
    assert golden.load("cds", "random_12b")[1] == {"pixel_bits": 12, "ppc": 1}
    assert "// parameters: pixel_bits=12\n" in verilog.generate("cds")
    assert "// parameters: pixel_bits=12, ppc=8\n" in verilog.generate("cds", {"ppc": 8})
