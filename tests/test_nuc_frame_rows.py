"""``[pipeline.nuc].coefficients = "frame"``: an area camera's per-pixel NUC (Ning et al.
2019: a gain and an offset for every pixel of the frame). The scene simulator draws a fixed
pattern row per output line (line r is sensor row r) and a coefficient line per row; the
golden chain stores that image in nuc_ddr (``image_rows`` = the lines) and corrects row r
with line r; the chain's output equals the scene simulator's. Line scanners keep one
coefficient line per window row. The gateware: tests/test_properties.py (nuc_ddr with
``image_rows``), cocotb_tests/test_camera_full.py (the camera cut) and the block's
``image_rows_*`` cases. With ``TDICAM_FULL=1``: ``tdicam run`` of the whole 5144 x 3800
frame pair."""

import numpy as np
import pytest

from tdicam.cosim.testing import FULL
from tdicam.errors import TdicamError
from tdicam.paths import SCENES
from tdicam.scene.loader import load_scene

_FULL = SCENES / "ning2019_gmax0504_full.toml"
#: A narrow cut of it: 48 columns on 8 lanes a gain (the scene's 40 need >= 40 columns; the
#: crop below is 16).
_NARROW = {"sensor": {"columns": 48, "lvds": {"lanes_per_gain": 8}}, "run": {"lines": 12}}
#: The scene's [pipeline.nuc] (an override replaces a sub-table whole).
_NUC = {"flash": "nand", "memory": "ddr", "coefficients": "frame"}


def _data(over):
    from tdicam.chain import design
    from tdicam.chain.cosim import scene_data
    sc = load_scene(_FULL, overrides=over)
    lines = over["run"]["lines"]
    return design, design.chain_plan(sc, stages=1, lines=lines), \
        scene_data(sc, stages=1, dv_over_v=0.0, lines=lines)


def test_the_area_camera_has_a_coefficient_line_per_row_and_the_chain_agrees():
    design, p, (data, res) = _data(_NARROW)
    step = next(s for s in p.steps if s.block == "nuc_ddr")
    assert step.params["image_rows"] == 12 and step.params["rows"] == 1
    for gain, offset in data.coeffs:                  # both gains
        assert gain.shape == offset.shape == (12, 48)
        assert len({g.tobytes() for g in gain}) == 12
    out = design.golden(p, data)[-1][2]
    assert np.array_equal(out.reshape(res.output.shape), res.output)


def test_a_line_scanner_keeps_its_window_rows():
    over = {**_NARROW, "pipeline": {"nuc": {**_NUC, "coefficients": "window"}}}
    _, p, (data, _) = _data(over)
    step = next(s for s in p.steps if s.block == "nuc_ddr")
    assert "image_rows" not in step.params
    assert all(g.shape == (1, 48) for g, _ in data.coeffs)


@pytest.mark.parametrize("over, words", [
    ({"pipeline": {"nuc": {**_NUC, "memory": "chip"}}}, "needs memory = \"ddr\""),
    ({"tdi": {"stages": 4}}, "[tdi].stages must be 1"),
])
def test_a_frame_image_where_it_cannot_be_is_one_line(over, words):
    from tdicam.chain import design
    with pytest.raises(TdicamError) as e:
        design.chain_plan(load_scene(_FULL, overrides={**_NARROW, **over}), lines=12)
    assert words in str(e.value) and "\n" not in str(e.value)


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="the whole 5144 x 3800 frame pair (~GiB, minutes): "
                                     "TDICAM_FULL=1")
def test_the_whole_frame_pair_runs_with_per_pixel_coefficients(tmp_path):
    from tdicam.run.runner import run_scene
    rep = run_scene(load_scene(_FULL), tmp_path, impact=False, progress=False)
    assert (tmp_path / "report.md").exists() and rep


def test_a_crop_keeps_its_rows_coefficients():
    """[run.rtl].crop of an area camera: rows y0.. of the coefficients go with frames y0..
    (nuc_ddr's output, pointwise, is the whole run's cropped)."""
    design, p, (data, _) = _data(_NARROW)
    sc = load_scene(_FULL, overrides=_NARROW)
    y0, h, x0, w = 3, 5, 8, 16
    pc = design.chain_plan(sc, stages=1, lines=h, width=w)
    cut = data.crop(x0, w, y0, h, coeff_rows=True)
    assert cut.coeffs[0][0].shape == (h, w)

    def nuc_tap(plan, d):
        return next(a for _, block, a in design.golden(plan, d) if block == "nuc_ddr")
    assert np.array_equal(nuc_tap(pc, cut), nuc_tap(p, data)[y0:y0 + h, :, x0:x0 + w])
