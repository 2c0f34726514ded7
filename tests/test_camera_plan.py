"""The camera budget of ``tdicam plan`` (tdicam.planning.camera) on the whole camera of Ning
et al. 2019 (scenes/ning2019_gmax0504_full.toml): its arithmetic against figures worked out
here by hand from the paper's numbers, the table in the command's output and its JSON, the
limiting part, the paper's configuration's answer on per-pixel NUC of both gains at
25 frame/s, bad ``[camera]`` keys refused with one line, and a crop of the scene through the
golden chain."""

import json
import math
import subprocess
import sys

import pytest

from tdicam.errors import TdicamError
from tdicam.model.ddr_efficiency import MEASURED_EFFICIENCY, PLAN_MARGIN, SHARED_EFFICIENCY
from tdicam.planning.camera import camera_plan
from tdicam.scene.loader import load_scene

SCENE = "scenes/ning2019_gmax0504_full.toml"

# the paper's numbers (Ning et al. 2019 §3.1, §3.2, §4.2, §4.3, §5)
COLS, ROWS, FPS, GAINS = 5144, 3800, 25, 2
LANES_PER_GAIN, LANE_BPS, WORD_BITS = 40, 300e6, 12
PIXEL_BITS, COEFF_BITS, UI_BITS = 10, 16, 256


def _plan(**camera):
    sc = load_scene(SCENE, overrides={"camera": camera} if camera else None)
    return camera_plan(sc)


def _rows(budget):
    return {r["name"]: r for r in budget["rows"]}


@pytest.fixture(scope="module")
def plan():
    return _plan()


def test_a_shared_interface_is_planned_at_the_arbiter_s_measured_order(plan):
    """The coefficient reads beside the reset frames and the frame buffer's lines (one
    DdrArbiter a channel): the arbiter's figure, the lower of the memory model's and
    LiteDRAM's (SHARED_EFFICIENCY, the fixture's: tests/test_ddr_arbiter.py) less the plan
    margin; the coefficients alone on the interface (the reset frame on chip):
    cds_ddr_wide's."""
    row = _rows(plan["scene"])["DDR interface"]
    low = min(SHARED_EFFICIENCY)
    assert plan["scene"]["ddr_efficiency"] == pytest.approx(low / 100 - PLAN_MARGIN)
    assert "DdrArbiter's shared order" in row["text"] and f"measured {low:g} %" in row["text"]
    sc = load_scene(SCENE, overrides={"pipeline": {"cds": {"memory": "chip"}}})
    alone = camera_plan(sc)["scene"]
    assert alone["ddr_efficiency"] == pytest.approx(
        min(MEASURED_EFFICIENCY["cds_ddr_wide"]) / 100 - PLAN_MARGIN)
    assert "cds_ddr_wide" in _rows(alone)["DDR interface"]["text"]


def test_lanes_and_samples_by_hand(plan):
    rows = _rows(plan["paper"])
    # 80 lanes x 300 Mbit/s = 24 Gbit/s
    assert rows["lanes"]["available"] == pytest.approx(80 * 300e6)
    # a lane: 5144 / 40 = 128.6 -> 129 pixel words (24 lanes full, 16 padded) + sync + header
    words_a_lane_line = 129 + 2
    need = 80 * words_a_lane_line * WORD_BITS * ROWS * 2 * FPS   # reset + signal frames
    assert rows["lanes"]["need"] == pytest.approx(need)
    assert rows["lanes"]["frame_rate_limit"] == pytest.approx(
        LANE_BPS / WORD_BITS / (2 * ROWS * words_a_lane_line))
    # 5144 x 3800 x 25 x 2 frames = 977.36 M samples a gain a second
    assert plan["paper"]["samples_per_gain_s"] == 5144 * 3800 * 25 * 2 == 977_360_000
    # at the paper's 100 MHz even 8 pixels a clock fall short; the scene's 200 MHz needs 8
    assert rows["processing"]["available"] == 800e6 and not rows["processing"]["ok"]
    assert plan["scene"]["ppc"] == 8
    assert _rows(plan["scene"])["processing"]["available"] == 1600e6


