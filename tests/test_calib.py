"""Calibration store: image format, software reader, golden reader model, Amaranth sim."""

import numpy as np
import pytest
from amaranth.hdl import Signal

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.blocks.calib import random_codes, reader_beats
from tdicam.errors import TdicamError
from tdicam.hdl.calib import CalibReader
from tdicam.model import calib, ecc
from tdicam.model.nuc import DEFAULT_FORMAT, NucFormat
from tdicam.cosim.streamsim import run_stream_component

FMT = DEFAULT_FORMAT


def _maps(rows=5, cols=7, seed=0, fmt=FMT):
    return random_codes(np.random.default_rng(seed), rows, cols, fmt)


# ---------------------------------------------------------------- image format
def test_header_layout():
    g, o = _maps(5, 7)
    img = calib.encode_image(g, o)
    assert img.dtype == np.uint8 and img.shape == (4 + 18, 9)  # ceil(35 / 2) = 18 words
    d, c = ecc.unpack_code(img)
    assert (ecc.encode(d) == c).all()  # every word is a code word, header included
    raw = img[:, :8]
    assert raw[0].tobytes() == b"TDICAL\x01\x00"
    assert int.from_bytes(raw[1, :4].tobytes(), "little") == 5
    assert int.from_bytes(raw[1, 4:].tobytes(), "little") == 7
    assert raw[2].tolist() == [2, 14, 16, 0, 1, 0, 0, 0]
    assert int.from_bytes(raw[3, :4].tobytes(), "little") == 18
    # payload = the nuc format's own packing (2 pixels, 4 coefficients per word)
    np.testing.assert_array_equal(d[4:], FMT.pack_words(g, o))
    assert d[4] & 0xFFFF == g[0, 0] and d[4] >> 32 & 0xFFFF == g[0, 1]


@pytest.mark.parametrize("rows,cols,fmt", [(5, 7, FMT), (4, 6, FMT), (1, 1, FMT),
                                           (3, 3, NucFormat(1, 8, 10, 2))])
def test_roundtrip(rows, cols, fmt):
    g, o = _maps(rows, cols, seed=rows, fmt=fmt)
    res = calib.read_image(calib.encode_image(g, o, fmt).tobytes())
    np.testing.assert_array_equal(res.gain, g)
    np.testing.assert_array_equal(res.offset, o)
    assert res.fmt == fmt and res.corrected == 0 and res.uncorrectable == 0 and res.crc_ok
    assert not res.defaulted.any()


def test_single_flips_invisible_double_flips_default_two_pixels():
    rng = np.random.default_rng(4)
    g, o = _maps(9, 11, seed=3)
    img = calib.encode_image(g, o)
    k = rng.choice([0, 1, 2], len(img), p=[0.3, 0.4, 0.3])
    k[:4] = np.minimum(k[:4], 1)  # header: single flips only (a double one is an error)
    pos = np.full((len(img), 2), -1)
    for w in np.nonzero(k)[0]:
        pos[w, :k[w]] = rng.choice(72, k[w], replace=False)
    bad = calib.flip_image_bits(img, pos)
    res = calib.read_image(bad)
    assert res.corrected == int((k == 1).sum()) > 0
    assert res.uncorrectable == int((k == 2).sum()) > 0
    px_bad = np.repeat(k[4:] == 2, 2)[:99].reshape(9, 11)
    np.testing.assert_array_equal(res.defaulted, px_bad)
    np.testing.assert_array_equal(res.gain, np.where(px_bad, FMT.gain_one, g))
    np.testing.assert_array_equal(res.offset, np.where(px_bad, 0, o))
    assert not res.crc_ok
    # single flips only: everything recovered, CRC intact
    only1 = calib.flip_image_bits(img, np.where(k[:, None] == 1, pos[:, :1], -1))
    res1 = calib.read_image(only1)
    np.testing.assert_array_equal(res1.gain, g)
    assert res1.crc_ok and res1.uncorrectable == 0


def _img(rows=3, cols=4):
    return calib.encode_image(*_maps(rows, cols))


def _with_header(word, value):
    img = _img()
    d, _ = ecc.unpack_code(img)
    d[word] = np.uint64(value)
    return ecc.pack_code(d, ecc.encode(d)).tobytes()


def _hdr(k, **kw):
    return calib.header_words(3, 4, FMT)[k]


