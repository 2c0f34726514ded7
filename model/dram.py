"""The memory controller behind the DDR buffers' MIG-style user interface: its cycle model,
the DRAM timing it charges and the steady-state window every DDR efficiency is measured over
(Ning et al. 2019 §4.2; the interface, addresses and words are :mod:`tdicam.model.ddr`'s).

:class:`MigSim` is the cycle-stepped Python model of the controller (the HDL model is
:class:`tdicam.hdl.simmodels.mig_model.MigModel`; both draw their stalls from the same xorshift32 sequence,
so their ready patterns are identical cycle for cycle): in-order reads with a latency drawn
from ``[lat_lo, lat_hi]`` cycles, a refresh window of ``refresh_cycles`` at the start of
every ``refresh_period`` cycles after the first (the refresh timer starts at reset) with
``app_rdy`` low, random drops of ``app_rdy`` and
``app_wdf_rdy`` (probability ``drop / 256`` each, independent), write data that must be
accepted before its write command (MIG allows data first), capacity and alignment checks.
An address outside the memory or not word aligned raises :class:`TdicamError` naming it.

With ``dram=`` :class:`DramTiming` :class:`MigSim` also charges what the order of accesses
costs on DDR3, as LiteDRAM's controller spends it (read off its command timeline): the
queue drain when a port moves to another bank, read/write turnarounds, opening a row in a
bank (row-bank-column mapping, 8 banks of :data:`ROW_WORDS`-word rows; precharge and
write recovery when another row is open) and a 44-cycle refresh (:data:`DRAM_STALLS`).
It is within +/-3 points of LiteDRAM on every pattern of :data:`PATTERNS` and on every DDR
block's recorded command order (:mod:`tdicam.cosim.litedram` replays the same traces into
LiteDRAM; tests/test_ddrref.py holds the recorded figures); the HDL model with the same
``dram`` is cycle-equal (:func:`tdicam.cosim.litedram.replay_hdl`) and charges it by default in
co-simulation.
:func:`pattern_efficiency` gives a named pattern's efficiency for the planner.
"""

from collections import deque
from dataclasses import dataclass

import numpy as np

from tdicam.errors import TdicamError, check_range
from tdicam.model.ddr import ADDR_BITS, ADDR_PER_WORD, CAPACITY_BYTES

__all__ = ["has_stalls", "slowdown", "ROW_WORDS", "BANKS", "DEFAULT_STALLS", "xorshift32", "worst_stall",
           "stall_pattern", "MigSim", "DramTiming", "DRAM_STALLS", "TREFI", "STARTUP",
           "WINDOW_REFRESHES", "window_cycles", "window_efficiency", "window_words"]

#: DRAM geometry behind the UI (two MT41K256M16, BL8, row-bank-column mapping): 256-bit
#: words per row (1024 columns / 8) and banks
ROW_WORDS = 128
BANKS = 8

#: Default stall pattern of the memory model: read latency 20..60 cycles, a 44-cycle refresh
#: every 780 cycles (tREFI 7.8 us) at 100 MHz — what LiteDRAM's DDR3 controller spends per
#: refresh (precharge all, tRP, tRFC 350 ns, rows opened again), as in :data:`DRAM_STALLS` —
#: each ready dropped with probability 16/256 per cycle.
DEFAULT_STALLS = {"lat_lo": 20, "lat_hi": 60, "refresh_period": 780, "refresh_cycles": 44,
                  "drop": 16, "seed": 1}


def xorshift32(s):
    """One step of the xorshift32 generator shared by :class:`MigSim` and the HDL model."""
    s ^= (s << 13) & 0xFFFFFFFF
    s ^= s >> 17
    s ^= (s << 5) & 0xFFFFFFFF
    return s


def _check_stalls(lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed):
    check_range("lat_lo", lat_lo, 2, 1000)
    check_range("lat_hi", lat_hi, lat_lo, 1000)
    check_range("refresh_period", refresh_period, 1, 1 << 20)
    check_range("refresh_cycles", refresh_cycles, 0, refresh_period - 1)
    check_range("drop", drop, 0, 255)
    check_range("seed", seed, 1, 0xFFFFFFFF)


def worst_stall(params):
    """Processing clocks the simulation MIG model can keep a DDR user waiting at once
    (:class:`tdicam.hdl.simmodels.mig_model.MigModel`, parameters ``params`` as a DDR
    block's stall parameters): a read issued as a refresh begins waits ``refresh_cycles``
    for the command and ``lat_hi`` for its data, ``refresh_cycles + lat_hi`` (104 with
    :data:`DEFAULT_STALLS`). A DDR block at the head of a chain (cds_ddr reads each signal
    frame's first reset line when the frame is presented) holds the stream that long."""
    p = {**DEFAULT_STALLS, **{k: v for k, v in params.items() if k in DEFAULT_STALLS}}
    return int(p["refresh_cycles"]) + int(p["lat_hi"])


