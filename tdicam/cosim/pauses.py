"""The one idle/backpressure pattern of every stream driver.

Every stream driver — the Amaranth simulator (:mod:`tdicam.cosim.streamsim`,
:mod:`tdicam.cosim.pysim`), cocotb per-beat mode (:mod:`tdicam.simtb.stream_tb`) and the
HDL engine of fast mode (:mod:`tdicam.cosim.tbgen`) — draws its stalls from :class:`Pauses`:
two xorshift32 generators stepped once per clock cycle, so the same seed and probabilities
give the same idle/backpressure pattern in all three.

Cycle ``c`` (0 = the first cycle after the initial reset) uses the generators' ``c``-th
states ``v_c``, ``r_c``:

* ``v_0 = seed & 0x7fffffff`` (``0x80000000`` when that is 0), ``r_0 = v_0 ^ 0x9e3779b9``,
  ``x_{c+1} = xorshift32(x_c)`` (shifts 13, 17, 5). Every seed 1..:data:`SEED_MAX` is its
  own starting state (an earlier ``| 1`` gave seeds ``2k`` and ``2k + 1`` one pattern); no
  state is 0, xorshift32's fixed point (``v_0 < 2**31`` or ``2**31``, never ``0x9e3779b9``);
* the source *offers* a beat on cycle ``c`` when ``v_c & 0xff >= idle_thr``; once offered,
  ``valid`` stays high until the beat is taken (AXI4-Stream rule), whatever the draws;
* the sink is *ready* on cycle ``c`` when ``r_c & 0xff >= bp_thr``;
* ``idle_thr = round(idle * 256)``, ``bp_thr = round(backpressure * 256)``.
"""

from tdicam.errors import check_range
from tdicam.model.dram import xorshift32

__all__ = ["Pauses", "PatternPauses", "thresholds", "xorshift32", "XOR_R", "ZERO_SEED_STATE", "start_state",
           "check_seed", "SEED_MAX"]

#: Largest seed the generators take (31 bits); the commands' --seed is 1..SEED_MAX.
SEED_MAX = 0x7FFFFFFF


def check_seed(option, seed):
    """``seed`` if it is an integer in 1..:data:`SEED_MAX`, else a one-line error (the
    generators keep 31 bits: a wider or negative seed would be folded silently)."""
    return check_range(option, seed, 1, SEED_MAX)

#: ``r_0 = v_0 ^ XOR_R``
XOR_R = 0x9E3779B9
#: ``v_0`` of seed 0 (or any multiple of 2**31), which no accepted seed reaches.
ZERO_SEED_STATE = 0x80000000


def start_state(seed):
    """``v_0`` of ``seed`` (module docstring): ``seed & 0x7fffffff``, or
    :data:`ZERO_SEED_STATE` when that is 0; one-to-one on 0..:data:`SEED_MAX`."""
    return (int(seed) & SEED_MAX) or ZERO_SEED_STATE


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
        self.v = start_state(seed)
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


class PatternPauses:
    """:class:`Pauses` whose sink ``ready`` follows ``pattern`` (booleans, one a cycle,
    repeated) instead of its draws; the source's offers are ``base``'s. For stall bursts
    longer than random draws give (the Amaranth simulator only: the Verilog engines draw
    from :class:`Pauses`)."""

    def __init__(self, base, pattern):
        self.base, self.pattern, self.cycle = base, [bool(x) for x in pattern], 0

    def offer(self):
        return self.base.offer()

    def ready(self):
        return self.pattern[self.cycle % len(self.pattern)]

    def step(self):
        self.base.step()
        self.cycle += 1


class StreamDriver:
    """The one stream source and sink: what a testbench drives on each cycle of a run.

    The Python twin of the fast-mode HDL engine (:mod:`tdicam.cosim.tbgen`), driving per-beat
    cocotb runs and the Amaranth simulator. Each cycle: :meth:`drive` gives ``(rst, valid,
    ready)`` for the DUT's reset, the input ``valid`` (beat :attr:`idx` on the data lines)
    and the output ``ready``; after the clock edge's handshakes are known, :meth:`settle`
    ends the cycle.

    * stalls from :class:`Pauses` (stepped every cycle); ``valid`` stays high until the beat
      is taken;
    * a reset asked for before beat ``k`` (``rst_before[k]``) holds ``rst`` for
      ``rst_cycles`` cycles from the cycle beat ``k`` would be presented, with ``valid`` and
      ``ready`` low; :attr:`seg` counts the resets so far;
    * :attr:`finished` once every beat was taken and no output moved for ``drain`` cycles,
      or after ``max_cycles``.
    """

    def __init__(self, rst_before, *, seed=1, idle=0.0, backpressure=0.0, rst_cycles=3,
                 drain=2000, max_cycles=None):
        self.rst_before = [bool(x) for x in rst_before]
        self.n_in = len(self.rst_before)
        self.pauses = Pauses(seed, idle, backpressure)
        self.rst_cycles, self.drain = rst_cycles, drain
        self.max_cycles = max_cycles
        self.idx = self.seg = self.cycle = self.quiet = self.rst_left = 0
        self.served = self.held = self.finished = self.timeout = False
        self.rst = self.valid = self.ready = False
        #: set to keep ``valid`` low (e.g. to measure a latency); the draws go on
        self.hold_source = False

    def drive(self):
        """``(rst, valid, ready)`` of the current cycle."""
        if (self.rst_left == 0 and self.idx < self.n_in and self.rst_before[self.idx]
                and not self.served):
            self.rst_left, self.served, self.held = self.rst_cycles, True, False
            self.seg += 1
        if self.rst_left:
            self.rst, self.valid, self.ready = True, False, False
        else:
            self.rst = False
            self.valid = (self.idx < self.n_in and not self.hold_source
                          and (self.held or self.pauses.offer()))
            self.ready = self.pauses.ready()
        return self.rst, self.valid, self.ready

    def settle(self, in_ready, out_valid):
        """End the cycle given the DUT's input ``ready`` and output ``valid``; returns
        ``(input beat taken, output beat taken)``."""
        took = self.valid and bool(in_ready)
        fired = self.ready and bool(out_valid)
        self.timeout = self.max_cycles is not None and self.cycle >= self.max_cycles
        self.finished = self.quiet >= self.drain or self.timeout
        self.quiet = 0 if fired else self.quiet + (self.idx >= self.n_in)
        if self.rst_left:
            self.rst_left -= 1
        if took:
            self.idx += 1
            self.served = False
        self.held = self.valid and not took
        self.pauses.step()
        self.cycle += 1
        return took, fired
