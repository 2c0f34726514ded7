"""Figures of a sweep's tidy table (:mod:`tdicam.sweeps.runner`), with matplotlib's Agg backend.

* ``snr_vs_stages.png`` — flat targets, at least two stage counts: the measured SNR gain
  over one exposure of every repeat (dots), their mean and standard deviation (error bars),
  the planning model's ``G(m)`` (line) and Tao Shuping et al., "Design and analysis of a
  digital-domain TDI CMOS camera for high-resolution space imaging", 2012, eq 28 (dotted;
  its worst case, or its charge-domain form), one colour per combination of the other axes.
* ``mtf_vs_mismatch.png`` — bar targets, at least two values of M dV/V: the measured MTF at
  the bar frequency of every repeat, mean and standard deviation, the velocity-mismatch
  model of Yuan Gaobin et al., "MTF velocity-mismatch model of TDI area-array CMOS image
  sensors", 2013 (line: aperture x temporal sampling x mismatch, mismatch only) and the same
  model at each run's effective mismatch with the rolling-shutter skew (crosses) and the
  exact footprint model of :class:`tdicam.model.physics.optics.Geometry` (plus signs).
* ``time_vs_fidelity.png`` — every finished run's task time (simulate and measure) against
  the fidelity requested and used (``auto -> fast``), coloured by stage count; bar: median.

Groups beyond :data:`MAX_GROUPS` are left out of a figure, and its title says so.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_GROUPS", "figures", "save"]

#: Largest number of curves (combinations of the other axes) in one figure.
MAX_GROUPS = 8


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _groups(df, sweep, exclude):
    cols = [k for k in sweep.keys if k not in exclude]
    if not cols:
        return [("", df)]
    out = []
    for vals, sub in df.groupby(cols, sort=False, dropna=False):
        vals = vals if isinstance(vals, tuple) else (vals,)
        out.append((", ".join(f"{c}={v}" for c, v in zip(cols, vals)), sub))
    return out


def _title(ax, text, n_groups):
    if n_groups > MAX_GROUPS:
        text += f" (first {MAX_GROUPS} of {n_groups} groups)"
    ax.set_title(text, fontsize=9)


def _spread(ax, x, y, color, label):
    """Every repeat as a dot, then mean +- standard deviation per x."""
    ax.plot(x, y, ".", color=color, alpha=0.35, ms=4)
    xs = np.unique(x)
    means = np.array([y[x == v].mean() for v in xs])
    sds = np.array([y[x == v].std(ddof=1) if (x == v).sum() > 1 else 0.0 for v in xs])
    ax.errorbar(xs, means, yerr=sds, fmt="o", color=color, ms=5, capsize=3, label=label)


def _snr(sweep, df, plt):
    ok = df[(df["status"] == "ok") & df["snr_gain_db"].notna()]
    if ok["stages"].nunique() < 2:
        return None
    fig, ax = plt.subplots(figsize=(7, 4.5))
    groups = _groups(ok, sweep, ("tdi.stages", "run.seed"))
    charge = sweep.runs[0].scene.tdi.domain == "charge"
    for i, (label, sub) in enumerate(groups[:MAX_GROUPS]):
        c = f"C{i}"
        x = sub["stages"].to_numpy(np.float64)
        _spread(ax, x, sub["snr_gain_db"].to_numpy(np.float64), c,
                f"measured {label}".strip() + f" ({sweep.repeats} repeats)")
        pred = sub.groupby("stages")[["snr_predicted_gain_db", "snr_eq28_gain_db"]].mean()
        ax.plot(pred.index, pred["snr_predicted_gain_db"], "-", color=c,
                label="planning model G(m)" if i == 0 else None)
        ax.plot(pred.index, pred["snr_eq28_gain_db"], ":", color=c,
                label=("Tao et al. 2012 eq 28 form (charge)" if charge
                       else "Tao et al. 2012 eq 28 (worst case)") if i == 0 else None)
    mm = np.geomspace(1, ok["stages"].max(), 100)
    ax.plot(mm, 10 * np.log10(mm), "--", color="0.6", lw=0.8, label="sqrt(m): 10 log10 m")
    ax.set_xscale("log")
    ticks = sorted(int(v) for v in ok["stages"].unique())
    ax.set_xticks(ticks, [str(t) for t in ticks])
    ax.minorticks_off()
    ax.set_xlabel("TDI stages m")
    ax.set_ylabel("SNR gain over one exposure (dB)")
    _title(ax, f"{sweep.name}: measured vs predicted SNR gain", len(groups))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def _mtf(sweep, df, plt):
    from tdicam.model.physics import plan
    ok = df[(df["status"] == "ok") & df["mtf_measured"].notna()]
    if ok["m_dv_over_v"].nunique() < 2:
        return None
    fig, ax = plt.subplots(figsize=(7, 4.5))
    groups = _groups(ok, sweep, ("motion.dv_over_v", "run.seed"))
    top = max(float(ok["m_dv_over_v"].abs().max()) * 1.1, 0.5)
    for i, (label, sub) in enumerate(groups[:MAX_GROUPS]):
        c = f"C{i}"
        x = sub["m_dv_over_v"].to_numpy(np.float64)
        _spread(ax, x, sub["mtf_measured"].to_numpy(np.float64), c,
                f"measured {label}".strip())
        ax.plot(x, sub["mtf_model_yuan2013"], "x", color=c, ms=6,
                label="Yuan et al. 2013 at the effective mismatch (with row skew)"
                if i == 0 else None)
        ax.plot(x, sub["mtf_model_footprint"], "+", color="k", ms=7,
                label="exact footprint model (what the engine simulates)" if i == 0 else None)
        scene = sweep.runs[int(sub.index[0])].scene
        m = int(sub["stages"].iloc[0])
        f = float(sub["mtf_frequency_cyc_per_px"].iloc[0])
        xx = np.linspace(min(0.0, float(x.min())), top, 200)
        ax.plot(xx, plan.mtf_system(f, m, xx / m, scene.sensor.q_over_p), "-", color=c,
                label=f"Yuan et al. 2013 model, M={m}, f={f:g} cyc/px")
    ax.set_xlabel("M dV/V (pixels)")
    ax.set_ylabel("MTF")
    ax.set_ylim(0, 1.05)
    _title(ax, f"{sweep.name}: MTF at the bar frequency vs velocity mismatch", len(groups))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def _time(sweep, df, plt):
    ok = df[df["status"] == "ok"]
    if ok.empty:
        return None
    cat = [r if r == u else f"{r} -> {u}"
           for r, u in zip(ok["fidelity_requested"], ok["fidelity"])]
    names = sorted(set(cat))
    pos = np.array([names.index(c) for c in cat], np.float64)
    jitter = ((np.arange(len(pos)) * 0.618034) % 1.0 - 0.5) * 0.4
    fig, ax = plt.subplots(figsize=(6, 4))
    stages = ok["stages"].astype(float).to_numpy()
    if len(set(stages)) > 1:
        from matplotlib.colors import LogNorm
        sc = ax.scatter(pos + jitter, ok["task_seconds"], c=stages, cmap="viridis", s=14,
                        norm=LogNorm(vmin=stages.min(), vmax=max(stages.max(), 2)))
        fig.colorbar(sc, ax=ax).set_label("TDI stages")
    else:
        ax.scatter(pos + jitter, ok["task_seconds"], s=14, label=f"{int(stages[0])} stages")
        ax.legend(fontsize=8)
    for i, n in enumerate(names):
        t = ok["task_seconds"][pos == i]
        ax.plot([i - 0.3, i + 0.3], [t.median()] * 2, "k-", lw=1.5)
    ax.set_xticks(range(len(names)), names)
    ax.set_yscale("log")
    ax.set_xlabel("fidelity (requested -> used)")
    ax.set_ylabel("time per run (s)")
    ax.set_title(f"{sweep.name}: time per run (bar: median)", fontsize=9)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def figures(sweep, df):
    """``(file name, figure)`` for each figure the table supports."""
    plt = _plt()
    out = []
    for name, make in (("snr_vs_stages.png", _snr), ("mtf_vs_mismatch.png", _mtf),
                       ("time_vs_fidelity.png", _time)):
        fig = make(sweep, df, plt)
        if fig is not None:
            out.append((name, fig))
    return out


def save(fig, path):
    """Write ``fig`` as PNG to ``path`` and close it."""
    plt = _plt()
    try:
        fig.savefig(path, dpi=110, format="png")
    finally:
        plt.close(fig)
