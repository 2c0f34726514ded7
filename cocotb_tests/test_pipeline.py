"""The scene pipeline as one generated top, co-simulated whole against the golden chain.

Default run (Icarus, small): the Ning et al. 2019 chain (cds -> nuc -> hdr -> tdi -> median3 with
enhancement) on a cut of its scene's raw data: 0 mismatches; a corrupted golden stage is
named with its first differing pixel, and the waveform around it is written; TDI spilled to
DDR (tdi_ddr and the MIG model) on a small cut of the spilling scene; the chain at 8 pixels
per clock up to TDI, the median after it at 1 behind a width converter, on Icarus and on
Verilator (one build each), and with 2 TDI stages on Icarus (the median at 4); a corrupted
pixel inside a beat is named by its column; the Verilator run is a standalone binary that
fails without its stimulus. With ``TDICAM_FULL=1``: the whole small scene through
Verilator, the chain at ppc 2 and 4 on both simulators, the DDR spill at ppc 4.
"""

import os
import struct
from pathlib import Path

import numpy as np
import pytest

from tdicam.chain import design
from tdicam.commands.run import run_scene
from tdicam import cosim
from tdicam.chain.cosim import cosimulate, run_top, scene_data, WAVE_WINDOW
from tdicam.scene.loader import load_scene

ROOT = Path(__file__).resolve().parents[1]
FULL = os.environ.get("TDICAM_FULL") == "1"


def _scene(sim, cols=24, lines=6, crop=None):
    rtl = {"simulator": sim}
    if crop is not None:
        rtl["crop"] = crop
    return load_scene(ROOT / "scenes" / "ning2019_chain.toml", overrides={
        "sensor": {"columns": cols}, "run": {"lines": lines, "rtl": rtl}})


@pytest.fixture(scope="module")
def small():
    sc = _scene("icarus")
    p = design.chain_plan(sc)
    data, _ = scene_data(sc, stages=8, dv_over_v=0.0, lines=6)
    return p, data


def test_icarus_chain_on_a_cut_of_the_scene_matches(small):
    p, data = small
    rep = cosimulate(p, data, "icarus", idle=0.2, backpressure=0.2, seed=3)
    assert rep["mismatches"] == 0 and not rep["timeout"], rep["message"]
    assert rep["pixels_compared"] == 6 * 24
    assert [t["tap"] for t in rep["taps"]] == ["cds_0", "cds_1", "nuc_0", "nuc_1", "hdr",
                                               "tdi", "median3"]
    assert all(t["mismatches"] == 0 and t["received"] == t["beats"] for t in rep["taps"])
    assert rep["input_pixels"] == 2 * 2 * 13 * 8 * 24     # lanes x (signal, reset) x frames


def _fst_times(path):
    """Start and end time (ps) from an FST file's header block."""
    raw = Path(path).read_bytes()
    assert raw[0] == 0                                     # header block first
    _, start, end = struct.unpack(">QQQ", raw[1:25])
    return start, end


def test_corrupted_stage_is_named_with_its_first_pixel_and_a_waveform(small, tmp_path):
    p, data = small
    hit = (4, 3, 7)                                        # frame, line, column of nuc_1

    def corrupt(gold):
        name, block, a = gold[3]
        a = a.copy()
        a[hit] ^= 1
        gold[3][2] = a

    rep = cosimulate(p, data, "icarus", corrupt=corrupt, wave_dir=tmp_path, seed=3,
                        idle=0.2, backpressure=0.2)
    first = rep["first_mismatch"]
    assert (first["block"], first["tap"]) == ("nuc", "nuc_1")
    assert (first["frame"], first["line"], first["column"]) == hit
    assert first["expected"] == first["received"] ^ 1
    assert rep["mismatches"] == 0                          # the output itself is right
    assert [t["tap"] for t in rep["taps"] if t["mismatches"]] == ["nuc_1"]
    wave = Path(rep["waveform"])
    assert wave.exists() and str(wave) in rep["message"]
    start, end = _fst_times(wave)
    t = first["cycle"] * 10_000                            # 10 ns clock, ps
    assert 0 < start <= t <= end                           # a window, not from time 0
    assert start >= t - (WAVE_WINDOW + 10) * 10_000


def test_run_rtl_crop_on_icarus(tmp_path):
    sc = _scene("icarus", crop=[4, 1, 12, 4])
    rep = run_scene(sc, tmp_path, impact=False, progress=False)
    last = rep["rtl"]["blocks"][-1]
    assert last["block"] == "pipeline" and last["status"] == "ran", last
    assert last["mismatches"] == 0 and last["pixels_compared"] == 12 * 4
    assert rep["rtl"]["crop"] == [4, 1, 12, 4]            # the scene's [x0, y0, width, height]


