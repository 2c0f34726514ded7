"""DDR command orders: the access patterns, their efficiency on the memory model, and their
replay into LiteDRAM (:mod:`tdicam.cosim.litedram`, the ``ddrref`` extra; skipped saying why when
it is missing).

Every efficiency figure is over a steady-state window of 4 refresh intervals (3128 cycles,
:func:`tdicam.model.dram.window_efficiency`). Default run: pattern checks on the model; the
memory model within +/-3 points of LiteDRAM's recorded figures (``ddr_litedram.json``) on
every pattern and DDR block's recorded command order it holds; the DDR table (docs/guide/benchmarks.md) equal to
the fixture and to the model re-measured; one short LiteDRAM replay (2 lines written and
read back, ~30 s of CPU). With ``TDICAM_FULL=1``: every DDR block's command order as it
records now (long enough for the window) replayed into LiteDRAM;
a block fails when its efficiency falls below what the planner counts on for it
(``Trace.planned``: :func:`tdicam.model.ddr_efficiency.tdi_spill_efficiency` for the TDI spill, 80 %
for the others) or when the memory model is more than 3 points from it.
"""

import json
import os
from pathlib import Path

import pytest

from tdicam.errors import TdicamError
from tdicam.cosim.litedram import BLOCKS
from tdicam.model import ddr_efficiency, ddr_traces, dram

FULL = os.environ.get("TDICAM_FULL") == "1"


def _ref():
    from tdicam.cosim import litedram
    why = litedram.available()
    if why:
        pytest.skip(why)
    return litedram


@pytest.mark.parametrize("name", [n for n in ddr_traces.PATTERNS
                                  if n.startswith(("write_read", "blocks", "two_ports"))])
def test_pattern_reads_follow_their_writes(name):
    """Every read of a read-back pattern reads a word written earlier (in the global order),
    and each word is read once."""
    tr = ddr_traces.pattern_trace(name, lines=6)
    order = tr.order or [(0, k) for k in range(len(tr.ports[0]))]
    written = set()
    for p, k in order:
        rd, a = tr.ports[p][k]
        if rd:
            assert a in written, (name, p, k, a)
        else:
            written.add(a)
    reads = [a for port in tr.ports for rd, a in port if rd]
    assert len(reads) == len(set(reads))


#: LiteDRAM's figures recorded with this harness's settings (``how`` in the file says how;
#: regenerate: ``python bench/bench_ddr.py --litedram --fixture tests/ddr_litedram.json``):
#: every pattern's steady-state efficiency (%), its lines and window (cycles), every DDR
#: block's recorded command order (as runs), its efficiency and window
FIXTURE = json.loads((Path(__file__).parent / "ddr_litedram.json").read_text())
LITEDRAM = {n: (v["lines"], v["efficiency"]) for n, v in FIXTURE["patterns"].items()}


@pytest.mark.parametrize("rec", [*FIXTURE["patterns"].values(), *FIXTURE["blocks"].values()])
def test_every_figure_spans_4_refresh_intervals(rec):
    """Every recorded LiteDRAM figure is words over a steady-state window of at least 4
    refresh intervals (tREFI = 782 cycles), so each pays its refreshes."""
    assert rec["window"] >= 4 * dram.TREFI == dram.window_cycles()


@pytest.mark.parametrize("name", list(LITEDRAM))
def test_dram_model_within_3_points_of_litedram(name):
    """The memory model with DRAM timing (banks, rows, turnarounds, refresh) gives every
    pattern's steady-state efficiency within +/-3 points of LiteDRAM's over the same window;
    the plain stall pattern does not (it ignores the order: the per-word interleave is 12 %
    on DRAM, ~89 % there)."""
    lines, want = LITEDRAM[name]
    assert lines == ddr_traces.pattern_lines(name)
    e = 100 * ddr_traces.pattern_efficiency(name, lines=lines)
    assert abs(e - want) <= 3, (name, e)


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="HDL model on every pattern: set TDICAM_FULL=1")
@pytest.mark.parametrize("name", list(LITEDRAM))
def test_hdl_model_within_3_points_of_litedram(name):
    """Long form of tests/test_ddr.py's cycle-equality test: the HDL controller model with
    DRAM timing, cycle-equal with the Python one on every pattern, within +/-3 points of
    LiteDRAM."""
    from tdicam.cosim.litedram import replay_hdl
    lines, want = LITEDRAM[name]
    tr = ddr_traces.pattern_trace(name, lines=lines)
    e = 100 * replay_hdl(tr, dram.DramTiming(), ddr_traces.PATTERNS[name][2])
    assert abs(e - want) <= 3, (name, e)


