"""Trade-study sweeps over scene keys on Dask: resumable, one tidy table, one labelled dataset.

A sweep file (TOML) names a base scene and the scene keys to vary::

    scene = "../seed003_ibis5_rolling_1_5_10.toml"   # relative to the sweep file
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

Keys are ``section.key`` paths of the scene schema (:mod:`tdicam.scene`), quoted or as TOML
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
point is validated through the scene loader (:func:`tdicam.scene.scene_from_dict`) before
anything runs, so a bad value gives the scene's own one-line error, prefixed with the sweep
file and the point. The seed of run ``(point, repeat)`` replaces ``[run].seed``: the first 63
bits of ``sha256`` of the point's validated scene (with the base seed) and the repeat index —
it depends on what is simulated, never on which worker runs it or in which order. More runs
than :data:`MAX_RUNS` need ``force=True`` (``--force``).

Execution
---------
Each run is one task: :func:`tdicam.engine.simulate` then :func:`tdicam.measure.measure`.
Tasks go to a ``dask.distributed`` cluster — a local one of ``workers`` processes with one
thread each (default: the CPU count; ``TDICAM_THREADS=1`` in each worker), or an existing
scheduler at ``scheduler`` — or run in this process (``serial``). A worker that dies loses
only its running tasks, which Dask runs again elsewhere; a task that kills its worker
:data:`ALLOWED_FAILURES` times, or raises, is recorded as failed with a one-line error and
the sweep goes on.

Store and resume
----------------
Each finished run is written to ``DIR/points/<hash>.json``, ``hash`` = sha256 of the run's
fully validated scene (seed included), the ``impact`` option, :data:`STORE_FORMAT` and the
tdicam version. The file is written to a temporary name in the same directory, flushed to
disk and renamed, so a file under a final name is always complete; files that do not parse
or hold another hash are treated as missing. A rerun (after a crash, Ctrl-C, ``limit``, or
an edit of the sweep file) computes only the runs without a finished record and reports how
many it reused; failed runs are tried again. Each record is the run's report: the scene
settings, the effects table (ran or skipped and why), notes, measurements with the planning
model's predictions, speed and the table row.

Results (``DIR/``)
------------------
``results.parquet`` and ``results.csv``: one row per point x repeat in point order — the
axis values (columns named by key), ``point``, ``repeat``, ``seed``, ``hash``, ``status``
(``ok``, ``failed``, ``missing`` when stopped early), ``error``, then :data:`RESULT_COLUMNS`.
``sweep.nc`` (netCDF-4 via h5netcdf): the same values as an :class:`xarray.Dataset` with
one dimension per product axis, ``zip`` for the zip group (its keys as coordinates along
it), and ``repeat``. ``summary.json`` and the plots: ``snr_vs_stages.png`` (flat targets,
measured gain per repeat with mean and standard deviation, the planning model and Tao et
al. 2012 eq 28), ``mtf_vs_mismatch.png`` (bar targets: MTF at the bar frequency against
M dV/V with the velocity-mismatch model of Yuan et al. 2013) and
``time_vs_fidelity.png``.

Every column except :data:`TIMING_COLUMNS` is a deterministic function of the sweep file
and the tdicam version: equal between serial and cluster runs, between two runs, and
between a resumed and an uninterrupted sweep.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import json
import math
import os
import socket
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tdicam import __version__
from tdicam.errors import TdicamError, check_range

__all__ = ["MAX_RUNS", "ALLOWED_FAILURES", "STORE_FORMAT", "RESULT_COLUMNS", "TIMING_COLUMNS",
           "Axis", "Run", "Sweep", "SweepResult", "load_sweep", "run_sweep", "run_one",
           "read_table"]

#: Largest number of runs (points x repeats) accepted without ``force``.
MAX_RUNS = 5000
#: A task whose worker dies this many times is recorded as failed.
ALLOWED_FAILURES = 3
#: Version of the record layout; part of every run's hash.
STORE_FORMAT = 1
#: Result columns of the table after the axis and bookkeeping columns, in order.
RESULT_COLUMNS = (
    "stages", "dv_over_v", "fidelity_requested", "fidelity",
    "mean_dn", "noise_dn",
    "snr_output_db", "snr_single_db", "snr_gain_db", "snr_predicted_gain_db",
    "snr_eq28_gain_db",
    "mtf_frequency_cyc_per_px", "m_dv_over_v", "mtf_measured", "mtf_measured_ctf",
    "mtf_model_yuan2013", "mtf_model_footprint",
    "seconds", "cpu_seconds", "task_seconds", "lines_per_s",
)
#: Columns that measure time and so differ from run to run.
TIMING_COLUMNS = ("seconds", "cpu_seconds", "task_seconds", "lines_per_s")
_STRING_COLUMNS = ("fidelity_requested", "fidelity", "status", "error", "hash")
_BOOK_COLUMNS = ("point", "repeat", "seed", "hash", "status", "error")
_FILE_KEYS = ("scene", "name", "repeats", "set", "axes", "zip")
_MAX_AXIS = 100_000
_RANGE_KEYS = frozenset({"start", "stop", "num", "step", "log"})
#: Scene keys that hold a list in the scene itself (its own sweep); promoted to axes.
_SCENE_LISTS = ("tdi.stages", "motion.dv_over_v")


# --------------------------------------------------------------------------------------
# the sweep file
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Axis:
    """One swept scene key: ``key`` (``"tdi.stages"``), its ``values``, and whether it moves
    with the other keys of the zip group (``zipped``)."""

    key: str
    values: tuple
    zipped: bool = False


@dataclass(frozen=True)
class Run:
    """One task: point ``point`` (index into :attr:`Sweep.points`), repeat ``repeat``, its
    validated scene (seed set), ``seed`` and the store ``hash``."""

    point: int
    repeat: int
    scene: object
    seed: int
    hash: str


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: axes, points (dicts key -> value) and runs (point-major)."""

    path: Path
    name: str
    scene_path: Path
    repeats: int
    axes: tuple[Axis, ...]
    zipped: tuple[Axis, ...]
    points: tuple[dict, ...]
    runs: tuple[Run, ...]
    impact: bool
    promoted: tuple[str, ...]

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


