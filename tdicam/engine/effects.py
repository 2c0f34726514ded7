"""The scene simulator's table of effects, in physical order, and the context of a run.

Each :class:`Effect` entry says, in one place, what one physical effect is: its name and
label, when a scene needs it and why (:attr:`Effect.need`, the reason the report prints),
its stated error bound in the fast aggregate (:attr:`Effect.bound`, with what fast does
instead, :attr:`Effect.fast_note`), and its implementations: ``render`` (how it shapes what
each exposure sees, the same in both fidelities), ``pattern`` (its share of the fixed
pattern), ``exact`` (what it does to one chunk of exposures in the exact path) and ``fast``
(what it does to the aggregated sum of the m exposures). The engine runs the entries that
ran, in table order (:meth:`tdicam.engine.context.RunContext.steps`).

The pipeline blocks are entries too, generated from the block registry: one per
:class:`tdicam.blocks.steps.Sim` row of a block's entry (:mod:`tdicam.engine.block_rows`), after
the physical effects.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from tdicam import blocks
from tdicam.engine import block_rows, fast
from tdicam.engine.streams import stream

__all__ = ["Effect", "EFFECTS", "EFFECT_NAMES", "FORCIBLE", "FixedPattern", "rounding_defect",
           "MOMENTS_BELOW_DITHER", "dark_charge_e", "stage_skew"]

#: Fast fidelity sums exact per-rounding moments where the Widrow defect exceeds this.
MOMENTS_BELOW_DITHER = 1e-4


@dataclass(frozen=True)
class Effect:
    """One physical effect (or pipeline block) of the scene simulator.

    Attributes
    ----------
    name, label : str
        Key (``--force``, ``--disable``, report) and the report's label.
    need : callable(RunContext) -> (bool, str)
        Whether the scene needs the effect, and why (printed in the report).
    bound : callable(RunContext) -> dict, optional
        Named error bounds of the fast aggregate for this effect (``{}``: exact in
        distribution); ``auto`` runs fast when the largest is within ``[run].tolerance``.
    fast_note : callable(RunContext, dict) -> (float, str) or None, optional
        The bound the record states in fast fidelity and what fast does instead.
    stage : str
        Where its implementations act: ``render`` (keywords of
        :class:`~tdicam.model.physics.optics.Geometry` and the renderer), ``pattern`` (the window
        rows' :class:`FixedPattern`), ``charge`` and ``conversion`` (one
        :class:`~tdicam.engine.exact.Exposure` chunk in the exact path, the
        :class:`~tdicam.engine.fast.Aggregate` in the fast path), ``blocks`` (frame stacks
        before the line-making block), ``lines`` (the line-making block, TDI), ``output``
        (after it).
    exact, fast : callable, optional
        Its implementation in the exact path and on the fast aggregate (the same function
        where fast fidelity does not change it; None where it has no step of its own there).
    forcible : bool
        Can run at zero strength (``--force``; the output must equal the skipped one).
    aggregated : bool
        Fast fidelity changes how it is computed (the record shows the fidelity used).
    per_exposure : bool
        A non-linear block on single exposures: fast cannot aggregate it (runs exact).
    """

    name: str
    label: str
    need: Callable
    bound: Callable | None = None
    fast_note: Callable | None = None
    stage: str = ""
    exact: Callable | None = None
    fast: Callable | None = None
    forcible: bool = False
    aggregated: bool = False
    per_exposure: bool = False


# --------------------------------------------------------------------------------------
# when each effect is needed, and why
# --------------------------------------------------------------------------------------


def dark_charge_e(sc):
    """Dark charge of one exposure (one line period), electrons."""
    return sc.sensor.dark_current_e_per_s * sc.line_period_s


def stage_skew(sc, m):
    """Rolling-shutter skew per stage (line periods), 0 where it does not apply."""
    t_row = sc.sensor.row_time_s
    if sc.sensor.shutter == "global" or m == 1 or t_row is None:
        return 0.0
    return (t_row / sc.line_period_s) * (1.0 if sc.tdi.direction == "forward" else -1.0)


def _need_optics(c):
    sig = c.scene.optics.psf_sigma_px
    return sig > 0, (f"Gaussian PSF sigma {sig:g} px" if sig > 0
                     else "[optics].psf_sigma_px = 0: perfect lens")


def _need_aperture(c):
    return True, (f"every pixel integrates its active area (q/p = {c.sensor.q_over_p:.3g}) "
                  f"while the image moves {1 - c.dv:.4g} px in the line period")


def _need_smear(c):
    m, dv, drift = c.m, c.dv, c.scene.motion.drift_deg
    if dv == 0 and drift == 0:
        return False, "dV/V = 0 and no drift"
    if m == 1:
        # one stage: nothing to misregister, but the image still moves 1 - dV/V px (and
        # tan(drift) across) per line period, which sets the exposure smear and line spacing
        return True, (f"1 stage: the image moves {1 - dv:.4g} px along and "
                      f"{(1 - dv) * math.tan(math.radians(drift)):.3g} px across per line "
                      f"period (dV/V = {dv:g}, drift {drift:g} deg); no stages to misregister")
    return True, (f"dV/V = {dv:g}, drift {drift:g} deg: M dV/V = {m * dv:.3g} px along, "
                  f"M tan(drift) = {m * math.tan(math.radians(drift)):.3g} px across")


def _need_rolling_skew(c):
    sen, m = c.sensor, c.m
    t_row, t_line = sen.row_time_s, c.scene.line_period_s
    if sen.shutter == "global":
        return False, "global shutter: all rows expose together"
    if m == 1:
        return False, "1 stage: no stage-to-stage skew"
    if t_row is None:
        return False, ("rolling shutter but no row time ([sensor].pixel_clock_mhz or "
                       "max_frame_rate_hz): skew unknown")
    return True, (f"T_row/T_line = {t_row / t_line:.4g} per stage, {m * t_row / t_line:.3g} px "
                  f"over {m} stages ({c.scene.tdi.direction} scan)")


def _when_positive(key, said, zero):
    """``need`` of an impairment that runs when ``[sensor].<key>`` is > 0."""
    def need(c):
        v = getattr(c.sensor, key)
        return v > 0, (said(v) if v > 0 else zero)
    return need


_need_prnu = _when_positive("prnu", lambda p: f"PRNU {100 * p:g} % RMS", "PRNU = 0")


def _need_dark_current(c):
    d = c.sensor.dark_current_e_per_s
    return d > 0, (f"{d:g} e-/s x {c.scene.line_period_s * 1e6:.4g} us = {c.dark_e:.3g} e- "
                   f"per exposure" if d > 0 else "dark current = 0")


_need_dsnu = _when_positive("dsnu_e", lambda d: f"DSNU {d:g} e- RMS", "DSNU = 0")


def _need_shot_noise(c):
    lit = c.signal_e > 0 or c.dark_e > 0
    return lit, ("charge is Poisson" if lit else "no light and no dark current")


def _need_full_well(c):
    sen = c.sensor
    peak = c.signal_e * (1 + 4 * sen.prnu) + c.dark_e + 4 * sen.dsnu_e
    if not c.digital:
        peak *= c.m
    reach = peak + 5 * math.sqrt(max(peak, 0.0))
    need = reach >= sen.full_well_e
    return need, (f"{'brightest exposure' if c.digital else 'charge sum'} reaches {reach:.4g} "
                  f"e- (mean + 5 sigma) {'>=' if need else '<'} full well "
                  f"{sen.full_well_e:g} e-")


def _need_reset_frames(c):
    takers = [b for b in c.scene.pipeline.blocks if blocks.get(b).pipeline.elems == 2]
    return bool(takers), (f"the {takers[0]} block subtracts a reset frame" if takers
                          else "no cds block in the pipeline")


_need_read_noise = _when_positive("read_noise_e", lambda r: f"{r:g} e- RMS per sample",
                                  "read noise = 0")


def _need_dual_gain(c):
    g = c.sensor.gains
    return len(g) == 2, (f"gains HG x{g[0]:g} / LG x{g[1]:g}" if len(g) == 2
                         else "one-gain sensor")


def _need_quantization(c):
    sen = c.sensor
    return True, f"{sen.bits}-bit ADC, {sen.conversion_gain_e_per_dn:.4g} e-/DN at gain 1"


def _lvds_bad_lanes(c):
    """Lanes of ``[sensor.lvds]`` that cannot train (empty when the link is ideal)."""
    from tdicam.model import lvds_front
    return lvds_front.scene_untrained_lanes(c.sensor.lvds, len(c.sensor.gains), c.seed)


def _need_lvds(c):
    lv = c.sensor.lvds
    if lv is None:
        return False, "no [sensor.lvds]: ideal lanes, no link simulated"
    n = lv.lanes_per_gain * len(c.sensor.gains)
    why = (f"{n} lanes at {lv.bit_rate_mbps:g} Mb/s, {lv.word_bits}-bit words, lane k of "
           f"{lv.lanes_per_gain} carries columns k, k+{lv.lanes_per_gain}, ...")
    if c.sensor.bits == lv.word_bits:
        why += f"; code {(1 << lv.word_bits) - 1} is the sync word (sent as one less)"
    if lv.simulate:
        bad = _lvds_bad_lanes(c)
        why += (f"; eyes and jitter given: every lane's training simulated (link model), "
                + (f"lanes {', '.join(map(str, bad))} fail: their columns are invalid (0)"
                   if bad else "all lanes lock"))
    else:
        why += "; no eye given: the link is ideal (training not simulated)"
    return True, why


def _exact_lvds(c, fr):
    """The frames as the front delivers them: wire codes, invalid lanes' columns 0."""
    from tdicam.model import lvds_front
    lv = c.sensor.lvds
    bad = _lvds_bad_lanes(c)
    n_g = len(c.sensor.gains)

    def deliver(stacks):
        out = []
        for k, a in enumerate(stacks):
            inv = lvds_front.invalid_columns(bad, a.shape[-1], lv.lanes_per_gain, n_g)[k]
            b = np.minimum(a, (1 << lv.word_bits) - 2).astype(a.dtype, copy=False)
            if inv.any():
                b = b.copy() if b is a else b
                b[..., inv] = 0
            out.append(b)
        return out
    fr.channels = deliver(fr.channels)
    if fr.resets is not None:
        fr.resets = deliver(fr.resets)
    if bad:
        note = (f"[sensor.lvds]: lanes {', '.join(map(str, bad))} did not train; their "
                f"columns are invalid (0) in every frame")
        if note not in c.notes:
            c.notes.append(note)


