"""``[pipeline.nuc] memory = "ddr"``: the chain's NUC keeps its coefficients in DDR (block
nuc_ddr, loaded at power-up from NAND or the calibration ROM), and the top puts every DDR
user of a gain channel behind one DdrArbiter on one MIG interface (``ddr_app_*``). The
co-simulation against the golden chain is ``cocotb_tests/test_system_ddr.py``."""

from pathlib import Path

import pytest

from tdicam.beats import PPC_CHOICES
from tdicam.chain import design
from tdicam.errors import TdicamError
from tdicam.model.nuc_ddr import coeff_layout
from tdicam.scene.loader import load_scene

ROOT = Path(__file__).resolve().parents[1]
CHAIN = ROOT / "scenes" / "ning2019_chain.toml"
SCENE = ROOT / "scenes" / "ning2019_gmax0504_system_ddr.toml"
BOTH = {"cds": {"memory": "ddr"}, "nuc": {"flash": "nand", "memory": "ddr"}}


def _scene(pipeline=BOTH, ddr=True, **over):
    o = {"sensor": {"columns": 24}, "tdi": {"stages": 4}, "run": {"lines": 3},
         "pipeline": pipeline, **over}
    if ddr:
        o["ddr"] = {"base": 4096}
    return load_scene(CHAIN, overrides=o)


def _members(ax):
    return {n: m.flow.name for n, m in ax.signature.members.items()}


def test_nuc_memory_ddr_plans_nuc_ddr_above_the_reset_frame():
    p = design.chain_plan(_scene())
    steps = {s.block: s for s in p.steps}
    assert [s.block for s in p.steps][:2] == ["cds_ddr", "nuc_ddr"]
    cds, nuc = steps["cds_ddr"], steps["nuc_ddr"]
    assert cds.params["base"] == 4096
    # the coefficient image starts where the reset frame ends (one word a 24-pixel line)
    assert nuc.params["base"] == design.uses()["cds_ddr"].memory.ddr_end(cds) == 4096 + 3 * 8 + 8
    assert nuc.params["width"] == 24 and nuc.params["rows"] == 4
    assert nuc.device and nuc.device["blocks"] == 4096       # the NAND part, as nuc's
    end = coeff_layout(24, base=nuc.params["base"]).end_addr(4)
    assert design.uses()["nuc_ddr"].memory.ddr_end(nuc) == end
    # without it, the chain is nuc as before
    plain = design.chain_plan(_scene({"cds": {"memory": "ddr"}, "nuc": {"flash": "nand"}}))
    assert [s.block for s in plain.steps][:2] == ["cds_ddr", "nuc"]


def test_one_mig_interface_a_channel_behind_an_arbiter():
    """Synthesis form: a channel's two DDR users (cds_ddr, nuc_ddr) share one MIG user
    interface at the top's ports (ddr_app_*, ddr_app_*_1) through a DdrArbiter each; the
    board puts one MIG model on each and shows its counters (ddr_writes ...)."""
    p = design.chain_plan(_scene())
    ax = design.top(p)
    top = _members(ax)
    for lane in ("", "_1"):
        for port, flow in (("app_addr", "Out"), ("app_en", "Out"), ("app_rdy", "In"),
                           ("app_rd_data", "In"), ("app_wdf_data", "Out")):
            assert top[f"ddr_{port}{lane}"] == flow
        assert top[f"nuc_ddr_calib_loaded{lane}"] == "Out"
        assert top[f"nuc_ddr_nand_cle{lane}"] == "Out"
    assert not any(n.startswith(("cds_ddr_app_", "nuc_ddr_app_")) for n in top)
    assert "nuc_ddr_frame_kind" not in top            # driven by the load, not a port
    from amaranth.hdl import Fragment
    frag = Fragment.get(ax, None)
    names = set()

    def walk(f, path=""):
        for sub, name, *_ in f.subfragments:
            names.add(f"{path}{name}")
            walk(sub, f"{path}{name}.")
    walk(frag)
    assert {"core.ddr_0_arbiter", "core.ddr_1_arbiter"} <= names
    board = design.top(p, board=True)
    bm = _members(board)
    assert not any("app_" in n or "nand_" in n for n in bm)
    for name in ("ddr_writes", "ddr_reads_1", "ddr_error", "nuc_ddr_calib_loaded_1"):
        assert bm[name] == "Out"
    devs = board.core.core.devices()
    assert sorted((st.name, k) for st, k, _ in devs) == [
        ("ddr", 0), ("ddr", 1), ("nuc_ddr", 0), ("nuc_ddr", 1)]


def test_nuc_ddr_alone_on_its_ddr_keeps_its_own_interface():
    """With the reset frame on chip nuc_ddr is the channel's only DDR user: its own
    nuc_ddr_app_* pins, no arbiter; the ROM load when there is no NAND part."""
    p = design.chain_plan(_scene({"nuc": {"memory": "ddr"}}))
    assert [s.block for s in p.steps][:2] == ["cds", "nuc_ddr"]
    assert p.steps[1].params["base"] == 4096 and not p.steps[1].device
    from amaranth.hdl import Fragment
    ax = design.top(p)
    Fragment.get(ax, None)                       # the ROM load elaborates
    top = _members(ax)
    assert top["nuc_ddr_app_en"] == "Out" and top["nuc_ddr_app_rdy_1"] == "In"
    assert top["nuc_ddr_calib_loaded"] == "Out"
    assert not any(n.startswith("ddr_") for n in top)


