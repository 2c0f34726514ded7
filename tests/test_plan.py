"""Planning physics (model/physics/plan.py, model/physics/metrics.py) and the ``tdicam plan`` command."""

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tdicam.cli import main
from tdicam.errors import TdicamError
from tdicam.planning import sizing
from tdicam.model.physics import metrics, plan

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "orbit_600km_1m_96.toml"
H_600 = 600e3

# Seed 000 Table 2 as printed: (GSD m, T1 ms, stages, F_f frame/s). The paper prints 129.6
# for 5 m / 96 stages; exact arithmetic gives 129.525... -> 129.5 (the paper multiplied the
# rounded 16.2 by 8). Every other row is reproduced as printed.
TABLE2 = [
    (5, "0.724", 12, "16.2"), (5, "0.724", 24, "32.4"), (5, "0.724", 48, "64.8"),
    (5, "0.724", 96, "129.5"),
    (2, "0.290", 12, "40.5"), (2, "0.290", 24, "81.0"), (2, "0.290", 48, "161.9"),
    (2, "0.290", 96, "323.8"),
    (1, "0.145", 12, "81.0"), (1, "0.145", 24, "161.9"), (1, "0.145", 48, "323.8"),
    (1, "0.145", 96, "647.6"),
]


# ------------------------------------------------------------------ orbit and frame rate


def test_ground_speed_600km():
    v = plan.ground_speed(H_600)
    assert f"{v / 1e3:.4f}" == "6.9080"
    assert isinstance(v, np.floating)


@pytest.mark.parametrize("gsd, t1_ms, m, ff", TABLE2)
def test_qu2010_table2(gsd, t1_ms, m, ff):
    t1 = plan.orbit_line_period(H_600, gsd)
    assert f"{t1 * 1e3:.3f}" == t1_ms
    assert f"{plan.required_frame_rate(m, 1024, t1):.1f}" == ff


def test_table2_paper_rounding_note():
    # The one row that differs from print: 129.5 exactly, the paper's 129.6 = 8 x 16.2.
    f = plan.required_frame_rate(96, 1024, plan.orbit_line_period(H_600, 5))
    assert 129.5 < f < 129.55
    assert round(8 * 16.2, 1) == 129.6


def test_spec_line_periods_4_digits():
    got = [f"{plan.orbit_line_period(H_600, g) * 1e3:.4f}" for g in (5, 2, 1)]
    assert got == ["0.7238", "0.2895", "0.1448"]


def test_frame_rate_vectorised():
    m = np.array([12, 24, 48, 96])
    f = plan.required_frame_rate(m, 1024, plan.orbit_line_period(H_600, 1.0))
    assert f.dtype == np.float64 and f.shape == (4,)
    np.testing.assert_allclose(f, [81.0, 161.9, 323.8, 647.6], atol=0.05)


def test_turntable_line_period():
    # Tao et al. 2012 eq 5: T = a / (omega l)
    assert plan.turntable_line_period(5.2e-6, 0.05, 0.5) == pytest.approx(5.2e-6 / 0.025, rel=1e-15)


@settings(max_examples=60, deadline=None)
@given(h=st.floats(0, 40000e3), gsd=st.floats(0.01, 1000),
       rows=st.integers(2, 8192), data=st.data())
def test_frame_rate_grows_with_stages_and_falls_with_gsd(h, gsd, rows, data):
    m = data.draw(st.integers(1, rows - 1))
    t1 = plan.orbit_line_period(h, gsd)
    assert plan.required_frame_rate(m + 1, rows, t1) > plan.required_frame_rate(m, rows, t1)
    t1_coarse = plan.orbit_line_period(h, gsd * 1.5)
    assert plan.required_frame_rate(m, rows, t1_coarse) < plan.required_frame_rate(m, rows, t1)


@settings(max_examples=60, deadline=None)
@given(h=st.floats(0, 40000e3), gsd=st.floats(1e-3, 1e4))
def test_line_period_times_ground_speed_is_gsd(h, gsd):
    v = plan.ground_speed(h)
    assert plan.line_period(gsd, v) * v == pytest.approx(gsd, rel=1e-12)


