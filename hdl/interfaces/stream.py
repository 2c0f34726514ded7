"""The pixel stream shared by every video block.

Pixels travel in raster order on an :class:`amaranth.lib.stream.Signature` whose payload is
:func:`pixel_layout`: ``data`` (one pixel, or an array of pixels or channels), ``first``
(start of frame, on the first pixel of a frame) and ``last`` (end of line, on the last pixel
of each row). A transfer happens on a clock edge where ``valid & ready``; a producer holds
``valid`` and ``payload`` until accepted. AXI4-Stream names appear only in
:mod:`tdicam.hdl.interfaces.axis`.
"""

from amaranth.hdl import Cat, Module, Mux, Shape, Signal, Value, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from tdicam.hdl.util import equals, pick

__all__ = ["pixel_layout", "pixel_signature", "channels_shape", "StreamRegister",
           "PairBuffer", "AdvanceBuffer", "Narrower"]


def pixel_layout(data_shape):
    """Struct layout ``{data: data_shape, first: 1, last: 1}``."""
    return data.StructLayout({"data": data_shape, "first": 1, "last": 1})


def pixel_signature(data_shape):
    """Stream signature carrying :func:`pixel_layout` of ``data_shape``."""
    return stream.Signature(pixel_layout(data_shape))


def channels_shape(bits, count):
    """``count`` unsigned ``bits``-wide elements: several pixels per clock or several channels
    of one pixel (element 0 in the least significant bits). ``count == 1`` gives a plain
    ``unsigned(bits)``."""
    if count == 1:
        return unsigned(bits)
    return data.ArrayLayout(unsigned(bits), count)


def element_bits(data_shape):
    """(element width, element count) of a pixel ``data`` shape."""
    if isinstance(data_shape, data.ArrayLayout):
        return Shape.cast(data_shape.elem_shape).width, data_shape.length
    return Shape.cast(data_shape).width, 1


class StreamRegister(wiring.Component):
    """A register slice on a stream (a skid buffer): ``valid``, ``payload`` and the
    upstream ``ready`` all come from registers.

    Full throughput (a beat per clock while the sink is ready), no beat lost or duplicated
    under any ``ready`` pattern; :attr:`latency` 1 cycle. Cuts every combinational path
    through it: the producer's data and valid to the consumer's registers, and the
    consumer's ready back to the producer (a beat accepted while the sink stalls waits in
    the second register).

    Parameters
    ----------
    payload_shape : shape-like
        The stream's payload (e.g. :func:`pixel_layout` of a data shape).
    """

    def __init__(self, payload_shape):
        super().__init__({"i_stream": In(stream.Signature(payload_shape)),
                          "o_stream": Out(stream.Signature(payload_shape))})

    latency = property(lambda self: 1, doc="Cycles from an accepted input beat to its "
                                           "output beat being valid.")

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        skid = Signal.like(i.payload)
        skid_valid = Signal()
        m.d.comb += i.ready.eq(~skid_valid)
        with m.If(~o.valid | o.ready):
            with m.If(skid_valid):
                m.d.sync += [o.valid.eq(1), o.payload.eq(skid), skid_valid.eq(0)]
            with m.Else():
                m.d.sync += [o.valid.eq(i.valid), o.payload.eq(i.payload)]
        with m.Elif(i.valid & ~skid_valid):
            m.d.sync += [skid.eq(i.payload), skid_valid.eq(1)]
        return m


