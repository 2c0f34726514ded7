"""Golden model, coefficient format and Amaranth simulation of the ``nuc`` block."""

import math
from fractions import Fraction

import numpy as np
import pytest
from amaranth.hdl import Fragment

from tdicam import blocks
from tdicam.cosim import golden, compare
from tdicam.cosim.codec import Beats
from tdicam.cosim.pysim import run_pysim
from tdicam.errors import TdicamError
from tdicam.hdl.nuc import Nuc
from tdicam.model.nuc import DEFAULT_FORMAT, NucFormat, identity_coeffs, nuc
from tdicam.cosim.streamsim import probe_latency, run_stream_component

FORMATS = [
    dict(pixel_bits=12),
    dict(pixel_bits=12, gain_int_bits=4, gain_frac_bits=12, offset_bits=16, offset_frac_bits=4),
    dict(pixel_bits=16, gain_int_bits=2, gain_frac_bits=16, offset_bits=18, offset_frac_bits=8,
         out_bits=20),
    dict(pixel_bits=10, gain_int_bits=1, gain_frac_bits=7, offset_bits=10, offset_frac_bits=2,
         out_bits=8),
    dict(pixel_bits=8, gain_int_bits=3, gain_frac_bits=4, offset_bits=2, out_bits=9),
]


def _reference(x, g, o, p):
    """Exact rational arithmetic, one pixel at a time."""
    gf, of = p.get("gain_frac_bits", 14), p.get("offset_frac_bits", 0)
    top = (1 << p.get("out_bits", p["pixel_bits"])) - 1
    out = []
    for xi, gi, oi in zip(x.ravel().tolist(), g.ravel().tolist(), o.ravel().tolist()):
        v = Fraction(gi, 1 << gf) * xi + Fraction(oi, 1 << of)
        out.append(min(max(math.floor(v + Fraction(1, 2)), 0), top))
    return np.array(out).reshape(x.shape)


def _fmt(p):
    return NucFormat(**{k: p[k] for k in ("gain_int_bits", "gain_frac_bits", "offset_bits",
                                          "offset_frac_bits") if k in p})


@pytest.mark.parametrize("p", FORMATS)
def test_model_matches_exact_arithmetic(p):
    rng = np.random.default_rng(1)
    fmt = _fmt(p)
    n = 3000
    x = rng.integers(0, 1 << p["pixel_bits"], n)
    g = rng.integers(0, fmt.gain_max + 1, n)
    o = rng.integers(fmt.offset_min, fmt.offset_max + 1, n)
    # plenty of exact halves: gain 1.5 on odd x, offsets of +-0.5 LSB
    g[:200] = 3 << (fmt.gain_frac_bits - 1)
    o[200:400] = np.where(fmt.offset_frac_bits > 0, (1 << max(fmt.offset_frac_bits - 1, 0)), 0)
    got = nuc(x, g, o, **p)
    np.testing.assert_array_equal(got.astype(np.int64), _reference(x, g, o, p))


@pytest.mark.parametrize("bits", [8, 10, 12, 14, 16])
def test_identity_is_exact_over_every_code(bits):
    x = np.arange(1 << bits)
    g, o = identity_coeffs(x.shape)
    out = nuc(x, g, o, pixel_bits=bits)
    np.testing.assert_array_equal(out, x)
    assert out.dtype == (np.uint8 if bits == 8 else np.uint16)


