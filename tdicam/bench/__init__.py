"""Benchmarks: what accuracy costs in time (``tdicam bench``, the scripts in ``bench/``).

:mod:`~tdicam.bench.suite` measures every block at every level (golden numpy, Amaranth
simulator, Icarus and Verilator per beat and fast, the exported testbench) and the scene
engine's fidelities; :mod:`~tdicam.bench.chain` times a scene's whole pipeline top;
:mod:`~tdicam.bench.plot` draws the figure; :mod:`~tdicam.bench.util` holds the shared helpers.

Layer: a service. May import the export, run, planning, chain, engine, scene, simulation and
hardware tools and everything below them; nothing imports it but the commands.
"""
