"""Benchmark input sizes the block entries share (items per level kind, see
:class:`tdicam.blocks.StreamWork`): frames of pixels, code words, TDI frames."""

#: Frames of a per-pixel block.
PX = {"pysim": 1, "beat": 3, "fast": 64, "icarus fast": 16}
PX_QUICK = {"pysim": 1, "beat": 1, "fast": 4}
#: 64/72-bit words.
WORDS = {"pysim": 4000, "beat": 12000, "fast": 300_000, "icarus fast": 60_000}
WORDS_QUICK = {"pysim": 1000, "beat": 2000, "fast": 20_000}
#: TDI frames (output from frame ``stages`` on).
TDI = {"pysim": 6, "beat": 12, "fast": 300, "icarus fast": 60}
TDI_QUICK = {"pysim": 5, "beat": 5, "fast": 20}
