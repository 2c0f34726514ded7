"""NAND calibration store: device model, stored image, golden store model, CLI, and the
gateware in the Amaranth simulator (golden equality and the exact cycle model)."""

import subprocess
import sys

import numpy as np
import pytest
from amaranth.sim import Simulator

from tdicam import blocks
from tdicam.blocks.calib import random_codes
from tdicam.blocks.nand_store import load_beats, store_beats
from tdicam.errors import TdicamError
from tdicam.hdl.nand_store import NandCalibTop
from tdicam.model import calib, ecc, nand_store
from tdicam.model.nuc import DEFAULT_FORMAT as FMT


def _words(rows, cols, seed=0):
    g, o = random_codes(np.random.default_rng(seed), rows, cols, FMT)
    return calib.encode_image(g, o, FMT), g, o


SMALL = nand_store.Geometry(pages_per_block=2, blocks=16)


# ---------------------------------------------------------------- device
def test_default_geometry_is_a_4gb_x8_part():
    g = nand_store.MT29F4G08
    assert (g.page_bytes, g.spare_bytes, g.pages_per_block, g.blocks) == (2048, 64, 64, 4096)
    assert g.bits == 4 << 30 and g.page_size == 2112 and g.words_per_page == 227
    assert g.marker_column == 2048


def test_device_program_erase_status_busy():
    d = nand_store.NandDevice(SMALL, fail_program=[3])
    page = np.full(2112, 0xFF, np.uint8)
    page[:4] = [0x0F, 0xF0, 0x00, 0xAA]
    assert d.program_page(1, 0, page) == nand_store.STATUS_PASS
    again = np.full(2112, 0xFF, np.uint8)
    again[:4] = [0xF0, 0xFF, 0xFF, 0x55]
    assert d.program_page(1, 0, again) == nand_store.STATUS_PASS
    assert d.read_page(1, 0)[:4].tolist() == [0x00, 0xF0, 0x00, 0x00]  # bits only clear
    assert (d.read_page(1, 1) == 0xFF).all() and not d.is_bad(1)
    assert d.program_page(3, 0, page) == nand_store.STATUS_FAIL
    assert (d.read_page(3, 0) == 0xFF).all()             # a failed program leaves it erased
    assert d.mark_bad(3) == nand_store.STATUS_PASS and d.is_bad(3)  # the marker write sticks
    assert d.erase_block(1) == nand_store.STATUS_PASS and (d.read_page(1, 0) == 0xFF).all()
    assert d.busy_s == pytest.approx(4 * 25e-6 + 4 * 200e-6 + 700e-6)
    d.flip_bits(3, 0, [0])
    assert d.read_page(3, 0)[0] == 0xFE
    with pytest.raises(TdicamError, match="block = 16 is out of range"):
        d.read_page(16, 0)


def test_sparse_4gb_part_with_100_bad_blocks_1280x1024():
    """A real-size part: a 1280 x 1024 calibration with 100 random bad blocks, stored and
    read back; only written pages cost memory."""
    rng = np.random.default_rng(3)
    words, g, o = _words(64, 1280, seed=1)  # 1/16 of the sensor: same code paths, 1/16 time
    bad = rng.choice(np.arange(1, 4096), 100, replace=False)
    dev = nand_store.write_store(words, bad_blocks=bad)
    res = nand_store.read_store(dev)
    assert res.scan.bad_count == 100 and (res.image.gain == g).all()
    assert set(res.scan.l2p[:3]).isdisjoint(bad)
    assert len(dev.pages) == res.pages + 100 + 1  # data pages, markers, the block map page


