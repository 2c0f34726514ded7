"""Benchmark: DDR line/frame buffers (Ning et al. 2019 §4.2) — interface efficiency and simulation speed.

Table 1, interface efficiency under the default stall pattern of the controller model
(read latency 20..60 cycles, 44-cycle refresh every 780, each ready dropped with
probability 16/256): the frame buffer's MIG ports driven by the Python model in cocotb,
one frame written alone then read (data beats / cycles of each phase; Ning et al. 2019 reports
> 80 % at 100 MHz). Table 2, pixels/s of the golden packing and of fast-mode
co-simulation (HDL controller model inside the design) for the round trip, CDS with the
reset frame in DDR and TDI with partial sums in DDR, with the sustained rate in input
beats per clock (TDI on chip: 1 beat/clock).

Table 4 (``--arbiter``, needs the ``ddrref`` extra): the camera's shared DDR order, nuc_ddr's
coefficient reads beside cds_ddr's reset frame writes and reads and the output links' frame
buffer's line writes and reads behind one
:class:`~tdicam.hdl.ddr_arbiter.DdrArbiter` (:func:`tdicam.cosim.shared_ddr.camera_trace`,
recorded now), on the memory model and LiteDRAM, as Table 3's rows (``--fixture FILE``
writes tests/ddr_arbiter_litedram.json).

Table 3 (``--litedram``, needs the ``ddrref`` extra): the efficiency of every access
pattern of :data:`tdicam.model.ddr_traces.PATTERNS` and of every DDR block's recorded command order
(writer, reader, frame buffer, CDS reset frames at the line width and 4096 columns, TDI
spill at 1280 and 4096 columns) on the project's memory model
beside LiteDRAM's (:mod:`tdicam.cosim.litedram`: DDR3-800 MT41K256M16 x2, 100 MHz, row-bank-column,
timing checker on). Every figure is words moved over a steady-state window of 4 refresh
intervals (4 x 782 = 3128 cycles after a 100-cycle start-up,
:func:`tdicam.model.dram.window_efficiency`); each trace is as long as that window needs
(:func:`tdicam.model.ddr_traces.pattern_lines`, :func:`tdicam.cosim.litedram.block_traces`).
LiteDRAM's simulation runs some cycles per second (about 10 minutes per row on a loaded
machine): ``--patterns NAME,NAME`` replays only the patterns and blocks named (``--help``
lists them).

    python bench/bench_ddr.py [--quick] [--litedram [--patterns NAME,NAME] [--fixture FILE]]
    python bench/bench_ddr.py --arbiter [--fixture FILE]
"""

import argparse
import time

import numpy as np

from tdicam import blocks, cosim
from tdicam.bench.util import machine, print_table
from tdicam.cosim.ddr import run_ui_cosim
from tdicam.blocks.tdi import pack_ctrl, stream_arrays
from tdicam.cosim.codec import Beats, frames_to_beats
from tdicam.cosim.litedram import BLOCKS as DDR_BLOCKS
from tdicam.errors import TdicamError
from tdicam.model.ddr import LineLayout, pack_lines
from tdicam.model.ddr_traces import PATTERNS
from tdicam.model.tdi import tdi_stream


def efficiency(sims=cosim.SIMULATORS, quick=False):
    """Rows {config, sim, words, write_eff, read_eff, mem_ok, wall}."""
    out = []
    cfgs = [("1296 px x 10 bit, 24 px/beat", dict(width=1296, rows=8 if quick else 32,
                                                   ppc=24), sims),
            ("72 ch x 170 px (Table 2), 1 px/beat", dict(width=170, rows=4, channels=72,
                                                         line_stride=4096), ("verilator",))]
    for name, kw, ss in cfgs:
        for sim in ss:
            r = run_ui_cosim(sim=sim, seed=2, **kw)
            out.append({"config": name, "sim": sim, "words": r["words"],
                        "write_eff": 100 * r["write_eff"], "read_eff": 100 * r["read_eff"],
                        "mem_ok": r["mem_mismatches"] == 0 and r["data_ok"],
                        "wall": r["wall"]})
    return out


def _tdi(params, seq, seed=1):
    rng = np.random.default_rng(seed)
    settings = [(m, d) for m, d, n in seq for _ in range(n)]
    frames = [rng.integers(0, 1 << params["pixel_bits"], (m, params["width"]))
              for m, _ in settings]
    a = stream_arrays(frames, settings, params)
    want = tdi_stream(a["pixels"], a["first"], a["last"], a["stages_active"], a["direction"],
                      **{k: params[k] for k in ("width", "stages", "pixel_bits", "out_bits",
                                                "ppc")})
    stim = Beats(a["pixels"], a["first"], a["last"],
                 ctrl=pack_ctrl(a["stages_active"], a["direction"]))
    return stim, Beats(want.data, want.first, want.last)


