"""Run a stream block's Verilog top in Amaranth's Python simulator.

Same stimulus and output convention as :func:`tdicam.cosim.run_stream` (beats, run-time
settings riding with each beat, resets before marked beats, random idle cycles and
backpressure), so the result compares with :func:`tdicam.cosim.compare`. Slow (Python per
cycle); used as a fidelity level in benchmarks and as a cross-check in tests.
"""

import random
import time

import numpy as np
from amaranth.hdl import ClockDomain, Module
from amaranth.sim import Simulator

from .. import blocks
from .codec import Beats
from .tbgen import RST_CYCLES

__all__ = ["run_pysim"]


def _pack(values, bits, padded):
    word = 0
    for k, v in enumerate(values):
        word |= int(v) << (k * padded)
    return word


def run_pysim(block, params, stim, *, idle=0.0, backpressure=0.0, seed=1, drain=200,
              max_cycles=None):
    """Simulate ``stim`` through ``block``; returns (output Beats, cycles, wall seconds)."""
    blk = blocks.get(block)
    params = blk.resolve(params)
    top = blk.build(params)
    from . import stream_ports
    _, _, ctrl = stream_ports(top)
    bits, count, padded, _ = top._in
    obits, ocount, opadded, _ = top._out
    m = Module()
    m.domains.sync = cd = ClockDomain("sync")
    m.submodules.top = top
    rng = random.Random(seed)
    n_in = len(stim)
    words = [_pack(stim.data[i], bits, padded) for i in range(n_in)]
    ctrl_vals = stim.ctrl.tolist()
    max_cycles = max_cycles or (n_in * 20 + 10000)
    out = {"data": [], "first": [], "last": [], "seg": []}
    state = {"cycles": 0}

    async def bench(ctx):
        idx = seg = quiet = 0
        valid = False
        rst_left = RST_CYCLES
        served = False
        cycles = 0
        while cycles < max_cycles:
            cycles += 1
            if rst_left == 0 and idx < n_in and stim.rst[idx] and not served:
                rst_left, served, valid = RST_CYCLES, True, False
                seg += 1
            if rst_left:
                rst_left -= 1
                ctx.set(cd.rst, 1)
                ctx.set(top.s_axis_tvalid, 0)
                ctx.set(top.m_axis_tready, 0)
                await ctx.tick()
                continue
            ctx.set(cd.rst, 0)
            if idx < n_in:
                if not valid:
                    valid = rng.random() >= idle
                ctx.set(top.s_axis_tdata, words[idx])
                ctx.set(top.s_axis_tuser, bool(stim.first[idx]))
                ctx.set(top.s_axis_tlast, bool(stim.last[idx]))
                shift = sum(w for _, w in ctrl)
                for name, w in ctrl:
                    shift -= w
                    ctx.set(getattr(top, name), (ctrl_vals[idx] >> shift) & ((1 << w) - 1))
            else:
                valid = False
            ctx.set(top.s_axis_tvalid, valid)
            ready = rng.random() >= backpressure
            ctx.set(top.m_axis_tready, ready)
            fired = ready and ctx.get(top.m_axis_tvalid)
            if fired:
                d = ctx.get(top.m_axis_tdata)
                out["data"].append([(d >> (k * opadded)) & ((1 << obits) - 1)
                                    for k in range(ocount)])
                out["first"].append(ctx.get(top.m_axis_tuser))
                out["last"].append(ctx.get(top.m_axis_tlast))
                out["seg"].append(seg)
            if valid and ctx.get(top.s_axis_tready):
                idx += 1
                served = valid = False
            quiet = 0 if fired else quiet + (idx >= n_in)
            await ctx.tick()
            if quiet >= drain:
                break
        state["cycles"] = cycles

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    t0 = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - t0
    n = len(out["first"])
    beats = Beats(np.array(out["data"], np.uint64).reshape(n, ocount), out["first"],
                  out["last"], np.array(out["seg"], np.uint8))
    return beats, state["cycles"], wall
