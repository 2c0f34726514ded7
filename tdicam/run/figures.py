"""The figures of a run (``tdicam run``, :meth:`tdicam.api.Simulation.figures`): the crop of
the raw exposure and the output on one relative scale, the normalised profile, the difference
from the ideal target, SNR against stages and the MTF, as matplotlib figures that
:func:`tdicam.run.runner.write_run` saves as PNG.

Layer: part of the run service.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["figures", "write_figures", "crop_window", "CROP", "DPI"]

#: Resolution ``tdicam run`` saves every figure at, dots per inch.
DPI = 110


#: Side of the square crop of ``crop.png`` / ``profile.png``, output pixels.
CROP = 64


def crop_window(shape, size=CROP, at=None):
    """``(y0, x0, h, w)`` of the ``size`` x ``size`` crop of an image (smaller when the
    image is): centred, or with its top-left at ``at = (column, line)`` (``[run].figure_crop``)
    moved in as far as the crop must to fit."""
    h, w = min(size, shape[0]), min(size, shape[1])
    if at is None:
        return (shape[0] - h) // 2, (shape[1] - w) // 2, h, w
    return min(int(at[1]), shape[0] - h), min(int(at[0]), shape[1] - w), h, w


def _crop_figures(scene, res, plt):
    """``crop.png``: raw exposure and output on the same crop, pixel axes, on one relative
    scale (:func:`~tdicam.run.quality.relative`: each above its zero-light pedestal over its
    mean, one colour range for both, so the noise TDI removes shows); ``profile.png``: the
    middle line of the crop across the direction the target varies most, raw exposure and
    output on that relative scale times the target's mean, the target on the same axis;
    ``difference.png`` (a target that is not constant): the output on the target's scale
    (:func:`~tdicam.run.quality.to_target_scale`) minus the target."""
    from tdicam.run.quality import relative, to_target_scale
    y0, x0, h, w = crop_window(res.output.shape, at=scene.run.figure_crop)
    ys, xs = slice(y0, y0 + h), slice(x0, x0 + w)
    ext = (x0 - 0.5, x0 + w - 0.5, y0 + h - 0.5, y0 - 0.5)
    m = res.stages
    raw, out = (relative(res.raw[ys, xs], res.pedestal_single),
                relative(res.output[ys, xs], res.pedestal_output))
    both = np.concatenate([raw.ravel(), out.ravel()])
    lo, hi = float(np.percentile(both, 0.5)), float(np.percentile(both, 99.5))
    fig, axes = plt.subplots(1, 2, figsize=(9, 4.2))
    for ax, arr, title in ((axes[0], raw, "raw exposure (1 read)"),
                           (axes[1], out, f"TDI output (m = {m})")):
        im = ax.imshow(arr, cmap="gray", extent=ext, interpolation="nearest",
                       vmin=lo, vmax=max(hi, lo + 1e-9))
        ax.set_title(title)
        ax.set_xlabel("column (px)")
        ax.set_ylabel("output line")
        fig.colorbar(im, ax=ax, label="signal / crop mean (above zero light)", shrink=0.85)
    fig.suptitle(f"{Path(scene.source).stem}: {w} x {h} crop at column {x0}, line {y0}, "
                 "one relative scale")
    fig.tight_layout()
    yield "crop.png", fig
    tgt = np.asarray(res.target, np.float64)[ys, xs]
    along = tgt.std(axis=0).mean() > tgt.std(axis=1).mean()   # varies down the lines
    if along:
        c = x0 + w // 2
        pos, cut = np.arange(y0, y0 + h), (ys, c)
        what, xlabel = f"column {c}", "output line (along track)"
    else:
        r = y0 + h // 2
        pos, cut = np.arange(x0, x0 + w), (r, xs)
        what, xlabel = f"line {r}", "column (px, cross track)"
    t_cut = np.asarray(res.target[cut], np.float64)
    scale = float(t_cut.mean()) or 1.0
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(pos, relative(res.output[cut], res.pedestal_output) * scale, "-",
            label=f"TDI output (m = {m})")
    ax.plot(pos, relative(res.raw[cut], res.pedestal_single) * scale, "-",
            label="raw exposure", alpha=0.8)
    ax.plot(pos, t_cut, ":", color="0.2", label="target")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("relative radiance (scaled to the target's mean)")
    ax.legend(fontsize=8, loc="best")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"{Path(scene.source).stem}: normalised profile along {what}")
    fig.tight_layout()
    yield "profile.png", fig
    scaled = to_target_scale(res.target, res.output, res.pedestal_output)
    if scaled is not None:
        d = scaled - np.asarray(res.target, np.float64)
        lim = float(np.percentile(np.abs(d), 99.5)) or 1.0
        fig, ax = plt.subplots(figsize=(8, 4.5))
        im = ax.imshow(d, cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest",
                       aspect="auto")
        ax.set_xlabel("column (px)")
        ax.set_ylabel("output line")
        fig.colorbar(im, ax=ax, label="output - target (relative radiance)")
        ax.set_title(f"{Path(scene.source).stem}: TDI output (m = {m}, on the target's "
                     f"scale) minus the ideal target; RMS {float(np.sqrt(np.mean(d * d))):.3g}")
        fig.tight_layout()
        yield "difference.png", fig


def figures(scene, rows, main):
    """The run's figures, ``(file name, matplotlib Figure)`` in the order ``tdicam run``
    writes them (the module docstring of :mod:`tdicam.run.runner` says what each shows):
    ``crop.png``, ``profile.png``, ``difference.png`` (a target that is not constant),
    ``snr_vs_stages.png`` (stages swept on a flat target), ``mtf.png`` (a bar target).
    ``rows`` are the sweep points' measurements, ``main`` the engine's result whose images
    are shown."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from tdicam.planning.predict import mtf_prediction, snr_prediction
    yield from _crop_figures(scene, main, plt)
    flat = [r for r in rows if "snr" in r and r["snr"]["gain_db"] is not None]
    if scene.target.kind == "flat" and flat:
        fig, ax = plt.subplots(figsize=(6, 4))
        ms = np.array([r["stages"] for r in flat])
        ax.plot(ms, [r["snr"]["gain_db"] for r in flat], "o", label=f"measured ({main.fidelity})")
        mm = np.arange(1, max(ms) + 1)
        cds = any(e["name"] == "reset_frames" and e["ran"] for e in
                  [x.to_dict() for x in main.effects])
        preds = [snr_prediction(scene, int(k), cds=cds) for k in mm]
        ax.plot(mm, [p["predicted_db"] for p in preds], "-", label="planning model G(m)")
        ax.plot(mm, [p["eq28_db"] for p in preds], "--",
                label="Tao et al. 2012 eq 28 (worst case)" if scene.tdi.domain == "digital"
                else "eq-28 form (charge)")
        ax.set_xscale("log")
        ax.set_xlabel("TDI stages m")
        ax.set_ylabel("SNR gain over one exposure (dB)")
        ax.set_title(f"{Path(scene.source).stem}: SNR vs stages ({scene.tdi.domain})")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        yield "snr_vs_stages.png", fig
    bars = [r for r in rows if "mtf" in r]
    if bars:
        fig, ax = plt.subplots(figsize=(6, 4))
        if len({r["dv_over_v"] for r in bars}) > 1:
            x = [r["mtf"]["m_dv_over_v"] for r in bars]
            ax.plot(x, [r["mtf"]["measured"] for r in bars], "o", label="measured")
            f = bars[0]["mtf"]["frequency_cyc_per_px"]
            for m in sorted({r["stages"] for r in bars}):
                # dV/V in (-1, 1): the image moves forward
                xx = np.linspace(0, min(max(max(x), 2.0), 0.999 * m), 200)
                pred = [mtf_prediction(scene, m, v / m, f) for v in xx]
                ax.plot(xx, [p["system"] for p in pred], "-", label=f"planned, M={m}")
                ax.plot(xx, [p["paper"]["system"] for p in pred], ":",
                        label=f"paper's model (Yuan et al. 2013), M={m}")
            ax.set_xlabel("M dV/V (pixels)")
            ax.set_title(f"MTF at {f:g} cycles/px vs velocity mismatch")
        else:
            g = main.geometry
            ff = np.linspace(0, 0.5, 101)
            ax.plot(ff, np.abs(g.mtf_along(ff)), "-", label="footprint model (along)")
            pred = [mtf_prediction(scene, g.stages, g.dv_over_v, v) for v in ff]
            ax.plot(ff, [p["system"] for p in pred], "--", label="planned (along)")
            ax.plot(ff, [p["paper"]["system"] for p in pred], ":",
                    label="paper's model, Yuan et al. 2013 (along)")
            for r in bars:
                ax.plot([r["mtf"]["frequency_cyc_per_px"]], [r["mtf"]["measured"]], "o",
                        label=f"measured M={r['stages']}")
            ax.set_xlabel("spatial frequency (cycles/pixel)")
            ax.set_title("MTF")
        ax.set_ylabel("MTF")
        ax.set_ylim(0, 1.05)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        yield "mtf.png", fig




def write_figures(out_dir, scene, rows, main) -> list[str]:
    """Save :func:`figures` as PNG files in ``out_dir`` (at :data:`DPI`), closing each;
    returns the file names."""
    import matplotlib.pyplot as plt
    names = []
    for name, fig in figures(scene, rows, main):
        fig.savefig(Path(out_dir) / name, dpi=DPI)
        plt.close(fig)
        names.append(name)
    return names
