"""3x3 median filter with optional edge enhancement (Ning et al. 2019 §4.4.3).

The median is a pipelined compare-exchange network on sorted columns (sort each 3-pixel
column once, then take ``med3(max of lows, med3 of mids, min of highs)`` across the 3
columns of a window). It is better than the paper's network (column 3-sorts, a 6-value
merge of <= 7 compares, a selection of <= 5): 13 comparators per output pixel instead of
15, 8 compare stages deep, one comparator per pipeline stage on every path. The network is
the table :data:`COLUMN_SORT` + :data:`WINDOW_MEDIAN`, which the gateware is built from and
which the tests prove correct over all 0/1 inputs (0-1 principle for min/max networks).

One module on purpose: the compare-exchange network, its line-buffer neighbourhood and the
enhancement stages are one pipeline whose stage timing is counted across all three
(``latency``); splitting them would spread that count over files. Inside it the
neighbourhood (:class:`_Neighbourhood`: sequencer, border rows, column function) is built
of named sub-components, each with its ``latency``: :class:`_LineBuffers` (2),
:class:`_Align` (the column's / window's position beside their arithmetic) and
:class:`_Window` (0).
"""

from types import SimpleNamespace

from amaranth.hdl import Cat, Const, Module, Mux, Shape, Signal, Value, signed, unsigned
from amaranth.lib import data, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from tdicam.errors import TdicamError, check_choice, check_multiple, check_range
from tdicam.beats import PPC_CHOICES
from tdicam.model.median3 import MAX_GAIN, MAX_SHIFT, MAX_WIDTH, default_enhance_shift
from tdicam.hdl.interfaces.stream import AdvanceBuffer, channels_shape, pixel_signature
from tdicam.hdl.util import equals, is_zero, pick
from tdicam.hdl.vendor import ecp5_bram, ecp5_dsp

__all__ = ["Median3", "check_geometry", "COLUMN_SORT", "WINDOW_MEDIAN", "run_network", "network_stats",
           "reciprocal_25"]

#: Sort one column (t, m, b: top, middle, bottom) into (lo, mid, hi). Each stage is a
#: tuple of ``(dst, "min"|"max", a, b)``; a stage is one register stage in the gateware.
COLUMN_SORT = (
    (("s_lo", "min", "t", "m"), ("s_hi", "max", "t", "m")),
    (("u_lo", "min", "s_hi", "b"), ("hi", "max", "s_hi", "b")),
    (("lo", "min", "s_lo", "u_lo"), ("mid", "max", "s_lo", "u_lo")),
)

#: Median of a window of three sorted columns (suffix 0 = left, 1 = centre, 2 = right):
#: ``med3(max(lo0, lo1, lo2), med3(mid0, mid1, mid2), min(hi0, hi1, hi2))``.
WINDOW_MEDIAN = (
    (("x1", "max", "lo0", "lo1"), ("a", "min", "mid0", "mid1"), ("b", "max", "mid0", "mid1"),
     ("z1", "min", "hi0", "hi1")),
    (("x", "max", "x1", "lo2"), ("c", "min", "b", "mid2"), ("z", "min", "z1", "hi2")),
    (("y", "max", "a", "c"), ("p", "min", "x", "z"), ("q", "max", "x", "z")),
    (("t", "min", "q", "y"),),
    (("med", "max", "p", "t"),),
)

_HMAX = 16  # bits of the run-time height port


def run_network(stages, env, outputs, *, minmax, reg=None):
    """Evaluate a min/max network stage by stage.

    ``minmax(fn, a, b)`` implements ``"min"``/``"max"``; ``reg(name, value)`` (optional)
    registers every wire live after a stage (new results and carried inputs). Returns the
    ``outputs`` wires. Used by the gateware (Amaranth values) and the tests (numpy).
    """
    env = dict(env)
    for k, stage in enumerate(stages):
        later = set(outputs) | {x for st in stages[k + 1:] for op in st for x in op[2:]}
        new = {dst: minmax(fn, env[a], env[b]) for dst, fn, a, b in stage}
        live = {n: v for n, v in {**env, **new}.items() if n in later}
        env = {n: (reg(n, v) if reg else v) for n, v in live.items()}
    return [env[o] for o in outputs]


def network_stats():
    """(compare stages, comparators per output pixel) of the median network.

    A comparator is one distinct (a, b) pair in a stage (a min and a max of the same pair
    share it); the column sort counts once per pixel because each column is sorted once
    and reused by the three windows that contain it.
    """
    stages = len(COLUMN_SORT) + len(WINDOW_MEDIAN)
    comps = sum(len({(a, b) for _, _, a, b in st}) for st in COLUMN_SORT + WINDOW_MEDIAN)
    return stages, comps


