"""bench/scene_regress.py, the before/after bit-identity check of the scene simulator:
timings masked, every other number and every image byte compared."""

import importlib.util
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("scene_regress", ROOT / "bench" / "scene_regress.py")
regress = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(regress)


def _tree(d, psnr=40.0, seconds=1.0, pixel=7, note="took 0.12 s"):
    d.mkdir()
    rep = {"effects": [{"name": "read_noise", "seconds": seconds,
                        "impact": {"psnr_db": psnr}}],
           "speed": {"lines_per_s": 1 / seconds, "stages": 8}, "notes": [note]}
    (d / "report.json").write_text(json.dumps(rep))
    a = np.arange(12, dtype=np.int64).reshape(3, 4)
    a[1, 2] = pixel
    np.save(d / "output.npy", a)
    return d


def test_compare_masks_timings_only(tmp_path):
    a = _tree(tmp_path / "a")
    assert regress.compare(a, _tree(tmp_path / "b", seconds=2.0, note="took 9 s"))[1] == []
    d = regress.compare(a, _tree(tmp_path / "c", psnr=40.000000001))[1]
    assert len(d) == 1 and "psnr_db" in d[0]
    d = regress.compare(a, _tree(tmp_path / "e", pixel=8))[1]
    assert d == ["output.npy: bytes differ"]
