"""Co-simulation of a scene's pipeline blocks in RTL (``[run.rtl]`` of a scene file).

Each chosen block with a registered stream block is run on the scene's crop through the
generated Verilog (fast mode) and compared bit for bit with its golden model on the same
input.
"""

from __future__ import annotations

import time

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["cosim_scene", "cosim_block"]


def cosim_scene(scene, res, crop):
    """Run each chosen block that has a registered stream block on the crop through the
    simulator and compare with its golden model on the same input."""
    from tdicam import blocks
    rt = scene.run.rtl
    arrays = res.frames_crop or {}
    out = {"simulator": rt.simulator, "crop": list(crop), "blocks": []}
    known = set(blocks.names())
    for name in ("cds", "nuc", "hdr", "median3", "tdi"):
        if name not in scene.pipeline.blocks:
            continue
        entry = {"block": name}
        out["blocks"].append(entry)
        if name not in known:
            entry["status"] = "skipped: no registered stream block (tdicam/blocks)"
            continue
        if name not in arrays:
            entry["status"] = "skipped: block did not run in this configuration"
            continue
        try:
            entry.update(cosim_block(name, blocks.get(name), arrays[name], rt))
        except TdicamError as exc:
            entry["status"] = f"error: {exc}"
    return out


def cosim_block(name, blk, arr, rt, corrupt=None):
    """Co-simulate one block on its crop arrays ``arr``; ``corrupt(arrays)`` may alter the
    expected arrays first (to show that the check can fail)."""
    from tdicam.cosim import compare, run_stream
    t0 = time.perf_counter()
    if name == "cds":
        from tdicam.model.cds import cds
        p = blk.resolve(arr["params"])
        sig, rst = arr["signal"].reshape(-1, *arr["signal"].shape[-2:]), \
            arr["reset"].reshape(-1, *arr["reset"].shape[-2:])
        a = {"signal": sig, "reset": rst, "out": cds(sig, rst, pixel_bits=p["pixel_bits"])}
    elif name == "nuc":
        from tdicam.model.nuc import nuc
        p = blk.resolve({k: v for k, v in arr["params"].items()})
        sh = (-1,) + arr["x"].shape[-2:]
        x, g, o = arr["x"].reshape(sh), arr["gain"].reshape(sh), arr["offset"].reshape(sh)
        a = {"x": x, "gain": g, "offset": o, "out": nuc(x, g, o, **p)}
    elif name == "hdr":
        from tdicam.model.hdr import hdr
        prm = dict(arr["params"])
        p = blk.resolve(prm)
        sh = (-1,) + arr["hg"].shape[-2:]
        hg, lg = arr["hg"].reshape(sh), arr["lg"].reshape(sh)
        a = {"hg": hg, "lg": lg, "gain_sel": np.zeros(len(hg), np.int64),
             "out": hdr(hg, lg, **p)}
    elif name == "median3":
        from tdicam.blocks.median3 import stream_case
        fr = np.asarray(arr["frames"])
        frames = list(fr.reshape(-1, *fr.shape[-2:]))     # (m, w) windows or one image
        p = blk.resolve({"width": int(fr.shape[-1]), **arr["params"]})
        a = stream_case(frames, p)
        if arr.get("out") is not None:
            # the engine ran the golden model on the same crop: it must agree
            _same("median3", a["out"], np.asarray(arr["out"]).reshape(a["out"].shape))
    elif name == "tdi":
        from tdicam.blocks.tdi import stream_arrays
        from tdicam.model.tdi import tdi_stream
        fr = np.asarray(arr["frames"])                    # (n_frames, m, w) on the crop
        prm = dict(arr["params"])
        m, d = int(prm["stages"]), int(prm["direction"])
        p = blk.resolve({"width": int(fr.shape[-1]), "stages": m,
                         "pixel_bits": prm["pixel_bits"], "out_bits": prm["out_bits"],
                         "ppc": 1})
        a = stream_arrays(list(fr), [(m, d)] * len(fr), p)
        r = tdi_stream(a["pixels"], a["first"], a["last"], a["stages_active"],
                       a["direction"], **p)
        a.update({"out": r.data, "out_first": r.first, "out_last": r.last})
        _same("tdi", r.data.reshape(-1, fr.shape[-1]), np.asarray(arr["out"]))
    else:
        return {"status": "skipped: no adapter for this block yet"}
    if corrupt is not None:
        corrupt(a)
    stim, exp = blk.to_beats(a, p)
    res = run_stream(name, p, stim, n_out=len(exp), sim=rt.simulator, mode="fast")
    cmp = compare(res.out, exp)
    return {"status": "ran", "pixels_compared": int(cmp.checked) * int(exp.data.shape[1]),
            "beats_compared": int(cmp.checked), "mismatches": int(cmp.mismatches),
            "message": cmp.message, "cycles": int(res.cycles),
            "seconds": time.perf_counter() - t0, "timeout": bool(res.timeout)}


def _same(block, stream_out, engine_out):
    """The block's stream model and the engine's golden call agree on the crop."""
    if stream_out.shape != engine_out.shape or not np.array_equal(stream_out, engine_out):
        raise TdicamError(f"[run.rtl]: the {block} stream model and the scene simulator's "
                          f"output differ on the crop ({stream_out.shape} vs "
                          f"{engine_out.shape})")
