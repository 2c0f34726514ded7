"""cocotb tests of the 7-series primitive models (:mod:`tdicam.cosim.xilinx7_io`) on the
wrapper of :mod:`tdicam.cosim.io_models`: one test per documented behaviour.

Each test states the behaviour it checks; ``cocotb_tests/test_io_models.py`` runs them on
both simulators and runs mutants of the model, each of which must fail its test.
"""

import random

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge, Timer
from cocotb.utils import get_sim_time

from tdicam.cosim.io_models import STREAM_BITS, UI_PS
from tdicam.cosim.xilinx7_io import TAP_PS

WIDTHS = (4, 6, 8, 10, 14)


def _bits(stream, first, n):
    """The n stream bits from index ``first``, the first one in the MSB."""
    out = 0
    for i in range(n):
        out = (out << 1) | ((stream >> ((first + i) % STREAM_BITS)) & 1 if first + i >= 0
                            else 0)
    return out


async def _start(dut, stream):
    """Load ``stream``, hold the deserializers in reset for 30 ticks (every CLKDIV has an
    edge in it: back to the first alignment), then let 60 ticks of the new stream in."""
    dut.stream.value = stream
    dut.rst.value = 1
    dut.go.value = 1
    await Timer(30 * UI_PS, unit="ps")
    dut.rst.value = 0
    await Timer(60 * UI_PS, unit="ps")


async def _edge(dut, w):
    """Wait for the next rising CLKDIV_w edge; returns (tick, word) read after it."""
    await RisingEdge(getattr(dut, f"cd{w}"))
    await ReadOnly()
    return int(dut.k.value), int(getattr(dut, f"word{w}").value)


@cocotb.test()
async def test_ibufds(dut):
    """IBUFDS: O follows I when I and IB differ (1/0 -> 1, 0/1 -> 0)."""
    for p, n, o in ((1, 0, 1), (0, 1, 0), (1, 0, 1)):
        dut.p.value, dut.n.value = p, n
        await Timer(1, unit="ps")
        assert int(dut.pad.value) == o, f"I={p} IB={n}: O={dut.pad.value}"
    if cocotb.SIM_NAME.lower().startswith("icarus"):
        dut.p.value, dut.n.value = 1, 1
        await Timer(1, unit="ps")
        assert not dut.pad.value.is_resolvable, "I = IB must give x"


@cocotb.test()
async def test_ibufds_diff_out(dut):
    """IBUFDS_DIFF_OUT: O as IBUFDS's, OB its complement."""
    for p, n, o in ((1, 0, 1), (0, 1, 0), (1, 0, 1)):
        dut.p.value, dut.n.value = p, n
        await Timer(1, unit="ps")
        got = (int(dut.pad_o.value), int(dut.pad_ob.value))
        assert got == (o, 1 - o), f"I={p} IB={n}: O, OB = {got}"


@cocotb.test()
async def test_idelayctrl_rdy(dut):
    """IDELAYCTRL: RDY low in reset, high from the 32nd REFCLK rising edge after it."""
    cocotb.start_soon(Clock(dut.refclk, 5000, unit="ps").start())
    dut.ctl_rst.value = 1
    await Timer(20, unit="ns")
    assert int(dut.rdy.value) == 0
    await FallingEdge(dut.refclk)
    dut.ctl_rst.value = 0
    for edge in range(1, 40):
        await RisingEdge(dut.refclk)
        await ReadOnly()
        if int(dut.rdy.value):
            break
    assert edge == 32, f"RDY rose at edge {edge}"
    await FallingEdge(dut.refclk)
    dut.ctl_rst.value = 1
    await Timer(1, unit="ps")
    assert int(dut.rdy.value) == 0


async def _load(dut, tap):
    dut.cntin.value = tap
    dut.ld.value = 1
    await Timer(100, unit="ps")
    dut.c.value = 1
    await Timer(100, unit="ps")
    dut.c.value = 0
    dut.ld.value = 0
    await Timer(100, unit="ps")


async def _step(dut, inc):
    dut.ce.value, dut.inc.value = 1, int(inc)
    await Timer(100, unit="ps")
    dut.c.value = 1
    await Timer(100, unit="ps")
    dut.c.value = 0
    dut.ce.value = 0
    await Timer(100, unit="ps")


async def _delay_fs(dut, out, level):
    """Drive the pair to ``level`` and return the time (fs) until ``out`` follows."""
    t0 = get_sim_time(unit="fs")
    dut.p.value, dut.n.value = level, 1 - level
    await (RisingEdge(out) if level else FallingEdge(out))
    return get_sim_time(unit="fs") - t0


@cocotb.test()
async def test_idelay_tap_delay(dut):
    """IDELAYE2: DATAOUT = IDATAIN delayed by tap x 1/(32 x 2 x f_REFCLK): 78.125 ps a tap
    at 200 MHz (VAR_LOAD, taps 0..31), 52.083 ps at 300 MHz (FIXED, IDELAY_VALUE 5)."""
    dut.p.value, dut.n.value = 0, 1
    await Timer(10, unit="ns")
    for tap in (0, 1, 2, 17, 30, 31):
        await _load(dut, tap)
        await Timer(10, unit="ns")
        for level in (1, 0):
            got = await _delay_fs(dut, dut.dly, level)
            assert got == round(tap * TAP_PS(200.0) * 1000), f"tap {tap}: {got} fs"
            await Timer(10, unit="ns")
    got = await _delay_fs(dut, dut.dlyf, 1)
    assert got == round(5 * TAP_PS(300.0) * 1000), f"fixed tap 5 at 300 MHz: {got} fs"


