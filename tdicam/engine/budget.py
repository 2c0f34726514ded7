"""Peak memory of a ``tdicam run``, estimated from the scene before any work, and the memory
the machine has for it.

:func:`estimate` adds up the arrays the scene simulator holds at its fullest moment — the
frame stacks of exact digital TDI (``lines + m - 1`` frames of ``m`` rows per ADC channel,
and their reset frames with CDS), the fine render grid of a two-dimensional target, the
largest temporaries of the pipeline blocks' golden models, the images of the result and
the copies made to write them — for every point of the scene's sweep at the fidelity it
will run at, plus the interpreter and its libraries (:data:`BASE_BYTES`). The coefficients
are the measured bytes per array element of each stage (``bench/bench_memory.py`` prints
estimate and measured peak RSS side by side for the bundled scenes).

:func:`available_bytes` is what the process may still use: ``MemAvailable`` of
``/proc/meminfo`` (else the free physical pages), lowered by a cgroup memory limit and an
address-space limit (``ulimit -v``) when one is set. :func:`check_fits` refuses, in one line,
a run that needs more.
"""

from __future__ import annotations

import os
import resource
from dataclasses import dataclass, field
from pathlib import Path

from tdicam.errors import TdicamError

from tdicam.engine.block_rows import ROWS
from tdicam.engine.context import decide
from tdicam.engine.streams import CHUNK_PIXELS
from tdicam.threads import threads

__all__ = ["BASE_BYTES", "MemoryEstimate", "estimate", "available_bytes", "check_fits",
           "gib"]

#: Resident memory of the interpreter, numpy, scipy and tdicam while the simulator runs,
#: and with matplotlib and PIL loaded while the result is measured and written (measured:
#: ~65 MB and ~105 MB; a 1-line run peaks at ~110 MB).
BASE_BYTES = 105 << 20
_BASE_SIM_BYTES = 68 << 20
#: scikit-image and its sample picture, loaded for a bundled-picture target.
_SKIMAGE_BYTES = 16 << 20
#: Impact study crop (lines, columns): see ``tdicam.engine._IMPACT_LINES``/``_IMPACT_COLS``.
_IMPACT = (32, 256)


def gib(n):
    """``n`` bytes as a short text in GiB (MiB below 1 GiB)."""
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.0f} MiB"


@dataclass
class MemoryEstimate:
    """The estimated peak resident memory of one run (bytes), what it is made of and the
    fidelity each sweep point runs at."""

    peak_bytes: int
    parts: dict = field(default_factory=dict)
    fidelity: dict = field(default_factory=dict)
    available_bytes: int | None = None
    options: dict = field(default_factory=dict)    # the arguments of estimate()

    def to_dict(self):
        """JSON form (the ``"memory"`` entry of report.json)."""
        return {"estimated_peak_bytes": int(self.peak_bytes),
                "estimated_peak": gib(self.peak_bytes),
                "available_bytes": self.available_bytes,
                "available": None if self.available_bytes is None
                else gib(self.available_bytes),
                "parts_bytes": {k: int(v) for k, v in self.parts.items()},
                "fidelity_per_point": dict(self.fidelity)}


def _target_shape(scene, lines):
    """(axes, oversample) of the scene's target without building a picture."""
    from tdicam.model.physics.targets import make_target
    t = make_target(scene.target, columns=scene.sensor.columns, lines=lines)
    return t.axes, t.oversample


