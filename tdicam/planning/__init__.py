"""The planning service behind ``tdicam plan``: size a digital-TDI camera and say whether it
works.

:mod:`~tdicam.planning.sizing` computes the plan (line and frame rate, window, memory, DDR
bandwidth, gateware rate, SNR, MTF) and its feasibility; :mod:`~tdicam.planning.predict`
what the planning model predicts a run measures (MTF, SNR gain), shared with ``tdicam run``;
:mod:`~tdicam.planning.report` its text and figures.

Layer: a service below :mod:`tdicam.run`. May import :mod:`tdicam.chain`, the engine, the
scene reader and everything below them.
"""