# ---------------------------------------------------------------- stored image
@pytest.mark.parametrize("n_bad", [1, 10, 100])
def test_bad_blocks_skipped_and_map_matches_scan(n_bad):
    geo = nand_store.Geometry(pages_per_block=2, blocks=128)
    words, g, o = _words(30, 40, seed=n_bad)
    rng = np.random.default_rng(n_bad)
    bad = rng.choice(np.arange(1, 5 if n_bad == 1 else 128), n_bad, replace=False)
    dev = nand_store.write_store(words, geo, bad_blocks=bad)
    sr = nand_store.scan(dev)
    assert sr.bad_count == n_bad and sr.bad[bad].all() and not sr.bad[0]
    res = nand_store.read_store(dev)
    np.testing.assert_array_equal(res.image.gain, g)
    np.testing.assert_array_equal(res.image.offset, o)
    assert nand_store._read_map(dev)[0] == sr.l2p[:2].tolist()


def test_grown_bad_block_after_program_failure():
    words, g, _ = _words(30, 40)
    dev = nand_store.write_store(words, SMALL, fail_program=[1, 3])
    assert dev.grown == [1, 3] and dev.bad_blocks() == [1, 3]
    sr = nand_store.scan(dev)
    assert sr.l2p[:2].tolist() == [2, 4]
    assert (nand_store.read_store(dev).image.gain == g).all()


def test_more_bad_blocks_than_spare_capacity_one_line_error():
    words, _, _ = _words(30, 40)
    with pytest.raises(TdicamError, match=r"^nand: too many bad blocks: 14 of 16 \(1 good "
                                          r"after block 0\), the calibration needs 2 blocks"):
        nand_store.write_store(words, SMALL, bad_blocks=range(2, 16))
    with pytest.raises(TdicamError, match="block 0 is guaranteed good"):
        nand_store.write_store(words, SMALL, bad_blocks=[0])
    dev = nand_store.write_store(words, SMALL)
    for b in range(2, 16):
        dev.mark_bad(b)  # went bad after writing
    with pytest.raises(TdicamError, match="too many bad blocks: 14 of 16, the calibration "
                                          "needs 2 good blocks after block 0, the part has 1"):
        nand_store.read_store(dev)
    out, sr, complete = nand_store.store_stream(dev, rows=30, cols=40)
    assert not complete and len(out) == 2 * (SMALL.words_per_block - 4)


def test_stored_map_disagreeing_with_scan_is_an_error():
    words, _, _ = _words(30, 40)
    dev = nand_store.write_store(words, nand_store.Geometry(pages_per_block=2, blocks=32))
    dev.mark_bad(1)  # a data block marked after writing: the map still lists it
    with pytest.raises(TdicamError, match=r"stored block map disagrees with the bad-block scan "
                                          r"at logical block 0 \(map: 1, scan: 2\)"):
        nand_store.read_store(dev)


def test_flips_in_pages_single_corrected_double_default_four_coefficients():
    words, g, o = _words(30, 40, seed=5)
    rng = np.random.default_rng(5)
    k = rng.choice([0, 1, 2], len(words), p=[0.5, 0.3, 0.2])
    k[:4] = 1
    pos = np.full((len(words), 2), -1)
    for w in np.nonzero(k)[0]:
        pos[w, :k[w]] = rng.choice(72, k[w], replace=False)
    dev = nand_store.write_store(calib.flip_image_bits(words, pos), SMALL, bad_blocks=[2])
    out, sr, complete = nand_store.store_stream(dev, rows=30, cols=40)
    assert complete and sr.bad_count == 1
    assert int(out.corrected[-1]) == (k == 1).sum() and int(out.uncorrectable[-1]) == (k == 2).sum()
    bad_px = np.repeat(k[4:] == 2, 2)
    np.testing.assert_array_equal(out.defaulted, bad_px)
    assert (out.gain[bad_px] == FMT.gain_one).all() and (out.offset[bad_px] == 0).all()
    np.testing.assert_array_equal(out.gain[~bad_px], g.ravel()[~bad_px])


