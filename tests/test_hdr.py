"""Golden model and Amaranth simulation of the ``hdr`` block."""

import math
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
from amaranth.hdl import Fragment
from amaranth.sim import Simulator

from tdicam import blocks
from tdicam.beats import frames_to_beats
from tdicam.cosim import golden
from tdicam.blocks.hdr import ramp_frame, scene_frames
from tdicam.cosim import compare
from tdicam.cosim.pysim import run_pysim
from tdicam.errors import TdicamError
from tdicam.hdl.hdr import Hdr
from tdicam.model.hdr import hdr, hdr_config
from tdicam.cosim.streamsim import probe_latency

MULTI = dict(gain_pairs="4.9:0.8,4.9:1.6,2.45:0.8")


def _rhu(fr):
    return math.floor(fr + Fraction(1, 2))


def _reference(hg, lg, sels, p):
    """Pixel-by-pixel re-statement of the documented behaviour with exact rationals."""
    cfg = hdr_config(**p)
    t, b, f, sf = cfg.threshold, cfg.band, cfg.lgt_frac_bits, cfg.slope_frac_bits
    slopes = [_rhu(Fraction(h) / Fraction(lo) * 2 ** sf) for h, lo in cfg.gain_pairs]
    slopes += [slopes[-1]] * (2 ** cfg.sel_bits - len(slopes))
    top = 2 ** cfg.out_bits - 1
    cur, lt, ht = 0, _rhu(Fraction(t * 2 ** (f + sf), slopes[0])), t * 2 ** f
    band = []
    out = np.zeros(hg.shape, np.int64)
    for k in range(hg.shape[0]):
        if band:
            lt = _rhu(Fraction(sum(lo for _, lo in band) * 2 ** f, len(band)))
            ht = _rhu(Fraction(sum(h for h, _ in band) * 2 ** f, len(band))) \
                if cfg.anchor == "band" else t * 2 ** f
        if sels[k] != cur:
            lt, ht = _rhu(Fraction(t * 2 ** (f + sf), slopes[sels[k]])), t * 2 ** f
        cur = sels[k]
        s = slopes[cur]
        band = []
        for idx, (h, lo) in enumerate(zip(hg[k].ravel().tolist(), lg[k].ravel().tolist())):
            if h < t:
                v = h
                if h >= t - b and len(band) < 2 ** cfg.count_bits - 1:
                    band.append((h, lo))
            else:
                v = _rhu(Fraction(ht, 2 ** f) + (lo - Fraction(lt, 2 ** f)) * Fraction(s, 2 ** sf))
                v = min(max(v, 0), top)
            out[k].flat[idx] = v
    return out


@pytest.mark.parametrize("p,sels", [
    ({}, [0, 0, 0]),
    (dict(anchor="threshold", band=8), [0, 0, 0]),
    (dict(MULTI, count_bits=4), [0, 2, 2, 1, 3, 3, 0]),
    (dict(pixel_bits=10, slope_frac_bits=0, lgt_frac_bits=0, out_bits=10), [0, 0]),
    (dict(pixel_bits=16, threshold=60000, band=3000, slope_frac_bits=12, lgt_frac_bits=8,
          gain_pairs="9.8:0.2"), [0, 0]),
])
def test_model_matches_exact_reference(p, sels):
    cfg = hdr_config(**p)
    rng = np.random.default_rng(4)
    hg, lg = scene_frames(cfg, rng, len(sels), 9, 30, sels)
    got = hdr(hg, lg, gain_sel=sels, **p)
    np.testing.assert_array_equal(got.astype(np.int64), _reference(hg, lg, sels, p))


def _ramp_steps(p, sel=0, frames=2):
    cfg = hdr_config(**p)
    hg, lg = ramp_frame(cfg, sel)
    out, st = hdr(np.stack([hg] * frames), np.stack([lg] * frames), gain_sel=[sel] * frames,
                  return_state=True, **p)
    out = out.astype(np.int64).reshape(frames, -1)
    j = int(np.argmax(hg.ravel() >= cfg.threshold))  # first LG code on the LG branch
    return cfg, np.diff(out, axis=1), j, st


