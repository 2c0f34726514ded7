"""The lanes' eye-mask picture of ``tdicam run`` (``eyes.png``): lanes x delay taps, each
tap passed or failed in the receiver's training scan, the chosen tap marked, a lane in
error labelled. Its numbers are report.json's ``rtl.eyes`` (one entry a lane:
:func:`tdicam.cosim.lvds_front.lane_eyes`)."""

import numpy as np

__all__ = ["EYES_PNG", "eye_figure"]

#: The picture's file name in a run's output folder.
EYES_PNG = "eyes.png"


def eye_figure(eyes, path):
    """Write the eye-mask picture of ``eyes`` (report.json's ``rtl.eyes``) to ``path``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    grid = np.array([e["taps"] for e in eyes], np.int64)
    n, taps = grid.shape
    fig, ax = plt.subplots(figsize=(8, 1.2 + 0.35 * n))
    ax.imshow(grid, cmap=ListedColormap(["#d9d9d9", "#2ca02c"]), vmin=0, vmax=1,
              aspect="auto", interpolation="nearest")
    moved = False
    for e in eyes:
        if e["locked"]:
            t0 = e.get("trained_tap", e["tap"])
            ax.plot(t0, e["lane"], marker="x", color="black", markersize=9, mew=2)
            if t0 != e["tap"]:
                moved = True
                ax.annotate("", xy=(e["tap"], e["lane"]), xytext=(t0, e["lane"]),
                            arrowprops={"arrowstyle": "->", "color": "#1f3fbf", "lw": 1.5})
                ax.plot(e["tap"], e["lane"], marker="o", color="#1f3fbf", markersize=7)
        else:
            ax.text(taps - 0.5, e["lane"], " error", va="center", ha="left", color="#c00000")
    ax.set_xticks(range(0, taps, 4))
    ax.set_yticks(range(n))
    ax.set_yticklabels([f"lane {e['lane']}" for e in eyes])
    ax.set_xlabel("delay tap (green: the training word passed; x: the chosen tap"
                  + (";\no: the tap at the end, tracking the drifting eye)" if moved else ")"))
    ax.set_title("Lane training: pass mask over the delay taps")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