def test_ground_speed_decreases_with_altitude():
    h = np.linspace(0, 2000e3, 50)
    assert np.all(np.diff(plan.ground_speed(h)) < 0)
    # at zero altitude the ground speed is the circular orbital speed sqrt(mu/R)
    assert plan.ground_speed(0.0) == pytest.approx(
        math.sqrt(plan.EARTH_MU_M3_S2 / plan.EARTH_RADIUS_M))


# ------------------------------------------------------------------ rolling-shutter timing


def test_row_time_and_timing_example():
    t_row = plan.row_time(3.5e-6, 1280, 100e6)
    assert t_row == pytest.approx(16.3e-6)
    tm = plan.rolling_timing(144.76e-6, t_row)
    assert (tm.n_lines, tm.m0) == (8, 8)
    assert tm.back_porch_s == pytest.approx(144.76e-6 - 8 * 16.3e-6)
    assert not tm.capped


def test_timing_exact_multiple_gives_zero_back_porch():
    assert 0.3 / 0.1 < 3 and (13 * 0.1e-6) / 0.1e-6 < 13  # float rounding falls short
    tm = plan.rolling_timing(0.3, 0.1)
    assert tm.n_lines == 3 and tm.back_porch_s == 0.0
    tm = plan.rolling_timing(13 * 0.1e-6, 0.1e-6)
    assert tm.n_lines == 13 and tm.back_porch_s == 0.0


def test_timing_capped_by_rows_and_frame_rate_equivalence():
    tm = plan.rolling_timing(1e-3, 1e-6, rows=100)
    assert tm.capped and tm.n_lines == 100 and tm.back_porch_s == pytest.approx(0.9e-3)
    # a 650 frame/s datasheet rate at r = 1024 admits exactly 96 stages at 1 m / 600 km
    t1 = plan.orbit_line_period(H_600, 1.0)
    tm = plan.rolling_timing(t1, plan.row_time_from_frame_rate(650.0, 1024), rows=1024)
    assert tm.m0 == 96
    assert plan.required_frame_rate(96, 1024, t1) <= 650.0 < plan.required_frame_rate(97, 1024, t1)


def test_timing_too_slow_gives_m0_zero():
    tm = plan.rolling_timing(1e-6, 2e-6)
    assert tm.m0 == 0 and tm.back_porch_s == 1e-6 and tm.available_frame_rate_hz == math.inf


@settings(max_examples=100, deadline=None)
@given(t_line=st.floats(1e-6, 1.0), t_row=st.floats(1e-8, 1e-3))
def test_timing_invariants(t_line, t_row):
    tm = plan.rolling_timing(t_line, t_row)
    assert 0.0 <= tm.back_porch_s < t_row
    assert tm.n_lines * t_row <= t_line * (1 + 1e-9)
    assert tm.m0 == tm.n_lines
    assert tm.back_porch_s + tm.n_lines * t_row == pytest.approx(t_line, rel=1e-9)


# ------------------------------------------------------------------ memory and DDR


def test_partial_sum_bits():
    assert plan.partial_sum_bits(12, 96) == 19
    assert [plan.partial_sum_bits(12, m) for m in (1, 2, 3, 4, 5, 128, 129)] == \
        [12, 13, 14, 14, 15, 19, 20]


def test_line_buffers_qu2010():
    assert plan.tdi_line_buffer_lines(96, "basic") == 4560
    assert plan.tdi_line_buffer_lines(96, "optimized") == 95
    assert plan.tdi_line_buffer_bits(1280, 96, 12, "basic") == 4560 * 1280 * 12
    assert plan.tdi_line_buffer_bits(1280, 96, 12) == 95 * 1280 * 19
    assert plan.tdi_line_buffer_lines(1) == 0
    assert plan.tdi_line_buffer_bits(1280, 1, 12, "basic") == 0


