"""The example notebook ``docs/examples/orbit_camera.ipynb`` runs, and what it plots is what
the command line reports.

The notebook is executed with nbclient in a fresh kernel (plan, two short simulations, a
six-point sweep on a local Dask cluster, the TDI block's Verilog and a small case
co-simulated on Icarus); it writes the MTF and SNR numbers it plotted (from the datasets
of ``tdicam.simulate``) into ``plotted.json``. ``tdicam run`` on the same scene files with
the same line count and seed must report exactly those numbers in its ``report.json``.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

import tdicam
from tdicam import cli

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "examples" / "orbit_camera.ipynb"
#: Output lines of each run: the notebook's default (TDICAM_NOTEBOOK_LINES), small for CI.
LINES = 32

nbformat = pytest.importorskip("nbformat", reason="pip install -e '.[docs]'")
nbclient = pytest.importorskip("nbclient", reason="pip install -e '.[docs]'")


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    """The notebook executed into a temporary folder: (notebook, its output folder)."""
    if shutil.which("iverilog") is None:
        pytest.skip("the notebook co-simulates on Icarus Verilog: apt-get install iverilog")
    out = tmp_path_factory.mktemp("notebook")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    env = {"TDICAM_NOTEBOOK_OUT": str(out), "TDICAM_NOTEBOOK_LINES": str(LINES), "CI": "1"}
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)          # the kernel inherits this process's environment
    try:
        client = nbclient.NotebookClient(
            nb, timeout=300, kernel_name="python3", record_timing=False,
            resources={"metadata": {"path": str(NOTEBOOK.parent)}})
        client.execute()
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return nb, out


def _cli_report(name, out):
    """``tdicam run SCENE --lines LINES --no-impact -o OUT`` on the bundled scene ``name``
    (the file the notebook's ``tdicam.Scene.example(name)`` reads): its report.json."""
    scene = tdicam.Scene.example(name).source
    assert cli.main(["run", str(scene), "--lines", str(LINES), "--no-impact", "-o",
                     str(out)]) == 0
    return json.loads((out / "report.json").read_text())


def test_notebook_runs_and_shows_its_figures(executed):
    nb, out = executed
    images = sum("image/png" in o.get("data", {}) for c in nb.cells
                 for o in c.get("outputs", ()))
    assert images >= 5      # plan (2), TDI output, MTF + SNR, sweep
    errors = [o for c in nb.cells for o in c.get("outputs", ()) if o.output_type == "error"]
    assert not errors
    text = "".join(o.get("text", "") for c in nb.cells for o in c.get("outputs", ()))
    assert "576 pixels checked, 0 mismatches" in text
    assert "output (9, 64): match" in text
    assert (out / "sweep" / "sweep.nc").is_file()


def test_plotted_numbers_equal_the_cli_report(executed, tmp_path):
    _, out = executed
    plotted = json.loads((out / "plotted.json").read_text())

    orbit = _cli_report("orbit_600km_1m_96", tmp_path / "orbit")
    mtf = [{"stages": r["stages"], "dv_over_v": r["dv_over_v"],
            **{k: r["mtf"][k] for k in ("measured", "planned", "yuan2013_model",
                                         "footprint_model")}}
           for r in orbit["measurements"]]
    assert plotted["mtf"] == mtf
    assert mtf[0]["measured"] is not None

    flat = _cli_report("flat_snr_sweep_96", tmp_path / "flat")
    snr = [{"stages": r["stages"],
            **{k: r["snr"][k] for k in ("gain_db", "output_db", "predicted_db", "eq28_db")}}
           for r in flat["measurements"]]
    assert plotted["snr"] == snr
    assert [r["stages"] for r in snr] == [1, 2, 4, 8, 16, 32, 96]
