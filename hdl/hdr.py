"""High/low-gain HDR merge (Ning et al. 2019 §4.4.2); golden model
:func:`tdicam.model.hdr.hdr` (its docstring defines the arithmetic and the frame state)."""

from amaranth.hdl import Array, Cat, Const, Module, Mux, Signal, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.model.hdr import DEFAULT_GAINS, hdr_config
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import quiet_reject

__all__ = ["Hdr"]


class Hdr(wiring.Component):
    """Merge HG and LG pixels of one exposure; junction measured on the previous frame.

    Parameters
    ----------
    pixel_bits, threshold, band, gain_pairs, slope_frac_bits, lgt_frac_bits, anchor,
    count_bits, out_bits
        As :func:`tdicam.model.hdr.hdr` (same names, units and defaults).

    Attributes
    ----------
    i_stream : In(pixel stream)
        ``data[0]`` = HG, ``data[1]`` = LG, ``pixel_bits`` each (tdata: HG in the low
        element, LG in the next, each padded to whole bytes).
    o_stream : Out(pixel stream)
        ``data`` = merged pixel, ``out_bits`` wide, clamped; ``first``/``last`` pass through.
    gain_sel : In(sel_bits), only when ``gain_pairs`` has two or more pairs
        Index of the programmed gain pair; sampled when a frame's first pixel (``first``) is
        accepted and used for that whole frame.

    Notes
    -----
    Pixel pipeline: four register stages (junction subtract, multiply, sum with rounding,
    clamp/select) advancing together when the output register is empty or taken;
    :attr:`latency` = 4
    cycles, 1 pixel/clock.

    Band statistics are updated one cycle after a pixel is accepted (registered band
    decision). Frame start: when a pixel with ``first`` is presented and the previous frame
    had band pixels, ``i_stream.ready`` stays low for :attr:`frame_start_cycles` cycles
    while two restoring dividers (one quotient bit per cycle, ``pixel_bits + lgt_frac_bits``
    bits) turn the band sums into ``L_T`` and ``H_T``; the pixel is then accepted with them.
    Pixels of the previous frame still in the pipeline are unaffected (each carries its own
    junction values). With an empty band there is no stall. Pixels before the first ``first`` after
    reset are merged with the reset values and counted as a frame.
    """

    @quiet_reject
    def __init__(self, *, pixel_bits=12, threshold=None, band=None, gain_pairs=DEFAULT_GAINS,
                 slope_frac_bits=8, lgt_frac_bits=4, anchor="band", count_bits=24,
                 out_bits=None):
        self._cfg = cfg = hdr_config(
            pixel_bits=pixel_bits, threshold=threshold, band=band, gain_pairs=gain_pairs,
            slope_frac_bits=slope_frac_bits, lgt_frac_bits=lgt_frac_bits, anchor=anchor,
            count_bits=count_bits, out_bits=out_bits)
        members = {
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, 2))),
            "o_stream": Out(pixel_signature(unsigned(cfg.out_bits))),
        }
        if cfg.sel_bits:
            members["gain_sel"] = In(unsigned(cfg.sel_bits))
        super().__init__(members)

    @property
    def config(self):
        """The resolved :class:`~tdicam.model.hdr.HdrConfig` (tables included)."""
        return self._cfg

    pixel_bits = property(lambda self: self._cfg.pixel_bits)
    threshold = property(lambda self: self._cfg.threshold)
    band = property(lambda self: self._cfg.band)
    gain_pairs = property(lambda self: self._cfg.gain_pairs)
    slope_frac_bits = property(lambda self: self._cfg.slope_frac_bits)
    lgt_frac_bits = property(lambda self: self._cfg.lgt_frac_bits)
    anchor = property(lambda self: self._cfg.anchor)
    count_bits = property(lambda self: self._cfg.count_bits)
    out_bits = property(lambda self: self._cfg.out_bits)

    @property
    def latency(self):
        """Cycles from an input transfer to the corresponding output being valid."""
        return 4

    @property
    def frame_start_cycles(self):
        """Cycles ``i_stream.ready`` is held low at a frame start after a non-empty band
        (last pixel counted, divider load, one per quotient bit, write-back)."""
        return self._cfg.lt_bits + 3

    def elaborate(self, platform):
        m = Module()
        cfg = self._cfg
        i, o = self.i_stream, self.o_stream
        pb, f, sf, cb = cfg.pixel_bits, cfg.lgt_frac_bits, cfg.slope_frac_bits, cfg.count_bits
        q = cfg.lt_bits
        t = cfg.threshold
        top = (1 << cfg.out_bits) - 1
        hg, lg = i.payload.data[0], i.payload.data[1]

        slopes = Array(Const(s, cfg.slope_bits) for s in cfg.slopes)
        seeds = Array(Const(s, q) for s in cfg.seeds)
        if not cfg.sel_bits:  # one gain pair: constants, no table
            slopes, seeds = [slopes[0]], [seeds[0]]

        # ---- frame state
        cur = Signal(max(cfg.sel_bits, 1))
        lt = Signal(q, init=cfg.seeds[0])
        ht = Signal(q, init=cfg.h_seed)
        sum_l, sum_h = Signal(pb + cb), Signal(pb + cb)
        n = Signal(cb)

        # ---- junction values for the pixel being accepted
        first = i.payload.first
        sel_now = self.gain_sel if cfg.sel_bits else 0
        reseed = first & (sel_now != cur) if cfg.sel_bits else Const(0, 1)
        sel_eff = Mux(first, sel_now, cur) if cfg.sel_bits else 0
        lt_eff = Mux(reseed, seeds[sel_now], lt)
        ht_eff = Mux(reseed, cfg.h_seed, ht)

        # ---- frame start: band means by two restoring dividers
        busy = Signal()
        cnt = Signal(range(q + 1))
        rem_l, rem_h = Signal(cb + 1), Signal(cb + 1)
        num_l, num_h = Signal(q), Signal(q)
        quo_l, quo_h = Signal(q), Signal(q)
        # band statistics run one stage behind the accepted pixel (timing): s_* hold the
        # pixel accepted last cycle, not yet counted; n_nz is n != 0 once it is counted
        s_v, s_first, s_band = Signal(), Signal(), Signal()
        s_hg, s_lg = Signal(pb), Signal(pb)
        n_nz = Mux(s_v, s_band | (~s_first & (n != 0)), n != 0)
        need_div = i.valid & first & n_nz
        load = Signal()
        divs = [(rem_l, num_l, quo_l, sum_l)]
        if cfg.anchor == "band":  # H_T = T otherwise: no HG statistics at all
            divs.append((rem_h, num_h, quo_h, sum_h))

        en = Signal()
        m.d.comb += [
            en.eq(~o.valid | o.ready),
            i.ready.eq(en & ~busy & ~need_div),
        ]
        # numerator (sum << f) + n // 2 < n << q: its bits above q start the remainder
        starts = []
        for rem, num, _, total in divs:
            numer = Signal(pb + cb + f)
            m.d.comb += numer.eq((total << f) + (n >> 1))
            starts += [rem.eq(numer[q:]), num.eq(numer[:q])]
        with m.If(load):  # statistics complete: the stage emptied while ready was low
            m.d.sync += [load.eq(0), cnt.eq(q), *starts]
        with m.Elif(busy):
            with m.If(cnt != 0):
                m.d.sync += cnt.eq(cnt - 1)
                for rem, num, quo, _ in divs:
                    trial = Cat(num[q - 1], rem)
                    ge = trial >= n
                    m.d.sync += [
                        rem.eq(Mux(ge, trial - n, trial)),
                        quo.eq(Cat(ge, quo[:q - 1])),
                        num.eq(num << 1),
                    ]
            with m.Else():  # write back; n = 0 lets the waiting first pixel in
                m.d.sync += [busy.eq(0), lt.eq(quo_l), n.eq(0),
                             ht.eq(quo_h if len(divs) == 2 else cfg.h_seed)]
        with m.Elif(need_div):
            m.d.sync += [busy.eq(1), load.eq(1)]

        # ---- band statistics and frame registers, on accepted pixels
        in_band = (hg < t) if t == cfg.band else (hg >= t - cfg.band) & (hg < t)
        m.d.sync += [s_v.eq(i.valid & i.ready), s_first.eq(first), s_band.eq(in_band),
                     s_hg.eq(hg), s_lg.eq(lg)]
        with m.If(i.valid & i.ready & first):
            m.d.sync += [cur.eq(sel_now), lt.eq(lt_eff), ht.eq(ht_eff)]
        take = s_band & (n != cfg.count_max)
        with m.If(s_v & (s_first | take)):  # a frame's first pixel restarts the statistics
            m.d.sync += [
                sum_l.eq(Mux(s_first, 0, sum_l) + Mux(take, s_lg, 0)),
                sum_h.eq(Mux(s_first, 0, sum_h) + Mux(take, s_hg, 0)),
                n.eq(Mux(s_first, 0, n) + take),
            ]

        # ---- pixel pipeline (global enable)
        v1, f1, l1, below1 = Signal(), Signal(), Signal(), Signal()
        hg1, d1 = Signal(pb), Signal(signed(pb + f + 1))
        ht1, s1 = Signal(q), Signal(cfg.slope_bits)
        v2, f2, l2, below2 = Signal(), Signal(), Signal(), Signal()
        hg2, ht2 = Signal(pb), Signal(q)
        p2 = Signal(signed(pb + f + 1 + cfg.slope_bits + 1))

        sh = f + sf
        acc = (ht2 << sf) + p2
        if sh:
            acc = acc + (1 << (sh - 1))
        v3, f3, l3, below3, hg3 = Signal(), Signal(), Signal(), Signal(), Signal(pb)
        acc3 = Signal(signed(acc.shape().width))
        y = acc3 >> sh  # flooring shift: round half up together with the added half
        sat = Mux(y < 0, 0, Mux(y > top, top, y))

        with m.If(en):
            m.d.sync += [
                v1.eq(i.valid & i.ready), f1.eq(first), l1.eq(i.payload.last),
                below1.eq(hg < t), hg1.eq(hg),
                d1.eq((lg << f) - lt_eff), ht1.eq(ht_eff), s1.eq(slopes[sel_eff]),
                v2.eq(v1), f2.eq(f1), l2.eq(l1), below2.eq(below1), hg2.eq(hg1), ht2.eq(ht1),
                p2.eq(d1 * s1),
                v3.eq(v2), f3.eq(f2), l3.eq(l2), below3.eq(below2), hg3.eq(hg2), acc3.eq(acc),
                o.valid.eq(v3), o.payload.first.eq(f3), o.payload.last.eq(l3),
                o.payload.data.eq(Mux(below3, hg3, sat)),
            ]
        return m
