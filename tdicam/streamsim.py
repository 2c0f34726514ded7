"""Drive a stream component in the Amaranth simulator with random stalls (for unit tests).

The Verilog co-simulation is :mod:`tdicam.cosim`; this runs the Amaranth design itself, in
Python, to check it before any Verilog is generated and to read its plain status ports.
"""

from amaranth.lib import data as _data
from amaranth.sim import Simulator

from .pauses import StreamDriver

__all__ = ["run_stream_component", "probe_latency"]


def _elements(payload_data):
    """Element count of a stream's data field: its ArrayLayout length, or None for a plain
    value."""
    if isinstance(payload_data, _data.View) and isinstance(payload_data.shape(), _data.ArrayLayout):
        return payload_data.shape().length
    return None


def run_stream_component(dut, stim, n_out, *, seed=1, p_valid=0.7, p_ready=0.6, timeout=1e-3,
                         status=(), latency_from=0):
    """Drive ``stim`` (Beats) into an Amaranth stream component with random idle cycles and
    backpressure (``p_valid``/``p_ready``: probability of offering / accepting on a cycle),
    drawn by :class:`tdicam.pauses.StreamDriver` (the same pattern as the Verilog
    co-simulation's for the same seed and probabilities, rounded to 1/256).

    Returns ``(out, lat, final)``: the output transfers as (data row, first, last) tuples,
    ``[cycles from the transfer of input beat latency_from to the first output being valid]``
    (the source pauses after that beat until then; ``latency_from=None`` skips this; the
    beat must be the first that produces an output), and the values of
    the ``status`` signals once ``n_out`` outputs were seen (plus ``"cycles"``, the clock
    count until then). Stops after ``timeout`` simulated seconds (10 ns clock) at the latest.
    """
    drv = StreamDriver([False] * len(stim), seed=seed, idle=1 - p_valid,
                       backpressure=1 - p_ready, max_cycles=max(1, round(timeout / 1e-8)))
    n_el = stim.data.shape[1]
    out, lat = [], []
    final = {}
    i, o = dut.i_stream, dut.o_stream

    async def bench(ctx):
        n_o = _elements(o.payload.data)
        since = None
        while len(out) < n_out and not drv.finished:
            _, valid, ready = drv.drive()
            ctx.set(i.valid, valid)
            ctx.set(o.ready, ready)
            if valid:
                k = drv.idx
                for e in range(n_el):
                    ctx.set(i.payload.data[e], int(stim.data[k, e]))
                ctx.set(i.payload.first, bool(stim.first[k]))
                ctx.set(i.payload.last, bool(stim.last[k]))
            o_valid = ctx.get(o.valid)
            if since is not None and o_valid:
                lat.append(drv.cycle - since)
                since, drv.hold_source = None, False
            if ready and o_valid:
                data = ctx.get(o.payload.data)
                row = [int(data)] if n_o is None else [int(data[e]) for e in range(n_o)]
                out.append((row, bool(ctx.get(o.payload.first)), bool(ctx.get(o.payload.last))))
            k = drv.idx
            took, _ = drv.settle(ctx.get(i.ready), o_valid)
            if took and k == latency_from:
                since, drv.hold_source = drv.cycle - 1, True
            await ctx.tick()
        ctx.set(i.valid, 0)
        ctx.set(o.ready, 0)
        await ctx.tick()
        final.update({name: ctx.get(getattr(dut, name)) for name in status})
        final["cycles"] = drv.cycle

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return out, lat, final


def probe_latency(dut, data, *, cycles=8, first=True):
    """Offer one beat (elements ``data``, tuser ``first``) with the sink always ready, and
    return ``[(o_stream.valid, element 0 of o_stream data)]`` for the ``cycles`` cycles after
    the accepting edge: a block of latency L shows ``valid`` at index ``L - 1``."""
    seen = []

    async def bench(ctx):
        ctx.set(dut.o_stream.ready, 1)
        for e, v in enumerate(data):
            ctx.set(dut.i_stream.payload.data[e], int(v))
        ctx.set(dut.i_stream.payload.first, first)
        ctx.set(dut.i_stream.valid, 1)
        await ctx.tick()  # accepted on this edge
        ctx.set(dut.i_stream.valid, 0)
        o = dut.o_stream.payload.data
        d = o if _elements(o) is None else o[0]
        for _ in range(cycles):
            seen.append((ctx.get(dut.o_stream.valid), ctx.get(d)))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return seen
