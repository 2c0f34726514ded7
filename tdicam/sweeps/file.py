"""Sweep files: parse, expand and validate the points and runs of a trade study.

A sweep file (TOML) names a base scene and the scene keys to vary::

    scene = "../tao2012_ibis5_rolling_1_5_10.toml"   # relative to the sweep file
    name = "tao2012_snr"                             # optional, default: the file's stem
    repeats = 4                                      # Monte-Carlo repeats per point [1]

    [set]                          # optional: fixed overrides of the base scene
    "run.lines" = 64
    "sensor.columns" = 128

    [axes]                         # the product of these is the set of points
    "tdi.stages" = [1, 2, 5, 10, 20, 40]
    "target.signal_e" = { start = 100, stop = 1000, num = 4 }

    [zip]                          # optional: keys that move together (one more axis)
    "motion.dv_over_v" = [0.0, 0.1]
    "motion.drift_deg" = [0.0, 0.5]

Keys are ``section.key`` paths of the scene schema (:mod:`tdicam.scene.loader`), quoted or as TOML
dotted keys (``tdi.stages = [...]``); ``pipeline.hdr.threshold_dn`` reaches a sub-table.
A value list is used as given (duplicates are an error); a range is a table
``{start, stop, num}`` (``num`` values from start to stop inclusive, ``log = true`` for a
geometric spacing) or ``{start, stop, step}`` (start, start + step, ... up to stop
inclusive). When start, stop and step are integers the values are integers (rounded and
de-duplicated for ``num``). Float values are rounded to 12 significant digits. A base scene
whose ``[tdi].stages`` or ``[motion].dv_over_v`` is a list (the scene's own sweep) gets that
list as an axis unless the sweep file varies the key.

Points, runs and seeds
----------------------
A *point* is one combination of axis values; a *run* is one point and one repeat. Every
point is validated through the scene loader (:func:`tdicam.scene.loader.scene_from_dict`) before
anything runs, so a bad value gives the scene's own one-line error, prefixed with the sweep
file and the point. With a ``limit`` (``--limit N``) only the points the first N runs still to
compute need are validated, plus every value of every axis once (the points that differ
from the first in one axis); the other points stay unvalidated (``missing`` in the results,
seed -1 and no hash) until a rerun reaches them. The seed of run ``(point, repeat)`` replaces ``[run].seed``: the first 63
bits of ``sha256`` of the point's validated scene (with the base seed) and the repeat index —
it depends on what is simulated, never on which worker runs it or in which order. More runs
than :data:`MAX_RUNS` need ``force=True`` (``--force``); more than :data:`MAX_FORCED_RUNS`
are refused before any point is expanded (split the sweep). A key is given once: in
``[set]``, ``[axes]`` or ``[zip]``.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from tdicam.version import __version__
from tdicam.errors import TdicamError, check_range
from tdicam.files import input_path
from tdicam.scene.loader import read_toml
from tdicam.scene.keys import get_key, set_key

__all__ = ["MAX_RUNS", "MAX_FORCED_RUNS", "STORE_FORMAT", "Axis", "SweepRun", "Sweep",
           "load_sweep", "read_sweep", "validate_sweep"]

#: Largest number of runs (points x repeats) accepted without ``force``.
MAX_RUNS = 5000
#: Largest number of runs accepted with ``force``: every run's scene is validated (about
#: 2 ms each) and held in memory with its results row (about 8 kB), so 50,000 runs take
#: about 2 minutes and 0.4 GB before the first one is computed.
MAX_FORCED_RUNS = 50_000
#: Version of the record layout; part of every run's hash (2: the ``saturated`` column).
STORE_FORMAT = 2
_FILE_KEYS = ("scene", "name", "repeats", "set", "axes", "zip")
_MAX_AXIS = 100_000
_RANGE_KEYS = frozenset({"start", "stop", "num", "step", "log"})
#: Scene keys that hold a list in the scene itself (its own sweep); promoted to axes.
_SCENE_LISTS = ("tdi.stages", "motion.dv_over_v")


@dataclass(frozen=True)
class Axis:
    """One swept scene key: ``key`` (``"tdi.stages"``), its ``values``, and whether it moves
    with the other keys of the zip group (``zipped``)."""

    key: str
    values: tuple
    zipped: bool = False


@dataclass(frozen=True)
class SweepRun:
    """One run of a sweep (a task: the scene run of one point, one repeat): point ``point``
    (index into :attr:`Sweep.points`), repeat ``repeat``, its validated scene (seed set),
    ``seed``, the store ``hash`` and ``settings``, the scene as the plain dict that was
    hashed. A run of a point not validated yet (``limit`` of
    :func:`validate_sweep`) has ``scene`` None, ``seed`` -1 and ``hash`` ""."""

    point: int
    repeat: int
    scene: object
    seed: int
    hash: str
    settings: dict = dataclasses.field(repr=False, compare=False)


@dataclass(frozen=True)
class Sweep:
    """A sweep: axes, points (dicts key -> value) and runs (point-major); the first
    ``validated`` points are validated (all of them after :func:`load_sweep`; none after
    :func:`read_sweep`), the others' runs are placeholders (see :class:`SweepRun`)."""

    path: Path
    name: str
    scene_path: Path
    repeats: int
    axes: tuple[Axis, ...]
    zipped: tuple[Axis, ...]
    points: tuple[dict, ...]
    runs: tuple[SweepRun, ...]
    impact: bool
    promoted: tuple[str, ...]
    validated: int = 0
    base: dict = dataclasses.field(default=None, repr=False, compare=False)
    src: str = ""

    @property
    def keys(self) -> tuple[str, ...]:
        """Every swept key: product axes, then the zip group."""
        return tuple(a.key for a in self.axes + self.zipped)

    @property
    def shape(self) -> tuple[int, ...]:
        """Dataset shape: one entry per product axis, the zip length, the repeats."""
        z = (len(self.zipped[0].values),) if self.zipped else ()
        return tuple(len(a.values) for a in self.axes) + z + (self.repeats,)


