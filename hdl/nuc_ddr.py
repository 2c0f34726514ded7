"""Per-pixel NUC with its coefficients in DDR (Ning et al. 2019 §4.2-§4.4.4).

:class:`NucDdr` — the calibration coefficients (what :class:`~tdicam.hdl.calib.CalibReader`
decodes from the NAND at power-up) written to DDR through a
:class:`~tdicam.hdl.ddr.LineWriter`, read back line by line through a
:class:`~tdicam.hdl.ddr.LineReader` in step with every pixel frame and applied by the
:class:`~tdicam.hdl.nuc.Nuc` datapath. A full GMAX0504 frame's coefficients (5144 x 3800
pixels x 2) cannot sit on chip as :class:`~tdicam.hdl.calib.CoeffBuffer` keeps them.
"""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.beats import PPC_CHOICES
from tdicam.errors import check_choice, check_multiple, check_range
from tdicam.model.ddr import ADDR_BITS, CAPACITY_BYTES, check_capacity
from tdicam.model.nuc import NucFormat, check_nuc_params
from tdicam.model.nuc_ddr import check_image_rows, coeff_layout
from tdicam.hdl.cds_ddr import frame_requests, port_wiring, track_kinds
from tdicam.hdl.ddr import LineReader, LineWriter
from tdicam.hdl.interfaces.mig import MigPort, connect_mig, mig_user_ports
from tdicam.hdl.interfaces.stream import (PairBuffer, StreamRegister, channels_shape,
                                          pixel_signature)
from tdicam.hdl.util import quiet_reject
from tdicam.hdl.vendor import ecp5_dsp

__all__ = ["NucDdr"]


