"""docs/scene-format.md is generated from the scene reader and up to date with it."""

from pathlib import Path

import pytest

from tdicam.scene import docs, reading

PAGE = Path(__file__).resolve().parents[1] / "docs" / "scene-format.md"


def test_page_is_up_to_date():
    assert PAGE.read_text() == docs.render(), (
        "docs/scene-format.md is stale: python -m tdicam.scene.docs docs/scene-format.md")


def test_every_key_the_reader_accepts_is_documented_with_its_range():
    allowed, info = docs.schema()
    assert set(allowed) == set(docs.SECTIONS)
    text = PAGE.read_text()
    for section, keys in allowed.items():
        assert f"## [{section}]" in text
        for key in keys:
            if f"{section}.{key}" not in allowed:
                assert f"| `{key}` |" in text
    # ranges and defaults come from the reader, not from a copy
    assert "| `bits` | integer | bit | 12 | 1..24 |" in text
    assert "| `dv_over_v` | number or list of them | fraction | 0 | (-1, 1) |" in text


def test_schema_probe_leaves_the_reader_untouched():
    before = {n: getattr(reading.Section, n) for n in ("number", "integer", "raw")}
    docs.schema()
    assert {n: getattr(reading.Section, n) for n in before} == before


def test_an_undocumented_key_is_refused(monkeypatch):
    keys = {s: dict(k) for s, k in docs.KEYS.items()}
    del keys["sensor"]["prnu"]
    monkeypatch.setattr(docs, "KEYS", keys)
    with pytest.raises(ValueError, match=r"\[sensor\].*prnu"):
        docs.render()


def test_a_computed_default_needs_a_written_rule(monkeypatch):
    keys = {s: dict(k) for s, k in docs.KEYS.items()}
    keys["tdi"]["output_bits"] = docs.KeyDoc("bit", "output width")
    monkeypatch.setattr(docs, "KEYS", keys)
    with pytest.raises(ValueError, match=r"\[tdi\]\.output_bits: the default depends"):
        docs.render()
