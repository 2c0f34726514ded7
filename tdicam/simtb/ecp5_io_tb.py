"""cocotb tests of the ECP5 primitive models (:mod:`tdicam.cosim.ecp5_io`) on the wrapper
of :mod:`tdicam.cosim.io_models`: one test per documented behaviour (run on both
simulators, and against mutants, by ``cocotb_tests/test_io_models.py``).
"""

import random

import cocotb
from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge, Timer
from cocotb.utils import get_sim_time

from tdicam.cosim.ecp5_io import N_STEPS, STEP_PS
from tdicam.cosim.io_models import STREAM_BITS, UI_PS


def _bit(stream, k):
    return (stream >> (k % STREAM_BITS)) & 1


async def _start(dut, stream):
    """Load ``stream``; CLKDIVF and the gearing in reset for 20 ticks, the divider released
    4 ticks before the gearing, then 20 ticks of the new stream."""
    dut.stream.value = stream
    dut.rst.value, dut.rst_div.value, dut.stop.value = 1, 1, 0
    dut.alignwd.value, dut.align_div.value = 0, 0
    dut.go.value = 1
    await Timer(20 * UI_PS + 300, unit="ps")
    dut.rst_div.value = 0
    await Timer(4 * UI_PS, unit="ps")
    dut.rst.value = 0
    await Timer(20 * UI_PS, unit="ps")


async def _delay_fs(dut, out):
    """Toggle A; the time (fs) until ``out`` follows."""
    level = 1 - int(dut.a.value)
    t0 = get_sim_time(unit="fs")
    dut.a.value = level
    await (RisingEdge(out) if level else FallingEdge(out))
    got = get_sim_time(unit="fs") - t0
    await Timer(5, unit="ns")
    return got


async def _move(dut, direction, n=1):
    dut.direction.value = direction
    for _ in range(n):
        await Timer(1, unit="ns")
        dut.move.value = 1
        await Timer(1, unit="ns")
        dut.move.value = 0
    await Timer(1, unit="ns")


def _fs(count):
    return round(count * STEP_PS * 1000)


async def _loadn(dut):
    dut.loadn.value = 0
    await Timer(1, unit="ns")
    dut.loadn.value = 1
    await Timer(1, unit="ns")


@cocotb.test()
async def test_delayf_step(dut):
    """DELAYF: Z = A delayed by count x 25 ps; the count starts at DEL_VALUE (10); a MOVE
    pulse steps it at MOVE's falling edge, DIRECTION 0 one step more delay, 1 one less."""
    await _loadn(dut)
    assert await _delay_fs(dut, dut.z) == _fs(10)
    await _move(dut, 0, 5)
    assert await _delay_fs(dut, dut.z) == _fs(15)
    await _move(dut, 1, 3)
    assert await _delay_fs(dut, dut.z) == _fs(12)
    dut.direction.value = 0
    dut.move.value = 1
    await Timer(1, unit="ns")
    assert await _delay_fs(dut, dut.z) == _fs(12), "no step before MOVE falls"
    dut.move.value = 0
    await Timer(1, unit="ns")
    assert await _delay_fs(dut, dut.z) == _fs(13), "one step when MOVE falls"


@cocotb.test()
async def test_delayf_limits(dut):
    """DELAYF: the count saturates at 0 and 127, CFLAG is high at the limit DIRECTION moves
    to; LOADN low returns it to DEL_VALUE and holds it there (MOVE ignored)."""
    await _loadn(dut)
    await _move(dut, 1, 15)
    assert await _delay_fs(dut, dut.z) == 0
    assert int(dut.cflag.value) == 1, "at 0 moving down"
    dut.direction.value = 0
    await Timer(1, unit="ns")
    assert int(dut.cflag.value) == 0
    await _move(dut, 0, N_STEPS + 5)
    assert await _delay_fs(dut, dut.z) == _fs(N_STEPS - 1)
    assert int(dut.cflag.value) == 1, "at 127 moving up"
    dut.direction.value = 1
    await Timer(1, unit="ns")
    assert int(dut.cflag.value) == 0
    dut.loadn.value = 0
    await _move(dut, 1, 3)
    dut.loadn.value = 1
    await Timer(1, unit="ns")
    assert await _delay_fs(dut, dut.z) == _fs(10)


@cocotb.test()
async def test_delayg(dut):
    """DELAYG: Z = A delayed by DEL_VALUE (40) x 25 ps = 1 ns."""
    assert await _delay_fs(dut, dut.zg) == _fs(40)
    assert await _delay_fs(dut, dut.zg) == _fs(40)


@cocotb.test()
async def test_iddrx1f(dut):
    """IDDRX1F: at each rising SCLK edge Q0 = the previous rising edge's sample (the earlier
    bit), Q1 = the falling edge's sample between."""
    stream = random.Random(4).getrandbits(STREAM_BITS)
    await _start(dut, stream)
    for _ in range(40):
        await RisingEdge(dut.eclki)
        await ReadOnly()
        k = int(dut.k.value)
        q = int(dut.q1.value)
        assert (q & 1, q >> 1) == (_bit(stream, k - 2), _bit(stream, k - 1)), f"tick {k}"


async def _sclk(dut):
    await RisingEdge(dut.sclk)
    await ReadOnly()
    return int(dut.k.value), int(dut.q2.value)