def test_tdi_spilled_to_ddr_matches():
    """TDI's partial sums in DDR (tdi_ddr behind the simulation MIG model), Icarus."""
    sc = load_scene(ROOT / "scenes" / "orbit_4096_ddr_spill.toml", overrides={
        "sensor": {"columns": 160}, "tdi": {"stages": 4}, "run": {"lines": 6},
        "target": {"period_px": 3.0}})
    assert [s.block for s in design.chain_plan(sc).steps] == ["tdi"]          # fits on chip
    p = design.chain_plan(sc, spill=True)
    assert [s.block for s in p.steps] == ["tdi_ddr"]
    data, _ = scene_data(sc, stages=4, dv_over_v=0.0, lines=6)
    rep = cosimulate(p, data, "icarus", idle=0.1, backpressure=0.1)
    assert rep["mismatches"] == 0 and rep["pixels_compared"] == 6 * 160, rep["message"]


#: (simulator, ppc, TDI stages) of the wide-beat chain runs: one build per simulator, and
#: one with the median at 4 pixels per clock behind a 2:1 width converter by default (its
#: frames of 2 rows x 3 beats are shorter than the chain's latency: TDI starts its last
#: frames after the stimulus ended, on the last beat's run-time port values).
WIDE = [("icarus", 8, 8), ("verilator", 8, 8), ("icarus", 8, 2)] + (
    [("icarus", 2, 8), ("icarus", 4, 8), ("verilator", 2, 8), ("verilator", 4, 8),
     ("verilator", 8, 2), ("icarus", 8, 4), ("verilator", 4, 1)] if FULL else [])


@pytest.mark.parametrize("sim, ppc, stages", WIDE)
def test_chain_at_ppc_matches(small, sim, ppc, stages):
    """cds -> nuc -> hdr -> tdi at ``ppc`` pixels per clock (NUC's coefficients ppc pairs
    a beat from the ECC calibration ROM), then a width converter and median3 at ``ppc /
    stages`` (at least 1), 20% idle cycles and backpressure: every tap equal to the golden
    chain, in beats of its stage's pixels."""
    p1, data = small
    sc = _scene(sim)
    p = design.chain_plan(sc, ppc=ppc, stages=stages)
    mp = design.rate_ppc(ppc, stages)
    assert p.ppc == ppc and [design.step_ppc(s) for s in p.steps] == [ppc] * 4 + [mp]
    if stages != 8:
        data, _ = scene_data(sc, stages=stages, dv_over_v=0.0, lines=6)
    rep = cosimulate(p, data, sim, idle=0.2, backpressure=0.2, seed=ppc)
    assert rep["mismatches"] == 0 and not rep["timeout"], rep["message"]
    assert rep["pixels_compared"] == 6 * 24
    per = [ppc] * (len(rep["taps"]) - 1) + [mp]
    assert all(t["mismatches"] == 0 and t["received"] == t["beats"] == t["pixels"] // n
               for t, n in zip(rep["taps"], per)), rep["taps"]
    assert rep["taps"][-1]["beats"] == 6 * 24 // mp


def test_standalone_verilator_run_fails_on_a_missing_stimulus_chunk(small):
    """The Verilator run is the standalone binary (no cocotb): it leaves the summary and
    the output file, and without a stimulus chunk it ends with a non-zero status and the
    FAIL line (same build as the ppc-8 Verilator run)."""
    _, data = small
    p = design.chain_plan(_scene("verilator"), ppc=8)
    got, info = run_top(p, data, "verilator", seed=8, idle=0.2, backpressure=0.2, keep=True)
    rundir = Path(info["rundir"])
    assert (Path(info["build_dir"]) / "main.cpp").exists() and not info["timeout"]
    assert info["accepted"] == info["input_beats"] and len(got["out"]) == 6 * 24
    (rundir / "stim_000000.bin").unlink()
    ok, _ = cosim.run_standalone(Path(info["build_dir"]), rundir,
                                 [f"+n_in={info['input_beats']}", "+n_out=144"])
    log = (rundir / "sim.log").read_text()
    assert not ok and "FAIL cannot open the stimulus file stim_000000.bin" in log, log


