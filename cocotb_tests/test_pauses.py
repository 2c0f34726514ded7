"""One idle/backpressure pattern: the same seed stalls the stream at the same cycles in
the Amaranth simulator, per-beat cocotb and the fast HDL engine (tdicam.cosim.pauses)."""

import numpy as np
import pytest

from tdicam import blocks, cosim
from tdicam.beats import frames_to_beats, mark_resets
from tdicam.cosim.pysim import run_pysim
from tdicam.model.cds import cds


def _stim():
    rng = np.random.default_rng(4)
    sig, rst = (rng.integers(0, 4096, (3, 4, 10)) for _ in range(2))
    stim = frames_to_beats(np.stack([sig, rst], -1), channels=2)
    exp = frames_to_beats(cds(sig, rst, pixel_bits=12))
    mark_resets(stim, exp, [57])          # a reset mid-frame: the same cycles too
    return stim, exp


@pytest.mark.parametrize("seed", [5, 6, 0x7654321])
def test_same_seed_same_stalls_in_every_driver(sim, seed):
    stim, exp = _stim()
    params = blocks.get("cds").resolve({"pixel_bits": 12})
    kw = {"idle": 0.4, "backpressure": 0.3, "seed": seed}
    ref = []
    out, _, _, _ = run_pysim("cds", params, stim, trace=ref, **kw)
    assert cosim.compare(out, exp).ok
    takes = [c for k, c in ref if k == "i"]
    assert len(takes) == len(stim) and len([k for k, _ in ref if k == "o"]) == len(out)
    # the pattern really stalls: input beats are not taken on consecutive cycles only
    assert takes[-1] - takes[0] > 1.3 * len(stim)
    for mode in cosim.MODES:
        res = cosim.run_stream("cds", params, stim, n_out=len(exp), sim=sim, mode=mode,
                               trace=True, **kw)
        assert cosim.compare(res.out, exp).ok, mode
        assert res.trace == ref, f"{sim} {mode}: transfer cycles differ from Amaranth's"
    other = []                            # the neighbour seed (2k <-> 2k + 1) stalls elsewhere
    run_pysim("cds", params, stim, trace=other, **{**kw, "seed": seed ^ 1})
    assert other != ref
