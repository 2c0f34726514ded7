"""High/low-gain HDR merge (Ning et al. 2019 §4.4.2); golden model
:func:`tdicam.model.hdr.hdr` (its docstring defines the arithmetic and the frame state)."""

from amaranth.hdl import Array, Cat, Const, Module, Mux, Signal, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_choice
from tdicam.model.hdr import DEFAULT_GAINS, hdr_config
from tdicam.beats import PPC_CHOICES
from tdicam.hdl.interfaces.stream import channels_shape, pixel_signature
from tdicam.hdl.util import quiet_reject
from tdicam.hdl.vendor import ecp5_dsp

__all__ = ["Hdr"]


class Hdr(wiring.Component):
    """Merge HG and LG pixels of one exposure; junction measured on the previous frame.

    Parameters
    ----------
    pixel_bits, threshold, band, gain_pairs, slope_frac_bits, lgt_frac_bits, anchor,
    count_bits, out_bits
        As :func:`tdicam.model.hdr.hdr` (same names, units and defaults).
    ppc : int
        Pixels per clock (per beat): 1, 2, 4 or 8 (default 1). The golden model does not
        know it: the output equals :func:`~tdicam.model.hdr.hdr` at every ppc.
    dsp : str
        ``"generic"`` (default: a ``*`` between fabric registers) or ``"ecp5"`` (the ECP5
        synthesis top: each lane's junction difference and the slope are a signed
        MULT18X18D's own input registers, the product register in the fabric,
        :mod:`tdicam.hdl.vendor.ecp5_dsp`, when they fit one (a difference ``pixel_bits +
        lgt_frac_bits + 1`` <= 18 bits, a slope <= 17 bits; otherwise the generic
        multiply); the same cycles, a simulator needs :mod:`tdicam.cosim.mult18x18d`).

    Attributes
    ----------
    i_stream : In(pixel stream of ``2 * ppc`` x ``pixel_bits``)
        Pixel-major pairs (as :func:`tdicam.beats.frames_to_beats` ``(ppc=, channels=2)``):
        ``data[2k]`` = HG, ``data[2k + 1]`` = LG of pixel ``k`` of the beat (0 the
        leftmost; tdata: HG of pixel 0 in the low element, its LG in the next, each padded
        to whole bytes). A row is ``width / ppc`` beats (the width is not a parameter).
    o_stream : Out(pixel stream of ``ppc`` x ``out_bits``)
        ``data[k]`` = merged pixel ``k`` (a plain value at ppc 1), ``out_bits`` wide,
        clamped; ``first``/``last`` pass through.
    gain_sel : In(sel_bits), only when ``gain_pairs`` has two or more pairs
        Index of the programmed gain pair; sampled when a frame's first beat (``first``) is
        accepted and used for that whole frame.

    Notes
    -----
    Pixel pipeline: four register stages (junction subtract, multiply, sum with rounding,
    clamp/select) per pixel lane (``ppc`` multipliers), advancing together when the output
    register is empty or taken; :attr:`latency` = 4 cycles at every ``ppc`` (1, 2, 4, 8:
    4, 4, 4, 4), ``ppc`` pixels/clock.

    Band statistics are updated one cycle after a beat is accepted (registered band
    decisions), adding the beat's band pixels: pixel ``k`` counts when it is in the band and
    the count, plus the band pixels before it in the beat, is below ``2**count_bits - 1``
    (the first band pixels in raster order, as the model). At ``ppc`` > 1 the count is
    updated one cycle after the beat and the sums four (the taken pixels masked, the sums
    of each half of the beat, their sum, the accumulation: at most two adders per stage,
    for 150 MHz at ppc 8), each a cycle
    after the band pixels before it in the beat are counted (the band compares and that
    count in one cycle were the Ning et al. 2019 chain's slowest path at ppc 8). Frame
    start: when a beat with ``first`` is presented and the previous frame had band pixels,
    ``i_stream.ready`` stays low for :attr:`frame_start_cycles` cycles (ppc 1: ``pixel_bits
    + lgt_frac_bits + 3``; ppc 2, 4, 8: four more, the statistics' extra stages) while two
    restoring dividers (one quotient bit per cycle, ``pixel_bits +
    lgt_frac_bits`` bits) turn the band sums into ``L_T`` and ``H_T``; the beat is then
    accepted with them. Pixels of the previous frame still in the pipeline are unaffected
    (each carries its own junction values). With an empty band there is no stall. Pixels
    before the first ``first`` after reset are merged with the reset values and counted as
    a frame.

    Raises
    ------
    TdicamError
        Bad parameters, ``ppc`` not one of 1, 2, 4, 8 (one line).
    """

    #: Multiplier descriptions (``dsp=``): ``"generic"`` (``*`` between fabric registers,
    #: mapped by the synthesis tool) or ``"ecp5"`` (a signed MULT18X18D with its input
    #: registers, :func:`tdicam.hdl.vendor.ecp5_dsp.mult`: the same stages and cycles).
    DSPS = ecp5_dsp.DSPS

    @quiet_reject
    def __init__(self, *, pixel_bits=12, threshold=None, band=None, gain_pairs=DEFAULT_GAINS,
                 slope_frac_bits=8, lgt_frac_bits=4, anchor="band", count_bits=24,
                 out_bits=None, ppc=1, dsp="generic"):
        self._ppc = check_choice("ppc", ppc, PPC_CHOICES)
        self._dsp = check_choice("dsp", dsp, self.DSPS)
        self._cfg = cfg = hdr_config(
            pixel_bits=pixel_bits, threshold=threshold, band=band, gain_pairs=gain_pairs,
            slope_frac_bits=slope_frac_bits, lgt_frac_bits=lgt_frac_bits, anchor=anchor,
            count_bits=count_bits, out_bits=out_bits)
        members = {
            "i_stream": In(pixel_signature(channels_shape(pixel_bits, 2 * ppc))),
            "o_stream": Out(pixel_signature(channels_shape(cfg.out_bits, ppc))),
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
    ppc = property(lambda self: self._ppc, doc="Pixels per clock (per beat).")
    dsp = property(lambda self: self._dsp, doc="Multiplier description, one of :attr:`DSPS`.")

    @property
    def latency(self):
        """Cycles from an input transfer to the corresponding output being valid: 4 at
        every ``ppc``."""
        return 4

    @property
    def frame_start_cycles(self):
        """Cycles ``i_stream.ready`` is held low at a frame start after a non-empty band
        (last pixel counted, divider load, one per quotient bit, write-back; at ``ppc`` > 1
        four more: the band sums are five stages behind the beat)."""
        return self._cfg.lt_bits + 3 + (4 if self._ppc > 1 else 0)

    def _lane_statistics(self, m, s_v, s_first, s_bands, s_hgs, s_lgs, n, sum_l, sum_h):
        """Band statistics at ppc > 1, five stages behind the accepted beat (timing).

        S (the registers ``s_*``: the beat and its band decisions); C (``c_*``: the beat
        again, with its band count and, per pixel, the band pixels before it in the beat):
        T counts ``n`` and masks the pixels taken; W adds the taken pixels of each half of
        the beat (adder trees), U the halves; V accumulates the sums. The first band pixels in
        raster order are taken while the count has room: pixel k when ``n`` + (band pixels
        before it) < ``count_max`` = ``2**count_bits - 1``. ``safe`` (``n`` of the cycle
        before + ``2 ppc - 1`` < ``count_max``; ``n`` grows by at most ``ppc`` a cycle)
        means every band pixel is taken; otherwise the room ``count_max - n = ~n`` is below
        ``2 ppc`` and its low 4 bits decide. ``n`` is 0 on a frame's first beat (the
        division wrote it back before the beat was accepted)."""
        cfg, P = self._cfg, self._ppc
        cb, cmax = cfg.count_bits, cfg.count_max
        # C: prefix band counts of the beat (from S's band registers)
        c_v, c_first = Signal(name="c_v"), Signal(name="c_first")
        c_bands = [Signal(name=f"c_band_{k}") for k in range(P)]
        c_before, c_cnt, acc = [], Signal(range(P + 1), name="c_cnt"), Const(0, 1)
        for k in range(P):
            b = Signal(range(P), name=f"c_before_{k}")
            m.d.sync += b.eq(acc)
            c_before.append(b)
            acc = acc + s_bands[k]
        c_hgs = [Signal.like(h, name=f"c_hg_{k}") for k, h in enumerate(s_hgs)]
        c_lgs = [Signal.like(x, name=f"c_lg_{k}") for k, x in enumerate(s_lgs)]
        m.d.sync += [c_cnt.eq(acc), c_v.eq(s_v), c_first.eq(s_first),
                     *(d.eq(x) for d, x in zip(c_bands + c_hgs + c_lgs,
                                               s_bands + s_hgs + s_lgs))]
        # T: count, mask
        safe = Signal(init=1, name="n_safe")
        m.d.sync += safe.eq(n + (2 * P - 1) < cmax)
        room = (~n)[:min(cb, 4)]
        add_n = Mux(safe | (c_cnt < room), c_cnt, room)
        with m.If(c_v):
            m.d.sync += n.eq(Mux(c_first, 0, n) + add_n)
        t_v, t_first = Signal(name="t_v"), Signal(name="t_first")
        m.d.sync += [t_v.eq(c_v), t_first.eq(c_first)]
        t_l, t_h = [], []
        for k in range(P):
            tk = c_bands[k] & (safe | (c_before[k] < room))
            for src, dst in ((c_lgs[k], t_l), (c_hgs[k], t_h)):
                r = Signal.like(src, name=f"t_{'l' if dst is t_l else 'h'}_{k}")
                m.d.sync += r.eq(Mux(tk, src, 0))
                dst.append(r)
        # U: the beat's sums, two stages: each half of the beat's lanes (adder tree), then
        # the halves (the eight lanes' tree in one cycle was 6.4-6.7 ns in the Ning et al.
        # 2019 chain at ppc 8)
        u_v, u_first = Signal(name="u_v"), Signal(name="u_first")
        w_v, w_first = Signal(name="w_v"), Signal(name="w_first")
        u_l, u_h = Signal(len(t_l[0]) + 3, name="u_l"), Signal(len(t_h[0]) + 3, name="u_h")
        halves = []
        for t_x, tag in ((t_l, "l"), (t_h, "h")):
            for j, part in enumerate((t_x[:P // 2], t_x[P // 2:])):
                r = Signal(len(t_x[0]) + 2, name=f"w_{tag}{j}")
                m.d.sync += r.eq(_tree(part))
                halves.append(r)
        m.d.sync += [w_v.eq(t_v), w_first.eq(t_first), u_v.eq(w_v), u_first.eq(w_first),
                     u_l.eq(halves[0] + halves[1]), u_h.eq(halves[2] + halves[3])]
        # V: accumulate (a frame's first beat restarts the sums)
        with m.If(u_v):
            m.d.sync += [sum_l.eq(Mux(u_first, 0, sum_l) + u_l),
                         sum_h.eq(Mux(u_first, 0, sum_h) + u_h)]

    def elaborate(self, platform):
        m = Module()
        cfg = self._cfg
        i, o = self.i_stream, self.o_stream
        pb, f, sf, cb = cfg.pixel_bits, cfg.lgt_frac_bits, cfg.slope_frac_bits, cfg.count_bits
        q = cfg.lt_bits
        t = cfg.threshold
        top = (1 << cfg.out_bits) - 1
        P = self._ppc
        lanes = range(P)
        # pixel k of the beat (0 the leftmost): HG in element 2k, LG in element 2k + 1
        hgs = [i.payload.data[2 * k] for k in lanes]
        lgs = [i.payload.data[2 * k + 1] for k in lanes]
        hg = hgs[0]

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

        # ---- junction values for the beat being accepted (all its pixels are in one frame)
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
        # band statistics run one stage behind the accepted beat (timing): s_* hold the
        # beat accepted last cycle, not yet counted; n_nz is n != 0 once it is counted
        s_v, s_first, s_band = Signal(), Signal(), Signal()
        s_hg, s_lg = Signal(pb), Signal(pb)
        s_bands, s_hgs, s_lgs = [s_band], [s_hg], [s_lg]
        for k in range(1, P):
            s_bands.append(Signal(name=f"s_band_{k}"))
            s_hgs.append(Signal(pb, name=f"s_hg_{k}"))
            s_lgs.append(Signal(pb, name=f"s_lg_{k}"))
        s_any = s_band if P == 1 else Cat(*s_bands).any()
        if P == 1:
            n_nz = Mux(s_v, s_any | (~s_first & (n != 0)), n != 0)
        else:
            seen = Signal(name="band_seen")
            # a flag instead of n != 0 and the stages behind S (this feeds i.ready, which
            # the producer's FIFO takes as its pop): the beats of the current frame past S
            # had band pixels (cleared by the division's write-back)
            with m.If(s_v):
                m.d.sync += seen.eq(Mux(s_first, 0, seen) | s_any)
            n_nz = Mux(s_v & s_first, s_any, (s_v & s_any) | seen)
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
        # ppc > 1: the sums are complete four cycles later (four more statistics stages)
        hold, branch = Signal(3), m.If
        if P > 1:
            with m.If(hold != 0):
                m.d.sync += [hold.eq(hold - 1), load.eq(hold == 1)]
            branch = m.Elif
        with branch(load):  # statistics complete: the stage emptied while ready was low
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
                if P > 1:
                    m.d.sync += seen.eq(0)
        with m.Elif(need_div):
            m.d.sync += [busy.eq(1), load.eq(1) if P == 1 else hold.eq(4)]

        # ---- band statistics and frame registers, on accepted beats
        def band_of(h):
            return (h < t) if t == cfg.band else (h >= t - cfg.band) & (h < t)
        in_band = band_of(hg)
        m.d.sync += [s_v.eq(i.valid & i.ready), s_first.eq(first), s_band.eq(in_band),
                     s_hg.eq(hg), s_lg.eq(lgs[0])]
        for k in range(1, P):
            m.d.sync += [s_bands[k].eq(band_of(hgs[k])), s_hgs[k].eq(hgs[k]),
                         s_lgs[k].eq(lgs[k])]
        with m.If(i.valid & i.ready & first):
            m.d.sync += [cur.eq(sel_now), lt.eq(lt_eff), ht.eq(ht_eff)]
        if P == 1:
            take = s_band & (n != cfg.count_max)
            add_l, add_h, add_n = Mux(take, s_lg, 0), Mux(take, s_hg, 0), take
            with m.If(s_v & (s_first | take)):  # a frame's first beat restarts the statistics
                m.d.sync += [
                    sum_l.eq(Mux(s_first, 0, sum_l) + add_l),
                    sum_h.eq(Mux(s_first, 0, sum_h) + add_h),
                    n.eq(Mux(s_first, 0, n) + add_n),
                ]
        else:
            self._lane_statistics(m, s_v, s_first, s_bands, s_hgs, s_lgs, n, sum_l, sum_h)

        # ---- pixel pipeline (global enable); lane 0 declared as before ppc existed (the
        # Verilog at ppc 1 is byte-identical to the single-pixel design's)
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

        L = {"below1": [below1], "hg1": [hg1], "d1": [d1], "below2": [below2], "hg2": [hg2],
             "p2": [p2], "below3": [below3], "hg3": [hg3], "acc3": [acc3]}
        shapes = {"below1": 1, "hg1": pb, "d1": signed(pb + f + 1), "below2": 1, "hg2": pb,
                  "p2": p2.shape(), "below3": 1, "hg3": pb, "acc3": acc3.shape()}
        for k in range(1, P):
            for name, lst in L.items():
                lst.append(Signal(shapes[name], name=f"{name}_{k}"))
        # (loops, not comprehensions: a name used in a nested scope would lose its
        # inferred signal name)
        accs, sats = [acc], [sat]
        for k in range(1, P):
            a = (ht2 << sf) + L["p2"][k]
            if sh:
                a = a + (1 << (sh - 1))
            accs.append(a)
            yk = L["acc3"][k] >> sh
            sats.append(Mux(yk < 0, 0, Mux(yk > top, top, yk)))
        outs = [o.payload.data] if P == 1 else [o.payload.data[k] for k in lanes]
        st = {name: [] for name in ("below1", "hg1", "d1", "below2", "hg2", "p2", "below3",
                                    "hg3", "acc3", "out")}
        # ecp5: d1 and s1 are each DSP block's input registers, p2 loads their product
        slope = slopes[sel_eff]
        fabric = self._dsp != "ecp5" or not ecp5_dsp.fits(d1.shape(), s1.shape())
        for k in lanes:
            diff = (lgs[k] << f) - lt_eff
            prod = L["d1"][k] * s1 if fabric else ecp5_dsp.mult(
                m, f"mul{k}", diff[:len(d1)].as_signed(), slope, en)
            st["below1"].append(L["below1"][k].eq(hgs[k] < t))
            st["hg1"].append(L["hg1"][k].eq(hgs[k]))
            if fabric:
                st["d1"].append(L["d1"][k].eq(diff))
            st["below2"].append(L["below2"][k].eq(L["below1"][k]))
            st["hg2"].append(L["hg2"][k].eq(L["hg1"][k]))
            st["p2"].append(L["p2"][k].eq(prod))
            st["below3"].append(L["below3"][k].eq(L["below2"][k]))
            st["hg3"].append(L["hg3"][k].eq(L["hg2"][k]))
            st["acc3"].append(L["acc3"][k].eq(accs[k]))
            st["out"].append(outs[k].eq(Mux(L["below3"][k], L["hg3"][k], sats[k])))

        with m.If(en):
            m.d.sync += [
                v1.eq(i.valid & i.ready), f1.eq(first), l1.eq(i.payload.last),
                *st["below1"], *st["hg1"], *st["d1"], ht1.eq(ht_eff),
                *((s1.eq(slope),) if fabric else ()),
                v2.eq(v1), f2.eq(f1), l2.eq(l1), *st["below2"], *st["hg2"], ht2.eq(ht1),
                *st["p2"],
                v3.eq(v2), f3.eq(f2), l3.eq(l2), *st["below3"], *st["hg3"], *st["acc3"],
                o.valid.eq(v3), o.payload.first.eq(f3), o.payload.last.eq(l3), *st["out"],
            ]
        return m


def _tree(values):
    """Sum of ``values`` as a balanced adder tree."""
    while len(values) > 1:
        values = [values[j] + values[j + 1] if j + 1 < len(values) else values[j]
                  for j in range(0, len(values), 2)]
    return values[0]