def test_corrupted_pixel_inside_a_wide_beat_is_named(small):
    """At ppc 8 a corrupted pixel in the middle of a beat (column 13 = beat 1, element 5) is
    named by its own frame, line and column (same Icarus build as the ppc-8 run)."""
    _, data = small
    p = design.chain_plan(_scene("icarus"), ppc=8)
    hit = (2, 5, 13)                                       # frame, line, column of hdr

    def corrupt(gold):
        a = gold[4][2].copy()
        a[hit] ^= 2
        gold[4][2] = a

    rep = cosimulate(p, data, "icarus", corrupt=corrupt, seed=8, idle=0.2,
                     backpressure=0.2)
    first = rep["first_mismatch"]
    assert (first["tap"], first["frame"], first["line"], first["column"]) == ("hdr", *hit)
    assert first["beat"] == (2 * 8 * 24 + 5 * 24 + 13) // 8
    assert first["expected"] == first["received"] ^ 2 and rep["mismatches"] == 0


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="DDR spill at ppc 4: TDICAM_FULL=1")
def test_tdi_spilled_to_ddr_at_ppc_4_matches():
    """560 columns: at ppc 4 a row of DDR partial sums needs more than 136 beats."""
    sc = load_scene(ROOT / "scenes" / "orbit_4096_ddr_spill.toml", overrides={
        "sensor": {"columns": 560}, "tdi": {"stages": 4}, "run": {"lines": 6},
        "target": {"period_px": 3.0}})
    p = design.chain_plan(sc, spill=True, ppc=4)
    assert [(s.block, s.params["ppc"]) for s in p.steps] == [("tdi_ddr", 4)]
    data, _ = scene_data(sc, stages=4, dv_over_v=0.0, lines=6)
    rep = cosimulate(p, data, "icarus", idle=0.1, backpressure=0.1)
    assert rep["mismatches"] == 0 and rep["pixels_compared"] == 6 * 560, rep["message"]


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="Verilator build of the whole chain: TDICAM_FULL=1")
def test_verilator_whole_small_scene(tmp_path):
    sc = _scene("verilator", cols=64, lines=16)
    rep = run_scene(sc, tmp_path, impact=False, progress=False)
    last = rep["rtl"]["blocks"][-1]
    assert last["status"] == "ran", last
    assert rep["rtl"]["crop"] is None and last["engine_agrees"] is True
    assert last["mismatches"] == 0 and last["pixels_compared"] == 64 * 16
    assert last["input_pixels"] == 2 * 2 * (16 + 7) * 8 * 64
    assert "| tap median3 | ran | 1024 | 0 |" in (tmp_path / "report.md").read_text()


@pytest.mark.parametrize("sim", ["icarus", "verilator"])
def test_orbit_chain_ecp5_synthesis_top_matches(sim):
    """The top ``tdicam synth pipeline`` places for the orbit chain at ppc 8 (NUC's
    MULT18X18D, TDI's and median3's DP16KD banks, the width converter's FIFO in DP16KD with
    its output register), co-simulated with the primitives' models on a 48-column cut with
    8 stages (the median at 1 pixel per clock), 20 % idle cycles and backpressure: every
    tap equal to the golden chain."""
    sc = load_scene(ROOT / "scenes" / "orbit_chain.toml", overrides={
        "sensor": {"columns": 48}, "run": {"lines": 8, "rtl": {"crop": [0, 0, 48, 8]}}})
    p = design.chain_plan(sc, stages=8, ppc=8)
    assert [design.step_ppc(s) for s in p.steps] == [8, 8, 1]
    data, _ = scene_data(sc, stages=8, dv_over_v=0.0, lines=8)
    rep = cosimulate(p, data, sim, idle=0.2, backpressure=0.2, seed=3, ecp5=True)
    assert rep["mismatches"] == 0 and not rep["timeout"], rep["message"]
    assert [(t["tap"], t["received"], t["mismatches"]) for t in rep["taps"]] == [
        ("nuc", 720, 0), ("tdi", 48, 0), ("median3", 384, 0)]


@pytest.mark.parametrize("sim", ["icarus", "verilator"])
def test_ning_chain_ecp5_synthesis_top_matches(small, sim):
    """The top ``tdicam synth pipeline`` places for the Ning et al. 2019 chain at ppc 8
    (NUC's and hdr's MULT18X18D with their input registers, the products of median3's edge
    enhancement in MULT18X18D output registers, TDI's and median3's DP16KD banks, the
    width converter's FIFO), co-simulated with the primitives' models on its 24-column cut,
    20 % idle cycles and backpressure: every tap equal to the golden chain."""
    _, data = small
    p = design.chain_plan(_scene(sim), ppc=8, stages=8)
    assert [design.step_ppc(s) for s in p.steps] == [8, 8, 8, 8, 1]
    rep = cosimulate(p, data, sim, idle=0.2, backpressure=0.2, seed=5, ecp5=True)
    assert rep["mismatches"] == 0 and not rep["timeout"], rep["message"]
    assert rep["pixels_compared"] == 6 * 24
    assert all(t["mismatches"] == 0 and t["received"] == t["beats"] for t in rep["taps"])
