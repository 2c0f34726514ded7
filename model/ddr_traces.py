"""DDR access patterns: the order of a DDR user's commands (:class:`Trace`), the named
patterns that matter here and their replay on the controller model
(:class:`tdicam.model.dram.MigSim`); :mod:`tdicam.cosim.litedram` replays the same traces
into LiteDRAM.

A :class:`Trace` is the order of a user's commands (``(is_read, word_address)`` per port);
:data:`PATTERNS` names the orders that matter here (single direction, line blocks,
the per-word read-then-write the TDI spill had, its line blocks now, two ports),
:func:`replay_model` runs a trace on :class:`~tdicam.model.dram.MigSim` with data always
available; :func:`pattern_efficiency` is a named pattern's steady-state efficiency.
"""

import dataclasses
from dataclasses import dataclass

from tdicam.errors import TdicamError
from tdicam.model.ddr import ADDR_PER_WORD
from tdicam.model.dram import (DEFAULT_STALLS, DRAM_STALLS, STARTUP, DramTiming, MigSim,
                               window_cycles, window_efficiency, window_words)

__all__ = ["Trace", "PATTERNS", "pattern_trace", "merged_commands", "trace_dram",
           "TraceDriver", "replay_model", "pattern_lines", "pattern_efficiency"]


@dataclass
class Trace:
    """Command order of one user: ``ports[p]`` = list of ``(is_read, word_addr)``.

    ``order`` (optional, two ports): the global order as ``(port, index)`` pairs, used for
    the read-after-write dependencies between ports. ``planned`` (optional): the efficiency
    the planner counts on for the block that issued it."""

    name: str
    ports: list
    order: list = None
    note: str = ""
    planned: float = None

    @property
    def words(self):
        return sum(len(p) for p in self.ports)


def _line(y, words, stride, base=0):
    return [base + y * stride + w for w in range(words)]


def pattern_trace(name, *, lines=32, words=54, stride=64):
    """The command order of a named access pattern (:data:`PATTERNS`), ``lines`` lines of
    ``words`` words at a ``stride``-word pitch (a 1280 x 10-bit line = 54 words at 64)."""
    if name not in PATTERNS:
        raise TdicamError(f"unknown DDR access pattern {name!r}; valid: {', '.join(PATTERNS)}")
    return PATTERNS[name][0](lines=lines, words=words, stride=stride)


def _write_only(*, lines, words, stride):
    return Trace("write_only", [[(0, a) for y in range(lines) for a in _line(y, words, stride)]])


def _read_only(*, lines, words, stride):
    return Trace("read_only", [[(1, a) for y in range(lines) for a in _line(y, words, stride)]])


def _table2(kind):
    def make(*, lines, words, stride):
        rd = int(kind == "read")
        return Trace(f"table2_{kind}", [[(rd, a) for y in range(lines)
                                         for a in _line(y, 510, 512)]])
    return make


def _line_pairs(lag):
    def make(*, lines, words, stride):
        cmds = []
        for y in range(lines + lag):
            if y < lines:
                cmds += [(0, a) for a in _line(y, words, stride)]
            if y >= lag:
                cmds += [(1, a) for a in _line(y - lag, words, stride)]
        return Trace(f"write_read_lag{lag}", [cmds])
    return make


def _blocks(block):
    def make(*, lines, words, stride):
        wr = [a for y in range(lines) for a in _line(y, words, stride)]
        # reads of the same lines, a line behind (reads of data written earlier)
        lag = words
        n, cmds, i, j = len(wr), [], 0, 0
        while i < n or j < n:
            for _ in range(min(block, n - i)):
                cmds.append((0, wr[i]))
                i += 1
            for _ in range(block):
                if j < n and (j + lag <= i or i == n):
                    cmds.append((1, wr[j]))
                    j += 1
        return Trace(f"blocks_{block}", [cmds])
    return make


def _per_word(*, lines, words, stride):
    # TdiDdr's order: for each word, read the stored sum, then write the new one
    cmds = []
    for y in range(lines):
        for a in _line(y, words, stride):
            cmds += [(1, a), (0, a)]
    return Trace("per_word_rw", [cmds])


def _row_blocks(*, lines, words, stride):
    # TdiDdr's order: a row's stored sums read as one block, then its new sums written
    cmds = []
    for y in range(lines):
        cmds += [(1, a) for a in _line(y, words, stride)]
        cmds += [(0, a) for a in _line(y, words, stride)]
    return Trace("row_blocks", [cmds])


def _two_ports(*, lines, words, stride):
    wr = [(0, a) for y in range(lines) for a in _line(y, words, stride)]
    rd = [(1, a) for y in range(lines - 1) for a in _line(y, words, stride)]
    order, i = [], 0
    for y in range(lines):
        order += [(0, i + w) for w in range(words)]
        i += words
        if y >= 1:
            order += [(1, (y - 1) * words + w) for w in range(words)]
    return Trace("two_ports", [wr, rd], order)


