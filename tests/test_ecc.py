"""SECDED (72,64) Hsiao code: H matrix, golden model sweeps, Amaranth simulation."""

import os

import numpy as np
import pytest
from amaranth.sim import Simulator

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.hdl.ecc import (DEC_OUT_BYTES, SecdedDecoder, SecdedDecoderStream, SecdedEncoder,
                            SecdedEncoderStream)
from tdicam.model import ecc
from tdicam.blocks.secded_dec import dec_beats, sweep_codes
from tdicam.blocks.secded_enc import enc_beats
from tdicam.cosim.streamsim import run_stream_component

FULL = os.environ.get("TDICAM_FULL") == "1"


def _ref_check(d):
    """Check bits straight from the definition, with Python ints."""
    return sum((bin(int(d) & ecc.ROW_MASKS[r]).count("1") & 1) << r for r in range(8))


# ---------------------------------------------------------------- the code
def test_h_matrix_is_a_balanced_hsiao_matrix():
    cols = ecc.COLUMNS.astype(int)
    assert ecc.H.shape == (8, 72)
    assert len(set(cols.tolist())) == 72 and 0 not in cols          # distinct, non-zero
    assert all(bin(c).count("1") % 2 == 1 for c in cols)            # odd weight
    assert ecc.H.sum(axis=1).tolist() == [27] * 8                    # balanced rows
    assert ecc.H[:, :64].sum(axis=1).tolist() == [26] * 8            # 26-input XOR trees
    assert cols[64:].tolist() == [1 << r for r in range(8)]         # check bits: unit columns
    w3 = [v for v in range(256) if bin(v).count("1") == 3]
    assert cols[:56].tolist() == w3                                  # construction step 2
    assert cols[56:64].tolist() == [((0x1F << k) | (0x1F >> (8 - k))) & 0xFF
                                    for k in range(8)]               # construction step 3


def test_docstring_prints_the_matrix():
    for line in ecc.h_matrix_text().splitlines():
        assert "    " + line in ecc.__doc__


def test_every_single_and_double_syndrome_by_linearity():
    """Data-independent: H (c XOR e) = H e. Single flips give their column (a unique code
    bit), double flips an even, non-zero syndrome that is no column."""
    cols = ecc.COLUMNS.astype(int)
    colset = set(cols.tolist())
    pairs = ecc.double_flip_pairs()
    assert len(pairs) == 2556
    s2 = cols[pairs[:, 0]] ^ cols[pairs[:, 1]]
    assert (s2 != 0).all()
    assert not any(int(s) in colset for s in s2)
    assert all(bin(int(s)).count("1") % 2 == 0 for s in s2)


def test_encode_matches_definition():
    rng = np.random.default_rng(3)
    d = np.concatenate([ecc.sweep_words(130), rng.integers(0, 1 << 64, 2000, dtype=np.uint64)])
    c = ecc.encode(d)
    assert c.dtype == np.uint8
    assert c.tolist() == [_ref_check(x) for x in d]
    assert ecc.encode(np.array([0], np.uint64)).tolist() == [0]


def _sweep(n_words):
    words = ecc.sweep_words(n_words)
    d, c, n = sweep_codes(words)
    res = ecc.decode(d, c)
    orig = np.repeat(words, 2629)
    return d, c, n, res, orig


@pytest.mark.parametrize("n_words", [64, 256] if FULL else [64])
def test_model_exhaustive_flips(n_words):
    """Every word of the sweep: error-free untouched, all 72 single flips corrected with the
    flag, all 2,556 double flips flagged uncorrectable and never 'corrected'."""
    d, c, n, res, orig = _sweep(n_words)
    assert len(d) == n_words * (1 + 72 + 2556)
    clean, single, double = n == 0, n == 1, n == 2
    assert clean.sum() == n_words and single.sum() == 72 * n_words
    assert double.sum() == 2556 * n_words
    np.testing.assert_array_equal(res.data[clean | single], orig[clean | single])
    assert not res.corrected[clean].any() and not res.uncorrectable[clean].any()
    assert (res.syndrome[clean] == 0).all()
    assert res.corrected[single].all() and not res.uncorrectable[single].any()
    assert res.uncorrectable[double].all() and not res.corrected[double].any()
    np.testing.assert_array_equal(res.data[double], d[double])  # passed through, not "fixed"


