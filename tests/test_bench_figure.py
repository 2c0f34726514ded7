"""``tdicam bench``'s figure: nothing clipped, and the accuracy-vs-time panel places every
level by its accuracy against the reference (no simulator run: synthetic rows)."""

from PIL import Image

from tdicam.bench import suite

LEVELS = ("golden", "pysim", "icarus beat", "icarus fast", "verilator beat", "verilator fast",
          "export verilator")


def rows():
    out = []
    for b, unit in (("tdi", "pixel"), ("median3", "pixel"), ("ecc", "word")):
        for k, lev in enumerate(LEVELS):
            acc = "reference" if lev == "golden" else "bit-exact"
            out.append(suite.row(b, lev, unit, 1000, 1e-3 * 10 ** k, accuracy=acc,
                                 mismatches=None if lev == "golden" else 0))
    out.append(suite.row("ecc", "icarus fast", "word", 1000, 0.5, accuracy="3 mismatching",
                         mismatches=3))
    out.append(suite.na_row("lvds", "pysim", "lane", "not run"))
    for fid, psnr in (("fast", 61.5), ("auto", 62.0), ("exact", None)):
        out.append(suite.row("scene", f"scene {fid}", "line", 256, 0.02 if fid != "exact"
                             else 0.4, accuracy="reference; other seed" if psnr is None else "PSNR",
                             psnr_db=psnr, snr_error_db=0.01,
                             noise_floor_psnr_db=61.8))
    return out


def test_tradeoff_points_classify_every_timed_level():
    pts = suite.tradeoff_points(rows())
    kinds = {(r["block"], r["level"]): (y, k) for r, y, k in pts}
    assert kinds[("tdi", "golden")] == (None, "exact")
    assert kinds[("tdi", "verilator fast")] == (None, "exact")
    assert kinds[("scene", "scene fast")] == (61.5, "psnr")
    assert kinds[("scene", "scene exact")] == (None, "exact")
    assert ("lvds", "pysim") not in kinds                  # no time: not a point
    wrong = [r for r, _, k in pts if k == "wrong"]
    assert len(wrong) == 1 and wrong[0]["mismatches"] == 3
    assert len(pts) == 3 * len(LEVELS) + 1 + 3


def test_plot_keeps_legends_inside_the_image(tmp_path, monkeypatch):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    saved = {}
    real_close = plt.close

    def keep(fig):
        saved["fig"] = fig
        return real_close(fig)
    monkeypatch.setattr(plt, "close", keep)
    path = suite.plot(rows(), tmp_path / "b.png", real_time=6908.0)
    fig = saved["fig"]
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    renderer = FigureCanvasAgg(fig).get_renderer()
    box = fig.get_tightbbox(renderer)                       # inches: what was saved
    w, h = Image.open(path).size
    # saved with bbox_inches="tight": the image covers the tight box (plus padding)
    assert box.width * 110 - 5 <= w <= box.width * 110 + 40
    assert box.height * 110 - 5 <= h <= box.height * 110 + 40
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 2
    for leg in legends:
        ext = leg.get_window_extent(renderer)
        assert box.x0 * fig.dpi - 1 <= ext.x0 and ext.x1 <= box.x1 * fig.dpi + 1
        assert box.y0 * fig.dpi - 1 <= ext.y0 and ext.y1 <= box.y1 * fig.dpi + 1
    labels = [t.get_text() for t in fig.axes[1].get_yticklabels()]
    assert "mismatches" in labels and labels[-1].startswith("bit-exact")
