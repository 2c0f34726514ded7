"""Small gateware helpers shared by the components of :mod:`tdicam.hdl`.

* :func:`is_zero`, :func:`equals` — ``x == 0`` written as a NOR (yosys prints a
  multi-bit ``x == 0`` as ``!x``, which Verilator ``-Wall`` flags).
* :func:`saturating_increment` — a counter that stops at its all-ones value (the error
  counters of the stream blocks).
* :func:`mux_select` — ``options[index]`` as a chain of 2-way muxes.
* :data:`NO_RW_CHECK`, :data:`NO_INIT` — memory attributes the Verilog writer
  (:mod:`tdicam.hw.verilog`) acts on (see there).
* :func:`quiet_reject` — constructor decorator: a component whose parameters were refused
  is never elaborated, so Amaranth must not warn about an unused elaboratable.
"""

import functools

from amaranth.hdl import Array, Mux

from tdicam.errors import TdicamError

__all__ = ["is_zero", "equals", "saturating_increment", "mux_select", "quiet_reject",
           "NO_RW_CHECK", "NO_INIT"]

#: Memory attribute: no read of an address in the cycle it is written (yosys' own name).
NO_RW_CHECK = "no_rw_check"
#: Memory attribute: no word is read before it is written (no initial contents emitted).
NO_INIT = "tdicam.no_init"


def is_zero(value):
    """``value == 0`` as ``~value.any()`` (lint-clean in the generated Verilog)."""
    return ~value.any()


def equals(value, const):
    """``value == const``, through :func:`is_zero` when ``const`` is 0."""
    return is_zero(value) if const == 0 else value == const


def pick(values, sel):
    """``values[sel]`` through a mux whose case statement covers every value of ``sel``'s
    bits (the last value repeated): a complete case, lint-clean in the generated Verilog."""
    n = 1 << (len(values) - 1).bit_length()
    return Array(list(values) + [values[-1]] * (n - len(values)))[sel]


def saturating_increment(m, counter):
    """Add 1 to ``counter`` in ``m.d.sync`` unless it holds its all-ones value.

    Call it inside the ``m.If`` of the event being counted."""
    with m.If(counter != (1 << len(counter)) - 1):
        m.d.sync += counter.eq(counter + 1)


def mux_select(options, index):
    """``options[index]`` as a mux chain (a variable shift would be 2**n words wide);
    ``options[0]`` for an ``index`` past the end."""
    v = options[0]
    for k in range(1, len(options)):
        v = Mux(index == k, options[k], v)
    return v


def quiet_reject(init):
    """Decorate a component's ``__init__``: when it raises :class:`TdicamError` the half-built
    component is marked so that Amaranth does not warn that it was never elaborated."""
    @functools.wraps(init)
    def wrapper(self, *args, **kwargs):
        try:
            init(self, *args, **kwargs)
        except TdicamError:
            self._MustUse__silence = True
            raise
    return wrapper
