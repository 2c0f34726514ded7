"""Long work shows where it is: a progress bar on a terminal, stage lines otherwise.

:class:`Progress` is what ``tdicam run``, ``bench``, ``demo`` and ``sweep`` report their
progress through. On a terminal (stderr a TTY, ``CI`` unset) it draws a tqdm bar whose
description names the current stage; elsewhere (a log, a pipe, CI) it writes one line per
stage to stderr, ``NAME: [k/n] STAGE (T s)``, with an estimate of the time left once a step
has finished. ``Progress(..., enabled=False)`` says nothing (the Python API's default).

Layer: a leaf (imports only the standard library and, on a terminal, tqdm).
"""

from __future__ import annotations

import os
import sys
import time

__all__ = ["Progress", "on_terminal"]


def on_terminal(stream=None) -> bool:
    """Whether ``stream`` (default stderr) is a terminal a bar can be drawn on (and ``CI``
    unset)."""
    stream = sys.stderr if stream is None else stream
    try:
        tty = stream is not None and stream.isatty()
    except (AttributeError, ValueError):
        tty = False
    return tty and not os.environ.get("CI")


class Progress:
    """Progress of one piece of long work.

    Parameters
    ----------
    name : str
        What is running (the bar's and every stage line's prefix).
    total : float
        Units of work in all (steps, pixels); 0 when unknown.
    unit : str
        The units' name on the bar (``"px"``, ``"run"``).
    enabled : bool
        False: say nothing at all.
    bar : bool or None
        Draw a bar (True), write stage lines (False); default: a bar on a terminal.

    ``stage(text)`` names what runs now; ``update(n)`` adds ``n`` units done; ``close()``
    ends (also as a context manager). Stage lines count the stages (``[k/n]`` when
    ``stages`` is given) and, once some work is done, estimate the time left from the
    units done so far; with ``stages`` and no ``total`` the bar counts the stages.
    """

    def __init__(self, name: str, total: float = 0, *, unit: str = "step",
                 enabled: bool = True, bar: bool | None = None, stages: int | None = None):
        self.name, self.total, self.unit, self.stages = name, float(total), unit, stages
        self.done, self.count = 0.0, 0
        self.t0 = time.perf_counter()
        self._bar = None
        self._by_stage = not self.total and bool(stages)   # no units: the bar counts stages
        self.mode = None if not enabled else ("bar" if (on_terminal() if bar is None else bar)
                                              else "lines")
        if self.mode == "bar":
            try:
                from tqdm import tqdm
            except ImportError:             # no tqdm: stage lines instead
                self.mode = "lines"
            else:
                self._bar = tqdm(total=stages if self._by_stage else (self.total or None),
                                 desc=name, unit="stage" if self._by_stage else unit,
                                 unit_scale=not self._by_stage, leave=False, mininterval=0.2)

    def eta(self, now: float | None = None) -> float | None:
        """Seconds left at ``now`` (default: the clock), from the rate so far (None before
        any work is done or with no total)."""
        if not self.total or self.done <= 0:
            return None
        now = time.perf_counter() if now is None else now
        rate = self.done / max(now - self.t0, 1e-9)
        return max(self.total - self.done, 0.0) / rate

    def stage(self, text: str) -> None:
        """Name the stage that runs now."""
        self.count += 1
        if self.mode == "bar":
            if self._by_stage and self.count > 1:
                self._bar.update(1)
            self._bar.set_description_str(f"{self.name}: {text}", refresh=True)
        elif self.mode == "lines":
            k = f"[{self.count}/{self.stages}] " if self.stages else ""
            now = time.perf_counter()
            left = self.eta(now)
            est = f", about {left:.0f} s left" if left is not None else ""
            print(f"{self.name}: {k}{text} ({now - self.t0:.0f} s{est})",
                  file=sys.stderr, flush=True)

    def update(self, n: float) -> None:
        """``n`` more units done."""
        self.done += n
        if self._bar is not None:
            self._bar.update(n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
