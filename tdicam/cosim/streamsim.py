"""Drive a stream component in the Amaranth simulator with random stalls (for unit tests).

The Verilog co-simulation is :mod:`tdicam.cosim`; this runs the Amaranth design itself, in
Python, to check it before any Verilog is generated and to read its plain status ports.
"""

from amaranth.lib import data as _data
from amaranth.sim import Simulator

from tdicam.cosim.pauses import StreamDriver

__all__ = ["run_stream_component", "probe_latency"]


def _elements(payload_data):
    """Element count of a stream's data field: its ArrayLayout length, or None for a plain
    value."""
    if isinstance(payload_data, _data.View) and isinstance(payload_data.shape(), _data.ArrayLayout):
        return payload_data.shape().length
    return None


def run_stream_component(dut, stim, n_out, *, seed=1, p_valid=0.7, p_ready=0.6, timeout=1e-3,
                         status=(), latency_from=0, ports=(), drain=0, trace=None, watch=()):
    """Drive ``stim`` (Beats) into an Amaranth stream component with random idle cycles and
    backpressure (``p_valid``/``p_ready``: probability of offering / accepting on a cycle),
    drawn by :class:`tdicam.cosim.pauses.StreamDriver` (the same pattern as the Verilog
    co-simulation's for the same seed and probabilities, rounded to 1/256).

    Returns ``(out, lat, final)``: the output transfers as (data row, first, last) tuples,
    ``[cycles from the transfer of input beat latency_from to the first output being valid]``
    (the source pauses after that beat until then; ``latency_from=None`` skips this; the
    beat must be the first that produces an output), and the values of
    the ``status`` signals once ``n_out`` outputs were seen (plus ``"cycles"``, the clock
    count until then). Stops after ``timeout`` simulated seconds (10 ns clock) at the latest.

    Keyword options: ``ports`` names run-time input ports driven from ``stim.ctrl`` with
    each beat (first port in the most significant bits, as at the Verilog top); ``drain``
    cycles keep running after the ``n_out``-th output (so extra outputs show in ``out``);
    ``trace``, a list, receives ``("i" | "o", cycle)`` of every transfer; ``watch`` names
    signals sampled every cycle, returned as ``final["watch"][name]`` lists.
    """
    drv = StreamDriver([False] * len(stim), seed=seed, idle=1 - p_valid,
                       backpressure=1 - p_ready, max_cycles=max(1, round(timeout / 1e-8)))
    n_el = stim.data.shape[1]
    out, lat = [], []
    final = {}
    i, o = dut.i_stream, dut.o_stream

    port_sigs = [getattr(dut, name) for name in ports]
    widths = [len(s) for s in port_sigs]
    watched = {name: [] for name in watch}

    async def bench(ctx):
        n_o, n_i = _elements(o.payload.data), _elements(i.payload.data)
        since, left = None, drain
        while not drv.finished and (len(out) < n_out or left > 0):
            if len(out) >= n_out:
                left -= 1
            _, valid, ready = drv.drive()
            ctx.set(i.valid, valid)
            ctx.set(o.ready, ready)
            if valid:
                k = drv.idx
                if n_i is None:
                    ctx.set(i.payload.data, int(stim.data[k, 0]))
                for e in range(n_el if n_i is not None else 0):
                    ctx.set(i.payload.data[e], int(stim.data[k, e]))
                ctx.set(i.payload.first, bool(stim.first[k]))
                ctx.set(i.payload.last, bool(stim.last[k]))
                shift = sum(widths)
                for sig, w in zip(port_sigs, widths):
                    shift -= w
                    ctx.set(sig, (int(stim.ctrl[k]) >> shift) & ((1 << w) - 1))
            for name in watch:
                watched[name].append(ctx.get(getattr(dut, name)))
            o_valid = ctx.get(o.valid)
            if since is not None and o_valid:
                lat.append(drv.cycle - since)
                since, drv.hold_source = None, False
            if ready and o_valid:
                data = ctx.get(o.payload.data)
                row = [int(data)] if n_o is None else [int(data[e]) for e in range(n_o)]
                out.append((row, bool(ctx.get(o.payload.first)), bool(ctx.get(o.payload.last))))
            k = drv.idx
            took, fired = drv.settle(ctx.get(i.ready), o_valid)
            if trace is not None:
                trace.extend([("i", drv.cycle - 1)] * took + [("o", drv.cycle - 1)] * fired)
            if took and k == latency_from:
                since, drv.hold_source = drv.cycle - 1, True
            if len(out) >= n_out and "cycles" not in final:
                final["cycles"] = drv.cycle
            await ctx.tick()
        ctx.set(i.valid, 0)
        ctx.set(o.ready, 0)
        await ctx.tick()
        final.update({name: ctx.get(getattr(dut, name)) for name in status})
        final.setdefault("cycles", drv.cycle)
        if watch:
            final["watch"] = watched

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