@pytest.mark.parametrize("block", [n for n, rec in FIXTURE["blocks"].items()
                                   if "efficiency" in rec])
def test_dram_model_within_3_points_of_litedram_on_blocks(block):
    """Each DDR block's recorded command order on the memory model with DRAM timing: within
    +/-3 points of LiteDRAM's figure for the same trace over the same steady-state window
    (recorded in the fixture; the live replay is the slow test below)."""
    from tdicam.cosim.litedram import trace_from_runs
    rec = FIXTURE["blocks"][block]
    tr = trace_from_runs(block, rec["runs"])
    words, window, e = ddr_traces.replay_model(tr, dram.DramTiming(), steady=True)
    assert window == rec["window"]
    assert abs(100 * e - rec["efficiency"]) <= 3, (block, e, rec["efficiency"])


def _readme_ddr_table():
    """``name -> (model %, LiteDRAM % or None: not measured, window cycles)`` of the DDR
    efficiency table (docs/guide/benchmarks.md)."""
    import re
    text = (Path(__file__).resolve().parents[1] / "docs" / "guide" / "benchmarks.md").read_text()
    rows = re.findall(r"^\| `(\w+)` \|[^|]*\|[^|]*\| (\d+) \| ([\d.]+) \| ([\d.]+|-) \|$",
                      text, re.M)
    return {n: (float(m), None if lite == "-" else float(lite), int(w))
            for n, w, m, lite in rows}


def test_readme_ddr_table_is_the_fixture_and_the_model():
    """the DDR table (docs/guide/benchmarks.md) shows, for every pattern and block of the fixture, LiteDRAM's
    recorded figure ("-" where it was not measured), the memory model's figure re-measured
    now (patterns; blocks on their recorded orders) and the window, each over 4 refresh
    intervals."""
    from tdicam.cosim.litedram import trace_from_runs
    table = _readme_ddr_table()
    assert set(table) == set(ddr_traces.PATTERNS) | set(BLOCKS)
    for name, (model, lite, window) in table.items():
        rec = FIXTURE["patterns"].get(name) or FIXTURE["blocks"].get(name) or {}
        assert window == dram.window_cycles(), name
        assert lite == (round(rec["efficiency"], 1) if "efficiency" in rec else None), name
        if name in ddr_traces.PATTERNS:
            e = ddr_traces.pattern_efficiency(name)
        else:
            e = ddr_traces.replay_model(trace_from_runs(name, rec["runs"]), dram.DramTiming(),
                                 steady=True)[2]
        assert model == round(100 * e, 1), (name, model, e)


def test_measured_figures_quoted_are_the_fixture():
    """The figures the planner's margin and TdiDdr's docstring quote are the DDR table's's
    (so the fixture's and the model's)."""
    import re

    from tdicam.hdl import tdi_ddr
    table = _readme_ddr_table()
    assert ddr_efficiency.MEASURED_EFFICIENCY == {n: table[n][:2] for n in BLOCKS}
    assert ddr_efficiency.closest_block(0.8)[0] == "ddr"      # the frame buffer, as the plan says
    doc = " ".join(tdi_ddr.TdiDdr.__doc__.split())
    quoted = re.search(r"([\d.]+) % at W = 1280 .*?, ([\d.]+) % at W = 4096", doc).groups()
    assert quoted == (f"{ddr_efficiency.MEASURED_EFFICIENCY['tdi_ddr'][0]:.1f}",
                      f"{ddr_efficiency.MEASURED_EFFICIENCY['tdi_ddr_wide'][0]:.1f}")
    lite = re.search(r"LiteDRAM over the same window: ([\d.]+) % and ([\d.]+) %", doc).groups()
    assert lite == (f"{ddr_efficiency.MEASURED_EFFICIENCY['tdi_ddr'][1]:.1f}",
                    f"{ddr_efficiency.MEASURED_EFFICIENCY['tdi_ddr_wide'][1]:.1f}")


