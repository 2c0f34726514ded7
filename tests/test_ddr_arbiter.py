"""``DdrArbiter``: several MigPort users on one MIG model through the arbiter, in Amaranth's
simulator, under random command streams, idle cycles and the model's random stalls (refresh,
dropped readies, DRAM timing): every read returns, to the port that asked, the word that
port last wrote there (data bit-exact, per-port order kept); the grant and take of every
cycle equal the golden model's (:func:`tdicam.model.ddr_arbiter.grants`) on the recorded
requests; the model's round-robin bound; one-line refusals; the camera's shared order (nuc_ddr
and cds_ddr saturated beside the output links' frame buffer at its planned share, behind the
arbiter) on the memory model within 3 points of LiteDRAM (tests/ddr_arbiter_litedram.json)."""

import json
from pathlib import Path

import numpy as np
import pytest
from amaranth.sim import Simulator

from tdicam.cosim.testing import FULL
from tdicam.errors import TdicamError
from tdicam.model.dram import DramTiming
from tdicam.model.ddr_arbiter import grants


def _bench(n, burst, stalls):
    from tdicam.cosim.shared_ddr import SharedDdr
    from tdicam.hdl.interfaces.mig import MigPort
    return SharedDdr([MigPort() for _ in range(n)], burst=burst, depth_words=n * 64, **stalls)


def _programs(n, cmds, rng):
    """Per port: (is_read, word index 0..63, data) commands; reads only of written words."""
    out = []
    for k in range(n):
        written, prog = [], []
        for _ in range(cmds):
            if written and rng.random() < 0.5:
                prog.append((1, int(rng.choice(written)), None))
            else:
                w = int(rng.integers(0, 64))
                written.append(w)
                prog.append((0, w, int(rng.integers(0, 1 << 62)) << 194 | k << 8 | w))
        out.append(prog)
    return out


def _run(n, burst, stalls, cmds, seed, idle):
    rng = np.random.default_rng(seed)
    dut = _bench(n, burst, stalls)
    progs = _programs(n, cmds, rng)
    got = [[] for _ in range(n)]
    want = []
    for k, prog in enumerate(progs):
        mem, exp = {}, []
        for rd, w, d in prog:
            if rd:
                exp.append(mem[w])
            else:
                mem[w] = d
        want.append(exp)
    rec = {"req": [], "rdy": [], "grant": [], "take": []}
    done = [False] * n

    def driver(k):
        u, prog = dut.users[k], progs[k]
        prng = np.random.default_rng(seed * 10 + k)

        async def bench(ctx):
            for rd, w, d in prog:
                addr = (k * 64 + w) * 8
                if rd:
                    ctx.set(u.rd_addr, addr)
                    ctx.set(u.rd_valid, 1)
                    await ctx.tick().until(u.rd_ready)
                    ctx.set(u.rd_valid, 0)
                else:
                    ctx.set(u.wr_addr, addr)
                    ctx.set(u.wr_data, d)
                    ctx.set(u.wr_valid, 1)
                    await ctx.tick().until(u.wr_ready)
                    ctx.set(u.wr_valid, 0)
                while prng.random() < idle:
                    await ctx.tick()
            done[k] = True
        return bench

    def reader(k):
        u = dut.users[k]
        prng = np.random.default_rng(seed * 20 + k)

        async def bench(ctx):
            async for _, _, v, r, d in ctx.tick().sample(u.rdata_valid, u.rdata_ready, u.rdata):
                if v and r:
                    got[k].append(int(d))
                ctx.set(u.rdata_ready, int(prng.random() >= 0.3))
        return bench

    async def monitor(ctx):
        arb = dut.arb
        cycles = 0
        async for _, _, *vals in ctx.tick().sample(
                *(getattr(arb, f"p{k}_app_en") for k in range(n)),
                *(getattr(arb, f"p{k}_app_rdy") for k in range(n)), arb.grant, arb.take,
                dut.model.error):
            req, rdy = vals[:n], vals[n:2 * n]
            g, tk, err = vals[2 * n:]
            assert not err, "MIG model error"
            rec["req"].append([bool(x) for x in req])
            rec["rdy"].append(bool(rdy[g]))
            rec["grant"].append(int(g))
            rec["take"].append(bool(tk))
            cycles += 1
            if all(done) and all(len(got[k]) == len(want[k]) for k in range(n)) or cycles > 60000:
                break

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    for k in range(n):
        sim.add_testbench(driver(k))
        sim.add_testbench(reader(k), background=True)
    sim.add_testbench(monitor)
    sim.run()
    return got, want, rec


@pytest.mark.parametrize("n, burst, seed", [(2, 1, 1), (3, 4, 2), (4, 16, 3)])
def test_data_exact_and_grant_order_is_the_golden_models(n, burst, seed):
    stalls = {"lat_lo": 20, "lat_hi": 60, "refresh_period": 300, "refresh_cycles": 30,
              "drop": 48, "seed": seed}
    got, want, rec = _run(n, burst, stalls, cmds=60, seed=seed, idle=0.3)
    for k in range(n):
        assert got[k] == want[k], f"port {k}: read data"
    req = np.array(rec["req"])
    ok = np.repeat(np.array(rec["rdy"])[:, None], n, axis=1)
    g, tk = grants(req, ok, burst=burst)
    assert (g == np.array(rec["grant"])).all() and (tk == np.array(rec["take"])).all()
    assert tk.sum() == n * 60                     # every command taken once
    # the grant moved among the ports (the test is not one port after another)
    switches = np.flatnonzero(np.diff(np.array(rec["grant"])[tk]))
    assert len(switches) > 2 * n


