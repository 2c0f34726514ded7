"""The streams between a pipeline top's stages (:mod:`tdicam.hdl.chain_top`): a
:class:`Link` (valid, ready, the pixel elements, the markers and the user fields the sensor's
front end adds), and what the top does with links: the fork of an input beat into channel
lanes, the join of two streams into one beat (a lane and its coefficient stream, or the HDR
gain channels), the re-framing of TDI's one-line frames into images for a 2-D block, a
register slice, the width converter before a block at fewer pixels per clock, and the one
that gathers a one-pixel-a-beat stream (the NAND store's coefficients) into the chain's.
"""

from amaranth.hdl import Cat, Const, Mux, Signal, Value

from tdicam.errors import TdicamError
from tdicam.hdl.interfaces.stream import AdvanceBuffer, Narrower, StreamRegister, element_bits

__all__ = ["Link", "fork", "eager_fork", "join", "frame_group", "register_slice", "narrow",
           "widen", "prepend"]


class Link:
    """One stream between two stages inside the top (producer side).

    ``valid``, ``first``, ``last`` and the pixel elements ``elems`` (a list of Values, one per
    channel) are driven by the producer; ``ready`` is a Signal the consumer drives. ``user``:
    per-beat side values the stream carries (name -> Value, e.g. the frame kind the
    sensor's front end reads from its lanes, :attr:`SourceStage.carries`), kept with the
    beat through forks, joins and register slices.
    """

    def __init__(self, valid, ready, first, last, elems, bits, user=None):
        self.valid, self.ready, self.first, self.last = valid, ready, first, last
        self.elems, self.bits = list(elems), bits
        self.user = dict(user or {})

    @classmethod
    def of_output(cls, stream):
        """The ``o_stream`` of a component."""
        bits, count = element_bits(stream.payload.data.shape())
        d = stream.payload.data
        elems = [d[k] for k in range(count)] if count > 1 else [d]
        return cls(stream.valid, stream.ready, stream.payload.first, stream.payload.last,
                   elems, bits)

    def feed(self, m, stream, *, who):
        """Drive component input ``stream`` from this link (elements zero-extended)."""
        bits, count = element_bits(stream.payload.data.shape())
        if len(self.elems) > count:
            raise TdicamError(f"{who}: takes {count} channel(s), gets {len(self.elems)}")
        if self.bits > bits:
            raise TdicamError(f"{who}: takes {bits}-bit pixels, the stage before gives "
                              f"{self.bits}-bit pixels")
        flat = Cat(*(Cat(e, Const(0, bits - len(Value.cast(e)))) for e in self.elems))
        m.d.comb += [
            stream.valid.eq(self.valid),
            self.ready.eq(stream.ready),
            stream.payload.first.eq(self.first),
            stream.payload.last.eq(self.last),
            Value.cast(stream.payload.data).eq(flat),
        ]

    def pixel_elems(self, lo, hi, ppc=1):
        """Elements ``lo:hi`` of each of the beat's ``ppc`` pixels, pixel-major (the beat
        carries ``ppc`` pixels of ``len(elems) / ppc`` elements each)."""
        n = len(self.elems) // ppc
        return [e for p in range(ppc) for e in self.elems[p * n + lo:p * n + hi]]

    def select(self, lo, hi, ppc=1):
        """The same beats with elements ``lo:hi`` of each pixel only (no handshake of its
        own)."""
        return Link(self.valid, self.ready, self.first, self.last,
                    self.pixel_elems(lo, hi, ppc), self.bits, self.user)


def fork(m, link, parts, name, ppc=1):
    """Split ``link`` into streams of each pixel's element ranges ``parts`` (``ppc``
    pixels a beat); a beat moves when every branch takes it (each branch's valid waits for
    the others' ready)."""
    if len(parts) == 1:
        return [link.select(*parts[0], ppc)]
    readies = [Signal(name=f"{name}_ready{k}") for k in range(len(parts))]
    outs = []
    for k, (lo, hi) in enumerate(parts):
        others = Cat(*(r for j, r in enumerate(readies) if j != k)).all()
        outs.append(Link(link.valid & others, readies[k], link.first, link.last,
                         link.pixel_elems(lo, hi, ppc), link.bits, link.user))
    m.d.comb += link.ready.eq(Cat(*readies).all())
    return outs


def eager_fork(m, link, parts, name, ppc=1):
    """:func:`fork` for blocks whose input ``ready`` waits for ``valid`` (a DDR block
    starts its reads on a presented frame start): each branch is offered the beat on its
    own and takes it when it is ready (a per-branch taken flag, cleared when every branch
    has it), so no branch's ``valid`` waits for another's ``ready`` (no combinational
    loop); the beat leaves the source in the cycle its last branch takes it."""
    taken = [Signal(name=f"{name}_taken{k}") for k in range(len(parts))]
    readies = [Signal(name=f"{name}_ready{k}") for k in range(len(parts))]
    done = Cat(*(r | t for r, t in zip(readies, taken))).all()
    outs = []
    for k, (lo, hi) in enumerate(parts):
        outs.append(Link(link.valid & ~taken[k], readies[k], link.first, link.last,
                         link.pixel_elems(lo, hi, ppc), link.bits, link.user))
        with m.If(link.valid & done):
            m.d.sync += taken[k].eq(0)
        with m.Elif(link.valid & readies[k]):
            m.d.sync += taken[k].eq(1)
    m.d.comb += link.ready.eq(done)
    return outs


