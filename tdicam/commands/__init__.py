"""CLI subcommands: one module each, discovered by :mod:`tdicam.cli` (``register(subparsers)``)."""