def _canon(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _sha(obj) -> str:
    return hashlib.sha256(_canon(obj).encode()).hexdigest()


def _scene_key(scene) -> dict:
    d = scene.to_dict()
    d.pop("source", None)
    return d


def _flatten(table, where, prefix="", path=(), spelled=None):
    """``{"tdi": {"stages": [..]}}`` and ``{"tdi.stages": [..]}`` -> ``{"tdi.stages": [..]}``;
    one key given in both spellings (``"tdi.stages" = ..`` and ``[axes.tdi] stages = ..``)
    is a one-line :class:`TdicamError` naming both (else one would be lost)."""
    out = {}
    spelled = {} if spelled is None else spelled
    for k, v in table.items():
        key = f"{prefix}{k}"
        here = path + (k,)
        if not (isinstance(v, dict) and not (v and set(v) <= _RANGE_KEYS)):
            if key in spelled:
                raise TdicamError(f"{where} {key}: given twice, as {_spelling(where, spelled[key])}"
                                  f" and as {_spelling(where, here)}; give it once")
            spelled[key] = here
        if isinstance(v, dict) and {"start", "stop"} & set(v) and not set(v) <= _RANGE_KEYS:
            extra = sorted(set(v) - _RANGE_KEYS)     # a range with a typo, not scene keys
            raise TdicamError(f"{where} {key}: range table: unknown key {extra[0]!r}; valid: "
                              f"{', '.join(sorted(_RANGE_KEYS))}")
        if isinstance(v, dict) and not (v and set(v) <= _RANGE_KEYS):
            if not v:
                raise TdicamError(f"{where} {key}: empty table")
            out.update(_flatten(v, where, key + ".", here, spelled))
        else:
            out[key] = v
    return out


def _spelling(where, path):
    """How a flattened key was written: ``[axes] "tdi.stages"``, ``[axes.tdi] stages``."""
    table = where.rsplit("[", 1)[-1].rstrip("]") if where.endswith("]") else ""
    name = path[-1] if "." not in path[-1] else f'"{path[-1]}"'
    return f"[{'.'.join((table,) + path[:-1]) if table else '.'.join(path[:-1])}] {name}"


def _tidy(v):
    if isinstance(v, float):
        return float(f"{v:.12g}")
    return v


def _range(spec, label):
    def num(name, integer=False):
        v = spec.get(name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise TdicamError(f"{label}: range {name} must be a finite number, got {v!r}")
        if integer and not isinstance(v, int):
            raise TdicamError(f"{label}: range {name} must be an integer, got {v!r}")
        return v
    for k in ("start", "stop"):
        if k not in spec:
            raise TdicamError(f"{label}: a range needs start and stop (and num or step)")
    if ("num" in spec) == ("step" in spec):
        raise TdicamError(f"{label}: a range needs exactly one of num and step")
    start, stop = num("start"), num("stop")
    ints = isinstance(start, int) and isinstance(stop, int)
    log = spec.get("log", False)
    if not isinstance(log, bool):
        raise TdicamError(f"{label}: range log must be true or false, got {log!r}")
    if "num" in spec:
        n = check_range(f"{label}: range num", num("num", integer=True), 0, _MAX_AXIS)
        if log:
            if start <= 0 or stop <= 0:
                raise TdicamError(f"{label}: a log range needs start and stop > 0")
            vals = np.geomspace(start, stop, n) if n else []
        else:
            vals = np.linspace(start, stop, n)
        if ints:
            return list(dict.fromkeys(int(round(v)) for v in vals))
        return [float(v) for v in vals]
    if log:
        raise TdicamError(f"{label}: log = true needs num, not step")
    step = num("step")
    ints = ints and isinstance(step, int)
    if step == 0 or (stop - start) / step < 0:
        return []
    count = (stop - start) / step + 1e-9            # inf for a tiny step: never int() it
    if count + 1 > _MAX_AXIS:
        many = (f"{int(count) + 1}" if count < 1e15 else f"about {count:.3g}"
                if math.isfinite(count) else "endlessly many")
        raise TdicamError(f"{label}: range gives {many} values, more than {_MAX_AXIS}")
    n = int(math.floor(count)) + 1
    return [start + i * step if ints else float(start + i * step) for i in range(n)]


def _axis(key, raw, label, zipped=False):
    if "." not in key or not all(key.split(".")):
        raise TdicamError(f"{label}: axis keys are section.key paths of the scene, e.g. "
                          f"'tdi.stages', got {key!r}")
    if isinstance(raw, dict):
        values = _range(raw, label)
    elif isinstance(raw, list):
        values = raw
    else:
        raise TdicamError(f"{label}: must be a list of values or a range table "
                          f"{{start, stop, num}} / {{start, stop, step}}, got {raw!r}")
    if not values:
        raise TdicamError(f"{label}: empty axis (it needs at least one value)")
    values = [_tidy(v) for v in values]
    seen = set()
    for v in values:
        try:
            c = _canon(v)
        except ValueError:                  # nan or inf (JSON has neither)
            raise TdicamError(f"{label}: value {v!r} is not a finite number") from None
        if c in seen:
            raise TdicamError(f"{label}: value {v!r} is listed twice")
        seen.add(c)
    return Axis(key, tuple(values), zipped)


def _deepcopy(data):
    return json.loads(json.dumps(data))


def _show_point(point):
    return ", ".join(f"{k} = {json.dumps(v)}" for k, v in point.items())


def _validation_progress(n_points, enabled, bounded=False):
    """A progress bar (a terminal) or one line (otherwise) while ``n_points`` points are
    validated (``bounded``: about that many, a ``limit`` stops it), when there are enough
    to take a while; None when quiet."""
    import os
    import sys
    if not enabled or n_points < 500:
        return None
    if sys.stderr.isatty() and not os.environ.get("CI"):
        try:
            from tqdm import tqdm
            return tqdm(total=n_points, desc="validating points", unit="point", leave=False)
        except ImportError:
            pass
    print(f"sweep: validating {'about ' * bounded}{n_points:,} points "
          f"(about {n_points * 2e-3:.0f} s)",
          file=sys.stderr, flush=True)
    return None


def load_sweep(path, *, force=False, impact=False, progress=False) -> Sweep:
    """Read, expand and validate a sweep file (see the module docstring):
    :func:`validate_sweep` of :func:`read_sweep`, every point validated.

    Parameters
    ----------
    path : str, Path or mapping
        The sweep TOML file, or its content as a dict (then ``scene`` is relative to the
        current folder, messages name it ``sweep`` and so does the default ``name``).
    force : bool
        Accept more than :data:`MAX_RUNS` runs.
    impact : bool
        Measure each effect's impact in every run (part of each run's hash).
    progress : bool
        Show the validation's progress on stderr when there are many points.

    Returns
    -------
    Sweep

    Raises
    ------
    TdicamError
        One line naming the file and the key: an unknown file key, an axis key the scene
        does not have, an empty axis, a zip group of unequal lengths, a value the scene
        loader rejects (its message, with the point), too many runs without ``force``
        (or more than :data:`MAX_FORCED_RUNS` with it), a key both fixed and swept.
    """
    return validate_sweep(read_sweep(path, force=force, impact=impact), progress=progress)


def read_sweep(path, *, force=False, impact=False) -> Sweep:
    """Read and expand a sweep file, no point validated yet (:func:`load_sweep` without
    the validation: every point listed, each run a placeholder, the counts checked)."""
    doc, path, src = _read_doc(path)
    scene_path, base = _base_scene(doc, path, src)
    name = _name(doc, path, src)
    repeats = _repeats(doc, src)
    tables = _tables(doc, src)
    _apply_set(base, tables, src)
    axes, zipped, promoted = _axes(base, tables, scene_path, src)
    _check_size(axes, zipped, repeats, force, src)
    points = tuple(dict(c) for c in _combos(axes, zipped))
    runs = tuple(SweepRun(i, r, None, -1, "", {}) for i in range(len(points))
                 for r in range(repeats))
    return Sweep(path=path, name=name, scene_path=scene_path, repeats=repeats,
                 axes=tuple(axes), zipped=tuple(zipped), points=points, runs=runs,
                 impact=bool(impact), promoted=tuple(promoted), base=base, src=src)


def validate_sweep(sweep: Sweep, *, progress=False, limit=None, finished=None) -> Sweep:
    """Validate the points of a :func:`read_sweep` sweep through the scene loader, in
    order, and give their runs seeds and hashes (see the module docstring).

    Parameters
    ----------
    sweep : Sweep
        From :func:`read_sweep`.
    progress : bool
        Show the validation's progress on stderr when there are many points.
    limit : int, optional
        Stop once the runs validated hold ``limit`` runs still to compute (not
        ``finished``; a point whose runs are all finished is validated still, so that
        ``limit=0`` reuses the finished prefix): only the points a ``limit``-bounded sweep
        runs are validated, after
        the points that differ from the first in one axis (every value of every axis once,
        each a point of the sweep: a cheap check of the axes); the later points keep their
        placeholder runs. None: every point.
    finished : callable(hash) -> bool, optional
        Whether run ``hash`` has a finished record (the store a rerun resumes from).

    Returns
    -------
    Sweep
        ``sweep`` with the validated points' runs and :attr:`Sweep.validated` set.

    Raises
    ------
    TdicamError
        The first point the scene loader rejects (its message, with the point).
    """
    def scene(index):
        point = sweep.points[index]
        return _point_scene(sweep.base, tuple(point.items()), point, sweep.scene_path,
                            sweep.src)

    n_points = len(sweep.points)
    cross = [] if limit is None else _cross(sweep)
    expect = (n_points if limit is None
              else min(n_points, len(cross) + -(-limit // sweep.repeats)))
    bar = _validation_progress(expect, progress, bounded=limit is not None)
    for index in cross:
        scene(index)
        if bar is not None:
            bar.update(1)
    runs, todo, index, done = [], set(), 0, True
    # past the limit, the points whose runs are all finished still count (reused runs)
    while index < n_points and (limit is None or len(todo) < limit or done):
        if bar is not None:
            bar.update(1)
        new = _point_runs(index, scene(index), sweep.repeats, sweep.impact)
        if limit is not None:
            fresh = {r.hash for r in new if not (finished is not None and finished(r.hash))}
            todo |= fresh
            done = not fresh
        runs += new
        index += 1
    if bar is not None:
        bar.close()
    return dataclasses.replace(sweep, runs=tuple(runs) + sweep.runs[len(runs):],
                               validated=index)


def _cross(sweep):
    """Indices of the points that differ from the first in one axis only (every value of
    every axis once, a zip group as one axis), the first included."""
    sizes = [len(a.values) for a in sweep.axes] + ([len(sweep.zipped[0].values)]
                                                   if sweep.zipped else [])
    out, stride = [0], 1
    for n in reversed(sizes):
        out += [i * stride for i in range(1, n)]
        stride *= n
    return sorted(out)


def _read_doc(path):
    """The sweep file's table, its path and the name messages give it; its keys checked."""
    if isinstance(path, Mapping):
        doc, path = dict(path), Path.cwd() / "sweep"
        src = "sweep"
    else:
        path = input_path(path, "sweep file")
        doc = read_toml(path, "sweep file")
        src = str(path)
    for k in doc:
        if k not in _FILE_KEYS:
            close = difflib.get_close_matches(k, _FILE_KEYS, n=1, cutoff=0.6)
            raise TdicamError(f"{src}: {k}: unknown key"
                              + (f"; did you mean {close[0]!r}?" if close
                                 else "; valid: " + ", ".join(_FILE_KEYS)))
    return doc, path, src


def _base_scene(doc, path, src):
    """The base scene's resolved path and its raw table (the scene validated first)."""
    from tdicam.scene.loader import load_scene
    if "scene" not in doc:
        raise TdicamError(f"{src}: scene: missing (the base scene file, relative to the "
                          f"sweep file)")
    if not isinstance(doc["scene"], str) or not doc["scene"].strip():
        raise TdicamError(f"{src}: scene: must be the base scene's file name (relative to "
                          f"the sweep file), got {doc['scene']!r}")
    scene_path = (path.resolve().parent / doc["scene"]).resolve()
    try:
        load_scene(scene_path)                   # the base scene's own errors first
    except TdicamError as exc:
        if str(scene_path) in str(exc) or scene_path.name in str(exc):
            raise
        raise TdicamError(f"{src}: scene {scene_path}: {exc}") from None
    return scene_path, read_toml(scene_path, "scene file")


def _name(doc, path, src):
    """The sweep's ``name`` (a folder name; the file's stem by default)."""
    name = doc.get("name", path.stem)
    if not isinstance(name, str) or not name.strip() or name in (".", "..") \
            or "/" in name or "\\" in name:
        raise TdicamError(f"{src}: name: must be a folder name (no '/', not '.' or '..'; the "
                          f"default output is out/sweeps/NAME), got {name!r}")
    return name


def _repeats(doc, src):
    """The sweep's ``repeats`` (an integer >= 1; 1 by default)."""
    repeats = doc.get("repeats", 1)
    if isinstance(repeats, bool) or not isinstance(repeats, int):
        raise TdicamError(f"{src}: repeats: must be an integer >= 1, got {repeats!r}")
    check_range(f"{src}: repeats", repeats, 1, None)
    return repeats


def _tables(doc, src):
    """The ``set``, ``axes`` and ``zip`` tables, each flattened to dotted scene keys."""
    tables = {}
    for t in ("set", "axes", "zip"):
        v = doc.get(t, {})
        if not isinstance(v, dict):
            raise TdicamError(f"{src}: {t}: must be a table of scene keys, got {v!r}")
        tables[t] = _flatten(v, f"{src}: [{t}]")
    return tables


def _apply_set(base, tables, src):
    """Write the ``[set]`` keys into the base scene's table (a key is fixed or swept)."""
    for key, value in tables["set"].items():
        for t in ("axes", "zip"):
            if key in tables[t]:
                raise TdicamError(f"{src}: [set] {key}: also in [{t}]; a key is either "
                                  f"fixed ([set]) or swept ([{t}]), not both")
        if "." not in key:
            raise TdicamError(f"{src}: [set] {key}: keys are section.key paths of the scene")
        set_key(base, key, value)


def _axes(base, tables, scene_path, src):
    """The crossed axes, the zipped axes and the scene keys promoted to axes (the base
    scene's own lists that no axis sweeps)."""
    axes = [_axis(k, v, f"{src}: [axes] {k}") for k, v in tables["axes"].items()]
    zipped = [_axis(k, v, f"{src}: [zip] {k}", True) for k, v in tables["zip"].items()]
    for z in zipped:
        if z.key in tables["axes"]:
            raise TdicamError(f"{src}: [zip] {z.key}: also in [axes]; a key is swept once")
        if len(z.values) != len(zipped[0].values):
            raise TdicamError(f"{src}: [zip] {z.key}: {len(z.values)} values, but "
                              f"{zipped[0].key} has {len(zipped[0].values)}; zipped keys "
                              f"move together and need equal lengths")
    swept = set(tables["axes"]) | set(tables["zip"])
    promoted = []
    for key in _SCENE_LISTS:
        v = get_key(base, key)
        if isinstance(v, list) and key not in swept:
            axes.append(_axis(key, v, f"{scene_path}: {key}"))
            promoted.append(key)
    return axes, zipped, promoted


def _check_size(axes, zipped, repeats, force, src):
    """Refuse more than :data:`MAX_RUNS` runs without ``force``, more than
    :data:`MAX_FORCED_RUNS` with it."""
    n_points = math.prod(len(a.values) for a in axes) * (len(zipped[0].values) if zipped
                                                         else 1)
    n_runs = n_points * repeats
    if n_runs > MAX_RUNS and not force:
        sizes = " x ".join([f"{a.key} ({len(a.values)})" for a in axes]
                           + ([f"zip ({len(zipped[0].values)})"] if zipped else [])
                           + [f"repeats ({repeats})"])
        raise TdicamError(f"{src}: {sizes} = {n_runs} runs, over the limit of {MAX_RUNS}; "
                          f"reduce the axes or pass --force")
    if n_runs > MAX_FORCED_RUNS:
        raise TdicamError(f"{src}: {n_runs:,} runs (points x repeats), over the "
                          f"{MAX_FORCED_RUNS:,} one sweep holds even with --force (its "
                          f"results table and dataset hold every run, even with --limit); "
                          f"split it into several sweep files")


def _combos(axes, zipped):
    """Every point as a tuple of (key, value): the axes crossed, the zip groups together."""
    combos = [()]
    for a in axes:
        combos = [c + ((a.key, v),) for c in combos for v in a.values]
    if zipped:
        combos = [c + tuple((z.key, z.values[i]) for z in zipped)
                  for c in combos for i in range(len(zipped[0].values))]
    return combos


def _point_scene(base, combo, point, scene_path, src):
    """One point's scene: the base table with the point's values, validated."""
    from tdicam.scene.loader import scene_from_dict
    data = _deepcopy(base)
    for key, value in combo:
        set_key(data, key, value)
    try:
        scene = scene_from_dict(data, base_dir=scene_path.parent, source=str(scene_path))
    except TdicamError as exc:
        raise TdicamError(f"{src}: point {_show_point(point)}: {exc}") from None
    for key in _SCENE_LISTS:
        section, k = key.split(".")
        if len(getattr(getattr(scene, section), k)) != 1:
            raise TdicamError(f"{src}: point {_show_point(point)}: {key} must be one "
                              f"value per point, got a list")
    return scene


def _point_runs(index, scene, repeats, impact):
    """The ``repeats`` runs of point ``index``: each its seed (from the scene and the
    repeat) and its hash (format, version, impact and settings)."""
    key = _scene_key(scene)
    runs = []
    for r in range(repeats):
        seed = int.from_bytes(hashlib.sha256(
            _canon({"scene": key, "repeat": r}).encode()).digest()[:8], "big") >> 1
        sc = dataclasses.replace(scene, run=dataclasses.replace(scene.run, seed=seed))
        settings = {**key, "run": {**key["run"], "seed": seed}}
        h = _sha({"format": STORE_FORMAT, "tdicam": __version__, "impact": bool(impact),
                  "scene": settings})
        runs.append(SweepRun(index, r, sc, seed, h, settings))
    return runs