def _flatten(table, where, prefix=""):
    """``{"tdi": {"stages": [..]}}`` and ``{"tdi.stages": [..]}`` -> ``{"tdi.stages": [..]}``."""
    out = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and not (v and set(v) <= _RANGE_KEYS):
            if not v:
                raise TdicamError(f"{where} {key}: empty table")
            out.update(_flatten(v, where, key + "."))
        else:
            out[key] = v
    return out


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
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    if n > _MAX_AXIS:
        raise TdicamError(f"{label}: range gives {n} values, more than {_MAX_AXIS}")
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
        c = _canon(v)
        if c in seen:
            raise TdicamError(f"{label}: value {v!r} is listed twice")
        seen.add(c)
    return Axis(key, tuple(values), zipped)


def _set_key(data, key, value):
    parts = key.split(".")
    node = data
    for p in parts[:-1]:
        nxt = node.get(p)
        if not isinstance(nxt, dict):
            nxt = {}
            node[p] = nxt
        node = nxt
    node[parts[-1]] = value


def _get_key(data, key):
    node = data
    for p in key.split("."):
        if not isinstance(node, dict) or p not in node:
            return None
        node = node[p]
    return node


def _deepcopy(data):
    return json.loads(json.dumps(data))


def _read_toml(path, what):
    p = Path(path)
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise TdicamError(f"{what} not found: {str(p)!r}") from None
    except IsADirectoryError:
        raise TdicamError(f"{what} is a directory: {str(p)!r}") from None
    except OSError as exc:
        raise TdicamError(f"cannot read {what} {str(p)!r}: {exc.strerror}") from None
    except tomllib.TOMLDecodeError as exc:
        raise TdicamError(f"{p}: invalid TOML: {exc}") from None


def _show_point(point):
    return ", ".join(f"{k} = {json.dumps(v)}" for k, v in point.items())