def test_nuc_memory_ddr_refusals():
    with pytest.raises(TdicamError, match=r"\[pipeline.nuc\].memory = 'ddr'.*no \[ddr\] "
                                          r"section"):
        _scene({"nuc": {"memory": "ddr"}}, ddr=False)
    with pytest.raises(TdicamError, match=r"gain_frac_bits.*<= 14 with memory"):
        _scene({"nuc": {"memory": "ddr", "gain_frac_bits": 15}})
    with pytest.raises(TdicamError, match=r"memory.*chip.*ddr"):
        _scene({"nuc": {"memory": "sram"}})


def test_the_bundled_scene_is_the_system_scene_with_nuc_in_ddr():
    sc = load_scene(SCENE)
    assert sc.pipeline.nuc.memory == "ddr" and sc.pipeline.cds.memory == "ddr"
    p = design.chain_plan(sc)
    assert [s.block for s in p.steps] == ["cds_ddr", "nuc_ddr", "hdr", "tdi", "median3"]
    base = load_scene(ROOT / "scenes" / "ning2019_gmax0504_system.toml")
    assert sc.pipeline.nuc.memory == "ddr" and base.pipeline.nuc.memory == "chip"
    assert sc.sensor == base.sensor and sc.tdi == base.tdi


def test_the_top_has_one_ddr_interface_a_gain_channel():
    """[camera].ddr_interfaces (the plan's budget) must be the top's count, one a gain
    channel, when its DDR users share them: another count is refused in one line."""
    sc = _scene(camera={"ddr_interfaces": 4, "frame_rate_hz": 25.0})
    p = design.chain_plan(sc)
    assert p.ddr_interfaces == 4
    with pytest.raises(TdicamError, match=r"\[camera\].ddr_interfaces = 4: the generated top "
                                          r"has one DDR interface a gain channel \(2\)"):
        design.top(p)
    assert design.chain_plan(_scene(camera={"ddr_interfaces": 2,
                                            "frame_rate_hz": 25.0})).ddr_interfaces == 2


def test_the_report_states_the_load_and_the_shared_ddr():
    """tdicam run's rtl section (system_figures) from a co-simulation's status outputs."""
    from tdicam.chain.cosim import system_figures
    p = design.chain_plan(_scene())
    st = {"nuc_ddr_calib_loaded": 1, "nuc_ddr_calib_loaded_1": 1, "startup_cycles": 1505,
          "ddr_writes": 36, "ddr_reads": 96, "ddr_stalls": 64, "ddr_error": 0,
          "ddr_writes_1": 36, "ddr_reads_1": 96, "ddr_stalls_1": 64, "ddr_error_1": 1}
    for k in ("bad_blocks", "corrected_words", "uncorrectable_words", "calib_error"):
        st.update({f"nuc_ddr_{k}": 0, f"nuc_ddr_{k}_1": 0})
    lines = {r["name"]: r for r in system_figures(p, {"status_outputs": st, "cycles": 9000})}
    assert lines["shared DDR traffic, channel 0"]["value"] == 132
    assert "12 of them the coefficient frame" in lines["shared DDR traffic, channel 1"]["text"]
    assert "MIG model ERROR" in lines["shared DDR traffic, channel 1"]["text"]
    assert "ERROR" not in lines["shared DDR traffic, channel 0"]["text"]
    assert lines["calibration load, channel 1"]["text"].startswith(
        "NUC calibration channel 1: loaded")
    assert lines["start-up cycles"]["value"] == 1505


def test_the_full_camera_plans_its_coefficients_in_ddr():
    """scenes/ning2019_gmax0504_full.toml (all 5144 columns; an area camera: one-row
    frames) with memory = "ddr": the top's two DDR interfaces carry both users, the
    coefficient image (3800 lines: coefficients = "frame") above the reset row; at the 8
    pixels a clock its plan asks the NAND load's one pixel's coefficients a beat are widened
    to the chain's 8 (the plan and the top at ppc 8; its Verilog:
    test_the_system_scene_at_8_pixels_a_clock_elaborates)."""
    full = ROOT / "scenes" / "ning2019_gmax0504_full.toml"
    sc = load_scene(full)
    p = design.chain_plan(sc)
    # the sensor's 80 lanes ([sensor.lvds]) first, the chain's source
    assert [s.block for s in p.steps][:3] == ["lvds", "cds_ddr", "nuc_ddr"]
    assert p.width == 5144 and p.steps[0].params["lanes"] == 80
    assert p.steps[2].device                       # the NAND part, as the scene's
    # per pixel: a coefficient line a sensor row of the whole frame (the frames one row)
    assert (p.steps[2].params["rows"], p.steps[2].params["image_rows"]) == (1, 3800)
    cds, nuc = p.steps[1:3]
    assert nuc.params["base"] == design.uses()["cds_ddr"].memory.ddr_end(cds) > 0
    top = _members(design.top(p))
    assert top["ddr_app_en_1"] == "Out" and "cds_ddr_app_en" not in top
    p8 = design.chain_plan(sc, ppc=8)
    assert p8.ppc == 8 and p8.steps[2].block == "nuc_ddr" and p8.steps[2].device
    assert p8.steps[2].params["ppc"] == 8


