"""The camera top's control bus (``--csr``) co-simulated through cocotbext-axi's AXI4-Lite
master and the generated Python driver, on a cut of the orbit chain scene (nuc -> tdi at 8
pixels per clock -> median3, 32 columns, 4 TDI stages) and on one of the NAND calibration
scene (nuc loading its coefficients from a worn NAND part -> tdi) and on the lanes' fault
cut of cocotb_tests/test_system.py; Icarus, a build each
(with ``TDICAM_FULL=1`` the orbit cut on Verilator too).

Every register read at reset (the map's reset values), every setting written and read back,
the output bit-exact against the golden chain, every status read after the run (no fault;
frame_count the output frames); the words at the C header's offsets (a C program built
with the peakrdl-cheader header prints them) are the registers the driver reads. A second pass writes TDI's ``stages_active`` = 0 (an invalid
setting) in the middle of frame 2: TDI samples it with the next frame's first beat, so
exactly the frames from 3 on are counted in ``tdi.frame_errors``, its fault bit is set and
``irq`` is high; writing 1s clears the counter, the interrupt status and ``irq``. On the
NAND scene the load's bad blocks and ECC counts are read over the bus, equal to the part
model's, and raise their fault and interrupt bits. On the lanes' fault cut (the sensor
front end in its word clock, its registers crossed into the bus's clock; lane 3 cannot
train, lane 0 dies mid-run) every frame's invalid lanes are read over the bus and equal
the golden front's, and a lane in error raises the interrupt.
"""

import json
import os
import shutil
import subprocess
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tdicam.chain import design, registers
from tdicam.chain.cosim import OVERFLOW, scene_data
from tdicam.cosim.build import build_sources, run_cocotb
from tdicam.hdl.csr_map import CAMERA_ID, version_word
from tdicam.hw.verilog import convert
from tdicam.scene.loader import load_scene

pytest.importorskip("cocotbext.axi")
# the loose-port tops and part models built for the stimulus only (never elaborated)
pytestmark = pytest.mark.filterwarnings("ignore::amaranth.hdl.UnusedElaboratable")
ROOT = Path(__file__).resolve().parents[1]
STAGES, COLS, LINES, CHANGE_FRAME = 4, 32, 8, 2


def _header_offsets(rm, header, tmp):
    """{"block.register": offset} as the C header states them (a C program built with it
    prints ``offsetof`` of every register)."""
    prog = ["#include <stddef.h>", "#include <stdio.h>", f'#include "{Path(header).name}"',
            "int main(void) {"]
    for r in rm.registers:
        path = r.name if r.block == "camera" else f"{r.block}.{r.name}"
        prog.append(f'    printf("{r.block}.{r.name} %zu\\n", offsetof({rm.name}_t, {path}));')
    (tmp / "offsets.c").write_text("\n".join(prog + ["    return 0;", "}"]) + "\n")
    subprocess.run(["cc", "-std=c11", "-I", str(Path(header).parent), "-o",
                    str(tmp / "offsets"), str(tmp / "offsets.c")], check=True)
    out = subprocess.run([str(tmp / "offsets")], check=True, capture_output=True, text=True)
    return {name: int(off) for name, off in (line.split() for line in out.stdout.splitlines())}


def _unused(obj, depth=4):
    """Mark a top built only for its ports, its parts and their models as not to be used
    (no UnusedElaboratable warnings)."""
    from amaranth.hdl import Elaboratable
    obj._MustUse__silence = True
    parts = list(vars(obj).values()) + [d.model for _, _, d in getattr(obj, "_devices", ())]
    for part in parts if depth else ():
        if isinstance(part, Elaboratable):
            _unused(part, depth - 1)


def _pack(data, padded):
    return [hex(sum(int(v) << (padded * k) for k, v in enumerate(row))) for row in data]