class NucDdr(wiring.Component):
    """Per-pixel NUC whose coefficients live in DDR (Ning et al. 2019 §4.2-§4.4.4).

    Golden model: :func:`tdicam.model.nuc_ddr.nuc_ddr_frames` (the DDR packing in
    :mod:`tdicam.model.nuc_ddr`'s docstring: 16-bit slots, 16 a 256-bit word, 4 a 64-bit
    quarter).

    Parameters
    ----------
    width, rows : int
        Frame size (pixels per line, lines); frames must be exactly ``rows`` x ``width``.
    pixel_bits, gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits, out_bits
        The :class:`~tdicam.hdl.nuc.Nuc` datapath's formats; gain and offset at most 16 bits
        (one stored slot, as the flash words').
    line_stride, base, capacity_bytes
        Where the coefficient image lives (:func:`tdicam.model.nuc_ddr.coeff_layout`).
    image_rows : int or None
        Lines of the coefficient image (a coefficient frame), a multiple of ``rows``: the
        ``j``-th pixel frame after a coefficient frame reads ``rows`` lines from line
        ``(j mod (image_rows / rows)) * rows``
        (:func:`tdicam.model.nuc_ddr.image_segment`: an area camera's sensor row ``r``, a
        frame of one line, against coefficient line ``r``); None: ``rows`` (every pixel
        frame reads the whole image; the gateware as it was).
    ppc : int
        Pixels per clock (per beat): 1, 2, 4 or 8; ``width`` a multiple of it.
    dsp : str
        The :class:`~tdicam.hdl.nuc.Nuc` datapath's multipliers (:attr:`DSPS`):
        ``"generic"`` (default: a ``*`` between fabric registers) or ``"ecp5"`` (the ECP5
        synthesis tops: each lane's input registers a MULT18X18D's own; the same ports,
        latency and cycles, a simulator needs :mod:`tdicam.cosim.mult18x18d`).

    Attributes
    ----------
    i_stream : In(pixel stream of ``2 * ppc`` x :attr:`elem_bits`)
        Frames of ``width / ppc`` beats a row (``image_rows`` rows a coefficient frame,
        ``rows`` a pixel frame); ``frame_kind`` presented with a frame's first
        beat says what it is. A coefficient frame's beat carries ``ppc`` pixels' (gain,
        offset) codes, pixel-major (:class:`~tdicam.hdl.calib.CalibReader`'s ``o_stream`` at
        ``ppc``: ``data[2k]`` gain, ``data[2k + 1]`` offset in two's complement in the low
        ``offset_bits``, zero above); a pixel frame's beat carries pixel ``k`` (0 the
        leftmost) in ``data[2k]`` (where its gain would be), the odd elements ignored.
    frame_kind : In(1)
        1: a coefficient frame — written to DDR, no output; 0: a pixel frame — every pixel
        corrected with its coefficients read back from DDR (the defaults, gain 1.0 and offset
        0, before any coefficient frame).
    o_stream : Out(pixel stream of ``ppc`` x ``out_bits``)
        One frame per pixel frame, ``first``/``last`` as on the input.

    Notes
    -----
    The reads of a pixel frame start when its first beat is presented (not yet accepted) and
    the coefficient frame's last word has been handed to the MIG port (one in-order queue:
    every read sees every earlier write); a pixel beat is accepted only with its
    coefficients in hand, so a following coefficient frame never overwrites a line still to
    be read. One DDR read per 8 pixels; ``ppc`` pixels/clock once the first line's reads have
    returned while the memory delivers a word per ``8 / ppc`` clocks. :attr:`latency` = the
    :class:`~tdicam.hdl.nuc.Nuc` core's, from an accepted pixel beat to its output beat.
    Same controller as :class:`~tdicam.hdl.cds_ddr.CdsDdr` (its reset frame is this block's
    coefficient frame).

    Raises
    ------
    TdicamError
        A parameter out of range, ``width`` not a multiple of ``ppc``, a coefficient wider
        than 16 bits, the image beyond the capacity (one line each).
    """

    #: Multiplier descriptions (``dsp=``), :attr:`tdicam.hdl.nuc.Nuc.DSPS`.
    DSPS = ecp5_dsp.DSPS

    @quiet_reject
    def __init__(self, *, width, rows, pixel_bits=12, gain_int_bits=2, gain_frac_bits=14,
                 offset_bits=16, offset_frac_bits=0, out_bits=None, line_stride=None, base=0,
                 capacity_bytes=CAPACITY_BYTES, ppc=1, image_rows=None, dsp="generic"):
        self._ppc = check_choice("ppc", ppc, PPC_CHOICES)
        self._dsp = check_choice("dsp", dsp, self.DSPS)
        self._out_bits = check_nuc_params(
            pixel_bits=pixel_bits, gain_int_bits=gain_int_bits, gain_frac_bits=gain_frac_bits,
            offset_bits=offset_bits, offset_frac_bits=offset_frac_bits, out_bits=out_bits)
        self._fmt = NucFormat(gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits)
        self._fmt._check_slots()
        check_multiple(width, ppc)
        check_range("rows", rows, 1, 1 << 16)
        self.layout = coeff_layout(width, line_stride=line_stride, base=base)
        self._image_rows = check_image_rows(rows, image_rows)
        check_capacity(self.layout, self._image_rows, capacity_bytes, "coefficient image")
        self._rows, self._pixel_bits = rows, pixel_bits
        self._elem_bits = max(pixel_bits, self._fmt.gain_bits, offset_bits)
        super().__init__({
            "i_stream": In(pixel_signature(channels_shape(self._elem_bits, 2 * ppc))),
            "o_stream": Out(pixel_signature(channels_shape(self._out_bits, ppc))),
            "frame_kind": In(1), "line_errors": Out(16), **mig_user_ports()})

    rows = property(lambda self: self._rows)
    image_rows = property(lambda self: self._image_rows,
                          doc="Lines of the coefficient image (a multiple of rows).")
    pixel_bits = property(lambda self: self._pixel_bits)
    out_bits = property(lambda self: self._out_bits)
    fmt = property(lambda self: self._fmt, doc="The coefficient format (NucFormat).")
    elem_bits = property(lambda self: self._elem_bits,
                         doc="Width of each input element: max(pixel, gain, offset bits).")
    ppc = property(lambda self: self._ppc, doc="Pixels per clock (per beat).")
    dsp = property(lambda self: self._dsp, doc="Multiplier description, one of :attr:`DSPS`.")

    def _core(self):
        from tdicam.hdl.nuc import Nuc
        return Nuc(pixel_bits=self._pixel_bits, out_bits=self._out_bits, ppc=self._ppc,
                   dsp=self._dsp, **self._fmt.params())

    @property
    def latency(self):
        """Cycles from an accepted pixel beat to its output beat being valid: the
        :class:`~tdicam.hdl.nuc.Nuc` core's (3 at ppc 1, 4 at ppc 2-8)."""
        core = self._core()
        core._MustUse__silence = True          # asked for its latency only
        return core.latency

    def elaborate(self, platform):
        m = Module()
        lay, ppc = self.layout, self._ppc
        m.submodules.port = port = MigPort(early_count=ppc > 1)
        m.submodules.writer = wr = LineWriter(layout=lay, elements=2 * ppc,
                                              rows=self._image_rows, early_sums=ppc > 1)
        m.submodules.reader = rd = LineReader(
            layout=lay, elements=2 * ppc, max_lines=port.rd_depth // lay.words_per_line + 3,
            early_last=ppc > 1)
        m.submodules.nuc = nuc = self._core()
        connect_mig(m, port, self)
        wiring.connect(m, nuc.o_stream, wiring.flipped(self.o_stream))
        m.d.comb += [self.line_errors.eq(wr.line_errors), wr.line_ok.eq(1),
                     *port_wiring(port, wr, rd)]
        i = self.i_stream
        kind = Signal()
        cur_kind = Mux(i.payload.first, self.frame_kind, kind)
        have = Signal()             # a coefficient frame has been stored
        launched = Signal()
        segs = self._image_rows // self._rows
        seg_base = None if segs == 1 else Signal(ADDR_BITS, init=lay.base)
        left, start = frame_requests(m, rd, lay, self._rows, seg_base)
        launch = i.valid & i.payload.first & ~self.frame_kind & have & ~launched \
            & ~left.any() & ~wr.busy
        with m.If(launch):
            m.d.sync += [launched.eq(1), *start]
        if seg_base is not None:
            # the next pixel frame's lines of the image; line 0 again after the last
            # segment and at every coefficient frame
            seg = Signal(range(segs))
            step = self._rows * lay.line_stride
            with m.If(launch):
                m.d.sync += [seg.eq(Mux(seg == segs - 1, 0, seg + 1)),
                             seg_base.eq(Mux(seg == segs - 1, lay.base, seg_base + step))]
            with m.If(i.valid & i.ready & cur_kind & i.payload.first):
                m.d.sync += [seg.eq(0), seg_base.eq(lay.base)]
        # the coefficients through a register slice (the reader's word-to-value select off
        # the multiplier's input registers, the ready chain back into the MIG port cut);
        # at ppc >= 2 a PairBuffer: the beat's kind and the core's ready (cs.ready) reach
        # its read pointer, not the enable of its 2 * ppc coefficients
        slice_kind = PairBuffer if ppc > 1 else StreamRegister
        m.submodules.coeff_reg = reg = slice_kind(rd.o_stream.payload.shape())
        wiring.connect(m, rd.o_stream, reg.i_stream)
        cs = reg.o_stream
        coeffs_ok = ~have | (cs.valid & (~i.payload.first | launched))
        pix_ok = nuc.i_stream.ready & coeffs_ok
        gain_one = self._fmt.gain_one
        d, nd = i.payload.data, nuc.i_stream.payload.data
        m.d.comb += [
            wr.i_stream.valid.eq(i.valid & cur_kind),
            *(wr.i_stream.payload.data[e].eq(d[e]) for e in range(2 * ppc)),
            wr.i_stream.payload.first.eq(i.payload.first),
            wr.i_stream.payload.last.eq(i.payload.last),
            nuc.i_stream.valid.eq(i.valid & ~cur_kind & coeffs_ok),
            *(nd[3 * k].eq(d[2 * k]) for k in range(ppc)),
            *(nd[3 * k + 1].eq(Mux(have, cs.payload.data[2 * k], gain_one))
              for k in range(ppc)),
            *(nd[3 * k + 2].eq(Mux(have, cs.payload.data[2 * k + 1], 0)) for k in range(ppc)),
            nuc.i_stream.payload.first.eq(i.payload.first),
            nuc.i_stream.payload.last.eq(i.payload.last),
            i.ready.eq(Mux(cur_kind, wr.i_stream.ready, pix_ok)),
            cs.ready.eq(i.valid & ~cur_kind & have & pix_ok),
        ]
        track_kinds(m, i, kind, cur_kind, have, launched)
        return m
