"""The scene pipeline as one design (no simulator): plan, golden chain against the scene
simulator, composed latency, deterministic lint-clean Verilog, one-line errors for
pipelines the hardware cannot build."""

import gc
import tomllib
from pathlib import Path

import numpy as np
import pytest

from tdicam import blocks
from tdicam.chain import design
from tdicam.errors import TdicamError
from tdicam.hw.lint import lint
from tdicam.model.chain import GoldenStage, chain
from tdicam.chain.cosim import scene_data
from tdicam.scene.loader import Ddr, load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[1]
CHAIN = ROOT / "scenes" / "ning2019_chain.toml"


def _small(path=CHAIN, **over):
    o = {"sensor": {"columns": 24}, "run": {"lines": 6}}
    for k, v in over.items():
        o.setdefault(k, {}).update(v)
    return load_scene(path, overrides=o)


def test_plan_of_the_ning2019_chain():
    p = design.chain_plan(_small())
    assert [s.block for s in p.steps] == ["cds", "nuc", "hdr", "tdi", "median3"]
    assert (p.lanes, p.lane_elems, p.in_bits) == (2, 2, 10)
    assert (p.stages, p.width, p.frames, p.lines) == (8, 24, 13, 6)
    by = {s.block: s for s in p.steps}
    assert by["tdi"].params["pixel_bits"] == 13          # the HDR output width
    assert by["tdi"].ports == {"stages_active": 8, "direction": 0}
    assert by["median3"].params["enhance"] is True
    assert by["median3"].group == 6 and by["median3"].ports == {"height": 6}
    for s in p.steps:                                    # every step is a valid block build
        blocks.get(s.block).resolve(s.params)


def test_golden_chain_equals_the_scene_simulator():
    sc = _small()
    p = design.chain_plan(sc)
    data, res = scene_data(sc, stages=8, dv_over_v=0.0, lines=6)
    gold = design.golden(p, data)
    assert [g[0] for g in gold] == ["cds_0", "cds_1", "nuc_0", "nuc_1", "hdr", "tdi",
                                    "median3"]
    assert gold[0][2].shape == (13, 8, 24) and gold[5][2].shape == (6, 1, 24)
    out = gold[-1][2].reshape(res.output.shape)
    assert out.dtype == np.uint16
    np.testing.assert_array_equal(out, res.output)


def test_top_latency_is_the_sum_of_the_blocks_and_taps_match_the_golden_stages():
    sc = _small()
    p = design.chain_plan(sc)
    ax = design.top(p, taps=True)
    core = ax.core
    ax._MustUse__silence = core._MustUse__silence = True   # inspected, not elaborated
    assert ax.latency == core.latency == sum(cs[0].latency for cs in core.cores) + 1
    # cds nuc hdr tdi median3+enhance, and the register slice after tdi (its FIFO read)
    assert core.latency == 1 + 3 + 4 + 9 + 31 + 1
    names = [t[0] for t in core.tap_shapes]
    data, _ = scene_data(sc, stages=8, dv_over_v=0.0, lines=6)
    assert names == [g[0] for g in design.golden(p, data)]


def test_verilog_is_deterministic_and_lint_clean(tmp_path):
    p = design.chain_plan(_small())
    a, b = design.verilog(p), design.verilog(p)
    assert a == b and "module pipeline" in a and str(ROOT) not in a
    f = tmp_path / "camera.v"
    f.write_text(a)
    assert lint(f) == []


def test_verilog_command(tmp_path, capsys):
    from tdicam.cli import main
    out = tmp_path / "camera.v"
    assert main(["verilog", "pipeline", "--scene", str(CHAIN), "-o", str(out)]) == 0
    assert "cds -> nuc -> hdr -> tdi -> median3" in capsys.readouterr().err
    assert "s_axis_tdata" in out.read_text() and "tap0_cds" not in out.read_text()
    assert main(["verilog", "pipeline"]) != 0            # no --scene: one-line error


