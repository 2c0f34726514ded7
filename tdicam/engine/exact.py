"""Exact fidelity: every exposure of every pixel is generated and converted.

Digital TDI (:func:`digital`): each frame row of each stage is cut into chunks of
:data:`~tdicam.engine.streams.CHUNK_PIXELS`; on each chunk (an :class:`Exposure`) the
charge effects of the table run (Poisson charge, full-well clip), then for every ADC channel
the conversion effects (reset sample, read noise, ADC); the frame stacks then go through the
golden blocks and the golden TDI accumulator. Charge-domain TDI (:func:`charge`): the charge
of the m exposures is summed before one conversion.
"""

from __future__ import annotations

import time

import numpy as np

from tdicam.errors import TdicamError
from tdicam.engine.block_rows import LINES, Frames, prepare
from tdicam.engine.streams import CHUNK_PIXELS, chunk_rng, run_chunks, stream

__all__ = ["Exposure", "digital", "charge", "expose", "convert"]

_READ = ("read", "read_lg")
_RESET = ("read_reset", "read_reset_lg")


class Exposure:
    """One chunk of exposures: its mean charge, generators and output frames.

    ``lam`` is the mean charge; the charge effects turn it into ``e``; for each channel the
    conversion effects work on ``v`` (a copy of ``e``) and write ``dst[ch]`` and
    ``reset_dst[ch]``. ``rng(name)`` gives the generator of stream ``name``: per chunk
    (``chunk = (seed, stage, j)``, single precision noise: the parallel digital loop) or the
    whole-pass generators (``gens``, double precision: the charge-domain loop).
    """

    def __init__(self, c, lam, dst, reset_dst, *, chunk=None, gens=None):
        self.lam = lam
        self.e = lam
        self.v = None
        self.dst, self.reset_dst = dst, reset_dst
        self.k = [g / c.sensor.conversion_gain_e_per_dn for g in c.gains]
        self.add = c.offset_dn + 0.5
        self.top = float(c.sensor.full_scale_dn)
        self._chunk = chunk
        self._gens = gens if gens is not None else {}
        self.dt = {}

    def rng(self, name):
        g = self._gens.get(name)
        if g is None:
            seed, s, j = self._chunk
            g = self._gens[name] = chunk_rng(seed, name, s, j)
        return g

    def read_noise(self, ch, r_e):
        """Read noise of the signal sample of channel ``ch`` (electrons)."""
        rng = self.rng(_READ[ch])
        if self._chunk is None:
            return r_e * rng.standard_normal(self.v.shape)
        z = rng.standard_normal(self.v.shape, np.float32)
        z *= np.float32(r_e)
        return z

    def reset_noise(self, ch, r_e):
        """The reset sample of channel ``ch`` in electrons: read noise alone."""
        shape = np.shape(self.e)
        if r_e <= 0:
            return np.zeros(shape)
        rng = self.rng(_RESET[ch])
        if self._chunk is None:
            return r_e * rng.standard_normal(shape)
        v = rng.standard_normal(shape, np.float32).astype(np.float64)
        v *= r_e
        return v


def expose(c, x):
    """The charge effects of the table on exposure chunk ``x``."""
    _steps(c, x, c.steps("charge", named=True))


def convert(c, x):
    """The conversion effects of the table, for every channel, on exposure chunk ``x``."""
    steps = c.steps("conversion", named=True)
    for ch in range(len(c.gains)):
        x.v = np.array(x.e, np.float64)
        _steps(c, x, steps, ch)


def _steps(c, x, steps, *args):
    for name, step in steps:
        t = time.perf_counter()
        step(c, x, *args)
        x.dt[name] = x.dt.get(name, 0.0) + time.perf_counter() - t


def _keeper(keep_frames, m, stacked):
    """Cut the RTL crop (and the m - 1 frames before it) out of a frame stack."""
    if keep_frames is None:
        return None
    y0, h, x0, w = keep_frames

    def keep(a):
        a = np.asarray(a)
        if stacked:
            return a[y0:y0 + h + m - 1, :, x0:x0 + w].copy()
        return a[..., y0:y0 + h, x0:x0 + w].copy()
    return keep


