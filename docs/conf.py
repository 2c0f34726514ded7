"""Sphinx configuration of the tdicam documentation.

Build: ``pip install -e '.[docs]'`` then ``sphinx-build -W -b html docs build/docs``
(``tests/test_docs.py`` runs the same build with warnings as errors). Markdown pages are read
by myst-parser (through myst-nb, which also renders ``examples/*.ipynb`` from their stored
outputs: the notebook is executed by ``tests/test_notebook.py``, not by the build);
docstrings are numpydoc. ``_ext/tdicam_docs.py`` adds the directives that generate pages
from the code: the block table (:mod:`tdicam.blocks`) and the API summary (``tdicam.__all__``).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import tdicam  # noqa: E402

project = "tdicam"
author = "the tdicam authors"
copyright = "2026, the tdicam authors"
release = tdicam.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "myst_nb",              # Markdown (myst-parser) and notebooks
    "tdicam_docs",
]

source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints", "examples/out"]

# Markdown: heading anchors so the pages can link to each other's sections
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# Notebooks: rendered from the outputs stored in the file; tests/test_notebook.py runs them
nb_execution_mode = "off"

# API reference
autodoc_member_order = "bysource"
autodoc_typehints = "none"             # numpydoc's Parameters sections carry the types
autosummary_generate = False           # the API page documents every name itself
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

html_theme = "furo"
html_title = f"tdicam {release}"
html_static_path: list[str] = []