def test_plan_and_top_at_every_ppc():
    """Every block up to TDI at the plan's ppc (the scene's [run.rtl].pixels_per_clock or
    the ``ppc`` argument), the median after TDI's 8 stages at 1 (8 times fewer pixels a
    second), a width converter before it; at ppc 1 the steps' parameters are those of
    before (only tdi states its ppc); the top's streams and taps carry each stage's ppc
    pixels a beat; the Verilog at ppc 1 equals the scene's default top."""
    sc = _small()
    p1 = design.chain_plan(sc)
    assert p1.ppc == 1 and [s.params.get("ppc") for s in p1.steps] == [None] * 3 + [1, None]
    assert design.chain_plan(sc, ppc=1) == p1
    assert design.chain_plan(_small(run={"rtl": {"pixels_per_clock": 4}})).ppc == 4
    for ppc in (2, 4, 8):
        p = design.chain_plan(sc, ppc=ppc)
        assert p.ppc == ppc and [s.params.get("ppc") for s in p.steps] == [ppc] * 4 + [None]
        assert [s.block for s in p.steps] == [s.block for s in p1.steps]
        assert design.out_ppc(p) == 1 and design.chain_text(p) == (
            f"cds -> nuc -> hdr -> tdi ({ppc} pixels per clock) -> {ppc}:1 width converter "
            f"-> median3 (1 pixel per clock)")
        ax = design.top(p, taps=True)
        core = ax.core
        ax._MustUse__silence = core._MustUse__silence = True   # inspected, not elaborated
        # 2 lanes x (signal, reset) per pixel in; one median pixel out
        assert (ax._in[1], ax._out[1]) == (4 * ppc, 1)
        assert [c for _, _, c in core.tap_shapes] == [ppc] * 6 + [1]  # one pixel each
        assert core.stage_ppc == [ppc] * 4 + [1]
        assert all(cs[0].i_stream.payload.data.shape().length % ppc == 0
                   for cs in core.cores[:-1])
    assert design.verilog(design.chain_plan(sc, ppc=1)) == design.verilog(p1)


def test_orbit_chain_scene_plans_at_8_pixels_per_clock():
    """scenes/orbit_chain.toml: Qu et al. 2010's orbit design point (1280 columns x 96
    stages) with nuc -> tdi -> median3, nuc and tdi at its [run.rtl] 8 pixels per clock,
    median3 at 1 after a width converter,
    NUC coefficients through the ECC calibration reader, TDI saturated at 16 bits."""
    sc = load_scene(ROOT / "scenes" / "orbit_chain.toml")
    assert sc.run.rtl.pixels_per_clock == 8 and sc.pipeline.nuc.ecc is True
    p = design.chain_plan(sc)
    assert (p.ppc, p.width, p.stages, p.lanes) == (8, 1280, 96, 1)
    assert [(s.block, s.params.get("ppc", 1)) for s in p.steps] == [
        ("nuc", 8), ("tdi", 8), ("median3", 1)]               # 96 stages: 96 x fewer pixels
    by = {s.block: s for s in p.steps}
    assert by["tdi"].params["out_bits"] == 16 and by["median3"].params["pixel_bits"] == 16
    assert by["tdi"].params["stages"] == 96 and by["median3"].group == sc.run.lines


@pytest.mark.parametrize("ppc, width, stages, msg", [
    (3, 24, None, r"^pipeline: pixels per clock = 3 is not valid; valid: 1, 2, 4, 8$"),
    (8, 20, None, r"^pipeline: pixels per clock = 8: the width 20 is not a multiple of it$"),
    (8, 16, 1, r"^pipeline: tdi -> median3: width \(ppc = 8\) = 16 is out of range; "
               r"valid: 24"),
])
def test_impossible_ppc_gives_one_line_errors(ppc, width, stages, msg):
    with pytest.raises(TdicamError, match=msg) as exc:
        design.chain_plan(_small(sensor={"columns": width}), ppc=ppc, stages=stages)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("stages, ppc, median_ppc", [(1, 8, 8), (2, 8, 4), (4, 8, 2),
                                                     (8, 8, 1), (3, 4, 2), (96, 2, 1)])
def test_a_block_after_tdi_gets_the_pixels_per_clock_of_its_rate(stages, ppc, median_ppc):
    """The median after TDI of ``stages`` gets ``stages`` times fewer pixels a second: it is
    built at ``ppc / stages`` rounded up to 1, 2, 4 or 8 (never fewer than carry the
    input's full rate), a width converter before it when that is fewer than ``ppc``."""
    p = design.chain_plan(_small(), ppc=ppc, stages=stages)
    assert [design.step_ppc(s) for s in p.steps] == [ppc] * 4 + [median_ppc]
    assert median_ppc * stages >= ppc and (median_ppc == 1 or median_ppc * stages < 2 * ppc)
    assert ("width converter" in design.chain_text(p)) == (median_ppc < ppc)
    ax = design.top(p)
    ax._MustUse__silence = ax.core._MustUse__silence = True
    assert ax._out[1] == median_ppc and ax.core.stage_ppc[-1] == median_ppc


