"""Fast fidelity against exact at the extremes (issue 18): low signal, little or no read
noise, fractional pedestals, CDS. Where ``auto`` picks fast its output must agree with exact
within ``[run].tolerance`` (plus sampling noise); everywhere, fast's stated bound (the largest
of its bounds) must cover the error it makes."""

import itertools
import math
import textwrap

import numpy as np
import pytest

from tdicam import engine
from tdicam.engine.context import decide
from tdicam.engine.effects import rounding_defect
from tdicam.scene.loader import load_scene

SIGNALS = (3.0, 6.0, 15.0, 40.0, 200.0)
READ = (0.0, 0.3, 1.0, 3.0)
TOL = 0.01


def flat(tmp_path, signal, read, pedestal, cds, stages=8):
    p = tmp_path / "s.toml"
    p.write_text(textwrap.dedent(f"""
    [orbit]
    altitude_km = 600
    gsd_m = 1.0
    [target]
    kind = "flat"
    signal_e = {signal}
    [sensor]
    columns = 128
    rows = 128
    read_noise_e = {read}
    black_level_dn = {pedestal}
    shutter = "global"
    [tdi]
    stages = {stages}
    [pipeline]
    blocks = {'["cds", "tdi"]' if cds else '["tdi"]'}
    [run]
    lines = 128
    seed = 11
    tolerance = {TOL}
    """))
    return load_scene(p)


def _stats(res):
    o = res.output.astype(np.float64)
    return o.mean(), o.var(), o.size


@pytest.mark.parametrize("signal,read,pedestal,cds",
                         list(itertools.product(SIGNALS, READ, (0.0, 64.5), (False, True))))
def test_fast_bound_holds_against_exact(tmp_path, signal, read, pedestal, cds):
    sc = flat(tmp_path, signal, read, pedestal, cds)
    worst = max(decide(sc, 8, 0.0, "fast", (), ()).bounds.values())
    auto = engine.simulate(sc, fidelity="auto", impact=False)
    assert auto.fidelity == ("fast" if worst <= TOL else "exact")
    fast = auto if auto.fidelity == "fast" else engine.simulate(sc, fidelity="fast",
                                                                 impact=False)
    ex = engine.simulate(sc, fidelity="exact", impact=False)
    (mf, vf, n), (me, ve, _) = _stats(fast), _stats(ex)
    sig = me - ex.pedestal_output
    se = math.sqrt((vf + ve) / n)
    assert abs(mf - me) <= max(worst, TOL) * sig + 4 * se, (worst, (mf - me) / sig)
    if worst <= TOL:
        assert abs(vf / ve - 1) <= 2 * TOL + 4 * math.sqrt(2 / n), (worst, vf / ve)


def test_issue_cases_pick_exact(tmp_path):
    """The cases of issue 18 where auto picked a biased fast: now exact."""
    for signal, read, pedestal, cds, stages in ((15.0, 0.0, 0.0, False, 8),
                                                (6.0, 0.3, 0.0, False, 96),
                                                (3.0, 1.0, 0.0, False, 96),
                                                (100.0, 0.0, 64.5, True, 8)):
        sc = flat(tmp_path, signal, read, pedestal, cds, stages=stages)
        res = engine.simulate(sc, fidelity="auto", impact=False, lines=4)
        assert res.fidelity == "exact", (signal, read, pedestal, cds)


def test_rounding_defect():
    # Gaussian noise alone: Widrow's first term
    assert rounding_defect(0.0, 4.0, 0.5) == pytest.approx(math.exp(-2 * math.pi ** 2 / 4))
    # a Poisson lattice of exactly 1/5 DN spacing is never dithered at harmonic 5
    assert rounding_defect(1e4, 5.0, 0.0) == pytest.approx(1.0)
    # 4.88 e-/DN, 15 e-: the 5th harmonic is barely damped (issue 18)
    assert rounding_defect(15.0, 20000 / 4096, 0.0) > 0.8
    # bright light with read noise: dithered
    assert rounding_defect(5000.0, 1.22, 8.0) < 1e-30