@settings(max_examples=100, deadline=None)
@given(m=st.integers(1, 4096), w=st.integers(1, 16384), bits=st.integers(1, 32))
def test_optimized_memory_never_exceeds_basic(m, w, bits):
    basic = plan.tdi_line_buffer_lines(m, "basic")
    opt = plan.tdi_line_buffer_lines(m, "optimized")
    assert opt <= basic
    assert basic - opt == (m - 1) * (m - 2) // 2 == plan.line_buffer_saving_lines(m)
    # in bits the optimized structure stores wider words: smaller unless m = 2 or the
    # pixels are very narrow; exactly when ceil(log2 m) <= bits (m/2 - 1)
    opt_bits = plan.tdi_line_buffer_bits(w, m, bits)
    basic_bits = plan.tdi_line_buffer_bits(w, m, bits, "basic")
    assert (opt_bits <= basic_bits) == ((m - 1).bit_length() <= bits * (m / 2 - 1) or m == 1)
    if m >= 3 and bits >= 4:
        assert opt_bits <= basic_bits


def test_ddr_bandwidth():
    assert plan.ddr_bandwidth_available() == pytest.approx(256 * 100e6 * 0.8)
    t1 = plan.orbit_line_period(H_600, 1.0)
    # 19-bit sums: 13 per 256-bit word, ceil(1280/13) = 99 words per line, 2 x 95 lines
    expected = 2 * 95 * 99 * 256 / t1
    assert plan.ddr_bandwidth_needed(1280, 96, 12, t1) == pytest.approx(expected, rel=1e-15)
    assert plan.ddr_bandwidth_needed(1280, 1, 12, t1) == 0.0
    mem = plan.tdi_memory(1280, 96, 12, t1, onchip_budget_bits=2_000_000)
    assert mem.fits_onchip is False and mem.ddr_ok is False
    assert mem.saving_lines == 4465 and mem.sum_bits == 19
    mem = plan.tdi_memory(1280, 8, 12, t1, onchip_budget_bits=200_000)
    assert mem.fits_onchip is True and mem.ddr_ok is True
    with pytest.raises(TdicamError, match="word_bits"):
        plan.ddr_bandwidth_needed(1280, 96, 12, t1, word_bits=16)


# ------------------------------------------------------------------ SNR


def test_snr_gain_one_stage_is_exactly_one():
    for a, c in [(0.03104, 1.42471), (0.0, 5.0), (3.0, 0.0), (0.1, 1e-9)]:
        assert plan.snr_gain_digital(1, a, c) == 1.0
        assert plan.snr_gain_charge(1, a, c, 2.0) == 1.0


@pytest.mark.parametrize("m", [2, 5, 10, 96, 1000])
def test_snr_gain_limits(m):
    # no quantization noise: temporal noise only, gain sqrt(m)
    assert plan.snr_gain_digital(m, 0.0, 3.0) == pytest.approx(math.sqrt(m), rel=1e-14)
    # quantization only: it grows as m like the signal, no gain
    assert plan.snr_gain_digital(m, 2.0, 0.0) == pytest.approx(1.0, rel=1e-15)
    # quantization dominating: tends to 1 from above
    g = plan.snr_gain_digital(m, 1e6, 1.0)
    assert 1.0 < g < 1.0 + 1e-5
    # in between: strictly between 1 and sqrt(m)
    assert 1.0 < plan.snr_gain_digital(m, 0.5, 1.0) < math.sqrt(m)


def test_snr_gain_tao2012_parameters():
    # Fig. 6(a) parameters of Tao et al. 2012: G(10) from eq 28
    g = plan.snr_gain_digital(10, 0.03104, 1.42471)
    assert g == pytest.approx(10 * (0.03104 + 1.42471) / (10 * 0.03104 + math.sqrt(10) * 1.42471))
    assert 2.9 < g < math.sqrt(10)


def test_charge_vs_digital_read_noise_limited_zhou2008():
    # read-noise-limited: charge domain gains m (4 stages +12.04 dB), digital sqrt(m) (+6.02)
    gc = plan.gain_db(plan.snr_gain_charge(4, 0.0, 0.0, 10.0))
    gd = plan.gain_db(plan.snr_gain_digital(4, 0.0, 10.0))
    assert gc == pytest.approx(20 * math.log10(4))
    assert gd == pytest.approx(20 * math.log10(2))
    assert abs(gc - (33.62 - 22.13)) < 0.6  # Zhou et al. 2008 measured +11.49 dB
    # shot-noise-limited: both domains gain sqrt(m)
    assert plan.snr_gain_charge(16, 0.0, 30.0, 0.0) == pytest.approx(4.0)