@pytest.mark.parametrize("dt", [-1, 0, 1])
@pytest.mark.parametrize("gains", ["4.9:0.8", "4.9:1.6", "2.45:0.8", "9.8:0.8", "1.1:1.0"])
def test_ramp_is_monotonic_with_one_slope_step_at_threshold(gains, dt):
    """Every LG code, HG = round(LG * ratio) clamped at full scale; thresholds T-1, T, T+1;
    the reset junction (frame 0) and the measured one (frame 1)."""
    p = dict(gain_pairs=gains, threshold=3072 + dt)
    cfg, steps, j, st = _ramp_steps(p)
    slope = cfg.slopes[0] / (1 << cfg.slope_frac_bits)
    assert (steps >= 0).all()
    assert (steps[:, j - 1] <= math.ceil(slope)).all(), steps[:, j - 1]
    assert steps.max() <= math.ceil(max(slope, cfg.slopes[0] / 256))  # nowhere bigger
    assert st["band_count"][0] > 0 and st["L_T"][1] != st["L_T"][0]  # measured, then used


@pytest.mark.parametrize("band", [1, 4, 8])
def test_ramp_threshold_anchor_narrow_band(band):
    """The paper's literal form T + (LG - LG_T) * s: monotonic; with a band narrower than the
    slope the threshold step stays within one extra slope step."""
    p = dict(anchor="threshold", band=band)
    cfg, steps, j, _ = _ramp_steps(p)
    slope = cfg.slopes[0] / (1 << cfg.slope_frac_bits)
    assert (steps >= 0).all()
    assert (steps[:, j - 1] <= 2 * math.ceil(slope)).all()


def test_threshold_anchor_wide_band_jumps_as_documented():
    _, steps, j, _ = _ramp_steps(dict(anchor="threshold", band=128))
    assert steps[1, j - 1] > 50  # ~band/2: why anchor="band" is the default
    _, steps, j, _ = _ramp_steps(dict(anchor="band", band=128))
    assert steps[1, j - 1] <= 7


