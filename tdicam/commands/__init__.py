"""CLI subcommands: one module each, discovered by :mod:`tdicam.cli` (``register(subparsers)``).

Layer: the top. A command parses its arguments and calls a service; it holds no work of its
own.
"""
