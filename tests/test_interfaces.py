"""The stream infrastructure shared by the blocks (:mod:`tdicam.hdl.interfaces.stream`)."""

import numpy as np
import pytest

from tdicam.beats import Beats
from tdicam.cosim.streamsim import run_stream_component
from amaranth.hdl import Module, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out
from amaranth.sim import Simulator

from tdicam.hdl.interfaces.stream import (AdvanceBuffer, Narrower, PairBuffer,
                                          StreamRegister, channels_shape, pixel_layout)


@pytest.mark.parametrize("count,seed,p_valid,p_ready", [
    (1, 1, 0.7, 0.6), (4, 2, 1.0, 1.0), (8, 3, 0.3, 0.9), (2, 4, 0.9, 0.2)])
def test_stream_register_passes_every_beat_once(count, seed, p_valid, p_ready):
    """Random idle cycles and backpressure (and none): every beat out once, in order, with
    its markers; latency 1 cycle."""
    rng = np.random.default_rng(seed)
    n = 400
    data = rng.integers(0, 1 << 12, (n, count))
    k = np.arange(n)
    stim = Beats(data, k % 100 == 0, k % 10 == 9)
    dut = StreamRegister(pixel_layout(channels_shape(12, count)))
    assert dut.latency == 1
    got, lat, _ = run_stream_component(dut, stim, n, seed=seed, p_valid=p_valid,
                                       p_ready=p_ready, drain=20)
    assert len(got) == n
    np.testing.assert_array_equal(np.array([g[0] for g in got]).reshape(n, count), data)
    assert [g[1] for g in got] == stim.first.tolist()
    assert [g[2] for g in got] == stim.last.tolist()
    assert lat == [1]


def test_stream_register_full_throughput():
    """Always offered, always accepted: one beat per clock (n beats in n + latency cycles)."""
    n = 200
    k = np.arange(n)
    stim = Beats(k[:, None] % 4096, k == 0, k % 20 == 19)
    trace = []
    got, _, _ = run_stream_component(StreamRegister(pixel_layout(channels_shape(12, 1))),
                                     stim, n, p_valid=1.0, p_ready=1.0, latency_from=None,
                                     trace=trace)
    outs = [c for d, c in trace if d == "o"]
    assert len(got) == n and outs == list(range(outs[0], outs[0] + n))


