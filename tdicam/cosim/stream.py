"""One stream block's Verilog top in a testbench on Icarus or Verilator, in the two drive
modes :mod:`tdicam.cosim` describes (``beat``: cocotb drives every cycle; ``fast``: the
stimulus in an HDL memory): :func:`run_stream` returns the output transfers.

Layer: part of :mod:`tdicam.cosim`.
"""

import json
import os
import shutil
import time
from dataclasses import dataclass

from amaranth.hdl import Shape

from tdicam import blocks
from tdicam.beats import Beats
from tdicam.errors import TdicamError
from tdicam.model import dram
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hw.verilog import convert
from tdicam.cosim import codec, dp16kd, mult18x18d, tbgen
from tdicam.cosim.build import build_sources, run_cocotb
from tdicam.cosim.pauses import check_seed, thresholds

__all__ = ["MODES", "SimResult", "stream_ports", "run_stream", "cycle_budget", "drain_cycles"]

MODES = ("beat", "fast")


def stream_ports(top):
    """(in tdata bits, out tdata bits (None: no ``m_axis``, a top that ends in the output
    links), ctrl ports [(name, width)]) of an :class:`AxisTop`
    (the control bus's inputs, ``s_axil_*`` or ``wb_*``, are not ctrl ports:
    :mod:`tdicam.cosim.tbbus`)."""
    from tdicam.hdl.csr import BUS_PREFIXES
    ctrl = []
    for name, member in top.signature.members.items():
        if member.flow.name == "In" and not name.startswith(("s_axis_", "m_axis_", *BUS_PREFIXES)):
            ctrl.append((name, Shape.cast(member.shape).width))
    return top._in[3], None if top._out is None else top._out[3], ctrl


def _build(blk, params, sim, wave=False, ecp5=False):
    """Build (or reuse) the testbench (``wave``: with the waveform window, its own build;
    ``ecp5``: the block's ECP5 top, :attr:`~tdicam.blocks.Block.ecp5_top`, with the
    vendor primitives' models :data:`tdicam.cosim.dp16kd.MODEL` and
    :data:`tdicam.cosim.mult18x18d.MODEL`, its own build); returns (build dir, seconds
    spent building, top)."""
    top = blk.build(params, ecp5=ecp5)
    if not isinstance(top, AxisTop):
        raise TdicamError(f"block {blk.name} is not a video stream block")
    in_bits, out_bits, ctrl = stream_ports(top)
    sources = {f"{blk.name}.v": convert(top, blk.name)}
    if ecp5:
        sources.update({dp16kd.FILE: dp16kd.MODEL, mult18x18d.FILE: mult18x18d.MODEL})
    sources["tb.v"] = tbgen.stream_testbench(blk.name, in_bits=in_bits, out_bits=out_bits,
                                             ctrl_ports=ctrl, wave=wave)
    bdir, build_time = build_sources(blk.name + ".ecp5" * ecp5 + ".wave" * wave, params, sim,
                                     sources)
    return bdir, build_time, top


@dataclass
class SimResult:
    """Output of one co-simulation run."""

    out: Beats
    cycles: int
    wall: float
    build_time: float
    timeout: bool
    accepted: int
    trace: list | None = None
    wave: str | None = None


def cycle_budget(params, n_in, n_out, idle=0.0, backpressure=0.0):
    """Cycles a co-simulation of ``n_in`` input and ``n_out`` output beats may run before it
    counts as timed out (the one budget of the Verilog and the Amaranth runs): 4 cycles a
    beat at the source's and sink's pause rates, times, for a block with DDR stall
    parameters, the memory model's slowdown (:func:`tdicam.model.dram.slowdown`) and its
    pixels a beat (a DDR block may move a word a pixel), plus 100,000 (start-up: a NAND
    scan, a stored line's reads). A run that ends sooner costs nothing more."""
    slow = 1.0 / ((1 - idle) * (1 - backpressure))
    if dram.has_stalls(params):
        slow *= dram.slowdown(params) * int(params.get("ppc", 1))
    return int((n_in + n_out) * 4 * slow) + 100_000


def drain_cycles(params, base):
    """Quiet cycles a co-simulation runs on after its last input was taken and its last
    output moved before it ends (so missing and extra outputs both show): ``base`` (the
    harness's figure), times, for a block with DDR stall parameters, the memory model's
    slowdown (:func:`tdicam.model.dram.slowdown`): a block that buffers its input beats
    may still owe outputs that wait on the memory (at ``drop = 255`` a grant comes every
    256 cycles on average)."""
    return int(base * dram.slowdown(params))           # 1.0 for a block without DDR