def load_sweep(path, *, force=False, impact=False) -> Sweep:
    """Read, expand and validate a sweep file (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The sweep TOML file.
    force : bool
        Accept more than :data:`MAX_RUNS` runs.
    impact : bool
        Measure each effect's impact in every run (part of each run's hash).

    Returns
    -------
    Sweep

    Raises
    ------
    TdicamError
        One line naming the file and the key: an unknown file key, an axis key the scene
        does not have, an empty axis, a zip group of unequal lengths, a value the scene
        loader rejects (its message, with the point), too many runs without ``force``.
    """
    from tdicam.scene import load_scene, scene_from_dict
    path = Path(path)
    doc = _read_toml(path, "sweep file")
    src = str(path)
    for k in doc:
        if k not in _FILE_KEYS:
            close = difflib.get_close_matches(k, _FILE_KEYS, n=1, cutoff=0.6)
            raise TdicamError(f"{src}: {k}: unknown key"
                              + (f"; did you mean {close[0]!r}?" if close
                                 else "; valid: " + ", ".join(_FILE_KEYS)))
    if "scene" not in doc or not isinstance(doc["scene"], str):
        raise TdicamError(f"{src}: scene: missing (the base scene file, relative to the "
                          f"sweep file)")
    scene_path = (path.resolve().parent / doc["scene"]).resolve()
    load_scene(scene_path)                       # the base scene's own errors first
    base = _read_toml(scene_path, "scene file")
    name = doc.get("name", path.stem)
    if not isinstance(name, str) or not name:
        raise TdicamError(f"{src}: name: must be a non-empty string, got {name!r}")
    repeats = doc.get("repeats", 1)
    if isinstance(repeats, bool) or not isinstance(repeats, int):
        raise TdicamError(f"{src}: repeats: must be an integer >= 1, got {repeats!r}")
    check_range(f"{src}: repeats", repeats, 1, None)
    tables = {}
    for t in ("set", "axes", "zip"):
        v = doc.get(t, {})
        if not isinstance(v, dict):
            raise TdicamError(f"{src}: {t}: must be a table of scene keys, got {v!r}")
        tables[t] = _flatten(v, f"{src}: [{t}]")
    for key, value in tables["set"].items():
        if "." not in key:
            raise TdicamError(f"{src}: [set] {key}: keys are section.key paths of the scene")
        _set_key(base, key, value)
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
        v = _get_key(base, key)
        if isinstance(v, list) and key not in swept:
            axes.append(_axis(key, v, f"{scene_path}: {key}"))
            promoted.append(key)
    n_points = math.prod(len(a.values) for a in axes) * (len(zipped[0].values) if zipped
                                                         else 1)
    n_runs = n_points * repeats
    if n_runs > MAX_RUNS and not force:
        sizes = " x ".join([f"{a.key} ({len(a.values)})" for a in axes]
                           + ([f"zip ({len(zipped[0].values)})"] if zipped else [])
                           + [f"repeats ({repeats})"])
        raise TdicamError(f"{src}: {sizes} = {n_runs} runs, over the limit of {MAX_RUNS}; "
                          f"reduce the axes or pass --force")
    combos = [()]
    for a in axes:
        combos = [c + ((a.key, v),) for c in combos for v in a.values]
    if zipped:
        combos = [c + tuple((z.key, z.values[i]) for z in zipped)
                  for c in combos for i in range(len(zipped[0].values))]
    points, runs, base_dir = [], [], scene_path.parent
    for index, combo in enumerate(combos):
        point = dict(combo)
        data = _deepcopy(base)
        for key, value in combo:
            _set_key(data, key, value)
        try:
            scene = scene_from_dict(data, base_dir=base_dir, source=str(scene_path))
        except TdicamError as exc:
            raise TdicamError(f"{src}: point {_show_point(point)}: {exc}") from None
        for key in _SCENE_LISTS:
            section, k = key.split(".")
            if len(getattr(getattr(scene, section), k)) != 1:
                raise TdicamError(f"{src}: point {_show_point(point)}: {key} must be one "
                                  f"value per point, got a list")
        key = _scene_key(scene)
        for r in range(repeats):
            seed = int.from_bytes(hashlib.sha256(
                _canon({"scene": key, "repeat": r}).encode()).digest()[:8], "big") >> 1
            sc = dataclasses.replace(scene, run=dataclasses.replace(scene.run, seed=seed))
            h = _sha({"format": STORE_FORMAT, "tdicam": __version__, "impact": bool(impact),
                      "scene": {**key, "run": {**key["run"], "seed": seed}}})
            runs.append(Run(index, r, sc, seed, h))
        points.append(point)
    return Sweep(path=path, name=name, scene_path=scene_path, repeats=repeats,
                 axes=tuple(axes), zipped=tuple(zipped), points=tuple(points),
                 runs=tuple(runs), impact=bool(impact), promoted=tuple(promoted))


