"""The memory estimate of ``tdicam run`` (:mod:`tdicam.engine.budget`): in range for the
bundled scenes, monotone in the sizes, a run that cannot fit refused in one line before any
work (with what it needs, what there is and what to change), ``--dry-run`` writing nothing.
How close the estimate is to the measured peak is ``bench/bench_memory.py``'s table."""

from pathlib import Path

import pytest

from tdicam.cli import main
from tdicam.engine import budget
from tdicam.scene.loader import load_scene

ROOT = Path(__file__).resolve().parents[1]
ORBIT = ROOT / "scenes" / "orbit_600km_1m_96.toml"
#: 65,536 lines x 2,048 columns at 128 stages, exact: 34 GiB of frame stacks alone.
HUGE = {"sensor": {"columns": 2048, "max_frame_rate_hz": 2000.0},
        "tdi": {"stages": 128}, "run": {"lines": 65536, "fidelity": "exact"}}
GIB = 1 << 30


def _est(over=None, **kw):
    return budget.estimate(load_scene(ORBIT, overrides=over or {}), **kw).peak_bytes


@pytest.mark.parametrize("scene", sorted(p.name for p in (ROOT / "scenes").glob("*.toml")))
def test_bundled_scene_estimates_in_range(scene):
    """The bundled scenes measure 110..160 MiB peak (bench/bench_memory.py); the orbit
    chain (1280 columns x 96 stages, its NUC needing the exact path: every exposure of
    127 frames kept) about 700 MiB; the whole camera of Ning et al. 2019 (a 5144 x 3800
    frame pair of two gains) about 7 GiB."""
    est = budget.estimate(load_scene(ROOT / "scenes" / scene))
    limit = {"orbit_chain.toml": 800 << 20,
             "ning2019_gmax0504_full.toml": 10 << 30,   # the whole 5144 x 3800 frame pair
             }.get(scene, 400 << 20)
    assert budget.BASE_BYTES <= est.peak_bytes < limit
    assert set(est.fidelity.values()) <= {"fast", "exact"} and est.fidelity


def test_huge_scene_estimate_holds_its_frame_stacks():
    stacks = (65536 + 127) * 128 * 2048 * 2            # uint16 frames of one channel
    est = _est(HUGE)
    assert stacks < est < 1.5 * stacks


def test_estimate_grows_with_every_size():
    for fid in ("fast", "exact"):
        by_lines = [_est(lines=n, fidelity=fid) for n in (1, 64, 256, 1024, 4096)]
        assert by_lines == sorted(by_lines) and by_lines[-1] > by_lines[0], (fid, by_lines)
        by_cols = [_est({"sensor": {"columns": c}}, fidelity=fid, lines=512)
                   for c in (64, 256, 1280)]
        assert by_cols == sorted(by_cols) and by_cols[-1] > by_cols[0], (fid, by_cols)
    by_m = [_est({"tdi": {"stages": m}}, fidelity="exact") for m in (1, 8, 32, 96)]
    assert by_m == sorted(by_m) and by_m[-1] > by_m[0]
    assert _est(fidelity="exact", lines=4096) > _est(fidelity="fast", lines=4096)


def test_run_that_cannot_fit_is_refused_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(budget, "available_bytes", lambda: 8 * GIB)
    scene = tmp_path / "huge.toml"
    scene.write_text(ORBIT.read_text().replace("columns = 1280", "columns = 2048")
                     .replace("max_frame_rate_hz = 650.0", "max_frame_rate_hz = 2000.0")
                     .replace("stages = 96", "stages = 128").replace("lines = 256", "lines = 65536")
                     .replace('fidelity = "auto"', 'fidelity = "exact"'))
    out = tmp_path / "o"
    assert main(["run", str(scene), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert err.startswith("tdicam: error: [run].lines = 65536 x [sensor].columns = 2048 at "
                          "128 stages, fidelity exact: the run needs about ")
    assert "8.0 GiB is available" in err and "[run].fidelity = 'fast' (needs about" in err
    assert not out.exists()
    fit = int(err.split("[run].lines <= ")[1].split(",")[0])
    sc = load_scene(scene)
    assert budget.estimate(sc, lines=fit).peak_bytes <= 8 * GIB
    assert budget.estimate(sc, lines=fit + 1).peak_bytes > 8 * GIB
    assert main(["run", str(scene), "--lines", "60000", "-o", str(out)]) == 2
    assert "--lines = 60000 x [sensor].columns" in capsys.readouterr().err
    assert main(["run", str(scene), "--dry-run"]) == 2 and not out.exists()


def test_dry_run_prints_configuration_and_estimate_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["run", str(ORBIT), "--dry-run", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "dry run, nothing written" in text and "96 (digital TDI)" in text
    assert "memory: estimated peak" in text and "available" in text
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_report_states_the_estimate(tmp_path):
    out = tmp_path / "o"
    assert main(["run", str(ORBIT), "--lines", "16", "--no-impact", "-o", str(out)]) == 0
    import json
    rep = json.loads((out / "report.json").read_text())
    mem = rep["configuration"]["memory"]
    assert mem["estimated_peak_bytes"] > budget.BASE_BYTES
    assert mem["available_bytes"] is None or mem["available_bytes"] > 0
    assert "* memory: estimated peak **" in (out / "report.md").read_text()


def test_available_memory_is_at_most_the_machine_memory():
    total = None
    with open("/proc/meminfo") as fh:
        for line in fh:
            if line.startswith("MemTotal:"):
                total = int(line.split()[1]) * 1024
    avail = budget.available_bytes()
    assert avail is not None and 0 <= avail <= total
