"""Co-simulation of the generated ``calib`` reader Verilog against its golden model.

Besides the golden cases: a calibration round trip -- real-valued maps written with the
image format, bits flipped in the image, the image streamed through the reader -- checked
against the original maps (not only against the model): single flips are invisible, double
flips give exactly the default coefficients for the two pixels (four coefficients) of the
word, and the counters (carried on every pixel by the ``debug`` build) are right.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.blocks.calib import reader_beats
from tdicam.cosim.testing import check_beats
from tdicam.model import calib
from tdicam.model.nuc import DEFAULT_FORMAT as FMT


def test_bad_header_case_really_is_bad():
    arrays, _ = golden.load("calib", "bad_header_7x9")
    assert arrays["out_header_error"][:126].all() and not arrays["out_header_error"][126:].any()


@pytest.mark.parametrize("flips", ["single", "double"])
def test_calibration_round_trip(sim, flips):
    """Maps -> image -> flipped bits -> reader Verilog -> the maps back."""
    params = blocks.get("calib").resolve({"rows": 7, "cols": 9, "debug": True})
    rng = np.random.default_rng(21 if flips == "single" else 22)
    n_img = 40
    gains, offsets, images, ks = [], [], [], []
    for _ in range(n_img):
        g_val = 1 + 0.1 * rng.standard_normal((7, 9))
        o_val = 50 * rng.standard_normal((7, 9))
        g, o = calib.codes_from_values(g_val, o_val, FMT)
        img = calib.encode_image(g, o, FMT)
        img, k = calib.inject_flips(rng, img, p_single=0.5 if flips == "single" else 0.2,
                                    p_double=0.0 if flips == "single" else 0.3,
                                    skip_header=flips == "double")
        gains.append(g)
        offsets.append(o)
        images.append(img)
        ks.append(k)
    words = np.concatenate(images)
    k = np.concatenate(ks)
    exp_out = calib.reader_stream(words, rows=7, cols=9, fmt=FMT)
    arrays = {"words": words}
    arrays.update({f"out_{f}": getattr(exp_out, f) for f in
                   ("gain", "offset", "corrected", "uncorrectable", "defaulted",
                    "header_error", "first", "last")})
    stim, exp = reader_beats(arrays, params)
    res = check_beats("calib", params, stim, exp, sim=sim, mode="fast", idle=0.2,
                      backpressure=0.2, seed=3)
    got = res.out.data.astype(np.int64)
    g_want = np.concatenate([g.ravel() for g in gains])
    o_want = np.concatenate([o.ravel() for o in offsets]) & 0xFFFF
    per = calib.HEADER_WORDS + calib.payload_words(7, 9)
    word_of_px = np.concatenate([i * per + calib.HEADER_WORDS + np.arange(63) // 2
                                 for i in range(n_img)])
    bad = k[word_of_px] == 2
    assert len(got) == 63 * n_img
    if flips == "single":
        assert not bad.any() and (k == 1).sum() > 500
    else:
        assert bad.sum() > 200
    np.testing.assert_array_equal(got[~bad, 0], g_want[~bad])        # gain
    np.testing.assert_array_equal(got[~bad, 1], o_want[~bad])        # offset
    assert (got[bad, 0] == FMT.gain_one).all() and (got[bad, 1] == 0).all()
    np.testing.assert_array_equal(got[:, 4] & 1, bad)                # defaulted flag
    assert not (got[:, 4] & 2).any()                                 # no header error
    # counters: words with a corrected / uncorrectable error up to each pixel's word
    np.testing.assert_array_equal(got[:, 2], np.cumsum(k == 1)[word_of_px])
    np.testing.assert_array_equal(got[:, 3], np.cumsum(k == 2)[word_of_px])
    assert got[-1, 2] == (k == 1).sum() and got[-1, 3] == (k == 2).sum()


def test_production_build_full_rate(sim):
    """The non-debug build (6 x 10) streaming images back to back at full rate."""
    params = blocks.get("calib").resolve({"rows": 6, "cols": 10})
    rng = np.random.default_rng(5)
    imgs, gs, os_ = [], [], []
    for _ in range(30):
        g = rng.integers(0, FMT.gain_max + 1, (6, 10))
        o = rng.integers(FMT.offset_min, FMT.offset_max + 1, (6, 10))
        imgs.append(calib.encode_image(g, o, FMT))
        gs.append(g)
        os_.append(o)
    words = np.concatenate(imgs)
    out = calib.reader_stream(words, rows=6, cols=10, fmt=FMT)
    arrays = {"words": words, **{f"out_{f}": getattr(out, f) for f in
                                 ("gain", "offset", "corrected", "uncorrectable", "defaulted",
                                  "header_error", "first", "last")}}
    stim, exp = reader_beats(arrays, params)
    res = check_beats("calib", params, stim, exp, sim=sim, mode="fast", idle=0.0,
                      backpressure=0.0)
    np.testing.assert_array_equal(res.out.data[:, 0].astype(np.int64),
                                  np.concatenate([g.ravel() for g in gs]))
    # 30 x (4 header + 30 payload words) in, 1800 pixels out at 1/clock: the header words
    # are the only bubbles (plus latency and the 2000-cycle drain window)
    assert res.cycles <= 30 * (4 + 60) + 2 + 2000 + 5


def test_calib_rom_ecp5_dp16kd_icarus(tmp_path):
    """The calibration ROM of the ECP5 synthesis top (``CalibRom(bram="ecp5")``: DP16KD
    primitives with their output register, the contents as INITVAL) on Icarus with the
    DP16KD model (:mod:`tdicam.cosim.dp16kd`): every beat once, in order, wrapping, under
    random backpressure; at full rate one beat a clock from its latency (4) on. Two ROMs in
    one build: three banks of 4 beats x 144 bits (x18 primitives, a partly used last bank),
    and 2053 beats x 72 bits (a full 2048-beat bank of x9 primitives, then a 5-beat one;
    two bytes constant in every word: bits no primitive holds)."""
    import shutil
    import subprocess
    from amaranth.back import verilog
    from tdicam.cosim import dp16kd
    from tdicam.hdl.calib_rom import CalibRom
    from tdicam.hw.tools import tool_env

    if shutil.which("iverilog") is None:
        pytest.skip("Icarus Verilog is not installed")
    rng = np.random.default_rng(29)
    words_a = rng.integers(0, 256, (22, 9))
    words_b = rng.integers(0, 256, (2053, 9))
    words_b[:, 2], words_b[:, 7] = 0xA5, 0
    roms = {"a": (words_a, 2, 4), "b": (words_b, 1, 2048)}
    src, cycles = [dp16kd.MODEL], 9000
    # rst rises after time 0: an event that starts Amaranth's combinational processes
    tb = ["`timescale 1ns/1ps", "module tb;", "  reg clk = 0, rst = 0;", "  integer cyc;",
          "  always #5 clk = ~clk;"]
    beats = {}
    for name, (words, per_beat, bank) in roms.items():
        rom = type("Rom", (CalibRom,), {"BANK": bank})(words.tolist(), per_beat=per_beat,
                                                         bram="ecp5")
        assert rom.latency == 4
        bits = 72 * per_beat
        beats[name] = [int.from_bytes(bytes(words[k:k + per_beat].ravel().tolist()), "little")
                       for k in range(0, len(words), per_beat)]
        src.append(verilog.convert(rom, name=f"rom_{name}"))
        tb += [f"  wire v_{name}; reg r_{name} = 0; wire [{bits + 1}:0] d_{name};",
               f"  rom_{name} u_{name} (.clk(clk), .rst(rst), .o_stream__valid(v_{name}),",
               f"    .o_stream__ready(r_{name}), .o_stream__payload(d_{name}));",
               "  always @(posedge clk) begin",
               f"    if (!rst && v_{name} && r_{name})",
               f"      $display(\"{name} %0d %h\", cyc, d_{name}[{bits - 1}:0]);",
               f"    r_{name} <= (cyc < 40) || ($random % 10 < 6 && $random % 10 > -6);",
               "  end"]
    assert "INITVAL_00" in src[1] and "REGMODE_B(\"OUTREG\")" in src[1]
    tb += ["  initial begin", "    cyc = 0; #1 rst = 1; @(posedge clk); #1 rst = 0;",
           f"    repeat ({cycles}) begin @(posedge clk); #1 cyc = cyc + 1; end",
           "    $finish;", "  end", "endmodule"]
    (tmp_path / "dut.v").write_text("\n".join(src))
    (tmp_path / "tb.v").write_text("\n".join(tb) + "\n")
    env = tool_env("icarus")
    subprocess.run(["iverilog", "-g2012", "-o", "sim.vvp", "tb.v", "dut.v"], cwd=tmp_path,
                   check=True, env=env)
    out = subprocess.run(["vvp", "-n", "sim.vvp"], cwd=tmp_path, check=True, env=env,
                         capture_output=True, text=True).stdout
    for name, want in beats.items():
        got = [line.split()[1:] for line in out.splitlines() if line.startswith(name + " ")]
        cyc = [int(c) for c, _ in got]
        data = [int(d, 16) for _, d in got]
        n = len(want)
        assert len(data) > n + 100, (name, len(data))
        assert data == [want[k % n] for k in range(len(data))], name
        # ready from the first cycle: the first beat at its latency (cycles counted from
        # the first edge after reset, 3 for the generic ROM), then one a clock
        assert cyc[:20] == list(range(4, 24)), (name, cyc[:20])
