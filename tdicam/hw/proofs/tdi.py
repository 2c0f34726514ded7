"""Formal harness of the TDI accumulator (:class:`tdicam.hdl.tdi.TdiAccumulator`)."""

from amaranth.asserts import AnySeq
from amaranth.hdl import Assert, Assume, Cat, Const, Elaboratable, Module, Value

from tdicam.hdl.tdi import TdiAccumulator

__all__ = ["TdiNoWrapProof"]


class TdiNoWrapProof(Elaboratable):
    """Formal harness: the partial-sum adders never carry out of the partial-sum width.

    Inputs (pixels, tuser, tlast, valid, ``stages_active``, ``direction``, the sink's
    ``ready``, the synchronous reset) are free on every cycle. Asserted on every cycle: the
    sum a pipeline beat writes back or outputs (stored partial sum + pixel, per lane) fits
    :attr:`TdiAccumulator.psum_bits`, and every partial sum written is at most
    ``(stages - 1) * (2**pixel_bits - 1)``; and no partial-sum bank reads an address in
    the cycle it is written for a beat that uses the stored sum (the contract of the banks'
    ``no_rw_check`` attribute, see :class:`TdiAccumulator`). Meant for a bounded model check from the initial
    state (:func:`tdicam.hw.formal.prove` ``mode="bmc"``, :meth:`depth` cycles: ``stages + 1``
    whole frames plus the pipeline), which covers every stage count, direction, setting
    change, reset and malformed-frame path reachable in that many cycles.

    ``full_scale`` assumes every pixel is ``2**pixel_bits - 1``: sound for this property,
    because no control decision depends on pixel values and every sum is a sum of pixels,
    so the largest sum of any control trace is the one with full-scale pixels; it makes the
    check several times faster. ``valid_settings`` assumes ``1 <= stages_active <= stages``
    (an invalid setting only drops its frame and restarts the fill, like a change of
    setting). ``psum_bits`` overrides the partial-sum width: a deliberately too narrow,
    wrapping mutant must fail; ``row_cycles`` overrides the fewest cycles per row: one too
    few (5) makes a row read a sum in the cycle it is written, and must fail.
    """

    def __init__(self, *, width=2, stages=3, pixel_bits=8, ppc=1, psum_bits=None, row_cycles=None,
                 full_scale=False, valid_settings=False):
        self.dut = TdiAccumulator(width=width, stages=stages, pixel_bits=pixel_bits, ppc=ppc,
                                  _psum_bits=psum_bits,
                                  **({} if row_cycles is None else {"_row_cycles": row_cycles}))
        self.dut._MustUse__silence = True   # elaborated by hand in elaborate()
        self.full_scale = full_scale
        self.valid_settings = valid_settings

    def depth(self, frames=None):
        """BMC depth covering ``frames`` whole frames (default ``stages + 1``) + pipeline."""
        d = self.dut
        frames = d.stages + 1 if frames is None else frames
        return frames * d.stages * d.row_cycles + d.latency + 2

    def elaborate(self, platform):
        m = Module()
        dut = self.dut
        m.submodules.dut = dut.elaborate(platform)   # by hand, to reach its probes
        i, o = dut.i_stream, dut.o_stream
        m.d.comb += [
            i.valid.eq(AnySeq(1)),
            Value.cast(i.payload).eq(AnySeq(len(Value.cast(i.payload)))),
            dut.stages_active.eq(AnySeq(len(dut.stages_active))),
            dut.direction.eq(AnySeq(1)),
            o.ready.eq(AnySeq(1)),
        ]
        if self.full_scale:
            pmax = (1 << dut.pixel_bits) - 1
            m.d.comb += Assume(Value.cast(i.payload.data) == Cat(*([Const(pmax, dut.pixel_bits)] * dut.ppc)))
        if self.valid_settings:
            m.d.comb += Assume((dut.stages_active >= 1) & (dut.stages_active <= dut.stages))
        p = dut.probe
        m.d.comb += Assert(~(p["b_valid"] & p["wrap"].any()))
        # the banks' no_rw_check contract: a read of the address written in the same cycle
        # (whose data is then undefined) is never used
        for ren, raddr, wen, waddr in p["ports"]:
            m.d.comb += Assert(~(ren & wen & (raddr == waddr)) | ~p["issue_use"])
        bound = (dut.stages - 1) * ((1 << dut.pixel_bits) - 1)
        ps = dut.psum_bits
        for k in range(dut.ppc):
            lane = p["sums"][k * ps:(k + 1) * ps]
            m.d.comb += Assert(~(p["b_valid"] & p["b_wr"]) | (lane <= bound))
        return m