def has_stalls(params):
    """``params`` (a block's) carry the simulation MIG model's stall parameters: a DDR block."""
    return any(k in params for k in DEFAULT_STALLS)


def slowdown(params):
    """How much slower than one grant a cycle the simulation MIG model serves a DDR user with
    stall parameters ``params`` (a DDR block's; keys it lacks take :data:`DEFAULT_STALLS`'
    values, a block without DDR keys is 1.0): ``256 / (256 - drop)`` cycles per granted
    ready (each ready dropped with probability ``drop / 256``, independently) times
    ``refresh_period / (refresh_period - refresh_cycles)`` (the refreshes' share), plus the
    read latency ``lat_hi`` spread over a 32-word burst. An upper bound on the mean, for
    sizing a simulation's cycle budget (:func:`tdicam.cosim.stream.cycle_budget`)."""
    if not has_stalls(params):
        return 1.0
    p = {**DEFAULT_STALLS, **{k: v for k, v in params.items() if k in DEFAULT_STALLS}}
    period, busy = int(p["refresh_period"]), int(p["refresh_cycles"])
    return (256 / (256 - int(p["drop"]))) * (period / (period - busy)) + int(p["lat_hi"]) / 32


def _refreshing(t, period, cycles):
    """Refresh at cycle ``t``: the first ``cycles`` of every ``period`` after the first (a
    refresh timer that starts at reset, as LiteDRAM's)."""
    return t >= period and t % period < cycles


def stall_pattern(cycles, *, lat_lo=20, lat_hi=60, refresh_period=780, refresh_cycles=44,
                  drop=16, seed=1):
    """Per-cycle (app_rdy allowed, app_wdf_rdy allowed, read latency) of the stall pattern.

    ``app_rdy`` is further low while the model's return queue is full and ``app_wdf_rdy``
    while its write-data FIFO is full (not included here). Identical to the HDL model.
    """
    _check_stalls(lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed)
    s = seed   # xorshift32 state: every seed its own pattern
    a = np.zeros(cycles, bool)
    w = np.zeros(cycles, bool)
    lat = np.zeros(cycles, np.int64)
    span = lat_hi - lat_lo + 1
    for t in range(cycles):
        refresh = _refreshing(t, refresh_period, refresh_cycles)
        a[t] = not refresh and (s & 0xFF) >= drop
        w[t] = ((s >> 8) & 0xFF) >= drop
        lat[t] = lat_lo + ((((s >> 16) & 0xFFFF) * span) >> 16)
        s = xorshift32(s)
    return a, w, lat