def _pass_bytes(c, lines, ncols, axes, k):
    """Peak bytes of one pass of context ``c`` over ``lines`` x ``ncols`` output pixels
    (result images included)."""
    from tdicam.engine import geometry
    n = float(lines) * ncols
    m = c.m
    geo = geometry(c)[0]
    tgt = 8.0 * n if "x" in axes else 8.0 * lines
    held = 24.0 * n + tgt
    chunk_px = float(min(n, ncols * max(1, CHUNK_PIXELS // max(ncols, 1))))
    if c.fast:
        per = (m + 8) if (geo.moving and "x" in axes) else 10
        return 28.0 * n + tgt + threads() * chunk_px * 8.0 * per
    n_ch = len(c.gains)
    resets = 2 if c.resets else 1
    if not c.digital:
        return 8.0 * n * (7 + 4 * n_ch * resets) + tgt
    n_f = lines + m - 1
    elems = float(n_f) * m * ncols
    stacks = elems * (2 if c.sensor.bits <= 16 else 4) * n_ch * resets
    ky = k if "y" in axes else 0
    kx = k if "x" in axes else 0
    grid = 0.0
    if ky and kx:
        rows = ky * (n_f * abs(geo.speed) + m + 8)
        cols = kx * (ncols + abs(geo.line_shear) * n_f + 8)
        grid = 8.0 * rows * cols
    work = threads() * CHUNK_PIXELS * 8.0 * 6
    # each block's figures are in its registry entry (SceneSim.scratch_bytes, SceneSim.post_bytes:
    # measured with tracemalloc on the bundled chains); its engine steps are its rows of the
    # effects table (ROWS), the "post" one on the output of the line-making block
    coeff = max([r.block.pipeline.sim.scratch_bytes for r in ROWS
                 if r.sim.where != "post" and c.ran(r.name)] or [0.0])
    post_bytes = sum(r.block.pipeline.sim.post_bytes for r in ROWS
                     if r.sim.where == "post" and c.ran(r.name))
    render = stacks + 3 * grid + work
    blocks = stacks + grid + 8.0 * n + elems * coeff
    post = held + grid + post_bytes * n
    return max(render, blocks, post)


def estimate(scene, *, fidelity=None, lines=None, force=(), impact=True, rtl=True):
    """Peak resident memory of ``tdicam run`` on ``scene``, before any work.

    Parameters
    ----------
    scene : tdicam.scene.Scene
    fidelity : {"exact", "fast", "auto"}, optional
        Default ``[run].fidelity``; ``auto`` is resolved per sweep point as the run does.
    lines : int, optional
        Default ``[run].lines``.
    force : iterable of str
        Effects forced on (``--force``).
    impact : bool
        The per-effect impact study runs (one crop pass at a time).
    rtl : bool
        The ``[run.rtl]`` co-simulation runs (when the scene has one): its input is an exact
        simulation of the main point with the raw frames kept, made beside the result (the
        simulators themselves run in processes of their own).

    Returns
    -------
    MemoryEstimate
        ``peak_bytes`` and its parts: ``base`` (interpreter and libraries), ``simulation``
        (the largest sweep point, with the main result held when others follow it),
        ``output`` (the result and the copies made to measure and write it), ``impact``,
        ``rtl_input``.
    """
    fid = scene.run.fidelity if fidelity is None else fidelity
    n_lines = int(scene.run.lines if lines is None else lines)
    cols = scene.sensor.columns
    stages, dvs = scene.tdi.stages, scene.motion.dv_over_v
    m_show = max(stages)
    axes, k = _target_shape(scene, n_lines)
    n = float(n_lines) * cols
    tgt = 8.0 * n if "x" in axes else 8.0 * n_lines
    held = 24.0 * n + tgt
    sim, fids, main_c = 0.0, {}, None
    points = [(m, dv) for m in stages for dv in dvs]
    from tdicam.engine import check_point
    for i, (m, dv) in enumerate(points):
        check_point(scene, m, dv, fid, force)
        c = decide(scene, m, dv, fid, force, ())
        fids[f"m={m} dv/V={dv:g}"] = "fast" if c.fast else "exact"
        after_main = any(p == (m_show, dvs[0]) for p in points[:i])
        sim = max(sim, _pass_bytes(c, n_lines, cols, axes, k) + (held if after_main else 0))
        if (m, dv) == (m_show, dvs[0]):
            main_c = c
    pattern = 2 * 16.0 * m_show * cols
    output = held + 25.0 * n + (8.0 * n if "x" in axes else 0.0)
    imp = 0.0
    if impact and main_c is not None:
        imp = held + _pass_bytes(main_c, min(n_lines, _IMPACT[0]), min(cols, _IMPACT[1]),
                                 axes, k)
    cosim = 0.0
    if rtl and scene.run.rtl is not None and main_c is not None:
        c = decide(scene, m_show, dvs[0], "exact", force, ())
        cosim = held + _pass_bytes(c, n_lines, cols, axes, k)
    parts = {"base": float(BASE_BYTES), "fixed_pattern": pattern, "simulation": sim,
             "output": output, "impact": imp, "rtl_input": cosim}
    if scene.target.kind == "image" and scene.target.image is not None:
        parts["base"] += _SKIMAGE_BYTES
        pattern += _SKIMAGE_BYTES
    peak = max(_BASE_SIM_BYTES + pattern + max(sim, imp), parts["base"] + max(output, cosim))
    opts = {"fidelity": fidelity, "force": tuple(force), "impact": impact, "rtl": rtl}
    return MemoryEstimate(int(peak), parts, fids, options=opts)


def _read_int(path):
    try:
        text = Path(path).read_text(errors="replace").strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def available_bytes():
    """Bytes this process may still allocate: ``MemAvailable`` (``/proc/meminfo``; else the
    free physical pages), lowered by a cgroup v2 memory limit and by ``RLIMIT_AS``; None when
    none of them can be read."""
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError, AttributeError):
            pass
    limits = []
    lim, cur = _read_int("/sys/fs/cgroup/memory.max"), _read_int("/sys/fs/cgroup/memory.current")
    if lim is not None and cur is not None:
        limits.append(max(0, lim - cur))
    try:
        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (OSError, ValueError):
        soft = resource.RLIM_INFINITY
    if soft != resource.RLIM_INFINITY:
        limits.append(max(0, soft - _vm_size()))
    vals = [v for v in [avail] + limits if v is not None]
    return min(vals) if vals else None


def _vm_size():
    """Address space this process already uses (bytes; 0 when unknown)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def check_fits(scene, est, *, fidelity=None, lines=None, labels=None):
    """Raise a one-line :class:`TdicamError` when ``est`` exceeds the available memory (and
    store that in ``est.available_bytes``): how much the run needs, how much there is, and
    what to change — the lines that would fit, the width, fast fidelity when it is smaller.

    ``labels`` names the keys as the user wrote them (``{"run.lines": "--lines"}``)."""
    labels = labels or {}
    avail = available_bytes()
    est.available_bytes = avail
    if avail is None or est.peak_bytes <= avail:
        return est
    n_lines = int(scene.run.lines if lines is None else lines)
    fid = scene.run.fidelity if fidelity is None else fidelity
    lines_key = labels.get("run.lines", "[run].lines")
    fid_key = "--fidelity" if fidelity is not None else "[run].fidelity"
    # the largest line count that fits, by bisection on the estimate (cheap: arithmetic)
    lo, hi = 0, n_lines
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if estimate(scene, **{**est.options, "lines": mid}).peak_bytes <= avail:
            lo = mid
        else:
            hi = mid
    hints = [f"{lines_key} <= {lo}" if lo >= 1 else
             f"fewer than {scene.sensor.columns} [sensor].columns"]
    if lo >= 1:
        hints.append(f"fewer [sensor].columns (now {scene.sensor.columns})")
    if fid != "fast":
        fast = estimate(scene, **{**est.options, "fidelity": "fast", "lines": n_lines}
                        ).peak_bytes
        if fast < est.peak_bytes:
            hints.append(f"{fid_key} = 'fast' (needs about {gib(fast)})")
    raise TdicamError(
        f"{lines_key} = {n_lines} x [sensor].columns = {scene.sensor.columns} at "
        f"{max(scene.tdi.stages)} stages, fidelity {fid}: the run needs about "
        f"{gib(est.peak_bytes)} of memory and {gib(avail)} is available; use "
        + ", or ".join(hints))
