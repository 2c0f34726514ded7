"""Trade-study sweeps (``tdicam sweep``): a scene over axes of scene keys, on Dask.

:mod:`~tdicam.sweeps.file` reads and validates a sweep file and its points,
:mod:`~tdicam.sweeps.runner` runs them (resumable), :mod:`~tdicam.sweeps.results` keeps the
finished runs and makes the tidy table and labelled dataset, :mod:`~tdicam.sweeps.plots`
draws them.

Layer: a service. May import :mod:`tdicam.run` (one run is a scene simulation and its
measurements) and everything below it; nothing imports it but the commands.
"""