def reciprocal_25(n_max):
    """(k, s) with ``(n * k) >> s == n // 25`` for every ``0 <= n <= n_max``.

    ``k = ceil(2**s / 25)``, ``e = 25 k - 2**s``; ``n_max * e < 2**s`` is sufficient
    (n = 25 q + r: ``n k / 2**s = q + (r + n e / 2**s) / 25`` and ``r <= 24``).
    """
    s = 0
    while True:
        k = -(-(1 << s) // 25)
        if n_max * (25 * k - (1 << s)) < (1 << s):
            return k, s
        s += 1


def check_geometry(width, ppc):
    """``(ppc, width)`` if ``ppc`` is 1, 2, 4 or 8 and ``width`` a multiple of it in
    ``3 ppc .. 8192`` (at least 3 beats per row), else a one-line :class:`TdicamError`
    naming both."""
    check_choice("ppc", ppc, PPC_CHOICES)
    if ppc == 1:
        return ppc, check_range("width", width, 3, MAX_WIDTH)
    check_range(f"width (ppc = {ppc})", width, 3 * ppc, MAX_WIDTH)
    return ppc, check_multiple(width, ppc)


def _lanes(shape, ppc):
    """``shape`` (ppc 1) or an array of ``ppc`` of it (lane 0 the leftmost pixel)."""
    return shape if ppc == 1 else data.ArrayLayout(shape, ppc)


def _minmax(fn, a, b):
    lt = b < a
    return Mux(lt, b, a) if fn == "min" else Mux(lt, a, b)


class _Enables:
    """Copies of a neighbourhood's advance at ppc >= 2: equal registers (the bits of its
    :class:`~tdicam.hdl.interfaces.stream.AdvanceBuffer`'s ``adv``), each the clock enable
    of about :attr:`BITS` register bits (:meth:`take`) or of one sub-component (:meth:`own`),
    so that no copy fans out to the thousands of flip-flops of a pipeline 8 pixels wide."""

    BITS = 256

    def __init__(self, name):
        self.name, self.copies, self.used = name, [], self.BITS

    def own(self):
        """A copy of its own (for a sub-component or the sequencer)."""
        self.used = self.BITS
        sig = Signal(name=f"{self.name}_adv{len(self.copies)}")
        self.copies.append(sig)
        return sig

    def take(self, bits):
        """The copy for a register of ``bits`` bits: the current one while it has room."""
        if self.used + bits > self.BITS:
            self.own()
            self.used = 0
        self.used += bits
        return self.copies[-1]


class _Pipe:
    """Registers that all move on one global advance (the pipeline's clock enable): ``adv``
    a signal, or :class:`_Enables` (copies of it). ``dsp``: how :meth:`product` registers a
    product ("generic" or "ecp5", :attr:`Median3.DSPS`)."""

    def __init__(self, m, adv, prefix, dsp="generic"):
        self.m, self.adv, self.prefix, self.n, self.dsp = m, adv, prefix, 0, dsp

    def _enable(self, bits):
        return self.adv.take(bits) if isinstance(self.adv, _Enables) else self.adv

    def reg(self, value, shape=None, name=None, reset=False):
        if shape is None:
            shape = value.shape() if isinstance(value, (Value, data.View)) else \
                Value.cast(value).shape()
        self.n += 1
        sig = Signal(shape, name=f"{self.prefix}_{name or 'r'}_{self.n}", reset_less=not reset)
        with self.m.If(self._enable(len(Value.cast(sig)))):
            self.m.d.sync += sig.eq(value)
        return sig

    def product(self, a, b, name):
        """``a * b`` (``b`` a value or an int) registered on the advance: a fabric register
        after a ``*``, or with ``dsp="ecp5"`` a MULT18X18D's own output register when the
        operands fit one and are at least 2 bits each (what yosys maps to one; the same
        value and cycle)."""
        a, b = Value.cast(a), Value.cast(b)
        if self.dsp != "ecp5" or min(len(a), len(b)) < 2 or \
                not ecp5_dsp.fits(a.shape(), b.shape()):
            return self.reg(a * b, name=name)
        self.n += 1
        return ecp5_dsp.mult(self.m, f"{self.prefix}_{name}_{self.n}", a, b,
                             self._enable(len(a) + len(b)), registers="output")

    def delay(self, value, n, name=None, reset=False):
        for _ in range(n):
            value = self.reg(value, name=name, reset=reset)
        return value


def _generic_line(m, pipe, tag, *, depth, bits, ra, wa, wd, we, rname):
    """A line buffer as an ``amaranth.lib.memory.Memory`` (read port enabled on the
    pipeline's advance) and a fabric register after its read port."""
    mem = Memory(shape=unsigned(bits), depth=depth, init=[])
    m.submodules[tag] = mem
    rp, wp = mem.read_port(), mem.write_port()
    q = pipe.reg(rp.data, name=rname)
    m.d.comb += [rp.addr.eq(ra), rp.en.eq(pipe.adv), wp.addr.eq(wa), wp.data.eq(wd),
                 wp.en.eq(we)]
    return q


def _ecp5_line(m, pipe, tag, *, depth, bits, ra, wa, wd, we, rname):
    """A line buffer as ECP5 DP16KD primitives whose own output register (clock enable the
    pipeline's advance) is the read's second stage (:func:`tdicam.hdl.vendor.ecp5_bram.
    pipe_bank`): the same two advances as :func:`_generic_line`."""
    return ecp5_bram.pipe_bank(m, tag, depth=depth, bits=bits, ra=ra, wa=wa, wd=wd, we=we,
                               en=pipe.adv)


#: How the line buffers are described (``bram=``): ``"generic"`` (``tdicam verilog``, every
#: simulation: yosys maps the memory, its block RAM's output register unused) or ``"ecp5"``
#: (the ECP5 synthesis top: DP16KD instances, their output register the read's second
#: stage). Both read in 2 advances; the block's latency and cycle behaviour are the same.
BRAMS = {"generic": _generic_line, "ecp5": _ecp5_line}


class _LineBuffers(wiring.Component):
    """The line buffers of a neighbourhood.

    ``taps`` memories of ``depth`` words of ``tap_bits`` (a row in memory ``w_slot``) and
    ``pays`` memories of ``pay_bits`` (a row in memory ``w_slot mod pays``), all read at
    ``rd_addr`` and written at ``w_addr`` when ``w_en``, everything on ``adv`` (the
    pipeline's clock enable). The writer presents a beat one advance after reading its
    address, so a read never meets a write to the same address. ``rd_taps[k]`` /
    ``rd_pays[k]`` hold memory k's word :attr:`latency` = 2 advances after its address:
    the read (1) and an output register with nothing in between (1; a block RAM's
    clock-to-out is slow: ~4.1 ns on ECP5 without its own output register). ``bram`` (a
    key of :data:`BRAMS`): ``"ecp5"`` makes that register the DP16KD's own.
    """

    def __init__(self, *, taps, pays, depth, tap_bits, pay_bits, name, bram="generic"):
        self._taps, self._pays, self._depth, self._name = taps, pays, depth, name
        self._line = BRAMS[bram]          # checked by Median3
        self._slot_bits = (taps - 1).bit_length()
        ports = {
            "adv": In(1), "rd_addr": In(range(depth)), "w_en": In(1),
            "w_addr": In(range(depth)), "w_slot": In(self._slot_bits),
            "w_tap": In(tap_bits),
            "rd_taps": Out(data.ArrayLayout(unsigned(tap_bits), taps)),
        }
        if pays:
            ports.update({"w_pay": In(pay_bits),
                          "rd_pays": Out(data.ArrayLayout(unsigned(pay_bits), pays))})
        super().__init__(ports)

    latency = property(lambda self: 2, doc="Advances from ``rd_addr`` to ``rd_*``.")

    def elaborate(self, platform):
        m = Module()
        pipe = _Pipe(m, self.adv, self._name)
        ports = [(self.w_tap, self.rd_taps, "lb", "rd",
                  [equals(self.w_slot, k) for k in range(self._taps)])]
        if self._pays:
            ports.append((self.w_pay, self.rd_pays, "pb", "prd",
                          [self.w_slot[0] == k for k in range(2)] if self._pays == 2 else
                          [Const(1, 1)]))
        for wdata, rd, mname, rname, slots in ports:
            for k, slot in enumerate(slots):
                m.d.comb += rd[k].eq(self._line(
                    m, pipe, f"{self._name}_{mname}{k}", depth=self._depth, bits=len(wdata),
                    ra=self.rd_addr, wa=self.w_addr, wd=wdata,
                    we=self.adv & self.w_en & slot, rname=rname))
        return m


class _Align(wiring.Component):
    """``o`` = ``i`` delayed :attr:`latency` advances (registers on ``adv``): the position
    and markers of a column or window travelling beside its arithmetic. Fields named in
    ``reset`` are cleared by reset (the valid flags); the others are reset-less."""

    def __init__(self, fields, n, *, reset=(), name="al"):
        self._n, self._reset, self._name = n, set(reset), name
        lay = data.StructLayout(fields)
        super().__init__({"adv": In(1), "i": In(lay), "o": Out(lay)})

    latency = property(lambda self: self._n, doc="Advances from ``i`` to ``o``.")

    def elaborate(self, platform):
        m = Module()
        pipe = _Pipe(m, self.adv, self._name)
        for name in self.i.shape().members:
            m.d.comb += getattr(self.o, name).eq(pipe.delay(
                getattr(self.i, name), self._n, name=name, reset=name in self._reset))
        return m


class _Window(wiring.Component):
    """The 2R+1 columns (beats at ppc > 1) of a neighbourhood's next output, borders
    replicated, from a stream of column values with their position.

    ``col`` is the column at the head of the pipeline (with ``valid``, ``cc`` its column
    index saturated at 2R, ``lastc`` the row's last, ``row0`` of output row 0); a shift
    register keeps the 2R columns taken before it. Only real columns shift in. After a
    row's last column, R pad steps produce its last R outputs; they overlap the next row's
    first R columns (which produce no output) or run alone, and find the old row's columns
    1 + npad deeper, npad = columns of the next row taken since. Outputs in the same cycle
    (:attr:`latency` 0): ``cols`` (left to right), ``out_valid``, ``first`` (output (0, 0)),
    ``last`` (a row's last output), ``left`` / ``right`` (the output is a row's first /
    last: its columns beyond the row are replicated)."""

    def __init__(self, *, radius, width, col_shape, name):
        self._r, self._w, self._name = radius, width, name
        super().__init__({
            "adv": In(1), "col": In(col_shape), "valid": In(1),
            "cc": In(range(2 * radius + 1)), "lastc": In(1), "row0": In(1),
            "cols": Out(data.ArrayLayout(col_shape, 2 * radius + 1)),
            "out_valid": Out(1), "first": Out(1), "last": Out(1), "left": Out(1),
            "right": Out(1),
        })

    latency = property(lambda self: 0, doc="Cycles from ``col`` to ``cols``.")

    def elaborate(self, platform):
        m = Module()
        R, W, adv = self._r, self._w, self.adv
        hv, hcc, hlast = self.valid, self.cc, self.lastc
        col = self.col
        sr = [col] + [Signal(col.shape(), name=f"{self._name}_sr{j}", reset_less=True)
                      for j in range(1, 2 * R + 1)]
        pend = Signal(range(R + 1), name=f"{self._name}_pend")
        npad = Signal(range(R + 1), name=f"{self._name}_npad")
        is_pad = pend != 0
        is_norm = hv & (hcc >= R) & ~is_pad
        with m.If(adv):
            with m.If(hv):
                m.d.sync += [sr[j].eq(sr[j - 1]) for j in range(1, 2 * R + 1)]
            with m.If(hv & hlast):
                m.d.sync += [pend.eq(R), npad.eq(0)]
            with m.Elif(is_pad):
                m.d.sync += pend.eq(pend - 1)
                with m.If(hv):
                    m.d.sync += npad.eq(npad + 1)
        for t in range(2 * R + 1):
            d = t - R
            sel = Signal(range(2 * R + 1), name=f"{self._name}_hsel{t}")
            with m.If(is_pad):
                with m.Switch(Cat(npad, pend)):
                    for p in range(1, R + 1):
                        k = R - p + 1       # pad k produces column x = W-1-R+k
                        x = W - 1 - R + k
                        for sh in range(k):
                            with m.Case(sh | (p << len(npad))):
                                if x + d < 0:
                                    j = sh + W                 # column 0
                                elif d > R - k:
                                    j = sh + 1                 # column W-1
                                else:
                                    j = sh + 1 + R - k - d     # column x+d
                                assert 1 <= j <= 2 * R
                                m.d.comb += sel.eq(j)
                    with m.Default():
                        m.d.comb += sel.eq(R)
            with m.Else():
                with m.Switch(hcc):
                    for c in range(R, 2 * R + 1):
                        x = c - R           # c = 2R stands for every x >= R
                        with m.Case(c):
                            m.d.comb += sel.eq(x + R if x + d < 0 else R - d)
                    with m.Default():
                        m.d.comb += sel.eq(R - d)
            m.d.comb += self.cols[t].eq(pick(sr, sel))
        m.d.comb += [self.out_valid.eq(is_pad | is_norm),
                     self.left.eq(is_norm & (hcc == R)),
                     self.first.eq(is_norm & (hcc == R) & self.row0),
                     self.last.eq(is_pad & (pend == 1)),
                     self.right.eq(is_pad)]
        return m


class _Neighbourhood(wiring.Component):
    """Streaming (2R+1) x (2R+1) neighbourhood stage with replicated borders, ``ppc``
    pixels (one beat) per clock.

    Input beats carry ``tap`` (the value the neighbourhood is formed of), ``pay`` (a value
    only needed for the centre pixel) and ``hm1`` (frame height - 1, sampled on the first
    pixel of each frame); output beats ``val`` (and ``hm1`` of the frame when
    ``carry_hm1``).

    ``col_fn(pipe, taps, pay) -> (value, depth)`` reduces one column (taps top to bottom,
    border rows already replicated) in ``depth`` register stages; ``win_fn(pipe, cols) ->
    (value, depth)`` reduces the 2R+1 column values of a window (left to right, border
    columns already replicated). ``pay`` rides in the column value; the window function
    takes it from the centre column.

    Line buffers: 2R memories of ``width`` taps, used circularly (row q of the stream in
    memory q mod 2R) and R memories of ``width`` payloads. Output row y needs input rows
    up to y + R: the last R rows of a frame are produced by a self-timed flush that reads
    the buffers while the next frame's first R rows are written behind it (a row of the new
    frame writes column c only after the flush has read the old row there for the last
    time), so frames follow each other at 1 pixel/clock and the last frame of a stream is
    not held back. Likewise the last R pixels of a row are produced by pad steps that
    overlap the next row's first R columns (which produce no output).

    At ``ppc`` > 1 everything above counts beats, not pixels: ``width / ppc`` beat columns,
    line buffers of ``width / ppc`` words of ``ppc`` taps, and a horizontal radius of one
    beat (pixel k of a beat needs pixels k-R..k+R, R <= 2 <= ppc: the neighbour beats' last
    / first R pixels), so one pad step ends a row. ``col_fn`` runs on every lane of a beat
    column; ``win_fn`` on every pixel's 2R+1 pixel columns (:meth:`_window`).

    ``bram``: how the line buffers are described (:data:`BRAMS`); ``dsp``: the products'
    registers (:meth:`_Pipe.product`). ``buffered`` (default:
    at ``ppc`` > 1): the pipeline moves on copies of an advance register and ends in an
    :class:`~tdicam.hdl.interfaces.stream.AdvanceBuffer` (one cycle more), so no
    combinational path runs from ``o_stream.ready`` to its clock enables, and has a
    register after its window's column select (one cycle more); otherwise the advance is
    ``~o_stream.valid | o_stream.ready``.
    """

    def __init__(self, *, radius, width, tap_shape, pay_shape, out_shape, col_fn, win_fn,
                 carry_hm1=False, name="nb", ppc=1, bram="generic", buffered=None,
                 dsp="generic"):
        self._r, self._w, self._ppc, self._bram, self._dsp = radius, width, ppc, bram, dsp
        self._buf = ppc > 1 if buffered is None else buffered
        self._tap_shape, self._pay_shape = Shape.cast(tap_shape), pay_shape
        self._col_fn, self._win_fn, self._carry = col_fn, win_fn, carry_hm1
        self._name = name
        fields = {"tap": _lanes(tap_shape, ppc), "hm1": unsigned(_HMAX)}
        if pay_shape is not None:
            fields["pay"] = _lanes(pay_shape, ppc)
        ofields = {"val": _lanes(out_shape, ppc)}
        if carry_hm1:
            ofields["hm1"] = unsigned(_HMAX)
        super().__init__({
            "i_stream": In(pixel_signature(data.StructLayout(fields))),
            "o_stream": Out(pixel_signature(data.StructLayout(ofields))),
            "marker_error": Out(unsigned(1)),
        })
        self.depth = None  # set by elaborate: register stages from input to output

    def elaborate(self, platform):
        m = Module()
        R, N, P = self._r, 2 * self._r, self._ppc
        W = self._w // P  # beats per row
        Rh = R if P == 1 else 1  # horizontal radius in beats: R <= 2 <= P pixels of a beat
        i, o = self.i_stream, self.o_stream
        nb = N.bit_length() - 1  # N is 2 or 4
        if not self._buf:
            adv = Signal(name=f"{self._name}_adv")
            m.d.comb += adv.eq(~o.valid | o.ready)
            en, own = adv, (lambda: adv)
        else:
            # the advance from registers (AdvanceBuffer, in copies): o.ready reaches no
            # clock enable; the sequencer's copy drives i.ready
            en = _Enables(self._name)
            adv, own = en.own(), en.own
        pipe = _Pipe(m, en, self._name, self._dsp)
        has_pay = self._pay_shape is not None
        pay_bits = P * Shape.cast(self._pay_shape).width if has_pay else 0
        tap_bits = P * self._tap_shape.width

        # ---- sequencer (S0). Everything i.ready depends on is a register or shallow logic
        # of registers (flags below are computed from next-state values), for timing.
        in_row = Signal(_HMAX)
        in_col = Signal(range(W))
        wslot = Signal(nb)              # memory of the row being written
        base_in = Signal(nb)            # memory of row 0 of the frame being input
        hm1_in = Signal(_HMAX)          # height - 1 of the frame being input
        oy = Signal(_HMAX)              # output row of the next column
        flush = Signal()                # producing the last rows of the previous frame
        frem = Signal(range(R + 1))     # flush rows remaining, the current one included
        fc = Signal(range(W))           # flush column
        fbase = Signal(nb)
        fhm1 = Signal(_HMAX)
        at_first = Signal(init=1)       # in_row == 0 and in_col == 0
        at_rend = Signal()              # in_col == W - 1
        at_lrow = Signal()              # in_row == hm1 of the frame being input
        rsmall = Signal(range(R + 1))   # min(in_row, R)
        f_rend = Signal()               # fc == W - 1
        col_le = Signal(init=1)         # in_col <= fc

        frame_end = at_rend & at_lrow
        flush_ends = (frem == 1) & f_rend
        # a new frame's row j (< R) may overwrite column c of the line that held the old
        # frame's row H + j - 2R once the flush has read it there for the last time (output
        # row H + j - R); a frame that ends during a flush ends with it (its own flush next)
        ok_during_flush = (rsmall < R) & (
            (rsmall + frem < R) | ((rsmall + frem == R) & col_le)) & \
            (~frame_end | flush_ends)
        m.d.comb += i.ready.eq(adv & (~flush | ok_during_flush))
        take = i.valid & i.ready
        hm1_port = i.payload.data.hm1

        col_ev = Signal()
        m.d.comb += col_ev.eq(Mux(flush, adv, take & (rsmall == R)))
        ev_c = Mux(flush, fc, in_col)
        ev_base = Mux(flush, fbase, base_in)
        ev_hm1 = Mux(flush, fhm1, hm1_in)

        # where each tap of the column comes from: tap t is row clamp(oy + t - R, 0, hm1)
        taps_sel, taps_stream = [], []
        for t in range(2 * R + 1):
            d = t - R
            if d < 0:
                q = Mux(oy < -d, 0, oy + d)
            elif d > 0:
                # only the flush reaches past the last row (frem rows are left)
                q = Mux(flush & (frem <= d), ev_hm1, oy + d) if d < R else \
                    Mux(flush, ev_hm1, oy + d)    # frem <= R always
            else:
                q = oy
            taps_sel.append((ev_base + q)[:nb])
            taps_stream.append(~flush if d == R else Const(0))
        psel = (ev_base + oy)[:nb - 1] if R > 1 else Const(0, 1)
        S = 2 * Rh
        if P == 1:
            cc = Mux(ev_c >= S, S, ev_c)  # column, saturated (enough for the borders)
        else:
            # at ppc >= 2 the saturated columns are registers of their own, min(in_col, S)
            # and min(fc, S), moved with in_col and fc: the compare ran from in_col through
            # the read address's multiplexer into a carry chain (the whole Ning et al. 2019
            # camera's slowest path at ppc 8, 8.6 ns, 116 MHz); at ppc 1 as it was
            in_cc, f_cc = Signal(range(S + 1)), Signal(range(S + 1))
            cc = Mux(flush, f_cc, in_cc)

        def sat_inc(v):
            return Mux(v == S, S, v + 1)

        # next-state values of the counters (for the registered flags)
        fadv = adv & flush
        n_in_col = Mux(take, Mux(at_rend, 0, in_col + 1), in_col)
        n_fc = Mux(fadv, Mux(f_rend, 0, fc + 1), fc)
        # col_le of the next cycle, from registers only: 4 outcomes, selected by the moves
        le_take = at_rend | (in_col < fc)                        # in_col + 1 <= fc
        le_fadv = Mux(f_rend, is_zero(in_col), col_le | (in_col == fc + 1))
        le_both = at_rend | (~f_rend & col_le)
        m.d.sync += col_le.eq(Mux(take, Mux(fadv, le_both, le_take),
                                  Mux(fadv, le_fadv, col_le)))
        with m.If(adv):
            # the flush first: a frame ending in the flush's last cycle overrides it
            with m.If(flush):
                m.d.sync += [fc.eq(n_fc), f_rend.eq(n_fc == W - 1)]
                if P > 1:
                    m.d.sync += f_cc.eq(Mux(f_rend, 0, sat_inc(f_cc)))
                with m.If(f_rend):
                    with m.If(frem == 1):
                        m.d.sync += [flush.eq(0), oy.eq(0)]
                    with m.Else():
                        m.d.sync += oy.eq(oy + 1)
                    m.d.sync += frem.eq(frem - 1)
            with m.If(take):
                m.d.sync += [in_col.eq(n_in_col), at_rend.eq(n_in_col == W - 1),
                             at_first.eq(0)]
                if P > 1:
                    m.d.sync += in_cc.eq(Mux(at_rend, 0, sat_inc(in_cc)))
                with m.If(at_first):
                    m.d.sync += [base_in.eq(wslot), hm1_in.eq(hm1_port),
                                 at_lrow.eq(is_zero(hm1_port))]
                with m.If(at_rend):
                    m.d.sync += wslot.eq(wslot + 1)
                    with m.If(at_lrow):
                        m.d.sync += [in_row.eq(0), rsmall.eq(0), at_first.eq(1),
                                     at_lrow.eq(0), flush.eq(1), fc.eq(0), f_rend.eq(0),
                                     fbase.eq(base_in), fhm1.eq(hm1_in),
                                     frem.eq(R if R == 1 else
                                             Mux(hm1_in >= R - 1, R, hm1_in + 1))]
                        if P > 1:
                            m.d.sync += f_cc.eq(0)
                    with m.Else():
                        m.d.sync += [in_row.eq(in_row + 1),
                                     rsmall.eq(Mux(rsmall == R, R, rsmall + 1)),
                                     at_lrow.eq(in_row + 1 == hm1_in)]
                    with m.If(rsmall == R):
                        m.d.sync += oy.eq(oy + 1)
                with m.If((i.payload.first != at_first) | (i.payload.last != at_rend)):
                    m.d.sync += self.marker_error.eq(1)

        # ---- line buffers: read at S0, data two advances later (_LineBuffers); written
        # from S1 (one cycle after the read of the same beat)
        m.submodules[f"{self._name}_lb"] = lb = _LineBuffers(
            taps=N, pays=R if has_pay else 0, depth=W, tap_bits=tap_bits, pay_bits=pay_bits,
            name=self._name, bram=self._bram)
        s1_we = pipe.reg(take, name="we", reset=True)
        s1_waddr = pipe.reg(in_col, name="waddr")
        s1_wslot = pipe.reg(wslot, name="wslot")
        s1_tap = pipe.reg(Value.cast(i.payload.data.tap), shape=unsigned(tap_bits), name="tap")
        s1_pay = pipe.reg(Value.cast(i.payload.data.pay), name="pay") if has_pay else None
        m.d.comb += [lb.adv.eq(own()), lb.rd_addr.eq(Mux(flush, fc, in_col)), lb.w_en.eq(s1_we),
                     lb.w_addr.eq(s1_waddr), lb.w_slot.eq(s1_wslot), lb.w_tap.eq(s1_tap)]
        if has_pay:
            m.d.comb += lb.w_pay.eq(s1_pay)

        s1_valid = pipe.reg(col_ev, name="cv", reset=True)
        s1_cc = pipe.reg(cc, shape=range(2 * Rh + 1), name="cc")
        s1_lastc = pipe.reg(Mux(flush, f_rend, at_rend), name="lastc")
        s1_row0 = pipe.reg(is_zero(oy), name="row0")
        s1_sel = [pipe.reg(s, shape=unsigned(nb), name=f"sel{t}") for t, s in enumerate(taps_sel)]
        s1_str = [pipe.reg(s, shape=1, name=f"str{t}") for t, s in enumerate(taps_stream)]
        s1_psel = pipe.reg(psel, name="psel")
        s1_hm1 = pipe.reg(ev_hm1, name="hm1") if self._carry else None

        # ---- S1b: the line buffers' output register
        tap_rd = [lb.rd_taps[k] for k in range(N)]
        pay_rd = [lb.rd_pays[k] for k in range(R)] if has_pay else []
        s1_tap = pipe.reg(s1_tap, name="tapb")
        s1_valid = pipe.reg(s1_valid, name="cv", reset=True)
        s1_cc, s1_lastc, s1_row0, s1_psel = (pipe.reg(v) for v in (s1_cc, s1_lastc, s1_row0,
                                                                    s1_psel))
        s1_sel = [pipe.reg(v) for v in s1_sel]
        s1_str = [pipe.reg(v) for v in s1_str]
        s1_hm1 = pipe.reg(s1_hm1) if self._carry else None

        # ---- S2: the column with its border rows replicated
        taps = [pipe.reg(Mux(s1_str[t], s1_tap, pick(tap_rd, s1_sel[t])),
                         shape=unsigned(tap_bits),
                         name=f"tap{t}") for t in range(2 * R + 1)]
        pay = pipe.reg(pick(pay_rd, s1_psel) if R > 1 else pay_rd[0],
                       shape=unsigned(pay_bits), name="cpay") if has_pay else None
        meta = {n: pipe.reg(v, name=n, reset=(n == "cv")) for v, n in
                ((s1_valid, "cv"), (s1_cc, "cc"), (s1_lastc, "lastc"), (s1_row0, "row0"))}
        if self._carry:
            meta["hm1"] = pipe.reg(s1_hm1, name="hm1")

        # ---- column reduction, the column's position delayed alongside (_Align)
        col, dc = self._columns(pipe, taps, pay)
        hmeta = self._align(m, own(), meta, dc, "ca")

        # ---- window (_Window): the 2R+1 columns of the next output (beat)
        m.submodules[f"{self._name}_win"] = win = _Window(
            radius=Rh, width=W, col_shape=col.shape(), name=self._name)
        m.d.comb += [win.adv.eq(own()), win.col.eq(col), win.valid.eq(hmeta.cv),
                     win.cc.eq(hmeta.cc), win.lastc.eq(hmeta.lastc), win.row0.eq(hmeta.row0)]
        cols = [win.cols[t] for t in range(2 * Rh + 1)]
        left, right = win.left, win.right
        wreg = P > 1 or self._buf
        if wreg:
            # a register between the window's column select and the first compare
            cols = [pipe.reg(c, name="wc") for c in cols]
            left, right = pipe.reg(left, name="wl"), pipe.reg(right, name="wr")

        val, dw = self._window(pipe, cols, left, right)
        wmeta = {"ov": win.out_valid, "of": win.first, "ol": win.last}
        if self._carry:
            wmeta["hm1"] = hmeta.hm1
        out = self._align(m, own(), wmeta, dw + wreg, "wa")
        if not self._buf:
            dst = o
        else:
            m.submodules[f"{self._name}_obuf"] = buf = AdvanceBuffer(o.payload.shape(),
                                                                     copies=len(en.copies))
            m.d.comb += [c.eq(buf.adv[k]) for k, c in enumerate(en.copies)]
            wiring.connect(m, buf.o_stream, wiring.flipped(o))
            dst = SimpleNamespace(valid=buf.i_valid, payload=buf.i_payload)
        m.d.comb += [dst.valid.eq(out.ov), dst.payload.first.eq(out.of),
                     dst.payload.last.eq(out.ol), dst.payload.data.val.eq(val)]
        if self._carry:
            m.d.comb += dst.payload.data.hm1.eq(out.hm1)
        self.depth = 3 + dc + dw + wreg + self._buf
        return m

    def _align(self, m, adv, values, n, name):
        """``values`` (a dict) delayed ``n`` advances by an :class:`_Align`; its output."""
        m.submodules[f"{self._name}_{name}"] = al = _Align(
            {k: Value.cast(v).shape() for k, v in values.items()}, n,
            reset=("cv", "ov"), name=f"{self._name}_{name}")
        m.d.comb += [al.adv.eq(adv)] + [getattr(al.i, k).eq(v) for k, v in values.items()]
        return al.o

    def _split(self, value, shape):
        """The ``ppc`` lane values of a beat word (lane 0 in the low bits)."""
        n = Shape.cast(shape).width
        return [value[k * n:(k + 1) * n] for k in range(self._ppc)]

    def _columns(self, pipe, taps, pay):
        """``col_fn`` on every lane of a beat column: (beat column value, depth)."""
        if self._ppc == 1:
            col, dc = self._col_fn(pipe, taps, pay)
            return Value.cast(col), dc
        lanes = zip(*(self._split(t, self._tap_shape) for t in taps))
        pays = self._split(pay, self._pay_shape) if pay is not None else [None] * self._ppc
        outs = [self._col_fn(pipe, list(t), p) for t, p in zip(lanes, pays)]
        self._col_shape = Value.cast(outs[0][0]).shape()
        return Cat(*(Value.cast(c) for c, _ in outs)), outs[0][1]

    def _window(self, pipe, cols, left, right):
        """``win_fn`` on every output pixel of a beat: (beat value, depth).

        ``cols`` are the beat columns left, centre, right (ppc > 1) or the 2R+1 pixel
        columns (ppc 1). At ppc > 1 pixel k of the centre beat takes pixel columns
        k-R..k+R: the left beat's last R, the centre's, the right beat's first R, the
        centre beat's pixel 0 (``left``: beat 0 of a row) or pixel ppc-1 (``right``: the
        row's last beat) replicated beyond the row's ends."""
        if self._ppc == 1:
            return self._win_fn(pipe, cols)
        P, R = self._ppc, self._r
        lb, cb, rb = (self._split(c, self._col_shape) for c in cols)
        px = {}
        for a in range(-R, P + R):
            if a < 0:
                px[a] = Mux(left, cb[0], lb[P + a])
            elif a >= P:
                px[a] = Mux(right, cb[P - 1], rb[a - P])
            else:
                px[a] = cb[a]
        outs = [self._win_fn(pipe, [px[k + d] for d in range(-R, R + 1)]) for k in range(P)]
        return Cat(*(Value.cast(v) for v, _ in outs)), outs[0][1]


# ---- the median network and the enhancement arithmetic as column / window functions

def _sorted_layout(bits):
    return data.StructLayout({"lo": bits, "mid": bits, "hi": bits})


def _sort_column(pipe, taps):
    t, mm, b = taps
    lo, mid, hi = run_network(COLUMN_SORT, {"t": t, "m": mm, "b": b}, ["lo", "mid", "hi"],
                              minmax=_minmax, reg=lambda n, v: pipe.reg(v, name=n))
    return lo, mid, hi


def _window_median(pipe, cols, bits):
    env = {}
    for j, c in enumerate(cols):
        v = data.View(_sorted_layout(bits), c)
        env.update({f"lo{j}": v.lo, f"mid{j}": v.mid, f"hi{j}": v.hi})
    med, = run_network(WINDOW_MEDIAN, env, ["med"], minmax=_minmax,
                       reg=lambda n, v: pipe.reg(v, name=n))
    return med


def _median_fns(bits):
    def col_fn(pipe, taps, pay):
        lo, mid, hi = _sort_column(pipe, taps)
        return Cat(lo, mid, hi), len(COLUMN_SORT)

    def win_fn(pipe, cols):
        return _window_median(pipe, cols, bits), len(WINDOW_MEDIAN)
    return col_fn, win_fn


def _stage_a_fns(bits):
    """Median + Laplacian + Sobel magnitude of the 3x3 window (enhance mode, stage A)."""
    lay = data.StructLayout({
        "lo": bits, "mid": bits, "hi": bits,
        "cs": bits + 2,            # t + 2m + b
        "dv": signed(bits + 1),    # b - t
        "mm": bits,                # m
        "tb": bits + 1,            # t + b
    })

    def col_fn(pipe, taps, pay):
        t, mm, b = taps
        lo, mid, hi = _sort_column(pipe, taps)
        tb1 = pipe.reg(t + b, shape=unsigned(bits + 1), name="tb")
        dv1 = pipe.reg(b - t, shape=signed(bits + 1), name="dv")
        mm1 = pipe.reg(mm, name="mm")
        cs2 = pipe.reg(tb1 + (mm1 << 1), shape=unsigned(bits + 2), name="cs")
        tb2, dv2, mm2 = pipe.reg(tb1), pipe.reg(dv1), pipe.reg(mm1)
        cs3, tb3, dv3, mm3 = pipe.reg(cs2), pipe.reg(tb2), pipe.reg(dv2), pipe.reg(mm2)
        v = Signal(lay, name="a_col")
        pipe.m.d.comb += [v.lo.eq(lo), v.mid.eq(mid), v.hi.eq(hi), v.cs.eq(cs3), v.dv.eq(dv3),
                          v.mm.eq(mm3), v.tb.eq(tb3)]
        return v, len(COLUMN_SORT)

    def win_fn(pipe, cols):
        c = [data.View(lay, x) for x in cols]
        sorted_cols = [Cat(x.lo, x.mid, x.hi) for x in c]
        med = _window_median(pipe, sorted_cols, bits)
        wb = bits + 3
        gx = pipe.reg(c[2].cs - c[0].cs, shape=signed(wb), name="gx")
        gyp = pipe.reg(c[0].dv + c[2].dv, shape=signed(wb), name="gyp")
        gyc = pipe.reg(c[1].dv << 1, shape=signed(wb), name="gyc")
        lap_a = pipe.reg((c[1].mm << 2) - c[1].tb, shape=signed(wb), name="lapa")
        lap_b = pipe.reg(c[0].mm + c[2].mm, shape=unsigned(bits + 1), name="lapb")
        agx = pipe.reg(Mux(gx < 0, -gx, gx), shape=unsigned(wb), name="agx")
        gy = pipe.reg(gyp + gyc, shape=signed(wb), name="gy")
        lap = pipe.reg(lap_a - lap_b, shape=signed(wb), name="lap")
        agy = pipe.reg(Mux(gy < 0, -gy, gy), shape=unsigned(wb), name="agy")
        agx3, lap3 = pipe.reg(agx), pipe.reg(lap)
        g = pipe.reg(agx3 + agy, shape=unsigned(wb), name="g")
        lap4 = pipe.reg(lap3)
        g5, lap5 = pipe.reg(g), pipe.reg(lap4)
        out = Signal(_a_out_layout(bits), name="a_out")
        pipe.m.d.comb += [out.med.eq(med), out.lap.eq(lap5), out.g.eq(g5)]
        return out, len(WINDOW_MEDIAN)
    return col_fn, win_fn


def _a_out_layout(bits):
    return data.StructLayout({"med": bits, "lap": signed(bits + 3), "g": bits + 3})


def _pay_layout(bits):
    return data.StructLayout({"med": bits, "lap": signed(bits + 3)})


#: Widest operand chunk of a product in :func:`_mul_add`: one MULT18X18D (18 x 18 signed;
#: an unsigned chunk is 17 bits, 18 as signed).
_DSP_BITS = 18
_CHUNK = _DSP_BITS - 1

#: Register stages of :func:`_mul_add`: the chunk products, two sums of partial terms, their
#: sum.
MUL_ADD_STAGES = 3


def _chunks(x):
    """``x`` (a value or an int >= 0) as ``[(chunk, shift)]``, each chunk fitting one
    MULT18X18D operand: a value of at most 18 bits (17 unsigned) whole, else its low 17 bits
    (unsigned) and the rest (with ``x``'s sign); an int in 17-bit pieces, zero pieces left
    out."""
    if isinstance(x, int):
        out, sh = [], 0
        while x:
            if x & ((1 << _CHUNK) - 1):
                out.append((x & ((1 << _CHUNK) - 1), sh))
            x, sh = x >> _CHUNK, sh + _CHUNK
        return out
    x = Value.cast(x)
    sh = x.shape()
    if len(x) <= (_DSP_BITS if sh.signed else _CHUNK):
        return [(x, 0)]
    hi = x[_CHUNK:].as_signed() if sh.signed else x[_CHUNK:]
    assert len(hi) <= (_DSP_BITS if sh.signed else _CHUNK), "operand wider than 2 chunks"
    return [(x[:_CHUNK], 0), (hi, _CHUNK)]


def _mul_add(pipe, a, b, name, extra=None):
    """``a * b (+ extra)`` in :data:`MUL_ADD_STAGES` register stages, every multiplier one
    MULT18X18D between two registers (``a`` and ``extra`` must be registers or wiring of
    registers, ``b`` too or an int).

    Stage 1: the products of ``a``'s and ``b``'s chunks (:func:`_chunks`) and ``extra``,
    registered; stage 2: two sums of about half the terms each, shifted into place; stage 3:
    their sum, in the shape of ``a * b + extra`` (exact: no bit of any term is lost).
    """
    prod = Value.cast(a) * b
    shape = (prod if extra is None else prod + extra).shape()
    wide = signed(shape.width + 2)
    terms = [(pipe.product(ca, cb, name=f"{name}p"), sa + sb)
             for ca, sa in _chunks(a) for cb, sb in _chunks(b)]
    if extra is not None:
        terms.append((pipe.reg(extra, name=f"{name}x"), 0))
    half = (len(terms) + 1) // 2

    def total(ts):
        v = Const(0, 1)
        for t, sh in ts:
            v = v + (t << sh)
        return v
    lo = pipe.reg(total(terms[:half]), shape=wide, name=f"{name}s")
    hi = pipe.reg(total(terms[half:]), shape=wide, name=f"{name}s")
    return pipe.reg(lo + hi, shape=shape, name=name)


def _add_tree(pipe, vals, width, name, plus=0):
    """The sum of 5 values (+ a constant ``plus``, added to the fifth in the first stage)
    in 3 register stages, one adder deep each."""
    a = pipe.reg(vals[0] + vals[1], shape=unsigned(width), name=name)
    b = pipe.reg(vals[2] + vals[3], shape=unsigned(width), name=name)
    e = pipe.reg(vals[4] + plus, shape=unsigned(width), name=name) if plus else \
        pipe.reg(vals[4], name=name)
    ab = pipe.reg(a + b, shape=unsigned(width), name=name)
    e2 = pipe.reg(e, name=name)
    return pipe.reg(ab + e2, shape=unsigned(width), name=name)


def _stage_b_fns(bits, gain, shift):
    """5x5 box sum of the gradient, mean, mask and final add (enhance mode, stage B), at
    every ``ppc`` with every multiplier between two registers (:func:`_wide_b_window`; at
    ppc 1 the multiplies once shared a stage with their carry chains: the Ning et al. 2019
    chain's slowest path after its median went to 1 pixel per clock)."""
    gb = bits + 3
    play = _pay_layout(bits)
    clay = data.StructLayout({"v": gb + 3, "pay": play})

    def col_fn(pipe, taps, pay):
        v = _add_tree(pipe, taps, gb + 3, "vs")
        p = pipe.delay(data.View(play, pay), 3, name="bpay")
        col = Signal(clay, name="b_col")
        pipe.m.d.comb += [col.v.eq(v), col.pay.eq(p)]
        return col, 3

    return col_fn, _wide_b_window(bits, gain, shift, clay)


#: Register stages of stage B's window function at ppc >= 2 (:func:`_wide_b_window`).
WIDE_B_STAGES = 3 + 2 * MUL_ADD_STAGES + 1


def _wide_b_window(bits, gain, shift, clay):
    """Stage B's window function with every multiplier between two registers (a chain
    meets 150 MHz only so), :data:`WIDE_B_STAGES` = 10 stages; ``clay`` the layout of the
    column values.

    The same integers as the golden model, regrouped exactly: box sum + 12 (3 stages, the
    12 added in the first); ``gmean = (box12 * k) >> s`` and, beside it, ``lapg = lap *
    gain`` (:func:`_mul_add`, 3 each); ``tot = (lapg * gmean + (med << shift) + rnd) >>
    shift`` (3; ``med * 2**shift + rnd`` is ``med`` and ``rnd``'s bits side by side, and
    ``floor((m 2**s + x + r) / 2**s) = m + floor((x + r) / 2**s)``); the clamp (1)."""
    full = (1 << bits) - 1
    gb = bits + 3
    k, s = reciprocal_25(200 * full + 12)
    rnd = (1 << (shift - 1)) if shift else 0

    def win_fn(pipe, cols):
        c = [data.View(clay, x) for x in cols]
        box12 = _add_tree(pipe, [x.v for x in c], gb + 5, "box", plus=12)       # 3 stages
        pay = pipe.delay(c[2].pay, 3, name="wpay")
        gsum = _mul_add(pipe, box12, k, "gsum")                                # 6
        gmean = gsum[s:s + gb]
        lapg = _mul_add(pipe, pay.lap, gain, "lapg")                           # 6
        med = pipe.delay(pay.med, MUL_ADD_STAGES, name="bmed")
        tsum = _mul_add(pipe, lapg, gmean, "tsum",
                        extra=Cat(Const(rnd, shift), med) if shift else med)   # 9
        tot = tsum >> shift
        out = pipe.reg(Mux(tot < 0, 0, Mux(tot > full, full, tot)), shape=unsigned(bits),
                       name="clamp")                                            # 10
        return out, WIDE_B_STAGES
    return win_fn


class Median3(wiring.Component):
    """3x3 median filter, replicated borders, 1-8 pixels/clock; optional edge enhancement.

    Equals :func:`tdicam.model.median3.median3` bit for bit (``scipy.ndimage.median_filter
    (frame, size=3, mode="nearest")`` without ``enhance``).

    Parameters
    ----------
    width : int
        Pixels per line, ``3 ppc``..8192 and a multiple of ``ppc`` (elaboration: it sizes
        the line buffers).
    pixel_bits : int
        Input and output pixel width, 8..16.
    enhance : bool
        Add the edge-enhancement detail of :func:`~tdicam.model.median3.median3`.
    enhance_gain : int
        0..255 (only with ``enhance``).
    enhance_shift : int or None
        0..48, ``None`` = ``pixel_bits + 2`` (only with ``enhance``).
    ppc : int
        Pixels per clock: 1, 2, 4 or 8. A beat carries ``ppc`` consecutive pixels of a row,
        element 0 the leftmost (TDATA = ``ppc`` pixels, as ``tdi``); ``first`` (TUSER) on
        a frame's first beat, ``last`` (TLAST) on a row's last. The filter, its borders
        and the enhancement do not depend on it: the output equals the golden model at
        every ppc.
    bram : {"generic", "ecp5"}
        How the line buffers are described (:data:`BRAMS`): ``"generic"`` memories (what
        ``tdicam verilog`` writes and every simulation runs) or, in the ECP5 synthesis top
        (``tdicam synth``), DP16KD instances whose output register is the line buffers'
        output register (:func:`tdicam.hdl.vendor.ecp5_bram.pipe_bank`; without it the
        block RAM's 4.1 ns clock-to-out and the routing to a fabric register were the orbit
        chain's slowest path). The same latency and cycle behaviour either way; any other
        value is a one-line :class:`~tdicam.errors.TdicamError`.
    dsp : {"generic", "ecp5"}
        How the enhancement's products are registered (:attr:`DSPS`): in the fabric after a
        ``*`` (``"generic"``, what ``tdicam verilog`` writes) or, in the ECP5 synthesis top,
        in each MULT18X18D's own output register (:func:`tdicam.hdl.vendor.ecp5_dsp.mult`;
        with the product register in the fabric the route out of the DSP block and back
        was Ning et al. 2019's chain's slowest path at ppc 8, 6.7 ns). The same latency and
        cycles either way; a simulator of the ECP5 top needs
        :mod:`tdicam.cosim.mult18x18d`.

    Attributes
    ----------
    i_stream : In(pixel stream of ``ppc`` x ``unsigned(pixel_bits)``)
    o_stream : Out(pixel stream of ``ppc`` x ``unsigned(pixel_bits)``)
        Same frame geometry as the input; ``first`` on beat (0, 0) of each frame,
        ``last`` on the last beat of each line.
    height : In(16)
        Rows of the frame, run time; sampled with the frame's first pixel (``first``), so it
        may change from frame to frame. 0 counts as 1. The block must know which row is a
        frame's last to replicate it, and it then finishes the frame on its own: no output
        waits for the next frame.
    marker_error : Out(1)
        Sticky (until reset): an accepted input beat had ``first``/``last`` where the
        block's own counters (``width``, ``height``) did not, or lacked them where they did.
        Geometry always comes from ``width``/``height``; the input markers are only checked.

    Notes
    -----
    **Latency.** Without ``enhance``, output pixel (y, x) becomes valid :attr:`latency`
    = 11 cycles after input pixel (min(y+1, H-1), min(x+1, W-1)) was accepted, when nothing
    stalls (one more cycle for x = W-1, produced by a pad step; the last row comes from the
    flush, which starts the cycle after the frame's last pixel): register stages are line
    buffer read (1), its output register (1), column with border rows (1), column sort (3),
    window median (5). With ``enhance`` the Laplacian/gradient stage (11 stages) feeds the
    5x5 stage (line buffers 2, column 1, vertical sum 3, horizontal sum 3, mean 3, mask 3
    with the add, clamp 1 = 16 stages, every multiplier between two registers:
    :func:`_wide_b_window`; at 8 pixels per clock a multiplier and its carry chain in one
    cycle cost the chain 60 MHz), each stage with a window register and an output buffer
    (1 + 1, see below): output (y, x) is valid 31 cycles after input (min(y+3, H-1),
    min(x+3, W-1)). At
    ``ppc`` 2, 4, 8 the cycle counts hold per beat: output beat (y, b) is valid
    :attr:`latency` cycles after input beat (min(y+1, H-1), min(b+1, W/ppc-1)), with
    ``enhance`` (min(y+3, H-1), min(b+2, W/ppc-1)) (each neighbourhood reaches one beat to
    the right); 13 without ``enhance``, 31 with it: each neighbourhood has a register after
    its window's column select and ends in an output buffer (1 + 1 each,
    :class:`~tdicam.hdl.interfaces.stream.AdvanceBuffer`, see below).

    **Throughput and backpressure.** One beat (``ppc`` pixels) per clock in and out,
    across rows and frames (the borders of one frame overlap the start of the next). One
    exception, with ``enhance`` only: a frame of a single row arriving while the 5x5 stage
    still produces the previous frame's last two rows waits for them (at most ``width /
    ppc`` cycles). Each neighbourhood's pipeline moves on one ``advance``: at ``ppc`` 1
    ``~o_stream.valid | o_stream.ready``; at ``ppc`` 2, 4, 8 a register, set while the
    neighbourhood's 3-beat output buffer has room for the beat its pipeline may push next
    (:class:`~tdicam.hdl.interfaces.stream.AdvanceBuffer`), so no combinational path runs
    from ``o_stream.ready`` to the thousands of clock enables or to ``i_stream.ready``
    (with the ready in the enables median3 --enhance at 8 pixels per clock closed at 96
    MHz). With ``enhance`` both neighbourhoods move so at ``ppc`` 1 too (each one's output
    buffer and window register add two cycles; the first's column select and first compare
    in one cycle, and the 5x5 stage's output valid through its ready into its sequencer,
    were each the Ning et al. 2019 chain's slowest path at ppc 8, 6.7-6.9 ns): with the
    first's advance combinational, the 5x5
    stage's input ready reached its clock enables in one cycle (Ning et al. 2019's chain
    at 8 pixels per clock, median3 at 1 after TDI: 6.9 ns; behind a register slice, the
    slice's full flag fanned out to them instead, 7.5 ns). ``i_stream.ready`` is
    ``advance`` and, while the previous frame's last rows are being produced, the condition that the new frame does not overwrite a line still
    needed. No pixel is lost or duplicated whatever ``ready`` does.

    **Memory.** Plain median: 2 line buffers of ``width`` x ``pixel_bits``. With
    ``enhance`` in addition: 4 lines of the gradient (``pixel_bits + 3``) for the 5x5 mean
    and 2 lines of the centre pixel's median and Laplacian (``2 pixel_bits + 3``), i.e.
    ``width * (10 pixel_bits + 18)`` bits in total (1280 x 12 bits: 176,640 bits). The
    same bits at every ``ppc``: each line buffer is ``width / ppc`` words of ``ppc``
    values.

    **Errors.** ``ppc`` not 1, 2, 4, 8, a width below ``3 ppc`` or not a multiple of
    ``ppc``: one-line :class:`~tdicam.errors.TdicamError` naming the values
    (:func:`check_geometry`).

    **Reset** (synchronous) clears the pipeline and the counters: the next pixel accepted
    is pixel (0, 0) of a new frame. Line buffer contents are never read before they are
    written within the same frame, so nothing leaks across frames or resets.
    """

    #: Product registers (``dsp=``): ``"generic"`` (fabric registers after a ``*``) or
    #: ``"ecp5"`` (each MULT18X18D's output register): the same values and cycles.
    DSPS = ecp5_dsp.DSPS

    def __init__(self, *, width=1280, pixel_bits=12, enhance=False, enhance_gain=1,
                 enhance_shift=None, ppc=1, bram="generic", dsp="generic"):
        self._ppc, self._width = check_geometry(width, ppc)
        self._bram = check_choice("bram", bram, BRAMS)
        self._dsp = check_choice("dsp", dsp, self.DSPS)
        self._bits = check_range("pixel_bits", pixel_bits, 8, 16)
        if not isinstance(enhance, bool):
            raise TdicamError(f"enhance must be true or false, got {enhance!r}")
        self._enhance = enhance
        self._gain = check_range("enhance_gain", enhance_gain, 0, MAX_GAIN)
        shift = default_enhance_shift(pixel_bits) if enhance_shift is None else enhance_shift
        self._shift = check_range("enhance_shift", shift, 0, MAX_SHIFT)
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, ppc))),
            "o_stream": Out(pixel_signature(channels_shape(pixel_bits, ppc))),
            "height": In(unsigned(_HMAX)),
            "marker_error": Out(unsigned(1)),
        })

    @property
    def width(self):
        return self._width

    @property
    def pixel_bits(self):
        return self._bits

    @property
    def ppc(self):
        """Pixels per clock (per beat)."""
        return self._ppc

    @property
    def enhance(self):
        return self._enhance

    bram = property(lambda self: self._bram, doc="Line-buffer description, a key of "
                                                 ":data:`BRAMS`.")
    dsp = property(lambda self: self._dsp, doc="Product registers, one of :attr:`DSPS`.")

    @property
    def enhance_gain(self):
        return self._gain

    @property
    def enhance_shift(self):
        return self._shift

    @property
    def latency(self):
        """Register stages from the input beat that completes a window to its output: 11
        at ``ppc`` 1, 13 at ``ppc`` 2, 4, 8; with ``enhance`` 31 at every ``ppc`` (every
        multiplier between two registers; each neighbourhood has 2 more than the plain
        median's at ppc 1: a register after its window's column select and its output
        buffer)."""
        # each neighbourhood's window register and AdvanceBuffer
        wide = 2 * int(self._ppc > 1 or self._enhance)
        plain = 3 + len(COLUMN_SORT) + len(WINDOW_MEDIAN) + wide
        if not self._enhance:
            return plain
        return plain + 3 + 3 + WIDE_B_STAGES + wide

    @property
    def line_buffer_bits(self):
        """Bits of line-buffer memory (see Notes)."""
        b, w = self._bits, self._width
        return w * (10 * b + 18) if self._enhance else 2 * w * b

    def elaborate(self, platform):
        m = Module()
        b, w, P = self._bits, self._width, self._ppc
        i, o = self.i_stream, self.o_stream
        hm1 = Mux(is_zero(self.height), 0, self.height - 1)
        if not self._enhance:
            col_fn, win_fn = _median_fns(b)
            m.submodules.a = a = _Neighbourhood(
                radius=1, width=w, tap_shape=unsigned(b), pay_shape=None,
                out_shape=unsigned(b), col_fn=col_fn, win_fn=win_fn, name="a", ppc=P,
                bram=self._bram, dsp=self._dsp)
            last = a
        else:
            col_fn, win_fn = _stage_a_fns(b)
            m.submodules.a = a = _Neighbourhood(
                radius=1, width=w, tap_shape=unsigned(b), pay_shape=None,
                out_shape=_a_out_layout(b), col_fn=col_fn, win_fn=win_fn, carry_hm1=True,
                name="a", ppc=P, bram=self._bram, buffered=True, dsp=self._dsp)
            col_fn, win_fn = _stage_b_fns(b, self._gain, self._shift)
            m.submodules.b = bb = _Neighbourhood(
                radius=2, width=w, tap_shape=unsigned(b + 3), pay_shape=_pay_layout(b),
                out_shape=unsigned(b), col_fn=col_fn, win_fn=win_fn, name="b", ppc=P,
                bram=self._bram, buffered=True, dsp=self._dsp)
            ao, bi = a.o_stream, bb.i_stream
            m.d.comb += [
                bi.valid.eq(ao.valid), ao.ready.eq(bi.ready),
                bi.payload.first.eq(ao.payload.first), bi.payload.last.eq(ao.payload.last),
            ]
            lanes = (lambda v: [v]) if P == 1 else (lambda v: [v[k] for k in range(P)])
            for av, bt, bp in zip(lanes(ao.payload.data.val), lanes(bi.payload.data.tap),
                                  lanes(bi.payload.data.pay)):
                m.d.comb += [bt.eq(av.g), bp.med.eq(av.med), bp.lap.eq(av.lap)]
            m.d.comb += bi.payload.data.hm1.eq(ao.payload.data.hm1)
            last = bb
        ai = a.i_stream
        m.d.comb += [
            ai.valid.eq(i.valid), i.ready.eq(ai.ready),
            ai.payload.first.eq(i.payload.first), ai.payload.last.eq(i.payload.last),
            ai.payload.data.tap.eq(i.payload.data), ai.payload.data.hm1.eq(hm1),
            o.valid.eq(last.o_stream.valid), last.o_stream.ready.eq(o.ready),
            o.payload.first.eq(last.o_stream.payload.first),
            o.payload.last.eq(last.o_stream.payload.last),
            o.payload.data.eq(last.o_stream.payload.data.val),
            self.marker_error.eq(a.marker_error),
        ]
        return m