def test_ppc_options_of_the_pipeline_commands(tmp_path, capsys):
    """``--ppc`` on ``tdicam verilog pipeline``: the top at that ppc; a bad value or one
    that does not divide the width is a one-line error naming the flag and both values."""
    from tdicam.cli import main
    out = tmp_path / "camera.v"
    assert main(["verilog", "pipeline", "--scene", str(CHAIN), "--ppc", "8", "-o",
                 str(out)]) == 0
    assert ("tdi (8 pixels per clock) -> 8:1 width converter -> median3 (1 pixel per "
            "clock)") in capsys.readouterr().err
    head = out.read_text().splitlines()[2:7]          # every block up to TDI at ppc 8
    assert len(head) == 5 and all(h.endswith(", ppc=8") for h in head[:4]), head
    assert "ppc=" not in head[4], head
    assert main(["verilog", "pipeline", "--scene", str(CHAIN), "--ppc", "3"]) == 2
    assert "--ppc = 3 is not valid; valid: 1, 2, 4, 8" in capsys.readouterr().err
    sc = _small(sensor={"columns": 20})
    with pytest.raises(TdicamError, match=r"^--ppc = 8: the width 20 is not a multiple of it$"):
        design.check_options(sc, ppc=8)
    design.check_options(sc, ppc=4)


@pytest.mark.parametrize("ppc", [1, 4])
def test_register_slice_passes_every_beat_once_at_full_rate(ppc):
    """The register slice between stages (a skid buffer at ppc 1, a 2-beat FIFO at ppc >=
    2): with random idle cycles and backpressure every beat comes out once, in order,
    markers kept; with neither, one beat a clock after a latency of 1 cycle."""
    from amaranth.hdl import Module
    from amaranth.lib import wiring
    from amaranth.lib.wiring import In, Out
    from tdicam.cosim.codec import Beats
    from tdicam.cosim.streamsim import run_stream_component
    from tdicam.hdl.chain_links import Link, register_slice
    from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature

    class Slice(wiring.Component):
        i_stream: In(pixel_signature(channels_shape(12, 4)))
        o_stream: Out(pixel_signature(channels_shape(12, 4)))

        def elaborate(self, platform):
            m = Module()
            i = self.i_stream
            link = Link(i.valid, i.ready, i.payload.first, i.payload.last,
                        [i.payload.data[k] for k in range(4)], 12)
            register_slice(m, link, "s", ppc).feed(m, self.o_stream, who="test")
            return m

    rng = np.random.default_rng(5)
    n = 300
    stim = Beats(rng.integers(0, 1 << 12, (n, 4)).astype(np.uint64),
                 np.arange(n) % 40 == 0, np.arange(n) % 8 == 7)
    for p, seed in ((0.6, 1), (0.9, 2), (0.3, 3)):
        got, _, _ = run_stream_component(Slice(), stim, n, seed=seed, p_valid=p, p_ready=p,
                                         latency_from=None, drain=20)
        assert [r for r, _, _ in got] == stim.data.astype(int).tolist()
        assert [f for _, f, _ in got] == stim.first.tolist()
        assert [la for _, _, la in got] == stim.last.tolist()
    got, lat, final = run_stream_component(Slice(), stim, n, p_valid=1.0, p_ready=1.0)
    assert lat == [1] and final["cycles"] <= n + 2


def test_chain_model_groups_and_merges():
    """The golden chain on its own: lanes merged by a merging stage, frames grouped."""
    a = np.arange(2 * 3 * 4).reshape(2, 3, 4)
    st = [GoldenStage("sum", lambda arrs, lane: arrs[0] + arrs[1], merge=True),
          GoldenStage("g", lambda arrs, lane: arrs[0] * 2, group=2)]
    out = chain([[a], [a + 1]], st)
    np.testing.assert_array_equal(out[0][1][0], 2 * a + 1)
    np.testing.assert_array_equal(out[1][1][0], (4 * a + 2).reshape(1, 6, 4))
    with pytest.raises(TdicamError, match="whole number of groups of 4"):
        chain([[a]], [GoldenStage("g", lambda arrs, lane: arrs[0], group=4)])