def digital(c, p):
    """Digital TDI: every exposure, the golden blocks, the golden TDI (pass ``p``)."""
    m, lines, ncols = c.m, p.lines, p.ncols
    n_f = lines + m - 1
    rend, grid = p.render_grid(-(m - 1), n_f - 1)
    bits = c.sensor.bits
    dt = np.uint16 if bits <= 16 else np.uint32
    n_ch = len(c.gains)
    frames = [np.empty((n_f, m, ncols), dt) for _ in range(n_ch)]
    resets = [np.empty((n_f, m, ncols), dt) for _ in range(n_ch)] if c.resets \
        else None
    rows = max(1, CHUNK_PIXELS // max(ncols, 1))
    chunks = [(j, a, min(n_f, a + rows)) for j, a in enumerate(range(0, n_f, rows))]
    moving = p.geometry.moving
    S, gain_map, dark_map = c.signal_e, p.pattern.gain, p.pattern.dark

    per_line = c.frame_rows         # an area camera: frame tau is sensor row tau

    def task(s, j, a, b):
        r = c.stage_row(s)
        t = time.perf_counter()
        # frame tau, stage s sees ground line tau - s
        rel = rend.sample(grid, np.arange(a, b) - s, s if moving else None)
        lam = np.multiply(S * rel, gain_map[a:b] if per_line else gain_map[r])
        lam += dark_map[a:b] if per_line else dark_map[r]
        lam = np.broadcast_to(lam, (b - a, ncols))
        x = Exposure(c, lam, [f[a:b, r, :] for f in frames],
                     None if resets is None else [f[a:b, r, :] for f in resets],
                     chunk=(c.seed, s, j))
        x.dt["render"] = time.perf_counter() - t
        expose(c, x)
        convert(c, x)
        return x.dt

    run_chunks(task, [(s, j, a, b) for s in range(m) for j, a, b in chunks], p.timer,
               p.progress, lambda s, j, a, b: (b - a) * ncols)
    r0 = c.stage_row(0)
    raw = frames[0][:lines, r0, :].astype(np.int64)
    prepare(c, gain_map, dark_map)
    if c.keep_raw:
        c.raw_data = {"signal": list(frames), "reset": None if resets is None else list(resets),
                      "coeffs": None, **c.prepared}
    fr = Frames(frames, resets, bits, p.timer, _keeper(p.keep_crop, m, True),
                keep_out=p.keep_crop)
    for step in c.steps("blocks"):
        step(c, fr)
    single = fr.channels[0][:lines, r0, :].astype(np.int64)
    for step in c.steps("lines") + c.steps("output"):
        step(c, fr)
    ped1 = c.zero_dn
    return p.result(fr.out, raw, single, ped1, m * ped1, fr.full_scale, n_f * m * ncols * n_ch,
                    fr.crop)


def charge(c, p):
    """Charge-domain TDI: the charge of m exposures summed, one readout, one conversion."""
    if c.frame_rows:
        raise TdicamError("[pipeline.nuc].coefficients = \"frame\" is an area camera's: "
                          "[tdi].mode must be digital (one stage), not charge")
    m, lines, ncols = c.m, p.lines, p.ncols
    moving = p.geometry.moving
    rend, grid = p.render_grid(0, lines - 1)
    S, gain_map, dark_map = c.signal_e, p.pattern.gain, p.pattern.dark
    gens = {name: stream(c.seed, name) for name in ("shot",) + _READ + _RESET}
    acc = np.zeros((lines, ncols))
    first = None
    g_lines = np.arange(lines)
    for s in range(m):
        r = c.stage_row(s)
        t = time.perf_counter()
        rel = rend.sample(grid, g_lines, s if moving else None)
        lam = (S * rel) * gain_map[r] + dark_map[r]
        p.timer.add("render", time.perf_counter() - t)
        x = Exposure(c, np.broadcast_to(lam, (lines, ncols)), None, None, gens=gens)
        expose(c, x)
        p.timer.merge(x.dt)
        e = np.array(x.e, np.float64)
        if s == 0:
            first = e.copy()
        t = time.perf_counter()
        acc += e
        p.timer.add(LINES, time.perf_counter() - t)
        if p.progress is not None:
            p.progress(lines * ncols)
    fw = c.full_well_e
    if fw is not None:
        np.minimum(acc, fw, out=acc)
    n_ch = len(c.gains)
    with_resets = c.resets

    def conv(e):
        dst = [np.empty(e.shape, np.int64) for _ in range(n_ch)]
        rst = [np.empty(e.shape, np.int64) for _ in range(n_ch)] if with_resets else None
        return Exposure(c, e, dst, rst, gens=gens)
    xs = [conv(acc), conv(first)]
    steps = c.steps("conversion", named=True)
    for ch in range(n_ch):          # the whole-pass generators: sum first, then stage 0
        for x in xs:
            x.v = np.array(x.e, np.float64)
            _steps(c, x, steps, ch)
            p.timer.merge(x.dt)
            x.dt = {}
    out_x, one_x = xs
    raw = one_x.dst[0].astype(np.int64)
    keep = _keeper(p.keep_crop, m, False)
    # charge TDI: each output pixel's response is the column mean of the window's gains
    prepare(c, gain_map.mean(axis=0, keepdims=True), dark_map.sum(axis=0, keepdims=True))
    fr = Frames([d[None] for d in out_x.dst], None if not with_resets else
                [d[None] for d in out_x.reset_dst], c.sensor.bits, p.timer, keep,
                keep_out=p.keep_crop)
    for step in c.steps("blocks"):
        step(c, fr)
    prepare(c, gain_map[:1], dark_map[:1])           # the single exposure: its own row
    fr1 = Frames([d[None] for d in one_x.dst], None if not with_resets else
                 [d[None] for d in one_x.reset_dst], c.sensor.bits, p.timer)
    for step in c.steps("blocks"):
        step(c, fr1)
    fr.out = fr.channels[0][0].astype(np.int64)
    single = fr1.channels[0][0].astype(np.int64)
    fr.full_scale = (1 << fr.bits) - 1
    ped = c.zero_dn
    for step in c.steps("output"):
        step(c, fr)
    return p.result(fr.out, raw, single, ped, ped, fr.full_scale, lines * m * ncols, fr.crop)