# --------------------------------------------------------------------------------------
# fast-aggregate bounds
# --------------------------------------------------------------------------------------


def _dark_rel(sc):
    """Darkest level of the scene relative to the bright one (1 for flat, 0 for pictures)."""
    kind = sc.target.kind
    if kind == "flat":
        return 1.0
    if kind in ("bars", "edge", "siemens"):
        cc = sc.target.contrast
        return (1 - cc) / (1 + cc)
    return 0.0


def _sigma_dn(c):
    """Temporal noise in front of the ADC at the darkest level of the scene, in DN."""
    sen = c.sensor
    conv = sen.conversion_gain_e_per_dn / sen.gains[0]
    var_e = _shot_e(c) + (sen.read_noise_e ** 2 if c.records["read_noise"].ran else 0.0)
    return math.sqrt(var_e) / conv


def _shot_e(c):
    """Mean charge (Poisson) at the darkest level of the scene, electrons (0 without shot
    noise)."""
    if not c.records["shot_noise"].ran:
        return 0.0
    return c.signal_e * _dark_rel(c.scene) + c.dark_e


def rounding_defect(shot_e, e_per_dn, read_dn):
    """Largest dependence of the ADC's rounding error on the signal, for Poisson charge of
    mean ``shot_e`` (electrons, ``e_per_dn`` per DN) plus Normal read noise ``read_dn`` DN.

    The rounding error's mean and correlation deviate from a uniform, independent error by
    the characteristic function of the value in front of the ADC at the harmonics
    ``2 pi j`` of the DN grid: ``|phi_j| = exp(-shot_e (1 - cos(2 pi j / e_per_dn)))
    exp(-2 pi^2 j^2 read_dn^2)``. The Poisson factor does not decay with ``j``: the charge is
    a lattice of ``1 / e_per_dn`` DN spacing, whose harmonics near ``j = n e_per_dn`` are
    barely damped at low light (Widrow's Gaussian bound ``exp(-2 pi^2 sigma^2)``, the
    ``j = 1`` term, misses them). Returns ``max_j |phi_j|`` over ``j = 1 ..
    max(8, 2 e_per_dn + 2)`` (at most 4096).
    """
    n = int(min(4096, max(8, math.ceil(2.0 * e_per_dn) + 2)))
    j = np.arange(1, n + 1, dtype=np.float64)
    log = -shot_e * (1.0 - np.cos(2.0 * np.pi * j / e_per_dn)) \
        - 2.0 * np.pi ** 2 * j * j * read_dn * read_dn
    return float(np.exp(log.max()))