def test_snr_db_additive_form():
    single = plan.snr_tdi_db(100.0, 0.5, 5.0)
    assert single == pytest.approx(20 * math.log10(100 / 5.5))
    assert plan.snr_tdi_db(100.0, 0.5, 5.0, 10) == pytest.approx(
        single + plan.gain_db(plan.snr_gain_digital(10, 0.5, 5.0)))


def test_noise_helpers():
    assert plan.quantization_noise(12.0) == pytest.approx(12 / math.sqrt(12))
    assert plan.temporal_noise(100.0, 3.0, 4.0) == pytest.approx(math.sqrt(113.0))


# ------------------------------------------------------------------ MTF


def test_mtf_nyquist_mismatch_values():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for m in (4, 8, 32, 96, 128):
            assert f"{plan.mtf_velocity_mismatch(plan.NYQUIST, m, 1.0 / m):.3f}" == "0.637"
            assert abs(plan.mtf_velocity_mismatch(plan.NYQUIST, m, 2.0 / m)) < 1e-12
            v = plan.mtf_velocity_mismatch(plan.NYQUIST, m, 0.0)
            assert v == 1.0 and not math.isnan(v)
            assert plan.mtf_system(plan.NYQUIST, m, 0.0) == pytest.approx(
                plan.mtf_aperture(plan.NYQUIST) * plan.mtf_temporal(plan.NYQUIST, m))


def test_mtf_128_stages_past_first_zero():
    # Yuan et al. 2013: 128 stages at dV/V = 0.02 is already past the first zero (M dV/V = 2.56)
    assert plan.mtf_velocity_mismatch(plan.NYQUIST, 128, 0.02, signed=True) < 0
    assert plan.mtf_velocity_mismatch(plan.NYQUIST, 128, 0.02) > 0      # an MTF is a modulus
    assert plan.mtf_velocity_mismatch(plan.NYQUIST, 128, -0.02) == plan.mtf_velocity_mismatch(
        plan.NYQUIST, 128, 0.02)


def test_mtf_factors():
    assert plan.mtf_aperture(plan.NYQUIST) == pytest.approx(2 / math.pi)
    assert plan.mtf_aperture(plan.NYQUIST, 0.5) == pytest.approx(np.sinc(0.25))
    assert plan.mtf_temporal(plan.NYQUIST, 1) == pytest.approx(np.sinc(0.25))
    assert plan.mtf_temporal(0.0, 96) == 1.0
    f = np.linspace(0, 0.5, 11)
    sys_ = plan.mtf_system(f, 8, 0.1, 0.8)
    np.testing.assert_allclose(sys_, np.sinc(f * 0.8) * np.sinc(f * 8 / 9) * np.sinc(f * 0.8))


# ------------------------------------------------------------------ image metrics


def test_metrics():
    rng = np.random.default_rng(1)
    flat = 1000.0 + rng.normal(0.0, 10.0, (200, 200))
    assert metrics.snr(flat) == pytest.approx(100.0, rel=0.02)
    assert metrics.snr_db(flat) == pytest.approx(40.0, abs=0.2)
    assert metrics.prnu(flat) == pytest.approx(0.01, rel=0.02)
    assert metrics.snr(np.full((4, 4), 7.0)) == math.inf
    bars = np.tile(np.repeat([100.0, 20.0], 2), (8, 5))  # vertical stripes, period 4
    assert metrics.bar_ctf(bars, axis=0) == pytest.approx(80 / 120)
    assert metrics.bar_mtf(bars) == pytest.approx(math.pi / 4 * 80 / 120)
    assert metrics.ctf(1.0, 0.0) == 1.0 and metrics.mtf_from_ctf(1.0) == pytest.approx(math.pi / 4)


@pytest.mark.parametrize("call, match", [
    (lambda: metrics.snr([]), "region must not be empty"),
    (lambda: metrics.snr(np.zeros(4)), "undefined"),
    (lambda: metrics.prnu([0.0, 0.0]), "flat mean"),
    (lambda: metrics.ctf(0.0, 0.0), "i_max \\+ i_min"),
    (lambda: metrics.bar_ctf(np.ones(4)), "2-D"),
    (lambda: metrics.snr([1.0, np.nan]), "finite"),
])
def test_metrics_bad_input(call, match):
    with pytest.raises(TdicamError, match=match):
        call()


