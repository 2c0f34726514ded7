"""The tdicam version: the one place it is written (``pyproject.toml`` reads it from here, so
the package metadata, ``tdicam --version``, ``tdicam.__version__`` and the headers of the
generated Verilog always agree).

Layer: a leaf; imports nothing.
"""

__all__ = ["__version__"]

__version__ = "0.1.0"
