"""Fast fidelity: the m exposures of a ground line aggregated (see :mod:`tdicam.engine`).

Output lines are cut in chunks of :data:`~tdicam.engine.streams.CHUNK_PIXELS`; on each chunk
the summed mean charge (rendering and fixed pattern as in exact, full well clipped on the
mean of every exposure) becomes an :class:`Aggregate` on which the fast implementations of
the table run in order — shot noise (Normal of the summed variance, Poisson where the summed
mean is small), full well (charge domain), read noise (summed variance), quantization (one
rounding plus ``Normal((n - 1)/12)``) — or, where the noise does not dither the ADC,
:func:`moment_sum` draws the sum of the roundings with their exact moments. The raw single
exposure of every output line is drawn exactly with its chunk (stage 0,
:func:`tdicam.engine.exact.expose` / ``convert``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError

from tdicam.model.physics import sensor as _sensor

from tdicam.engine.block_rows import Frames, subtract_reset
from tdicam.engine.exact import Exposure, convert, expose
from tdicam.engine.streams import CHUNK_PIXELS, chunk_rng, run_chunks

__all__ = ["Aggregate", "path", "shot_noise", "full_well", "read_noise", "quantization",
           "moment_sum", "integer_draw"]


@dataclass
class Aggregate:
    """The sum of the m exposures (digital) or the one readout (charge) of a chunk of output
    pixels on its way to integers: mean charge ``lam`` (e-), DN per electron ``k``, the
    variance in DN so far (``sd`` per pixel, ``var_dn`` common), the value in DN ``x``,
    conversions summed ``n_conv``, the summed pedestal ``pedm``, full scale ``top``."""

    lam: np.ndarray
    k: float
    n_conv: int
    pedm: float
    top: int
    gauss_min: float
    rng_q: object
    rng_shot: object
    out: np.ndarray
    sd: np.ndarray | None = None
    x: np.ndarray | None = None
    small: np.ndarray | None = None
    var_dn: float = 0.0


def shot_noise(c, a):
    """Poisson charge of the summed mean: a Normal of the same mean and variance where the
    mean is >= ``1 / (4 tolerance^2)`` (Berry-Esseen distance < tolerance), Poisson below."""
    a.small = np.flatnonzero(a.lam < a.gauss_min)
    a.sd = a.lam * (a.k * a.k)
    if a.small.size:
        a.sd.flat[a.small] = 0.0
    a.x = a.lam * a.k
    if a.small.size:
        a.x.flat[a.small] = a.rng_shot.poisson(a.lam.flat[a.small]) * a.k


def full_well(c, a):
    """Charge domain: the summed charge clipped at the full well (digital TDI clips every
    exposure's mean before the sum, in :func:`path`)."""
    if not c.digital and a.small is not None:
        np.minimum(a.x, c.sensor.full_well_e * a.k, out=a.x)


def read_noise(c, a):
    """Read noise of every conversion summed: ``Normal(0, n r^2)``."""
    var_read = (c.n_reads * (c.m if c.digital else 1)) * c.read_noise_e * c.read_noise_e
    a.var_dn += var_read * a.k * a.k


def quantization(c, a):
    """n roundings -> one rounding of the sum plus ``Normal(0, (n - 1)/12)`` DN."""
    a.var_dn += (a.n_conv - 1) / 12.0
    z = a.rng_q.standard_normal(a.lam.shape, dtype=np.float32)
    sd = a.sd if a.sd is not None else np.zeros(a.lam.shape)
    sd += a.var_dn
    np.sqrt(sd, out=sd)
    sd *= z
    x = a.x if a.x is not None else a.lam * a.k
    x += sd
    x += a.pedm + 0.5
    np.clip(x, 0.0, a.top + 0.5, out=x)
    a.out[...] = x                      # truncation of x >= 0: round half up


def path(c, p):
    """Fast fidelity over pass ``p``."""
    if c.frame_rows:
        raise TdicamError("[pipeline.nuc].coefficients = \"frame\" (a fixed pattern row per "
                          "line) runs at exact fidelity only: set [run].fidelity = \"exact\"")
    m, lines, ncols = c.m, p.lines, p.ncols
    sen = c.sensor
    moving = p.geometry.moving
    digital = c.digital
    S, gain_map, dark_map = c.signal_e, p.pattern.gain, p.pattern.dark
    k = c.gains[0] / sen.conversion_gain_e_per_dn
    n_conv = c.n_reads * (m if digital else 1)        # conversions summed per output pixel
    tol = c.scene.run.tolerance
    gauss_min = 0.25 / tol / tol          # inf (all Poisson) for a tolerance below ~1e-154
    r_rows = [c.stage_row(s) for s in range(m)]
    gsum = gain_map[r_rows].sum(axis=0) if not moving else None
    dsum = dark_map.sum(axis=0)
    out = np.empty((lines, ncols), np.int64)
    raw = np.empty((lines, ncols), np.int64)
    single = np.empty((lines, ncols), np.int64)
    chunk = max(1, min(lines, CHUNK_PIXELS // max(ncols, 1)))
    ped = c.offset_dn if not c.resets else 0.0
    pedm = ped * (m if digital else 1)
    fw = c.full_well_e
    r0 = r_rows[0]
    top = (1 << (sen.bits + (int(m) - 1).bit_length() if digital else sen.bits)) - 1
    gmat = gain_map[r_rows] if moving else None        # (m, W): row weight of each stage
    gsum_all = gain_map[r_rows].sum(axis=0)
    rend = p.renderer
    steps = c.steps("charge", fast=True) + c.steps("conversion", fast=True)
    c1 = c.with_effects(c.on - {"dual_gain"})         # the raw exposure: HG channel only

    def work(ci, lo, hi):
        """Output lines lo..hi-1 (and their raw exposure) from the generators of chunk ci."""
        dt = {}
        rng_q = chunk_rng(c.seed, "quant", 0, ci)
        rng_shot = chunk_rng(c.seed, "shot", 0, ci)
        g_lines = np.arange(lo, hi)
        t = time.perf_counter()
        grid = rend.grid(lo, hi - 1)
        if moving and c.fast_fpn_mean and fw is None:
            # sum_s rel_s w_s ~ mean_s(rel_s) sum_s w_s: error prnu std_s(rel)/sqrt(m)
            first = rend.sample(grid, g_lines, 0)
            mu = (S * rend.stage_mean(grid, g_lines)) * gsum_all
        elif moving:
            rels = [rend.sample(grid, g_lines, s) for s in range(m)]
            first = rels[0]
            if fw is not None:
                mu = sum(np.minimum((S * rels[s]) * gmat[s] + dark_map[r_rows[s]], fw)
                         - dark_map[r_rows[s]] for s in range(m))
            elif rels[0].shape[1] == 1:
                # target constant across track: sum_s rel_s(g) w_s(x) is a matrix product
                mu = S * (np.concatenate(rels, axis=1) @ gmat)
            else:
                mu = np.zeros((hi - lo, ncols))
                for s in range(m):
                    mu += (S * rels[s]) * gmat[s]
        else:
            rel = rend.sample(grid, g_lines, None)
            first = rel
            if fw is not None:
                mu = sum(np.minimum((S * rel) * gain_map[rr] + dark_map[rr], fw)
                         - dark_map[rr] for rr in r_rows)
            else:
                mu = (S * rel) * gsum
        lam = mu + dsum
        if lam.shape != (hi - lo, ncols):
            lam = np.broadcast_to(lam, (hi - lo, ncols)).copy()
        dt["render"] = time.perf_counter() - t
        t = time.perf_counter()
        if c.quant_moments and n_conv > 1:
            # noise too small to dither the ADC: sum the exact mean and variance of every
            # rounding (model.sensor.quantized_moments) instead of m roundings -> 1 + (n-1)/12
            rel_s = [rend.sample(grid, g_lines, s) for s in range(m)] if moving else [rel] * m
            x = moment_sum(c, rel_s, gain_map, dark_map, r_rows, k, (hi - lo, ncols), rng_q)
            np.clip(x, 0.0, top + 0.5, out=x)
            out[lo:hi] = x
            dt["quantization"] = time.perf_counter() - t
        else:
            a = Aggregate(lam, k, n_conv, pedm, top, gauss_min, rng_q, rng_shot, out[lo:hi])
            for step in steps:
                step(c, a)
            dt["shot_noise"] = time.perf_counter() - t
        # the raw exposure of these ground lines: stage 0 alone, exact
        t = time.perf_counter()
        lam1 = np.broadcast_to((S * first) * gain_map[r0] + dark_map[r0], (hi - lo, ncols))
        rst1 = [np.empty((hi - lo, ncols), np.int64)] if c.resets else None
        x = Exposure(c1, lam1, [raw[lo:hi]], rst1, chunk=(c.seed, 0, ci),
                     gens={"shot": rng_shot})
        expose(c1, x)
        convert(c1, x)
        if rst1 is not None:
            single[lo:hi] = subtract_reset(c, raw[lo:hi], rst1[0], sen.bits)
        else:
            single[lo:hi] = raw[lo:hi]
        dt["raw_exposure"] = time.perf_counter() - t
        return dt

    run_chunks(work, [(ci, lo, min(lines, lo + chunk))
                      for ci, lo in enumerate(range(0, lines, chunk))],
               p.timer, p.progress,
               # in the exact engine's units ((lines + m - 1) x m x columns exposures in all):
               # the last chunk also counts the m - 1 lines that fill the window
               lambda ci, lo, hi: (hi - lo + (m - 1) * (hi == lines)) * ncols * m)
    fr = Frames([out], None, sen.bits, p.timer, out=out, full_scale=top)
    for step in c.steps("lines", fast=True) + c.steps("output", fast=True):
        step(c, fr)
    return p.result(fr.out, raw, single, ped, pedm, fr.full_scale, lines * m * ncols, fr.crop)


def moment_sum(c, rel_s, gain_map, dark_map, r_rows, k, shape, rng_q):
    """Sum of the m (digital) or 1 (charge) conversions of each output pixel, drawn as a
    Normal with the exact mean and variance of every rounding, plus 1/2 (for truncation)."""
    S = c.signal_e
    fw = c.full_well_e
    digital = c.digital
    shot = c.ran("shot_noise")
    r_e = c.read_noise_e
    mean = np.zeros((1, 1))
    var = np.zeros((1, 1))
    lam_all = 0.0

    def flat(rel):
        # a target constant along the lines: one row of moments serves every line
        return rel[:1] if rel.shape[0] > 1 and np.all(rel == rel[:1]) else rel
    for s, rr in enumerate(r_rows):
        lam = (S * flat(rel_s[s])) * gain_map[rr] + dark_map[rr]
        if fw is not None:
            lam = np.minimum(lam, fw)
        if not digital:
            lam_all = lam_all + lam
            continue
        mu_s, v_s = _sensor.quantized_moments(
            lam * k + c.offset_dn, k * np.sqrt((lam if shot else 0.0) + r_e * r_e))
        mean = mean + mu_s
        var = var + v_s
    if not digital:
        if fw is not None:
            lam_all = np.minimum(lam_all, fw)
        mean, var = _sensor.quantized_moments(lam_all * k + c.offset_dn,
                                              k * np.sqrt((lam_all if shot else 0.0)
                                                          + r_e * r_e))
    n_sig = len(r_rows) if digital else 1
    if c.resets:
        mu_r, v_r = _sensor.quantized_moments(c.offset_dn, k * r_e)
        mean = mean - n_sig * mu_r
        var = var + n_sig * v_r
    return integer_draw(np.broadcast_to(mean, shape), np.broadcast_to(var, shape), rng_q)


def integer_draw(mean, var, rng):
    """Integers with exactly the given mean and variance (plus 1/2, for truncation).

    Variance <= 3/4: ``F + Y``, ``F = round(mean)``, ``Y`` in {-1, 0, 1} with
    ``P(+-1) = (var + d^2 +- d) / 2``, ``d = mean - F`` (valid for every integer variable's
    moments). Above: ``round(Normal(mean, var - 1/12))``, whose rounding the Normal dithers
    (Widrow defect < 2e-6).
    """
    f = np.floor(mean + 0.5)
    d = mean - f
    u = rng.random(mean.shape)
    p_dn = np.clip((var + d * d - d) * 0.5, 0.0, 1.0)
    p_up = np.clip((var + d * d + d) * 0.5, 0.0, 1.0)
    small = f + (u < p_up) - ((u >= p_up) & (u < p_up + p_dn))
    z = rng.standard_normal(mean.shape)
    big = mean + np.sqrt(np.maximum(var - 1.0 / 12.0, 0.0)) * z
    return np.where(var <= 0.75, small, big) + 0.5