# --------------------------------------------------------------------------------------
# one run (executed on a worker)
# --------------------------------------------------------------------------------------


def _one_line(exc) -> str:
    if isinstance(exc, TdicamError):
        return str(exc)
    text = " ".join(str(exc).split()) or "(no message)"
    return f"{type(exc).__name__}: {text}"


def _finite(v):
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def run_one(scene, impact=False) -> dict:
    """Simulate and measure one validated scene; never raises for an error of the run.

    Returns
    -------
    dict
        ``status`` (``ok`` or ``failed``), ``error`` (one line or None), ``row`` (the
        :data:`RESULT_COLUMNS` values), and the report parts: ``effects``, ``notes``,
        ``measurements``, ``speed``, ``worker``.
    """
    from tdicam import engine
    from tdicam.measure import measure
    t0 = time.perf_counter()
    worker = f"{socket.gethostname()}:{os.getpid()}"
    try:
        res = engine.simulate(scene, impact=impact)
        meas = measure(scene, res)
        out = np.asarray(res.output, np.float64)
        mean = float(out.mean()) - float(res.pedestal_output)
        noise = float(out.std()) if scene.target.kind == "flat" else None
    except Exception as exc:      # noqa: BLE001 - a failing run is recorded, the sweep goes on
        return {"status": "failed", "error": _one_line(exc), "row": None, "worker": worker,
                "task_seconds": time.perf_counter() - t0}
    snr, mtf = meas.get("snr", {}), meas.get("mtf", {})
    row = {
        "stages": int(res.stages), "dv_over_v": float(res.dv_over_v),
        "fidelity_requested": scene.run.fidelity, "fidelity": res.fidelity,
        "mean_dn": _finite(mean), "noise_dn": _finite(noise),
        "snr_output_db": _finite(snr.get("output_db")),
        "snr_single_db": _finite(snr.get("single_db")),
        "snr_gain_db": _finite(snr.get("gain_db")),
        "snr_predicted_gain_db": _finite(snr.get("predicted_db")),
        "snr_eq28_gain_db": _finite(snr.get("eq28_db")),
        "mtf_frequency_cyc_per_px": _finite(mtf.get("frequency_cyc_per_px")),
        "m_dv_over_v": float(res.stages * res.dv_over_v),
        "mtf_measured": _finite(mtf.get("measured")),
        "mtf_measured_ctf": _finite(mtf.get("measured_ctf")),
        "mtf_model_yuan2013": _finite(mtf.get("seed001_model")),
        "mtf_model_footprint": _finite(mtf.get("footprint_model")),
        "seconds": float(res.seconds), "cpu_seconds": float(res.cpu_seconds),
        "task_seconds": time.perf_counter() - t0, "lines_per_s": _finite(res.lines_per_s),
    }
    return {"status": "ok", "error": None, "row": row, "worker": worker,
            "effects": [e.to_dict() for e in res.effects], "notes": list(res.notes),
            "measurements": json.loads(json.dumps(meas, default=_jsonable)),
            "speed": {"seconds": float(res.seconds), "cpu_seconds": float(res.cpu_seconds),
                      "lines_per_s": _finite(res.lines_per_s),
                      "exposure_pixels_per_s": _finite(res.exposure_pixels_per_s)}}


def _jsonable(o):
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    return str(o)


def _run_task(scene, impact):
    """Dask task body: :func:`run_one` (module-level so workers import it by name)."""
    return run_one(scene, impact)


# --------------------------------------------------------------------------------------
# the store
# --------------------------------------------------------------------------------------


def _record_path(store: Path, h: str) -> Path:
    return store / f"{h}.json"