@pytest.mark.parametrize("data,match", [
    (_img().tobytes()[:-1], "not a whole number of 9-byte flash words"),
    (_img().tobytes()[:27], "truncated: 27 bytes, the header alone is 36"),
    (_img().tobytes()[:-9], "truncated: the header says 6 payload words, the file has 5"),
    (_img().tobytes() + _img().tobytes()[:9], "1 words of trailing data"),
    (b"", "truncated: 0 bytes"),
    (_with_header(0, int.from_bytes(b"XDICAL\x01\x00", "little")), "not a tdicam calibration"),
    (_with_header(0, int.from_bytes(b"TDICAL\x02\x00", "little")), "unsupported image version 2"),
    (_with_header(1, 0 | 4 << 32), "malformed header: 0 x 4 pixels"),
    (_with_header(2, _hdr(2) ^ (7 << 32)), "malformed header: packing 6"),
    (_with_header(2, _hdr(2) ^ (1 << 40)), "reserved bytes"),
    (_with_header(2, _hdr(2) & ~0xFF), "coefficient format: gain_int_bits = 0"),
    (_with_header(2, (_hdr(2) & ~0xFF) | 4), "flash packing needs coefficients of at most 16"),
    (_with_header(3, 7), "malformed header: 7 payload words for 3 x 4 pixels, which need 6"),
], ids=["partial_word", "short_header", "short_payload", "trailing", "empty", "magic",
        "version", "dims", "packing", "reserved", "format", "too_wide", "word_count"])
def test_malformed_images_one_line_errors(data, match):
    with pytest.raises(TdicamError, match=match) as exc:
        calib.read_image(data, name="x.cal")
    assert "\n" not in str(exc.value) and str(exc.value).startswith("x.cal: ")


def test_uncorrectable_header_word_is_an_error():
    img = calib.flip_image_bits(_img(), np.where(np.arange(10)[:, None] == 2, [[5, 9]], -1))
    with pytest.raises(TdicamError, match="header word 2 has an uncorrectable error"):
        calib.read_image(img)


def test_codes_from_values():
    g, o = calib.codes_from_values(np.array([1.0, 0.5, 1 / 16384 * 2.5, 3.99993]),
                                   np.array([0.0, -3.5, 2.5, -32768]))
    assert g.tolist() == [16384, 8192, 3, 65535]   # round half up
    assert o.tolist() == [0, -3, 3, -32768]
    with pytest.raises(TdicamError, match="gain map has 1 values outside the format's range "
                                          "0..3.99994"):
        calib.codes_from_values(np.array([1.0, 4.0]), np.zeros(2))
    with pytest.raises(TdicamError, match="offset map has 1 values outside"):
        calib.codes_from_values(np.ones(2), np.array([0, 40000]))
    with pytest.raises(TdicamError, match="gain map has 1 NaN"):
        calib.codes_from_values(np.array([np.nan]), np.zeros(1))


def test_write_and_load(tmp_path):
    g, o = _maps()
    n = calib.write_image(tmp_path / "c.cal", g, o)
    assert n == (4 + 18) * 9
    res = calib.load_image(tmp_path / "c.cal")
    np.testing.assert_array_equal(res.gain, g)
    with pytest.raises(TdicamError, match="calibration image not found"):
        calib.load_image(tmp_path / "missing.cal")


# ---------------------------------------------------------------- reader golden model
def test_reader_model_agrees_with_software_reader():
    rng = np.random.default_rng(8)
    g, o = _maps(7, 9, seed=8)
    img, k = calib.inject_flips(rng, calib.encode_image(g, o), p_single=0.3, p_double=0.3)
    out = calib.reader_stream(img, rows=7, cols=9)
    sw = calib.read_image(img)
    assert len(out) == 63
    np.testing.assert_array_equal(out.gain, sw.gain.ravel())
    np.testing.assert_array_equal(out.offset.astype(np.int64),
                                  sw.offset.ravel() & 0xFFFF)
    np.testing.assert_array_equal(out.defaulted, sw.defaulted.ravel())
    assert out.corrected[-1] == sw.corrected and out.uncorrectable[-1] == sw.uncorrectable
    # counts are cumulative up to each pixel's word
    word = 4 + np.arange(63) // 2
    np.testing.assert_array_equal(out.corrected, np.cumsum(k == 1)[word])
    assert out.first.tolist() == [i == 0 for i in range(63)]
    assert out.last.tolist() == [i % 9 == 8 for i in range(63)]


