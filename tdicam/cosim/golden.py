"""Golden-vector store: ``golden/<block>/<case>.npz`` and ``golden/manifest.json``.

Each case file is a deflate-compressed ``.npz`` written deterministically (fixed zip timestamps, sorted members) holding the case's input and
expected-output arrays with their exact dtypes, plus ``__params__`` (the block parameters
as JSON). The manifest records, per case, the file, block, parameters, generator, seed,
model version and, per array, dtype, shape and ``sha256(dtype.str | shape | bytes)``.

:func:`check` regenerates every case from the golden models and compares arrays whole
(dtype, shape, values), naming the case and the first differing index; a missing, corrupt
or tampered file is reported in one line naming the file.
"""

import fcntl
import hashlib
import io
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tdicam import blocks as _blocks
from tdicam.errors import TdicamError
from tdicam.files import check_dir, check_file, read_bytes, write_file
from tdicam.paths import GOLDEN

__all__ = ["golden_dir", "array_sha256", "generate", "regen", "check", "load", "case_names",
           "case_shapes", "write_npz", "PARAMS_KEY"]

MANIFEST = "manifest.json"
#: Largest golden file read (the bundled ones are a few KiB).
MAX_GOLDEN_BYTES = 256 << 20
PARAMS_KEY = "__params__"


def golden_dir():
    return GOLDEN


def array_sha256(a):
    a = np.require(a, requirements="C")
    h = hashlib.sha256(f"{a.dtype.str}|{list(a.shape)}|".encode())
    h.update(a.tobytes())
    return h.hexdigest()


