"""The figure of ``tdicam bench`` (:func:`plot`): throughput per level, and what accuracy
costs in time. Split from :mod:`tdicam.bench.suite`, which measures the rows this draws."""

import math
from pathlib import Path

from tdicam.bench.util import UNIT_ABBR, scene_line_period

__all__ = ["plot", "tradeoff_points"]


def _unit_abbr(unit):
    return UNIT_ABBR.get(unit, unit)


def plot(rows, path, *, title="", real_time=None):
    """One PNG, two panels. Top: throughput of every level, grouped by block, log scale.
    Bottom: what accuracy costs in time: time per unit (log) against accuracy with the
    reference, one point per block and level — the bit-exact levels together on the top
    line, levels with mismatches on the bottom line, the scene engine's fast and auto by
    the PSNR of their output against exact (same seed), with exact's seed-to-seed PSNR (the
    noise floor: no better agreement is meaningful) as a dashed line. Legends sit outside
    the axes and the figure is cropped to them, so nothing is clipped."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(dict.fromkeys(r["block"] for r in rows))
    levels = list(dict.fromkeys(r["level"] for r in rows if r["rate"]))
    colors = {lev: plt.get_cmap("tab10")(k % 10) for k, lev in enumerate(levels)}
    fig, (ax, tr) = plt.subplots(2, 1, figsize=(max(8.0, 1.2 * len(names) + 2), 10.5))
    labels, seen = [], set()
    for i, b in enumerate(names):
        mine = [r for r in rows if r["block"] == b and r["rate"]]
        width = 0.8 / max(1, len(mine))
        for j, r in enumerate(mine):
            x = i + (j - (len(mine) - 1) / 2) * width
            ax.bar(x, r["rate"], width, color=colors[r["level"]],
                   label=None if r["level"] in seen else r["level"])
            seen.add(r["level"])
        if b == "scene" and mine:
            rt = real_time or 1.0 / scene_line_period()
            ax.hlines(rt, i - 0.45, i + 0.45, colors="k", linestyles="--")
            ax.annotate(f"real time {rt:,.0f} lines/s", (i, rt), fontsize=7, ha="center",
                        va="bottom")
        unit = _unit_abbr(mine[0]["unit"]) + "/s" if mine else "n/a"
        labels.append(f"{b}\n({unit})")
    ax.set_xticks(range(len(names)))
    ax.set_xticklabels(labels, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("throughput (units/s, log scale)")
    ax.set_title(title or "tdicam bench: throughput per fidelity level", fontsize=9)
    ax.grid(axis="y", which="both", alpha=0.3)
    if levels:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False,
                  title="level", title_fontsize=8)
    _tradeoff(tr, rows, colors, names)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    from tdicam.files import open_output
    with open_output(path) as fh:       # this exact name (savefig would add .png)
        fig.savefig(fh, dpi=110, bbox_inches="tight", format="png")
    plt.close(fig)
    return Path(path)


_MARKERS = "osD^vP*Xh<>p"


def tradeoff_points(rows):
    """``[(row, y, kind)]`` of the accuracy-vs-time panel: ``kind`` is ``"exact"`` (bit-exact
    or the reference itself, drawn on the top line), ``"wrong"`` (mismatches, bottom line)
    or ``"psnr"`` (``y`` = PSNR against the reference, dB). Rows without a time are left
    out."""
    out = []
    for r in rows:
        if not r.get("per_unit_s"):
            continue
        if r.get("psnr_db") is not None:
            out.append((r, r["psnr_db"], "psnr" if math.isfinite(r["psnr_db"]) else "exact"))
        elif r.get("mismatches"):
            out.append((r, None, "wrong"))
        elif r["accuracy"] in ("bit-exact", "reference") or str(r["accuracy"]).startswith(
                "reference"):
            out.append((r, None, "exact"))
    return out


def _tradeoff(ax, rows, colors, names):
    pts = tradeoff_points(rows)
    psnr = [y for _, y, k in pts if k == "psnr"]
    floors = [r["noise_floor_psnr_db"] for r in rows if r.get("noise_floor_psnr_db")]
    finite = psnr + [f for f in floors if math.isfinite(f)]
    lo, hi = (min(finite), max(finite)) if finite else (20.0, 60.0)
    span = max(hi - lo, 10.0)
    top, bottom = hi + 0.35 * span, lo - 0.35 * span
    marks = {b: _MARKERS[i % len(_MARKERS)] for i, b in enumerate(names)}
    for r, y, kind in pts:
        yy = {"exact": top, "wrong": bottom}.get(kind, y)
        ax.scatter(r["per_unit_s"], yy, s=46, color=colors.get(r["level"], "0.5"),
                   marker=marks[r["block"]], edgecolors="k", linewidths=0.4, zorder=3)
        if r["block"] == "scene":
            fid = r["level"].replace("scene ", "")
            err = r.get("snr_error_db")
            text = fid if fid == "exact" or err is None else f"{fid} (SNR {err:+.2f} dB)"
            ax.annotate(text, (r["per_unit_s"], yy), fontsize=7, textcoords="offset points",
                        xytext=(6, -10 if fid == "auto" else 4))
    for f in {f for f in floors if math.isfinite(f)}:
        ax.axhline(f, color="0.3", ls="--", lw=0.8)
        ax.annotate(f"scene exact vs exact, other seed: {f:.1f} dB (noise floor)", (0.01, f),
                    xycoords=("axes fraction", "data"), fontsize=7, va="bottom")
    ax.axhline(top, color="0.8", lw=0.6, zorder=0)
    ax.set_xscale("log")
    ax.set_ylim(bottom - 0.15 * span, top + 0.15 * span)
    ticks = [t for t in ax.get_yticks() if bottom + 0.1 * span < t < top - 0.1 * span]
    ax.set_yticks([bottom] * any(k == "wrong" for _, _, k in pts) + ticks + [top])
    ax.set_yticklabels((["mismatches"] if any(k == "wrong" for _, _, k in pts) else [])
                       + [f"{t:g}" for t in ticks] + ["bit-exact /\nreference"], fontsize=8)
    ax.set_xlabel("time per unit (s per pixel, word, lane sample or line: the block's unit; "
                  "log scale)")
    ax.set_ylabel("accuracy against the reference\n(scene: PSNR vs exact, dB)")
    ax.set_title("what accuracy costs in time (one point per block and level; left and up "
                 "is better)", fontsize=9)
    ax.grid(True, which="both", alpha=0.25)
    from matplotlib.lines import Line2D
    used = list(dict.fromkeys(r["block"] for r, _, _ in pts))
    handles = [Line2D([], [], ls="", marker=marks[b], color="0.6", markeredgecolor="k",
                      label=f"{b} ({_unit_abbr(_unit_of(rows, b))})")
               for b in used]
    if handles:
        ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                  frameon=False, title="block (unit); colour = level", title_fontsize=8)


def _unit_of(rows, block):
    return next((r["unit"] for r in rows if r["block"] == block), "")