def test_page_layout_and_map_block():
    words, _, _ = _words(30, 40)
    dev = nand_store.write_store(words, SMALL)
    p = dev.read_page(1, 0)
    np.testing.assert_array_equal(p[:227 * 9].reshape(227, 9), words[:227])
    assert (p[227 * 9:] == 0xFF).all()                  # pad bytes and spare area erased
    m = dev.read_page(0, 0)[:9 * 4].reshape(4, 9)
    d, c = ecc.unpack_code(m)
    assert (ecc.encode(d) == c).all()
    assert int(d[0]).to_bytes(8, "little") == b"TDINAND\x01"
    assert int(d[2]) == 2 | len(words) << 32 and int(d[3]) == 1 | 2 << 16 | 0xFFFF << 32 \
        | 0xFFFF << 48


def test_image_file_round_trip_and_errors(tmp_path):
    words, g, _ = _words(30, 40)
    dev = nand_store.write_store(words, SMALL, bad_blocks=[3])
    f = tmp_path / "a.nand"
    n = nand_store.save_image(dev, f)
    assert n == 24 + len(dev.pages) * (4 + 2112)
    back = nand_store.load_image(f)
    assert back.pages.keys() == dev.pages.keys() and back.bad_blocks() == [3]
    raw = f.read_bytes()
    for data, match in ((raw[:-1], "truncated"), (raw + b"\0", "wrong size"),
                        (raw[:10], "truncated: 10 bytes"), (b"X" * 30, "not a tdicam NAND")):
        with pytest.raises(TdicamError, match=match):
            nand_store.read_image_bytes(data, name="x")


def test_relayout_and_load_coefficients(tmp_path):
    words, g, o = _words(30, 40)
    dev = nand_store.write_store(words, nand_store.Geometry(pages_per_block=2, blocks=64))
    new, k = nand_store.relayout(dev, bad_blocks=[1, 2], fail_program=[4], flips=(0.2, 0.0),
                                 rng=np.random.default_rng(1))
    assert new.bad_blocks() == [1, 2, 4] and (k == 1).sum() > 50
    nand_store.save_image(new, tmp_path / "n.nand")
    gain, offset, res = nand_store.load_coefficients(tmp_path / "n.nand", rows=30, cols=40)
    np.testing.assert_array_equal(gain, g / FMT.gain_one)
    np.testing.assert_array_equal(offset, o)
    assert res.image.corrected == (k == 1).sum()
    with pytest.raises(TdicamError, match="calibration is 30 x 40 pixels, the sensor is 10 x 40"):
        nand_store.load_coefficients(tmp_path / "n.nand", rows=10, cols=40)


def test_store_roundtrip_for_the_scene_pipeline():
    words, g, o = _words(30, 40, seed=4)
    geometry = nand_store.Geometry(pages_per_block=2, blocks=64)
    gain, offset, res = nand_store.store_roundtrip(g, o, geometry=geometry, bad_blocks=20,
                                                   p_double=0.05, seed=3)
    assert res.scan.bad_count == 20 and res.image.uncorrectable > 0
    d = res.image.defaulted
    assert d.sum() == 2 * res.image.uncorrectable
    np.testing.assert_array_equal(gain[~d], g[~d])
    assert (gain[d] == FMT.gain_one).all() and (offset[d] == 0).all()


def test_timing_figures():
    """The stated load times at 50 MHz (t_R = 25 us), from the cycle model."""
    t = nand_store.timing(1024, 1280)
    assert t.busy_cycles == 1250 and t.pages == 2888 and t.blocks == 46
    assert t.scan_cycles == 3 + 1250 + 4096 * (14 + 1250 + 2)
    assert round(t.scan_s * 1e3, 1) == 103.7 and round(t.load_s, 3) == 0.309
    big = nand_store.timing(5120, 5120)
    assert big.pages == 57741 and round(big.load_s, 2) == 6.18


