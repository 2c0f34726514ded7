"""The one co-simulation path of tests, ``tdicam sim``, ``tdicam run`` and ``tdicam bench``:
stimulus and expected beats (from case arrays, scene arrays or a stored golden case) through
a simulator, compared with the golden model, with the waveform of a mismatch written on
request.

Layer: part of :mod:`tdicam.cosim`.
"""

import shutil
from dataclasses import dataclass

import numpy as np

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.cosim.compare import Comparison, compare
from tdicam.cosim.pysim import run_pysim
from tdicam.cosim.stream import SimResult, run_stream
from tdicam.cosim import golden

__all__ = ["AMARANTH", "CaseRun", "run_beats", "WAVE_WINDOW", "wave_window", "keep_wave",
           "waveform", "run_case", "run_scene", "run_golden_case"]


#: Drivers :func:`run_beats` accepts besides :data:`SIMULATORS`: the Amaranth simulator.
AMARANTH = "amaranth"


@dataclass
class CaseRun:
    """One co-simulation checked against the golden model (:func:`run_beats`).

    Attributes
    ----------
    block, sim, mode : str
        What ran: ``sim`` one of :data:`SIMULATORS` or ``"amaranth"`` (mode ``"beat"``).
    result : SimResult
        The simulator's output and timing.
    comparison : Comparison
        Beat-by-beat comparison with the expected beats.
    n_in, n_out : int
        Stimulus beats and expected output beats.
    elements : int
        Output elements (pixels, bytes) per beat.
    waveform : dict or None
        On a mismatch, when :func:`run_beats` was given a ``wave_dir``: ``path`` of the FST
        file, ``cycles`` (first, last) it holds and ``cycle`` of the first mismatching
        output transfer (see :func:`waveform`); ``path`` None and ``error`` when it could
        not be written (no Icarus).
    """

    block: str
    sim: str
    mode: str
    result: SimResult
    comparison: Comparison
    n_in: int
    n_out: int
    elements: int
    waveform: dict | None = None

    @property
    def mismatches(self):
        """Mismatching beats, every expected beat counted when the run timed out."""
        return self.comparison.mismatches + (self.n_out if self.result.timeout else 0)

    @property
    def ok(self):
        return (self.comparison.ok and not self.result.timeout
                and self.result.accepted == self.n_in)

    @property
    def pixels(self):
        return self.comparison.checked * self.elements

    def message(self):
        """One line: what went wrong (or ``match``), naming block, simulator and mode."""
        r, where = self.result, f"{self.block} {self.sim} {self.mode}"
        if r.timeout:
            return f"{where}: timed out after {r.cycles} cycles"
        if not self.comparison.ok:
            return (f"{where}: {self.comparison.mismatches} mismatches; "
                    f"{self.detail()}")
        if r.accepted != self.n_in:
            return f"{where}: accepted {r.accepted} of {self.n_in} input beats"
        return "match"

    def detail(self):
        """The comparison's message and, if written, where the waveform is."""
        w = self.waveform
        if w is None:
            return self.comparison.message
        if w["path"] is None:
            return f"{self.comparison.message}; no waveform: {w['error']}"
        return (f"{self.comparison.message}; waveform {w['path']} (cycles {w['cycles'][0]}.."
                f"{w['cycles'][1]}, mismatch at cycle {w['cycle']}, Icarus)")

    def row(self):
        """The dict ``tdicam sim`` prints and returns per case."""
        r = self.result
        return {"beats": self.comparison.checked, "pixels": self.pixels,
                "mismatches": self.comparison.mismatches, "cycles": r.cycles,
                "wall_s": r.wall, "build_s": r.build_time, "timeout": r.timeout,
                "message": self.detail(),
                "waveform": (self.waveform or {}).get("path")}


def run_beats(block, params, stim, exp, *, sim, mode="fast", idle=0.0, backpressure=0.0,
              seed=1, wave_dir=None, label=None, **kw):
    """Co-simulate ``stim`` through ``block`` and compare the output with ``exp``.

    The one co-simulation path of tests, ``tdicam sim``, ``tdicam run`` and ``tdicam
    bench``: ``sim`` is a Verilog simulator (:func:`run_stream`, ``mode`` beat or fast) or
    ``"amaranth"`` (:func:`tdicam.cosim.pysim.run_pysim`, the Verilog top in Amaranth's
    simulator). ``kw`` goes to the driver (``max_cycles``, ``drain``, ``keep``).
    ``wave_dir``: on a mismatch of a Verilog simulator, write the waveform of the cycles
    around the first one there (:func:`waveform`; ``label`` names the file, e.g. the case);
    a run that matches costs nothing more.
    Returns a :class:`CaseRun`.
    """
    blk = blocks.get(block) if isinstance(block, str) else block
    params = blk.resolve(params)
    if sim == AMARANTH:
        out, cycles, wall, timeout = run_pysim(blk.name, params, stim, idle=idle,
                                               backpressure=backpressure, seed=seed,
                                               n_out=len(exp), **kw)
        res = SimResult(out, cycles, wall, 0.0, timeout, len(stim))
        mode = "beat"
    else:
        res = run_stream(blk.name, params, stim, n_out=len(exp), sim=sim, mode=mode,
                         idle=idle, backpressure=backpressure, seed=seed, **kw)
    elements = exp.data.shape[1] if len(exp) else 1
    run = CaseRun(blk.name, sim, mode, res, compare(res.out, exp), len(stim), len(exp),
                  elements)
    if wave_dir is not None and run.comparison.first is not None and sim != AMARANTH:
        try:
            run.waveform = waveform(blk, params, stim, exp, run.comparison.first, wave_dir,
                                    idle=idle, backpressure=backpressure, seed=seed,
                                    label=label or f"{sim}-{mode}-seed{seed}",
                                    ecp5=kw.get("ecp5", False))
        except TdicamError as exc:     # the mismatch is the news; say why there is no wave
            run.waveform = {"path": None, "error": str(exc)}
    return run


