"""The golden-vector store: determinism, checks, and one-line errors on damage."""

import shutil

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cli import main
from tdicam.errors import TdicamError


@pytest.fixture
def store(tmp_path, monkeypatch):
    """A private copy of the golden store."""
    dst = tmp_path / "golden"
    shutil.copytree(golden.golden_dir(), dst)
    monkeypatch.setattr(golden, "golden_dir", lambda: dst)
    return dst


def test_check_passes_on_repo():
    results = golden.check()
    assert results and all(r.ok for r in results), [r.message for r in results if not r.ok]


def test_generation_is_deterministic():
    a = golden.generate("cds", "random_12b")
    b = golden.generate("cds", "random_12b")
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].dtype == b[k].dtype and np.array_equal(a[k], b[k])


def test_regen_is_byte_identical(store):
    before = {p.name: p.read_bytes() for p in (store / "cds").glob("*.npz")}
    man = (store / "manifest.json").read_bytes()
    golden.regen(["cds"])
    assert {p.name: p.read_bytes() for p in (store / "cds").glob("*.npz")} == before
    assert (store / "manifest.json").read_bytes() == man


def test_one_changed_byte_fails_check(store, capsys):
    path = store / "cds" / "random_12b.npz"
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))
    assert main(["golden", "check", "cds"]) == 1
    out = capsys.readouterr().out
    line = [l for l in out.splitlines() if "random_12b" in l][0]
    assert line.startswith("FAIL cds/random_12b: golden/cds/random_12b.npz") or \
        "random_12b.npz" in line
    assert "Traceback" not in out


def test_tampered_array_is_named(store):
    arrays, params = golden.load("cds", "random_12b")
    arrays["out"] = arrays["out"].copy()
    arrays["out"][0, 1, 2] ^= 1
    params = blocks.get("cds").recorded(params)     # as stored: no ppc at its default
    arrays[golden.PARAMS_KEY] = np.array(__import__("json").dumps(params, sort_keys=True))
    golden.write_npz(store / "cds" / "random_12b.npz", arrays)
    with pytest.raises(TdicamError, match=r"random_12b.npz: array 'out' does not match"):
        golden.load("cds", "random_12b")


def test_model_drift_names_case_and_index(store, monkeypatch):
    from tdicam.blocks import cds
    real = cds.cds

    def drifted(s, r, pixel_bits):
        out = real(s, r, pixel_bits=pixel_bits)
        out.flat[5] ^= 1
        return out
    monkeypatch.setattr(cds, "cds", drifted)
    bad = [r for r in golden.check(["cds"]) if not r.ok]
    assert bad
    assert "array 'out': first difference at index" in bad[0].message
    assert bad[0].key in bad[0].message


def test_missing_file(store):
    (store / "cds" / "hard_12b.npz").unlink()
    with pytest.raises(TdicamError, match="hard_12b.npz: golden file is missing"):
        golden.load("cds", "hard_12b")


def test_truncated_file(store):
    p = store / "cds" / "hard_12b.npz"
    p.write_bytes(p.read_bytes()[:100])
    with pytest.raises(TdicamError, match="hard_12b.npz: golden file is corrupt"):
        golden.load("cds", "hard_12b")


def test_corrupt_manifest(store, capsys):
    (store / "manifest.json").write_text("{not json")
    assert main(["golden", "check"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tdicam: error: golden/manifest.json: manifest is corrupt") or \
        "manifest is corrupt" in err
    assert len(err.strip().splitlines()) == 1


def test_endless_file_is_not_a_golden_file(store, monkeypatch):
    """A case file that is a device giving endless bytes is read up to the limit and
    refused in one line (it was a MemoryError)."""
    p = store / "cds" / "hard_12b.npz"
    p.unlink()
    p.symlink_to("/dev/zero")
    monkeypatch.setattr(golden, "MAX_GOLDEN_BYTES", 1 << 20)
    with pytest.raises(TdicamError, match="hard_12b.npz: not a golden file: it goes on past "
                                          "1 MiB"):
        golden.load("cds", "hard_12b")
