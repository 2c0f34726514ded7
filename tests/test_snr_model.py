"""Planning SNR model of digital TDI with quantization split into independent and shared
parts (tdicam.model.physics.plan.snr_gain_digital_predicted) and the quantized-Gaussian moments the
fast fidelity uses (tdicam.model.physics.sensor.quantized_moments)."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tdicam.errors import TdicamError
from tdicam.model.physics import plan, sensor

ROOT = Path(__file__).resolve().parents[1]


def _shared_fraction_numeric(s):
    mu = np.linspace(0, 1, 2000, endpoint=False)
    b = sensor.quantized_moments(mu, s)[0] - mu
    return 12 * float(np.mean(b * b))


@pytest.mark.parametrize("s", [0.03, 0.1, 0.2, 0.3, 0.45])
def test_correlated_fraction_is_the_variance_of_the_rounding_bias(s):
    assert float(plan.quantization_correlated_fraction(s)) == pytest.approx(
        _shared_fraction_numeric(s), rel=2e-3, abs=1e-9)


def test_correlated_fraction_limits():
    assert float(plan.quantization_correlated_fraction(0.0)) == pytest.approx(1.0, abs=1e-6)
    assert float(plan.quantization_correlated_fraction(0.5)) < 3.2e-5
    r = plan.quantization_correlated_fraction(np.array([0.0, 0.1, 0.2, 0.5, 1.0]))
    assert np.all(np.diff(r) < 0)
    with pytest.raises(TdicamError, match="sigma_dn = -1 is out of range"):
        plan.quantization_correlated_fraction(-1.0)


@pytest.mark.parametrize("m", [1, 2, 5, 96])
def test_predicted_gain_limits_and_eq28_bound(m):
    assert plan.snr_gain_digital_predicted(m, 0.7, 3.0) == pytest.approx(math.sqrt(m))
    assert plan.snr_gain_digital_predicted(m, 2.0, 0.0, 1.0) == pytest.approx(1.0)
    for a, c in [(0.35, 70.0), (1.41, 33.2), (17.6, 44.0), (5.0, 1.0)]:
        g28 = float(plan.snr_gain_digital(m, a, c))
        g0 = float(plan.snr_gain_digital_predicted(m, a, c))
        assert g28 <= g0 * (1 + 1e-12)
        # the shared part lowers the gain monotonically
        gs = [float(plan.snr_gain_digital_predicted(m, a, c, r)) for r in (0.0, 0.3, 1.0)]
        assert gs[0] >= gs[1] >= gs[2]
        if m > 1:
            assert gs[0] > gs[2]
    assert plan.snr_gain_digital_predicted(1, 3.0, 4.0, 0.5) == 1.0


def test_predicted_gain_bad_input():
    with pytest.raises(TdicamError, match="correlated = 1.5 is out of range; valid: 0..1"):
        plan.snr_gain_digital_predicted(4, 1.0, 1.0, 1.5)
    with pytest.raises(TdicamError, match="sigma_ad \\+ sigma_cmos = 0"):
        plan.snr_gain_digital_predicted(4, 0.0, 0.0)
    with pytest.raises(TdicamError, match="stages"):
        plan.snr_gain_digital_predicted(0, 1.0, 1.0)


@pytest.mark.parametrize("mu,s", [(10.3, 0.2), (10.5, 0.2), (7.25, 0.7), (3.1, 1.0),
                                  (3.1, 2.0), (4.0, 0.0), (4.5, 0.0)])
def test_quantized_moments_match_monte_carlo(mu, s):
    x = np.floor(mu + s * np.random.default_rng(1).standard_normal(400_000) + 0.5)
    mean, var = sensor.quantized_moments(mu, s)
    n = x.size
    assert float(mean) == pytest.approx(x.mean(), abs=5 * x.std() / n ** 0.5 + 1e-9)
    assert float(var) == pytest.approx(x.var(), abs=5 * x.var() * (2 / n) ** 0.5 + 1e-9)


def test_plan_prints_prediction_and_eq28_worst_case():
    out = subprocess.run([sys.executable, "-m", "tdicam", "plan", "--scene",
                          str(ROOT / "scenes" / "flat_snr_sweep_96.toml")],
                         capture_output=True, text=True, check=True, cwd=ROOT).stdout
    assert "predicted digital TDI gain +19.82 dB" in out       # 10 log10(96): flat field
    assert "paper's worst case: digital TDI G(96)" in out and "Tao et al. 2012 eq 28" in out