def speed(sims=cosim.SIMULATORS, quick=False):
    """Rows {engine, mode, design, pixels, seconds, pixels_s, beats_per_clock, mismatches}."""
    out = []
    rng = np.random.default_rng(1)
    fr = rng.integers(0, 1024, (4, 1024, 1280))
    lay = LineLayout(width=1280)
    t0 = time.perf_counter()
    pack_lines(fr.reshape(-1, 1280), lay)
    t = time.perf_counter() - t0
    out.append({"engine": "numpy", "mode": "-", "design": "pack 1280x1024 10-bit",
                "pixels": fr.size, "seconds": t, "pixels_s": fr.size / t})
    runs = []
    for sim in sims:
        lines = 128 if (quick or sim == "icarus") else 1024
        p = blocks.get("ddr").resolve({"width": 1280, "rows": 64, "ppc": 8})
        f = rng.integers(0, 1024, (1, lines, 1280, 1))
        s = frames_to_beats(f, ppc=8)
        runs.append(("ddr", p, s, s, sim, f.size, f"round trip 1280x{lines}, 8 px/beat"))
        p = blocks.get("cds_ddr").resolve({"width": 512, "rows": 16, "pixel_bits": 10})
        arr = {"frames": rng.integers(0, 1024, (4, 16, 512)), "kinds": np.array([1, 0, 0, 0])}
        from tdicam.model.cds_ddr import cds_ddr_frames
        arr["out"] = cds_ddr_frames(arr["frames"], arr["kinds"], pixel_bits=10)
        st, ex = blocks.get("cds_ddr").streams.to_beats(arr, p)
        runs.append(("cds_ddr", p, st, ex, sim, arr["frames"].size, "CDS 512x16, reset in DDR"))
        p = blocks.get("tdi_ddr").resolve({"width": 512, "stages": 16})
        nfr = 18 if (quick or sim == "icarus") else 40
        st, ex = _tdi(p, [(16, 0, nfr)])
        runs.append(("tdi_ddr", p, st, ex, sim, len(st), f"TDI 512x16 DDR psums, {nfr} frames"))
        if sim == "verilator" and not quick:
            p = blocks.get("tdi_ddr").resolve({"width": 4096, "stages": 32, "ppc": 4})
            st, ex = _tdi(p, [(32, 0, 35)])
            runs.append(("tdi_ddr", p, st, ex, sim, 4 * len(st), "TDI 4096x32 ppc4 (spill)"))
    for block, p, st, ex, sim, pixels, name in runs:
        res = cosim.run_stream(block, p, st, n_out=len(ex), sim=sim, mode="fast", idle=0.0,
                               backpressure=0.0, seed=1)
        cmp = cosim.compare(res.out, ex)
        out.append({"engine": sim, "mode": "fast", "design": name, "pixels": pixels,
                    "seconds": res.wall, "pixels_s": pixels / res.wall,
                    "beats_per_clock": len(st) / max(res.cycles - 2000, 1),
                    "mismatches": cmp.mismatches, "build_s": res.build_time})
    return out


def select(text):
    """(patterns, blocks) named in ``text``, comma-separated names of
    :data:`tdicam.model.ddr_traces.PATTERNS` and :data:`tdicam.cosim.litedram.BLOCKS` in the order given;
    (None, None), every one, for None. An unknown name is a one-line
    :class:`~tdicam.errors.TdicamError` naming the valid ones."""
    if text is None:
        return None, None
    names = [n for n in dict.fromkeys(x.strip() for x in text.split(",")) if n]
    valid = [*PATTERNS, *DDR_BLOCKS]
    bad = next((n for n in names if n not in valid), None)
    if bad is not None or not names:
        what = "no name given" if bad is None else f"unknown name {bad!r}"
        raise TdicamError(f"--patterns: {what}; valid: {', '.join(valid)}")
    return [n for n in names if n in PATTERNS], [n for n in names if n in DDR_BLOCKS]


def litedram(patterns=None, blocks=None):
    """Rows {what, kind, words, lines, window, stall_eff, model_eff, lite_eff, lite_ok,
    planned, wall}: steady-state efficiency (%, over ``window`` cycles = 4 refresh
    intervals) of each access pattern (every one of :data:`PATTERNS` by default) and each
    DDR block's command order (:data:`tdicam.cosim.litedram.BLOCKS` by default) on the
    memory model with the plain stall pattern, with DRAM timing
    (:class:`~tdicam.model.dram.DramTiming`; the HDL model is cycle-equal with it) and on
    LiteDRAM, and what the planner counts on for the block."""
    from tdicam.cosim.litedram import block_traces
    from tdicam.model.ddr_traces import pattern_lines, pattern_trace
    rows, lines_of = [], {}

    def one(kind, name, trace, windows=None):
        rows.append(_row(kind, name, trace, lines_of[name], windows))

    for name in PATTERNS if patterns is None else patterns:
        lines_of[name] = pattern_lines(name)
        one("pattern", name, pattern_trace(name, lines=lines_of[name]), PATTERNS[name][2])
    blocks = DDR_BLOCKS if blocks is None else blocks
    if blocks:
        traces = block_traces()
        for name in blocks:
            lines_of[name] = None
            one("block", name, traces[name])
    return rows