def _x2(stream, k, off=0):
    """Expected {Q3..Q0} at the SCLK edge of tick k: Q0 = sample k-3-off .. Q3 = k-off."""
    return sum(_bit(stream, k - 3 - off + i) << i for i in range(4))


@cocotb.test()
async def test_iddrx2f_order(dut):
    """IDDRX2F: at each rising SCLK edge Q0..Q3 = the last four ECLK-edge samples, Q0 the
    earliest, Q3 the sample of the ECLK edge SCLK rises from."""
    stream = random.Random(5).getrandbits(STREAM_BITS)
    await _start(dut, stream)
    for _ in range(40):
        k, q = await _sclk(dut)
        assert q == _x2(stream, k), f"tick {k}: {q:04b} != {_x2(stream, k):04b}"


@cocotb.test()
async def test_iddrx2f_latency(dut):
    """IDDRX2F latency: a single 1 sampled at tick t shows at the first SCLK edge at or after
    t (t <= k <= t + 3), and at no other."""
    await _start(dut, 0)
    for off in range(4):
        await Timer(1, unit="ps")
        t = int(dut.k.value) + 20 + off
        dut.stream.value = 1 << (t % STREAM_BITS)
        seen = []
        while True:
            k, q = await _sclk(dut)
            if q:
                seen.append(k)
            if k > t + 12:
                break
        assert len(seen) == 1 and t <= seen[0] <= t + 3, (t, seen)


@cocotb.test()
async def test_iddrx2f_alignwd(dut):
    """IDDRX2F ALIGNWD: high at an SCLK edge moves the word boundary one bit earlier from
    that edge's word on; four pulses return to the first alignment."""
    stream = random.Random(6).getrandbits(STREAM_BITS)
    await _start(dut, stream)
    for n in range(1, 5):
        await FallingEdge(dut.sclk)
        dut.alignwd.value = 1
        k, q = await _sclk(dut)
        assert q == _x2(stream, k, n % 4), f"pulse {n}: word of the sampling edge"
        await FallingEdge(dut.sclk)
        dut.alignwd.value = 0
        for _ in range(3):
            k, q = await _sclk(dut)
            assert q == _x2(stream, k, n % 4), f"pulse {n}, tick {k}"


@cocotb.test()
async def test_clkdivf_ratio(dut):
    """CLKDIVF DIV 2.0: SCLK (CDIVX) rises at every second ECLK rising edge, the first one
    after RST falls; low in reset; ALIGNWD at an ECLK edge slips its phase one ECLK cycle."""
    await _start(dut, 0)
    dut.rst.value = 1                    # the gearing checks SCLK = ECLK / 2: keep it out
    rises = []
    for _ in range(5):
        await RisingEdge(dut.sclk)
        rises.append(int(dut.k.value))
    assert all(b - a == 4 for a, b in zip(rises, rises[1:])), rises
    await FallingEdge(dut.eclki)
    dut.rst_div.value = 1
    await Timer(10 * UI_PS, unit="ps")
    assert int(dut.sclk.value) == 0
    await FallingEdge(dut.eclki)
    dut.rst_div.value = 0
    k_rel = int(dut.k.value)
    await RisingEdge(dut.sclk)
    assert int(dut.k.value) == k_rel + 1, "rises with the first ECLK edge after reset"
    await FallingEdge(dut.sclk)
    await FallingEdge(dut.eclki)
    dut.align_div.value = 1
    await RisingEdge(dut.eclki)
    await FallingEdge(dut.eclki)
    dut.align_div.value = 0
    rises = []
    for _ in range(3):
        await RisingEdge(dut.sclk)
        rises.append(int(dut.k.value))
    assert rises[1] - rises[0] == 4 and (rises[0] - k_rel) % 4 == 3, (k_rel, rises)
    await _start(dut, 0)


@cocotb.test()
async def test_eclksyncb(dut):
    """ECLKSYNCB: STOP sampled at ECLKI's falling edge: ECLKO stops and restarts low, every
    high pulse is a whole ECLKI high phase (no glitch), no edge while stopped."""
    await _start(dut, 0)
    dut.rst.value = 1
    pulses, stopped_edges = [], 0
    t_rise = None

    async def watch():
        nonlocal t_rise
        while True:
            await RisingEdge(dut.eclk)
            t_rise = get_sim_time(unit="ps")
            await FallingEdge(dut.eclk)
            pulses.append(get_sim_time(unit="ps") - t_rise)

    task = cocotb.start_soon(watch())
    rng = random.Random(7)
    for _ in range(6):
        await Timer(rng.randrange(3 * UI_PS, 9 * UI_PS) + 317, unit="ps")
        dut.stop.value = 1
        await FallingEdge(dut.eclki)
        await Timer(1, unit="ps")
        n0 = len(pulses)
        await Timer(8 * UI_PS, unit="ps")
        stopped_edges += len(pulses) - n0 + int(dut.eclk.value)
        await Timer(rng.randrange(0, UI_PS) + 111, unit="ps")
        dut.stop.value = 0
    await Timer(8 * UI_PS, unit="ps")
    task.cancel()
    assert stopped_edges == 0, "ECLKO moved while STOP was sampled high"
    assert pulses and all(p == UI_PS for p in pulses), sorted(set(pulses))
    await _start(dut, 0)