# ------------------------------------------------------------------ bad input (model)


@pytest.mark.parametrize("call, text", [
    (lambda: plan.orbit_line_period(H_600, 0.0),
     "gsd_m = 0 is out of range; valid: 0..inf, excluding 0"),
    (lambda: plan.orbit_line_period(H_600, -2.0),
     "gsd_m = -2 is out of range; valid: 0..inf, excluding 0"),
    (lambda: plan.ground_speed(-1.0), "altitude_m = -1 is out of range; valid: 0\\.\\."),
    (lambda: plan.required_frame_rate(0, 1024, 1e-4), "stages = 0 is out of range; valid: 1..1024"),
    (lambda: plan.required_frame_rate(1025, 1024, 1e-4),
     "stages = 1025 is out of range; valid: 1..1024"),
    (lambda: plan.line_period(1.0, 0.0),
     "ground_speed_m_s = 0 is out of range; valid: 0..inf, excluding 0"),
    (lambda: plan.turntable_line_period(5e-6, 0.0, 1.0),
     "angular_speed_rad_s = 0 is out of range; valid: 0..inf, excluding 0"),
    (lambda: plan.tdi_line_buffer_lines(0), "stages = 0 is out of range; valid: 1..inf"),
    (lambda: plan.tdi_line_buffer_lines(4, "fancy"), "structure = 'fancy' is not valid"),
    (lambda: plan.partial_sum_bits(12, 2.5), "stages must be an integer"),
    (lambda: plan.snr_gain_digital(4, 0.0, 0.0), "sigma_ad \\+ sigma_cmos = 0"),
    (lambda: plan.snr_gain_digital(4, -1.0, 1.0), "sigma_ad = -1 is out of range; valid: 0..inf"),
    (lambda: plan.mtf_aperture(0.5, 1.5), "q_over_p = 1.5 is out of range; valid: 0..1"),
    (lambda: plan.ddr_bandwidth_available(efficiency=1.2),
     "efficiency = 1.2 is out of range; valid: 0..1"),
    (lambda: plan.ground_speed(float("nan")), "altitude_m = nan is out of range"),
    (lambda: plan.required_frame_rate(np.array([4, 0]), 1024, 1e-4), "stages = 0"),
])
def test_model_bad_input(call, text):
    with pytest.raises(TdicamError, match=text) as exc:
        call()
    assert "\n" not in str(exc.value)


# ------------------------------------------------------------------ the command


def run_cli(capsys, *argv):
    try:
        code = main(["plan", *argv])
    except SystemExit as exc:  # argparse's own errors may exit instead of returning
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_default_prints_table2(capsys):
    code, out, err = run_cli(capsys)
    # the reference TDI synthesis reaches 849 M pixel/s at ppc 8: feasible, exit 0
    assert code == 0 and err == ""
    ref8 = sizing.REFERENCE_TDI_FMAX_MHZ[8]
    assert f"ppc 8 at {ref8:g} MHz meets it: yes" in out and "feasible: yes" in out
    assert "v_g = 6.9080 km/s" in out
    for _gsd, t1, m, ff in TABLE2:
        assert ff in out and t1 in out
    table = [ln.split() for ln in out.splitlines() if ln.strip()[:1].isdigit()]
    assert [row[-1] for row in table] == [ff for *_, ff in TABLE2]
    assert "Feasibility at GSD 1 m, 96 stages" in out
    assert "19 bits" in out and "4465 lines" in out


def test_cli_scene(capsys):
    code, out, err = run_cli(capsys, "--scene", str(SCENE), "--fpga-clock-mhz", "120")
    assert code == 0, err
    assert "647.6" in out and "available 650.0 frame/s: ok" in out
    assert "n_lines 96, M0 96" in out
    assert "= 0.259 (M dV/V = 0, rolling skew 0.996 px" in out      # the camera model
    assert "mismatch 1.000 = 0.409" in out                         # the paper's, beside it
    assert "feasible: yes" in out