def join(m, a, b, name, ppc=1):
    """One stream whose beats carry, for each of the ``ppc`` pixels, ``a``'s elements then
    ``b``'s (pixel-major); markers from ``a``."""
    ready = Signal(name=f"{name}_ready")
    m.d.comb += [a.ready.eq(ready & b.valid), b.ready.eq(ready & a.valid)]
    na, nb = len(a.elems) // ppc, len(b.elems) // ppc
    elems = [e for p in range(ppc)
             for e in a.elems[p * na:(p + 1) * na] + b.elems[p * nb:(p + 1) * nb]]
    return Link(a.valid & b.valid, ready, a.first, a.last, elems, max(a.bits, b.bits),
                {**b.user, **a.user})


def frame_group(m, link, height, name):
    """Re-frame: ``first`` kept only on every ``height``-th frame start (``height`` 0 counts
    as 1), so ``height`` one-line frames (TDI's output lines) become one image. No latency,
    no state but the frame counter."""
    cnt = Signal(16, name=f"{name}_frames")
    ready = Signal(name=f"{name}_ready")
    m.d.comb += link.ready.eq(ready)
    with m.If(link.valid & ready & link.first):
        with m.If(cnt + 1 >= height):
            m.d.sync += cnt.eq(0)
        with m.Else():
            m.d.sync += cnt.eq(cnt + 1)
    return Link(link.valid, ready, link.first & ~cnt.any(), link.last, link.elems, link.bits,
                link.user)


def register_slice(m, link, name, ppc=1):
    """A register slice (skid buffer) on ``link``: a
    :class:`~tdicam.hdl.interfaces.stream.StreamRegister` (submodule ``name``) on its beat and
    markers, so the beat, its markers and valid come out of registers and the ready handed
    back upstream is a register too: no combinational path crosses it; one beat a clock
    sustained, latency 1 cycle, no beat lost or duplicated whatever ``ready`` does. Cuts the
    path from a block's unregistered output (e.g. a memory read) into the next block's
    logic.

    At ``ppc`` >= 2 the slice is a 3-beat FIFO instead
    (:class:`~tdicam.hdl.interfaces.stream.AdvanceBuffer`, submodule ``name``): the same
    latency (1) and rate, the ready handed upstream a register (computed one cycle ahead
    from the FIFO's level and this cycle's push), valid a flag of the level, the beat read
    from the FIFO's slots through its read multiplexer. A skid buffer's output register
    loads on the consumer's ready, so that ready (often a block's logic, several LUTs deep)
    fans out to every bit of a wide beat (ppc x 16 bits and more: the orbit chain's slowest
    path at 8 pixels per clock, median3's input ready into the TDI slice, 7.9 ns); here it
    reaches the FIFO's read pointer and level counters only."""
    user = list(link.user.values())
    width = sum(len(Value.cast(e)) for e in link.elems + user) + 2
    ready = Signal(name=f"{name}_ready")
    word = Cat(*link.elems, link.first, link.last, *user)
    if ppc == 1:
        m.submodules[name] = reg = StreamRegister(width)
        m.d.comb += [reg.i_stream.valid.eq(link.valid), reg.i_stream.payload.eq(word),
                     link.ready.eq(reg.i_stream.ready), reg.o_stream.ready.eq(ready)]
        o_valid, o_data = reg.o_stream.valid, reg.o_stream.payload
    else:
        m.submodules[name] = buf = AdvanceBuffer(width)
        m.d.comb += [buf.i_valid.eq(link.valid), buf.i_payload.eq(word),
                     link.ready.eq(buf.adv), buf.o_stream.ready.eq(ready)]
        o_valid, o_data = buf.o_stream.valid, buf.o_stream.payload

    def unpack(values, lo):
        out = []
        for e in values:
            n = len(Value.cast(e))
            out.append(o_data[lo:lo + n])
            lo += n
        return out, lo
    elems, lo = unpack(link.elems, 0)
    carried, _ = unpack(user, lo + 2)
    return Link(o_valid, ready, o_data[lo], o_data[lo + 1], elems, link.bits,
                dict(zip(link.user, carried)))


