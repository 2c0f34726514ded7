"""Bit-identity check of the scene simulator before and after a change.

Two jobs:

``dump DIR``
    runs :func:`tdicam.engine.simulate` on every bundled scene (``scenes/*.toml``) at its own
    fidelity and at ``exact`` and ``fast``, on a few lines, with the impact study, plus one
    run with every forcible effect forced on and one with effects disabled, and writes each
    result's arrays (``.npy``: target, raw, single, output and the golden blocks' crop
    arrays) and its records (``.json``: effects table, notes, pedestals, full scale,
    geometry) into ``DIR/<scene>-<variant>/``.
``compare A B``
    compares two such trees, or two ``tdicam run`` output folders: every ``.json`` number and
    string except timings, load and paths (masked below), every image and array file
    (``.png``, ``.tif``, ``.npy``) byte for byte, and ``report.md`` with its timings masked.
    Prints one line per file that differs and exits 1 if any does.

Usage::

    python bench/scene_regress.py dump /tmp/before          # on the old tree
    python bench/scene_regress.py dump /tmp/after           # on the new tree
    python bench/scene_regress.py compare /tmp/before /tmp/after
    python bench/scene_regress.py compare out/before/orbit out/after/orbit   # tdicam run dirs
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: JSON keys whose values are timings, machine load or paths (not compared).
SKIP_KEYS = frozenset({"seconds", "cpu_seconds", "wall_seconds", "lines_per_s",
                       "exposure_pixels_per_s", "x_real_time", "exposure_pixels_per_cpu_s",
                       "load_average_1min", "threads", "cpus", "scene", "source"})
#: Timings inside strings (notes, summary, report.md).
_TIMING = [
    (re.compile(r"took [0-9.e+-]+ s"), "took * s"),
    (re.compile(r"[0-9.e+-]+ lines/s"), "* lines/s"),
    (re.compile(r"[0-9.]+x real time"), "*x real time"),
    (re.compile(r"[0-9.]+ M exposure-pixels/s"), "* M exposure-pixels/s"),
    (re.compile(r"# tdicam run: .*"), "# tdicam run: *"),
]
_NUMBER = re.compile(r"[0-9][0-9.e+-]*")
_VARIANTS = ("scene", "exact", "fast", "forced", "disabled")
_LINES = 40
#: Extra cases on bundled scenes that reach the other branches of the engine:
#: (name, scene, overrides, simulate keywords).
EXTRA = [
    ("orbit-moving-fast", "orbit_600km_1m_96", {"motion": {"dv_over_v": 0.05},
                                                "sensor": {"columns": 256}},
     {"fidelity": "fast"}),
    ("orbit-moving-fullwell-fast", "orbit_600km_1m_96",
     {"motion": {"dv_over_v": 0.05, "drift_deg": 1.0}, "target": {"signal_e": 19000.0},
      "sensor": {"columns": 200}}, {"fidelity": "fast", "stages": 8}),
    ("flat-lowlight-moments-fast", "flat_snr_sweep_96",
     {"target": {"signal_e": 15.0}, "sensor": {"read_noise_e": 0.0}}, {"fidelity": "fast"}),
    ("flat-cds-pedestal-fast", "flat_snr_sweep_96",
     {"target": {"signal_e": 100.0}, "sensor": {"read_noise_e": 0.0, "black_level_dn": 64.5},
      "pipeline": {"blocks": ["cds", "tdi"]}, "tdi": {"stages": 8}}, {"fidelity": "fast"}),
    ("flat-cds-auto", "flat_snr_sweep_96", {"pipeline": {"blocks": ["cds", "tdi"]}},
     {"fidelity": "auto"}),
    ("charge-moments-fast", "zhou2008_interline_ccd_charge_4",
     {"target": {"signal_e": 30.0}, "sensor": {"read_noise_e": 0.0}}, {"fidelity": "fast"}),
    ("charge-fullwell-nuc-exact", "zhou2008_interline_ccd_charge_4",
     {"target": {"signal_e": 15000.0}, "sensor": {"prnu": 0.02, "dsnu_e": 3.0},
      "pipeline": {"blocks": ["cds", "nuc", "tdi"]}}, {"fidelity": "exact"}),
    ("turntable-reverse-median-pre", "yuan2013_lab_turntable_8",
     {"tdi": {"direction": "reverse"}, "pipeline": {"blocks": ["median3", "tdi"]},
      "optics": {"psf_sigma_px": 0.7}, "sensor": {"prnu": 0.01}}, {"fidelity": "auto"}),
    ("turntable-reverse-fast", "yuan2013_lab_turntable_8",
     {"tdi": {"direction": "reverse"}, "optics": {"psf_sigma_px": 0.7}},
     {"fidelity": "fast", "dv_over_v": 0.125}),
    ("hdr-nuc-noecc", "ning2019_gmax0504_hdr",
     {"pipeline": {"nuc": {"ecc": False}, "blocks": ["cds", "nuc", "hdr", "median3", "tdi"]}},
     {"fidelity": "exact"}),
    ("hdr-median-post-fast", "ning2019_gmax0504_hdr",
     {"pipeline": {"blocks": ["cds", "tdi", "median3"], "hdr": None, "nuc": None},
      "sensor": {"gains": [1.0]}, "tdi": {"output_bits": 14}},
     {"fidelity": "fast"}),
]


def _mask_text(s):
    for rx, rep in _TIMING:
        s = rx.sub(rep, s)
    return s


def _mask(obj):
    if isinstance(obj, dict):
        return {k: ("*" if k in SKIP_KEYS else _mask(v)) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_mask(v) for v in obj]
    if isinstance(obj, str):
        return _mask_text(obj)
    return obj


def _mask_md(text):
    out = []
    section = None
    for line in text.splitlines():
        if line.startswith("## "):
            section = line
        if section == "## Speed":
            line = _NUMBER.sub("*", line)
        elif section == "## Effects" and line.startswith("| ") and not line.startswith(
                "| effect") and not line.startswith("|---"):
            cells = line.split("|")
            if len(cells) > 7:
                cells[6] = " * "                            # time (s) column
            line = "|".join(cells)
        out.append(_mask_text(line))
    return "\n".join(out)


def _dump_result(res, where):
    where.mkdir(parents=True, exist_ok=True)
    for name in ("target", "raw", "single", "output"):
        np.save(where / f"{name}.npy", np.asarray(getattr(res, name)))
    for block, arrs in sorted((res.frames_crop or {}).items()):
        for k, v in sorted(arrs.items()):
            if isinstance(v, np.ndarray):
                np.save(where / f"crop_{block}_{k}.npy", v)
    g = res.geometry
    rec = {
        "stages": res.stages, "dv_over_v": res.dv_over_v, "fidelity": res.fidelity,
        "effects": [e.to_dict() for e in res.effects], "notes": res.notes,
        "pedestal_single": res.pedestal_single, "pedestal_output": res.pedestal_output,
        "output_full_scale": res.output_full_scale, "exposure_pixels": res.exposure_pixels,
        "geometry": {k: getattr(g, k) for k in ("stages", "dv_over_v", "drift_deg", "skew",
                                                "q_over_p", "psf_sigma_px")},
        "crop_params": {b: {k: v for k, v in a.items() if not isinstance(v, np.ndarray)}
                        for b, a in (res.frames_crop or {}).items()},
    }
    (where / "result.json").write_text(json.dumps(rec, indent=1, default=str))


def dump(out):
    """Run every bundled scene in every variant and write the results under ``out``."""
    from tdicam.engine import FORCIBLE, simulate
    from tdicam.scene.loader import load_scene
    out = Path(out)
    crop = (1, 4, 3, 9)
    for path in sorted((ROOT / "scenes").glob("*.toml")):
        sc = load_scene(path)
        m = max(sc.tdi.stages)
        for var in _VARIANTS:
            kw = {"stages": m, "lines": _LINES, "keep_crop": crop}
            if var in ("exact", "fast"):
                kw["fidelity"] = var
            elif var == "forced":
                kw.update(force=list(FORCIBLE), fidelity="exact", stages=min(sc.tdi.stages))
            elif var == "disabled":
                kw.update(disable=["read_noise", "shot_noise"],
                          dv_over_v=sc.motion.dv_over_v[-1])
            _dump_one(simulate, sc, kw, out / f"{path.stem}-{var}")
    for name, stem, over, kw in EXTRA:
        sc = load_scene(ROOT / "scenes" / f"{stem}.toml", overrides=over)
        _dump_one(simulate, sc, {"lines": _LINES, "keep_crop": crop, **kw}, out / name)


def _dump_one(simulate, sc, kw, where):
    """One run into ``where`` (its one-line error into ``error.txt`` if it refuses)."""
    from tdicam.errors import TdicamError
    try:
        res = simulate(sc, **kw)
    except TdicamError as exc:
        where.mkdir(parents=True, exist_ok=True)
        (where / "error.txt").write_text(str(exc) + "\n")
        print(f"{where.name}: error: {exc}")
        return
    _dump_result(res, where)
    print(f"{where.name}: {res.fidelity}, output {res.output.shape}")


def compare(a, b):
    """Differences between trees ``a`` and ``b`` (list of one-line messages)."""
    a, b = Path(a), Path(b)
    fa = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    fb = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    fa = {p for p in fa if p.suffix != ".log"}
    fb = {p for p in fb if p.suffix != ".log"}
    diffs = [f"only in {a}: {p}" for p in sorted(fa - fb)]
    diffs += [f"only in {b}: {p}" for p in sorted(fb - fa)]
    n = 0
    for p in sorted(fa & fb):
        n += 1
        x, y = a / p, b / p
        if p.suffix == ".json":
            jx, jy = _mask(json.loads(x.read_text())), _mask(json.loads(y.read_text()))
            if jx != jy:
                diffs.append(f"{p}: {_first_json_diff(jx, jy)}")
        elif p.suffix == ".md":
            if _mask_md(x.read_text()) != _mask_md(y.read_text()):
                diffs.append(f"{p}: text differs (timings masked)")
        elif x.read_bytes() != y.read_bytes():
            diffs.append(f"{p}: bytes differ")
    return n, diffs


def _first_json_diff(x, y, path="$"):
    if type(x) is not type(y):
        return f"{path}: {x!r} != {y!r}"
    if isinstance(x, dict):
        for k in sorted(set(x) | set(y)):
            if k not in x or k not in y:
                return f"{path}.{k}: present on one side only"
            if x[k] != y[k]:
                return _first_json_diff(x[k], y[k], f"{path}.{k}")
    if isinstance(x, list):
        if len(x) != len(y):
            return f"{path}: length {len(x)} != {len(y)}"
        for i, (u, v) in enumerate(zip(x, y)):
            if u != v:
                return _first_json_diff(u, v, f"{path}[{i}]")
    return f"{path}: {x!r} != {y!r}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("dump")
    d.add_argument("out")
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    args = ap.parse_args(argv)
    if args.cmd == "dump":
        dump(args.out)
        return 0
    n, diffs = compare(args.a, args.b)
    for line in diffs:
        print(line)
    print(f"{n} files compared, {len(diffs)} differences")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