@pytest.mark.parametrize("blocks_, over, msg", [
    (["tdi", "cds"], {}, r"^pipeline: cds acts on single exposures and cannot follow tdi"),
    (["tdi", "lvds"], {}, r"^pipeline: block 'lvds' has no gateware stage"),
    (["hdr", "tdi"], {"sensor": {"gains": [1.0]}},
     r"^pipeline: input -> hdr: pipeline: hdr merges two gain channels"),
    # the scene without hdr (with it the scene itself refuses 14-bit pixels into hdr -> tdi)
    (["hdr", "tdi"], {"sensor": {"bits": 14}, "pipeline": {
        "blocks": ["tdi"], "cds": None, "nuc": None, "hdr": None, "median3": None}},
     r"^pipeline: hdr -> tdi: .*pixel.bits.* out of range"),
    (["tdi", "median3"], {"tdi": {"output": "full"}, "sensor": {"bits": 14}, "pipeline": {
        "blocks": ["tdi"], "cds": None, "nuc": None, "hdr": None, "median3": None}},
     r"^pipeline: tdi -> median3: .*pixel.bits.* out of range"),
])
def test_impossible_pipelines_give_one_line_errors(blocks_, over, msg):
    sc = _small(**over)
    with pytest.raises(TdicamError, match=msg) as exc:
        design.chain_plan(sc, blocks=blocks_)
    assert "\n" not in str(exc.value)


def test_synthesis_top_uses_each_blocks_ecp5_top():
    """``tdicam synth pipeline`` places each block's ECP5 top where it has one (the TDI
    stage's DP16KD banks, one read stage more; the NUC calibration ROM's banks as DP16KD
    with their contents as INITVAL, off the pixels' path); the plain top (``tdicam verilog
    pipeline``, every simulation) keeps the generic descriptions."""
    from tdicam.hw.verilog import rtlil
    p = design.chain_plan(_small())
    block = design.PipelineBlock(p, None)
    ecp5, plain = block.build(ecp5=True), block.build()
    assert ecp5.latency == plain.latency + 1
    text = rtlil(ecp5, "pipeline")
    assert "DP16KD" in text and "DP16KD" not in rtlil(plain, "pipeline")
    assert "rom_bank0_0" in text and "INITVAL_00" in text     # the ROM of lane 0


@pytest.mark.filterwarnings("ignore:.*created but never used")   # top inspected only
def test_spill_to_ddr_is_planned_when_the_memory_does_not_fit():
    sc = load_scene(ROOT / "scenes" / "orbit_4096_ddr_spill.toml")
    p = design.chain_plan(sc)
    assert [s.block for s in p.steps] == ["tdi_ddr"]          # 7.39 Mbit > 3.83 Mbit
    ax = design.top(p)
    assert ax.latency is None                                 # DDR: variable
    del ax
    gc.collect()                       # its "never used" warnings, filtered, fire here
    assert [s.block for s in design.chain_plan(sc, spill=False).steps] == ["tdi"]
    assert [s.block for s in design.chain_plan(sc, device="xc7k325t").steps] == ["tdi"]
    with pytest.raises(TdicamError, match=r"^pipeline: a DDR spill was asked but no block "
                                          r"of cds -> nuc -> hdr keeps its memory in DDR"):
        design.chain_plan(_small(), blocks=["cds", "nuc", "hdr"], spill=True)


def test_a_spill_needs_a_ddr_section():
    """[pipeline.tdi].memory says where TDI's partial sums live; a spill goes through the
    scene's [ddr] interface, and without one the plan fails in one line naming both the
    block and its DDR variant."""
    data = tomllib.loads((ROOT / "scenes" / "orbit_4096_ddr_spill.toml").read_text())
    sc = scene_from_dict(data)
    assert sc.ddr == Ddr(interface="mig", base=0) and sc.pipeline.tdi.memory == "auto"
    del data["ddr"]
    with pytest.raises(TdicamError, match=r"^pipeline: input -> tdi: its partial sums "
                       r"\(7393280 bits\) exceed the ecp5-85f's on-chip RAM \(3833856 bits\): "
                       r"it spills to DDR through tdi_ddr, but the scene has no \[ddr\] "
                       r"section") as exc:
        design.chain_plan(scene_from_dict(data))
    assert "\n" not in str(exc.value)
    data["pipeline"]["tdi"] = {"memory": "chip"}              # on chip: no DDR needed
    assert [s.block for s in design.chain_plan(scene_from_dict(data)).steps] == ["tdi"]
    # memory = 'ddr' without [ddr]: the scene loader refuses it, before any plan or run
    with pytest.raises(TdicamError, match=r"^\[pipeline.tdi\].memory = 'ddr' keeps its "
                       r"partial sums in DDR, but the scene has no \[ddr\] section"):
        _small(pipeline={"tdi": {"memory": "ddr"}})
    sc = _small(pipeline={"tdi": {"memory": "ddr"}}, ddr={"base": 4096},
                sensor={"columns": 160})            # tdi_ddr: more than 148 beats a row
    p = design.chain_plan(sc)
    assert [s.block for s in p.steps] == ["cds", "nuc", "hdr", "tdi_ddr", "median3"]
    assert p.steps[3].params["base"] == 4096
    # --memory auto
    assert [s.block for s in design.chain_plan(sc, spill="auto").steps][3] == "tdi"


