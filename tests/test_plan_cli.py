"""``tdicam plan`` at the extremes (full well, no light, absurd physics, argparse corners,
closed pipes, exit status), what the gateware must do, and the shared-quantization fraction
against an independent evaluation."""

import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate
from scipy.special import ndtr

from tdicam.planning import sizing
from tdicam.cli import main
from tdicam.model.physics import plan

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "orbit_600km_1m_96.toml"


def run_cli(capsys, *argv):
    try:
        code = main(["plan", *argv])
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


# ------------------------------------------------------------------ gateware (issue 19)


def test_gateware_rate_of_the_orbit_scene(capsys):
    code, out, _ = run_cli(capsys, "--scene", str(SCENE), "--json")
    g = json.loads(out)["design"]["gateware"]
    assert g["pixel_rate"] == pytest.approx(96 * 1280 / 144.7593e-6, rel=1e-5)
    assert round(g["pixel_rate"] / 1e6) == 849
    assert [o["ppc"] for o in g["options"]] == [1, 2, 4, 8]
    assert g["options"][3]["clock_needed_mhz"] == pytest.approx(849 / 8, abs=0.1)
    # reference synthesis: ppc 1 and 4 are short (< 106 MHz x 8 / ppc needed), ppc 8 meets it
    ref = sizing.REFERENCE_TDI_FMAX_MHZ
    assert [o["meets"] for o in g["options"]] == [False, None, False, True]   # no ppc 2 row
    assert g["ok"] is True and g["ppc"] == 8 and g["clock_mhz"] == ref[8]
    assert g["best_pixel_rate"] == pytest.approx(8 * ref[8] * 1e6)
    assert g["margin"] == pytest.approx(8 * ref[8] * 1e6 / g["pixel_rate"] - 1)
    assert code == 0
    code, out, _ = run_cli(capsys, "--scene", str(SCENE))
    assert "TDI input 848.9 M pixel/s" in out
    assert (f"ppc 8 at {ref[8]:g} MHz meets it: yes "
            f"(margin {(8 * ref[8] * 1e6 / g['pixel_rate'] - 1) * 100:+.1f} %)") in out


def test_gateware_with_a_given_clock(capsys):
    code, out, _ = run_cli(capsys, "--scene", str(SCENE), "--fpga-clock-mhz", "120", "--json")
    g = json.loads(out)["design"]["gateware"]
    assert code == 0 and g["ok"] is True
    assert g["ppc"] == 8 and g["clock_mhz"] == 120           # ppc 4 gives 480 M: short
    assert g["margin"] == pytest.approx(960e6 / g["pixel_rate"] - 1)
    code, out, _ = run_cli(capsys, "--scene", str(SCENE), "--fpga-clock-mhz", "120")
    assert "ppc 8 at 120 MHz meets it: yes (margin +13.1 %)" in out


def test_gateware_skips_ppc_the_width_does_not_allow():
    g = sizing.gateware_plan(4, 12, 1e-3)
    assert [o["ppc"] for o in g["options"]] == [1, 2, 4]     # 12 is no multiple of 8


# ------------------------------------------------------------------ SNR at the extremes


def test_signal_clipped_at_full_well(capsys):
    code, out, _ = run_cli(capsys, "--gsd-m", "1", "--stages", "96", "--signal-e", "1e9",
                           "--json")
    snr = json.loads(out)["design"]["snr"]
    assert snr["clipped_at_full_well"] is True and snr["signal_asked_e"] == 1e9
    assert snr["signal_e"] == pytest.approx(20000.0)
    full = math.sqrt(20000.0)                              # shot-noise limit of a full well
    assert snr["single_db"] < 20 * math.log10(full) + 0.01
    assert snr["tdi_db"] < 70
    code, out, _ = run_cli(capsys, "--gsd-m", "1", "--stages", "96", "--signal-e", "1e9")
    assert "exceeds the full well 20000 e-: clipped to 20000 e-" in out


def test_charge_domain_clips_the_charge_sum(capsys):
    code, out, _ = run_cli(capsys, "--gsd-m", "1", "--stages", "4", "--domain", "charge",
                           "--signal-e", "10000", "--json")
    snr = json.loads(out)["design"]["snr"]
    assert snr["clipped_at_full_well"] is True and snr["signal_e"] == pytest.approx(5000.0)


def test_no_signal_no_gain(capsys):
    code, out, err = run_cli(capsys, "--gsd-m", "1", "--stages", "96", "--signal-e", "0")
    assert err == "" and "+39.65" not in out
    assert "no SNR and no TDI gain" in out
    code, out, _ = run_cli(capsys, "--gsd-m", "1", "--stages", "96", "--signal-e", "0",
                           "--json")
    snr = json.loads(out)["design"]["snr"]
    assert snr["gain_charge_db"] is None and snr["gain_digital_db"] is None
    assert snr["single_db"] is None and snr["predicted"] is None


def test_help_states_defaults_bounds_and_exit_status(capsys):
    code, out, _ = run_cli(capsys, "--help")
    text = " ".join(out.split())
    assert code == 0
    assert "RMS read noise in electrons (default 0: an ideal readout" in text
    assert "--gsd-m" in text and "valid 0.001..100000" in text
    assert "valid 0..100000" in text                                  # altitude, km
    assert f"{sizing.EXIT_INFEASIBLE} when its feasibility report says NO" in text


# ------------------------------------------------------------------ exit status