class _SideBySide(wiring.Component):
    """A :class:`StreamRegister` and a :class:`PairBuffer` on the same input and ready."""

    def __init__(self):
        super().__init__({"valid": In(1), "payload": In(16), "ready": In(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.reg = self.reg = reg = StreamRegister(16)
        m.submodules.pair = self.pair = pair = PairBuffer(16)
        for dut in (reg, pair):
            m.d.comb += [dut.i_stream.valid.eq(self.valid),
                         dut.i_stream.payload.eq(self.payload),
                         dut.o_stream.ready.eq(self.ready)]
        return m


@pytest.mark.parametrize("seed,p_valid,p_ready", [(1, 0.7, 0.6), (2, 1.0, 0.3), (3, 0.4, 1.0)])
def test_pair_buffer_is_stream_register_cycle_for_cycle(seed, p_valid, p_ready):
    """Random valid and ready: the PairBuffer's input ready, output valid and (while valid)
    payload equal the StreamRegister's on every cycle (the same handshake, so a block that
    swaps one for the other is cycle-identical); the beats out once, in order."""
    dut = _SideBySide()
    rng = np.random.default_rng(seed)
    n, got = 600, []
    sim = Simulator(dut)
    sim.add_clock(1e-8)

    async def bench(ctx):
        sent = 0
        for _ in range(n):
            ctx.set(dut.valid, bool(rng.random() < p_valid))
            ctx.set(dut.payload, sent)
            r = bool(rng.random() < p_ready)
            ctx.set(dut.ready, r)
            a, b = dut.reg, dut.pair
            assert ctx.get(a.i_stream.ready) == ctx.get(b.i_stream.ready)
            assert ctx.get(a.o_stream.valid) == ctx.get(b.o_stream.valid)
            if ctx.get(b.o_stream.valid):
                assert ctx.get(a.o_stream.payload) == ctx.get(b.o_stream.payload)
                if r:
                    got.append(ctx.get(b.o_stream.payload))
            sent += ctx.get(dut.valid) and ctx.get(b.i_stream.ready)
            await ctx.tick()
    sim.add_testbench(bench)
    sim.run()
    assert len(got) > n // 5 and got == list(range(len(got)))


class _EnabledPipe(wiring.Component):
    """``stages`` registers moving on one clock enable, the enable and the last stage
    through an :class:`AdvanceBuffer` (how median3's neighbourhoods use it at ppc >= 2)."""

    def __init__(self, stages):
        self._stages = stages
        super().__init__({"i_stream": In(stream.Signature(16)),
                          "o_stream": Out(stream.Signature(16))})

    def elaborate(self, platform):
        m = Module()
        m.submodules.buf = self.buf = buf = AdvanceBuffer(16)
        m.d.comb += self.i_stream.ready.eq(buf.adv)
        v, d = self.i_stream.valid, self.i_stream.payload
        for k in range(self._stages):
            nv, nd = Signal(name=f"v{k}"), Signal(16, name=f"d{k}")
            with m.If(buf.adv):
                m.d.sync += [nv.eq(v), nd.eq(d)]
            v, d = nv, nd
        m.d.comb += [buf.i_valid.eq(v), buf.i_payload.eq(d)]
        wiring.connect(m, buf.o_stream, wiring.flipped(self.o_stream))
        return m


@pytest.mark.parametrize("stages", [1, 6])
def test_advance_buffer_long_stalls_at_full_rate(stages):
    """Source always valid, the sink's ready in long bursts (1 to 40 cycles high or low) and
    alternating every cycle: every beat out once and in order (a push into a full FIFO
    would lose one), no output bubble while ready stays high once beats are in flight (a
    credit one too tight would stall the pipeline), the FIFO never above its depth."""
    dut = _EnabledPipe(stages)
    buf_depth = AdvanceBuffer.depth
    rng = np.random.default_rng(stages)
    ready = []
    while len(ready) < 1500:
        ready += [bool(len(ready) // 7 % 2)] * int(rng.integers(1, 41))
        ready += [True, False] * 5
    n = 600
    got, fired = [], []
    sim = Simulator(dut)
    sim.add_clock(1e-8)

    async def bench(ctx):
        sent = 0
        for r in ready:
            ctx.set(dut.i_stream.valid, sent < n)
            ctx.set(dut.i_stream.payload, sent)
            ctx.set(dut.o_stream.ready, r)
            took = ctx.get(dut.i_stream.valid) and ctx.get(dut.i_stream.ready)
            ov = ctx.get(dut.o_stream.valid)
            if ov and r:
                got.append(ctx.get(dut.o_stream.payload))
            fired.append((r, ov))
            assert ctx.get(dut.buf.level) <= buf_depth
            sent += took
            await ctx.tick()
    sim.add_testbench(bench)
    sim.run()
    assert got == list(range(n))
    # once the first beat came out, every cycle with ready high pops until all were out
    first = next(c for c, (r, ov) in enumerate(fired) if ov)
    pops = np.cumsum([r and ov for r, ov in fired])
    last = int(np.argmax(pops == n))
    assert all(ov for r, ov in fired[first:last + 1] if r)


def _narrowed(stim, ratio):
    """What a :class:`Narrower` of ``ratio`` must give for ``stim``: each beat's elements
    in ``ratio`` beats, first on the first, last on the last."""
    n, count = stim.data.shape
    data = stim.data.reshape(n * ratio, count // ratio)
    first = np.zeros(n * ratio, bool)
    last = np.zeros(n * ratio, bool)
    first[0::ratio], last[ratio - 1::ratio] = stim.first, stim.last
    return data, first, last


@pytest.mark.parametrize("count_in,count_out,depth,seed,p_valid,p_ready", [
    (8, 1, 160, 1, 0.7, 0.6), (8, 1, 4, 2, 1.0, 1.0), (8, 2, 16, 3, 0.3, 0.9),
    (4, 1, 2, 4, 0.9, 0.2), (8, 4, 8, 5, 1.0, 0.3), (2, 1, 3, 6, 0.5, 1.0),
    (4, 4, 3, 7, 0.6, 0.7)])
def test_narrower_splits_every_beat_in_order(count_in, count_out, depth, seed, p_valid,
                                             p_ready):
    """Random idle cycles and backpressure, full-scale and zero elements, a one-beat row:
    every input beat's elements leave in ``count_in / count_out`` beats in element order,
    ``first`` on the first, ``last`` on the last, nothing lost or repeated; latency 5."""
    rng = np.random.default_rng(seed)
    n = 300
    data = rng.integers(0, 1 << 16, (n, count_in))
    data[:20], data[20:40] = 0xFFFF, 0
    k = np.arange(n)
    stim = Beats(data, k % 50 == 0, (k % 10 == 9) | (k == 3))
    dut = Narrower(16, count_in, count_out, depth)
    assert (dut.ratio, dut.latency) == (count_in // count_out, 5)
    ratio = dut.ratio
    got, lat, _ = run_stream_component(dut, stim, n * ratio, seed=seed, p_valid=p_valid,
                                       p_ready=p_ready, drain=30)
    want, first, last = _narrowed(stim, ratio)
    assert len(got) == n * ratio
    np.testing.assert_array_equal(
        np.array([g[0] for g in got], np.int64).reshape(n * ratio, count_out), want)
    np.testing.assert_array_equal([g[1] for g in got], first)
    np.testing.assert_array_equal([g[2] for g in got], last)
    assert lat == [5]


def test_narrower_takes_a_burst_of_depth_beats_while_the_output_drains():
    """Offered every cycle with the sink always ready: the input is never held while the
    FIFO has room (a line of ``depth`` beats goes in at one a clock), and the output moves
    ``count_out`` elements every clock once started (no bubble between input beats)."""
    depth, n = 40, 40
    k = np.arange(n)
    stim = Beats(np.tile(k[:, None], (1, 8)), k == 0, k == n - 1)
    trace = []
    got, _, _ = run_stream_component(Narrower(12, 8, 1, depth), stim, n * 8, p_valid=1.0,
                                     p_ready=1.0, latency_from=None, trace=trace)
    ins = [c for d, c in trace if d == "i"]
    outs = [c for d, c in trace if d == "o"]
    assert ins == list(range(ins[0], ins[0] + n))
    assert outs == list(range(outs[0], outs[0] + 8 * n))
    assert len(got) == 8 * n


@pytest.mark.parametrize("args", [(16, 8, 3, 4), (16, 8, 1, 1), (16, 4, 0, 4)])
def test_narrower_refuses_impossible_shapes_in_one_line(args):
    with pytest.raises(ValueError, match="Narrower") as e:
        Narrower(*args)
    assert "\n" not in str(e.value)


def _run_crossing(fifo, *, w_period, r_period, n, p_w, p_r, seed, reset_at=None):
    """Drive ``fifo`` (write domain ``write``, read ``read``) with ``n`` entries offered
    with probability ``p_w`` a write cycle and taken with ``p_r`` a read cycle; the
    write domain reset (one write cycle) after ``reset_at`` writes, if given. Returns
    (written, read, read cycles with r_rdy & r_en)."""
    from amaranth.hdl import ClockDomain
    m = Module()
    m.domains.write, m.domains.read = wdom, _ = ClockDomain("write"), ClockDomain("read")
    m.submodules.q = fifo
    sim = Simulator(m)
    sim.add_clock(w_period, domain="write")
    sim.add_clock(r_period, domain="read")
    rng = np.random.default_rng(seed)
    vals = rng.integers(0, 1 << fifo.width, n).tolist()
    written, got, takes = [], [], []
    done = [False]

    async def writer(ctx):
        k, cycles = 0, 0
        while k < n and cycles < 50 * n:          # bounded: a stuck queue ends the run
            cycles += 1
            en = bool(rng.random() < p_w)
            ctx.set(fifo.w_en, en)
            ctx.set(fifo.w_data, vals[k])
            _, _, rdy = await ctx.tick("write").sample(fifo.w_rdy)
            if en and rdy:
                written.append(vals[k])
                k += 1
                if reset_at is not None and k == reset_at:
                    ctx.set(fifo.w_en, 0)
                    await ctx.tick("write")
                    ctx.set(wdom.rst, 1)
                    await ctx.tick("write")
                    ctx.set(wdom.rst, 0)
                    written.append(None)
                    for _ in range(8):
                        await ctx.tick("write")
        ctx.set(fifo.w_en, 0)
        done[0] = True

    async def reader(ctx):
        cyc, idle = 0, 0
        while idle < 200:
            en = bool(rng.random() < p_r)
            ctx.set(fifo.r_en, en)
            _, _, rdy, data = await ctx.tick("read").sample(fifo.r_rdy, fifo.r_data)
            if en and rdy:
                got.append(data)
                takes.append(cyc)
                idle = 0
            elif done[0]:
                idle += 1
            cyc += 1

    sim.add_testbench(writer)
    sim.add_testbench(reader)
    sim.run()
    return written, got, takes


@pytest.mark.parametrize("depth,w_period,r_period,p_w,p_r,seed", [
    (2, 7e-9, 3e-9, 0.8, 0.9, 1), (4, 3e-9, 7e-9, 1.0, 0.5, 2), (16, 40e-9, 8e-9, 1.0, 1.0, 3),
    (64, 5e-9, 5.5e-9, 0.6, 0.4, 4), (8, 8e-9, 40e-9, 0.9, 1.0, 5)])
def test_registered_async_fifo_passes_every_entry_once_in_order(depth, w_period, r_period,
                                                                 p_w, p_r, seed):
    """Random writes and reads on two unrelated clocks (either faster, the queue full and
    empty): every entry read once, in order; the same entries as Amaranth's AsyncFIFO."""
    from amaranth.lib.fifo import AsyncFIFO
    from tdicam.hdl.interfaces.crossing import RegisteredAsyncFIFO
    n = 300
    ref = _run_crossing(AsyncFIFO(width=12, depth=depth, r_domain="read", w_domain="write"),
                        w_period=w_period, r_period=r_period, n=n, p_w=p_w, p_r=p_r,
                        seed=seed)
    ours = _run_crossing(RegisteredAsyncFIFO(width=12, depth=depth, r_domain="read",
                                             w_domain="write"),
                         w_period=w_period, r_period=r_period, n=n, p_w=p_w, p_r=p_r,
                         seed=seed)
    for written, got, _ in (ref, ours):
        assert got == written and len(got) == n


def test_registered_async_fifo_reads_every_cycle_and_sees_a_write_one_cycle_late():
    """Writes far faster than reads, read every cycle: once the queue holds entries, one
    leaves every read cycle (no bubble after a read); the first is readable exactly one
    read cycle after Amaranth's AsyncFIFO has it."""
    from amaranth.lib.fifo import AsyncFIFO
    from tdicam.hdl.interfaces.crossing import RegisteredAsyncFIFO
    kw = dict(w_period=2e-9, r_period=10e-9, n=40, p_w=1.0, p_r=1.0, seed=7)
    _, _, t_ref = _run_crossing(AsyncFIFO(width=8, depth=64, r_domain="read",
                                          w_domain="write"), **kw)
    _, got, t = _run_crossing(RegisteredAsyncFIFO(width=8, depth=64, r_domain="read",
                                                  w_domain="write"), **kw)
    assert len(got) == 40
    assert t[0] == t_ref[0] + 1
    assert np.all(np.diff(t) == 1)


def test_registered_async_fifo_write_reset_empties_it():
    """The write domain's reset mid-stream, entries in the queue: the reader gets what
    Amaranth's AsyncFIFO gives (the same entries as the reset reaches the read side), then
    every entry written after the reset, in order, and not all of those written before."""
    from amaranth.lib.fifo import AsyncFIFO
    from tdicam.hdl.interfaces.crossing import RegisteredAsyncFIFO
    kw = dict(w_period=2e-9, r_period=9e-9, n=60, p_w=1.0, p_r=0.5, seed=3, reset_at=30)
    _, ref, _ = _run_crossing(AsyncFIFO(width=10, depth=16, r_domain="read",
                                        w_domain="write"), **kw)
    written, got, _ = _run_crossing(RegisteredAsyncFIFO(width=10, depth=16, r_domain="read",
                                                        w_domain="write"), **kw)
    cut = written.index(None)
    after = written[cut + 1:]
    assert got == ref
    assert got[len(got) - len(after):] == after and len(got) < len(written) - 1


def test_registered_async_fifo_refuses_a_depth_not_a_power_of_two_and_no_width():
    from tdicam.errors import TdicamError
    from tdicam.hdl.interfaces.crossing import RegisteredAsyncFIFO
    for depth in (12, 1):
        with pytest.raises(TdicamError, match=f"depth = {depth} must be a power of two"):
            RegisteredAsyncFIFO(width=8, depth=depth)
    with pytest.raises(TdicamError, match="width = 0 must be a whole number of bits"):
        RegisteredAsyncFIFO(width=0, depth=4)
