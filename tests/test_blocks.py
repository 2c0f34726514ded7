"""The block registry's contract: every stream block's scene-array adapters agree with its
golden function, and the registry holds one block per module."""

import importlib

import numpy as np
import pytest

from tdicam import blocks
from tdicam.errors import TdicamError

#: (frame shape, parameters) of a small scene-array run per stream block (the entries')
SMALL = {b.name: b.streams.small for b in blocks.all_blocks() if b.streams.to_beats is not None}


def test_one_block_per_module():
    for blk in blocks.all_blocks():
        mod = importlib.import_module(f"tdicam.blocks.{blk.name}")
        assert mod.BLOCK is blk and not hasattr(mod, "BLOCKS")


def test_every_stream_block_states_its_scene_contract():
    for name in SMALL:
        b = blocks.get(name)
        st = b.streams
        assert st.stream and st.golden and st.example and st.small, name


@pytest.mark.parametrize("name", sorted(SMALL))
def test_scene_arrays_round_trip(name):
    """example -> golden equals example -> case arrays -> expected beats -> from_beats,
    whole arrays with dtypes."""
    b = blocks.get(name)
    shape, given = SMALL[name]
    a = b.streams.example(np.random.default_rng(3), 3, shape, b.resolve(given))
    p = b.scene_params(a, given)
    want = b.run_golden(a, p)
    stim, exp = b.streams.to_beats(b.case_arrays(a, p), p)
    got = b.from_beats(exp, a, p)
    assert len(stim) > 0 and set(got) == set(want)
    for k in want:
        assert got[k].dtype == want[k].dtype and got[k].shape == want[k].shape, k
        np.testing.assert_array_equal(got[k], want[k])


def test_side_inputs_defaults_and_errors():
    hdr = blocks.get("hdr")
    a = hdr.streams.example(np.random.default_rng(1), 2, (4, 64), hdr.resolve())
    assert hdr.inputs(a)["gain_sel"].tolist() == [0, 0]
    with pytest.raises(TdicamError, match="needs input 'lg'"):
        hdr.inputs({"hg": a["hg"]})
    nuc = blocks.get("nuc")
    x = np.zeros((2, 3, 5), np.uint16)
    full = nuc.inputs({"x": x, "gain": np.full((3, 5), 1 << 14), "offset": 0})
    assert full["gain"].shape == x.shape and full["offset"].shape == x.shape
    with pytest.raises(TdicamError, match="input 'gain' has shape"):
        nuc.inputs({"x": x, "gain": np.zeros((4, 4)), "offset": 0})
    tdi = blocks.get("tdi")
    fr = np.zeros((5, 3, 16), np.uint16)
    assert tdi.scene_params({"frames": fr})["stages"] == 3
    assert tdi.scene_params({"frames": fr})["width"] == 16


def test_param_range_message():
    with pytest.raises(TdicamError, match=r"^--pixel-bits = 40 is out of range; valid: 8\.\.16$"):
        blocks.get("cds").resolve({"pixel_bits": 40})
    with pytest.raises(TdicamError, match="--pixel-bits must be an integer, got 'x'"):
        blocks.get("cds").resolve({"pixel_bits": "x"})
