"""A pipeline top that ends in the camera's output links (``[pipeline].output = "links"``)
when its input is the sensor's lanes (``[sensor.lvds]``): the lanes' cocotb testbench
(:mod:`tdicam.simtb.system_lanes_tb`) with the third clock, ``link_clk`` at the scene's
``[camera].link_clock_mhz``, the links' words compared with the golden chain's output
through the frame selector and ``model.tlk2711``, and decoded back into the image. The
stream-input form is cocotb_tests/test_camera_full.py."""

from dataclasses import replace

import numpy as np

from tdicam.chain import design
from tdicam.chain.cosim import cosimulate, scene_data
from tdicam.model import tlk2711
from tdicam.paths import SCENES
from tdicam.scene.loader import load_scene

LANES = SCENES / "ning2019_gmax0504_system_lanes.toml"


def test_the_lanes_top_with_links_matches_on_icarus():
    """The system scene from its lanes (a 16-column, 3-stage, 2-line cut, as
    cocotb_tests/test_system.py) with 2 links and K = 1 (every image sent: the cut's one)."""
    sc = load_scene(LANES, overrides={
        "sensor": {"columns": 16}, "tdi": {"stages": 3}, "pipeline": {"output": "links"},
        "camera": {"frame_rate_hz": 25.0, "output_frame_rate_hz": 25.0},
        "run": {"lines": 2, "rtl": {"crop": None}}})
    p = design.chain_plan(sc)
    p = replace(p, steps=tuple(replace(s, device={**s.device, "blocks": 16}) if s.device
                               else s for s in p.steps))
    assert p.links.keep == 1 and p.links.links == 2
    data, _ = scene_data(sc, stages=3, dv_over_v=0.0, lines=2)
    rep = cosimulate(p, data, "icarus", front={"word_ns": 40.0})
    assert rep["mismatches"] == 0 and not rep["timeout"], rep["message"]
    assert all(t["mismatches"] == 0 and t["received"] == t["beats"] > 0 for t in rep["taps"])
    assert rep["words_compared"] == 2 * design.link_word_count(p) > 0
    got = tlk2711.decode(rep["link_words"], width=16, pixel_bits=16, links=2)
    want = design.golden(p, data)[-1][2]
    assert len(got.frames) == len(want)
    assert all(np.array_equal(g, w) for g, w in zip(got.frames, want))