class PairBuffer(StreamRegister):
    """:class:`StreamRegister`'s handshake, cycle for cycle, as a two-beat FIFO: the
    consumer's ``ready`` reaches no payload register's enable.

    A skid buffer's output register loads on the consumer's ``ready``, so that ready (a
    block's logic, several LUTs deep) fans out to every bit of a wide beat (``nuc_ddr``'s
    coefficient slice at 8 pixels per clock, 258 bits: the whole Ning et al. 2019 camera's
    slowest path, its input beat's frame kind into that enable, 8.61 ns). Here each beat
    is written into one of two slots on the producer's side alone (``i.valid`` and the
    register ``i.ready``); ``ready`` moves the read pointer and the two flags; ``payload``
    is the read pointer's slot (a 2:1 select after the registers).

    Same behaviour as :class:`StreamRegister` under every ``valid`` and ``ready`` pattern:
    ``i.ready`` = fewer than 2 beats held (a register), ``o.valid`` = a beat held (a
    register), the beats in order, :attr:`latency` 1 cycle.

    Parameters
    ----------
    payload_shape : shape-like
        The stream's payload.
    """

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        slots = [Signal.like(i.payload, name=f"slot{k}") for k in range(2)]
        wp, rp, full = Signal(), Signal(), Signal()
        push, pop = i.valid & ~full, o.valid & o.ready
        m.d.comb += [i.ready.eq(~full), o.payload.eq(Mux(rp, slots[1], slots[0]))]
        with m.If(push):
            m.d.sync += wp.eq(~wp)
        for k, slot in enumerate(slots):
            with m.If(push & (wp if k else ~wp)):
                m.d.sync += slot.eq(i.payload)
        with m.If(pop):
            m.d.sync += rp.eq(~rp)
        with m.If(push & ~pop):
            m.d.sync += [o.valid.eq(1), full.eq(o.valid)]
        with m.Elif(pop & ~push):
            m.d.sync += [o.valid.eq(full), full.eq(0)]
        return m


class AdvanceBuffer(wiring.Component):
    """The output buffer of a pipeline that moves on one clock enable, which makes that
    enable a register: no combinational path from the consumer's ``ready`` to the
    pipeline's clock enables (or through them to its input ``ready``).

    The pipeline's registers move on :attr:`adv` (flip-flops); its last stage's beat
    (``i_valid``, ``i_payload``, registers of the pipeline) is pushed into a :attr:`depth`
    = 3 beat FIFO on every cycle with ``adv & i_valid``; ``o_stream`` delivers the FIFO's
    head. ``adv`` of the next cycle is computed from registers only, one cycle ahead: the
    FIFO's level now plus this cycle's push (an upper bound of the next level, whatever
    ``ready`` does) leaves room for a beat. So a push always finds room, no beat is lost or
    duplicated under any ``ready`` pattern, and while ``o_stream.ready`` stays high the
    pipeline advances on every cycle (the level stays at 1: one beat per clock in and out).
    After a stall ``adv`` returns one cycle after the first pop; the FIFO's two other beats
    cover that cycle, so the output has no bubble.

    Parameters
    ----------
    payload_shape : shape-like
        The stream's payload.
    copies : int
        Bits of :attr:`adv`: equal copies of the enable, each from its own level counter
        (copies that synthesis cannot merge), so that each drives a part of the pipeline
        and none fans out to all of it. The FIFO has a counter of its own.

    Attributes
    ----------
    adv : Out(copies)
        The pipeline's clock enable, ``copies`` equal registers (reset 1).
    i_valid, i_payload : In
        The pipeline's last stage: a beat, taken when ``adv & i_valid``.
    o_stream : Out(stream of ``payload_shape``)
        The beats in order, :attr:`latency` 1 cycle after their push.
    """

    depth = 3

    def __init__(self, payload_shape, copies=1):
        self._copies = copies
        super().__init__({"adv": Out(copies, init=(1 << copies) - 1), "i_valid": In(1),
                          "i_payload": In(payload_shape),
                          "o_stream": Out(stream.Signature(payload_shape))})

    latency = property(lambda self: 1, doc="Cycles from a push to the beat at the FIFO's "
                                           "head (when it was empty).")

    def elaborate(self, platform):
        m = Module()
        F, o = self.depth, self.o_stream
        pop = o.valid & o.ready

        def counter(adv, name):
            """``adv`` (a register) and its level counter; the push it gives."""
            level = Signal(range(F + 1), name=f"{name}level")
            push = adv & self.i_valid
            m.d.sync += [level.eq(level + push - pop), adv.eq(level + push < F)]
            return level, push
        adv = Signal(init=1, name="fifo_adv")
        self.level, push = counter(adv, "fifo_")
        for k in range(self._copies):
            counter(self.adv[k], f"adv{k}_")
        pay = Value.cast(self.i_payload)
        slots = [Signal(len(pay), name=f"slot{k}", reset_less=True) for k in range(F)]
        wp, rp = Signal(range(F)), Signal(range(F))

        def step(p):
            return Mux(p == F - 1, 0, p + 1)
        with m.If(push):
            m.d.sync += wp.eq(step(wp))
            for k in range(F):
                with m.If(equals(wp, k)):
                    m.d.sync += slots[k].eq(pay)
        with m.If(pop):
            m.d.sync += rp.eq(step(rp))
        m.d.comb += [o.valid.eq(self.level != 0), o.payload.eq(pick(slots, rp))]
        return m