@cocotb.test()
async def test_idelay_var_load(dut):
    """IDELAYE2 VAR_LOAD: LD loads CNTVALUEIN at a rising C edge; CE steps the tap up with
    INC, down without, wrapping 31 <-> 0; CNTVALUEOUT is the tap; FIXED ignores C."""
    await _load(dut, 7)
    assert int(dut.cntout.value) == 7
    await _step(dut, 1)
    assert int(dut.cntout.value) == 8
    await _step(dut, 0)
    await _step(dut, 0)
    assert int(dut.cntout.value) == 6
    await _load(dut, 31)
    await _step(dut, 1)
    assert int(dut.cntout.value) == 0, "31 + 1 wraps to 0"
    await _step(dut, 0)
    assert int(dut.cntout.value) == 31, "0 - 1 wraps to 31"
    dut.cntin.value, dut.ld.value, dut.ce.value, dut.inc.value = 3, 1, 1, 1
    await Timer(100, unit="ps")
    dut.c.value = 1
    await Timer(100, unit="ps")
    dut.c.value, dut.ld.value, dut.ce.value = 0, 0, 0
    assert int(dut.cntout.value) == 3, "LD has priority over CE"
    assert int(dut.cntoutf.value) == 5


@cocotb.test()
async def test_iserdes_bit_order(dut):
    """ISERDESE2 NETWORKING DDR, 4/6/8 bits (master) and 10/14 bits (master + slave): the
    first bit received is the highest Q (slave Q4 / Q8 with width expansion), the last Q1;
    the word sampled in the CLKDIV period ending at an edge is on Q from the next edge."""
    rng = random.Random(1)
    stream = rng.getrandbits(STREAM_BITS)
    await _start(dut, stream)
    for w in WIDTHS:
        for _ in range(12):
            k, word = await _edge(dut, w)
            if k >= 2 * w:
                exp = _bits(stream, k - 2 * w, w)
                assert word == exp, f"{w} bits at tick {k}: {word:0{w}b} != {exp:0{w}b}"


@cocotb.test()
async def test_iserdes_latency(dut):
    """ISERDESE2 latency: a single 1 sampled at tick t (in the CLKDIV period of word
    m = t // W) shows on Q at the CLKDIV edge of tick (m + 2) W, and at no other edge."""
    await _start(dut, 0)
    for w in (8, 10, 14):
        await Timer(1, unit="ps")          # out of the read-only phase of the last edge
        k_now = int(dut.k.value)
        t = k_now + 5 * w + 3
        dut.stream.value = 1 << (t % STREAM_BITS)
        seen = []
        while True:
            k, word = await _edge(dut, w)
            if word:
                seen.append(k)
            if k > t + 5 * w:
                break
        assert seen == [(t // w + 2) * w], f"{w} bits: bit of tick {t} seen at {seen}"


async def _slip(dut, w):
    """Pulse BITSLIP for one CLKDIV cycle (sampled high at the next rising edge); returns
    the tick of that edge."""
    cd = getattr(dut, f"cd{w}")
    await FallingEdge(cd)
    getattr(dut, f"bs{w}").value = 1
    await RisingEdge(cd)
    k = int(dut.k.value)
    await FallingEdge(cd)
    getattr(dut, f"bs{w}").value = 0
    return k


def _offsets(w, n):
    """Word-boundary offsets (bits earlier) after 0..n DDR slips: +1, -3, +1, -3, ..."""
    d, out = 0, [0]
    for i in range(n):
        d = (d + 1) % w if i % 2 == 0 else (d - 3) % w
        out.append(d)
    return out


async def _check_slips(dut, w, stream, count):
    offs = _offsets(w, count)
    for i in range(1, count + 1):
        ks = await _slip(dut, w)
        # the edge that samples BITSLIP captures the slipped word: Q from the next edge
        while True:
            k, word = await _edge(dut, w)
            if k == ks + w:
                break
        assert word == _bits(stream, k - 2 * w - offs[i], w), \
            f"{w} bits, slip {i}: {word:0{w}b}, offset {offs[i]} expected"
        k, word = await _edge(dut, w)
        assert word == _bits(stream, k - 2 * w - offs[i], w)
    return offs


@cocotb.test()
async def test_iserdes_bitslip(dut):
    """ISERDESE2 DDR BITSLIP: slips alternate a shift right by one (boundary one bit
    earlier) and a shift left by three; W slips visit each of the W alignments once and
    return to the first; the slipped word is on Q one CLKDIV cycle after the edge that
    samples BITSLIP."""
    rng = random.Random(2)
    stream = rng.getrandbits(STREAM_BITS)
    await _start(dut, stream)
    for w in (8, 10):
        offs = await _check_slips(dut, w, stream, w)
        assert sorted(offs[:w]) == list(range(w)) and offs[w] == 0


@cocotb.test()
async def test_iserdes_reset(dut):
    """ISERDESE2 RST: Q reads 0 while it is high; after it the bitslip state is back at the
    first alignment and the next slip is again a shift right by one."""
    rng = random.Random(3)
    stream = rng.getrandbits(STREAM_BITS)
    await _start(dut, stream)
    w = 10
    await _check_slips(dut, w, stream, 3)
    await FallingEdge(dut.cd10)
    dut.rst.value = 1
    for _ in range(2):
        k, word = await _edge(dut, w)
        assert word == 0, "Q is 0 in reset"
    await FallingEdge(dut.cd10)
    dut.rst.value = 0
    k_rel = int(dut.k.value)
    for _ in range(4):
        k, word = await _edge(dut, w)
    assert word == _bits(stream, k - 2 * w, w) and k - 2 * w > k_rel, "alignment reset"
    await _check_slips(dut, w, stream, 2)