def _bound_quantization(c):
    """Rounding defect of the summed roundings (signal and, with CDS, reset conversions:
    :func:`rounding_defect`), and the per-exposure clipping (ADC range, CDS clamp at 0) the
    aggregate cannot reproduce."""
    sen, S = c.sensor, c.signal_e
    conv = sen.conversion_gain_e_per_dn / sen.gains[0]
    dark_rel = _dark_rel(c.scene)
    sigma_dn = _sigma_dn(c)
    read_dn = (sen.read_noise_e if c.records["read_noise"].ran else 0.0) / conv
    defect = rounding_defect(_shot_e(c), conv, read_dn)
    if c.records["reset_frames"].ran:
        # the reset sample: read noise alone in front of the ADC (a fractional pedestal with
        # little read noise is rounded the same way every time)
        defect = max(defect, rounding_defect(0.0, conv, read_dn))
    n_reads = 2 if c.records["reset_frames"].ran else 1
    lo_level = (S * dark_rel + c.dark_e) / conv + sen.black_level_dn
    hi_level = (S + c.dark_e) / conv + sen.black_level_dn
    sd = max(sigma_dn, 1e-9)
    p_lo = 0.5 * math.erfc(lo_level / sd / math.sqrt(2)) if n_reads == 1 else \
        0.5 * math.erfc((S * dark_rel + c.dark_e) / conv / (sd * math.sqrt(2)) / math.sqrt(2))
    if n_reads == 2:
        # the reset sample (read noise around the pedestal) clipped at code 0
        p_lo += 0.5 * math.erfc((c.offset_dn + 0.5) / max(read_dn, 1e-9) / math.sqrt(2))
    p_hi = 0.5 * math.erfc((sen.full_scale_dn - hi_level) / sd / math.sqrt(2))
    return {"quantization": defect, "clipping": min(1.0, p_lo + p_hi)}