def test_cli_json(capsys):
    code, out, _ = run_cli(capsys, "--scene", str(SCENE), "--dv-over-v", "0", str(1 / 96),
                           "--onchip-kbit", "4096", "--json", "--fpga-clock-mhz", "200")
    assert code == 0
    rep = json.loads(out)
    d = rep["design"]
    assert d["stages"] == 96 and d["frame_rate"]["ok"] is True
    assert d["window"]["m0"] == 96
    assert d["memory"]["saving_lines"] == 4465 and d["memory"]["fits_onchip"] is True
    assert d["ddr"]["ok"] is False
    mm = d["mtf_nyquist"]
    assert mm[0]["paper"]["mismatch"] == 1.0 and round(mm[1]["paper"]["mismatch"], 3) == 0.637
    assert round(mm[0]["system"], 3) == 0.259 and mm[0]["reversed"] is False
    assert rep["orbit"]["ground_speed_m_s"] == pytest.approx(6908.018, abs=1e-3)


def test_cli_overrides_scene_stages(capsys):
    code, out, _ = run_cli(capsys, "--scene", str(SCENE), "--stages", "8", "48", "--json",
                           "--fpga-clock-mhz", "200")
    rep = json.loads(out)
    assert code == 0 and [p["stages"] for p in rep["points"]] == [8, 48]


def test_cli_row_timing_option_replaces_scene_timing(capsys):
    # the scene gives max_frame_rate_hz; --pixel-clock-mhz replaces it instead of clashing
    code, out, err = run_cli(capsys, "--scene", str(SCENE), "--pixel-clock-mhz", "1280",
                             "--row-blanking-us", "0.3", "--json", "--fpga-clock-mhz", "200")
    assert code == 0, err
    rep = json.loads(out)
    assert rep["sensor"]["row_time_s"] == pytest.approx(1.3e-6)
    assert rep["design"]["window"]["m0"] == 111


def test_cli_turntable(capsys):
    code, out, _ = run_cli(capsys, "--angular-speed-rad-s", "0.05", "--distance-m", "0.5",
                           "--pitch-um", "5.2", "--stages", "4", "--json")
    rep = json.loads(out)
    assert code == 0 and rep["mode"] == "turntable"
    assert rep["design"]["line_period_s"] == pytest.approx(5.2e-6 / 0.025)


def test_cli_plot(tmp_path, capsys):
    code, out, _ = run_cli(capsys, "--gsd-m", "1", "--stages", "96", "--plot", str(tmp_path / "p"),
                           "--fpga-clock-mhz", "150")
    assert code == 0
    for name in ("snr_gain.png", "mtf_mismatch.png", "frame_rate.png"):
        data = (tmp_path / "p" / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000


@pytest.mark.parametrize("argv, text", [
    (["--gsd-m", "0"], "--gsd-m = 0.0 is out of range; valid: 0.001..100000"),
    (["--gsd-m", "-1"], "--gsd-m = -1.0 is out of range; valid: 0.001..100000"),
    (["--altitude-km", "-1"], "--altitude-km = -1.0 is out of range; valid: 0..100000"),
    (["--stages", "0"], "--stages = 0 is out of range; valid: 1..inf"),
    (["--stages", "2000"], "--stages: must be <= 1024"),
    (["--rows", "64", "--stages", "65"], "--stages: must be <= 64"),
    (["--angular-speed-rad-s", "0", "--distance-m", "1"],
     "--angular-speed-rad-s = 0.0 is out of range; valid: 1e-06..1000"),
    (["--angular-speed-rad-s", "1", "--distance-m", "0"],
     "--distance-m = 0.0 is out of range; valid: 0.001..1000"),
    (["--dv-over-v", "1"], "--dv-over-v = 1.0 is out of range; valid: (-1, 1)"),
    (["--gsd-m", "1", "--angular-speed-rad-s", "1"], "not both"),
    (["--ddr-efficiency", "1.5"], "--ddr-efficiency = 1.5 is out of range; valid: (0, 1]"),
    (["--scene", "/nonexistent/scene.toml"], "scene file not found"),
])
def test_cli_bad_input(capsys, argv, text):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2 and out == ""
    assert err.startswith("tdicam: error: ") and err.count("\n") == 1
    assert text in err


def test_cli_unknown_option(capsys):
    code, out, err = run_cli(capsys, "--frame-rate", "600")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "--frame-rate" in err and "Traceback" not in err
