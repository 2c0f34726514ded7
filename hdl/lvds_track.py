"""Eye tracking of a locked LVDS lane (issue 46 step 5, beyond Ning et al. 2019 §4.1).

A second sampler per lane (the *monitor*: in a device the slave delay line of a
master/slave IDELAYE2 pair, as litevideo's ``S7DataCapture`` and AMD XAPP860's window
monitoring use it) probes the eye at ``tap - margin`` and ``tap + margin`` in turn while the
data sampler keeps delivering words at ``tap``: the monitor's words, through a gearbox with
the data's slip, are compared with the data words. When the low probe disagrees and the high
one agrees the eye has moved up: the data tap steps up by one (and down the other way).
Inside the eye two neighbouring taps sample the same bits, so a step loses no word. The
exact timing and the golden model are :mod:`tdicam.model.lvds_track`.
"""

from amaranth.hdl import Array, Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_range
from tdicam.model.lvds import N_TAPS
from tdicam.model.lvds_track import COUNT_BITS, probe_words

__all__ = ["LaneTracker"]


class LaneTracker(wiring.Component):
    """The tracker of one lane (word clock).

    Parameters
    ----------
    word_bits : 10 or 12
    settle : int
        The trainer's; the monitor's words are compared from ``settle + 2`` words after its
        load (its delay, the deserializer, the gearbox and the two stages).
    margin : int, 1..15
        Probe distance from the data tap (taps).

    Attributes
    ----------
    locked : In(1)
        The trainer's ``locked``: the tracker runs while it is high (idle and cleared else).
    tap, slip : In(5), In(4)
        The data tap and slip (the trainer's).
    word : In(word_bits)
        The trainer's aligned data word (its ``word``: the gearbox output 2 cycles earlier).
    mon_raw : In(word_bits)
        The monitor deserializer's word.
    n_check : In(8)
        Words compared per probe (0 counts as 1).
    mon_tap, mon_ld : Out(5), Out(1)
        The monitor's tap (clamped to 0..31) and its load strobe (the first cycle of each
        probe).
    up, down : Out(1)
        Step the data tap (one cycle; never both; never past 0 or 31).
    count : Out(8)
        Corrections made since lock (wraps).
    """

    def __init__(self, *, word_bits=10, settle=8, margin=4):
        self._w, self._settle = word_bits, settle
        self._margin = check_range("track_margin", margin, 1, 15)
        super().__init__({
            "locked": In(1), "tap": In(5), "slip": In(4), "word": In(word_bits),
            "mon_raw": In(word_bits), "n_check": In(8),
            "mon_tap": Out(5), "mon_ld": Out(1), "up": Out(1), "down": Out(1),
            "count": Out(COUNT_BITS),
        })

    @property
    def margin(self):
        return self._margin

    def elaborate(self, platform):
        m = Module()
        w, settle, mg = self._w, self._settle, self._margin
        prev = Signal(w)
        m.d.sync += prev.eq(self.mon_raw)
        both = Cat(self.mon_raw, prev)
        g = Array([both[w - s:2 * w - s] for s in range(w)]
                  + [both[:w]] * (16 - w))[self.slip]
        m_a, m_b = Signal(w), Signal(w)
        m.d.sync += [m_a.eq(g), m_b.eq(m_a)]
        n_eff = Mux(self.n_check.any(), self.n_check, 1)
        top = probe_words(settle, 255)
        cnt = Signal(range(top + 1))
        side, fail, fail_lo = Signal(), Signal(), Signal()
        first = settle + 2
        in_win = (cnt >= first) & (cnt < first + n_eff)
        last = cnt == first + n_eff
        lo = Mux(self.tap >= mg, self.tap - mg, 0)
        hi = Mux(self.tap <= N_TAPS - 1 - mg, self.tap + mg, N_TAPS - 1)
        m.d.comb += [self.mon_tap.eq(Mux(side, hi, lo)),
                     self.mon_ld.eq(self.locked & (cnt == 0))]
        with m.If(~self.locked):
            m.d.sync += [cnt.eq(0), side.eq(0), fail.eq(0), fail_lo.eq(0),
                         self.count.eq(0)]
        with m.Else():
            m.d.sync += cnt.eq(cnt + 1)
            with m.If(in_win & (self.word != m_b)):
                m.d.sync += fail.eq(1)
            with m.If(last):
                m.d.sync += [cnt.eq(0), fail.eq(0), side.eq(~side)]
                with m.If(~side):
                    m.d.sync += fail_lo.eq(fail)
                with m.Else():
                    up = fail_lo & ~fail & (self.tap != N_TAPS - 1)
                    down = ~fail_lo & fail & (self.tap != 0)
                    m.d.comb += [self.up.eq(up), self.down.eq(down)]
                    with m.If(up | down):
                        m.d.sync += self.count.eq(self.count + 1)
        return m