def _read_record(store: Path, h: str):
    """The finished record of run ``h`` or None (absent, unreadable or not this run's)."""
    try:
        rec = json.loads(_record_path(store, h).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict) or rec.get("hash") != h or "status" not in rec:
        return None
    return rec


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.parent / f".tmp-{path.name}-{os.getpid()}-{os.urandom(4).hex()}"
    try:
        with open(tmp, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _store_record(store: Path, sweep: Sweep, run: Run, result: dict) -> dict:
    point = sweep.points[run.point]
    rec = {"format": STORE_FORMAT, "tdicam": __version__, "hash": run.hash,
           "sweep": str(sweep.path), "axes": point, "repeat": run.repeat, "seed": run.seed,
           "scene_settings": _scene_key(run.scene), "impact": sweep.impact, **result}
    _write_atomic(_record_path(store, run.hash),
                  json.dumps(rec, indent=1, default=_jsonable, allow_nan=False))
    return rec


# --------------------------------------------------------------------------------------
# execution
# --------------------------------------------------------------------------------------


@dataclass
class SweepResult:
    """What :func:`run_sweep` did: counts, failed runs, output files, timing."""

    sweep: Sweep
    out_dir: Path
    total: int
    computed: int
    reused: int
    failed: list
    missing: int
    files: list
    wall_seconds: float
    where: str

    def summary(self) -> str:
        """The lines ``tdicam sweep`` prints."""
        sw = self.sweep
        axes = ", ".join(f"{a.key} ({len(a.values)})" for a in sw.axes)
        if sw.zipped:
            axes += (", zip " + "+".join(z.key for z in sw.zipped)
                     + f" ({len(sw.zipped[0].values)})")
        rate = (f", {self.computed / self.wall_seconds:.2f} runs/s" if self.computed and
                self.wall_seconds > 0 else "")
        lines = [f"sweep {sw.name}: {len(sw.points)} points x {sw.repeats} repeats = "
                 f"{self.total} runs over {axes or 'no axes'}",
                 f"computed {self.computed}, reused {self.reused} from {self.out_dir}/points, "
                 f"failed {len(self.failed)}, missing {self.missing}; {self.where}, "
                 f"{self.wall_seconds:.1f} s{rate}"]
        if sw.promoted:
            lines.append("axes taken from the scene's own lists: " + ", ".join(sw.promoted))
        for f in self.failed[:20]:
            lines.append(f"  failed: point {f['point']} ({_show_point(f['axes'])}) repeat "
                         f"{f['repeat']}: {f['error']}")
        if len(self.failed) > 20:
            lines.append(f"  ... and {len(self.failed) - 20} more failed runs "
                         f"(summary.json lists them all)")
        if self.missing:
            lines.append(f"stopped early: {self.missing} runs not computed; run the same "
                         f"command again to finish (finished runs are reused)")
        lines.append(f"wrote {self.out_dir}/: " + ", ".join(self.files))
        return "\n".join(lines)


def _progress(total, initial, desc, enabled):
    if not enabled or not sys.stderr.isatty() or os.environ.get("CI"):
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, initial=initial, desc=desc, unit="run", leave=True)


def _local_cluster(workers):
    import logging

    from dask.distributed import LocalCluster
    n = check_range("--workers", workers, 1, 256) if workers is not None \
        else max(1, os.cpu_count() or 1)
    return LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                        dashboard_address=None, silence_logs=logging.ERROR,
                        env={"TDICAM_THREADS": "1"}), f"local Dask cluster of {n} workers"


def _connect(scheduler, timeout):
    from dask.distributed import Client
    try:
        return Client(scheduler, timeout=timeout)
    except Exception as exc:  # noqa: BLE001 - every failure to connect is one user error
        raise TdicamError(f"--scheduler {scheduler}: cannot connect within {timeout:g} s "
                          f"({_one_line(exc)})") from None


def _execute_dask(todo, sweep, client, on_done):
    """Submit every run in ``todo`` and pass each result to ``on_done`` as it finishes."""
    from dask.distributed import as_completed
    futures = {}
    for run in todo:
        if run.hash in futures:
            continue
        fut = client.submit(_run_task, run.scene, sweep.impact, key=f"tdicam-run-{run.hash}",
                            pure=False, retries=0)
        futures[fut.key] = (fut, run)
    pending = as_completed([f for f, _ in futures.values()], loop=client.loop)
    try:
        for fut in pending:
            _, run = futures[fut.key]
            try:
                result = fut.result()
            except Exception as exc:  # noqa: BLE001 - KilledWorker and the like
                result = {"status": "failed", "error": _one_line(exc), "row": None,
                          "worker": None}
            fut.release()
            if not on_done(run, result):
                break
    finally:
        for fut, _ in futures.values():
            if not fut.done():
                fut.cancel()


