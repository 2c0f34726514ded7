"""The frame selector before the output links (:class:`tdicam.hdl.frame_select.FrameSelect`)
equals its golden model (:func:`tdicam.model.frame_select.select`): a hypothesis property
drawing ``K``, the frames an image, small frames and random idle cycles and backpressure,
in Amaranth's simulator; the ratio check of ``[camera]``."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tdicam.beats import frames_to_beats
from tdicam.cosim.streamsim import run_stream_component
from tdicam.cosim.testing import FULL
from tdicam.errors import TdicamError
from tdicam.hdl.frame_select import FrameSelect
from tdicam.model import frame_select


def _expected(frames, g, keep, ppc):
    """The golden images as beats: ``first`` on each image's first beat."""
    imgs = frame_select.select(frames, image_frames=g, keep=keep)
    rows = [frames_to_beats(im[None], ppc=ppc) for im in imgs]
    return [(list(map(int, b.data[j])), bool(b.first[j]), bool(b.last[j]))
            for b in rows for j in range(len(b))]


def _run(frames, g, keep, ppc, seed, p_valid, p_ready):
    stim = frames_to_beats(frames, ppc=ppc)
    want = _expected(frames, g, keep, ppc)
    dut = FrameSelect(bits=12, count=ppc, keep=keep, image_frames=g)
    out, _, _ = run_stream_component(dut, stim, len(want), seed=seed, p_valid=p_valid,
                                     p_ready=p_ready, latency_from=None, drain=20)
    got = [(list(r) if isinstance(r, list) else [r], f, la) for r, f, la in out]
    return got, want


@settings(max_examples=200 if FULL else 25, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(keep=st.integers(1, 6), g=st.integers(1, 4), n=st.integers(1, 14),
       rows=st.integers(1, 2), ppc=st.sampled_from([1, 2, 8]), seed=st.integers(1, 2**20),
       p_valid=st.sampled_from([1.0, 0.7, 0.3]), p_ready=st.sampled_from([1.0, 0.6, 0.2]),
       full=st.booleans())
def test_gateware_equals_golden_property(keep, g, n, rows, ppc, seed, p_valid, p_ready, full):
    rng = np.random.default_rng(seed)
    w = 2 * ppc
    frames = np.full((n, rows, w), 4095) if full else rng.integers(0, 4096, (n, rows, w))
    got, want = _run(frames, g, keep, ppc, seed, p_valid, p_ready)
    assert got == want


def test_a_mutant_selector_is_caught():
    """The check can fail: keeping the second image of each K instead of the first."""
    frames = np.arange(6 * 4).reshape(6, 1, 4) % 4096
    got, want = _run(frames, 1, 3, 2, 1, 1.0, 1.0)
    assert got == want
    shifted = _expected(frames[1:], 1, 3, 2)
    assert shifted != want


@pytest.mark.parametrize("fps, out, k", [(25, 5, 5), (25, 25, 1), (30, 7.5, 4)])
def test_keep_every_is_the_ratio(fps, out, k):
    assert frame_select.keep_every(fps, out) == k


def test_a_non_integer_ratio_is_refused_in_one_line():
    with pytest.raises(TdicamError, match=r"25 / 10 = 2.5 is not a whole number") as e:
        frame_select.keep_every(25, 10)
    assert "\n" not in str(e.value)


def test_images_of_the_last_partial_image():
    frames = np.arange(5 * 1 * 2).reshape(5, 1, 2)
    imgs = frame_select.images(frames, 2)
    assert [im.shape for im in imgs] == [(2, 2), (2, 2), (1, 2)]
    assert [im[0, 0] for im in frame_select.select(frames, image_frames=2, keep=2)] == [0, 8]


# ---- the scene key: [pipeline].output

FULL_SCENE = "ning2019_gmax0504_full.toml"


def _load(name, **over):
    from tdicam.paths import SCENES
    from tdicam.scene.loader import load_scene
    return load_scene(SCENES / name, overrides=over)


def test_the_whole_camera_ends_in_its_links():
    from tdicam.chain import design
    sc = _load(FULL_SCENE, run={"lines": 8}, sensor={"columns": 40})
    assert sc.pipeline.output == "links"
    p = design.chain_plan(sc, stages=1, lines=8, ppc=8)
    lk = p.links
    assert (lk.links, lk.pixel_bits, lk.clock_mhz, lk.keep) == (2, 16, 100.0, 5)
    assert (lk.image_rows, lk.frame_rows) == (8, 8)      # median3 frames the cut's lines


def test_output_links_needs_camera_and_a_whole_ratio():
    with pytest.raises(TdicamError, match=r"\[pipeline\]\.output: 'links' .* give a "
                                          r"\[camera\] section"):
        _load("orbit_chain.toml", pipeline={"output": "links"})
    with pytest.raises(TdicamError, match="2.5 is not a whole number"):
        _load(FULL_SCENE, camera={"output_frame_rate_hz": 10.0})
    with pytest.raises(TdicamError, match="did you mean 'links'"):
        _load(FULL_SCENE, pipeline={"output": "link"})


def test_a_scene_without_the_key_is_as_before():
    """The default is the pixel stream, absent from the scene's dict (reports unchanged),
    and its plan has no links."""
    from tdicam.chain import design
    sc = _load("orbit_chain.toml")
    assert sc.pipeline.output == "stream" and "output" not in sc.to_dict()["pipeline"]
    assert design.chain_plan(sc).links is None


def test_links_narrower_than_the_chain_s_pixels_are_refused_in_one_line():
    from tdicam.chain import design
    sc = _load(FULL_SCENE, run={"lines": 8}, sensor={"columns": 40},
               camera={"link_pixel_bits": 12})
    with pytest.raises(TdicamError, match=r"output is 1\d-bit pixels, \[camera\]"
                                          r"\.link_pixel_bits = 12 would drop bits") as e:
        design.chain_plan(sc, stages=1, lines=8, ppc=8)
    assert "\n" not in str(e.value)