def test_ddr_traffic_by_hand(plan):
    # both users on an interface (behind the top's DdrArbiter): the arbiter's measured order
    eff = min(SHARED_EFFICIENCY) / 100 - PLAN_MARGIN
    # a coefficient line: gain + offset of 5144 pixels, 16 bits each, 16 a 256-bit word
    coeff_line = math.ceil(COLS * 2 * COEFF_BITS / UI_BITS)
    # a reset line: 24 10-bit pixels a 256-bit word (Table 2)
    reset_line = math.ceil(COLS / 24)
    assert (coeff_line, reset_line) == (643, 215)
    # one gain an interface: its coefficients read, its reset frame written and read back
    bits_a_s = (coeff_line + 2 * reset_line) * ROWS * UI_BITS * FPS
    assert bits_a_s == pytest.approx(26.095e9, rel=1e-4)
    # the frame buffer before the links (25 frame/s read, the links carry 10.21): an image
    # line of 5144 16-bit pixels is 322 words, written at 25 frame/s and read at the links'
    # pace, shared by the 2 interfaces
    link_fps = 100e6 / (4 + ROWS * (4 + COLS // 2 + 2))
    image_line = math.ceil(COLS * 16 / UI_BITS)
    assert image_line == 322
    image = image_line * ROWS * UI_BITS * (FPS + link_fps) / 2
    assert image == pytest.approx(5.514e9, rel=1e-3)
    paper = _rows(plan["paper"])["DDR interface"]
    assert paper["need"] == pytest.approx(bits_a_s + image)
    # (built: the scene's top has it before its links, tdicam.chain.design.link_plan)
    assert plan["paper"]["frame_buffer"] == {"line_words": 322, "images": 1, "built": True}
    # the frame rate it reads: the per-frame words at F, the image read at the links' pace
    per_frame = (coeff_line + 2 * reset_line) * ROWS * UI_BITS + image_line * ROWS * UI_BITS / 2
    assert paper["frame_rate_limit"] == pytest.approx(
        (256 * 100e6 * eff - image_line * ROWS * UI_BITS * link_fps / 2) / per_frame)
    # the paper's MIG: 256 bit x 100 MHz (the 1600 MT/s x 32-bit pins would give twice it)
    assert paper["available"] == pytest.approx(256 * 100e6 * eff)
    assert not paper["ok"] and plan["paper_ddr_ok"] is False
    scene = _rows(plan["scene"])["DDR interface"]
    assert scene["available"] == pytest.approx(256 * 200e6 * eff) and scene["ok"]
    opts = {o["option"]: o for o in plan["options"]}
    # with the frame buffer beside them, fewer coefficient bits or NUC after the merge no
    # longer fit the paper's 17.69 Gbit/s; a faster user clock or more interfaces do
    assert {n for n, o in opts.items() if o["ok"]} == {
        "DDR user clock 200 MHz (1600 MT/s at 4:1)", "4 interfaces (8 SDRAMs x16)"}
    # 8-bit coefficients halve the coefficient words: 322 a line
    assert opts["8-bit coefficients"]["need_bps"] == pytest.approx(
        (math.ceil(COLS * 2 * 8 / UI_BITS) + 2 * reset_line) * ROWS * UI_BITS * FPS + image)
    # after the HDR merge: one coefficient image over the 2 interfaces
    assert opts["NUC after the HDR merge (one channel)"]["need_bps"] == pytest.approx(
        (coeff_line + 2 * 2 * reset_line) * ROWS * UI_BITS * FPS / 2 + image)
    assert opts["4 interfaces (8 SDRAMs x16)"]["need_bps"] == pytest.approx(
        (bits_a_s + image) / 2)


def test_reset_frame_on_chip_leaves_the_coefficients():
    """cds keeping the reset frame on chip: the DDR moves the coefficients only (643 words
    a line, one gain an interface); the sensor still sends the reset frames."""
    b = _plan()
    sc = load_scene(SCENE, overrides={"pipeline": {"cds": {"memory": "chip"}}})
    chip = camera_plan(sc)["scene"]
    words = dict(chip["ddr_words_per_frame"])
    image_write, image_read = words.pop("image write"), words.pop("image read")
    assert words == {"coefficients": 2 * ROWS * 643, "reset write": 0, "reset read": 0}
    assert image_write == ROWS * 322
    assert _rows(chip)["DDR interface"]["need"] == pytest.approx(
        (ROWS * 643 + (image_write + image_read) / 2) * UI_BITS * FPS)
    assert chip["samples_per_gain_s"] == b["scene"]["samples_per_gain_s"]


def test_nand_and_links_by_hand(plan):
    # NAND: 2 pixels (4 coefficients) a 72-bit word, 227 words a 2048-byte page (9 bytes
    # each), 64 pages a block, t_R 25 us at the controller's 50 MHz = 1250 clocks
    words = math.ceil(COLS * ROWS / 2) + 4
    pages = math.ceil(words / (2048 // 9))
    blocks = math.ceil(pages / 64)
    load = pages * (14 + 1250) + words * 18 + blocks * 2 + 1
    scan = 3 + 1250 + 4096 * (14 + 1250 + 2)
    nand = _rows(plan["paper"])["NAND load"]
    assert nand["seconds"] == pytest.approx((scan + 2 * load) / 50e6)   # one part, 2 gains
    assert nand["need"] == 2 * blocks
    # links: 2 x 16 bit x 100 MHz = 3.2 Gbit/s; a link sends half a row: header 4, 2572
    # 16-bit pixels, trailer 2, a frame header of 4
    links = _rows(plan["paper"])["output links"]
    per_frame = 4 + ROWS * (4 + COLS // 2 + 2)
    assert links["available"] == pytest.approx(100e6 / per_frame)
    assert links["available"] == pytest.approx(10.21, abs=0.005)


def test_limiting_part(plan):
    sb, pb = plan["scene"], plan["paper"]
    assert sb["feasible"] and sb["limiter"] == "output links"
    assert sb["sustained_hz"] == pytest.approx(_rows(sb)["output links"]["available"])
    assert sb["read_limiter"] == "lanes" and sb["read_limit_hz"] >= FPS
    assert pb["read_limiter"] == "DDR interface" and pb["read_limit_hz"] < FPS
    assert set(pb["infeasible"]) == {"processing", "DDR interface"}
    for r in pb["rows"]:
        assert (r["fix"] is None) == r["ok"]


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "tdicam", *args], capture_output=True,
                          text=True)


def test_cli_table_and_json():
    r = _cli("plan", "--scene", SCENE)
    # the budget fits; the verdict is the synthesis record's: the split camera's chain
    # device (119.1 MHz at ppc 8, 953 M samples/s) does not reach the 977 M samples/s a gain
    assert r.returncode == 1, r.stderr
    out = r.stdout
    for name in ("lanes", "processing", "DDR interface", "DDR capacity", "NAND load",
                 "output links"):
        assert f"\n  {name} " in out
    assert "limited by the output links" in out
    assert "per-pixel NUC of both gains at 25 frame/s in the paper's DDR: does NOT fit" in out
    assert "feasible: NO (chain pixel rate (synthesis record))" in out
    assert "needs 977.4 M pixel/s (a gain channel's samples at [camera].frame_rate_hz)" in out
    j = _cli("plan", "--scene", SCENE, "--json")
    rep = json.loads(j.stdout)
    assert rep["camera"]["scene"]["limiter"] == "output links"
    assert rep["camera"]["paper_ddr_ok"] is False and rep["camera"]["scene"]["feasible"]
    assert rep["feasible"] is False and rep["design"]["gateware"]["chain_ok"] is False
    # the camera on the recorded silicon: the split's slower device sets the frame rate read
    si = rep["camera"]["silicon"]
    parts = {r["part"]: r for r in si["rows"]}
    chain, front = parts["chain"], parts["front"]
    assert set(parts) == {"front", "chain"}
    assert chain["pixel_rate"] == pytest.approx(chain["fmax_mhz"] * 1e6 * chain["ppc"])
    # the front device against a line from the lanes: 5144 columns in 131 word clocks of 25 MHz
    assert front["need"] == pytest.approx(5144 * 25e6 / 131) and front["meets"]
    assert si["read_limit_hz"] == pytest.approx(chain["pixel_rate"] / (2 * COLS * ROWS))
    assert si["read_limiter"] == "chain device"
    assert si["ok"] is (chain["pixel_rate"] >= 2 * COLS * ROWS * FPS) is False
    assert ("on the synthesis record's ECP5-85F (the front device " in out
            and f"reads up to {si['read_limit_hz']:.2f} frame/s (limited by the "
                "chain device): NO at 25 frame/s" in out)


def test_infeasible_says_no():
    """The paper's DDR in the scene: the verdict says NO and names the part."""
    sc = load_scene(SCENE, overrides={"camera": {"ddr_user_clock_mhz": 100.0}})
    from tdicam.planning.sizing import plan_report
    rep = plan_report([sc])
    assert not rep["feasible"] and "camera DDR interface" in rep["infeasible"]


@pytest.mark.parametrize("camera, msg", [
    ({"coeff_bits": 3}, r"^\[camera\]\.coeff_bits"),
    ({"nuc": "after"}, r"^\[camera\]\.nuc"),
    ({"links": 3}, r"^\[camera\]\.links"),
    ({"ddr_lanes": 2}, r"^\[camera\].*ddr_lanes"),
    ({"output_frame_rate_hz": 30.0}, r"^\[camera\]\.output_frame_rate_hz: 30 is above"),
    ({"clock_mhz": "fast"}, r"^\[camera\]\.clock_mhz: must be a number"),
    ({"frame_rate_hz": 30.0}, r"^\[camera\]\.frame_rate_hz: 30 is above the sensor's 25"),
])
def test_bad_keys(camera, msg):
    with pytest.raises(TdicamError, match=msg) as e:
        load_scene(SCENE, overrides={"camera": camera})
    assert "\n" not in str(e.value)


def test_frame_rate_needed():
    with pytest.raises(TdicamError, match=r"^\[camera\]\.frame_rate_hz: missing"):
        load_scene(SCENE, overrides={"sensor": {"max_frame_rate_hz": None}})


def test_cli_bad_key_exit_2(tmp_path):
    text = open(SCENE).read().replace("[camera]\n", "[camera]\ncoeff_bits = 40\n")
    p = tmp_path / "bad.toml"
    p.write_text(text)
    r = _cli("plan", "--scene", str(p))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "coeff_bits" in r.stderr


def test_crop_runs():
    """The whole frame is a benchmark's job; a 48-column, 16-line crop through the golden
    chain (cds with reset frames, nuc from NAND, hdr, median3)."""
    from tdicam import api
    sc = load_scene(SCENE, overrides={"sensor": {"columns": 48}, "run": {"lines": 16}})
    sim = api.simulate(sc, impact=False)
    assert sim.dataset["tdi"].shape == (16, 48)


def test_lanes_from_the_scene_and_other_plans_unchanged():
    """A [sensor.lvds] section gives the lane row its lanes (the 256-column window: 2 lanes
    a gain, 128 columns each, no padding); a scene without [camera] has no camera entry."""
    sc = load_scene("scenes/ning2019_gmax0504_system_lanes.toml",
                    overrides={"camera": {"frame_rate_hz": 25.0}})
    lanes = _rows(camera_plan(sc)["scene"])["lanes"]
    assert lanes["available"] == 4 * LANE_BPS
    assert lanes["need"] == pytest.approx(4 * (128 + 2) * WORD_BITS * ROWS * 2 * 25)
    from tdicam.planning.sizing import plan_report
    rep = plan_report([load_scene("scenes/ning2019_gmax0504_system_lanes.toml")])
    assert "camera" not in rep


def test_the_full_scene_starts_from_its_80_lanes_and_its_lane_rows_agree():
    """The full scene's [sensor.lvds] (40 lanes a gain, 5144 columns: 129 words a lane, 16
    padded slots a gain) makes the front the chain's source, and the system plan's lane
    pixel rate is the lane model's: 2 gains x 5144 columns every 131 word clocks (a padded
    slot carries no pixel), the camera budget's row the same 131 words a lane."""
    from tdicam.chain import design
    from tdicam.model import lvds_front
    from tdicam.planning.sizing import system_plan
    sc = load_scene(SCENE)
    lv = sc.sensor.lvds
    assert (lv.lanes_per_gain, lv.word_bits, lv.bit_rate_mbps) == (40, 12, 300.0)
    p = design.chain_plan(sc, ppc=8, lines=4)
    assert p.steps[0].block == "lvds"
    assert {k: p.steps[0].params[k] for k in ("lanes", "lanes_per_gain", "columns")} == \
        {"lanes": 80, "lanes_per_gain": 40, "columns": 5144}
    assert lvds_front.line_words(5144, 40) == 131 and lvds_front.padded_slots(5144, 40) == 16
    word_hz = 300e6 / 12
    rows = system_plan(sc, {"stages": 1, "line_period_s": 1e-3}, ddr_bits=256,
                       ddr_clock_hz=100e6)
    rate = next(r for r in rows if r["name"] == "lane pixel rate")
    assert rate["value"] == pytest.approx(2 * 5144 * word_hz / 131)
    assert "16 padded slot(s) a gain" in rate["text"]
    budget = _rows(camera_plan(sc)["scene"])["lanes"]
    assert budget["need"] == pytest.approx(80 * 131 * 12 * ROWS * 2 * FPS)


def test_frame_buffer_only_when_the_links_are_slower():
    """No image waits when the links carry the sensor's frames (a 1280-column window at
    5 frame/s); 5144 columns at 25 frame/s: one image of 322-word lines, written a frame,
    read at the links' 10.21 frame/s."""
    from tdicam.model.physics.camera import frame_buffer_words
    assert frame_buffer_words(1280, 1024, pixel_bits=16, frame_rate_hz=5.0,
                              output_frame_rate_hz=5.0, link_frame_rate_hz=40.0) == (0, 0, 0, 0)
    line, write, read, images = frame_buffer_words(
        COLS, ROWS, pixel_bits=16, frame_rate_hz=25.0, output_frame_rate_hz=5.0,
        link_frame_rate_hz=10.21)
    assert (line, write, images) == (322, 322 * ROWS, 1)
    assert read == pytest.approx(write * 10.21 / 25)
    sc = load_scene(SCENE, overrides={"camera": {"frame_rate_hz": 10.0,
                                                 "output_frame_rate_hz": 10.0}})
    assert camera_plan(sc)["scene"]["frame_buffer"] is None


def test_the_top_buffers_its_images_where_the_links_are_slower():
    """At full width a kept row on the 2 links (2,578 words at 100 MHz, 25.78 us) is slower
    than the lanes' next reset and signal line (2 x 131 words of 40 ns, 10.48 us) and the
    links carry 10.2 whole frames a second against the sensor's 25: the top has a DDR
    frame buffer of the cut's rows before them (the frame-rate budget's one image), and so
    does the chain part from the pixels. The 40-column cut on 16 lanes a gain (26 words,
    0.26 us against 2 x 5 x 40 ns) keeps up: no buffer, its top as before. The 48-column
    cut on 24 lanes a gain with 80 MHz links (30 words, 0.375 us against 2 x 4 x 40 ns)
    carries the frames but not the lines: one image of room from the lanes' rule alone."""
    from tdicam.bench.camera import _cut_scene, camera_cut
    from tdicam.chain import design
    from tdicam.model.tlk2711 import line_words
    from tdicam.chain.link_rates import link_buffer_images, link_times, links_keep_up
    assert line_words(5144, links=2) == 2578 and line_words(40, links=2) == 26
    assert line_words(48, links=2) == 30
    full, narrow = _cut_scene(8)[0], _cut_scene(8, 40, 16)[0]
    slow = _cut_scene(8, 48, 24, link_clock_mhz=80.0)[0]
    assert link_times(full) == pytest.approx((2578 / 100, 2 * 131 * 0.04))
    assert link_times(narrow) == pytest.approx((26 / 100, 2 * 5 * 0.04))
    assert link_times(slow) == pytest.approx((30 / 80, 2 * 4 * 0.04))
    assert (links_keep_up(full), link_buffer_images(full)) == (False, 1)
    assert (links_keep_up(narrow), link_buffer_images(narrow)) == (True, 0)
    assert (links_keep_up(slow), link_buffer_images(slow)) == (False, 0)
    assert camera_cut(8, links=False)[0].links is None
    assert camera_cut(8)[0].links.buffer_rows == 8
    assert camera_cut(16)[0].links.buffer_rows == 16
    assert camera_cut(8, columns=40, lanes_per_gain=16, nand_blocks=16)[0].links.buffer_rows == 0
    assert camera_cut(8, columns=48, lanes_per_gain=24, nand_blocks=16,
                      link_clock_mhz=80.0)[0].links.buffer_rows == 8
    assert design.chain_plan(full, lines=8, part="chain").links.buffer_rows == 8
    assert design.chain_plan(slow, lines=8, part="chain").links.buffer_rows == 0


def test_the_tops_frame_buffer_shares_the_gains_ddr_interfaces():
    """The whole camera's top (the chain device, 8 rows of the full width): the frame
    buffer's rows dealt to the two gains' DDR interfaces, each behind the interface's
    arbiter after nuc_ddr and cds_ddr, from above their regions: the plan's even share of
    the buffer on each of the scene's ddr_interfaces is what the top does; no MIG user
    interface of its own. A top with no DDR block gives its buffer one (and a MIG model on
    the co-simulation board)."""
    from tdicam.bench.camera import _cut_scene
    from tdicam.blocks.steps import LinkPlan
    from tdicam.chain import design
    from tdicam.hdl.chain_board import Board
    from tdicam.hdl.chain_top import Pipeline
    from tdicam.model.ddr import ADDR_PER_WORD
    full = _cut_scene(8)[0]
    p = design.chain_plan(full, lines=8, part="chain")
    pipe = _pipeline_of(design.top(p))
    assert pipe.shared_ddr == {k: ["cds_ddr", "nuc_ddr", "frame_buffer"] for k in (0, 1)}
    assert [b.rows for b in pipe.frame_buffers] == [4, 4] and pipe.own_frame_buffers == []
    assert not any(n.startswith("frame_buffer_app") for n in pipe.signature.members)
    assert {"ddr_app_addr", "ddr_app_addr_1"} <= set(pipe.signature.members)
    ends = [design._use(s.block).memory.ddr_end(s) for s in p.steps
            if design._use(s.block).memory.ddr_end is not None]
    assert p.links.buffer_base == max(ends) > 0
    # the board's shared model holds the buffer's rows too
    board = Board(pipe)
    deep = {k: dev.model.depth_words for st, k, dev in board._devices if st.name == "ddr"}
    fb_end = pipe.frame_buffers[0].layout.end_addr(4) // ADDR_PER_WORD
    assert deep[0] >= fb_end and deep[1] >= fb_end
    # no DDR block: the buffer on a MIG user interface (and model) of its own
    lone = Pipeline([], in_bits=16, ppc=8, width=40, links=LinkPlan(
        links=2, pixel_bits=16, clock_mhz=100.0, keep=1, image_rows=4, frame_rows=4,
        buffer_rows=4))
    assert lone.shared_ddr == {} and len(lone.own_frame_buffers) == 1 and lone.has_devices()
    assert "frame_buffer_ddr_writes" in Board(lone).signature.members


def _pipeline_of(top):
    """The :class:`~tdicam.hdl.chain_top.Pipeline` inside a generated top."""
    from tdicam.hdl.chain_top import Pipeline
    seen = top
    while not isinstance(seen, Pipeline):
        seen = getattr(seen, "_core", None) or getattr(seen, "core", None) or seen._top
    return seen