def test_plain_model_ignores_the_order():
    assert ddr_traces.pattern_efficiency("per_word_rw", dram=None) > 0.8


def test_model_efficiency_and_errors():
    e = {n: ddr_traces.pattern_efficiency(n) for n in ("write_only", "per_word_rw")}
    assert 0.8 < e["write_only"] <= 1 and e["per_word_rw"] < 0.2, e
    with pytest.raises(TdicamError, match="unknown DDR access pattern 'nope'"):
        ddr_traces.pattern_efficiency("nope")
    with pytest.raises(TdicamError, match="before the 4-refresh window .100..3228 cycles. "
                                          "closes: make the trace longer"):
        ddr_traces.pattern_efficiency("write_only", lines=8)


def test_litedram_short_replay():
    """Short form: 2 lines written and read back through LiteDRAM (one port, line n written
    then line n-1 read), every read checked against the last write to its address, no DDR3
    timing violation, an efficiency between the per-word interleave's and the ideal."""
    ref = _ref()
    r = ref.replay(ddr_traces.pattern_trace("write_read_lag1", lines=2))
    assert r.words == 216
    assert r.mismatches == 0 and r.violations == [], r
    assert 0.5 < r.efficiency < 1, r


def test_litedram_rejects_address_outside_memory():
    ref = _ref()
    with pytest.raises(TdicamError, match="word addresses must lie in"):
        ref.replay(ddr_traces.Trace("far", [[(0, ref.MEM_ROWS * 8 * 128)]]))


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="LiteDRAM replay of every block: set TDICAM_FULL=1")
@pytest.mark.parametrize("block", BLOCKS)
def test_litedram_block_efficiency(block):
    """Each DDR block's order as it records now, on LiteDRAM: data right, no timing
    violation, an efficiency no lower than what the planner counts on for it (the TDI
    spill: its access pattern on the DRAM model less :data:`tdicam.model.ddr_efficiency.PLAN_MARGIN`;
    the others: 80 %), and the memory model within +/-3 points of it on the same trace."""
    ref = _ref()
    tr = _block_traces(ref)[block]
    r = ref.replay(tr, steady=True)
    assert r.mismatches == 0 and r.violations == []
    assert r.efficiency >= tr.planned, \
        f"{block}: {r.efficiency:.1%} on LiteDRAM, the plan counts on {tr.planned:.1%}"
    m = ddr_traces.replay_model(tr, dram.DramTiming(), steady=True)[2]
    assert abs(r.efficiency - m) <= 0.03, (block, r.efficiency, m)


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="LiteDRAM replay of every pattern: set TDICAM_FULL=1")
@pytest.mark.parametrize("name", list(ddr_traces.PATTERNS))
def test_litedram_matches_the_dram_model(name):
    """The same trace on LiteDRAM and on the memory model: within +/-3 points."""
    ref = _ref()
    tr = ddr_traces.pattern_trace(name, lines=ddr_traces.pattern_lines(name))
    win = ddr_traces.PATTERNS[name][2]
    r = ref.replay(tr, steady=True,
                   **({} if win is None else {"read_time": win[0], "write_time": win[1]}))
    assert r.ok, r
    m = ddr_traces.replay_model(tr, dram.DramTiming(), win, steady=True)[2]
    assert abs(r.efficiency - m) <= 0.03, (name, r.efficiency, m)


