"""Co-simulation of a scene's whole pipeline in RTL (``[run.rtl]`` of a scene file).

The scene's ``[pipeline]`` becomes one generated top (:mod:`tdicam.pipeline`); the scene's
raw data -- every exposure frame of every channel, the reset frames, the NUC calibration
codes -- runs through it in fast mode and every block's output (tap) is compared bit for
bit with the golden chain on the same data. Without ``crop`` the whole scene runs; with
``crop = [x0, y0, width, height]`` only the input columns and frames that make that output
window (the golden chain runs on the same cut data, so a 2-D block's borders are those of
the crop).
"""

from __future__ import annotations

import time

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["cosim_scene", "scene_data"]


def scene_data(scene, *, stages, dv_over_v, lines):
    """The raw data of one exact simulation of ``scene``: (:class:`~tdicam.pipeline.
    SceneData`, engine result).

    The scene simulator keeps its raw frames internal; they are taken, unchanged, where
    they enter its pre-TDI blocks (``engine._pre_tdi_blocks``). The run is exact and has
    the same seed, so the frames are those of ``tdicam run``'s exact result.
    """
    from tdicam import engine
    from tdicam.pipeline import SceneData
    seen = {}
    orig = engine._pre_tdi_blocks

    def capture(cfg, on, frames_ch, resets_ch, *args, **kw):
        seen["data"] = SceneData(list(frames_ch), None if resets_ch is None
                                 else list(resets_ch), cfg._nuc_coeffs)
        return orig(cfg, on, frames_ch, resets_ch, *args, **kw)

    engine._pre_tdi_blocks = capture
    try:
        res = engine.simulate(scene, stages=stages, dv_over_v=dv_over_v, fidelity="exact",
                              lines=lines, impact=False)
    finally:
        engine._pre_tdi_blocks = orig
    if "data" not in seen:
        raise TdicamError("[run.rtl]: the scene simulator gave no raw frames (digital TDI, "
                          "exact fidelity needed)")
    return seen["data"], res


def cosim_scene(scene, res, crop, *, out_dir=None, corrupt=None):
    """Run the scene's pipeline in RTL and compare with its golden chain.

    Parameters
    ----------
    scene : Scene
    res : engine SimResult
        The run's main result (stages, velocity mismatch and lines are taken from it).
    crop : (y0, h, x0, w)
        Used when ``[run.rtl].crop`` is given; without it the whole scene runs.
    out_dir : path or None
        Where the waveform of a mismatch goes.
    corrupt : callable or None
        Alters the golden stages first (tests: the check can fail).

    Returns
    -------
    dict
        ``simulator``, ``crop`` (None: whole scene), ``blocks`` (one entry per tap, then the
        ``pipeline`` entry with the totals: pixels compared, mismatches, input pixels, build
        and run seconds, input pixels/s, the first mismatch and the waveform path).
    """
    from tdicam import pipeline as pl
    rt = scene.run.rtl
    m, lines = int(res.stages), int(res.output.shape[0])
    out = {"simulator": rt.simulator, "crop": None if rt.crop is None else list(crop),
           "blocks": []}
    try:
        p = pl.plan(scene, stages=m, lines=lines)
        t0 = time.perf_counter()
        data, ex = scene_data(scene, stages=m, dv_over_v=res.dv_over_v, lines=lines)
        golden_s = time.perf_counter() - t0
        agree, gold = None, None
        if rt.crop is not None:
            y0, h, x0, w = crop
            data = data.crop(x0, w, y0, h + m - 1)
            p = pl.plan(scene, stages=m, lines=h, width=w)
        else:
            gold = pl.golden(p, data)
            last = gold[-1][2]
            agree = bool(np.array_equal(last.reshape(ex.output.shape), ex.output))
            if not agree:
                raise TdicamError("[run.rtl]: the golden chain and the scene simulator's "
                                  "output differ")
        rep = pl.cosimulate(p, data, rt.simulator, gold=gold, corrupt=corrupt,
                           wave_dir=out_dir)
    except TdicamError as exc:
        out["blocks"].append({"block": "pipeline", "status": f"error: {exc}"})
        return out
    for t in rep["taps"]:
        out["blocks"].append({"block": f"tap {t['tap']}", "status": "ran",
                              "pixels_compared": t["beats"], "mismatches": t["mismatches"]})
    summary = {k: v for k, v in rep.items() if k != "taps"}
    summary.update({"block": "pipeline", "status": "ran", "engine_agrees": agree,
                    "scene_data_seconds": golden_s})
    out["blocks"].append(summary)
    return out