def _bound_full_well(c):
    # clipping of single exposures: cannot aggregate
    return {"full_well": 1.0} if c.records["full_well"].ran else {}


def _moving(c):
    return c.m > 1 and (c.records["smear"].ran or c.records["rolling_skew"].ran)


def _bound_prnu(c):
    if not (_moving(c) and c.records["prnu"].ran):
        return {}
    # sum_s rel_s w_s taken as mean(rel) sum(w): error std prnu sqrt(m) std_s(rel) S,
    # std_s(rel) <= (1 - dark)/2, relative to the bright level m S
    return {"prnu_smear": c.sensor.prnu * (1.0 - _dark_rel(c.scene)) / 2.0 / math.sqrt(c.m)}


def _note_quantization(c, b):
    if c.quant_moments:
        return b["quantization"], (
            f"; fast: the noise does not dither the ADC (rounding defect "
            f"{b['quantization']:.2g}): the sum of the roundings drawn as a Normal with the "
            f"exact mean and variance of each rounding (shape not reproduced), clipping "
            f"probability {b['clipping']:.2g}")
    return b["quantization"], (f"; fast: m roundings -> 1 rounding + Normal((n-1)/12) DN, "
                               f"rounding defect {b['quantization']:.2g}, clipping probability "
                               f"{b['clipping']:.2g}")


def _note_full_well(c, b):
    if c.quant_moments or not c.records["full_well"].ran:
        return None
    return 1.0, "; fast: clipped on the mean per exposure (approximate)"


def _note_prnu(c, b):
    if c.quant_moments or "prnu_smear" not in b:
        return None
    return b["prnu_smear"], (f"; fast: moving stages weighted by the mean row gain, error <= "
                             f"{b['prnu_smear']:.2g} of the bright level")


# --------------------------------------------------------------------------------------
# implementations: rendering and fixed pattern (both fidelities)
# --------------------------------------------------------------------------------------


def _render_optics(c, kw):
    kw["psf_sigma_px"] = c.scene.optics.psf_sigma_px
    kw["optics"] = True


def _render_aperture(c, kw):
    kw["aperture"] = True


def _render_smear(c, kw):
    kw["dv_over_v"] = c.dv
    kw["drift_deg"] = c.scene.motion.drift_deg


def _render_rolling_skew(c, kw):
    kw["skew"] = c.skew


@dataclass
class FixedPattern:
    """Gain and dark-charge maps of the window rows (whole sensor width)."""

    gain: np.ndarray
    dark: np.ndarray


def _pattern_prnu(c, fp):
    fp.gain = np.maximum(1.0 + c.sensor.prnu * stream(c.seed, "fpn_prnu").standard_normal(
        fp.gain.shape), 0.0)


def _pattern_dark_current(c, fp):
    fp.dark = np.full(fp.dark.shape, c.dark_e)


def _pattern_dsnu(c, fp):
    fp.dark = np.maximum(fp.dark + c.sensor.dsnu_e * stream(c.seed, "fpn_dsnu")
                         .standard_normal(fp.dark.shape), 0.0)


# --------------------------------------------------------------------------------------
# implementations: charge and conversion on one chunk of exposures (exact)
# --------------------------------------------------------------------------------------


def _exact_shot(c, x):
    x.e = x.rng("shot").poisson(x.lam).astype(np.float64)