def test_reader_model_bad_header_defaults_whole_image_and_counts_saturate():
    g, o = _maps(3, 4)
    img = calib.encode_image(g, o)
    wrong = calib.encode_image(*_maps(4, 3))  # other geometry, same word count
    out = calib.reader_stream(np.concatenate([wrong, img]), rows=3, cols=4)
    assert len(out) == 24
    assert out.header_error[:12].all() and out.defaulted[:12].all()
    assert (out.gain[:12] == FMT.gain_one).all() and (out.offset[:12] == 0).all()
    assert not out.header_error[12:].any()
    np.testing.assert_array_equal(out.gain[12:], g.ravel())
    many = calib.flip_image_bits(img, np.full((10, 1), 70))  # every word: one flip
    out = calib.reader_stream(np.concatenate([many] * 30), rows=3, cols=4, count_bits=8)
    assert out.corrected.max() == 255 and out.corrected[-1] == 255


# ---------------------------------------------------------------- gateware (Amaranth sim)
def _check_case(case, **kw):
    blk = blocks.get("calib")
    arrays, params = golden.load(blk, case)
    stim, exp = reader_beats(arrays, params)
    dut = CalibReader(**params)
    out, lat, final = run_stream_component(
        dut, stim, len(exp), status=("corrected_count", "uncorrectable_count", "header_error"),
        timeout=2e-4, latency_from=4, **kw)
    assert [r for r, _, _ in out] == exp.data.astype(int).tolist()
    assert [f for _, f, _ in out] == exp.first.tolist()
    assert [la for _, _, la in out] == exp.last.tolist()
    return arrays, lat, final, dut


def test_amaranth_reader_matches_model_with_stalls():
    arrays, lat, final, dut = _check_case("flips_7x9", seed=2)
    assert final["corrected_count"] == int((arrays["flips"] == 1).sum())
    assert final["uncorrectable_count"] == int((arrays["flips"] == 2).sum())
    assert final["header_error"] == 0
    # the first payload word is the 5th word: its pixel is valid `latency` cycles later
    assert lat == [dut.latency] == [4]


def test_amaranth_reader_bad_headers_and_plain_build():
    _, _, final, _ = _check_case("bad_header_7x9", seed=3, p_valid=0.9, p_ready=0.9)
    assert final["header_error"] == 0  # the last image's header was good
    _, _, final, dut = _check_case("flips_6x10_plain", seed=4)
    assert dut.o_stream.payload.data.shape().length == 2 and dut.elem_bits == 16


def test_amaranth_reader_full_rate():
    """Words offered every cycle, sink always ready: one pixel per clock."""
    g, o = _maps(6, 10, seed=1)
    img = calib.encode_image(g, o)
    from tdicam.cosim.codec import Beats
    stim = Beats(img.astype(np.uint64), np.arange(len(img)) == 0, np.zeros(len(img), bool))
    dut = CalibReader(rows=6, cols=10)
    out, lat, final = run_stream_component(dut, stim, 60, p_valid=1.0, p_ready=1.0,
                                           latency_from=None)
    assert [r[0] for r, _, _ in out] == g.ravel().tolist()
    assert [r[1] for r, _, _ in out] == (o.ravel() & 0xFFFF).tolist()
    # 4 header words + 4-cycle latency + 60 pixels at 1/clock
    assert final["cycles"] <= 4 + 4 + 60 + 1


@pytest.mark.parametrize("rows,cols", [(1, 1), (1, 3), (2, 1), (3, 5)])
def test_amaranth_reader_tiny_images(rows, cols):
    """One payload word, odd pixel counts, single row / column; three images back to back
    with single and double flips."""
    rng = np.random.default_rng(rows * 10 + cols)
    imgs = [calib.inject_flips(rng, calib.encode_image(*_maps(rows, cols, seed=s)),
                               p_single=0.3, p_double=0.3)[0] for s in range(3)]
    words = np.concatenate(imgs)
    out = calib.reader_stream(words, rows=rows, cols=cols)
    arrays = {"words": words, **{f"out_{f}": getattr(out, f) for f in
                                 ("gain", "offset", "corrected", "uncorrectable", "defaulted",
                                  "header_error", "first", "last")}}
    params = blocks.get("calib").resolve({"rows": rows, "cols": cols, "debug": True})
    stim, exp = reader_beats(arrays, params)
    got, _, _ = run_stream_component(CalibReader(**params), stim, len(exp), seed=rows,
                                     latency_from=None, timeout=1e-4)
    assert len(exp) == 3 * rows * cols
    assert [r for r, _, _ in got] == exp.data.astype(int).tolist()
    assert [f for _, f, _ in got] == exp.first.tolist()
    assert [la for _, _, la in got] == exp.last.tolist()