class MigSim:
    """Cycle-stepped model of a MIG-style DDR3 controller's user interface.

    Call :meth:`outputs` for the values the controller drives in the current cycle (they
    depend on its state only), then :meth:`step` with what the user drove in that cycle.
    Memory is a dict of 256-bit Python ints keyed by word address; unwritten words read 0.

    Parameters
    ----------
    capacity_bytes : int
        Memory size; addresses ``>= capacity_bytes / 4`` are out of range.
    lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed
        The stall pattern (:data:`DEFAULT_STALLS`).
    wdf_depth, ret_depth : int
        Write-data FIFO and read-return queue depths (``app_wdf_rdy``/``app_rdy`` low when
        full).

    Raises
    ------
    TdicamError
        From :meth:`step`: an out-of-range or unaligned address, a write command without
        write data accepted before it, ``app_wdf_end`` missing on a data beat.
    """

    WDF_DEPTH = 16
    RET_DEPTH = 128

    def __init__(self, *, capacity_bytes=CAPACITY_BYTES, lat_lo=20, lat_hi=60,
                 refresh_period=780, refresh_cycles=44, drop=16, seed=1, dram=None):
        _check_stalls(lat_lo, lat_hi, refresh_period, refresh_cycles, drop, seed)
        self.dram = dram
        self.busy_until = 0         # DRAM timing: app_rdy low before this cycle
        self.last_dir = self.last_bank = None
        self.open_rows = {}
        self.units = min(capacity_bytes // 4, 1 << ADDR_BITS)
        self.lat_lo, self.lat_hi = lat_lo, lat_hi
        self.refresh_period, self.refresh_cycles = refresh_period, refresh_cycles
        self.drop = drop
        self.s = seed   # xorshift32 state: every seed its own pattern
        self.t = 0
        self.mem = {}
        self.wdf = deque()
        self.ret = deque()          # (due cycle, data)
        self.last_due = -1
        self.stats = {"writes": 0, "reads": 0, "cycles": 0}

    def outputs(self):
        """dict: app_rdy, app_wdf_rdy, app_rd_data_valid, app_rd_data for this cycle."""
        refresh = _refreshing(self.t, self.refresh_period, self.refresh_cycles)
        rdy = (not refresh and (self.s & 0xFF) >= self.drop
               and len(self.ret) < self.RET_DEPTH - 2 and self.t >= self.busy_until)
        wrdy = ((self.s >> 8) & 0xFF) >= self.drop and len(self.wdf) < self.WDF_DEPTH
        valid = bool(self.ret) and self.ret[0][0] <= self.t
        return {"app_rdy": rdy, "app_wdf_rdy": wrdy, "app_rd_data_valid": valid,
                "app_rd_data": self.ret[0][1] if valid else 0}

    def _addr(self, addr):
        if addr % ADDR_PER_WORD or addr >= self.units:
            raise TdicamError(f"DDR address {addr} is out of range or not word aligned "
                              f"(valid: multiples of {ADDR_PER_WORD} below {self.units})")
        return addr

    def step(self, *, app_en=0, app_cmd=0, app_addr=0, app_wdf_wren=0, app_wdf_data=0,
             app_wdf_end=1):
        """Advance one clock edge with the user's signals of this cycle; returns the read
        data delivered in this cycle (int) or None."""
        o = self.outputs()
        if _refreshing(self.t, self.refresh_period, self.refresh_cycles):
            self.open_rows.clear()          # a refresh precharges every bank
        span = self.lat_hi - self.lat_lo + 1
        lat = self.lat_lo + ((((self.s >> 16) & 0xFFFF) * span) >> 16)
        out = None
        if o["app_rd_data_valid"]:
            out = self.ret.popleft()[1]
        if app_en and o["app_rdy"]:
            a = self._addr(int(app_addr))
            if self.dram is not None:
                self._dram_cost(int(app_cmd) == 1, a // ADDR_PER_WORD)
            if int(app_cmd) == 0:
                if not self.wdf:
                    raise TdicamError(f"DDR write command to {a} without write data "
                                      "accepted before it")
                self.mem[a] = self.wdf.popleft()
                self.stats["writes"] += 1
            elif int(app_cmd) == 1:
                due = max(self.t + lat, self.last_due + 1)
                self.last_due = due
                self.ret.append((due, self.mem.get(a, 0)))
                self.stats["reads"] += 1
            else:
                raise TdicamError(f"app_cmd = {int(app_cmd)} is not valid; valid: 0 (write), "
                                  "1 (read)")
        if app_wdf_wren and o["app_wdf_rdy"]:
            if not app_wdf_end:
                raise TdicamError("app_wdf_end low on a 256-bit data beat (one beat per "
                                  "burst: it must be high with every app_wdf_wren)")
            self.wdf.append(int(app_wdf_data))
        self.s = xorshift32(self.s)
        self.t += 1
        self.stats["cycles"] += 1
        return out

    def read_word(self, addr):
        return self.mem.get(self._addr(addr), 0)

    def _dram_cost(self, read, word):
        """Hold ``app_rdy`` low after a command for what it cost on DRAM
        (:meth:`DramTiming.cost`, from the previous command's direction and bank and the
        rows open in the banks)."""
        bank, row = (word // ROW_WORDS) % BANKS, word // (ROW_WORDS * BANKS)
        cost = self.dram.cost(self.last_bank, self.last_dir, bank, read,
                              self.open_rows.get(bank), row)
        self.open_rows[bank] = row
        self.last_dir, self.last_bank = read, bank
        self.busy_until = self.t + 1 + cost


@dataclass(frozen=True)
class DramTiming:
    """DRAM costs of :class:`MigSim` with ``dram=`` given, in controller cycles (100 MHz,
    DDR3-800 behind a 1:4 controller), read off LiteDRAM's command timeline
    (:mod:`tdicam.cosim.litedram`; its bank machines, crossbar and multiplexer, one port).

    The gap a command costs (:meth:`cost`; the model holds ``app_rdy`` low for it after the
    command) is built as LiteDRAM's controller spends it:

    * ``vis``: cycles until the command reaches its bank's queue — ``first`` for the first
      command (the pipeline fills), ``bank`` when the previous command went to another bank
      (the crossbar lets a port into a new bank only when the old one's queue is empty),
      else 0;
    * the turnaround: read->write ``vis + rd_to_wr`` (the controller leaves its read state
      only once it sees the write, then waits out the read latency), write->read
      ``max(wr_to_rd, vis + 3)`` (tWTR counts from the last write while the read comes
      in), same direction ``vis``; the controller idles in its read state, so the first
      command, a write, pays the read->write turnaround;
    * plus ``activate`` when the command's bank has no row open or another row (row-bank-
      column mapping, :data:`ROW_WORDS`-word rows, :data:`BANKS` banks; a refresh closes
      every row), ``precharge`` more when another row was open; when the previous command
      wrote to that bank, the precharge waits ``write_recovery`` (tWR) after it, which runs
      during the turnaround: the turnaround counts as ``max(turn, write_recovery)``
      (charging both one after the other made the model 3.8 points pessimistic on
      ``write_read_lag16``: 74.2 % against LiteDRAM's 78.0 %; now 75.7 %).

    Use it with :data:`DRAM_STALLS` (refresh 44 cycles every 782, no random drops). The HDL
    model (:class:`tdicam.hdl.simmodels.mig_model.MigModel`) with the same ``dram`` is cycle-equal."""

    rd_to_wr: int = 8
    wr_to_rd: int = 5
    activate: int = 5
    precharge: int = 3
    write_recovery: int = 10
    bank: int = 3
    first: int = 6

    def cost(self, last_bank, last_read, bank, read, open_row, row):
        """Cycles the command (``bank``, ``read``, ``row``; its bank's ``open_row`` or None)
        costs after one to ``last_bank`` (None: the first command) in direction
        ``last_read``."""
        vis = self.first if last_bank is None else (self.bank if bank != last_bank else 0)
        was_read = True if last_bank is None else last_read
        if read == was_read:
            turn = vis
        elif read:
            turn = max(self.wr_to_rd, vis + 3)
        else:
            turn = vis + self.rd_to_wr
        act = 0 if open_row == row else self.activate
        if open_row is not None and open_row != row:
            act += self.precharge
            if bank == last_bank and not last_read:
                turn = max(turn, self.write_recovery)     # tWR runs during the turnaround
        return turn + act


#: stall pattern to use with :class:`DramTiming`: refresh 44 cycles (precharge all, tRFC,
#: rows opened again), read data 9 cycles after the read's turn (LiteDRAM's read latency 8
#: plus one; the gaps :class:`DramTiming` charges already hold the commands back)
DRAM_STALLS = {"lat_lo": 9, "lat_hi": 9, "refresh_period": 782, "refresh_cycles": 44,
               "drop": 0, "seed": 1}

#: the refresh interval tREFI in controller cycles (7.8 us at 100 MHz; :data:`DRAM_STALLS`)
TREFI = DRAM_STALLS["refresh_period"]
#: cycles after the first command that an efficiency window skips (the controller's
#: pipeline fill, the first row activations and read latency)
STARTUP = 100
#: refresh intervals an efficiency window spans: every DDR efficiency figure is words moved
#: in ``WINDOW_REFRESHES * TREFI`` cycles of steady state (so it pays its refreshes)
WINDOW_REFRESHES = 4


def window_cycles(refreshes=WINDOW_REFRESHES):
    """Length (cycles) of an efficiency window of ``refreshes`` refresh intervals."""
    return int(refreshes) * TREFI


def window_efficiency(beats, first, end, *, refreshes=WINDOW_REFRESHES, name="trace"):
    """``(words, cycles, efficiency)`` over the steady-state window of a replay.

    ``beats`` are the cycles of the data beats (a write's word taken, a read's word
    returned), ``first`` the cycle of the first command, ``end`` the cycle the replay had
    reached when it stopped, ``end`` of a replay that ran out of commands = its last beat
    + 1. The window opens :data:`STARTUP` cycles after ``first`` and lasts
    :func:`window_cycles` (``refreshes``) cycles; the efficiency is the beats inside it /
    its length. Raises :class:`TdicamError` when the replay ends before the window closes
    (the trace is too short to measure)."""
    lo = first + STARTUP
    hi = lo + window_cycles(refreshes)
    if end < hi:
        raise TdicamError(f"trace {name}: its replay ends {end - first} cycles after the "
                          f"first command, before the {refreshes}-refresh window "
                          f"({STARTUP}..{hi - first} cycles) closes: make the trace longer")
    words = sum(1 for t in beats if lo <= t < hi)
    return words, hi - lo, words / (hi - lo)


def window_words(refreshes=WINDOW_REFRESHES):
    """Commands a trace needs at least to cover the start-up and the window (a command
    takes at least one cycle, so this many always do at any efficiency)."""
    return STARTUP + window_cycles(refreshes) + 64
