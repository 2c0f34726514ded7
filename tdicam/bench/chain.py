"""A scene's chain as one design, timed: a scene's whole pipeline top in fast-mode co-simulation.

:func:`pipeline_run` makes a scene's raw frames (one exact run of the scene simulator), runs
them through the golden chain and through the generated pipeline top
(:mod:`tdicam.chain.design`, :func:`tdicam.chain.cosim.run_top`), and compares the output bit
for bit;
:func:`pipeline_rows` turns that into ``tdicam bench pipeline`` rows (``golden`` and one
``<sim> fast`` row per simulator). Used by ``tdicam bench pipeline`` and
``bench/bench_pipeline.py``.
"""

import os
import time

from tdicam.bench.util import row
from tdicam.paths import SCENES

__all__ = ["PIPELINE_SCENE", "QUICK_SCENE", "TARGET_PX_S", "PPCS", "pipeline_run",
           "pipeline_rows", "legend"]

#: The bundled scene ``tdicam bench pipeline`` runs: the 600 km / 1 m / 96-stage orbit
#: camera of Qu et al. 2010 with its chain nuc -> tdi -> median3 (1280 columns, 32 output
#: lines: 127 frames x 96 x 1280).
PIPELINE_SCENE = SCENES / "orbit_chain.toml"
#: Pixels per clock of the top, one row each per simulator (side by side).
PPCS = (1, 8)
#: ``--quick``: the Ning et al. 2019 chain (cds -> nuc -> hdr -> tdi -> median3, 256 columns,
#: 8 stages), 8 output lines (the orbit scene's 96 stages need 103 frames before 8 lines)
QUICK_SCENE = SCENES / "ning2019_chain.toml"
#: Input pixels per wall second through the whole chain after the build at the widest of
#: :data:`PPCS` (the target).
TARGET_PX_S = 8_000_000
_QUICK_LINES = 8


def pipeline_run(scene=PIPELINE_SCENE, *, sim="verilator", lines=None, taps=False,
                 idle=0.0, backpressure=0.0, seed=1, ppc=None):
    """One whole-chain run of ``scene`` (a path) on ``sim``.

    Parameters
    ----------
    lines : int or None
        Output lines (default: the scene's ``[run].lines``).
    taps : bool
        Also write every block's output (slower; the mismatch search uses them).
    idle, backpressure : float
        Probability of an idle input cycle / of output backpressure per cycle.
    ppc : int or None
        Pixels per clock of the top (default: the scene's ``[run.rtl].pixels_per_clock``,
        else 1).

    Returns
    -------
    dict
        ``chain`` (blocks in order), ``frames``, ``rows``, ``width``, ``ppc``,
        ``input_pixels``,
        ``cycles``, ``compared`` (output pixels), ``mismatches`` (output beats whose data or
        frame markers differ, plus any missing or extra), seconds of ``scene_s`` (exact
        scene run), ``golden_s`` (numpy chain), ``build_s`` (0 when the build was cached),
        ``run_s`` (simulator wall time), ``cpu_s`` (the simulator process's CPU time,
        build excluded) and ``load`` (the 1-minute load average after the run).
    """
    from tdicam.chain import design
    from tdicam.beats import frames_to_beats
    from tdicam.chain.cosim import beats_differ, run_top, scene_data
    from tdicam.scene.loader import load_scene

    sc = load_scene(scene)
    m = int(sc.tdi.stages[0])
    lines = int(lines or sc.run.lines)
    p = design.chain_plan(sc, stages=m, lines=lines, ppc=ppc)
    t = time.perf_counter()
    data, _ = scene_data(sc, stages=m, dv_over_v=float(sc.motion.dv_over_v[0]), lines=lines)
    scene_s = time.perf_counter() - t
    t = time.perf_counter()
    gold = design.golden(p, data)
    golden_s = time.perf_counter() - t
    got, info = run_top(p, data, sim, taps=taps, idle=idle, backpressure=backpressure,
                        seed=seed)
    exp = frames_to_beats(gold[-1][2], ppc=design.out_ppc(p))
    out = got["out"]
    n = min(len(out), len(exp))
    bad = int(beats_differ(out, exp).sum()) + abs(len(out) - len(exp))
    return {"chain": [s.block for s in p.steps], "frames": p.frames, "rows": p.stages,
            "width": p.width, "ppc": p.ppc, "lanes": p.lanes, "lane_elems": p.lane_elems,
            "input_pixels": p.input_pixels * p.lane_elems, "cycles": int(info["cycles"]),
            "compared": n * out.data.shape[1], "mismatches": bad, "scene_s": scene_s,
            "golden_s": golden_s, "build_s": info["build_seconds"],
            "run_s": info["run_seconds"], "cpu_s": info["run_cpu_seconds"],
            "load": os.getloadavg()[0]}


