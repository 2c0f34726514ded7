"""Drive a stream design in the Amaranth simulator with random stalls: the one source/sink
loop (:func:`drive`) over the ports of a stream component (:func:`run_stream_component`, for
unit tests) or of a block's Verilog top (:func:`tdicam.cosim.pysim.run_pysim`), told apart
by a :class:`StreamEnds` that says how the ports are reached.

The Verilog co-simulation is :mod:`tdicam.cosim`; this runs the Amaranth design itself, in
Python, to check it before any Verilog is generated and to read its plain status ports.
"""

from dataclasses import dataclass
from typing import Any, Callable

from amaranth.lib import data as _data
from amaranth.sim import Simulator

from tdicam.cosim.pauses import PatternPauses, StreamDriver

__all__ = ["StreamEnds", "drive", "run_stream_component", "probe_latency"]


def _elements(payload_data):
    """Element count of a stream's data field: its ArrayLayout length, or None for a plain
    value."""
    if isinstance(payload_data, _data.View) and isinstance(payload_data.shape(), _data.ArrayLayout):
        return payload_data.shape().length
    return None


@dataclass(frozen=True)
class StreamEnds:
    """How the source and sink reach a design's ports: the input ``i_valid``/``i_ready``,
    the output ``o_valid``/``o_ready`` signals, the reset (``rst``; None: not driven),
    ``put(ctx, k)`` (input beat ``k`` on the data lines, with its run-time settings) and
    ``take(ctx)`` (the output beat on the lines, as ``(data row, first, last)``)."""

    i_valid: Any
    i_ready: Any
    o_valid: Any
    o_ready: Any
    put: Callable
    take: Callable
    rst: Any = None


def set_ports(ctx, ports, value):
    """Drive run-time ``ports`` (``(signal, width)`` pairs) from one packed ``value`` (the
    first port in the most significant bits, as at the Verilog top)."""
    shift = sum(w for _, w in ports)
    for sig, w in ports:
        shift -= w
        ctx.set(sig, (value >> shift) & ((1 << w) - 1))


async def drive(ctx, drv, ends, *, more=None, trace=None, each=None):
    """The source/sink loop: each cycle ``drv`` (a :class:`StreamDriver`) says what to
    drive, the beats move through ``ends``, until ``drv`` is finished or ``more()`` says
    stop.

    ``trace``, a list, receives ``("i" | "o", cycle)`` of every transfer; ``each(ctx, cycle,
    k, o_valid, took, beat)`` is called every cycle after the handshakes (``k``: the input
    beat offered, ``beat``: the output beat taken, or None)."""
    while not drv.finished and (more is None or more()):
        rst, valid, ready = drv.drive()
        if ends.rst is not None:
            ctx.set(ends.rst, rst)
        ctx.set(ends.i_valid, valid)
        ctx.set(ends.o_ready, ready)
        if valid:
            ends.put(ctx, drv.idx)
        k, cycle = drv.idx, drv.cycle
        o_valid = ctx.get(ends.o_valid)
        took, fired = drv.settle(ctx.get(ends.i_ready), not rst and o_valid)
        beat = ends.take(ctx) if fired else None
        if trace is not None:
            trace.extend([("i", cycle)] * took + [("o", cycle)] * fired)
        if each is not None:
            each(ctx, cycle, k, o_valid, took, beat)
        await ctx.tick()


def _component_ends(dut, stim, ports):
    """The :class:`StreamEnds` of a stream component's ``i_stream`` / ``o_stream`` (elements
    set one by one) and its run-time ``ports`` (named attributes)."""
    i, o = dut.i_stream, dut.o_stream
    n_el = stim.data.shape[1]
    n_o, n_i = _elements(o.payload.data), _elements(i.payload.data)
    port_sigs = [(getattr(dut, name), len(getattr(dut, name))) for name in ports]

    def put(ctx, k):
        if n_i is None:
            ctx.set(i.payload.data, int(stim.data[k, 0]))
        for e in range(n_el if n_i is not None else 0):
            ctx.set(i.payload.data[e], int(stim.data[k, e]))
        ctx.set(i.payload.first, bool(stim.first[k]))
        ctx.set(i.payload.last, bool(stim.last[k]))
        set_ports(ctx, port_sigs, int(stim.ctrl[k]))

    def take(ctx):
        data = ctx.get(o.payload.data)
        row = [int(data)] if n_o is None else [int(data[e]) for e in range(n_o)]
        return row, bool(ctx.get(o.payload.first)), bool(ctx.get(o.payload.last))
    return StreamEnds(i.valid, i.ready, o.valid, o.ready, put, take)


def run_stream_component(dut, stim, n_out, *, seed=1, p_valid=0.7, p_ready=0.6, timeout=1e-3,
                         status=(), latency_from=0, ports=(), drain=0, trace=None, watch=(),
                         ready_pattern=None):
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
    signals sampled every cycle, returned as ``final["watch"][name]`` lists;
    ``ready_pattern`` (booleans, repeated) replaces the sink's ``p_ready`` draws, e.g. for
    long stall bursts.
    """
    drv = StreamDriver([False] * len(stim), seed=seed, idle=1 - p_valid,
                       backpressure=1 - p_ready, max_cycles=max(1, round(timeout / 1e-8)))
    if ready_pattern is not None:
        drv.pauses = PatternPauses(drv.pauses, ready_pattern)
    out, lat = [], []
    final = {}
    ends = _component_ends(dut, stim, ports)
    watched = {name: [] for name in watch}
    state = {"since": None, "left": drain}

    def more():
        if len(out) < n_out:
            return True
        state["left"] -= 1
        return state["left"] >= 0

    def each(ctx, cycle, k, o_valid, took, beat):
        for name in watch:
            watched[name].append(ctx.get(getattr(dut, name)))
        if state["since"] is not None and o_valid:
            lat.append(cycle - state["since"])
            state["since"], drv.hold_source = None, False
        if beat is not None:
            out.append(beat)
        if took and k == latency_from:
            state["since"], drv.hold_source = cycle, True
        if len(out) >= n_out and "cycles" not in final:
            final["cycles"] = drv.cycle

    async def bench(ctx):
        await drive(ctx, drv, ends, more=more, trace=trace, each=each)
        ctx.set(ends.i_valid, 0)
        ctx.set(ends.o_ready, 0)
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