def test_single_flip_syndrome_names_the_bit():
    words = np.full(72, 0x0123_4567_89AB_CDEF, np.uint64)
    d, c = ecc.flip(words, ecc.encode(words), np.arange(72))
    res = ecc.decode(d, c)
    assert res.syndrome.tolist() == ecc.COLUMNS.tolist()
    assert (res.data == words).all() and res.corrected.all()


def test_three_and_more_flips_follow_the_table():
    """>= 3 flips: syndrome 0 -> clean, a column -> that bit flipped, else uncorrectable."""
    rng = np.random.default_rng(9)
    n = 4000
    data = rng.integers(0, 1 << 64, n, dtype=np.uint64)
    k = rng.integers(3, 9, n)
    pos = np.full((n, 8), -1)
    for i in range(n):
        pos[i, :k[i]] = rng.choice(72, k[i], replace=False)
    d, c = ecc.flip(data, ecc.encode(data), pos)
    res = ecc.decode(d, c)
    col_of = {int(v): j for j, v in enumerate(ecc.COLUMNS)}
    seen = set()
    for i in range(n):
        s = int(res.syndrome[i])
        assert s == (int(c[i]) ^ _ref_check(d[i]))
        if s == 0:
            kind, want = "clean", int(d[i])
        elif s in col_of:
            j = col_of[s]
            kind, want = "alias", int(d[i]) ^ ((1 << j) if j < 64 else 0)
        else:
            kind, want = "unc", int(d[i])
        seen.add(kind)
        assert int(res.data[i]) == want
        assert bool(res.corrected[i]) == (kind == "alias")
        assert bool(res.uncorrectable[i]) == (kind == "unc")
    assert {"alias", "unc"} <= seen
    odd = np.array([bin(int(s)).count("1") % 2 for s in res.syndrome]) == 1
    assert (res.uncorrectable & odd).any()  # odd syndromes that are no column are flagged


def test_pack_unpack_flip_roundtrip():
    rng = np.random.default_rng(2)
    d = rng.integers(0, 1 << 64, 100, dtype=np.uint64)
    c = ecc.encode(d)
    b = ecc.pack_code(d, c)
    assert b.shape == (100, 9) and b.dtype == np.uint8
    assert b[0, :8].tobytes() == int(d[0]).to_bytes(8, "little") and b[0, 8] == c[0]
    d2, c2 = ecc.unpack_code(b)
    np.testing.assert_array_equal(d2, d)
    np.testing.assert_array_equal(c2, c)
    f, g = ecc.flip(d, c, np.stack([np.full(100, 5), np.full(100, 70)], axis=1))
    assert ((f ^ d) == 32).all() and ((g ^ c) == 64).all()


def test_sweep_words():
    w = ecc.sweep_words(64)
    assert len(w) == 64 == len(set(w.tolist()))
    assert w[0] == 0 and w[1] == np.uint64(2**64 - 1)
    ones = [x for x in w.tolist() if bin(x).count("1") == 1]
    zeros = [x for x in w.tolist() if bin(x).count("1") == 63]
    assert len(ones) >= 20 and len(zeros) >= 20 and 1 in ones and (1 << 63) in ones
    w256 = ecc.sweep_words(256)
    assert len(set(w256.tolist())) == 256
    assert {1 << k for k in range(64)} <= set(w256.tolist())
    assert {(2**64 - 1) ^ (1 << k) for k in range(64)} <= set(w256.tolist())
    np.testing.assert_array_equal(ecc.sweep_words(64), w)  # deterministic


@pytest.mark.parametrize("call,match", [
    (lambda: ecc.encode(np.array([-1])), "outside 0..2\\*\\*64-1"),
    (lambda: ecc.encode(np.array([1.5])), "integer"),
    (lambda: ecc.decode(np.zeros(3, np.uint64), np.zeros(2, np.uint8)), "shape"),
    (lambda: ecc.decode(np.zeros(1, np.uint64), np.array([256])), "0..255"),
    (lambda: ecc.flip(np.zeros(1, np.uint64), np.zeros(1, np.uint8), [[72]]), "0..71"),
])
def test_model_bad_input(call, match):
    with pytest.raises(TdicamError, match=match):
        call()


# ---------------------------------------------------------------- gateware (Amaranth sim)
def _vectors(n, seed):
    """Random words with 0, 1 or 2 random flips, plus a few wider errors."""
    rng = np.random.default_rng(seed)
    data = rng.integers(0, 1 << 64, n, dtype=np.uint64)
    k = rng.choice([0, 1, 2, 3, 4], n, p=[0.2, 0.35, 0.35, 0.05, 0.05])
    pos = np.full((n, 4), -1)
    for i in range(n):
        pos[i, :k[i]] = rng.choice(72, k[i], replace=False)
    return (data,) + ecc.flip(data, ecc.encode(data), pos)