# ---------------------------------------------------------------- gateware (Amaranth sim)
def _run(params, dev, *, p_ready=1.0, seed=1):
    """Load ``dev`` into the simulation model, start, collect the output; returns
    (rows of elements + first + last, {"start", "scan", "done", "error"} cycles)."""
    dut = NandCalibTop(**params)
    rd = dut.store.reader
    n_el = 6 if rd.debug else 2
    stim, _ = store_beats(load_beats(dev, params["slots"]),
                          {f: np.zeros(0) for f in ("gain", "offset", "corrected",
                                                    "uncorrectable", "defaulted",
                                                    "header_error", "first", "last")}
                          | {"bad_blocks": 0}, params)
    rng = np.random.default_rng(seed)
    out, ev = [], {}

    async def source(ctx):
        for k in range(len(stim)):
            for e in range(4):
                ctx.set(dut.i_stream.payload.data[e], int(stim.data[k, e]))
            ctx.set(dut.i_stream.valid, 1)
            await ctx.tick().until(dut.i_stream.ready)
        ctx.set(dut.i_stream.valid, 0)

    async def sink(ctx):
        async for _, _, v, d, f, la, st, sd, dn, er in ctx.tick().sample(
                dut.o_stream.valid, dut.o_stream.payload.data, dut.o_stream.payload.first,
                dut.o_stream.payload.last, dut.store.start, dut.store.scan_done, dut.done,
                dut.error):
            ev["cycle"] = ev.get("cycle", 0) + 1
            c = ev["cycle"]
            if st and "start" not in ev:
                ev["start"] = c
            if sd and "scan" not in ev:
                ev["scan"] = c
            if v and ctx.get(dut.o_stream.ready):
                out.append([int(d[e]) for e in range(n_el)] + [int(f), int(la)])
            if (dn or er) and "done" not in ev:
                ev["done"], ev["error"] = c, er
            if "done" in ev and c > ev["done"] + 30:
                break
            ctx.set(dut.o_stream.ready, int(rng.random() < p_ready))

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(source)
    sim.add_testbench(sink)
    sim.run()
    return np.array(out, np.int64).reshape(-1, n_el + 2), ev


def _expected(dev, params):
    out, sr, complete = nand_store.store_stream(dev, rows=params["rows"], cols=params["cols"])
    cols = [out.gain, out.offset]
    if params["debug"]:
        cols += [out.corrected, out.uncorrectable,
                 out.defaulted.astype(np.uint64) | out.header_error.astype(np.uint64) << 1,
                 np.full(len(out), sr.bad_count)]
    cols += [out.first, out.last]
    return np.stack([np.asarray(c, np.int64) for c in cols], axis=1), complete


def _params(geo, **kw):
    p = {"rows": 20, "cols": 30, "debug": True, "device": True, "slots": 4,
         "page_bytes": geo.page_bytes, "pages_per_block": geo.pages_per_block,
         "blocks": geo.blocks}
    p.update(kw)
    return blocks.get("nand_store").resolve(p)


@pytest.mark.parametrize("ppb,blocks_,busy,bad,fail", [(1, 8, 3, [2], []),
                                                       (2, 4, 7, [], [1])])
def test_amaranth_matches_golden_and_cycle_model(ppb, blocks_, busy, bad, fail):
    """Golden equality (doubles and singles, bad and grown blocks) and the exact scan and
    load cycle counts of :func:`tdicam.model.nand_store.timing`."""
    geo = nand_store.Geometry(pages_per_block=ppb, blocks=blocks_)
    words, _, _ = _words(20, 30, seed=ppb)
    words, k = calib.inject_flips(np.random.default_rng(ppb), words, p_single=0.2,
                                  p_double=0.1)
    dev = nand_store.write_store(words, geo, bad_blocks=bad, fail_program=fail)
    params = _params(geo, busy_cycles=busy)
    got, ev = _run(params, dev)
    want, complete = _expected(dev, params)
    assert complete and (k == 2).any() and not ev["error"]
    np.testing.assert_array_equal(got, want)
    t = nand_store.timing(20, 30, geo, busy_cycles=busy)
    assert ev["scan"] - ev["start"] == t.scan_cycles
    assert ev["done"] - ev["scan"] == t.load_cycles