def run_sweep(sweep: Sweep, out_dir, *, workers=None, scheduler=None, serial=False,
              limit=None, progress=True, connect_timeout=10.0, on_run=None) -> SweepResult:
    """Run the missing runs of ``sweep`` and write the results into ``out_dir``.

    Parameters
    ----------
    sweep : Sweep
        From :func:`load_sweep`.
    out_dir : str or Path
        Results directory; ``out_dir/points`` is the store (see the module docstring).
    workers : int, optional
        Processes of the local Dask cluster (default: the CPU count).
    scheduler : str, optional
        Address of a running ``dask scheduler`` to use instead of a local cluster.
    serial : bool
        Run every task in this process, in order (debugging).
    limit : int, optional
        Stop after computing this many runs (the rest stay missing for a rerun).
    progress : bool
        Show a progress bar (on a terminal, not with ``CI`` set).
    connect_timeout : float
        Seconds to wait for ``scheduler``.
    on_run : callable(run, record) -> None, optional
        Called after each computed run is stored (a test hook).

    Returns
    -------
    SweepResult

    Raises
    ------
    TdicamError
        ``out_dir`` cannot be created, or the scheduler cannot be reached.
    """
    t0 = time.perf_counter()
    out_dir = Path(out_dir)
    store = out_dir / "points"
    try:
        store.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise TdicamError(f"-o {str(out_dir)!r}: cannot create the directory: "
                          f"{exc.strerror}") from None
    done = {}
    for run in sweep.runs:
        if run.hash not in done:
            rec = _read_record(store, run.hash)
            if rec is not None and rec["status"] == "ok":
                done[run.hash] = rec
    reused = sum(1 for r in sweep.runs if r.hash in done)
    todo = [r for r in sweep.runs if r.hash not in done]
    if limit is not None:
        check_range("--limit", limit, 0, None)
    computed = 0
    bar = _progress(len(sweep.runs), reused, sweep.name, progress)

    def on_done(run, result):
        nonlocal computed
        done[run.hash] = _store_record(store, sweep, run, result)
        computed += 1
        if bar is not None:
            bar.update(sum(1 for r in sweep.runs if r.hash == run.hash))
        if on_run is not None:
            on_run(run, done[run.hash])
        return limit is None or computed < limit

    where = "serial"
    try:
        if todo and (limit is None or limit > 0):
            if serial:
                seen = set()
                for run in todo:
                    if run.hash in seen:
                        continue
                    seen.add(run.hash)
                    if not on_done(run, run_one(run.scene, sweep.impact)):
                        break
            else:
                _run_on_dask(todo, sweep, on_done, workers, scheduler, connect_timeout)
                where = (f"Dask scheduler {scheduler}" if scheduler else
                         f"local Dask cluster of {workers or os.cpu_count() or 1} workers")
        elif not serial:
            where = "nothing to compute"
    finally:
        if bar is not None:
            bar.close()
    files = write_results(sweep, out_dir, done)
    failed = [{"point": r.point, "repeat": r.repeat, "hash": r.hash,
               "axes": sweep.points[r.point], "error": done[r.hash]["error"]}
              for r in sweep.runs if r.hash in done and done[r.hash]["status"] != "ok"]
    missing = sum(1 for r in sweep.runs if r.hash not in done)
    result = SweepResult(sweep, out_dir, len(sweep.runs), computed, reused, failed, missing,
                         files, time.perf_counter() - t0, where)
    summary = {"name": sweep.name, "sweep": str(sweep.path), "scene": str(sweep.scene_path),
               "axes": {a.key: list(a.values) for a in sweep.axes},
               "zip": {z.key: list(z.values) for z in sweep.zipped},
               "repeats": sweep.repeats, "runs": result.total, "computed": computed,
               "reused": reused, "failed": failed, "missing": missing, "where": where,
               "wall_seconds": result.wall_seconds, "files": files,
               "tdicam": __version__}
    _write_atomic(out_dir / "summary.json", json.dumps(summary, indent=1, default=_jsonable))
    result.files = files + ["summary.json"]
    return result


def _run_on_dask(todo, sweep, on_done, workers, scheduler, connect_timeout):
    import dask
    from dask.distributed import Client
    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES - 1}):
        if scheduler:
            client, cluster = _connect(scheduler, connect_timeout), None
        else:
            cluster, _ = _local_cluster(workers)
            client = Client(cluster)
        try:
            _execute_dask(todo, sweep, client, on_done)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


# --------------------------------------------------------------------------------------
# results: table, dataset, plots
# --------------------------------------------------------------------------------------