def narrow(m, link, ppc_in, ppc_out, depth, name, bram="generic"):
    """``link`` (``ppc_in`` pixels a beat) as beats of ``ppc_out`` pixels, through a
    :class:`~tdicam.hdl.interfaces.stream.Narrower` (submodule ``name``) whose FIFO holds
    ``depth`` input beats (its memory described as ``bram``), then a :func:`register_slice`
    (the consumer's ready reaches a register, not the converter's FIFO read): for a block
    after TDI, whose output is ``stages`` times slower than its input and needs fewer
    pixels per clock. Pixels, rows and frames unchanged;
    latency 6 cycles (:attr:`Narrower.latency` and the slice's 1)."""
    if link.user:
        raise TdicamError(f"pipeline: {name}: a stream carrying {', '.join(link.user)} "
                          f"cannot change its pixels per clock")
    n = len(link.elems) // ppc_in
    m.submodules[name] = nar = Narrower(link.bits, len(link.elems), n * ppc_out, depth, bram)
    link.feed(m, nar.i_stream, who=name)
    return register_slice(m, Link.of_output(nar.o_stream), f"{name}_slice", ppc_out)


def widen(m, link, ppc, name):
    """``link`` (one pixel a beat, its elements ``link.elems``) as beats of ``ppc`` pixels,
    pixel-major (every element of the leftmost pixel first, as :func:`join` and
    :func:`prepend` put them): ``ppc`` beats gathered by a
    :class:`~tdicam.hdl.tlk2711.Widener` (submodule ``name``; each pixel's elements one
    wide pixel of it), then a :func:`register_slice` (``{name}_slice``: the consumer's
    ready reaches registers, not the held beats' enables). ``first`` from a beat's first
    pixel, ``last`` from its last: rows (a multiple of ``ppc`` pixels, the chain's width)
    and frames unchanged. For the NAND store's coefficients (:class:`~tdicam.hdl.
    nand_store.NandCalibStore`, one pixel's a beat) before ``nuc_ddr`` at the chain's
    pixels per clock. ``ppc`` 1: ``link`` itself. Latency 1 cycle from the beat that
    completes an output beat (the Widener's 0 and the slice's 1)."""
    if ppc == 1:
        return link
    if link.user:
        raise TdicamError(f"pipeline: {name}: a stream carrying {', '.join(link.user)} "
                          f"cannot change its pixels per clock")
    from tdicam.hdl.tlk2711 import Widener
    n, eb = len(link.elems), link.bits
    m.submodules[name] = wid = Widener(pixel_bits=n * eb, ppc=1, beats=ppc, links=1)
    i, o = wid.i_stream, wid.o_stream
    m.d.comb += [
        i.valid.eq(link.valid), link.ready.eq(i.ready),
        i.payload.first.eq(link.first), i.payload.last.eq(link.last),
        i.payload.data.eq(Cat(*(Cat(e, Const(0, eb - len(Value.cast(e))))
                                for e in link.elems))),
    ]
    d = Value.cast(o.payload.data)
    elems = [d[(p * n + k) * eb:(p * n + k + 1) * eb] for p in range(ppc) for k in range(n)]
    return register_slice(m, Link(o.valid, o.ready, o.payload.first, o.payload.last, elems,
                                  eb), f"{name}_slice", ppc)


def prepend(m, load, link, rows, port, name, ppc=1):
    """One frame of ``load`` (``rows`` lines: a block's power-up load, NUC's coefficient
    frame) before every frame of ``link``: ``(stream, loaded)``. The stream's beats are
    ``load``'s as they are until its ``rows``-th line end is taken, then ``link``'s with
    each of the ``ppc`` pixels' elements followed by a 0 (where ``load`` has its second
    element a pixel); the user value ``port`` is 1 on the load's beats, 0 after (the
    block's ``frame_kind``). ``loaded`` (a register) is high from the cycle after the
    load's last beat is taken; ``link`` is not taken before. No latency."""
    loaded = Signal(name=f"{name}_loaded")
    row = Signal(range(max(rows, 2)), name=f"{name}_row")
    ready = Signal(name=f"{name}_ready")
    m.d.comb += [load.ready.eq(ready & ~loaded), link.ready.eq(ready & loaded)]
    with m.If(load.valid & ready & ~loaded & load.last):
        with m.If(row == rows - 1):
            m.d.sync += loaded.eq(1)
        with m.Else():
            m.d.sync += row.eq(row + 1)
    n = len(link.elems) // ppc
    px = [e for p in range(ppc) for e in link.elems[p * n:(p + 1) * n] + [Const(0, 1)]]
    if len(px) != len(load.elems):
        raise TdicamError(f"pipeline: {name}: the load gives {len(load.elems)} elements a "
                          f"beat, the stream {len(px)}")
    elems = [Mux(loaded, a, b) for a, b in zip(px, load.elems)]
    return Link(Mux(loaded, link.valid, load.valid), ready,
                Mux(loaded, link.first, load.first), Mux(loaded, link.last, load.last),
                elems, max(link.bits, load.bits), {**link.user, port: ~loaded}), loaded