def _row(kind, name, trace, lines, windows=None):
    """One row of :func:`litedram`: ``trace`` on the memory model (plain stalls, DRAM
    timing) and on LiteDRAM over the steady-state window."""
    from tdicam.cosim.litedram import replay
    from tdicam.model.ddr_traces import replay_model
    from tdicam.model.dram import DramTiming, window_cycles
    kw = {} if windows is None else {"read_time": windows[0], "write_time": windows[1]}
    r = replay(trace, steady=True, **kw)
    row = {"what": name, "kind": kind, "words": trace.words, "lines": lines,
           "window": window_cycles(), "trace": trace, "result": r,
           "stall_eff": 100 * replay_model(trace, steady=True)[2],
           "model_eff": 100 * replay_model(trace, DramTiming(), windows, steady=True)[2],
           "lite_eff": 100 * r.efficiency, "lite_ok": "yes" if r.ok else "NO",
           "planned": None if trace.planned is None else 100 * trace.planned,
           "wall": r.wall}
    print(f"  {kind} {name}: model {row['model_eff']:.1f} %, LiteDRAM "
          f"{row['lite_eff']:.1f} % ({r.wall:.0f} s)", flush=True)
    return row


def arbiter():
    """Table 4's row: the camera's shared DDR order (:func:`tdicam.cosim.shared_ddr.
    camera_trace`: nuc_ddr's coefficient reads beside cds_ddr's reset writes and reads,
    512 x 16 frames at 8 pixels a clock, and the output links' frame buffer at its planned
    share, behind one DdrArbiter) recorded now, on the memory model and LiteDRAM over the
    steady-state window."""
    from tdicam.cosim.shared_ddr import CAMERA_TRACE, camera_trace
    t = time.time()
    tr = camera_trace()
    print(f"  recorded {CAMERA_TRACE}: {tr.words} commands ({tr.note}) in "
          f"{time.time() - t:.0f} s", flush=True)
    return [_row("arbiter", CAMERA_TRACE, tr, None)]


def write_arbiter_fixture(path, row, how):
    """Write :func:`arbiter`'s row as tests/ddr_arbiter_litedram.json: the order (as runs,
    :func:`tdicam.cosim.litedram.trace_runs`), LiteDRAM's and the model's figures."""
    import json

    from tdicam.cosim.litedram import trace_runs
    r = row["result"]
    fx = {"how": how, "name": row["what"], "window": row["window"],
          "efficiency": round(row["lite_eff"], 2), "model": round(row["model_eff"], 2),
          "words": r.words, "mismatches": r.mismatches, "violations": len(r.violations),
          "runs": trace_runs(row["trace"])}
    with open(path, "w") as f:
        json.dump(fx, f, indent=1)
        f.write("\n")


def write_fixture(path, rows, how, merge=False):
    """Write the rows of :func:`litedram` as the fixture of tests/test_ddrref.py
    (:func:`tdicam.cosim.litedram.fixture`). ``merge``: update only these rows' entries of
    the fixture already at ``path`` (the others, and its ``how``, kept; ``how`` then gets
    a note naming the rows replayed now and where)."""
    import json
    from pathlib import Path

    from tdicam.cosim.litedram import fixture
    pats = {r["what"]: {"lines": r["lines"], "efficiency": round(r["lite_eff"], 2),
                        "window": r["window"]}
            for r in rows if r["kind"] == "pattern"}
    blk = {r["what"]: r for r in rows if r["kind"] == "block"}
    fx = fixture({n: r["result"] for n, r in blk.items()},
                 {n: r["trace"] for n, r in blk.items()}, how, pats)
    if merge and Path(path).exists():
        old = json.loads(Path(path).read_text())
        try:
            for part in ("patterns", "blocks"):
                old[part].update(fx[part])
            old["how"] += f" Replayed again, {', '.join(r['what'] for r in rows)}: {how}"
        except (KeyError, TypeError, AttributeError) as exc:
            raise TdicamError(f"{path}: not a LiteDRAM fixture of bench_ddr.py "
                              f"(no {exc}): write a new file without --patterns") from None
        fx = old
    with open(path, "w") as f:
        json.dump(fx, f, indent=1)
        f.write("\n")