def _rows(sweep: Sweep, done: dict) -> list[dict]:
    rows = []
    for run in sweep.runs:
        rec = done.get(run.hash)
        row = {k: _coord_value(v) for k, v in sweep.points[run.point].items()}
        row.update({"point": run.point, "repeat": run.repeat, "seed": run.seed,
                    "hash": run.hash, "status": "missing" if rec is None else rec["status"],
                    "error": None if rec is None else rec.get("error")})
        vals = (rec or {}).get("row") or {}
        for c in RESULT_COLUMNS:
            row[c] = vals.get(c)
        rows.append(row)
    return rows


def _coord_value(v):
    return json.dumps(v) if isinstance(v, (list, dict)) else v


def table(sweep: Sweep, done: dict):
    """The tidy :class:`pandas.DataFrame` of ``sweep`` from the records in ``done``."""
    import pandas as pd
    df = pd.DataFrame(_rows(sweep, done), columns=list(sweep.keys) + list(_BOOK_COLUMNS)
                      + list(RESULT_COLUMNS))
    for c in RESULT_COLUMNS:
        if c in _STRING_COLUMNS:
            df[c] = df[c].astype(object)
        elif c == "stages":
            df[c] = df[c].astype("Int64")
        else:
            df[c] = pd.to_numeric(df[c], errors="coerce").astype("float64")
    df["seed"] = df["seed"].astype("int64")
    return df


def dataset(sweep: Sweep, df):
    """The labelled N-D :class:`xarray.Dataset` of the table ``df``."""
    import xarray as xr
    dims = [a.key for a in sweep.axes] + (["zip"] if sweep.zipped else []) + ["repeat"]
    shape = sweep.shape
    coords = {a.key: _coord_array(a.values) for a in sweep.axes}
    if sweep.zipped:
        for z in sweep.zipped:
            coords[z.key] = ("zip", _coord_array(z.values))
        coords["zip"] = np.arange(len(sweep.zipped[0].values))
    coords["repeat"] = np.arange(sweep.repeats)
    data = {}
    for c in ("seed",) + _BOOK_COLUMNS[3:] + RESULT_COLUMNS:
        col = df[c]
        if c in _STRING_COLUMNS:
            arr = np.array(["" if v is None or v != v else str(v) for v in col], dtype=object)
        elif c == "seed":
            arr = col.to_numpy(np.int64)
        else:
            arr = col.astype("float64").to_numpy(np.float64, na_value=np.nan)
        data[c] = (dims, arr.reshape(shape))
    ds = xr.Dataset(data, coords=coords,
                    attrs={"title": f"tdicam sweep {sweep.name}", "tdicam": __version__,
                           "sweep": str(sweep.path), "scene": str(sweep.scene_path)})
    return ds


def _coord_array(values):
    if any(isinstance(v, (list, dict)) for v in values):
        return np.array([json.dumps(v) for v in values], dtype=object)
    if all(isinstance(v, bool) for v in values):
        return np.array([int(v) for v in values], dtype=np.int8)
    if all(isinstance(v, str) for v in values):
        return np.array(values, dtype=object)
    return np.asarray(values)


def read_table(out_dir):
    """The tidy table a sweep wrote into ``out_dir`` (from ``results.parquet``)."""
    import pandas as pd
    return pd.read_parquet(Path(out_dir) / "results.parquet")


def write_results(sweep: Sweep, out_dir: Path, done: dict) -> list[str]:
    """Write table, dataset and plots atomically; return the file names written."""
    df = table(sweep, done)
    files = []

    def atomic(name, writer):
        final = out_dir / name
        tmp = out_dir / f".tmp-{name}-{os.getpid()}"
        try:
            writer(tmp)
            os.replace(tmp, final)
        finally:
            tmp.unlink(missing_ok=True)
        files.append(name)

    atomic("results.parquet", lambda p: df.to_parquet(p, index=False))
    atomic("results.csv", lambda p: df.to_csv(p, index=False))
    ds = dataset(sweep, df)
    atomic("sweep.nc", lambda p: ds.to_netcdf(p, engine="h5netcdf"))
    from tdicam import sweepplots
    for name, fig in sweepplots.figures(sweep, df):
        atomic(name, lambda p, fig=fig: sweepplots.save(fig, p))
    return files