def pipeline_rows(*, sims, repeat, quick, stalls, build):
    """``tdicam bench pipeline``: the orbit chain scene's whole chain, golden and fast
    co-simulation at each of :data:`PPCS` pixels per clock (one run each, ``repeat`` not
    used; ``build_s`` is the run's own build, 0 when cached, whatever ``build`` says; Icarus
    only with ``--quick``, which runs 8 output lines of :data:`QUICK_SCENE` instead: the
    whole orbit chain scene is 15.6 M input pixels)."""
    lines = _QUICK_LINES if quick else None
    rows, gold = [], None
    for sim in sims:
        if sim == "icarus" and not quick:
            rows.append(row("pipeline", "icarus fast", "pixel", 0, None, accuracy="n/a",
                            note="whole scene on Icarus: too slow; run with --quick"))
            continue
        for ppc in PPCS:
            gold = _sim_row(rows, gold, sim, ppc, quick, lines, stalls)
    return rows


def _sim_row(rows, gold, sim, ppc, quick, lines, stalls):
    """Append the ``<sim> fast ppc <n>`` row (and the golden row first); returns it."""
    r = pipeline_run(QUICK_SCENE if quick else PIPELINE_SCENE, sim=sim, lines=lines,
                     idle=stalls, backpressure=stalls, ppc=ppc)
    n = r["input_pixels"]
    judged = ppc == max(PPCS)
    what = (f"{' -> '.join(r['chain'])}, {r['frames']} frames x {r['rows']} x "
            f"{r['width']}")
    if gold is None:
        gold = row("pipeline", "golden", "pixel", n, r["golden_s"], input=f"{n:,} px",
                   accuracy="reference", x_ref=1.0, note=what)
        rows.insert(0, gold)
    rate = n / r["run_s"]
    target = (f"target {TARGET_PX_S:,} px/s {'met' if rate >= TARGET_PX_S else 'not met'}"
              if judged else f"target judged at ppc {max(PPCS)}")
    rows.append(row("pipeline", f"{sim} fast ppc {ppc}", "pixel", n, r["run_s"],
                    input=f"{n:,} px", build_s=r["build_s"], mismatches=r["mismatches"],
                    accuracy="bit-exact" if r["mismatches"] == 0
                    else f"{r['mismatches']} mismatching",
                    note=f"{r['cycles']:,} cycles; {n / max(r['cpu_s'], 1e-9):,.0f} px "
                    f"per simulator CPU s; load {r['load']:.1f}; {target}"
                    + (f" (quick scene, {r['cycles']:,} cycles: start-up dominates; "
                       "the target is for the whole orbit chain scene)" if quick
                       else " (whole scene)")))
    return gold


def legend(*, stalls, quick):
    """What the ``pipeline`` rows of :func:`pipeline_rows` mean (lines under the table)."""
    what = (f"{_QUICK_LINES} output lines of {QUICK_SCENE.name}" if quick
            else f"the whole {PIPELINE_SCENE.name} scene")
    what += f", through the top at {' and '.join(map(str, PPCS))} pixels per clock"
    return (f"pipeline rows: {what}, its raw frames through the numpy golden chain (golden) "
            f"and through the generated camera top in fast-mode co-simulation with "
            f"{stalls:.0%} idle and {stalls:.0%} backpressure; each row is one run (median s "
            f"= that run's seconds, --repeat not used), compared bit for bit with the golden "
            f"chain. Simulator rows: wall time of the simulator run incl. start-up and "
            f"stimulus load (Verilator: the standalone binary, no cocotb); the build is "
            f"timed apart (build s: that run's own build, 0.0 = cached build reused). throughput = input pixels per wall second; note: cycles, "
            f"input pixels per CPU second of the simulator process, the 1-minute load "
            f"average after the run, and the target of "
            f"{TARGET_PX_S:,} input pixels per wall second on the whole orbit chain scene at "
            f"ppc {max(PPCS)}.")