def _cosim(p, data, tag, sim="icarus"):
    """The --csr top of plan ``p`` (with its external parts' models) run by
    :mod:`tdicam.simtb.csr_tb` on ``sim``: (top, register map, stimulus, result)."""
    ax = design.top(p, data, board=True, csr=True)
    regmap = ax.core.regmap
    bdir, _ = build_sources("pipeline_csr", {"scene": tag, "cols": p.width,
                                             "stages": p.stages}, sim,
                            {"pipeline.v": convert(ax, "pipeline")}, top="pipeline")
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    files = registers.write_files(regmap, rundir)
    plain = design.top(p, data, board=True)         # the loose-port top: its beats
    _unused(plain)
    stim = design.stimulus(p, data, plain)
    _, _, in_padded, _ = ax._in
    beats = [[d, int(f), int(l)] for d, f, l in zip(_pack(stim.data, in_padded), stim.first,
                                                     stim.last)]
    per_frame = int(np.flatnonzero(stim.first)[1])
    settings = {f"{r.block}.{r.name}": r.reset for r in regmap.registers
                if r.access == "rw" and r.block != "camera"}
    probe = _header_offsets(regmap, files["header"], rundir)
    job = {"beats": beats, "settings": settings, "driver": files["driver"], "drain": 400,
           "probe": probe,
           "change": {"register": "tdi.stages_active", "value": 0,
                      "beat": CHANGE_FRAME * per_frame + per_frame // 2}}
    (rundir / "job.json").write_text(json.dumps(job))
    ok, _ = run_cocotb(bdir, sim, "csr_tb", rundir, [], top="pipeline")
    assert ok, (rundir / "sim.log").read_text()[-3000:]
    return ax, regmap, stim, json.loads((rundir / "result.json").read_text())


def _orbit(sim="icarus"):
    sc = load_scene(ROOT / "scenes" / "orbit_chain.toml", overrides={
        "sensor": {"columns": COLS},
        "run": {"lines": LINES, "rtl": {"crop": [0, 0, COLS, LINES]}}})
    p = design.chain_plan(sc, stages=STAGES)
    data, _ = scene_data(sc, stages=STAGES, dv_over_v=0.0, lines=LINES)
    return (p, data, *_cosim(p, data, "orbit_chain", sim))


@pytest.fixture(scope="module")
def run():
    return _orbit()


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_gateware_answers_at_the_c_headers_offsets(run):
    """The words the bus returns at the C header's offsets are the registers the driver
    (the map's offsets) reads, in two states."""
    _, _, _, regmap, _, res = run
    assert set(res["probe_inverted"]) == {f"{r.block}.{r.name}" for r in regmap.registers}
    assert res["probe_inverted"] == res["inverted"]
    assert res["probe_changed"] == res["changed"]
    assert len(set(res["inverted"].values()) | set(res["changed"].values())) >= 8


def test_registers_at_reset_and_written(run):
    _, _, _, regmap, _, res = run
    want = {f"{r.block}.{r.name}": r.reset for r in regmap.registers}
    assert want["camera.id"] == CAMERA_ID and want["camera.version"] == version_word()
    assert want["tdi.stages_active"] == STAGES and want["median3.height"] > 0
    got = dict(res["reset"])
    assert got.pop("camera.startup") == 1           # nothing holds the orbit chain's input
    want.pop("camera.startup")
    assert got == want
    rw = {f"{r.block}.{r.name}": r for r in regmap.registers if r.access == "rw"
          and r.block != "camera"}
    assert set(rw) == {"tdi.stages_active", "tdi.direction", "median3.height"}
    assert {k: res["inverted"][k] for k in rw} == {
        k: r.reset ^ ((1 << r.width) - 1) for k, r in rw.items()}
    assert res["written"] == {**want, "camera.startup": 1}


def test_output_bit_exact_and_status_read(run):
    p, data, ax, regmap, _, res = run
    gold = design.golden(p, data)[-1][2]
    bits, count, padded, _ = ax._out
    got = np.array([[(int(d, 16) >> (padded * k)) & ((1 << bits) - 1) for k in range(count)]
                    for d, _, _ in res["out"]], np.int64).ravel()
    assert got.size == gold.size > 0
    np.testing.assert_array_equal(got, gold.ravel())
    after = res["after"]
    assert after["camera.frame_count"] == gold.shape[0]
    assert after["tdi.frame_errors"] == 0 and after["median3.marker_error"] == 0
    assert after["camera.fault_summary"] == 0 and after["camera.irq_status"] == 0
    assert res["irq_after"] == 0


def test_setting_written_mid_frame_takes_effect_at_the_next_frame(run):
    _, _, _, regmap, stim, res = run
    frames = int(stim.first.sum())
    bit = 1 << [f"{r.block}.{r.name}" for r in regmap.faults].index("tdi.frame_errors")
    ch = res["changed"]
    assert ch["tdi.stages_active"] == 0
    assert ch["tdi.frame_errors"] == frames - (CHANGE_FRAME + 1)     # frames 3 .. end
    assert ch["camera.fault_summary"] & bit and ch["camera.irq_status"] & bit
    assert res["irq_changed"] == 1
    cl = res["cleared"]
    assert cl["tdi.frame_errors"] == 0 and cl["camera.irq_status"] == 0
    assert cl["camera.fault_summary"] == 0 and res["irq_cleared"] == 0


@pytest.fixture(scope="module")
def nand():
    """A 24-column, 4-stage cut of the NAND calibration scene (nuc from a worn NAND part:
    200 bad blocks, corrected and uncorrectable words; 512 blocks, the faults' seed 23, as
    cocotb_tests/test_system.py's cut)."""
    sc = load_scene(ROOT / "scenes" / "ning2019_nand_calib_faults.toml", overrides={
        "sensor": {"columns": 24}, "tdi": {"stages": STAGES}, "run": {"lines": LINES}})
    p = design.chain_plan(sc)
    p = replace(p, steps=tuple(replace(s, device={**s.device, "blocks": 512, "seed": 23})
                               if s.device else s for s in p.steps))
    data, _ = scene_data(sc, stages=STAGES, dv_over_v=0.0, lines=LINES)
    return (p, data, *_cosim(p, data, "nand_calib_faults"))


def test_nand_load_faults_in_the_status_registers_and_the_interrupt(nand):
    """The NAND load's bad blocks and ECC counts read over the bus equal the part model's;
    they are faults: their summary and interrupt bits set by the load, ``irq`` high once
    enabled; the output bit-exact; cleared by writing 1s."""
    from tdicam.blocks.nuc import nand_part
    p, data, ax, regmap, _, res = nand
    after = res["after"]
    _, model = nand_part(p.steps[0], *data.coeffs[0], 0)
    assert after["nuc.bad_blocks"] == model.scan.bad_count == 200
    assert after["nuc.corrected_words"] == model.image.corrected > 0
    assert after["nuc.uncorrectable_words"] == model.image.uncorrectable > 0
    assert after["nuc.calib_loaded"] == 1 and after["nuc.calib_error"] == 0
    assert after["camera.startup"] == 1 and after["camera.startup_cycles"] > 0
    faults = [f"{r.block}.{r.name}" for r in regmap.faults]
    bits = sum(1 << faults.index(n) for n in ("nuc.bad_blocks", "nuc.corrected_words",
                                             "nuc.uncorrectable_words"))
    assert after["camera.fault_summary"] == bits and after["camera.irq_status"] == bits
    assert res["irq_after"] == 0                  # not enabled yet
    assert res["irq_changed"] == 1
    gold = design.golden(p, data)[-1][2]
    bits_, count, padded, _ = ax._out
    got = np.array([[(int(d, 16) >> (padded * k)) & ((1 << bits_) - 1) for k in range(count)]
                    for d, _, _ in res["out"]], np.int64).ravel()
    np.testing.assert_array_equal(got, gold.ravel())
    cl = res["cleared"]
    assert cl["nuc.bad_blocks"] == cl["nuc.corrected_words"] == 0
    assert cl["camera.irq_status"] == 0 and res["irq_cleared"] == 0


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("TDICAM_FULL") != "1",
                    reason="the orbit cut on Verilator too: TDICAM_FULL=1")
def test_orbit_chain_cut_on_verilator():
    """The orbit cut's checks on Verilator (its own build)."""
    run = _orbit("verilator")
    test_registers_at_reset_and_written(run)
    test_output_bit_exact_and_status_read(run)
    test_setting_written_mid_frame_takes_effect_at_the_next_frame(run)
    if shutil.which("cc"):
        test_gateware_answers_at_the_c_headers_offsets(run)


LANES = ROOT / "scenes" / "ning2019_gmax0504_system_lanes.toml"


@pytest.fixture(scope="module")
def lanes_fault():
    """The lanes cut of cocotb_tests/test_system.py (16 columns, 3 stages, 16-block NAND
    parts; lane 3's eye 6 taps wide, lane 0 dying in the middle of frame 3) with the bus:
    the front's status read through it, only ``lvds.lane_error``'s interrupt enabled."""
    from tdicam.chain.cosim import cosimulate, lane_fault_cut
    p, data, front = lane_fault_cut(LANES)
    rep = cosimulate(p, data, "icarus", front=front, csr=True)
    return p, rep


def test_lane_fault_in_the_status_registers_and_the_interrupt(lanes_fault):
    """Through the bus (the front's word-clock status crossed into the processing clock):
    every frame's status read as ``lvds.frame_invalid`` is the golden front's (lane 3 in
    every frame, the cut frame all lanes, lane 0 and 3 after it), the pixels bit-exact;
    ``lvds.lane_error`` reads 0b1001 at the end of the words and raised the interrupt (only
    its bit enabled; the handler reads the status and the mask, and clears): at training
    with lane 3 alone in error, after the frames are released with lane 0 in error."""
    from tdicam.model import lvds_front
    p, rep = lanes_fault
    assert rep["mismatches"] == 0 and not rep["timeout"], rep["message"]
    assert all(t["mismatches"] == 0 and t["received"] == t["beats"] > 0 for t in rep["taps"])
    lanes, st, regs = rep["lanes"], rep["status_outputs"], rep["registers"]
    narrow, both = lvds_front.lane_mask([3]), lvds_front.lane_mask([0, 3])
    assert lanes["frame_status"] == [narrow] * 3 + [0b1111] + [both] * 4
    # the front's registers as read at the end of the sensor's words (past them the lanes
    # stand still and lose their lock: ``registers``, read at the very end, all in error)
    assert (st["lvds_lane_error"], st["lvds_lane_locked"]) == (0b1001, 0b0110)
    assert (st["lvds_frames_out"], st["lvds_frames_affected"]) == (8, 8)
    assert st["lvds_frames_dropped"] >= 2 and st["lvds_lane_errors"] >= 2
    assert st[OVERFLOW] == 0 and regs["lvds.lane_error"] == 0b1111
    assert regs["lvds.train_word"] == p.steps[0].ports["train_word"]
    faults = [f"{r.block}.{r.name}" for r in design.register_map(p).faults]
    bit = 1 << faults.index("lvds.lane_error")
    assert regs["camera.fault_summary"] & bit and regs["camera.irq_enable"] == bit
    irq = rep["irq"]
    assert len(irq) >= 2 and all(s & bit for _, s, _ in irq), irq
    up = rep["startup"]
    assert irq[0][0] < up["frames_released"] and irq[0][2] == 0b1000    # lane 3: training
    late = [e for e in irq if e[0] > up["frames_released"]]
    assert late and all(e[2] & 1 for e in late), irq                     # lane 0: its death