def test_exit_status_follows_the_feasibility(capsys):
    ok = ("--scene", str(SCENE), "--fpga-clock-mhz", "200")
    assert run_cli(capsys, *ok)[0] == 0
    code, out, _ = run_cli(capsys, "--scene", str(SCENE), "--fpga-clock-mhz", "50")
    assert code == sizing.EXIT_INFEASIBLE and "feasible: NO (gateware pixel rate)" in out
    code, out, _ = run_cli(capsys, *ok, "--device", "ecp5-25f", "--ddr-clock-mhz", "10",
                           "--json")
    rep = json.loads(out)
    assert code == 1 and rep["feasible"] is False and rep["infeasible"] == ["DDR bandwidth"]


# ------------------------------------------------------------------ argparse and pipes


def test_negative_exponent_is_a_number(capsys):
    code, out, err = run_cli(capsys, "--gsd-m", "1", "--stages", "8", "--dv-over-v", "-1e-12",
                             "--json")
    assert err == "", err
    assert json.loads(out)["design"]["mtf_nyquist"][0]["dv_over_v"] == -1e-12


def test_closed_pipe_is_not_a_traceback():
    p = subprocess.Popen([sys.executable, "-m", "tdicam", "plan"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, cwd=ROOT)
    p.stdout.close()                    # the reader is gone before the plan is printed
    err = p.stderr.read().decode()
    p.wait(timeout=120)
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    assert p.returncode in (0, sizing.EXIT_INFEASIBLE)


# ------------------------------------------------------------------ absurd physics


@pytest.mark.parametrize("argv, text", [
    (["--gsd-m", "1e-300"], "--gsd-m = 1e-300 is out of range; valid: 0.001..100000"),
    (["--altitude-km", "1e12"], "--altitude-km = 1000000000000.0 is out of range; valid: "
                                "0..100000"),
    (["--angular-speed-rad-s", "1e-12", "--distance-m", "1"],
     "--angular-speed-rad-s = 1e-12 is out of range; valid: 1e-06..1000"),
    (["--gsd-m", "1", "--row-blanking-us", "3"], "--row-blanking-us: needs --pixel-clock-mhz"),
    (["--scene", str(SCENE), "--row-blanking-us", "3"], "--row-blanking-us: needs --pixel-clock-mhz"),
    (["--gsd-m", "1", "--fpga-clock-mhz", "0"], "--fpga-clock-mhz = 0.0 is out of range"),
    (["--gsd-m", "1", "--fpga-clock-mhz", "nan"], "--fpga-clock-mhz = nan is out of range"),
    (["--onchip-kbit", "-1"], "--onchip-kbit = -1.0 is out of range; valid: 0..100000000"),
])
def test_absurd_options_one_line_error(capsys, argv, text):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert text in err, err


def test_absurd_scene_value_named_by_its_key(tmp_path, capsys):
    p = tmp_path / "far.toml"
    p.write_text(textwrap.dedent("""
        [orbit]
        altitude_km = 1e12
        gsd_m = 1.0
    """))
    code, out, err = run_cli(capsys, "--scene", str(p))
    assert code == 2 and "[orbit].altitude_km = 1000000000000.0 is out of range; valid: " \
                          "0..100000" in err


def test_model_bounds_the_altitude():
    from tdicam.errors import TdicamError
    with pytest.raises(TdicamError, match="altitude_m = 1000000000000000 is out of range; valid: "
                                          "0..100000000"):
        plan.ground_speed(1e15)


# ------------------------------------------------------------------ shared quantization


def _rho_independent(s):
    """12 Var_mu[E(round(mu + n) - mu - n)], n ~ N(0, s^2): the rounding bias from the normal
    CDF (no Fourier series), its variance over mu by adaptive quadrature."""
    j = np.arange(-int(10 * s) - 3, int(10 * s) + 4)

    def bias(mu):
        return float(np.sum(j * (ndtr((j + 0.5 - mu) / s) - ndtr((j - 0.5 - mu) / s)))) - mu

    w = 8.0 * s                          # the step of the bias at mu = 1/2 is ~s wide
    pts = [0.5 - w, 0.5, 0.5 + w] if w < 0.4 else [0.5]
    val, _ = integrate.quad(lambda mu: bias(mu) ** 2, 0.0, 1.0, points=pts, limit=400,
                            epsabs=1e-13, epsrel=1e-11)
    return 12.0 * val


@pytest.mark.parametrize("s", list(np.logspace(-9, 1, 21)) + [3.4e-4, 1.5e-7, 1.7e-3])
def test_correlated_fraction_against_quadrature(s):
    assert float(plan.quantization_correlated_fraction(s)) == pytest.approx(
        _rho_independent(s), abs=2e-8)


def test_plan_of_a_scene_states_the_run_memory(capsys):
    """``tdicam plan --scene FILE`` states what ``tdicam run FILE`` would need (the run's
    estimate, tdicam.engine.budget) beside the memory available; ``--json`` the same."""
    import json

    from tdicam import paths
    from tdicam.cli import main
    from tdicam.engine import budget
    from tdicam.scene.loader import load_scene
    scene = str(paths.REPO / "scenes" / "orbit_600km_1m_96.toml")
    main(["plan", "--scene", scene])
    est = budget.gib(budget.estimate(load_scene(scene)).peak_bytes)
    assert f"run memory: 'tdicam run {scene}' peaks at about {est} (estimate)" \
        in capsys.readouterr().out
    main(["plan", "--scene", scene, "--json"])
    mem = json.loads(capsys.readouterr().out)["run_memory"]
    assert mem["estimated_peak"] == est and mem["fits"] in (True, False, None)
