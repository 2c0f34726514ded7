"""The documentation site builds with warnings as errors, and documents the whole public API.

``sphinx-build -W -b html docs DIR`` (one process; the notebook is rendered from its stored
outputs, not executed: ``tests/test_notebook.py`` runs it): a broken cross-reference, a
page outside every toctree, a docstring numpydoc cannot parse or a Markdown error fails the
suite. Every name in ``tdicam.__all__`` must have a docstring and an entry in the API
reference (``api.html``, read from the site's ``objects.inv``).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import tdicam

DOCS = Path(__file__).resolve().parents[1] / "docs"

pytest.importorskip("sphinx", reason="pip install -e '.[docs]'")
pytest.importorskip("myst_nb", reason="pip install -e '.[docs]'")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built into a temporary folder; fails with sphinx's warnings."""
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-j", "1", "-b", "html",
         "-d", str(out / ".doctrees"), str(DOCS), str(out / "html")],
        capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"sphinx-build -W failed:\n{proc.stderr}{proc.stdout}"
    return out / "html"


def _inventory(html: Path) -> dict:
    """``{object name: page}`` of the Python objects the site documents."""
    from sphinx.util.inventory import InventoryFile
    with open(html / "objects.inv", "rb") as fh:
        inv = InventoryFile.load(fh, "", lambda base, uri: uri)
    out = {}
    for role, items in inv.items():
        if role.startswith("py:"):
            for name, item in items.items():
                uri = item.uri if hasattr(item, "uri") else item[2]
                out[name] = uri.split("#")[0]
    return out


def test_site_builds_without_warnings(site):
    for page in ("index", "getting-started", "guide/index", "guide/blocks", "guide/run",
                 "guide/sweeps", "scene-format", "api", "references",
                 "examples/orbit_camera"):
        assert (site / f"{page}.html").is_file(), page


def test_notebook_page_shows_its_stored_outputs(site):
    """The site renders the notebook from the outputs stored in it (nothing is executed):
    a notebook committed without them would show code only."""
    text = (site / "examples" / "orbit_camera.html").read_text()
    assert text.count("<img") >= 5
    assert "0 mismatches" in text


def test_every_public_name_is_documented_in_the_api_reference(site):
    documented = _inventory(site)
    missing = [n for n in tdicam.__all__ if documented.get(f"tdicam.{n}") != "api.html"
               and documented.get(n) != "api.html"]
    assert not missing, f"public names without an entry in docs/api.md: {missing}"
    bare = [n for n in tdicam.__all__ if not (getattr(tdicam, n).__doc__ or "").strip()]
    assert not bare, f"public names without a docstring: {bare}"


def test_block_page_lists_every_block(site):
    from tdicam import blocks
    text = (site / "guide" / "blocks.html").read_text()
    for name in blocks.names():
        assert f'id="block-{name.replace("_", "-")}"' in text, name


def test_api_page_follows_all(monkeypatch):
    """The API page is generated from ``tdicam.__all__``: a new public name appears there
    with no edit of the page (here: a function added to ``__all__``)."""
    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        import tdicam_docs
    finally:
        sys.path.remove(str(DOCS / "_ext"))

    def extra():
        """A public function."""
    extra.__module__ = "tdicam"
    monkeypatch.setattr(tdicam, "extra", extra, raising=False)
    monkeypatch.setattr(tdicam, "__all__", [*tdicam.__all__, "extra"])
    text = tdicam_docs.api_markdown()
    assert ".. autofunction:: tdicam.extra" in text
    assert "   extra\n" in text


def _docs_ext():
    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        import tdicam_docs
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    return tdicam_docs


def test_generated_regions_are_current():
    """The Markdown pages hold their generated parts (blocks, scenes, effects, API) as plain
    Markdown that reads without Sphinx; a change in the code that they do not follow fails
    here (the fix: ``python docs/_ext/tdicam_docs.py``)."""
    stale = _docs_ext().update(check=True)
    assert not stale, f"stale generated docs {stale}: run python docs/_ext/tdicam_docs.py"


def test_api_page_reads_without_sphinx():
    """docs/api.md itself (not only the site) documents every public name and the Scene and
    Simulation methods with their signatures and docstrings."""
    text = (DOCS / "api.md").read_text()
    for n in tdicam.__all__:
        obj = getattr(tdicam, n)
        head = f"## `tdicam.{n}`" if n == "blocks" else f"## `{n}"
        assert head in text, n
    for member in ("Scene.load(", "Scene.replace(changes", "Scene.with_run(", "Simulation.figures(",
                   "Simulation.save(", "Plan.figures("):
        assert f"### `{member}" in text, member
    assert "```{" not in text.split("<!-- generated tdicam-api")[1], "a bare directive"