def run_stream(block, params, stim, *, n_out, sim, mode="fast", idle=0.0, backpressure=0.0,
               seed=1, max_cycles=None, drain=None, keep=False, trace=False, wave=None,
               ecp5=False):
    """Co-simulate ``stim`` (:class:`~tdicam.beats.Beats`) through a stream block.

    Parameters
    ----------
    n_out : int
        Output transfers the golden model expects (sizes the ``max_cycles`` default).
        The run stops once every input was accepted and no output moved for ``drain``
        cycles (so lost and duplicated outputs both show), or at ``max_cycles``.
    idle, backpressure : float in [0, 1)
        Probability of an idle input cycle / of ``m_axis_tready`` low on a cycle, drawn by
        :class:`tdicam.cosim.pauses.Pauses` from ``seed``: the same pattern in both modes.
    trace : bool
        Record ``SimResult.trace``: ``("i" | "o", cycle)`` of every input and output
        transfer, cycle 0 the first after the initial reset.
    wave : (first, last) cycle or None
        Fast mode on Icarus only: dump every testbench signal of those cycles (counted like
        ``trace``) to ``SimResult.wave`` (an FST file in the kept run folder) and stop the
        run after them (a separate build with the waveform window; see
        :func:`tdicam.cosim.tbgen.stream_testbench`).
    ecp5 : bool
        Simulate the block's ECP5 synthesis top (:attr:`tdicam.blocks.Block.ecp5_top`:
        vendor primitives) with the models of :mod:`tdicam.cosim.dp16kd` and
        :mod:`tdicam.cosim.mult18x18d`.
    """
    if mode not in MODES:
        raise TdicamError(f"unknown mode {mode!r}; valid: {', '.join(MODES)}")
    if wave is not None and (sim, mode) != ("icarus", "fast"):
        raise TdicamError("a waveform window is written by Icarus in fast mode")
    idle_thr, bp_thr = thresholds(idle, backpressure)
    check_seed("seed", seed)                 # a negative or wide seed would be folded
    blk = blocks.get(block)
    params = blk.resolve(params)
    bdir, build_time, top = _build(blk, params, sim, wave=wave is not None, ecp5=ecp5)
    _, _, ctrl = stream_ports(top)
    ctrl_bits = max(1, sum(w for _, w in ctrl))
    bits, count, padded, _ = top._in
    n_in = len(stim)
    if max_cycles is None:
        max_cycles = cycle_budget(params, n_in, n_out, idle, backpressure)
    if wave is not None:
        max_cycles = min(max_cycles, int(wave[1]) + 2)
    if drain is None:
        drain = drain_cycles(params, 2000)
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    for name, data in tbgen.stimulus_files(stim, elem_padded_bits=padded, ctrl_bits=ctrl_bits):
        (rundir / name).write_bytes(data)
    seed = int(seed) & 0x7fffffff
    job = {"mode": mode, "n_in": n_in, "n_out": int(n_out), "idle": idle,
           "backpressure": backpressure, "seed": seed, "max_cycles": max_cycles,
           "trace": bool(trace),
           "drain": drain, "rst_cycles": tbgen.RST_CYCLES, "in_padded": padded,
           "in_count": count, "ctrl_bits": ctrl_bits, "out_padded": top._out[2],
           "out_count": top._out[1]}
    (rundir / "job.json").write_text(json.dumps(job))
    plusargs = [f"+n_in={n_in}", f"+n_out={int(n_out)}", f"+max_cycles={max_cycles}",
                f"+drain={drain}", f"+idle={idle_thr}",
                f"+bp={bp_thr}", f"+seed={seed}"] + ["+trace"] * bool(trace)
    if wave is not None:
        plusargs += [f"+wave_from={int(wave[0])}", f"+wave_to={int(wave[1])}"]
    ok, wall = run_cocotb(bdir, sim, "stream_tb", rundir, plusargs, waves=wave is not None)
    summary = rundir / "summary.json"
    if not ok or not summary.exists():
        raise TdicamError(f"{sim} simulation of {block} failed; see {rundir / 'sim.log'}")
    info = json.loads(summary.read_text())
    out = codec.decode_output((rundir / "out.hex").read_bytes(),
                              elem_padded_bits=top._out[2], count=top._out[1])
    events = None
    if trace:
        events = [(k, int(c)) for k, c in (ln.split() for ln in
                                           (rundir / "trace.txt").read_text().splitlines())]
    if not keep and wave is None:
        shutil.rmtree(rundir, ignore_errors=True)
    return SimResult(out, info["cycles"], wall, build_time, bool(info["timeout"]),
                     info["accepted"], events,
                     None if wave is None else str(rundir / "wave.fst"))