@pytest.mark.parametrize("over, msg", [
    ({"ddr": {"base": 12}}, r"^\[ddr\].base: must be a multiple of 8"),
    ({"ddr": {"interface": "axi"}}, r"^\[ddr\].interface: must be one of 'mig'"),
    ({"ddr": {"clock": 1}}, r"^\[ddr\].clock: unknown key"),
    ({"pipeline": {"tdi": {"memory": "sram"}}}, r"^\[pipeline.tdi\].memory: must be one of"),
])
def test_ddr_section_is_checked(over, msg):
    with pytest.raises(TdicamError, match=msg):
        _small(**over)


def test_charge_domain_and_impossible_pixels_per_clock_are_refused():
    """A chain the whole-chain top cannot build is refused: charge-domain TDI by the plan;
    with [run.rtl], charge domain and a pixels per clock the top does not take or that
    does not divide the width already by the scene."""
    sc = load_scene(ROOT / "scenes" / "zhou2008_interline_ccd_charge_4.toml")
    with pytest.raises(TdicamError, match="charge"):
        design.chain_plan(sc)
    with pytest.raises(TdicamError, match=r"^\[run.rtl\].pixels_per_clock: must be one of "
                                          r"1, 2, 4, 8, got 3$"):
        _small(run={"rtl": {"pixels_per_clock": 3}})
    with pytest.raises(TdicamError, match=r"^\[run.rtl\].pixels_per_clock: 8 does not divide "
                                          r"the \[sensor\].columns 20"):
        _small(sensor={"columns": 20}, run={"rtl": {"pixels_per_clock": 8}})
    with pytest.raises(TdicamError, match=r"^\[run.rtl\]: needs \[tdi\].domain = 'digital'"):
        load_scene(ROOT / "scenes" / "zhou2008_interline_ccd_charge_4.toml",
                   overrides={"run": {"rtl": {}}})
    sc = _small(run={"rtl": {"pixels_per_clock": 1}})
    assert sc.pipeline.after_lines("median3") is True and design.chain_plan(sc).steps


@pytest.mark.parametrize("n, bank", [(11, 4), (8, 4), (3, 2048), (1, 2048)])
def test_calibration_rom_streams_its_words_again_and_again_under_backpressure(n, bank):
    """CalibRom (banked, the bank reads registered, a register slice after the select):
    with random backpressure every beat comes out once, in order, wrapping to the first
    after the last (several banks, a partly used last one, one bank, one beat); with a
    ready sink, one beat a clock after the pipeline fills."""
    from amaranth.sim import Simulator
    from tdicam.hdl.calib_rom import CalibRom

    rng = np.random.default_rng(n)
    words = rng.integers(0, 256, (2 * n, 9)).tolist()
    beats = [int.from_bytes(bytes(words[k] + words[k + 1]), "little")
             for k in range(0, 2 * n, 2)]

    class Rom(CalibRom):
        BANK = bank

    for p_ready in (0.4, 1.0):
        dut = Rom(words, per_beat=2)
        got, cycles = [], []

        async def bench(ctx):
            o = dut.o_stream
            for cyc in range(6 * n + 40):
                ready = int(rng.random() < p_ready)
                ctx.set(o.ready, ready)
                await ctx.delay(1e-9)
                if ctx.get(o.valid) and ready:
                    got.append(ctx.get(o.payload.data.as_value()))
                    cycles.append(cyc)
                await ctx.tick()

        sim = Simulator(dut)
        sim.add_clock(1e-8)
        sim.add_testbench(bench)
        sim.run()
        assert len(got) > 2 * n
        assert got == [beats[k % n] for k in range(len(got))]
        if p_ready == 1.0:
            assert cycles[0] == 3 and np.all(np.diff(cycles) == 1)
