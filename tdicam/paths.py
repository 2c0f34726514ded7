"""Where the repository's folders are (the package runs from a checkout).

Layer: a leaf; imports nothing of tdicam.
"""

from pathlib import Path

__all__ = ["REPO", "SCENES", "GOLDEN"]

#: The repository root (``tdicam/``'s parent).
REPO = Path(__file__).resolve().parent.parent
#: Bundled scene files.
SCENES = REPO / "scenes"
#: Golden vectors.
GOLDEN = REPO / "golden"