def _exact_full_well(c, x):
    x.e = np.minimum(x.e, c.sensor.full_well_e)


def _exact_reset(c, x, ch):
    """The reset sample of channel ``ch``: read noise alone, converted."""
    v = x.reset_noise(ch, c.read_noise_e)
    _adc_into(v, x.k[ch], x.add, x.top, x.reset_dst[ch])


def _exact_read(c, x, ch):
    r_e = c.read_noise_e
    if r_e > 0:
        x.v += x.read_noise(ch, r_e)


def _exact_quantization(c, x, ch):
    _adc_into(x.v, x.k[ch], x.add, x.top, x.dst[ch])


def _adc_into(x, k, add, top, dst):
    """``clamp(floor(x k + add), 0, top)`` into ``dst`` (``x`` is overwritten)."""
    x *= k
    x += add
    np.floor(x, out=x)
    np.clip(x, 0.0, top, out=x)
    dst[...] = x


# --------------------------------------------------------------------------------------
# the table
# --------------------------------------------------------------------------------------


def _fast(name):
    """Fast implementation ``name`` of :mod:`tdicam.engine.fast`."""
    return getattr(fast, name)



def _block_effect(row):
    """The effect of a block's :class:`~tdicam.engine.block_rows.Row`: timed under its name; on
    the fast aggregate its own fast step, or (after the line-making block) the exact one."""
    sim = row.sim
    fast = sim.fast
    if fast is None and sim.stage == "output":
        fast = block_rows.timed(row.name, sim.exact)
    return Effect(row.name, sim.label, block_rows.need(row.block.name, sim.where), stage=sim.stage,
                  exact=block_rows.timed(row.name, sim.exact), fast=fast,
                  aggregated=sim.aggregated, per_exposure=sim.per_exposure)


#: Every effect in the fixed physical order.
EFFECTS = (
    Effect("optics", "optics PSF (Gaussian)", _need_optics, stage="render",
           exact=_render_optics, fast=_render_optics, forcible=True),
    Effect("aperture", "pixel aperture + exposure motion", _need_aperture, stage="render",
           exact=_render_aperture, fast=_render_aperture),
    Effect("smear", "motion smear (dV/V, drift)", _need_smear, stage="render",
           exact=_render_smear, fast=_render_smear, forcible=True, aggregated=True),
    Effect("rolling_skew", "rolling-shutter row skew", _need_rolling_skew, stage="render",
           exact=_render_rolling_skew, fast=_render_rolling_skew, forcible=True,
           aggregated=True),
    Effect("prnu", "PRNU", _need_prnu, bound=_bound_prnu, fast_note=_note_prnu,
           stage="pattern", exact=_pattern_prnu, fast=_pattern_prnu, forcible=True,
           aggregated=True),
    Effect("dark_current", "dark current", _need_dark_current, stage="pattern",
           exact=_pattern_dark_current, fast=_pattern_dark_current, forcible=True,
           aggregated=True),
    Effect("dsnu", "DSNU", _need_dsnu, stage="pattern", exact=_pattern_dsnu,
           fast=_pattern_dsnu, forcible=True, aggregated=True),
    Effect("shot_noise", "photon/dark shot noise", _need_shot_noise, stage="charge",
           exact=_exact_shot, fast=_fast("shot_noise"), aggregated=True),
    Effect("full_well", "full-well clipping", _need_full_well, bound=_bound_full_well,
           fast_note=_note_full_well, stage="charge", exact=_exact_full_well,
           fast=_fast("full_well"), forcible=True, aggregated=True),
    Effect("reset_frames", "reset frames for CDS", _need_reset_frames, stage="conversion",
           exact=_exact_reset),
    Effect("read_noise", "read noise", _need_read_noise, stage="conversion",
           exact=_exact_read, fast=_fast("read_noise"), forcible=True, aggregated=True),
    Effect("dual_gain", "dual-gain channels (HG/LG)", _need_dual_gain),
    Effect("quantization", "ADC quantization per exposure", _need_quantization,
           bound=_bound_quantization, fast_note=_note_quantization, stage="conversion",
           exact=_exact_quantization, fast=_fast("quantization"), aggregated=True),
    Effect("sensor_lanes", "sensor LVDS lanes (front end)", _need_lvds, stage="blocks",
           exact=_exact_lvds, per_exposure=True),
) + tuple(_block_effect(r) for r in block_rows.ROWS)
EFFECT_NAMES = tuple(e.name for e in EFFECTS)
#: Effects that can be forced on at zero strength (to check that skipping them is exact).
FORCIBLE = tuple(e.name for e in EFFECTS if e.forcible)
