"""Scene simulator engine (tdicam/engine/): the table of effects, effect decisions,
skip == forced-at-zero, fidelity selection, bad scenes."""

import dataclasses
import textwrap

import numpy as np
import pytest

from tdicam import engine
from tdicam.errors import TdicamError
from tdicam.scene.loader import load_scene

ORBIT = "[orbit]\naltitude_km = 600\ngsd_m = 1.0\n"


def scene(tmp_path, text):
    p = tmp_path / "s.toml"
    p.write_text(textwrap.dedent(text))
    return load_scene(p)


def small(tmp_path, extra="", stages=4, dv=0.0, kind='kind = "bars"\nperiod_px = 4.0'):
    return scene(tmp_path, ORBIT + f"""
[target]
{kind}
signal_e = 800.0
[sensor]
columns = 48
rows = 64
bits = 12
read_noise_e = 5.0
prnu = 0.01
dsnu_e = 1.0
dark_current_e_per_s = 2000.0
black_level_dn = 32.0
shutter = "global"
[tdi]
stages = {stages}
[motion]
dv_over_v = {dv}
[run]
lines = 24
seed = 7
""" + extra)


def rec(res, name):
    return next(e for e in res.effects if e.name == name)


def test_skips_and_reasons(tmp_path):
    res = engine.simulate(small(tmp_path), fidelity="exact", impact=False)
    assert not rec(res, "smear").ran and "dV/V = 0 and no drift" in rec(res, "smear").why
    assert not rec(res, "hdr").ran and not rec(res, "dual_gain").ran
    assert "one-gain" in rec(res, "dual_gain").why
    assert not rec(res, "rolling_skew").ran and "global shutter" in rec(res, "rolling_skew").why
    assert not rec(res, "optics").ran
    assert rec(res, "prnu").ran and rec(res, "shot_noise").ran and rec(res, "tdi").ran
    assert res.output.shape == (24, 48) and res.raw.shape == (24, 48)


def test_one_gain_skips_hdr_even_when_listed(tmp_path):
    sc = small(tmp_path, '[pipeline]\nblocks = ["hdr", "tdi"]\n')
    res = engine.simulate(sc, fidelity="exact", impact=False)
    assert not rec(res, "hdr").ran and "one-gain sensor" in rec(res, "hdr").why


@pytest.mark.parametrize("fid", ["exact", "fast"])
@pytest.mark.parametrize("effect", ["smear", "optics", "rolling_skew"])
def test_skipped_equals_forced_at_zero(tmp_path, fid, effect):
    sc = small(tmp_path)
    a = engine.simulate(sc, fidelity=fid, impact=False)
    b = engine.simulate(sc, fidelity=fid, impact=False, force=[effect])
    assert not rec(a, effect).ran and rec(b, effect).ran and "forced" in rec(b, effect).why
    assert np.array_equal(a.output, b.output)
    assert np.array_equal(a.raw, b.raw)


def test_zero_strength_impairments_equal_skipped(tmp_path):
    clean = scene(tmp_path, ORBIT + """
[target]
kind = "flat"
signal_e = 500.0
[sensor]
columns = 32
rows = 64
black_level_dn = 16.0
[tdi]
stages = 3
[run]
lines = 16
""")
    a = engine.simulate(clean, fidelity="exact", impact=False)
    forced = ["prnu", "dsnu", "dark_current", "read_noise", "full_well"]
    b = engine.simulate(clean, fidelity="exact", impact=False, force=forced)
    for n in forced:
        assert not rec(a, n).ran and rec(b, n).ran
    assert np.array_equal(a.output, b.output)


def test_smear_runs_with_mismatch(tmp_path):
    res = engine.simulate(small(tmp_path, dv=0.1), fidelity="exact", impact=False)
    assert rec(res, "smear").ran and "M dV/V = 0.4" in rec(res, "smear").why


def test_one_stage_image_moves_at_one_minus_dv(tmp_path):
    # issue 20: at M = 1 the smear effect used to be off, so the image moved 1 px per line
    # period whatever dV/V; the ideal along-track bars must now repeat every 4 / (1 - dV/V)
    # lines and the exposure smear must follow (tests/test_plan_mtf.py checks the MTF)
    kind = 'kind = "bars"\nperiod_px = 4.0\ndirection = "along_track"'
    res = engine.simulate(small(tmp_path, stages=1, dv=0.5, kind=kind), fidelity="exact",
                          impact=False)
    assert rec(res, "smear").ran and "moves 0.5 px along" in rec(res, "smear").why
    assert res.geometry.speed == 0.5
    col = res.target[:, 0]
    assert np.allclose(col[8:], col[:-8]) and not np.allclose(col[4:], col[:-4])
    still = engine.simulate(small(tmp_path, stages=1, kind=kind), fidelity="exact",
                            impact=False)
    assert not rec(still, "smear").ran and still.geometry.speed == 1.0


def test_impact_measured(tmp_path):
    res = engine.simulate(small(tmp_path), fidelity="exact", impact=True)
    r = rec(res, "read_noise")
    assert r.impact["psnr_db"] > 20 and r.impact["rms_dn"] > 0
    assert rec(res, "quantization").impact["note"]