#: name -> (trace maker, description, controller windows (read_time, write_time) or None)
PATTERNS = {
    "write_only": (_write_only, "write only", None),
    "read_only": (_read_only, "read only", None),
    "table2_write": (_table2("write"), "Table 2 layout (510-word lines) write", None),
    "table2_read": (_table2("read"), "Table 2 layout (510-word lines) read", None),
    "write_read_lag1": (_line_pairs(1), "one port, write line n then read line n-1", None),
    "write_read_lag16": (_line_pairs(16), "one port, write line n then read line n-16", None),
    "blocks_27": (_blocks(27), "one port, reads and writes in blocks of 27 words", None),
    "blocks_18": (_blocks(18), "one port, reads and writes in blocks of 18 words", None),
    "blocks_8": (_blocks(8), "one port, reads and writes in blocks of 8 words", None),
    "per_word_rw": (_per_word, "one port, one read then one write per word (the old TdiDdr)",
                    None),
    "row_blocks": (_row_blocks, "one port, a line read as one block then written back "
                                "(TdiDdr)", None),
    "two_ports": (_two_ports, "two ports (writer + reader), controller defaults", None),
    "two_ports_64": (_two_ports, "two ports, 64-cycle read and write windows", (64, 64)),
}


#: LiteDRAM's controller defaults (``ControllerSettings``): read window 32 cycles, write
#: window 16 cycles
_DEFAULT_WINDOWS = (32, 16)
#: commands a turn carries beyond its window's cycles: LiteDRAM leaves a direction only when
#: the other one has a command queued, and the bank machines' command queues
#: (``cmd_buffer_depth`` 8) plus the command in flight are issued in the turn. Read off
#: LiteDRAM over the steady-state window (tests/ddr_litedram.json): ``two_ports`` (32/16)
#: 73.2 % (this rule 73.4 %; counting the window's cycles alone, 65.7 %), ``two_ports_64``
#: 82.2 % (84.1 %)
TURN_QUEUED = 9


def _windows(trace, order, read_time, write_time):
    """Merge a writer port and a reader port as a controller with read and write windows
    of ``read_time`` and ``write_time`` cycles does: up to ``write_time + TURN_QUEUED``
    writes, then up to ``read_time + TURN_QUEUED`` reads whose words were written
    (``order`` gives the dependencies), and so on."""
    rank = {pk: n for n, pk in enumerate(order)}
    w = [pk for pk in order if not trace.ports[pk[0]][pk[1]][0]]
    r = [pk for pk in order if trace.ports[pk[0]][pk[1]][0]]
    last_w = {}
    for n, pk in enumerate(order):
        if not trace.ports[pk[0]][pk[1]][0]:
            last_w[trace.ports[pk[0]][pk[1]][1]] = n
    out, i, j = [], 0, 0
    while i < len(w) or j < len(r):
        for _ in range(write_time + TURN_QUEUED):
            if i < len(w):
                out.append(w[i])
                i += 1
        done = rank[w[i - 1]] if i else -1
        for _ in range(read_time + TURN_QUEUED):
            if j < len(r) and (i == len(w) or last_w.get(trace.ports[r[j][0]][r[j][1]][1],
                                                         -1) <= done):
                out.append(r[j])
                j += 1
    return out


def merged_commands(trace, dram=None, windows=None):
    """The one-port command order :func:`replay_model` issues for ``trace``: a two-port
    trace merged in ``trace.order`` (with ``dram``: in the controller's read and write
    windows, ``windows`` or LiteDRAM's defaults (32, 16) cycles)."""
    order = trace.order or [(0, k) for k in range(len(trace.ports[0]))]
    if len(trace.ports) == 2 and dram is not None:
        order = _windows(trace, order, *(windows or _DEFAULT_WINDOWS))
    return [trace.ports[p][k] for p, k in order]


def trace_dram(trace, dram):
    """The DRAM timing a replay of ``trace`` charges: ``dram``, except for a two-port trace,
    whose ports each keep their own queue in their bank (LiteDRAM's crossbar holds a port,
    not the controller, to one bank at a time), so the merged stream pays no queue drain
    when it changes bank (``bank`` = 0)."""
    if dram is None or len(trace.ports) < 2:
        return dram
    return dataclasses.replace(dram, bank=0)