#: Cycles of waveform kept before and after the first mismatch.
WAVE_WINDOW = 64


def wave_window(cycle):
    """The cycles ``(first, last)`` of the waveform around a mismatch at ``cycle``."""
    return max(0, cycle - WAVE_WINDOW), cycle + WAVE_WINDOW


def keep_wave(src, dst, what):
    """Move the waveform ``src`` a run wrote to ``dst`` and remove the run's folder; a
    one-line error naming ``what`` and the folder when the simulator wrote none."""
    from pathlib import Path
    src, dst = Path(src), Path(dst)
    if not src.exists():
        raise TdicamError(f"Icarus wrote no waveform for {what}; see {src.parent}")
    from tdicam.files import check_dir
    check_dir(dst.parent, "wave_dir")
    shutil.move(str(src), dst)
    shutil.rmtree(src.parent, ignore_errors=True)
    return str(dst)


def waveform(block, params, stim, exp, first, wave_dir, *, idle, backpressure, seed, label,
             ecp5=False):
    """Write the waveform around a mismatch: ``<wave_dir>/<block>-<label>.fst``.

    The stimulus runs again on Icarus in fast mode with the same idle/backpressure pattern
    (:class:`tdicam.cosim.pauses.Pauses` draws the same one in both modes and simulators, so the
    DUT sees the same cycles): once with the transfer trace, for the cycle of output
    transfer ``first["index"]`` (the last transfer's cycle when it is missing), then with
    the waveform window ``cycle +- WAVE_WINDOW``. Returns ``{"path", "cycles": (first,
    last), "cycle"}``.
    """
    from pathlib import Path
    blk = blocks.get(block) if isinstance(block, str) else block
    kw = dict(n_out=len(exp), sim="icarus", mode="fast", idle=idle,
              backpressure=backpressure, seed=seed, ecp5=ecp5)
    traced = run_stream(blk.name, params, stim, trace=True, **kw)
    outs = [c for k, c in traced.trace if k == "o"]
    cycle = outs[min(first["index"], len(outs) - 1)] if outs else traced.cycles
    lo, hi = wave_window(cycle)
    res = run_stream(blk.name, params, stim, wave=(lo, hi), **kw)
    path = keep_wave(res.wave, Path(wave_dir) / f"{blk.name}-{label}.fst", blk.name)
    return {"path": path, "cycles": (lo, hi), "cycle": int(cycle)}


def run_case(block, params, arrays, *, corrupt=None, **kw):
    """:func:`run_beats` on case arrays (a golden case's, or :meth:`Block.case_arrays` of
    scene arrays): the block's ``to_beats`` makes stimulus and expected beats.
    ``corrupt(arrays)`` may alter a copy of the arrays first (to show a check can fail)."""
    blk = blocks.get(block) if isinstance(block, str) else block
    if blk.streams.to_beats is None:
        raise TdicamError(f"block {blk.name} has no stream co-simulation; run its cocotb "
                          f"tests (pytest cocotb_tests/test_{blk.name}.py)")
    params = blk.resolve(params)
    if corrupt is not None:
        arrays = {k: np.array(v, copy=True) for k, v in arrays.items()}
        corrupt(arrays)
    stim, exp = blk.streams.to_beats(arrays, params)
    return run_beats(blk, params, stim, exp, **kw)


def run_scene(block, arrays, params=None, **kw):
    """:func:`run_case` on scene arrays (frames and side inputs, see
    :mod:`tdicam.blocks`): parameters fitted to the arrays, golden outputs from the
    block's golden function. Returns (:class:`CaseRun`, the output as scene arrays)."""
    blk = blocks.get(block) if isinstance(block, str) else block
    p = blk.scene_params(arrays, params)
    run = run_case(blk, p, blk.case_arrays(arrays, p), **kw)
    out = blk.from_beats(run.result.out, arrays, p) if run.ok else None
    return run, out


def run_golden_case(block, case, **kw):
    """:func:`run_case` on the stored golden ``case`` (name) of ``block`` (a waveform, if
    any, is named after the case)."""
    blk = blocks.get(block) if isinstance(block, str) else block
    arrays, params = golden.load(blk, case)
    kw.setdefault("label", f"{case}-{kw.get('sim')}-{kw.get('mode', 'fast')}")
    return run_case(blk, params, arrays, **kw)