def test_auto_picks_exact_for_per_exposure_blocks(tmp_path):
    sc = small(tmp_path, '[pipeline]\nblocks = ["nuc", "tdi"]\n')
    res = engine.simulate(sc, fidelity="fast", impact=False)
    assert res.fidelity == "exact"
    assert any("not applicable" in n for n in res.notes)
    assert rec(res, "nuc").ran


def test_auto_picks_fast_when_dithered(tmp_path):
    res = engine.simulate(small(tmp_path), fidelity="auto", impact=False)
    assert res.fidelity == "fast"
    assert rec(res, "quantization").bound < 1e-3


def test_fast_matches_exact_statistics(tmp_path):
    sc = small(tmp_path, kind='kind = "flat"', stages=8)
    ex = engine.simulate(sc, fidelity="exact", impact=False, lines=200)
    fa = engine.simulate(sc, fidelity="fast", impact=False, lines=200)
    assert abs(ex.output.mean() - fa.output.mean()) / ex.output.mean() < 2e-3
    assert abs(ex.output.std() / fa.output.std() - 1) < 0.05


def test_cds_nuc_hdr_median_chain_runs(tmp_path):
    sc = scene(tmp_path, ORBIT + """
[target]
kind = "siemens"
signal_e = 20000.0
[sensor]
columns = 40
rows = 64
bits = 10
full_well_e = 40000.0
gains = [4.9, 0.8]
prnu = 0.02
read_noise_e = 4.0
shutter = "global"
[tdi]
stages = 3
output = "saturate"
output_bits = 16
[pipeline]
blocks = ["cds", "nuc", "hdr", "tdi", "median3"]
[pipeline.hdr]
threshold_dn = 768
band_dn = 32
[run]
lines = 20
fidelity = "auto"
""")
    res = engine.simulate(sc, impact=False)
    for n in ("cds", "nuc", "hdr", "tdi", "median3_post", "reset_frames", "dual_gain"):
        assert rec(res, n).ran, n
    assert not rec(res, "median3_pre").ran
    assert res.fidelity == "exact"
    assert res.single.max() > 1.5 * 1023    # HDR output extends past the 10-bit HG range
    assert res.raw.max() == 1023            # while the raw HG channel saturates


def test_bad_inputs(tmp_path):
    sc = small(tmp_path)
    with pytest.raises(TdicamError, match="unknown effect"):
        engine.simulate(sc, force=["smeer"])
    with pytest.raises(TdicamError, match="fidelity"):
        engine.simulate(sc, fidelity="medium")
    with pytest.raises(TdicamError, match=r"\[sensor\]\.bits"):
        # a scene the reader would refuse, made past it (the engine checks it again)
        engine.simulate(dataclasses.replace(sc, sensor=dataclasses.replace(sc.sensor, bits=16)),
                        fidelity="exact", impact=False)


def test_median_after_wide_tdi_is_a_clear_error(tmp_path):
    # the scene loader refuses it before any work ...
    with pytest.raises(TdicamError, match=r"^\[tdi\]\.output: median3 after TDI takes at most "
                                          r"16-bit pixels; the TDI output is 17 bits"):
        small(tmp_path, '[pipeline]\nblocks = ["tdi", "median3"]\n', stages=32)
    # ... and the simulator of a scene made around the loader says the same
    import dataclasses
    sc = small(tmp_path, '[pipeline]\nblocks = ["tdi"]\n', stages=32)
    sc = dataclasses.replace(sc, pipeline=dataclasses.replace(sc.pipeline,
                                                              blocks=("tdi", "median3")))
    with pytest.raises(TdicamError, match=r"\[tdi\]\.output"):
        engine.simulate(sc, fidelity="exact", impact=False)


def test_effect_table_is_in_physical_order_and_complete():
    names = [e.name for e in engine.EFFECTS]
    assert names == ["optics", "aperture", "smear", "rolling_skew", "prnu", "dark_current",
                     "dsnu", "shot_noise", "full_well", "reset_frames", "read_noise",
                     "dual_gain", "quantization", "sensor_lanes", "cds", "nuc", "hdr",
                     "median3_pre", "tdi", "median3_post"]
    stages = ["render", "pattern", "charge", "conversion", "blocks", "lines", "output"]
    order = [stages.index(e.stage) for e in engine.EFFECTS if e.stage]
    assert order == sorted(order)                  # the stages follow the physical order
    for e in engine.EFFECTS:
        if e.stage:
            assert e.exact is not None, e.name     # every acting effect runs in exact
        if e.per_exposure:
            assert e.fast is None, e.name          # non-linear single-exposure blocks
    assert engine.FORCIBLE == ("optics", "smear", "rolling_skew", "prnu", "dark_current",
                               "dsnu", "full_well", "read_noise")


def test_every_record_states_why(tmp_path):
    res = engine.simulate(small(tmp_path), fidelity="fast", impact=False)
    assert [r.name for r in res.effects] == list(engine.EFFECT_NAMES)
    assert all(r.why for r in res.effects)
    assert rec(res, "quantization").why.count("fast:") == 1