@pytest.mark.parametrize("ppc", [2, 4, 8])
def test_amaranth_reader_at_ppc(ppc):
    """ppc / 2 flash words a beat in, ppc pixels' coefficients a beat out (the pipeline
    top's NUC side input at ppc): three images back to back -- single and double flips,
    then a bad header (every pixel defaulted) -- equal to the golden reader model, with
    idle cycles and backpressure; the counters at the end equal the model's."""
    from tdicam.cosim.codec import Beats
    rows, cols = 3, 2 * ppc
    k = max(1, ppc // 2)
    rng = np.random.default_rng(ppc)
    imgs = [calib.inject_flips(rng, calib.encode_image(*_maps(rows, cols, seed=s)),
                               p_single=0.3, p_double=0.2)[0] for s in range(2)]
    wrong = calib.encode_image(*_maps(rows, cols + 1, seed=9))[:4]   # another size's header
    imgs.append(np.concatenate([wrong, imgs[0][4:]]))
    words = np.concatenate(imgs)
    m = calib.reader_stream(words, rows=rows, cols=cols)
    n = 3 * rows * cols
    assert m.header_error[-1] and m.defaulted[-rows * cols:].all() and m.defaulted[:-rows * cols].any()
    beats = words.reshape(-1, 9 * k).astype(np.uint64)
    stim = Beats(beats, np.zeros(len(beats), bool), np.zeros(len(beats), bool))
    dut = CalibReader(rows=rows, cols=cols, ppc=ppc)
    assert dut.words_per_beat == k and dut.o_stream.payload.data.shape().length == 2 * ppc
    got, _, final = run_stream_component(
        dut, stim, n // ppc, seed=ppc, latency_from=None, timeout=1e-4,
        status=("corrected_count", "uncorrectable_count", "header_error"))
    exp = np.stack([m.gain, m.offset], axis=-1).reshape(-1, 2 * ppc)
    assert [r for r, _, _ in got] == exp.astype(int).tolist()
    beat = np.arange(n // ppc)
    assert [f for _, f, _ in got] == (beat % (rows * cols // ppc) == 0).tolist()
    assert [la for _, _, la in got] == (beat % (cols // ppc) == cols // ppc - 1).tolist()
    assert (final["corrected_count"], final["uncorrectable_count"], final["header_error"]) \
        == (int(m.corrected[-1]), int(m.uncorrectable[-1]), 1)


@pytest.mark.parametrize("ppc", [2, 8])
def test_amaranth_reader_full_rate_at_ppc(ppc):
    """Beats of words offered every cycle, sink always ready: one output beat of ppc
    pixels per clock (the camera's coefficient rate at ppc pixels per clock)."""
    from tdicam.cosim.codec import Beats
    rows, cols = 6, 4 * ppc
    g, o = _maps(rows, cols, seed=ppc)
    k = max(1, ppc // 2)
    beats = calib.encode_image(g, o).reshape(-1, 9 * k).astype(np.uint64)
    stim = Beats(beats, np.zeros(len(beats), bool), np.zeros(len(beats), bool))
    n = rows * cols // ppc
    out, _, final = run_stream_component(CalibReader(rows=rows, cols=cols, ppc=ppc), stim, n,
                                         p_valid=1.0, p_ready=1.0, latency_from=None)
    assert [r for r, _, _ in out] == np.stack([g.ravel(), o.ravel() & 0xFFFF],
                                              axis=-1).reshape(n, -1).tolist()
    # 4 / k header beats + 4-cycle latency + n beats at 1/clock
    assert final["cycles"] <= 4 // k + 4 + n + 1


@pytest.mark.parametrize("kw,match", [
    ({"ppc": 3}, "ppc = 3 is not valid; valid: 1, 2, 4, 8"),
    ({"ppc": 4, "cols": 6}, "cols = 6 is not a multiple of ppc = 4"),
    ({"ppc": 2, "debug": True}, "debug needs ppc = 1"),
])
def test_reader_bad_ppc(kw, match):
    with pytest.raises(TdicamError, match=match):
        CalibReader(**kw)


@pytest.mark.parametrize("kw,match", [
    ({"rows": 0}, "rows = 0 is out of range"),
    ({"gain_int_bits": 3}, "flash packing needs coefficients of at most 16 bits"),
    ({"count_bits": 40}, "count_bits = 40"),
])
def test_reader_bad_params(kw, match):
    with pytest.raises(TdicamError, match=match):
        CalibReader(**kw)
    with pytest.raises(TdicamError, match=match.replace("rows = 0 is", "--rows = 0 is")
                       .replace("count_bits = 40", "--count-bits = 40")):
        blocks.get("calib").resolve(kw)


# ---------------------------------------------------------------- tdicam calib
def _run(*args):
    import subprocess
    import sys
    return subprocess.run([sys.executable, "-m", "tdicam", "calib", *args], capture_output=True,
                          text=True)


def test_cli_write_read_check_inject(tmp_path, capsys):
    from tdicam.cli import main
    rng = np.random.default_rng(0)
    gain = 1 + 0.05 * rng.standard_normal((12, 17))
    offset = 20 * rng.standard_normal((12, 17))
    np.savez(tmp_path / "maps.npz", gain=gain, offset=offset)
    img = tmp_path / "c.cal"
    assert main(["calib", "write", str(tmp_path / "maps.npz"), "-o", str(img)]) == 0
    assert main(["calib", "check", str(img)]) == 0
    assert "0 corrected, 0 uncorrectable" in capsys.readouterr().out
    assert main(["calib", "read", str(img), "-o", str(tmp_path / "d.npz")]) == 0
    with np.load(tmp_path / "d.npz") as z:
        np.testing.assert_allclose(z["gain"], gain, atol=0.5 / 16384)  # round half up
        np.testing.assert_allclose(z["offset"], offset, atol=0.5)
        assert z["gain_code"].dtype == np.int64 and not z["defaulted"].any()
    # single flips only: decoded maps identical, check passes
    one = tmp_path / "one.cal"
    assert main(["calib", "inject", str(img), "-o", str(one), "--single", "0.5",
                 "--header"]) == 0
    capsys.readouterr()
    assert main(["calib", "check", str(one)]) == 0
    assert "payload CRC ok" in capsys.readouterr().out
    np.testing.assert_array_equal(calib.load_image(one).gain, calib.load_image(img).gain)
    # double flips: check fails (exit 1) and names the damage
    two = tmp_path / "two.cal"
    assert main(["calib", "inject", str(img), "-o", str(two), "--double", "0.3"]) == 0
    capsys.readouterr()
    assert main(["calib", "check", str(two)]) == 1
    out = capsys.readouterr().out
    res = calib.load_image(two)
    assert f"{res.uncorrectable} uncorrectable" in out and res.uncorrectable > 0
    assert "CRC MISMATCH" in out


def test_cli_codes_and_npy_inputs(tmp_path):
    from tdicam.cli import main
    g, o = _maps(4, 5, fmt=NucFormat(2, 10, 12, 1))
    np.save(tmp_path / "g.npy", g)
    np.save(tmp_path / "o.npy", o)
    img = tmp_path / "c.cal"
    assert main(["calib", "write", "--gain", str(tmp_path / "g.npy"), "--offset",
                 str(tmp_path / "o.npy"), "--codes", "--gain-frac-bits", "10",
                 "--offset-bits", "12", "--offset-frac-bits", "1", "-o", str(img)]) == 0
    res = calib.load_image(img)
    np.testing.assert_array_equal(res.gain, g)
    np.testing.assert_array_equal(res.offset, o)
    assert res.fmt == NucFormat(2, 10, 12, 1)


@pytest.mark.parametrize("make,args,match", [
    (lambda p: p.write_bytes(_img().tobytes()[:50]), ["check", "{f}"],
     "{f}: 50 bytes is not a whole number of 9-byte flash words"),
    (lambda p: p.write_bytes(_img().tobytes()[:-18]), ["read", "{f}"],
     "{f}: truncated: the header says 6 payload words, the file has 4"),
    (lambda p: p.write_bytes(b"\0" * 90), ["check", "{f}"],
     "{f}: not a tdicam calibration image"),
    (lambda p: None, ["check", "{f}"], "calibration image not found: '{f}'"),
    (lambda p: p.write_bytes(b"junk"), ["write", "{f}", "-o", "{f}.cal"],
     "{f}: not a numpy .npz or .npy file"),
    (lambda p: np.savez(p, gain=np.ones((2, 2))), ["write", "{f}", "-o", "{f}.cal"],
     "no array 'offset'"),
    (lambda p: np.savez(p, gain=np.full((2, 2), 9.0), offset=np.zeros((2, 2))),
     ["write", "{f}", "-o", "{f}.cal"], "gain map has 4 values outside the format's range"),
    (lambda p: np.savez(p, gain=np.ones((2, 2)), offset=np.zeros((2, 2))),
     ["write", "{f}", "-o", "{f}.cal", "--gain-int-bits", "3"],
     "flash packing needs coefficients of at most 16 bits"),
    (lambda p: None, ["inject", "{f}", "-o", "x", "--double", "2"],
     "--double = 2.0 is out of range; valid: 0..1"),
])
def test_cli_one_line_errors(tmp_path, make, args, match):
    f = tmp_path / "f.npz"
    make(f)
    proc = _run(*[a.format(f=f) for a in args])
    assert proc.returncode == 2
    err = proc.stderr.strip()
    assert "Traceback" not in proc.stderr and len(err.splitlines()) == 1
    assert match.format(f=f) in err


def test_reader_feeds_nuc():
    """CalibReader -> (zip with the pixel stream) -> Nuc, in the Amaranth simulator: the
    corrected image equals the nuc golden model applied with the coefficients the software
    reader decodes from the same (damaged) image."""
    from amaranth.hdl import Module
    from amaranth.sim import Simulator

    from tdicam.hdl.nuc import Nuc
    from tdicam.model.nuc import nuc

    rows, cols = 4, 6
    rng = np.random.default_rng(12)
    g, o = calib.codes_from_values(1 + 0.2 * rng.standard_normal((rows, cols)),
                                   30 * rng.standard_normal((rows, cols)))
    img, k = calib.inject_flips(rng, calib.encode_image(g, o), p_single=0.3, p_double=0.3)
    assert (k == 2).any()
    x = rng.integers(0, 4096, (rows, cols))
    soft = calib.read_image(img)
    want = nuc(x, soft.gain, soft.offset, pixel_bits=12).ravel().tolist()

    m = Module()
    m.submodules.rd = rd = CalibReader(rows=rows, cols=cols)
    m.submodules.nuc = nu = Nuc(pixel_bits=12)
    px_valid = Signal()
    px_data = Signal(12)
    px_first, px_last = Signal(), Signal()
    px_ready = Signal()
    both = px_valid & rd.o_stream.valid
    m.d.comb += [
        nu.i_stream.valid.eq(both),
        nu.i_stream.payload.data[0].eq(px_data),
        nu.i_stream.payload.data[1].eq(rd.o_stream.payload.data[0]),
        nu.i_stream.payload.data[2].eq(rd.o_stream.payload.data[1]),
        nu.i_stream.payload.first.eq(px_first),
        nu.i_stream.payload.last.eq(px_last),
        rd.o_stream.ready.eq(both & nu.i_stream.ready),
        px_ready.eq(both & nu.i_stream.ready),
    ]
    got, markers = [], []

    async def flash(ctx):
        for w in img:
            for e in range(9):
                ctx.set(rd.i_stream.payload.data[e], int(w[e]))
            ctx.set(rd.i_stream.valid, 1)
            await ctx.tick().until(rd.i_stream.ready)
            ctx.set(rd.i_stream.valid, 0)
            if rng.random() < 0.3:
                await ctx.tick()

    async def pixels(ctx):
        for n, v in enumerate(x.ravel()):
            ctx.set(px_data, int(v))
            ctx.set(px_first, n == 0)
            ctx.set(px_last, n % cols == cols - 1)
            ctx.set(px_valid, 1)
            await ctx.tick().until(px_ready)
            ctx.set(px_valid, 0)

    async def sink(ctx):
        ctx.set(nu.o_stream.ready, 1)
        async for _, _, valid, data, first, last in ctx.tick().sample(
                nu.o_stream.valid, nu.o_stream.payload.data, nu.o_stream.payload.first,
                nu.o_stream.payload.last):
            if valid:
                got.append(int(data))
                markers.append((bool(first), bool(last)))
            if len(got) == rows * cols:
                break

    sim = Simulator(m)
    sim.add_clock(1e-8)
    for tb in (flash, pixels, sink):
        sim.add_testbench(tb)
    sim.run_until(2e-5)
    assert got == want
    assert markers == [(n == 0, n % cols == cols - 1) for n in range(rows * cols)]
