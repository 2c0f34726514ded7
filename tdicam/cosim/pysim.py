"""Run a stream block's Verilog top in Amaranth's Python simulator.

Same stimulus and output convention as :func:`tdicam.cosim.run_stream` (beats, run-time
settings riding with each beat, resets before marked beats) and the same source/sink
(:class:`tdicam.cosim.pauses.StreamDriver`: the same idle/backpressure pattern for the same
seed; the one Amaranth loop :func:`tdicam.cosim.streamsim.drive`, here on the top's AXI4-Stream
ports), so the result compares with :func:`tdicam.cosim.compare`. Slow (Python per cycle);
used as a fidelity level in benchmarks and as a cross-check in tests.
"""

import time

import numpy as np
from amaranth.hdl import ClockDomain, Module
from amaranth.sim import Simulator

from tdicam import blocks
from tdicam.beats import Beats
from tdicam.cosim.pauses import StreamDriver
from tdicam.cosim.stream import cycle_budget, drain_cycles, stream_ports
from tdicam.cosim.streamsim import StreamEnds, drive, set_ports
from tdicam.cosim.tbgen import RST_CYCLES

__all__ = ["run_pysim"]


def _pack(values, padded):
    word = 0
    for k, v in enumerate(values):
        word |= int(v) << (k * padded)
    return word


def run_pysim(block, params, stim, *, idle=0.0, backpressure=0.0, seed=1, drain=None,
              max_cycles=None, trace=None, n_out=None):
    """Simulate ``stim`` through ``block``; returns (output Beats, cycles, wall seconds,
    timed out). The run stops ``drain`` quiet cycles after the last transfer (default
    :func:`tdicam.cosim.stream.drain_cycles` of 200), or at
    ``max_cycles`` (default :func:`tdicam.cosim.stream.cycle_budget` for ``n_out`` expected
    outputs, ``len(stim)`` when not given): then it timed out.

    ``trace``, a list, receives ``("i" | "o", cycle)`` of every transfer (as
    :func:`tdicam.cosim.run_stream` with ``trace=True``).
    """
    blk = blocks.get(block)
    params = blk.resolve(params)
    top = blk.build(params)
    _, _, ctrl = stream_ports(top)
    bits, count, padded, _ = top._in
    obits, ocount, opadded, _ = top._out
    m = Module()
    m.domains.sync = cd = ClockDomain("sync")
    m.submodules.top = top
    n_in = len(stim)
    words = [_pack(stim.data[i], padded) for i in range(n_in)]
    ctrl_vals = stim.ctrl.tolist()
    drv = StreamDriver(stim.rst, seed=seed, idle=idle, backpressure=backpressure,
                       rst_cycles=RST_CYCLES,
                       drain=drain_cycles(params, 200) if drain is None else drain,
                       max_cycles=max_cycles or cycle_budget(
                           params, n_in, n_in if n_out is None else n_out, idle, backpressure))
    out = {"data": [], "first": [], "last": [], "seg": []}
    port_sigs = [(getattr(top, name), w) for name, w in ctrl]

    def put(ctx, k):
        ctx.set(top.s_axis_tdata, words[k])
        ctx.set(top.s_axis_tuser, bool(stim.first[k]))
        ctx.set(top.s_axis_tlast, bool(stim.last[k]))
        set_ports(ctx, port_sigs, ctrl_vals[k])

    def take(ctx):
        d = ctx.get(top.m_axis_tdata)
        return ([(d >> (k * opadded)) & ((1 << obits) - 1) for k in range(ocount)],
                ctx.get(top.m_axis_tuser), ctx.get(top.m_axis_tlast))

    def each(ctx, cycle, k, o_valid, took, beat):
        if beat is not None:
            for key, v in zip(("data", "first", "last"), beat):
                out[key].append(v)
            out["seg"].append(drv.seg)

    ends = StreamEnds(top.s_axis_tvalid, top.s_axis_tready, top.m_axis_tvalid,
                      top.m_axis_tready, put, take, rst=cd.rst)

    async def bench(ctx):
        ctx.set(cd.rst, 1)
        for _ in range(RST_CYCLES):
            await ctx.tick()
        await drive(ctx, drv, ends, trace=trace, each=each)

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    t0 = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - t0
    n = len(out["first"])
    beats = Beats(np.array(out["data"], np.uint64).reshape(n, ocount), out["first"],
                  out["last"], np.array(out["seg"], np.uint8))
    return beats, drv.cycle, wall, drv.timeout