def test_tdi_cannot_be_disabled(tmp_path):
    with pytest.raises(TdicamError, match="disable tdi"):
        engine.simulate(small(tmp_path), disable=["tdi"], impact=False)


def test_stages_beyond_the_sweep(tmp_path):
    """stages=m larger than every [tdi].stages of the scene (issue 18: IndexError before)."""
    sc = small(tmp_path, stages=2)
    for fid in ("exact", "fast"):
        res = engine.simulate(sc, stages=6, fidelity=fid, impact=False)
        assert res.stages == 6 and res.output.shape == (24, 48)
        assert rec(res, "tdi").ran


@pytest.mark.parametrize("over,msg", [
    ({"tdi": {"stages": 200}, "sensor": {"rows": 256}},
     r"^\[tdi\]\.stages: must be <= 128 for digital TDI"),
    ({"sensor": {"bits": 16}}, r"^\[sensor\]\.bits: digital TDI takes 8\.\.14-bit pixels"),
    ({"sensor": {"bits": 4, "black_level_dn": 0.0}},
     r"^\[sensor\]\.bits: digital TDI takes 8\.\.14-bit pixels"),
])
def test_validity_does_not_depend_on_fidelity(over, msg):
    """One rule in the schema: what exact refuses, fast and auto refuse too (issue 18)."""
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    with pytest.raises(TdicamError, match=msg):
        load_scene(root / "scenes" / "orbit_600km_1m_96.toml",
                   overrides={**over, "sensor": {**over.get("sensor", {}),
                                                 "max_frame_rate_hz": None}})
    # charge-domain TDI has no accumulator: the same values are valid there
    sc = load_scene(root / "scenes" / "orbit_600km_1m_96.toml", overrides={
        **over, "tdi": {**over.get("tdi", {}), "domain": "charge"},
        "sensor": {**over.get("sensor", {}), "max_frame_rate_hz": None, "columns": 16,
                   "full_well_e": 1e7}})
    for fid in ("fast", "exact"):
        engine.simulate(sc, fidelity=fid, lines=4, impact=False)


def test_stage_override_checked_like_the_schema(tmp_path):
    with pytest.raises(TdicamError, match=r"^\[tdi\]\.stages: must be <= 128"):
        sc = small(tmp_path)
        engine.simulate(dataclasses.replace(sc, sensor=dataclasses.replace(sc.sensor, rows=400)),
                        stages=200, fidelity="fast", impact=False)


def test_huge_psf_is_a_one_line_error(tmp_path):
    sc = small(tmp_path, "[optics]\npsf_sigma_px = 1e6\n")
    with pytest.raises(TdicamError, match=r"^\[optics\]\.psf_sigma_px: must be <= 64"):
        engine.simulate(sc, fidelity="fast", impact=False)


def _nuc_flat(tmp_path, nuc):
    return scene(tmp_path, ORBIT + f"""
[target]
kind = "flat"
signal_e = 2000.0
[sensor]
columns = 64
rows = 64
prnu = 0.05
black_level_dn = 32.0
[tdi]
stages = 4
[pipeline]
blocks = ["nuc", "tdi"]
[pipeline.nuc]
{nuc}
[run]
lines = 16
seed = 3
fidelity = "exact"
""")


def test_nuc_coefficients_from_nand_flash(tmp_path):
    """[pipeline.nuc] flash = "nand" (issue 22): bad blocks and single flips are invisible
    (mapped around, corrected: the output equals the in-memory ECC path bit for bit); a
    double flip gives its two pixels the default coefficients, so their columns keep the
    PRNU and only those columns change; the counters are reported."""
    ref = engine.simulate(_nuc_flat(tmp_path, ""), impact=False)
    assert ref.flash is None
    clean = engine.simulate(_nuc_flat(tmp_path, 'flash = "nand"\nbad_blocks = 100\n'
                                                'flip_single = 0.5'), impact=False)
    f = clean.flash[0]
    assert f["bad_blocks"] == 100 and f["corrected_words"] > 30
    assert f["uncorrectable_words"] == 0 and f["defaulted_pixels"] == 0
    assert f["pixels"] == 4 * 64 and f["words"] == 4 + 4 * 64 // 2
    assert np.array_equal(clean.output, ref.output) and clean.output.dtype == ref.output.dtype
    bad = engine.simulate(_nuc_flat(tmp_path, 'flash = "nand"\nflip_double = 0.2'),
                          impact=False)
    f = bad.flash[0]
    assert f["uncorrectable_words"] > 5 and f["defaulted_pixels"] == 2 * f["uncorrectable_words"]
    assert any("uncorrectable" in n for n in bad.notes)
    changed = np.nonzero((bad.output != ref.output).any(axis=0))[0]
    assert 0 < len(changed) <= f["defaulted_pixels"]
    # uncorrected PRNU (5 %) shows: the columns' spread grows
    assert bad.output.mean(axis=0).std() > 2 * ref.output.mean(axis=0).std()
