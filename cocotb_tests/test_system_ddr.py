"""The system scene with the NUC coefficients in DDR (``[pipeline.nuc] memory = "ddr"``,
``scenes/ning2019_gmax0504_system_ddr.toml``) co-simulated through its generated top against
the golden chain: each channel's NAND load written to DDR as nuc_ddr's coefficient frame at
power-up, then read back with every pixel frame, beside cds_ddr's reset-frame writes and
reads, both users of a channel behind one DdrArbiter on the channel's one MIG interface
(the MIG model outside the top on its ``ddr_app_*`` pins).

Default run: a 24-column, 4-stage, 3-line cut (16-block NAND parts: a short scan) on each
simulator, Icarus with random idle and backpressure; the same cut at 8 pixels a clock (the
NAND store's one pixel's coefficients a beat gathered by the chain's ``widen``) on Icarus.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np

from tdicam.chain import design
from tdicam.chain.cosim import cosimulate, scene_data
from tdicam.scene.loader import load_scene

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "ning2019_gmax0504_system_ddr.toml"


def _cut(ppc=None):
    sc = load_scene(SCENE, overrides={"sensor": {"columns": 24}, "tdi": {"stages": 4},
                                      "run": {"lines": 3}})
    p = design.chain_plan(sc, ppc=ppc)
    p = replace(p, steps=tuple(replace(s, device={**s.device, "blocks": 16}) if s.device
                               else s for s in p.steps))
    data, _ = scene_data(sc, stages=4, dv_over_v=0.0, lines=3)
    return p, data


def test_coefficients_in_ddr_match_the_golden_chain_through_the_shared_ddr(sim):
    p, data = _cut()
    assert [s.block for s in p.steps] == ["cds_ddr", "nuc_ddr", "hdr", "tdi", "median3"]
    kw = {"idle": 0.2, "backpressure": 0.2, "seed": 5} if sim == "icarus" else {}
    rep = cosimulate(p, data, sim, **kw)
    assert rep["mismatches"] == 0 and not rep["timeout"], rep["message"]
    assert rep["pixels_compared"] == 3 * 24
    taps = {t["tap"]: t for t in rep["taps"]}
    assert all(t["mismatches"] == 0 and t["received"] == t["beats"] for t in rep["taps"])
    assert taps["nuc_ddr_0"]["beats"] == p.frames * 4 * 24
    # the correction is not the identity: the golden nuc_ddr output differs from its input
    gold = {name: a for name, _, a in design.golden(p, data)}
    assert not np.array_equal(gold["nuc_ddr_0"], gold["cds_ddr_0"])
    st = rep["status_outputs"]
    # one MIG model a channel carries both users: the coefficient frame (4 lines of 3 words)
    # written once and read with every frame, the reset frames (a word a line) each way
    frames = p.frames
    for sfx in ("", "_1"):
        assert st[f"nuc_ddr_calib_loaded{sfx}"] == 1 and st[f"nuc_ddr_calib_error{sfx}"] == 0
        assert st[f"ddr_writes{sfx}"] == 4 * 3 + frames * 4
        assert st[f"ddr_reads{sfx}"] == frames * 4 * 3 + frames * 4
        assert st[f"ddr_error{sfx}"] == 0
    assert not any(n.startswith(("cds_ddr_ddr_", "nuc_ddr_ddr_")) for n in st)



def test_the_nand_load_at_8_pixels_a_clock_matches_the_golden_chain():
    """The cut at ppc 8 on Icarus with random idle and backpressure: the NAND store's
    coefficients, one pixel's a beat, widened to 8 pixels' a beat for nuc_ddr's coefficient
    frame; every tap bit-exact, the load's DDR traffic as at ppc 1 (the same 16-byte words)."""
    p, data = _cut(ppc=8)
    assert p.ppc == 8 and p.steps[1].block == "nuc_ddr" and p.steps[1].device
    rep = cosimulate(p, data, "icarus", idle=0.2, backpressure=0.2, seed=7)
    assert rep["mismatches"] == 0 and not rep["timeout"], rep["message"]
    assert rep["pixels_compared"] == 3 * 24
    assert all(t["mismatches"] == 0 and t["received"] == t["beats"] for t in rep["taps"])
    st = rep["status_outputs"]
    for sfx in ("", "_1"):
        assert st[f"nuc_ddr_calib_loaded{sfx}"] == 1 and st[f"nuc_ddr_calib_error{sfx}"] == 0
        assert st[f"ddr_writes{sfx}"] == 4 * 3 + p.frames * 4
        assert st[f"ddr_error{sfx}"] == 0