def test_round_half_up_both_signs():
    p = dict(pixel_bits=12, offset_frac_bits=1)
    one = DEFAULT_FORMAT.gain_one
    # 10 - 0.5 = 9.5 -> 10; 10 + 0.5 -> 11 (half up); 1.5 * 3 = 4.5 -> 5; 0 - 0.5 -> 0
    x = np.array([10, 10, 3, 0, 1])
    g = np.array([one, one, 3 * one // 2, one, one])
    o = np.array([-1, 1, 0, -1, -3])  # offsets in halves
    assert nuc(x, g, o, **p).tolist() == [10, 11, 5, 0, 0]


@pytest.mark.parametrize("p", FORMATS)
def test_extremes_saturate_never_wrap(p):
    fmt = _fmt(p)
    full = (1 << p["pixel_bits"]) - 1
    top = (1 << p.get("out_bits", p["pixel_bits"])) - 1
    x = np.array([full, full, 0, full, 1])
    g = np.array([fmt.gain_max, 0, 0, fmt.gain_max, 0])
    o = np.array([fmt.offset_max, fmt.offset_min, fmt.offset_min, fmt.offset_min, 0])
    got = nuc(x, g, o, **p).astype(np.int64)
    biggest = fmt.gain_max / fmt.gain_one * full + fmt.offset_max / (1 << fmt.offset_frac_bits)
    if biggest > top:
        assert got[0] == top  # largest product + largest offset: clamps high
    assert got[1] == 0 and got[2] == 0  # most negative: clamps at 0, no wrap to a big value
    assert got.tolist() == _reference(x, g, o, p).tolist()


def test_no_numpy_wrap_with_unsigned_inputs():
    out = nuc(np.array([100], np.uint16), np.array([0], np.uint16), np.array([-200], np.int16))
    assert out.tolist() == [0]


@pytest.mark.parametrize("kwargs,match", [
    ({"pixel_bits": 7}, "pixel_bits = 7 is out of range; valid: 8..16"),
    ({"gain_int_bits": 0}, "gain_int_bits = 0 is out of range; valid: 1..4"),
    ({"gain_frac_bits": 17}, "gain_frac_bits = 17"),
    ({"gain_int_bits": 4, "gain_frac_bits": 16}, "gain_int_bits \\+ gain_frac_bits = 20 is too "
                                                 "wide; valid: at most 18"),
    ({"offset_bits": 1}, "offset_bits = 1"),
    ({"offset_bits": 4, "offset_frac_bits": 4}, "offset_frac_bits = 4 is out of range; "
                                                 "valid: 0..3"),
    ({"out_bits": 21}, "out_bits = 21"),
])
def test_bad_params_one_line(kwargs, match):
    x = np.zeros(2, int)
    with pytest.raises(TdicamError, match=match) as exc:
        nuc(x, x + 16384, x, **kwargs)
    assert "\n" not in str(exc.value)
    with pytest.raises(TdicamError, match=match):
        Nuc(**kwargs)
    with pytest.raises(TdicamError) as exc:
        blocks.get("nuc").resolve(kwargs)
    assert "\n" not in str(exc.value)


def test_bad_inputs():
    z = np.zeros(3, int)
    with pytest.raises(TdicamError, match="x has values outside 0..4095"):
        nuc(z + 4096, z, z)
    with pytest.raises(TdicamError, match="gain has codes outside 0..65535"):
        nuc(z, z - 1, z)
    with pytest.raises(TdicamError, match="offset has codes outside -32768..32767"):
        nuc(z, z, z + 40000)
    with pytest.raises(TdicamError, match="shape"):
        nuc(z, np.zeros(4, int), z)
    with pytest.raises(TdicamError, match="integer"):
        nuc(z, z * 1.0, z)


def test_flash_word_format():
    fmt = DEFAULT_FORMAT
    assert (fmt.gain_bits, fmt.gain_one, fmt.offset_min, fmt.offset_max) == \
        (16, 16384, -32768, 32767)
    assert fmt.pixels_per_word == 2
    assert fmt.default_word() == 0x0000_4000_0000_4000
    w = fmt.pack_words([0x4000, 0xFFFF], [-1, 0x1234])
    assert w.tolist() == [0x1234_FFFF_FFFF_4000]
    rng = np.random.default_rng(3)
    g = rng.integers(0, 1 << 16, 101)
    o = rng.integers(-32768, 32768, 101)
    gu, ou = fmt.unpack_words(fmt.pack_words(g, o))
    np.testing.assert_array_equal(gu[:101], g)
    np.testing.assert_array_equal(ou[:101], o)
    assert (gu[101], ou[101]) == (fmt.gain_one, 0)  # odd count padded with defaults
    narrow = NucFormat(gain_int_bits=1, gain_frac_bits=7, offset_bits=10, offset_frac_bits=2)
    gu, ou = narrow.unpack_words(narrow.pack_words([128, 255], [-512, 511]))
    assert gu.tolist() == [128, 255] and ou.tolist() == [-512, 511]
    with pytest.raises(TdicamError, match="at most 16 bits"):
        NucFormat(gain_int_bits=2, gain_frac_bits=16).pack_words([0], [0])


def test_format_codes_from_reals():
    fmt = DEFAULT_FORMAT
    assert fmt.gain_code([1.0, 0.5, 99.0, -1.0]).tolist() == [16384, 8192, 65535, 0]
    assert fmt.offset_code([-1.5, 2.49, 1e9]).tolist() == [-1, 2, 32767]
    assert fmt.params() == {"gain_int_bits": 2, "gain_frac_bits": 14, "offset_bits": 16,
                            "offset_frac_bits": 0}


def test_component_params_and_latency():
    dut = Nuc(pixel_bits=10, gain_int_bits=1, gain_frac_bits=7, offset_bits=10,
              offset_frac_bits=2, out_bits=8)
    assert (dut.pixel_bits, dut.gain_bits, dut.offset_bits, dut.out_bits) == (10, 8, 10, 8)
    assert dut.elem_bits == 10 and dut.latency == 3
    Fragment.get(dut, None)
    dflt = Nuc()
    assert dflt.out_bits == 12 and dflt.elem_bits == 16
    Fragment.get(dflt, None)


def _run_core(dut, x, g, o, *, pad_garbage, rng, p_valid=0.7, p_ready=0.6):
    """Random valid/ready in the Amaranth simulator; returns the output transfers. With
    ``pad_garbage`` the element bits above each field's width carry random junk."""
    n = len(x)
    w = dut.elem_bits

    def garbage(bits):
        if not pad_garbage or w <= bits:
            return np.zeros(n, np.uint64)
        return rng.integers(0, 1 << (w - bits), n).astype(np.uint64) << np.uint64(bits)

    off = np.asarray(o, np.int64) & ((1 << dut.offset_bits) - 1)
    data = np.stack([np.asarray(x, np.uint64) | garbage(dut.pixel_bits),
                     np.asarray(g, np.uint64) | garbage(dut.gain_bits),
                     off.astype(np.uint64) | garbage(dut.offset_bits)], axis=1)
    k = np.arange(n)
    got, _, _ = run_stream_component(dut, Beats(data, k == 0, k % 7 == 6), n,
                                     seed=int(rng.integers(1 << 31)), p_valid=p_valid,
                                     p_ready=p_ready, timeout=1e-8 * (40 * n + 200),
                                     latency_from=None)
    return [(row[0], first, last) for row, first, last in got]


@pytest.mark.parametrize("p", [FORMATS[0], FORMATS[2], FORMATS[3]])
def test_amaranth_sim_with_stalls_and_padding_garbage(p):
    """The core ignores element bits above each field's width; no pixel lost or duplicated."""
    rng = np.random.default_rng(5)
    fmt = _fmt(p)
    n = 150
    x = rng.integers(0, 1 << p["pixel_bits"], n)
    g = rng.integers(0, fmt.gain_max + 1, n)
    o = rng.integers(fmt.offset_min, fmt.offset_max + 1, n)
    want = nuc(x, g, o, **p).tolist()
    got = _run_core(Nuc(**p), x, g, o, pad_garbage=True, rng=rng)
    assert [v[0] for v in got] == want
    assert [v[1] for v in got] == [k == 0 for k in range(n)]
    assert [v[2] for v in got] == [k % 7 == 6 for k in range(n)]


def test_latency_is_three_cycles_at_full_rate():
    dut = Nuc()
    seen = probe_latency(dut, [1000, DEFAULT_FORMAT.gain_one], cycles=6)
    # output valid `latency` edges after the accepting edge, for exactly one cycle
    assert [v for v, _ in seen] == [0, 0, 1, 0, 0, 0]
    assert seen[2][1] == 1000
    assert dut.latency == 3


@pytest.mark.parametrize("case", ["saturate_wide", "reset_mid_frame_12b"])
def test_amaranth_pysim_of_verilog_top_matches_golden(case):
    blk = blocks.get("nuc")
    arrays, params = golden.load(blk, case)
    stim, exp = blk.streams.to_beats(arrays, params)
    got, cycles, _, timeout = run_pysim("nuc", params, stim, idle=0.3, backpressure=0.3, seed=2)
    cmp = compare(got, exp)
    assert cmp.ok and not timeout, cmp.message


def test_golden_cases_cover_the_hard_cases():
    blk = blocks.get("nuc")
    arrays, params = golden.load(blk, "identity_12b")
    np.testing.assert_array_equal(arrays["out"], arrays["x"])
    arrays, params = golden.load(blk, "saturate_12b")
    out = arrays["out"].astype(np.int64)
    assert out.min() == 0 and out.max() == 4095
    arrays, _ = golden.load(blk, "reset_mid_frame_12b")
    assert 0 < int(arrays["reset_before"][0]) < arrays["x"][0].size


def test_stream_elements_two_complement_offset():
    e = DEFAULT_FORMAT.stream_elements([5, 6], [16384, 1], [-1, 7])
    assert e.tolist() == [[5, 16384, 0xFFFF], [6, 1, 7]]
    with pytest.raises(TdicamError, match="offset has codes outside"):
        DEFAULT_FORMAT.stream_elements([0], [0], [1 << 20])


# ---- pixels per clock

@pytest.mark.parametrize("ppc", [1, 2, 4, 8])
def test_ppc_latency_is_three_cycles_at_ppc_1_four_above(ppc):
    dut = Nuc(ppc=ppc)
    lat = 3 if ppc == 1 else 4
    assert dut.ppc == ppc and dut.latency == lat
    data = [v for k in range(ppc) for v in (1000 + k, DEFAULT_FORMAT.gain_one, 0)]
    seen = probe_latency(dut, data, cycles=6)
    assert [v for v, _ in seen] == [int(c == lat - 1) for c in range(6)]
    assert seen[lat - 1][1] == 1000


@pytest.mark.parametrize("p,ppc", [(FORMATS[0], 2), (FORMATS[2], 4), (FORMATS[3], 8),
                                   (FORMATS[4], 8)])
def test_amaranth_sim_ppc_with_stalls_and_padding_garbage(p, ppc):
    """ppc (x, gain, offset) triples per beat, pixel-major, with junk above each field's
    width; random valid/ready; every lane equals the golden model."""
    rng = np.random.default_rng(ppc)
    fmt = _fmt(p)
    n = 24 * ppc
    x = rng.integers(0, 1 << p["pixel_bits"], n)
    g = rng.integers(0, fmt.gain_max + 1, n)
    o = rng.integers(fmt.offset_min, fmt.offset_max + 1, n)
    x[:3], g[:3], o[:3] = (1 << p["pixel_bits"]) - 1, fmt.gain_max, fmt.offset_max  # saturate
    want = nuc(x, g, o, **p).reshape(-1, ppc)
    dut = Nuc(**p, ppc=ppc)
    w = dut.elem_bits

    def garbage(bits):
        if w <= bits:
            return np.zeros(n, np.uint64)
        return rng.integers(0, 1 << (w - bits), n).astype(np.uint64) << np.uint64(bits)

    off = np.asarray(o, np.int64) & ((1 << dut.offset_bits) - 1)
    data = np.stack([np.asarray(x, np.uint64) | garbage(dut.pixel_bits),
                     np.asarray(g, np.uint64) | garbage(dut.gain_bits),
                     off.astype(np.uint64) | garbage(dut.offset_bits)], axis=1)
    nb = n // ppc
    k = np.arange(nb)
    stim = Beats(data.reshape(nb, 3 * ppc), k == 0, k % 6 == 5)
    got, lat, _ = run_stream_component(dut, stim, nb, seed=5)
    np.testing.assert_array_equal(np.array([r for r, _, _ in got]), want)
    assert [f for _, f, _ in got] == (k == 0).tolist()
    assert [lst for _, _, lst in got] == (k % 6 == 5).tolist()
    assert lat == [dut.latency] and dut.latency == (3 if ppc == 1 else 4)


@pytest.mark.parametrize("case", ["saturate_wide_p8", "reset_mid_frame_12b_p4"])
def test_amaranth_pysim_of_verilog_top_matches_golden_ppc(case):
    blk = blocks.get("nuc")
    arrays, params = golden.load(blk, case)
    stim, exp = blk.streams.to_beats(arrays, params)
    assert stim.data.shape[1] == 3 * params["ppc"]
    got, _, _, timeout = run_pysim("nuc", params, stim, idle=0.3, backpressure=0.3, seed=2)
    cmp = compare(got, exp)
    assert cmp.ok and not timeout, cmp.message


def test_ppc_errors_are_one_line():
    blk = blocks.get("nuc")
    with pytest.raises(TdicamError, match=r"^ppc = 5 is not valid; valid: 1, 2, 4, 8$"):
        Nuc(ppc=5)
    p = blk.resolve({"ppc": 4})
    x = np.zeros((1, 2, 6), np.int64)
    g, o = identity_coeffs(x.shape)
    with pytest.raises(TdicamError, match=r"^--width 6 is not a multiple of --ppc 4$"):
        blk.streams.to_beats({"x": x, "gain": g, "offset": o, "out": x}, p)


def test_ecp5_top_multipliers_are_dsp_blocks_with_their_input_registers():
    """``dsp="ecp5"``: one MULT18X18D a lane with REG_INPUTA/B on CLK0 and no output
    register (the product register stays in the fabric), the same latency; an unknown
    ``dsp`` is a one-line error naming it and the valid values."""
    from amaranth.back import rtlil
    for ppc in (1, 8):
        top = Nuc(ppc=ppc, dsp="ecp5")
        assert top.latency == Nuc(ppc=ppc).latency == (3 if ppc == 1 else 4)
        text = rtlil.convert(top)
        assert text.count("cell \\MULT18X18D") == ppc
        assert text.count('parameter \\REG_INPUTA_CLK "CLK0"') == ppc
        assert text.count('parameter \\REG_OUTPUT_CLK "NONE"') == ppc
    with pytest.raises(TdicamError, match="dsp.*'xilinx'.*generic, ecp5"):
        Nuc(dsp="xilinx")
