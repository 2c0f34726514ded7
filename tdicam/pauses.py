"""The one idle/backpressure pattern of every stream driver.

Every stream driver — the Amaranth simulator (:mod:`tdicam.streamsim`,
:mod:`tdicam.cosim.pysim`), cocotb per-beat mode (:mod:`tdicam.cosim.tb.stream_tb`) and the
HDL engine of fast mode (:mod:`tdicam.cosim.tbgen`) — draws its stalls from :class:`Pauses`:
two xorshift32 generators stepped once per clock cycle, so the same seed and probabilities
give the same idle/backpressure pattern in all three.

Cycle ``c`` (0 = the first cycle after the initial reset) uses the generators' ``c``-th
states ``v_c``, ``r_c``:

* ``v_0 = seed | 1`` (seed as a 32-bit value), ``r_0 = v_0 ^ 0x9e3779b9``,
  ``x_{c+1} = xorshift32(x_c)`` (shifts 13, 17, 5);
* the source *offers* a beat on cycle ``c`` when ``v_c & 0xff >= idle_thr``; once offered,
  ``valid`` stays high until the beat is taken (AXI4-Stream rule), whatever the draws;
* the sink is *ready* on cycle ``c`` when ``r_c & 0xff >= bp_thr``;
* ``idle_thr = round(idle * 256)``, ``bp_thr = round(backpressure * 256)``.
"""

from .errors import check_range

__all__ = ["Pauses", "thresholds", "xorshift32", "XOR_R"]

#: ``r_0 = v_0 ^ XOR_R``
XOR_R = 0x9E3779B9


def xorshift32(s):
    """One step of the 32-bit xorshift generator (shifts 13, 17, 5)."""
    s ^= (s << 13) & 0xFFFFFFFF
    s ^= s >> 17
    s ^= (s << 5) & 0xFFFFFFFF
    return s


def thresholds(idle, backpressure):
    """``(idle_thr, bp_thr)`` in 1/256 of the probabilities, checked to be in [0, 1)."""
    for name, p in (("idle", idle), ("backpressure", backpressure)):
        check_range(name, p, 0, 1, integer=False, hi_open=True)
    return round(idle * 256), round(backpressure * 256)


class Pauses:
    """Per-cycle offer/ready draws of one stream run (see the module docstring).

    Call :meth:`offer` and :meth:`ready` for the current cycle, then :meth:`step` once per
    clock cycle (reset cycles included, the initial reset excluded).
    """

    def __init__(self, seed=1, idle=0.0, backpressure=0.0):
        self.idle_thr, self.bp_thr = thresholds(idle, backpressure)
        self.v = (int(seed) | 1) & 0xFFFFFFFF
        self.r = self.v ^ XOR_R

    def offer(self):
        """The source may raise ``valid`` this cycle."""
        return (self.v & 0xFF) >= self.idle_thr

    def ready(self):
        """The sink is ready this cycle."""
        return (self.r & 0xFF) >= self.bp_thr

    def step(self):
        """Advance to the next cycle."""
        self.v = xorshift32(self.v)
        self.r = xorshift32(self.r)