@pytest.mark.parametrize("registered,pipelined", [(False, False), (True, False), (True, True)])
def test_plain_components_match_model(registered, pipelined):
    enc = SecdedEncoder(registered=registered)
    dec = SecdedDecoder(registered=registered, pipelined=pipelined)
    assert enc.latency == int(registered)
    assert dec.latency == int(registered) + int(pipelined)
    _, d, c = _vectors(150, seed=int(registered))
    want = ecc.decode(d, c)
    got_check, got = [], []

    async def bench(ctx):
        for k in range(len(d)):
            ctx.set(enc.data, int(d[k]))
            ctx.set(dec.code, int(d[k]) | int(c[k]) << 64)
            for _ in range(dec.latency):
                await ctx.tick()
            code = ctx.get(enc.code)
            got_check.append(code >> 64)
            assert code & (2**64 - 1) == int(d[k])
            got.append((ctx.get(dec.data), ctx.get(dec.corrected), ctx.get(dec.uncorrectable),
                        ctx.get(dec.syndrome)))

    from amaranth.hdl import Module
    m = Module()
    m.submodules.enc, m.submodules.dec = enc, dec
    sim = Simulator(m)
    if registered:
        sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    assert got_check == ecc.encode(d).tolist()
    assert [g[0] for g in got] == want.data.tolist()
    assert [bool(g[1]) for g in got] == want.corrected.tolist()
    assert [bool(g[2]) for g in got] == want.uncorrectable.tolist()
    assert [g[3] for g in got] == want.syndrome.tolist()


@pytest.mark.parametrize("registered,pipelined", [(False, False), (True, False), (True, True)])
def test_stream_wrappers_match_model_with_stalls(registered, pipelined):
    data, d, c = _vectors(120, seed=5 + registered)
    for dut, (stim, exp), lat in (
            (SecdedEncoderStream(registered=registered), enc_beats(data), 1 + registered),
            (SecdedDecoderStream(registered=registered, pipelined=pipelined), dec_beats(d, c),
             1 + registered + pipelined)):
        assert dut.latency == lat
        out, lat, _ = run_stream_component(dut, stim, len(exp), seed=3)
        assert [r for r, _, _ in out] == exp.data.astype(int).tolist()
        assert [f for _, f, _ in out] == exp.first.tolist()
        assert [la for _, _, la in out] == exp.last.tolist()
        assert lat == [dut.latency]
    assert exp.data.shape[1] == DEC_OUT_BYTES


def _built(block, params):
    top = blocks.get(block).build(params)
    obj = top
    while obj is not None:  # inspected, never elaborated: no UnusedElaboratable warnings
        obj._MustUse__silence = True
        obj = getattr(obj, "core", None)
    return top


def test_blocks_registered():
    enc = blocks.get("secded_enc")
    assert isinstance(_built("secded_enc", {}), SecdedEncoder)
    assert isinstance(_built("secded_dec", {"registered": "true"}), SecdedDecoder)
    assert _built("secded_dec", {"registered": 1}).latency == 1
    assert _built("secded_dec", {"stream": 1, "registered": 1}).latency == 2
    with pytest.raises(TdicamError, match="--registered must be true or false"):
        enc.resolve({"registered": "maybe"})


def test_verilog_plain_ports(tmp_path):
    import re

    from tdicam.cli import main
    for block, ports in (("secded_enc", [("input", 63, "data"), ("output", 71, "code")]),
                         ("secded_dec", [("input", 71, "code"), ("output", 63, "data"),
                                         ("output", None, "corrected"),
                                         ("output", None, "uncorrectable"),
                                         ("output", 7, "syndrome")])):
        for reg in ("0", "1"):
            path = tmp_path / f"{block}{reg}.v"
            assert main(["verilog", block, "--registered", reg, "-o", str(path)]) == 0
            text = path.read_text()
            assert re.search(rf"^module {block}\(", text, re.M)
            for direction, msb, name in ports:
                width = rf"\[{msb}:0\] " if msb else ""
                assert re.search(rf"^\s*{direction} {width}{name};", text, re.M), (block, name)
            assert ("input clk;" in text) == (reg == "1")