def test_reset_values_and_empty_band_keeps_junction():
    cfg = hdr_config()
    assert cfg.slopes == (1568,) and cfg.seeds == (round(3072 * 16 / 6.125),)
    assert cfg.out_bits == 15 and cfg.threshold == 3072 and cfg.band == 128
    rng = np.random.default_rng(2)
    hg, lg = scene_frames(cfg, rng, 4, 12, 20)
    hg[1][(hg[1] >= 2944) & (hg[1] < 3072)] = 3072
    hg[2][(hg[2] >= 2944) & (hg[2] < 3072)] = 2943
    out, st = hdr(hg, lg, return_state=True)
    assert st["L_T"][0] == cfg.seeds[0] and st["H_T"][0] == 3072 * 16
    assert st["band_count"].tolist()[1:3] == [0, 0]
    assert st["L_T"][1] == st["L_T"][2] == st["L_T"][3]  # empty bands: kept, no division
    assert st["H_T"][1] == st["H_T"][2] == st["H_T"][3]
    assert st["L_T"][1] != cfg.seeds[0]
    in_band = (hg[0] >= 2944) & (hg[0] < 3072)
    assert st["L_T"][1] == (int(lg[0][in_band].sum()) * 16 + int(in_band.sum()) // 2) \
        // int(in_band.sum())


def test_gain_change_reseeds_and_uses_new_slope():
    p = dict(MULTI)
    cfg = hdr_config(**p)
    assert cfg.sel_bits == 2 and cfg.slopes == (1568, 784, 784, 784)
    rng = np.random.default_rng(3)
    sels = [0, 0, 1, 1, 3, 2]
    hg, lg = scene_frames(cfg, rng, 6, 10, 20, sels)
    _, st = hdr(hg, lg, gain_sel=sels, return_state=True, **p)
    assert st["slope"].tolist() == [1568, 1568, 784, 784, 784, 784]
    assert st["L_T"][0] == cfg.seeds[0] and st["L_T"][1] != cfg.seeds[0]
    assert st["L_T"][2] == cfg.seeds[1]  # gain change: the old measurement is dropped
    assert st["L_T"][3] != cfg.seeds[1]
    assert st["L_T"][4] == cfg.seeds[3]  # 3 pads the 3-pair table with the last pair
    # the first frame after reset at a non-zero pair starts from that pair's seed
    _, st = hdr(hg[2:], lg[2:], gain_sel=sels[2:], return_state=True, **p)
    assert st["L_T"][0] == cfg.seeds[1]


def test_count_saturates():
    p = dict(count_bits=4)
    hg = np.full((2, 4, 10), 3000)
    lg = np.arange(80).reshape(2, 4, 10) + 400
    _, st = hdr(hg, lg, return_state=True, **p)
    assert st["band_count"][0] == 15
    assert st["L_T"][1] == ((400 + 414) * 15 // 2 * 16 + 7) // 15  # first 15 in raster order


def test_full_scale_and_clamp():
    full = 4095
    hg = np.array([[[full, full, 0, full, 3071]]])
    lg = np.array([[[full, 0, full, 1000, 0]]])
    out = hdr(hg, lg).astype(np.int64)[0, 0]
    cfg = hdr_config()
    expect_top = (3072 * 16 * 256 + (full * 16 - cfg.seeds[0]) * 1568 + 2048) >> 12
    assert out.tolist() == [expect_top, 0, 0, (3072 * 16 * 256 + (1000 * 16 - cfg.seeds[0])
                                               * 1568 + 2048) >> 12, 3071]
    out = hdr(hg, lg, out_bits=12).astype(np.int64)[0, 0]  # narrow output clamps high
    assert out[0] == 4095
    assert hdr(hg, lg).dtype == np.uint16


@pytest.mark.parametrize("kwargs,match", [
    ({"pixel_bits": 17}, "pixel_bits = 17 is out of range; valid: 8..16"),
    ({"threshold": 0}, "threshold = 0 is out of range; valid: 1..4095"),
    ({"threshold": 100, "band": 101}, "band = 101 is out of range; valid: 1..100"),
    ({"gain_pairs": "4.9-0.8"}, "gain_pairs = '4.9-0.8' is not valid"),
    ({"gain_pairs": "0.8:4.9"}, "gain pair 0.8:4.9 is not valid"),
    ({"gain_pairs": "4.9:0"}, "gain pair 4.9:0 is not valid"),
    ({"gain_pairs": ",".join(["2:1"] * 17)}, "gain_pairs has 17 pairs; valid: 1..16"),
    ({"anchor": "middle"}, "anchor = 'middle' is not valid; valid: band, threshold"),
    ({"count_bits": 3}, "count_bits = 3"),
    ({"out_bits": 11}, "out_bits = 11 is out of range; valid: 12..24"),
    ({"slope_frac_bits": 13}, "slope_frac_bits = 13"),
])
def test_bad_params_one_line(kwargs, match):
    z = np.zeros((1, 2, 2), int)
    with pytest.raises(TdicamError, match=match) as exc:
        hdr(z, z, **kwargs)
    assert "\n" not in str(exc.value)
    with pytest.raises(TdicamError, match=match):
        Hdr(**kwargs)


def test_bad_inputs():
    z = np.zeros((2, 2, 2), int)
    with pytest.raises(TdicamError, match="hg has values outside 0..4095"):
        hdr(z + 4096, z)
    with pytest.raises(TdicamError, match="shape"):
        hdr(z, z[:1])
    with pytest.raises(TdicamError, match="gain_sel has values outside 0..0"):
        hdr(z, z, gain_sel=1)
    with pytest.raises(TdicamError, match="gain_sel has values outside 0..3"):
        hdr(z, z, gain_sel=[0, 4], **MULTI)
    with pytest.raises(TdicamError, match="one integer per frame"):
        hdr(z, z, gain_sel=[0, 0, 0], **MULTI)


def test_cli_bad_param_is_one_line():
    proc = subprocess.run([sys.executable, "-m", "tdicam", "verilog", "hdr", "--gain-pairs",
                           "1:3"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "gain pair 1:3 is not valid" in proc.stderr


def test_component_ports_and_properties():
    dut = Hdr(**MULTI)
    assert "gain_sel" in dut.signature.members and dut.latency == 4
    assert dut.frame_start_cycles == 12 + 4 + 3
    assert dut.config.sel_bits == 2 and dut.out_bits == 15
    Fragment.get(dut, None)
    one = Hdr()
    assert "gain_sel" not in one.signature.members
    Fragment.get(one, None)


def test_frame_start_stall():
    """Amaranth sim: a frame start after a non-empty band holds ready low for exactly
    frame_start_cycles; after an empty band it does not."""
    dut = Hdr(pixel_bits=12)
    pixels = [(3000, 490, 1, 0), (100, 20, 0, 1),   # frame 0: one band pixel
              (3500, 570, 1, 0), (100, 20, 0, 1),   # frame 1: starts after a division
              (100, 20, 1, 1)]                      # frame 2: band of frame 1 was empty
    waits, outs = [], []

    async def bench(ctx):
        ctx.set(dut.o_stream.ready, 1)
        for hg, lg, first, last in pixels:
            ctx.set(dut.i_stream.payload.data[0], hg)
            ctx.set(dut.i_stream.payload.data[1], lg)
            ctx.set(dut.i_stream.payload.first, first)
            ctx.set(dut.i_stream.payload.last, last)
            ctx.set(dut.i_stream.valid, 1)
            n = 0
            while not ctx.get(dut.i_stream.ready):
                await ctx.tick()
                n += 1
            waits.append(n)
            await ctx.tick()
        ctx.set(dut.i_stream.valid, 0)
        for _ in range(5):
            await ctx.tick()

    async def monitor(ctx):
        async for _, _, valid, data in ctx.tick().sample(dut.o_stream.valid,
                                                          dut.o_stream.payload.data):
            if valid:
                outs.append(data)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.add_testbench(monitor, background=True)
    sim.run()
    assert waits == [0, 0, dut.frame_start_cycles, 0, 0]
    hg = np.array([[[3000, 100]], [[3500, 100]], [[100, 0]]])
    lg = np.array([[[490, 20]], [[570, 20]], [[20, 0]]])
    assert outs == hdr(hg, lg).ravel().tolist()[:5]


def test_latency_is_four_cycles():
    dut = Hdr()
    seen = probe_latency(dut, [1234], cycles=5)
    assert [v for v, _ in seen] == [0, 0, 0, 1, 0] and seen[3][1] == 1234
    assert dut.latency == 4


@pytest.mark.parametrize("case", ["gain_change_multi", "reset_mid_frame_multi",
                                  "empty_band_12b"])
def test_amaranth_pysim_of_verilog_top_matches_golden(case):
    blk = blocks.get("hdr")
    arrays, params = golden.load(blk, case)
    stim, exp = blk.streams.to_beats(arrays, params)
    got, _, _, timeout = run_pysim("hdr", params, stim, idle=0.3, backpressure=0.3, seed=2)
    cmp = compare(got, exp)
    assert cmp.ok and not timeout, cmp.message


def _load(case):
    """A golden case's arrays and the golden model's parameters (the block's without
    ``ppc``, which the model does not know)."""
    arrays, params = golden.load("hdr", case)
    params.pop("ppc")
    return arrays, params


def test_golden_cases_exercise_what_they_claim():
    arrays, params = _load("empty_band_12b")
    cfg = hdr_config(**params)
    _, st = hdr(arrays["hg"], arrays["lg"], return_state=True, **params)
    assert st["band_count"].tolist()[1:3] == [0, 0] and st["band_count"][0] > 0
    arrays, params = _load("gain_change_multi")
    assert len(set(arrays["gain_sel"].tolist())) == 4
    _, st = hdr(arrays["hg"], arrays["lg"], gain_sel=arrays["gain_sel"], return_state=True,
                **params)
    assert (st["band_count"] == 15).any()  # counter saturation reached
    arrays, params = golden.load("hdr", "scene_coarse_16b")
    assert int(arrays["out"].max()) == 65535  # output clamp reached
    arrays, params = golden.load("hdr", "reset_mid_frame_12b")
    assert 0 < int(arrays["reset_before"][0]) < arrays["hg"][0].size
    assert cfg.threshold == 3072


def test_compare_reports_a_missing_segment_instead_of_crashing():
    """An output with no beat in the last segment (e.g. a reset the testbench missed) is a
    count mismatch, not an exception (the reset_mid_frame cases rely on this)."""
    from tdicam.cosim.codec import Beats
    exp = Beats(np.zeros((4, 1)), [1, 0, 1, 0], [0, 1, 0, 1], np.array([0, 0, 1, 1]))
    got = exp.select(exp.seg == 0)
    cmp = compare(got, exp)
    assert not cmp.ok and cmp.message == "segment 1: 0 beats out, expected 2"


@pytest.mark.parametrize("case", ["ramp_12b", "ramp_multi", "ramp_12b_p8", "ramp_multi_p8"])
def test_golden_ramp_cases_are_monotonic(case):
    """The ramp golden cases (co-simulated on both simulators) hold the monotonic sweep."""
    arrays, params = _load(case)
    cfg = hdr_config(**params)
    n = 1 << cfg.pixel_bits
    for k in range(2):  # frame 2 starts with the threshold-edge pixels
        out = arrays["out"][k].ravel()[:n].astype(np.int64)
        steps = np.diff(out)
        assert (steps >= 0).all() and steps.max() <= 7
    assert set(arrays["hg"][2].ravel()[:65].tolist()) >= {cfg.threshold + d for d in (-1, 0, 1)}


# ---- pixels per clock

@pytest.mark.parametrize("ppc", [1, 2, 4, 8])
def test_ppc_latency_is_four_cycles(ppc):
    dut = Hdr(ppc=ppc)
    assert dut.ppc == ppc and dut.latency == 4
    # ppc > 1: three more (the band sums four stages behind the beat, for timing)
    assert dut.frame_start_cycles == 12 + 4 + 3 + (4 if ppc > 1 else 0)
    seen = probe_latency(dut, [v for k in range(ppc) for v in (1234 + k, 200)], cycles=5)
    assert [v for v, _ in seen] == [0, 0, 0, 1, 0] and seen[3][1] == 1234


@pytest.mark.parametrize("ppc", [2, 8])
def test_frame_start_stall_ppc(ppc):
    """At ppc pixels per beat the frame-start division stalls exactly
    frame_start_cycles (four more than at ppc 1) after a frame with band pixels (lanes 1 and ppc - 1), none after
    an empty band; the merged lanes equal the golden model."""
    dut = Hdr(pixel_bits=12, ppc=ppc)
    t = dut.threshold
    rng = np.random.default_rng(ppc)
    hg = rng.integers(0, t - dut.band, (3, 1, 2 * ppc))       # below the band
    lg = rng.integers(0, 500, (3, 1, 2 * ppc))
    hg[0, 0, 1], hg[0, 0, ppc - 1] = t - 1, t - 2             # frame 0: band pixels
    hg[1, 0, 0], lg[1, 0, 0] = 3500, 570                      # frame 1: merged at the junction
    hg[1, 0, ppc:] = t + 100                                   # and above T
    beats = frames_to_beats(np.stack([hg, lg], -1), ppc=ppc, channels=2)
    waits, outs = [], []

    async def bench(ctx):
        ctx.set(dut.o_stream.ready, 1)
        for k in range(len(beats)):
            for e, v in enumerate(beats.data[k]):
                ctx.set(dut.i_stream.payload.data[e], int(v))
            ctx.set(dut.i_stream.payload.first, bool(beats.first[k]))
            ctx.set(dut.i_stream.payload.last, bool(beats.last[k]))
            ctx.set(dut.i_stream.valid, 1)
            n = 0
            while not ctx.get(dut.i_stream.ready):
                await ctx.tick()
                n += 1
            waits.append(n)
            await ctx.tick()
        ctx.set(dut.i_stream.valid, 0)
        for _ in range(6):
            await ctx.tick()

    async def monitor(ctx):
        async for _, _, valid, data in ctx.tick().sample(dut.o_stream.valid,
                                                          dut.o_stream.payload.data):
            if valid:
                outs.append([int(data[k]) for k in range(ppc)])

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.add_testbench(monitor, background=True)
    sim.run()
    assert waits == [0, 0, dut.frame_start_cycles, 0, 0, 0]
    assert outs == hdr(hg, lg).reshape(-1, ppc).tolist()


@pytest.mark.parametrize("case", ["ramp_multi_p8", "gain_change_multi_p8",
                                  "reset_mid_frame_multi_p4", "empty_band_12b_p8"])
def test_amaranth_pysim_of_verilog_top_matches_golden_ppc(case):
    """ppc lanes against the golden model; ``ramp_multi_p8`` saturates the 4-bit band count
    inside a beat (checked below), so only the first band pixels of that beat count."""
    blk = blocks.get("hdr")
    arrays, params = golden.load(blk, case)
    stim, exp = blk.streams.to_beats(arrays, params)
    got, _, _, timeout = run_pysim("hdr", params, stim, idle=0.3, backpressure=0.3, seed=2)
    cmp = compare(got, exp)
    assert cmp.ok and not timeout, cmp.message


def test_ramp_multi_p8_saturates_the_count_inside_a_beat():
    arrays, params = _load("ramp_multi_p8")
    cfg = hdr_config(**params)
    h = arrays["hg"][2].ravel()
    band = np.flatnonzero((h >= cfg.threshold - cfg.band) & (h < cfg.threshold))
    last = band[cfg.count_max - 1]              # the last band pixel counted
    assert last % 8 != 7 and last + 1 in band   # a band pixel after it in the same beat


def test_ppc_errors_are_one_line():
    blk = blocks.get("hdr")
    with pytest.raises(TdicamError, match=r"^ppc = 16 is not valid; valid: 1, 2, 4, 8$"):
        Hdr(ppc=16)
    p = blk.resolve({"ppc": 8})
    z = np.zeros((1, 2, 12), np.uint16)
    with pytest.raises(TdicamError, match=r"^--width 12 is not a multiple of --ppc 8$"):
        blk.streams.to_beats({"hg": z, "lg": z, "gain_sel": np.zeros(1, np.int64), "out": z}, p)


def test_ecp5_top_multipliers_are_signed_dsp_blocks_with_their_input_registers():
    """``dsp="ecp5"``: one signed MULT18X18D a lane with REG_INPUTA/B on CLK0 and no output
    register, the same latency; operands too wide for one block (16-bit pixels with 4
    fraction bits: a 21-bit difference) keep the generic multiply; an unknown ``dsp`` is a
    one-line error naming it and the valid values."""
    from amaranth.back import rtlil
    for ppc in (1, 8):
        top = Hdr(ppc=ppc, dsp="ecp5")
        assert top.dsp == "ecp5" and top.latency == Hdr(ppc=ppc).latency == 4
        text = rtlil.convert(top)
        assert text.count("cell \\MULT18X18D") == ppc
        assert text.count('parameter \\REG_INPUTA_CLK "CLK0"') == ppc
        assert text.count('parameter \\REG_INPUTB_CLK "CLK0"') == ppc
        assert text.count('parameter \\REG_OUTPUT_CLK "NONE"') == ppc
        assert text.count("connect \\SIGNEDA 1'1") == ppc
    assert "MULT18X18D" not in rtlil.convert(Hdr(pixel_bits=16, ppc=2, dsp="ecp5"))
    with pytest.raises(TdicamError, match="dsp.*'xilinx'.*generic, ecp5"):
        Hdr(dsp="xilinx")
