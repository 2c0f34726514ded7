"""The ``tdicam run`` service: a scene in; the camera's images, figures and report out.

:mod:`~tdicam.run.runner` runs the scene engine (and, with ``[run.rtl]``, the whole-scene
co-simulation) and writes the outputs; :mod:`~tdicam.run.measure` measures image quality
next to the planning model's predictions; :mod:`~tdicam.run.report` writes report.md and
the summary.

Layer: a service. May import :mod:`tdicam.planning`, :mod:`tdicam.chain`, the engine, the scene
reader and everything below them; imported by the sweeps, the benchmarks and the commands.
"""