def test_amaranth_out_of_blocks_error_and_backpressure():
    geo = nand_store.Geometry(pages_per_block=1, blocks=4)
    words, _, _ = _words(20, 30, seed=9)
    dev = nand_store.write_store(words, geo)
    dev.mark_bad(2)  # went bad after writing: only block 1 is left for 2 logical blocks
    dev.mark_bad(3)
    params = _params(geo, busy_cycles=3)
    got, ev = _run(params, dev, p_ready=0.3)
    want, complete = _expected(dev, params)
    assert not complete and ev["error"] and len(want) == 2 * 227 - 8
    np.testing.assert_array_equal(got, want)


def test_store_params_checked():
    with pytest.raises(TdicamError, match="pages_per_block = 3 must be a power of two"):
        NandCalibTop(rows=4, cols=4, pages_per_block=3, blocks=8)
    with pytest.raises(TdicamError, match="slots"):
        blocks.get("nand_store").resolve({"slots": 0})


# ---------------------------------------------------------------- CLI
def _tdicam(*args):
    return subprocess.run([sys.executable, "-m", "tdicam", *map(str, args)],
                          capture_output=True, text=True)


def test_cli_nand_write_read_inject(tmp_path):
    from tdicam.cli import main as _main

    def main(args):
        return _main([str(a) for a in args])
    rng = np.random.default_rng(2)
    np.savez(tmp_path / "m.npz", gain=1 + 0.01 * rng.standard_normal((30, 40)),
             offset=np.round(rng.standard_normal((30, 40)) * 20))
    img = tmp_path / "a.nand"
    assert main(["calib", "write", tmp_path / "m.npz", "-o", img, "--nand", "--blocks", "64",
                 "--pages-per-block", "2"]) == 0
    assert main(["calib", "check", img]) == 0
    bad = tmp_path / "b.nand"
    assert main(["calib", "inject", img, "-o", bad, "--bad-blocks", "40", "--single", "0",
                 "--double", "0.05", "--fail-program", "1"]) == 0
    assert main(["calib", "check", bad]) == 1   # uncorrectable words
    dev = nand_store.load_image(bad)
    assert len(dev.bad_blocks()) >= 40
    out = tmp_path / "dec"                      # no .npz suffix: written as given
    assert main(["calib", "read", bad, "-o", out]) == 0
    with np.load(out) as z:
        d = z["defaulted"]
    assert d.sum() > 0 and d.sum() % 2 == 0


def test_cli_read_output_is_the_name_given(tmp_path):
    """``calib read IMG -o X`` writes X (it used to print "wrote X" and write X.npz)."""
    words, g, _ = _words(6, 8)
    (tmp_path / "p.cal").write_bytes(words.tobytes())
    p = _tdicam("calib", "read", tmp_path / "p.cal", "-o", tmp_path / "X")
    assert p.returncode == 0 and f"wrote {tmp_path / 'X'}:" in p.stdout
    assert not (tmp_path / "X.npz").exists()
    with np.load(tmp_path / "X") as z:
        np.testing.assert_array_equal(z["gain_code"], g)


def test_cli_nand_reports_times(tmp_path):
    np.savez(tmp_path / "m.npz", gain=np.ones((16, 16)), offset=np.zeros((16, 16)))
    p = _tdicam("calib", "write", tmp_path / "m.npz", "-o", tmp_path / "a.nand", "--nand")
    assert p.returncode == 0, p.stderr
    assert "power-up scan of 4096 blocks 103.7 ms" in p.stdout