class TraceDriver:
    """The user side of a replay: issues ``cmds`` (``(is_read, word_addr)``) back to back
    on a MIG UI, write data offered as early as the controller takes it (data first), each
    command as soon as it may go. Each cycle: :meth:`drive` (the UI inputs of this cycle),
    then :meth:`update` with the controller's ``app_rdy``, ``app_wdf_rdy`` and
    ``app_rd_data_valid`` of the same cycle. Drives any controller model the same way
    (:class:`MigSim`, :class:`tdicam.hdl.simmodels.mig_model.MigModel`)."""

    def __init__(self, cmds):
        self.cmds = list(cmds)
        self.writes = [a for rd, a in self.cmds if not rd]
        self.nreads = len(self.cmds) - len(self.writes)
        self.ci = self.wi = self.wc = self.got = self.t = self.last = 0
        self.beats = []         # cycle of each data beat (see :attr:`result`)

    @property
    def done(self):
        return self.ci >= len(self.cmds) and self.got >= self.nreads

    def drive(self):
        """dict of app_en, app_cmd, app_addr, app_wdf_wren, app_wdf_data for this cycle."""
        rd, a = self.cmds[self.ci] if self.ci < len(self.cmds) else (0, 0)
        self._en = self.ci < len(self.cmds) and bool(rd or self.wi > self.wc)
        self._wren = self.wi < len(self.writes)
        self._rd = rd
        return {"app_en": int(self._en), "app_cmd": int(rd), "app_addr": a * ADDR_PER_WORD,
                "app_wdf_wren": int(self._wren), "app_wdf_data": 0}

    def update(self, app_rdy, app_wdf_rdy, app_rd_data_valid):
        if self._wren and app_wdf_rdy:
            self.wi += 1
        if self._en and app_rdy:
            self.ci += 1
            if not self._rd:
                self.wc += 1
                self.last = self.t
                self.beats.append(self.t)
        if app_rd_data_valid:
            self.got += 1
            self.last = self.t
            self.beats.append(self.t)
        self.t += 1

    @property
    def result(self):
        """``(words, cycles, efficiency)``: cycles from the first command offered to the
        last data beat (a write's command accepted, a read's data returned)."""
        return len(self.cmds), self.last + 1, len(self.cmds) / (self.last + 1)


def replay_model(trace, dram=None, windows=None, *, steady=False, **stalls):
    """Replay ``trace`` (:class:`Trace`) through :class:`MigSim` with data always available
    (:class:`TraceDriver`; a two-port trace merged by :func:`merged_commands`). Stalls:
    :data:`DEFAULT_STALLS` without ``dram``, :data:`DRAM_STALLS` with it, updated by
    ``stalls``. Returns ``(words, cycles, efficiency)``: over the whole trace
    (:attr:`TraceDriver.result`), or with ``steady`` over the steady-state window
    (:func:`window_efficiency`; the replay stops when it closes)."""
    cmds = merged_commands(trace, dram, windows)
    base = DEFAULT_STALLS if dram is None else DRAM_STALLS
    sim = MigSim(dram=trace_dram(trace, dram), **{**base, **stalls})
    drv = TraceDriver(cmds)
    stop = STARTUP + window_cycles() if steady else None
    while not drv.done and (stop is None or drv.t < stop):
        o = sim.outputs()
        sim.step(**drv.drive())
        drv.update(o["app_rdy"], o["app_wdf_rdy"], o["app_rd_data_valid"])
        if drv.t > 100 * len(cmds) + 10000:
            raise TdicamError(f"trace {trace.name}: the memory model did not finish")
    if steady:
        return window_efficiency(drv.beats, 0, drv.last + 1 if drv.done else drv.t,
                                 name=trace.name)
    return drv.result


def pattern_lines(name, *, words=54):
    """Lines of ``words`` words the pattern ``name`` needs to cover the start-up and the
    steady-state window (:func:`window_words`; the line-lag patterns at least their lag + 1)."""
    lag = 17 if name == "write_read_lag16" else 2
    per_line = pattern_trace(name, lines=lag, words=words).words / lag
    return max(lag, -(-window_words() // int(per_line)) + 1)


def pattern_efficiency(name, *, lines=None, words=54, stride=64, dram=DramTiming(),
                       **stalls):
    """Steady-state efficiency (words moved / cycles, 0..1, over :func:`window_efficiency`'s
    window of :data:`WINDOW_REFRESHES` refresh intervals) of the named access pattern
    (:data:`PATTERNS`) on the memory model :class:`MigSim` with DRAM timing ``dram`` (default
    :class:`DramTiming`, stalls :data:`DRAM_STALLS`; ``dram=None``: the plain stall pattern
    :data:`DEFAULT_STALLS`, which ignores the order of accesses), ``lines`` lines (default
    :func:`pattern_lines`) of ``words`` words at a ``stride``-word pitch. For the planner:
    the DDR share a design can count on for that order of accesses."""
    lines = pattern_lines(name, words=words) if lines is None else lines
    tr = pattern_trace(name, lines=lines, words=words, stride=stride)
    return replay_model(tr, dram, PATTERNS[name][2], steady=True, **stalls)[2]