def run(sims=cosim.SIMULATORS, quick=False):
    """Both tables as one list of dicts (``table`` = "efficiency" or "speed")."""
    return ([{"table": "efficiency", **r} for r in efficiency(sims, quick)]
            + [{"table": "speed", **r} for r in speed(sims, quick)])


def parse_args(argv=None):
    """The command line; ``patterns`` and ``blocks`` hold the ``--patterns`` selection
    (None: every one). A bad selection ends in one line and exit status 2."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller runs")
    ap.add_argument("--litedram", action="store_true",
                    help="only Table 3: memory model vs LiteDRAM (slow; ddrref extra)")
    ap.add_argument("--arbiter", action="store_true",
                    help="only Table 4: the camera's shared DDR order (nuc_ddr, cds_ddr and "
                         "the links' frame buffer behind one DdrArbiter) on the memory model "
                         "and LiteDRAM (slow; "
                         "ddrref extra); with --fixture: write it as "
                         "tests/ddr_arbiter_litedram.json")
    ap.add_argument("--fixture", metavar="FILE",
                    help="with --litedram: write LiteDRAM's figures and the blocks' traces "
                         "as the JSON fixture of tests/test_ddrref.py (tests/ddr_litedram.json); "
                         "with --patterns: update only those entries of an existing fixture")
    ap.add_argument("--patterns", metavar="NAME,NAME",
                    help="with --litedram: replay only these access patterns and DDR blocks' "
                         f"command orders (default: all). Patterns: {', '.join(PATTERNS)}; "
                         f"blocks: {', '.join(DDR_BLOCKS)}")
    a = ap.parse_args(argv)
    try:
        a.patterns, a.blocks = select(a.patterns)
    except TdicamError as exc:
        ap.exit(2, f"{ap.prog}: error: {exc}\n")
    return a


def main(argv=None):
    a = parse_args(argv)
    if a.litedram or a.arbiter:
        rows = arbiter() if a.arbiter else litedram(patterns=a.patterns, blocks=a.blocks)
        print(machine())
        print_table(rows, [("kind", "kind", "s"), ("what", "pattern / block", "s"),
                           ("words", "trace words", "d"), ("window", "window cycles", "d"),
                           ("stall_eff", "stall model %", ".1f"),
                           ("model_eff", "DRAM model %", ".1f"),
                           ("lite_eff", "LiteDRAM %", ".1f"), ("lite_ok", "data+timing ok", ""),
                           ("planned", "plan counts on %", ".1f"),
                           ("wall", "wall s", ".0f")],
                    title="DDR efficiency over 4 refresh intervals of steady state, memory "
                          "model vs LiteDRAM")
        if a.fixture and a.arbiter:
            write_arbiter_fixture(a.fixture, rows[0],
                                  f"python bench/bench_ddr.py --arbiter --fixture FILE; "
                                  f"{time.strftime('%Y-%m-%d')}, {machine()}")
        elif a.fixture:
            how = (f"python bench/bench_ddr.py --litedram --fixture FILE; "
                   f"{time.strftime('%Y-%m-%d')}, {machine()}")
            try:
                write_fixture(a.fixture, rows, how,
                              merge=a.patterns is not None or a.blocks is not None)
            except TdicamError as exc:
                raise SystemExit(f"bench_ddr.py: error: {exc}") from None
        return
    rows = run(quick=a.quick)
    print(machine())
    print_table([r for r in rows if r["table"] == "efficiency"],
                [("config", "config", "s"), ("sim", "sim", "s"), ("words", "words", "d"),
                 ("write_eff", "write eff %", ".1f"), ("read_eff", "read eff %", ".1f"),
                 ("mem_ok", "bit-exact", ""), ("wall", "wall s", ".1f")],
                title="MIG UI efficiency, default stall pattern (target >= 80 %)")
    print()
    print_table([r for r in rows if r["table"] == "speed"],
                [("engine", "engine", "s"), ("mode", "mode", "s"), ("design", "design", "s"),
                 ("pixels", "pixels", "d"), ("seconds", "wall s", ".2f"),
                 ("pixels_s", "pixels/s", ",.0f"), ("beats_per_clock", "beats/clk", ".3f"),
                 ("mismatches", "mismatches", "d"), ("build_s", "build s", ".1f")],
                title="simulation speed (fast mode, no idle/backpressure; wall incl. start-up)")
    eff = [r for r in rows if r["table"] == "efficiency"]
    ok = all(r["write_eff"] >= 80 and r["read_eff"] >= 80 for r in eff)
    print(f"interface efficiency >= 80 % for writes and reads: {'met' if ok else 'NOT met'}")


if __name__ == "__main__":
    main()