@pytest.mark.parametrize("args,match", [
    (["read", "{d}/t.nand"], "{d}/t.nand: truncated"),
    (["read", "{d}/w.nand"], "{d}/w.nand: wrong size"),
    (["write", "{d}/m.npz", "--nand", "-o", "{d}/no/such/x.nand"], "cannot write"),
    (["read", "{d}/a.nand", "-o", "{d}/no/such/x"], "cannot write"),
    (["inject", "{d}/a.nand", "-o", "{d}/x", "--seed", "-1"],
     "--seed = -1 is out of range"),
    (["inject", "{d}/p.cal", "-o", "{d}/x", "--seed", "-1"],
     "--seed = -1 is out of range"),   # issue 18: was a traceback
    (["inject", "{d}/p.cal", "-o", "{d}/x", "--bad-blocks", "2"],
     "need a NAND image"),
    (["write", "{d}/m.npz", "--nand", "-o", "{d}/x", "--blocks", "2", "--pages-per-block",
      "1"], "nand: too many bad blocks: 0 of 2"),
    (["inject", "{d}/a.nand", "-o", "{d}/x", "--bad-blocks", "5000"], "only 63 good blocks"),
])
def test_cli_nand_one_line_errors(tmp_path, args, match):
    np.savez(tmp_path / "m.npz", gain=np.ones((30, 40)), offset=np.zeros((30, 40)))
    words, _, _ = _words(30, 40)
    geometry = nand_store.Geometry(pages_per_block=2, blocks=64)
    nand_store.save_image(nand_store.write_store(words, geometry), tmp_path / "a.nand")
    raw = (tmp_path / "a.nand").read_bytes()
    (tmp_path / "t.nand").write_bytes(raw[:100])
    (tmp_path / "w.nand").write_bytes(raw + raw[24:30])
    (tmp_path / "p.cal").write_bytes(words.tobytes())
    proc = _tdicam("calib", *[a.format(d=tmp_path) for a in args])
    assert proc.returncode == 2, proc.stdout
    err = proc.stderr.strip()
    assert "Traceback" not in proc.stderr and len(err.splitlines()) == 1
    assert match.format(d=tmp_path) in err


@pytest.mark.parametrize("rows, cols, page_bytes, ppb", [(1, 1, 512, 1), (30, 40, 2048, 2),
                                                        (7, 300, 512, 4), (64, 64, 512, 1)])
def test_programmed_pages_counts_what_write_store_programs(rows, cols, page_bytes, ppb):
    g = nand_store.Geometry(page_bytes=page_bytes, pages_per_block=ppb, blocks=256)
    n = calib.HEADER_WORDS + calib.payload_words(rows, cols)
    z = np.zeros((rows, cols), np.int64)
    dev = nand_store.store_device(z + 1, z, geometry=g)
    written = [r for r, p in dev.pages.items() if (p[:g.page_bytes] != 0xFF).any()]
    assert nand_store.programmed_pages(n, g) == len(written)


def test_too_few_model_slots_are_refused_before_the_work():
    from tdicam import blocks
    with pytest.raises(TdicamError, match=r"slots = 1: .* program 2 pages .*give slots >= 2"):
        blocks.get("nand_store").resolve({"rows": 1, "cols": 1, "slots": 1, "page_bytes": 512,
                                          "pages_per_block": 1, "blocks": 2, "device": True})


def test_part_beyond_the_model_builds_for_its_pins_and_refuses_to_elaborate():
    """A part whose image programs more pages than the simulation model holds (the whole
    camera's per-pixel coefficient image) is still built for its pins (the register map
    asks every device for them); elaborating it, i.e. simulating it, is a one-line error."""
    from amaranth.back import rtlil
    from tdicam.hdl.nand_store import MAX_SLOTS, NandPart
    g = nand_store.Geometry(page_bytes=512, pages_per_block=1, blocks=MAX_SLOTS + 2)
    dev = nand_store.NandDevice(g)
    for b in range(MAX_SLOTS + 1):
        dev.program_page(b, 0, np.zeros(g.page_size, np.uint8))
    part = NandPart(dev, page_bytes=512, pages_per_block=1, blocks=g.blocks)
    assert "dq_out" in part.signature.members
    with pytest.raises(TdicamError, match=rf"programs {MAX_SLOTS + 1} pages, .* at most "
                                          rf"{MAX_SLOTS}; simulate a cut of fewer rows"):
        rtlil.convert(part)