def write_npz(path, arrays):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name in sorted(arrays):
            info = zipfile.ZipInfo(name + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            member = io.BytesIO()
            np.lib.format.write_array(member, np.require(arrays[name], requirements="C"),
                                      allow_pickle=False)
            zf.writestr(info, member.getvalue(), compresslevel=9)
    data = buf.getvalue()
    check_dir(path.parent, "golden")
    check_file(path, "golden")
    if not path.exists() or path.read_bytes() != data:
        write_file(path, data)


def _read_npz(path):
    rel = _rel(path)
    if not path.exists():
        raise TdicamError(f"{rel}: golden file is missing (run 'tdicam golden regen')")
    data = read_bytes(path, "golden file", MAX_GOLDEN_BYTES)
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except Exception as exc:  # zipfile, numpy format and OS errors all mean "corrupt"
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if "pickle" in msg:             # numpy's advice to load it unsafely: never given
            msg = "not a .npz file"
        raise TdicamError(f"{rel}: golden file is corrupt ({msg})") from None


def _rel(path):
    """``path`` as ``golden/<block>/<case>.npz`` (relative to the golden folder's parent:
    the checkout or the installed package), else as given."""
    try:
        return str(Path(path).resolve().relative_to(GOLDEN.resolve().parent))
    except ValueError:
        return str(path)


def _read_manifest():
    path = golden_dir() / MANIFEST
    if not path.exists():
        return {"format": 1, "cases": {}}
    try:
        man = json.loads(path.read_text())
        _check_manifest(man)
        return man
    except (ValueError, OSError) as exc:
        raise TdicamError(f"{_rel(path)}: manifest is corrupt ({exc})") from None


def _check_manifest(man):
    """Raise ValueError naming the first thing in ``man`` that is not a manifest's layout
    (a JSON list, a case that is not a table, an array record without its sha256, ...)."""
    if not isinstance(man, dict):
        kind = {list: "a list", str: "a string", bool: "a boolean", int: "a number",
                float: "a number"}.get(type(man), "null")
        raise ValueError(f"{kind}, not a table")
    if not isinstance(man.get("cases"), dict):
        raise ValueError("no 'cases' table")
    for key, entry in man["cases"].items():
        if not isinstance(entry, dict) or not isinstance(entry.get("arrays"), dict):
            raise ValueError(f"case {key!r} has no 'arrays' table")
        if "model_version" not in entry:
            raise ValueError(f"case {key!r} has no 'model_version'")
        for name, rec in entry["arrays"].items():
            if not isinstance(rec, dict) or not isinstance(rec.get("sha256"), str):
                raise ValueError(f"case {key!r}: array {name!r} has no sha256")


def _write_manifest(man):
    man["cases"] = dict(sorted(man["cases"].items()))
    write_file(golden_dir() / MANIFEST, json.dumps(man, indent=1, sort_keys=True) + "\n")


def case_names(block):
    return [c.name for c in _blocks.get(block).cases()]


def case_shapes(block, case):
    """``{array: shape}`` of a stored case as the manifest records it (nothing is read but
    the manifest; the parameters' entry left out)."""
    name = _blocks.get(block).name if isinstance(block, str) else block.name
    man = _read_manifest()
    key = f"{name}/{case}"
    if key not in man["cases"]:
        raise TdicamError(f"{_rel(golden_dir() / name / f'{case}.npz')}: case is not in "
                          f"golden/manifest.json (run 'tdicam golden regen {name}')")
    return {k: tuple(a["shape"]) for k, a in man["cases"][key]["arrays"].items()
            if k != PARAMS_KEY}


def _find_case(block, name):
    for c in block.cases():
        if c.name == name:
            return c
    raise TdicamError(f"block {block.name} has no golden case {name!r}; valid: "
                      f"{', '.join(c.name for c in block.cases())}")


def generate(block, case):
    """Arrays of ``case`` computed from the models (inputs, expected outputs, params)."""
    if isinstance(block, str):
        block = _blocks.get(block)
    if isinstance(case, str):
        case = _find_case(block, case)
    params = block.resolve(case.params)
    arrays = dict(case.make(params, np.random.default_rng(case.seed)))
    arrays[PARAMS_KEY] = np.array(json.dumps(block.recorded(params), sort_keys=True))
    return arrays


def _entry(block, case, arrays):
    return {
        "file": f"{block.name}/{case.name}.npz",
        "block": block.name,
        "case": case.name,
        "params": block.recorded(block.resolve(case.params)),
        "generator": f"tdicam.blocks.{block.name}:{case.name}",
        "seed": case.seed,
        "tags": list(case.tags),
        "model_version": block.model_version,
        "arrays": {k: {"dtype": v.dtype.str, "shape": list(v.shape), "sha256": array_sha256(v)}
                   for k, v in sorted(arrays.items())},
    }


def _selected(names):
    return [_blocks.get(n) for n in names] if names else _blocks.all_blocks()


def regen(names=None):
    """Regenerate the golden files of the named blocks (all when empty); returns case count."""
    check_dir(golden_dir(), "golden")
    with open(golden_dir() / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return _regen(names)


def _check_outputs(blocks):
    """Every path a regen writes, checked before any case is generated (one error line: a
    case file that is a folder, a block folder that is a file, a stale ``.npz`` that is not
    a file)."""
    check_file(golden_dir() / MANIFEST, "golden")
    for block in blocks:
        folder = golden_dir() / block.name
        if not folder.exists():
            continue                    # made by write_npz
        check_dir(folder, "golden")
        for stale in folder.glob("*.npz"):
            check_file(stale, "golden")
        for case in block.cases():
            check_file(folder / f"{case.name}.npz", "golden")


def _regen(names):
    man = _read_manifest()
    count = 0
    _check_outputs(_selected(names))
    for block in _selected(names):
        keep = set()
        for case in block.cases():
            arrays = generate(block, case)
            write_npz(golden_dir() / block.name / f"{case.name}.npz", arrays)
            man["cases"][f"{block.name}/{case.name}"] = _entry(block, case, arrays)
            keep.add(case.name)
            count += 1
        for stale in (golden_dir() / block.name).glob("*.npz"):
            if stale.stem not in keep:
                stale.unlink()
        for key in [k for k in man["cases"] if k.split("/")[0] == block.name]:
            if key.split("/", 1)[1] not in keep:
                del man["cases"][key]
    _write_manifest(man)
    return count


def load(block, case):
    """Arrays of a stored case, verified against the manifest; params decoded to a dict
    (parameters the case does not record at their default filled in:
    :meth:`~tdicam.blocks.Block.with_defaults`)."""
    block = _blocks.get(block) if isinstance(block, str) else block
    name = block.name
    man = _read_manifest()
    key = f"{name}/{case}"
    path = golden_dir() / name / f"{case}.npz"
    if key not in man["cases"]:
        raise TdicamError(f"{_rel(path)}: case is not in golden/manifest.json "
                          f"(run 'tdicam golden regen {name}')")
    arrays = _read_npz(path)
    _verify(path, arrays, man["cases"][key]["arrays"])
    params = json.loads(str(arrays.pop(PARAMS_KEY)))
    return arrays, block.with_defaults(params)


def _verify(path, arrays, recorded):
    rel = _rel(path)
    if set(arrays) != set(recorded):
        raise TdicamError(f"{rel}: arrays {sorted(arrays)} differ from the manifest's "
                          f"{sorted(recorded)}")
    for k, rec in recorded.items():
        if array_sha256(arrays[k]) != rec["sha256"]:
            raise TdicamError(f"{rel}: array {k!r} does not match its manifest sha256 "
                              f"(file changed or corrupt)")


def first_difference(a, b):
    """None when equal (dtype, shape, values), else a short description."""
    if a.dtype != b.dtype:
        return f"dtype {a.dtype} != {b.dtype}"
    if a.shape != b.shape:
        return f"shape {a.shape} != {b.shape}"
    diff = np.argwhere(a != b)
    if len(diff) == 0:
        return None
    idx = tuple(int(i) for i in diff[0])
    return f"first difference at index {idx}: stored {a[idx]!r}, model {b[idx]!r} " \
           f"({len(diff)} elements differ)"


@dataclass
class CheckResult:
    key: str
    ok: bool
    message: str


def check(names=None):
    """Regenerate every case of the named blocks and compare with the store."""
    man = _read_manifest()
    results = []
    for block in _selected(names):
        for case in block.cases():
            key = f"{block.name}/{case.name}"
            path = golden_dir() / block.name / f"{case.name}.npz"
            try:
                if key not in man["cases"]:
                    raise TdicamError(f"{_rel(path)}: case is not in golden/manifest.json")
                stored = _read_npz(path)
                _verify(path, stored, man["cases"][key]["arrays"])
                fresh = generate(block, case)
                if set(stored) != set(fresh):
                    raise TdicamError(f"{key}: stored arrays {sorted(stored)} != model's "
                                      f"{sorted(fresh)}")
                for k in sorted(fresh):
                    d = first_difference(stored[k], fresh[k])
                    if d is not None:
                        raise TdicamError(f"{key}: array {k!r}: {d}")
                if man["cases"][key]["model_version"] != block.model_version:
                    raise TdicamError(f"{key}: stored with model version "
                                      f"{man['cases'][key]['model_version']}, the model is "
                                      f"{block.model_version}")
                results.append(CheckResult(key, True, "ok"))
            except TdicamError as exc:
                results.append(CheckResult(key, False, str(exc)))
    known = {f"{b.name}/{c.name}" for b in _selected(names) for c in b.cases()}
    for b in _selected(names):
        for key in man["cases"]:
            if key.split("/")[0] == b.name and key not in known:
                results.append(CheckResult(key, False, f"{key}: in the manifest but no longer "
                                                       f"defined by the block"))
    return results
