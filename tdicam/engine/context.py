"""The context of one run of the scene simulator and its configuration from the table.

:func:`decide` asks every :data:`~tdicam.engine.effects.EFFECTS` entry whether the scene
needs it and why, applies ``--force`` / ``disable``, gathers the fast bounds and picks the
fidelity; the resulting :class:`RunContext` is passed through the engine instead of positional
tuples, and :meth:`RunContext.steps` gives each stage the implementations of the running
effects in physical order.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from tdicam.errors import TdicamError

from tdicam.engine.block_rows import ROWS, pedestal, takes_resets
from tdicam.engine.effects import EFFECTS, FORCIBLE, MOMENTS_BELOW_DITHER, dark_charge_e, stage_skew

__all__ = ["EffectRecord", "RunContext", "decide"]


@dataclass
class EffectRecord:
    """One row of the effects table."""

    name: str
    label: str
    ran: bool
    why: str
    fidelity: str = "-"
    seconds: float = 0.0
    bound: float | None = None
    impact: dict | None = None

    def to_dict(self):
        return dataclasses.asdict(self)


@dataclass
class RunContext:
    """Everything one run of the engine needs, passed through instead of positional tuples.

    The configuration (:func:`decide`) fixes the scene point, the records and the fidelity;
    :meth:`with_effects` gives the context of one pass with another set of effects (the
    impact study). Effect strengths are read here (``read_noise_e`` ...) and are zero (or
    None) where the effect does not run in this pass.
    """

    scene: object
    m: int
    dv: float
    fidelity: str                 # requested: exact | fast | auto
    records: dict
    on: frozenset                 # effects that run in this pass
    forced: frozenset
    fast: bool                    # aggregate the exposures
    skew: float
    dark_e: float
    n_reads: int                  # conversions per exposure (2 with a reset frame)
    offset_dn: float              # ADC pedestal (black level + CDS reset level)
    notes: list
    bounds: dict
    fast_fpn_mean: bool = False   # fast: moving stages weighted by the mean row gain
    quant_moments: bool = False   # fast: exact moments of every rounding (noise < ~0.7 DN)
    prepared: dict = dataclasses.field(default_factory=dict)  # blocks' side inputs (prepare)
    flash: dict = dataclasses.field(default_factory=dict)  # NAND store counters per channel
    keep_raw: bool = False        # hand out the raw frames entering the blocks (exact digital)
    raw_data: dict | None = None  # {"signal", "reset", "coeffs"} when keep_raw

    # ---- the effects of this pass, in table order
    def ran(self, name):
        return name in self.on

    def steps(self, stage, fast=False, named=False):
        """Implementations of the running effects of ``stage``, in physical order (with
        ``named``: ``(name, implementation)`` pairs)."""
        out = []
        for e in EFFECTS:
            fn = e.fast if fast else e.exact
            if e.stage == stage and fn is not None and e.name in self.on:
                out.append((e.name, fn) if named else fn)
        return out

    def with_effects(self, on):
        return dataclasses.replace(self, on=frozenset(on), prepared={}, keep_raw=False,
                                   raw_data=None)

    # ---- strengths in this pass
    @property
    def sensor(self):
        return self.scene.sensor

    @property
    def digital(self):
        return self.scene.tdi.domain == "digital"

    @property
    def seed(self):
        return self.scene.run.seed

    @property
    def signal_e(self):
        return self.scene.target.signal_e

    @property
    def gains(self):
        """Channel gains converted: both with dual gain, else the high gain alone."""
        g = self.sensor.gains
        return tuple(g) if self.ran("dual_gain") else tuple(g[:1])

    @property
    def read_noise_e(self):
        return self.sensor.read_noise_e if self.ran("read_noise") else 0.0

    @property
    def full_well_e(self):
        return self.sensor.full_well_e if self.ran("full_well") else None

    @property
    def resets(self):
        """Every exposure also converts a reset sample (for CDS)."""
        return self.ran("reset_frames")

    @property
    def zero_dn(self):
        """DN of zero light after the exposure blocks: 0 with CDS, else the pedestal."""
        return 0.0 if takes_resets(self) else self.offset_dn

    @property
    def frame_rows(self):
        """An area camera whose output line ``r`` is sensor row ``r``
        (``[pipeline.nuc].coefficients = "frame"``): its fixed pattern and NUC coefficients
        have a row per output line; otherwise every line is made by the window's rows."""
        pl = self.scene.pipeline
        return pl is not None and pl.nuc.coefficients == "frame"

    def stage_row(self, s):
        """0-based window row that makes stage s (first exposure s = 0) of a ground line."""
        return self.m - 1 - s if self.scene.tdi.direction == "forward" else s


# --------------------------------------------------------------------------------------
# configuration of one run
# --------------------------------------------------------------------------------------


def decide(scene, m, dv, fidelity, force, disable):
    """The context of one scene point: which effects run and why, the fidelity, the bounds."""
    force, disable = frozenset(force), frozenset(disable)
    c = RunContext(scene, m, dv, fidelity, {}, frozenset(), force, False, stage_skew(scene, m),
                   dark_charge_e(scene), 1, 0.0, [], {})
    for eff in EFFECTS:
        need, why = eff.need(c)
        if eff.name in disable:
            need, why = False, f"disabled by request ({why})"
        elif eff.name in force and not need:
            if not eff.forcible:
                raise TdicamError(f"--force {eff.name}: only {', '.join(FORCIBLE)} can be "
                                  f"forced on")
            need, why = True, f"forced on at zero strength ({why})"
        c.records[eff.name] = EffectRecord(eff.name, eff.label, bool(need), why)
    rec = c.records
    c.on = frozenset(n for n, r in rec.items() if r.ran)
    c.n_reads = 2 if rec["reset_frames"].ran else 1
    c.offset_dn = scene.sensor.black_level_dn + (pedestal(scene) if rec["reset_frames"].ran
                                                 else 0.0)
    bounds = c.bounds
    for eff in EFFECTS:
        if eff.bound is not None:
            bounds.update(eff.bound(c))
    tol = scene.run.tolerance
    per_exposure = [e.name for e in EFFECTS if e.per_exposure and rec[e.name].ran] \
        if c.digital else []     # charge sum happens before any block
    fast = fidelity == "fast"
    if fidelity == "auto":
        worst = max(bounds.values())
        fast = worst <= tol and not per_exposure
        c.notes.append(f"auto: {'fast' if fast else 'exact'} (largest fast-aggregate bound "
                       f"{worst:.3g} vs tolerance {tol:g}"
                       + (f"; per-exposure blocks {', '.join(per_exposure)}" if per_exposure
                          else "") + ")")
    if fast and per_exposure:
        c.notes.append(f"fast aggregate not applicable: {', '.join(per_exposure)} act on "
                       f"single exposures and are not linear; ran exact")
        fast = False
    c.fast = fast
    mode = "fast" if fast else "exact"
    for eff in EFFECTS:
        if eff.aggregated and rec[eff.name].ran:
            rec[eff.name].fidelity = mode
    c.quant_moments = fast and bounds["quantization"] > MOMENTS_BELOW_DITHER
    c.fast_fpn_mean = fast and "prnu_smear" in bounds
    if fast:
        for eff in EFFECTS:
            note = eff.fast_note(c, bounds) if eff.fast_note is not None else None
            if note is not None:
                rec[eff.name].bound, extra = note
                rec[eff.name].why += extra
    if len(scene.sensor.gains) == 2 and not any(rec[r.name].ran for r in ROWS
                                                 if r.block.pipeline.merge):
        c.notes.append("two gains but no hdr merge: the HG channel feeds the chain")
    return c
