"""Scene files: the schema every ``[section]`` and key follows, the reader, and its docs.

:mod:`~tdicam.scene.loader` reads a TOML scene into a validated, immutable
:class:`~tdicam.scene.loader.Scene` (every key checked against its range, named as the user
wrote it); :mod:`~tdicam.scene.docs` generates ``docs/scene-format.md`` from it.

Layer: below the engine and the camera. May import the blocks' registry, the models and the
leaves; never the simulators, the services or the commands.
"""
