"""Registry of gateware blocks: what ``tdicam verilog|golden|sim|bench`` know about.

Every module in this package defines ``BLOCK = Block(...)`` (or ``BLOCKS = [...]``) and is
discovered automatically. A :class:`Block` ties together, under one name, the Amaranth
component (``hdl/<name>.py``), the golden model (``model/<name>.py``), the golden cases
(``golden/<name>/``) and the co-simulation (``cocotb_tests/test_<name>.py``).
"""

import importlib
import pkgutil
from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import TdicamError

__all__ = ["Param", "Case", "Block", "get", "names", "all_blocks"]


@dataclass(frozen=True)
class Param:
    """One elaboration parameter of a block.

    ``lo``/``hi`` bound integers (inclusive); ``choices`` lists the valid values instead;
    ``default = None`` means optional (the block derives it).
    """

    name: str
    default: Any
    help: str
    lo: int | None = None
    hi: int | None = None
    choices: tuple | None = None
    type: type = int

    def describe(self):
        if self.choices is not None:
            rng = "{" + ", ".join(str(c) for c in self.choices) + "}"
        elif self.lo is not None or self.hi is not None:
            rng = f"{self.lo if self.lo is not None else ''}..{self.hi if self.hi is not None else ''}"
        else:
            rng = self.type.__name__
        dflt = "derived" if self.default is None else self.default
        return f"--{self.name.replace('_', '-')} ({rng}, default {dflt}): {self.help}"

    def check(self, value):
        if value is None and self.default is None:
            return None
        if self.type is int:
            if isinstance(value, bool) or not isinstance(value, int):
                try:
                    value = int(str(value), 0)
                except ValueError:
                    raise TdicamError(f"--{self.name.replace('_', '-')} must be an integer, "
                                      f"got {value!r}") from None
        elif self.type is bool:
            if isinstance(value, str):
                if value.lower() not in ("0", "1", "true", "false", "yes", "no"):
                    raise TdicamError(f"--{self.name.replace('_', '-')} must be true or false, "
                                      f"got {value!r}")
                value = value.lower() in ("1", "true", "yes")
            value = bool(value)
        else:
            value = self.type(value)
        if self.choices is not None and value not in self.choices:
            raise TdicamError(f"--{self.name.replace('_', '-')} = {value} is not valid; "
                              f"valid: {', '.join(str(c) for c in self.choices)}")
        if (self.lo is not None and value < self.lo) or (self.hi is not None and value > self.hi):
            raise TdicamError(f"--{self.name.replace('_', '-')} = {value} is out of range; "
                              f"valid: {self.lo}..{self.hi}")
        return value


@dataclass(frozen=True)
class Case:
    """A golden case: parameters + a deterministic generator of its arrays.

    ``make(params, rng)`` returns a dict of named numpy arrays: the inputs and the expected
    outputs computed by the golden model. ``tags`` mark what a case exercises
    (e.g. ``"reset"``, ``"fullscale"``) and ``"fast-only"`` for cases too long for per-beat.
    """

    name: str
    params: dict
    make: Callable
    seed: int = 1
    tags: tuple = ()


@dataclass(frozen=True)
class Block:
    """A registered gateware block.

    Attributes
    ----------
    name : str
        One name everywhere: ``hdl/<name>.py``, ``model/<name>.py``, ``golden/<name>/``.
    top : callable(**params) -> wiring.Component
        The Verilog top (AXI4-Stream names) for stream blocks, or a plain-port component.
    cases : callable() -> list[Case]
    to_beats : callable(arrays, params) -> (stimulus Beats, expected Beats) or None
        For stream blocks: the stream co-simulation stimulus and expected output of a case.
    check : callable(params) or None
        Cross-parameter checks, raising :class:`TdicamError` before elaboration.
    model_version : str
        Bump when the golden model's definition changes (recorded in the manifest).
    """

    name: str
    summary: str
    params: tuple
    top: Callable
    cases: Callable
    to_beats: Callable | None = None
    check: Callable | None = None
    model_version: str = "1"
    elem_bits: Callable | None = None
    extra: dict = field(default_factory=dict)

    def resolve(self, given=None):
        """Full, checked parameter dict from ``given`` (unknown names are errors)."""
        given = dict(given or {})
        known = {p.name: p for p in self.params}
        for key in given:
            if key not in known:
                valid = ", ".join("--" + k.replace("_", "-") for k in known) or "none"
                raise TdicamError(f"block {self.name} has no parameter "
                                  f"--{key.replace('_', '-')}; valid: {valid}")
        out = {}
        for p in self.params:
            out[p.name] = p.check(given[p.name]) if p.name in given else p.default
        if self.check is not None:
            self.check(out)
        return out

    def build(self, params=None):
        """Elaborable Verilog top for checked ``params``."""
        return self.top(**self.resolve(params))


_REGISTRY = None


def _load():
    global _REGISTRY
    if _REGISTRY is None:
        reg = {}
        for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
            if info.name.startswith("_"):
                continue
            mod = importlib.import_module(f"{__name__}.{info.name}")
            for blk in getattr(mod, "BLOCKS", [getattr(mod, "BLOCK", None)]):
                if blk is not None:
                    reg[blk.name] = blk
        _REGISTRY = reg
    return _REGISTRY


def names():
    return sorted(_load())


def all_blocks():
    return [_load()[n] for n in names()]


def get(name):
    reg = _load()
    if name not in reg:
        raise TdicamError(f"unknown block {name!r}; valid: {', '.join(sorted(reg))}")
    return reg[name]
