"""The lanes' eye-mask pictures of ``tdicam run``: lanes x delay taps, each tap passed or
failed in the receiver's training scan, the chosen tap marked, a lane in error labelled.
``eyes.png``: as the chain's co-simulation measured it (the generic PHY's eye-status ports,
the link model's captures in; report.json's ``rtl.eyes``, one entry a lane:
:func:`tdicam.cosim.lvds_front.lane_eyes`); ``eyes_<phy>.png`` (:func:`device_png`): as the
device PHY's receiver measured it from serial bits (``[run.rtl].phy``; report.json's
``rtl.phy_checks[].eyes``: :func:`tdicam.chain.phy_check.device_eyes`)."""

import numpy as np

__all__ = ["EYES_PNG", "eye_figure", "device_png"]

#: The picture's file name in a run's output folder.
EYES_PNG = "eyes.png"


def device_png(phy):
    """The file name of the eye-mask picture the device PHY ``phy`` measured from the pins."""
    return f"eyes_{phy}.png"


def eye_figure(eyes, path, *, title="Lane training: pass mask over the delay taps"):
    """Write the eye-mask picture of ``eyes`` (report.json's ``rtl.eyes``, or a phy check's
    ``eyes``) to ``path``, under ``title``."""
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
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