@pytest.mark.parametrize("ppc", PPC_CHOICES[1:])
def test_the_nand_load_widens_to_the_chain_s_pixels_per_clock(ppc):
    """At ppc 2, 4 and 8 the NAND store (one pixel's (gain, offset) a beat) feeds nuc_ddr's
    coefficient frame through the chain's widen (a Widener and its register slice, per
    lane); the top elaborates (co-simulation at ppc 8: cocotb_tests/test_system_ddr.py).
    At ppc 1 there is none (the top as before)."""
    from amaranth.hdl import Fragment
    p = design.chain_plan(_scene(run={"lines": 3, "rtl": {"pixels_per_clock": ppc}}))
    assert p.ppc == ppc and p.steps[1].block == "nuc_ddr" and p.steps[1].device
    names = _subfragments(Fragment.get(design.top(p), None))
    for lane in (0, 1):
        assert {f"nuc_ddr_widen{lane}", f"nuc_ddr_widen{lane}_slice"} <= names
    one = _subfragments(Fragment.get(design.top(design.chain_plan(_scene())), None))
    assert not any(n.startswith("nuc_ddr_widen") for n in one)


@pytest.mark.parametrize("ppc", [1, 8])
def test_a_register_slice_follows_each_ddr_block_above_1_pixel_a_clock(ppc):
    """At ppc >= 2 each lane's cds_ddr and nuc_ddr hand their output on through a register
    slice, so hdr's input ready stops there instead of running through both DDR blocks'
    handshakes into cds_ddr's read launch (the whole camera's slowest path at ppc 8); at
    ppc 1 neither has one (the top as it was)."""
    from amaranth.hdl import Fragment
    p = design.chain_plan(_scene(run={"lines": 3, "rtl": {"pixels_per_clock": ppc}}))
    assert p.ppc == ppc and [s.block for s in p.steps[:2]] == ["cds_ddr", "nuc_ddr"]
    names = _subfragments(Fragment.get(design.top(p), None))
    slices = {f"{b}_{lane}_slice" for b in ("cds_ddr", "nuc_ddr") for lane in (0, 1)}
    assert slices <= names if ppc > 1 else not slices & names
    assert {"cds_ddr_0", "nuc_ddr_1"} <= names


def _subfragments(frag):
    """The last names of every subfragment of ``frag``, at any depth."""
    names = set()

    def walk(f):
        for sub, name, *_ in f.subfragments:
            names.add(name)
            walk(sub)
    walk(frag)
    return names


def test_the_system_scene_at_8_pixels_a_clock_elaborates(tmp_path):
    """``tdicam verilog pipeline --scene scenes/ning2019_gmax0504_system_ddr.toml --ppc 8``
    (its NAND load at 8 pixels a clock) writes the top, with each lane's widener."""
    from tdicam.cli import main
    out = tmp_path / "system_ddr_p8.v"
    assert main(["verilog", "pipeline", "--no-csr", "--scene", str(SCENE), "--ppc", "8",
                 "-o", str(out)]) == 0
    text = out.read_text()
    assert "module pipeline" in text and "nuc_ddr_widen1_slice" in text


@pytest.mark.filterwarnings("ignore:.*created but never used")   # tops inspected only
def test_the_synthesis_top_multiplies_nuc_ddr_in_dsp_blocks_with_their_registers():
    """``tdicam synth pipeline`` places each lane's nuc_ddr multipliers as MULT18X18D with
    their own input registers (``dsp="ecp5"``, as nuc's and hdr's ECP5 tops); before, a
    fabric register through a bare MULT18X18D into a fabric register was the whole camera
    chain's slowest path on one seed (8.13 ns). The plain top (every simulation) keeps the
    generic ``*``."""
    from amaranth.back import rtlil
    p = design.chain_plan(_scene(run={"lines": 3, "rtl": {"pixels_per_clock": 2}}))
    block = design.PipelineBlock(p, None)
    ecp5, plain = rtlil.convert(block.build(ecp5=True)), rtlil.convert(block.build())
    # 2 gain channels x 2 pixels a clock in nuc_ddr, beside hdr's own (ECP5 top in both)
    nuc = [ln for ln in ecp5.split("\nmodule ") if "nuc_ddr" in ln.split("\n", 1)[0]
           and "cell \\MULT18X18D" in ln]
    assert sum(m.count("cell \\MULT18X18D") for m in nuc) == 2 * 2
    assert 'parameter \\REG_INPUTA_CLK "CLK0"' in "".join(nuc)
    assert not any("nuc_ddr" in ln.split("\n", 1)[0] and "MULT18X18D" in ln
                   for ln in plain.split("\nmodule "))