def test_round_robin_bound():
    """A port that keeps requesting waits at most (n - 1) * burst takes of the others."""
    rng = np.random.default_rng(5)
    n, burst, T = 4, 3, 4000
    req = rng.random((T, n)) < 0.7
    req[:, 0] = True
    ok = rng.random((T, n)) < 0.8
    g, tk = grants(req, ok, burst=burst)
    waited = 0
    for t in range(T):
        if tk[t]:
            waited = 0 if g[t] == 0 else waited + 1
            assert waited <= (n - 1) * burst
    assert set(g[tk]) == set(range(n))


@pytest.mark.parametrize("kw, words", [({"n_ports": 1}, "n_ports"), ({"n_ports": 2, "burst": 0},
                                                                     "burst")])
def test_bad_parameters_are_one_line(kw, words):
    from tdicam.hdl.ddr_arbiter import DdrArbiter
    with pytest.raises(TdicamError) as e:
        DdrArbiter(**kw)
    assert words in str(e.value) and "\n" not in str(e.value)


#: LiteDRAM's figure on the camera's shared DDR order (nuc_ddr's coefficient reads beside
#: cds_ddr's reset frame writes and reads and the output links' frame buffer's image line
#: writes and reads, behind one DdrArbiter), the order as runs;
#: regenerate: ``python bench/bench_ddr.py --arbiter --fixture tests/ddr_arbiter_litedram.json``
_FIXTURE = Path(__file__).with_name("ddr_arbiter_litedram.json")


def _fixture():
    return json.loads(_FIXTURE.read_text())


def test_arbiter_order_on_the_model_within_3_points_of_litedram():
    """The arbiter's real access order (recorded, tdicam.cosim.shared_ddr.camera_trace) on
    the memory model with DRAM timing: the fixture's model figure, and within 3 points of
    LiteDRAM's over a window of 4 refresh intervals (every read checked, no timing
    violation)."""
    from tdicam.cosim.litedram import trace_from_runs
    from tdicam.model.ddr_traces import replay_model
    from tdicam.model.dram import WINDOW_REFRESHES, window_cycles
    fx = _fixture()
    tr = trace_from_runs(fx["name"], fx["runs"])
    words, cycles, eff = replay_model(tr, DramTiming(), steady=True)
    assert cycles == fx["window"] == window_cycles() and WINDOW_REFRESHES >= 4
    assert round(100 * eff, 2) == fx["model"]
    assert abs(100 * eff - fx["efficiency"]) <= 3, (100 * eff, fx["efficiency"])
    assert fx["mismatches"] == 0 and fx["violations"] == 0
    # the three users in the order: the CDS reset frame's writes and reads below word 512,
    # the coefficient reads from word 512, the frame buffer's writes and reads from word
    # 1536 (above the coefficients' 16 lines of 64 words); no run crosses a region's edge
    def region(a):
        return ("cds", "nuc", "fb")[(a >= 512) + (a >= 1536)]
    assert all(region(a0) == region(a0 + n - 1) for _, a0, n in fx["runs"])
    kinds = {(rd, region(a0)) for rd, a0, n in fx["runs"]}
    assert kinds == {(0, "cds"), (1, "cds"), (1, "nuc"), (0, "fb"), (1, "fb")}
    # the frame buffer at its planned share: its writes ~FB_WRITE_SHARE of the others'
    # words (10 %), its reads FB_READ_SHARE of its writes (to a 32-word line: read by lines)
    from tdicam.cosim.shared_ddr import FB_READ_SHARE, FB_WRITE_SHARE
    fw = sum(n for rd, a0, n in fx["runs"] if not rd and region(a0) == "fb")
    fr = sum(n for rd, a0, n in fx["runs"] if rd and region(a0) == "fb")
    others = sum(n for _, _, n in fx["runs"]) - fw - fr
    assert abs(fw / others / FB_WRITE_SHARE - 1) <= 0.1, (fw, others)
    assert abs(fr - FB_READ_SHARE * fw) <= 32, (fr, fw)


def test_the_plan_s_shared_figure_is_the_fixture_s():
    """tdicam.model.ddr_efficiency.SHARED_EFFICIENCY (what the camera plan counts on for an
    interface its users share) is the fixture's model and LiteDRAM figures."""
    from tdicam.model.ddr_efficiency import SHARED_EFFICIENCY
    fx = _fixture()
    assert SHARED_EFFICIENCY == (round(fx["model"], 1), round(fx["efficiency"], 1))


def test_benchmarks_page_quotes_the_fixture():
    """docs/guide/benchmarks.md's row of the shared order: the fixture's trace length,
    window, model and LiteDRAM figures."""
    import re
    fx = _fixture()
    text = (Path(__file__).resolve().parents[1] / "docs" / "guide" / "benchmarks.md").read_text()
    row = re.search(rf"^\| [^|]*\(`{fx['name']}`\) \| (\d+) words recorded \| (\d+) \| "
                    rf"([\d.]+) \| ([\d.]+) \|$", text, re.M)
    assert row, "no row of the shared DDR order on the benchmarks page"
    words = sum(n for _, _, n in fx["runs"])
    assert row.groups() == (str(words), str(fx["window"]), f"{fx['model']:.1f}",
                            f"{fx['efficiency']:.1f}")


@pytest.mark.skipif(not FULL, reason="records the camera's order (~70 s): TDICAM_FULL=1")
def test_arbiter_order_recorded_now_is_the_fixtures():
    from tdicam.cosim.litedram import trace_runs
    from tdicam.cosim.shared_ddr import camera_trace
    assert trace_runs(camera_trace()) == _fixture()["runs"]
