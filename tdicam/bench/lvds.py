"""The ``lvds`` benchmark: LVDS bit training is not a video stream, so the block entry names
this runner (:data:`tdicam.bench.suite.HARNESS_RUNNERS`) instead of a stream workload."""

import numpy as np

from tdicam import blocks
from tdicam.bench.build import build_seconds
from tdicam.bench.util import median_time, na_row, row
from tdicam.cosim.lvds import check_run, run_amaranth, run_link, testbench
from tdicam.hw.verilog import convert
from tdicam.model import lvds

__all__ = ["rows"]


def rows(*, sims, repeat, quick, stalls, build):
    """The ``lvds`` benchmark rows: a random link of lanes trained by the golden model, by
    the receiver in Amaranth's simulator (one DUT's worth of lanes) and by its Verilog on
    each simulator (HDL-driven link; no per-beat level). ``stalls`` does not apply."""
    n, n_check = (8, 4) if quick else (32, 16)
    rng = np.random.default_rng(1)
    link = lvds.Link([lvds.random_lane(rng, max_word_delay=1) for _ in range(n)])
    cycles = lvds.training_words(10, n_check, 8) + 8
    t, gold = median_time(lambda: lvds.run(link, cycles=cycles, n_check=n_check), repeat)
    name, inp = "lvds", f"{n} lanes, training (n_check {n_check})"
    params = blocks.get("lvds").resolve({"phy": "none"})
    out = [row(name, "golden", "lane", n, t, input=inp, accuracy="reference", x_ref=1.0)]
    # the Python simulator trains the first group of lanes (a prefix of the same link)
    k = params["lanes"]
    part = lvds.Link(link.lanes[:k])
    gold_k = lvds.run(part, cycles=cycles, n_check=n_check)
    res = [_pysim(part, cycles, n_check, params) for _ in range(repeat)]
    bad = max(len(set(ev) ^ set(gold_k.events)) for ev, _ in res)
    out.append(row(name, "pysim", "lane", k, float(np.median([w for _, w in res])),
                     input=f"{k} lanes, training (n_check {n_check})",
                     accuracy="bit-exact" if bad == 0 else f"{bad} status events differ",
                     mismatches=bad))

    def sources():
        top = blocks.get("lvds").build(params)
        return {"lvds.v": convert(top, "lvds"), "tb.v": testbench(top)[0]}

    for sim in sims:
        out.append(na_row(name, f"{sim} beat", "lane", "HDL-driven link only"))
        res = [run_link(link, cycles=cycles, n_check=n_check, sim=sim)
               for _ in range(repeat)]
        bad = [len(check_run(link, r, gold, cycles=cycles)) for r in res]
        acc = "bit-exact" if max(bad) == 0 else f"{max(bad)} lanes/segments differ"
        out.append(row(name, f"{sim} fast", "lane", n,
                         float(np.median([r.wall for r in res])), input=inp, accuracy=acc,
                         mismatches=max(bad),
                         build_s=build_seconds(res[0].build_time, build, "lvds", params, sim,
                                          sources)))
    return out


def _pysim(link, cycles, n_check, params):
    """Train ``link`` (one DUT's worth of lanes) on :class:`~tdicam.hdl.lvds.LvdsRx` in
    Amaranth's simulator: (status events as the golden model lists them, wall seconds)."""
    events, _, seconds = run_amaranth(link, cycles, n_check=n_check, settle=params["settle"],
                                   min_run=params["min_run"], pick=params["pick"])
    return events, seconds
