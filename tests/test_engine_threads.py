"""The exact exposure loop runs on threads; its output must not depend on their number."""

from pathlib import Path

import numpy as np
import pytest

from tdicam import engine
from tdicam.errors import TdicamError
from tdicam.scene.loader import load_scene

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("scene,over", [
    ("orbit_600km_1m_96.toml", {"sensor": {"columns": 200}, "tdi": {"stages": 8}}),
    ("ning2019_gmax0504_hdr.toml", {"sensor": {"columns": 160}}),
])
def test_exact_frames_do_not_depend_on_thread_count(monkeypatch, scene, over):
    sc = load_scene(ROOT / "scenes" / scene, overrides={**over, "run": {"lines": 700}})
    outs = []
    for n in ("1", "2", "3"):
        monkeypatch.setenv("TDICAM_THREADS", n)
        assert engine.threads() == int(n)
        r = engine.simulate(sc, fidelity="exact", impact=False)
        outs.append((r.output, r.raw, r.single))
    for o in outs[1:]:
        for a, b in zip(outs[0], o):
            assert np.array_equal(a, b)
    # several row blocks really ran (65536 // 200 = 327 rows per block, 700+ frame rows)
    assert outs[0][0].shape[0] == 700


def test_thread_count_setting_is_checked(monkeypatch):
    monkeypatch.setenv("TDICAM_THREADS", "two")
    with pytest.raises(TdicamError, match="TDICAM_THREADS = 'two': must be an integer"):
        engine.threads()