def _pipe_memory(m, tag, *, bram, depth, bits, ra, wa, wd, we, en):
    """A ``depth`` x ``bits`` memory whose read is two stages moving on ``en`` (address
    edge, then a register): ``"generic"`` an ``amaranth.lib.memory.Memory`` read port and a
    fabric register after it, ``"ecp5"`` DP16KD primitives with their own output register
    (:func:`tdicam.hdl.vendor.ecp5_bram.pipe_bank`; a block RAM's read without it leaves
    the block 4.1-4.3 ns after the clock). Returns the read word."""
    if bram == "ecp5":
        from tdicam.hdl.vendor import ecp5_bram
        return ecp5_bram.pipe_bank(m, tag, depth=depth, bits=bits, ra=ra, wa=wa, wd=wd,
                                   we=we, en=en)
    m.submodules[tag] = mem = Memory(shape=unsigned(bits), depth=depth, init=[])
    rd, wr = mem.read_port(), mem.write_port()
    q = Signal(bits, name=f"{tag}_q")
    m.d.comb += [rd.addr.eq(ra), rd.en.eq(en), wr.addr.eq(wa), wr.data.eq(wd), wr.en.eq(we)]
    with m.If(en):
        m.d.sync += q.eq(rd.data)
    return q


class Narrower(wiring.Component):
    """A width converter to fewer elements a beat, with a FIFO before it: a stream of
    ``count_in`` elements a beat in, of ``count_out`` a beat out (fewer pixels per clock).

    Each input beat leaves as ``ratio = count_in // count_out`` output beats, in element
    order: output beat ``k`` carries input elements ``k * count_out`` to
    ``(k + 1) * count_out - 1`` (the leftmost pixels first, as pixel-major beats put them).
    ``first`` is on the first of them only, ``last`` on the last only: rows, frames and
    pixels come out as they went in. The input beats wait in a FIFO of :attr:`depth` beats
    (a block RAM in synthesis) that takes one a clock while it has room, so a burst of up
    to ``depth`` beats (a line of TDI's output at the chain's pixels per clock) passes
    without holding the producer while the output drains ``count_out`` elements a clock.

    Backpressure: ``i_stream.ready`` is a register (the FIFO has room); the output beats
    leave through an :class:`AdvanceBuffer`, so the read side moves on a register (the
    buffer has room) and ``o_stream.ready`` reaches no clock enable of the converter (with
    the ready in the read's enables, through 5 LUTs, that was the orbit chain's slowest
    path on a seed at 8 pixels per clock, 7.1-7.3 ns). No beat is lost or duplicated under
    any ``valid`` or ``ready`` pattern. Throughput: ``count_out`` elements a clock out
    while the FIFO is not empty and the sink is ready. :attr:`latency` = 5 cycles from an
    input beat taken into an empty FIFO to its first output beat being valid (the write,
    the read's address and its register, the output register, the buffer).

    Parameters
    ----------
    bits : int
        Width of each element.
    count_in, count_out : int
        Elements a beat in and out; ``count_out`` divides ``count_in``.
    depth : int
        FIFO depth in input beats (at least 2).
    bram : {"generic", "ecp5"}
        The FIFO's memory: an ``amaranth.lib.memory.Memory`` (every simulation, ``tdicam
        verilog``) or, in the ECP5 synthesis top, DP16KD primitives whose output register
        is the read's second stage (the same cycles).

    Raises
    ------
    ValueError
        ``count_out`` does not divide ``count_in``, ``depth`` < 2, or an unknown ``bram``
        (one line).
    """

    #: Cycles from an input beat taken into an empty FIFO to its first output beat being valid.
    LATENCY = 5

    def __init__(self, bits, count_in, count_out, depth, bram="generic"):
        if count_out < 1 or count_in % count_out:
            raise ValueError(f"Narrower: {count_out} elements a beat out do not divide "
                             f"{count_in} in")
        if depth < 2:
            raise ValueError(f"Narrower: FIFO depth {depth} beats: at least 2")
        if bram not in ("generic", "ecp5"):
            raise ValueError(f"Narrower: bram = {bram!r}; valid: generic, ecp5")
        self._bits, self._in, self._out, self._depth = bits, count_in, count_out, depth
        self._bram = bram
        super().__init__({"i_stream": In(pixel_signature(channels_shape(bits, count_in))),
                          "o_stream": Out(pixel_signature(channels_shape(bits, count_out)))})

    bits = property(lambda self: self._bits, doc="Width of each element.")
    count_in = property(lambda self: self._in, doc="Elements an input beat.")
    count_out = property(lambda self: self._out, doc="Elements an output beat.")
    depth = property(lambda self: self._depth, doc="FIFO depth, input beats.")
    bram = property(lambda self: self._bram, doc="The FIFO's memory description.")
    ratio = property(lambda self: self._in // self._out, doc="Output beats an input beat.")
    latency = property(lambda self: self.LATENCY, doc="Cycles from an input beat taken into "
                                                      "an empty FIFO to its first output "
                                                      "beat being valid.")

    def elaborate(self, platform):
        m = Module()
        i, o = self.i_stream, self.o_stream
        n, w, depth = self.ratio, self._bits * self._out, self._depth
        word = Cat(Value.cast(i.payload.data), i.payload.first, i.payload.last)
        wp, rp = Signal(range(depth)), Signal(range(depth))
        level = Signal(range(depth + 1))        # written, not yet out of the head
        avail = Signal(range(depth + 1))        # written, not yet read
        v1, v2 = Signal(), Signal()             # read stage 1 (address), 2 (head) hold one
        k = Signal(range(n), name="part")
        # flags of the registers, kept beside them (k == n - 1, avail != 0): the read's
        # enables are a LUT of registers
        end = Signal(init=n == 1, name="part_end")         # k == n - 1
        any_avail = Signal(name="any_avail")               # avail != 0
        # the output register moves on the buffer's room (a register), its beat pushed
        m.submodules.obuf = obuf = AdvanceBuffer(o.payload.shape())
        ov = Signal(name="o_valid")
        op = Signal(o.payload.shape(), name="o_payload")
        wiring.connect(m, obuf.o_stream, wiring.flipped(o))
        m.d.comb += [obuf.i_valid.eq(ov), obuf.i_payload.eq(op)]
        load = obuf.adv                         # the output register takes a part
        pop = load & v2 & end                   # the head's last part leaves
        en = ~v2 | pop                          # the read pipeline moves
        issue = en & any_avail
        push = i.valid & i.ready
        m.d.comb += i.ready.eq(level != depth)
        m.d.sync += any_avail.eq(Mux(push, any_avail | ~issue, Mux(issue, avail != 1,
                                                                    any_avail)))

        def step(p):
            return Mux(p == depth - 1, 0, p + 1)
        # every outcome computed from the registers alone: push, pop and issue (late, from
        # the consumer's ready and the producer's valid) only select
        def count(c, up, down):
            return Mux(up, Mux(down, c, c + 1), Mux(down, c - 1, c))
        m.d.sync += [level.eq(count(level, push, pop)), avail.eq(count(avail, push, issue))]
        with m.If(push):
            m.d.sync += wp.eq(step(wp))
        with m.If(issue):
            m.d.sync += rp.eq(step(rp))
        with m.If(en):
            m.d.sync += [v1.eq(issue), v2.eq(v1)]
        head = _pipe_memory(m, "fifo", bram=self._bram, depth=depth, bits=len(word), ra=rp,
                            wa=wp, wd=word, we=push, en=en)
        # the head's first part straight from the read, the others from a register shifted
        # a part a beat: a 2:1 select, not an n:1 one, before the output register (the 8:1
        # select by k was the orbit chain's slowest path on a seed, 6.7 ns)
        fresh = Signal(init=1, name="part_first")          # k == 0
        rest = Signal(w * max(n - 1, 1), name="rest")      # parts k + 1.. of the head
        with m.If(load):
            m.d.sync += [ov.eq(v2),
                         Value.cast(op.data).eq(
                             Mux(fresh, head[:w], rest[:w]) if n > 1 else head[:w]),
                         op.first.eq(head[-2] & fresh),
                         op.last.eq(head[-1] & end)]
            with m.If(v2):
                m.d.sync += [k.eq(Mux(end, 0, k + 1)),
                             end.eq(Mux(end, n == 1, k + 1 == n - 1)), fresh.eq(end)]
                if n > 1:
                    m.d.sync += rest.eq(Mux(fresh, head[w:w * n], rest >> w))
        return m