_TRACES = {}


def _block_traces(ref):
    if not _TRACES:
        _TRACES.update(ref.block_traces())
    return _TRACES


def _bench_ddr():
    import importlib.util
    path = Path(__file__).resolve().parents[1] / "bench" / "bench_ddr.py"
    spec = importlib.util.spec_from_file_location("bench_ddr", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bench_ddr_patterns_pick_what_litedram_replays(monkeypatch, capsys):
    """``bench/bench_ddr.py --litedram --patterns NAME,NAME``: the names listed in --help,
    patterns and block orders picked apart, an unknown name refused in one line naming the
    valid ones, and only the picked ones replayed (LiteDRAM itself stood in for)."""
    from types import SimpleNamespace

    from tdicam.cosim import litedram
    bd = _bench_ddr()
    with pytest.raises(SystemExit) as e:
        bd.parse_args(["--help"])
    helptext = " ".join(capsys.readouterr().out.split())
    assert e.value.code == 0 and all(n in helptext for n in [*ddr_traces.PATTERNS, *BLOCKS])
    a = bd.parse_args(["--litedram"])
    assert a.patterns is None and a.blocks is None
    a = bd.parse_args(["--litedram", "--patterns", "blocks_8,tdi_ddr, write_only"])
    assert a.patterns == ["blocks_8", "write_only"] and a.blocks == ["tdi_ddr"]
    for argv, why in [(["--patterns", "write_only,nosuch"], "unknown name 'nosuch'; valid: "),
                      (["--patterns", ","], "no name given; valid: ")]:
        with pytest.raises(SystemExit) as e:
            bd.parse_args(["--litedram", *argv])
        err = capsys.readouterr().err
        assert e.value.code == 2 and err.count("\n") == 1 and why in err, err
        if "valid" in why:
            assert ", ".join([*ddr_traces.PATTERNS, *BLOCKS]) in err
    seen = []
    monkeypatch.setattr(litedram, "replay", lambda trace, **kw: seen.append(trace.name)
                        or SimpleNamespace(efficiency=0.5, ok=True, wall=0.0))
    rows = bd.litedram(patterns=["write_only"], blocks=[])
    assert [r["what"] for r in rows] == ["write_only"] and len(seen) == 1
    assert rows[0]["window"] == 4 * dram.TREFI
    assert bd.litedram(patterns=[], blocks=[]) == [] and len(seen) == 1
    picked = []
    monkeypatch.setattr(bd, "litedram", lambda **kw: picked.append(kw) or [])
    bd.main(["--litedram", "--patterns", "read_only,writer"])
    assert picked == [{"patterns": ["read_only"], "blocks": ["writer"]}]


def test_bench_ddr_fixture_update_keeps_the_other_rows(tmp_path):
    """``--fixture FILE --patterns NAME``: the named rows replace theirs in the fixture,
    every other row and the ``how`` are kept (a note naming the rows is added); a file that
    is not a fixture is refused in one line."""
    from types import SimpleNamespace
    bd = _bench_ddr()
    path = tmp_path / "fx.json"
    path.write_text(json.dumps(FIXTURE))
    row = {"what": "write_only", "kind": "pattern", "lines": 62, "lite_eff": 86.94,
           "window": 3128, "result": SimpleNamespace()}
    bd.write_fixture(path, [row], "now", merge=True)
    got = json.loads(path.read_text())
    assert got["patterns"]["write_only"] == {"lines": 62, "efficiency": 86.94, "window": 3128}
    assert {k: v for k, v in got["patterns"].items() if k != "write_only"} == \
        {k: v for k, v in FIXTURE["patterns"].items() if k != "write_only"}
    assert got["blocks"] == FIXTURE["blocks"]
    assert got["how"].startswith(FIXTURE["how"]) and "write_only: now" in got["how"]
    path.write_text("[1, 2]")
    with pytest.raises(TdicamError, match="not a LiteDRAM fixture"):
        bd.write_fixture(path, [row], "now", merge=True)
