"""TDI accumulator: golden model (three structures), gateware in the Amaranth simulator,
memory size, parameter errors, latency and throughput."""

import subprocess
import sys

import numpy as np
import pytest
from amaranth.hdl import ClockDomain, Fragment, Module, Shape
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out
from amaranth.sim import Simulator
from hypothesis import given, settings
from hypothesis import strategies as st

from tdicam import blocks
from tdicam.cosim import golden
from tdicam.cosim.codec import Beats
from tdicam.errors import TdicamError
from tdicam.hdl.tdi import TdiAccumulator
from tdicam.model.physics import plan
from tdicam.cosim.streamsim import run_stream_component
from tdicam.model.tdi import (BasicTdi, OptimizedTdi, basic_line_buffers, full_bits,
                              optimized_line_buffers, settings_valid, slots_needed, tdi,
                              tdi_basic, tdi_frames, tdi_optimized, tdi_stream)
from tdicam.hw.verilog import convert


def _direct(frames, m, direction):
    """O(t) written out term by term from Qu et al. 2010 eq 3 (mirrored rows for direction 1)."""
    T, _, W = frames.shape
    out = []
    for t in range(m - 1, T):
        line = [0] * W
        for k in range(1, m + 1):             # row k (1-based)
            src_row = k if direction == 0 else m + 1 - k
            fr = frames[t - k + 1]            # row k sees the line k-1 frames before row 1
            for w in range(W):
                line[w] += int(fr[src_row - 1, w])
        out.append(line)
    return np.array(out, np.int64).reshape(-1, W)


# ---------------------------------------------------------------- golden model

@pytest.mark.parametrize("direction", [0, 1])
def test_three_structures_equal_definition_m1_to_32(direction):
    rng = np.random.default_rng(direction)
    for m in range(1, 33):
        frames = rng.integers(0, 4096, (m + 4, m, 6)).astype(np.uint16)
        want = _direct(frames, m, direction) if m <= 12 else None
        got = [fn(frames, pixel_bits=12, direction=direction)
               for fn in (tdi, tdi_basic, tdi_optimized)]
        for g in got:
            assert g.dtype == (np.uint16 if full_bits(12, m) <= 16 else np.uint32)
            assert g.shape == (5, 6)
            np.testing.assert_array_equal(g, got[0])
        if want is not None:
            np.testing.assert_array_equal(got[0].astype(np.int64), want)


@pytest.mark.parametrize("m", [96, 128])
def test_structures_agree_large_m(m):
    rng = np.random.default_rng(m)
    frames = rng.integers(0, 1 << 14, (m + 3, m, 16)).astype(np.uint16)
    for d in (0, 1):
        a = tdi(frames, pixel_bits=14, direction=d)
        np.testing.assert_array_equal(a, tdi_basic(frames, pixel_bits=14, direction=d))
        np.testing.assert_array_equal(a, tdi_optimized(frames, pixel_bits=14, direction=d))
        # one spot check against the definition
        t = m + 2
        col = [int(frames[t - k + 1, (k if d == 0 else m + 1 - k) - 1, 5]) for k in range(1, m + 1)]
        assert int(a[3, 5]) == sum(col)


def test_tdi_honours_tdicam_threads(monkeypatch):
    """Large inputs (>= 2**24 pixel terms) spread over TDICAM_THREADS threads: the result
    does not depend on the count, and a bad value is a one-line error."""
    rng = np.random.default_rng(3)
    frames = rng.integers(0, 4096, (159, 32, 4096)).astype(np.uint16)
    out = {}
    for n in ("1", "3"):
        monkeypatch.setenv("TDICAM_THREADS", n)
        out[n] = tdi(frames, pixel_bits=12)
    np.testing.assert_array_equal(out["1"], out["3"])
    monkeypatch.setenv("TDICAM_THREADS", "two")
    with pytest.raises(TdicamError, match="TDICAM_THREADS = 'two'"):
        tdi(frames, pixel_bits=12)


@settings(max_examples=60, deadline=None)
@given(m=st.integers(1, 24), extra=st.integers(0, 6), w=st.integers(1, 9),
       bits=st.integers(8, 14), direction=st.integers(0, 1), sat=st.integers(0, 7),
       seed=st.integers(0, 2 ** 32 - 1))
def test_hypothesis_basic_equals_optimized(m, extra, w, bits, direction, sat, seed):
    rng = np.random.default_rng(seed)
    frames = rng.integers(0, 1 << bits, (m - 1 + extra, m, w))
    fb = full_bits(bits, m)
    out_bits = None if sat == 0 else min(bits + sat - 1, fb)
    kw = dict(pixel_bits=bits, out_bits=out_bits, direction=direction)
    a, b, c = tdi(frames, **kw), tdi_basic(frames, **kw), tdi_optimized(frames, **kw)
    assert a.shape == (max(extra, 0), w)
    for x in (b, c):
        assert x.dtype == a.dtype
        np.testing.assert_array_equal(x, a)
    if extra:
        ref = np.minimum(_direct(frames, m, direction), (1 << (out_bits or fb)) - 1)
        np.testing.assert_array_equal(a.astype(np.int64), ref)


def test_line_buffer_counts_and_saving():
    for m in (1, 2, 4, 12, 96, 128):
        basic, opt = BasicTdi(m), OptimizedTdi(m, 8)
        assert basic.line_buffers == basic_line_buffers(m) == m * (m - 1) // 2
        assert opt.line_buffers == optimized_line_buffers(m) == m - 1
        assert basic.line_buffers - opt.line_buffers == (m - 1) * (m - 2) // 2
        # reverse scan needs one line more (m >= 2): see slots_needed
        assert OptimizedTdi(m, 8, direction=1).line_buffers == (m if m > 1 else 0)
    # the basic FIFOs really hold m(m-1)/2 lines once full
    b = BasicTdi(5)
    for _ in range(7):
        b.push(np.zeros((5, 3), np.uint16))
    assert sum(len(f) for f in b.fifos) == 10


def test_full_scale_never_wraps_and_saturates_exactly():
    for bits, m in ((12, 96), (14, 128), (8, 2)):
        full = (1 << bits) - 1
        frames = np.full((m + 1, m, 4), full, np.uint16)
        out = tdi(frames, pixel_bits=bits, stages=m)
        assert out.tolist() == [[m * full] * 4] * 2          # no numpy or width wrap
        assert m * full < 1 << full_bits(bits, m)
        sat = tdi(frames, pixel_bits=bits, stages=m, out_bits=bits)
        assert sat.tolist() == [[full] * 4] * 2
        assert sat.dtype == (np.uint8 if bits == 8 else np.uint16)
    # sums beyond 65535 from uint16 input (the numpy wrap trap)
    frames = np.full((20, 20, 2), 4095, np.uint16)
    assert int(tdi(frames, pixel_bits=12)[0, 0]) == 20 * 4095


def test_output_needs_m_frames():
    frames = np.ones((5, 6, 3), np.uint16)
    assert tdi(frames, pixel_bits=12).shape == (0, 3)
    assert tdi_basic(frames, pixel_bits=12).shape == (0, 3)
    assert tdi_optimized(frames, pixel_bits=12).shape == (0, 3)
    assert tdi(np.ones((6, 6, 3), np.uint16), pixel_bits=12).tolist() == [[6, 6, 6]]


def test_settings_validity():
    assert settings_valid(96, 0, 96) and settings_valid(95, 1, 96)
    assert not settings_valid(96, 1, 96)     # reverse at m_max needs m_max lines
    assert not settings_valid(0, 0, 96) and not settings_valid(97, 0, 96)
    assert settings_valid(1, 1, 1) and settings_valid(1, 1, 2) and not settings_valid(2, 1, 2)
    assert slots_needed(1, 0) == slots_needed(1, 1) == 0
    assert slots_needed(5, 0) == 4 and slots_needed(5, 1) == 5


def _frames_stream(frames, settings_, ppc):
    from tdicam.blocks.tdi import stream_arrays
    params = {"width": frames[0].shape[1], "ppc": ppc, "pixel_bits": 12}
    return stream_arrays(frames, settings_, params)


def test_stream_model_equals_frame_model_with_setting_changes():
    rng = np.random.default_rng(3)
    seq = [(5, 0)] * 7 + [(2, 0)] * 3 + [(4, 1)] * 6 + [(1, 0)] * 2 + [(5, 0)] * 5 + [(0, 0)] \
        + [(3, 1)] * 4
    frames = [rng.integers(0, 4096, (max(m, 1), 8)) for m, _ in seq]
    lines, idx = tdi_frames(frames, [m for m, _ in seq], [d for _, d in seq], stages=5)
    # runs: 7 frames m=5 -> 3 lines, m=2 -> 2, m=4 rev -> 3, m=1 -> 2, m=5 -> 1, m=3 rev -> 2
    assert idx.tolist() == [4, 5, 6, 8, 9, 13, 14, 15, 16, 17, 22, 26, 27]
    for ppc in (1, 2, 4):
        a = _frames_stream(frames, seq, ppc)
        res = tdi_stream(a["pixels"], a["first"], a["last"], a["stages_active"], a["direction"],
                         width=8, stages=5, ppc=ppc)
        assert res.frame_errors == 1          # the m = 0 frame
        np.testing.assert_array_equal(res.data.reshape(-1, 8), lines)
        assert res.first.tolist() == ([True] + [False] * (8 // ppc - 1)) * len(lines)
        assert res.last.tolist() == ([False] * (8 // ppc - 1) + [True]) * len(lines)
    # first line: frames 0..4, m = 5 forward: row k of frame 4-k+1
    want = sum(frames[5 - k][k - 1] for k in range(1, 6))
    np.testing.assert_array_equal(lines[0], want)


def test_stream_model_cut_output_line_is_zero_padded():
    rng = np.random.default_rng(4)
    m, W = 3, 8
    frames = [rng.integers(1, 4096, (m, W)) for _ in range(4)]
    a = _frames_stream(frames, [(m, 0)] * 4, 1)
    cut = 3 * m * W + 5                      # frame 3 cut after 5 pixels of its output row
    n = {k: v[:cut] for k, v in a.items()}
    nxt = _frames_stream([frames[0]], [(m, 0)], 1)
    s = {k: np.concatenate([n[k], nxt[k]]) for k in n}
    res = tdi_stream(s["pixels"], s["first"], s["last"], s["stages_active"], s["direction"],
                     width=W, stages=m)
    full = tdi(np.stack(frames), pixel_bits=12)
    assert res.frame_errors == 1
    assert res.data[:W, 0].tolist() == full[0].tolist()
    assert res.data[W:W + 5, 0].tolist() == full[1, :5].tolist()
    assert res.data[W + 5:, 0].tolist() == [0, 0, 0]
    assert res.last.tolist() == ([False] * 7 + [True]) * 2
    # unfinished at the end of input: no padding (more beats may come)
    res = tdi_stream(n["pixels"], n["first"], n["last"], m, 0, width=W, stages=m)
    assert len(res.first) == W + 5 and res.frame_errors == 0


@pytest.mark.parametrize("kwargs,match", [
    ({"pixel_bits": 15}, "pixel_bits = 15 is out of range; valid: 8..14"),
    ({"stages": 4, "out_bits": 20}, r"out_bits = 20 is out of range; valid: 12\.\.14"),
    ({"stages": 4, "out_bits": 11}, "out_bits = 11 is out of range"),
    ({"stages": 129}, "stages = 129 is out of range; valid: 1..128"),
    ({"stages": 0}, "stages = 0 is out of range"),
    ({"stages_active": 5, "stages": 4}, "stages_active = 5 is out of range; valid: 1..4"),
    ({"direction": 2}, "direction = 2 is not valid"),
])
def test_model_bad_params(kwargs, match):
    frames = np.zeros((6, kwargs.get("stages_active", 4), 4), np.uint16)
    with pytest.raises(TdicamError, match=match):
        tdi(frames, **kwargs)


def test_model_bad_input():
    with pytest.raises(TdicamError, match="frames has values outside 0..4095"):
        tdi(np.full((3, 2, 2), 4096, np.uint16), pixel_bits=12)
    with pytest.raises(TdicamError, match="integer"):
        tdi(np.zeros((3, 2, 2)), pixel_bits=12)
    with pytest.raises(TdicamError, match="frames have 3 rows, stages_active = 2"):
        tdi(np.zeros((3, 3, 2), np.uint16), stages_active=2)
    with pytest.raises(TdicamError, match="shape"):
        tdi(np.zeros((3, 2), np.uint16))


# ---------------------------------------------------------------- gateware

@pytest.mark.parametrize("kwargs,match", [
    ({"width": 63, "stages": 4, "ppc": 4}, "width = 63 is not a multiple of ppc = 4"),
    ({"width": 4, "stages": 4, "ppc": 4}, r"need at least 2 \(width >= 2 \* ppc\)"),
    ({"width": 64, "stages": 0}, "stages = 0 is out of range; valid: 1..128"),
    ({"width": 64, "stages": 129}, "stages = 129 is out of range; valid: 1..128"),
    ({"width": 64, "stages": 4, "pixel_bits": 7}, "pixel_bits = 7 is out of range; valid: 8..14"),
    ({"width": 64, "stages": 4, "pixel_bits": 16}, "pixel_bits = 16 is out of range"),
    ({"width": 64, "stages": 4, "ppc": 3}, "ppc = 3 is not valid; valid: 1, 2, 4, 8"),
    ({"width": 8193, "stages": 4}, "width = 8193 is out of range; valid: 1..8192"),
    ({"width": 64, "stages": 4, "out_bits": 15}, "out_bits = 15 is out of range; valid: 12..14"),
])
def test_component_bad_params(kwargs, match):
    with pytest.raises(TdicamError, match=match):
        TdiAccumulator(**kwargs)


@pytest.mark.parametrize("args,expect", [
    (["--width", "63", "--ppc", "4"], "width = 63 is not a multiple of ppc = 4"),
    (["--stages", "0"], "--stages = 0 is out of range; valid: 1..128"),
    (["--stages", "200"], "--stages = 200 is out of range; valid: 1..128"),
    (["--pixel-bits", "16"], "--pixel-bits = 16 is out of range; valid: 8..14"),
    (["--pixel-bits", "7"], "--pixel-bits = 7 is out of range; valid: 8..14"),
    (["--ppc", "3"], "--ppc = 3 is not valid; valid: 1, 2, 4, 8"),
    (["--out-bits", "20"], "out_bits = 20 is out of range; valid: 12..19"),
])
def test_cli_bad_params_one_line(args, expect):
    proc = subprocess.run([sys.executable, "-m", "tdicam", "verilog", "tdi", *args],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    err = proc.stderr.strip()
    assert len(err.splitlines()) == 1 and expect in err and "Traceback" not in err, err


def test_component_properties():
    dut = TdiAccumulator(width=1280, stages=96, pixel_bits=12, ppc=4)
    assert (dut.width, dut.stages, dut.pixel_bits, dut.ppc) == (1280, 96, 12, 4)
    assert dut.psum_bits == dut.out_bits == 19 and not dut.saturating
    assert dut.latency == 9
    assert dut.memory_lines == 95
    assert dut.memory_shape == (4, 95 * 320, 19)
    assert dut.memory_parts == (18, 1)
    assert TdiAccumulator(width=64, stages=4, pixel_bits=14).memory_parts == (9, 4, 2, 1)
    assert dut.row_cycles == 320 and TdiAccumulator(width=8, stages=3, ppc=2).row_cycles == 6
    sat = TdiAccumulator(width=64, stages=4, out_bits=12)
    assert sat.out_bits == 12 and sat.psum_bits == 14 and sat.saturating
    assert len(dut.stages_active) == 7 and len(dut.direction) == 1


def _memories(dut):
    """(name, depth, width, read ports, write ports) of the partial-sum memories (named
    psum_b<bit offset>_<bank>) of the elaborated design."""
    frag = Fragment.get(dut, None)
    found = []

    def walk(f, name):
        if type(f).__name__ == "MemoryInstance" and name.startswith("psum"):
            found.append((name, f._data.depth, Shape.cast(f._data.shape).width,
                          len(f._read_ports), len(f._write_ports)))
        for sub, sub_name, *_ in f.subfragments:
            walk(sub, str(sub_name))
    walk(frag, "")
    return found


_BANK = {18: 2048, 9: 2048, 4: 4096, 2: 8192, 1: 16384}   # words per bank of each part width
_DP16KD = ((16384, 1), (8192, 2), (4096, 4), (2048, 9), (1024, 18))   # (depth, width) modes


def _block_rams(mems):
    """DP16KD blocks the banks need: each memory in its cheapest DP16KD mode."""
    return sum(min(-(-d // bd) * -(-w // bw) for bd, bw in _DP16KD) for _, d, w, *_ in mems)


def _bank_memories(dut):
    """(name, depth, width) of the DP16KD banks ``bram="ecp5"`` builds (:attr:`memory_banks`:
    each bank holds its part of every lane, ppc x part bits)."""
    out, lo = [], 0
    for pw, depths in dut.memory_banks:
        out += [(f"psum_b{lo}_{c}", d, dut.ppc * pw) for c, d in enumerate(depths)]
        lo += pw
    return out


@pytest.mark.parametrize("width,stages,bits,ppc", [
    (64, 4, 12, 1), (64, 4, 12, 4), (256, 32, 12, 1), (1280, 96, 12, 1), (1280, 96, 12, 8),
    (8192, 128, 14, 8), (48, 5, 14, 2), (16, 2, 8, 1), (64, 4, 14, 1)])
def test_memory_is_m_minus_1_lines(width, stages, bits, ppc):
    """The elaborated design holds exactly (m_max-1) x W partial sums of the full width —
    (m_max-1)(m_max-2)/2 lines fewer than the basic structure — in ppc lanes: the generic
    description one memory of (m-1) W/ppc words of ppc x psum bits with one read and one
    write port. The ECP5 banks (:attr:`memory_banks`) split a lane's words by bits into
    parts of a DP16KD data width (18, 9, 4, 2, 1; 19 bits = 18 + 1) and each part by
    address into banks (2048 words for 18 and 9 bits, one block RAM's depth below): every
    bit is stored exactly once there too."""
    dut = TdiAccumulator(width=width, stages=stages, pixel_bits=bits, ppc=ppc)
    mems = _memories(dut)
    psum = bits + (stages - 1).bit_length()
    depth = (stages - 1) * width // ppc
    assert mems == [("psum", depth, ppc * psum, 1, 1)]
    parts = {}
    for name, d, bw in _bank_memories(dut):
        _, offset, index = name.split("_")
        pw = bw // ppc
        assert bw == pw * ppc
        assert d == min(_BANK[pw], depth - int(index) * _BANK[pw])
        parts.setdefault((int(offset[1:]), pw), []).append(d)
    # the parts tile the word's bits, each holds every word of every lane
    offsets = sorted(parts)
    assert [o for o, _ in offsets] == [sum(w for _, w in offsets[:i])
                                       for i in range(len(offsets))]
    assert sum(w for _, w in offsets) == psum
    assert all(sum(ds) == depth for ds in parts.values())
    words = depth * ppc
    assert words == (stages - 1) * width
    assert words * psum == (stages - 1) * width * full_bits(bits, stages)
    assert basic_line_buffers(stages) * width - words == \
        (stages - 1) * (stages - 2) // 2 * width
    # agrees with the planning model's line-buffer count and partial-sum width
    assert plan.tdi_line_buffer_lines(stages) == stages - 1
    assert plan.tdi_line_buffer_lines(stages, "basic") == basic_line_buffers(stages)
    assert plan.partial_sum_bits(bits, stages) == psum


def test_reference_memory_block_rams():
    """At the reference parameters the ECP5 banks need 127 DP16KD for ppc=1 (119 for the
    18-bit part + 8 of 16384 x 1) and 128 for ppc=4 and ppc=8 (120 + 8); the floor is
    ceil(95 x 1280 x 19 / 18432) = 126 (yosys' counts: the silicon-cost rows, docs/guide/silicon.md)."""
    for ppc, n, n18 in ((1, 127, 119), (4, 128, 120), (8, 128, 120)):
        mems = _bank_memories(TdiAccumulator(width=1280, stages=96, pixel_bits=12, ppc=ppc))
        assert _block_rams(mems) == n
        assert _block_rams([x for x in mems if x[0].startswith("psum_b0_")]) == n18


def test_memory_in_generated_verilog():
    """The memory in the Verilog: no initial value (no ``initial`` block spelling out zeros),
    yosys' ``no_rw_check`` attribute."""
    from tdicam.hdl.interfaces.axis import AxisTop
    text = convert(AxisTop(TdiAccumulator(width=64, stages=6, pixel_bits=10, ppc=2)), "tdi")
    lines = [ln.strip() for ln in text.splitlines()]
    decls = sorted((lines[i - 1], ln) for i, ln in enumerate(lines) if ln.startswith("reg [")
                   and ln.endswith("];") and "] psum" in ln)
    # 5 lines x 64 pixels of 13 bits, as 160 words of 2 lanes x 13 bits
    assert decls == [("(* no_rw_check = 32'd1 *)", "reg [25:0] psum [159:0];")]
    assert not any("psum" in ln and "=" in ln and "<=" not in ln for ln in lines)


def _dp16kd(dut):
    """(name, DATA_WIDTH_B, REGMODE_B) of the DP16KD instances of the elaborated design."""
    found = []

    def walk(f, name):
        if type(f).__name__ == "Instance" and f.type == "DP16KD":
            found.append((name, f.parameters["DATA_WIDTH_B"], f.parameters["REGMODE_B"]))
        for sub, sub_name, *_ in getattr(f, "subfragments", ()):
            walk(sub, str(sub_name))
    walk(Fragment.get(dut, None), "")
    return found


def test_bram_parameter():
    assert TdiAccumulator(width=64, stages=4).bram == "generic"
    assert TdiAccumulator(width=64, stages=4, bram="ecp5").bram == "ecp5"
    with pytest.raises(TdicamError, match="^bram = 'xc7' is not valid; valid: generic, ecp5$"):
        TdiAccumulator(width=64, stages=4, bram="xc7")


@pytest.mark.parametrize("width,stages,bits,ppc", [
    (1280, 96, 12, 1), (1280, 96, 12, 4), (1280, 96, 12, 8), (64, 4, 12, 1), (48, 5, 14, 2),
    (256, 32, 12, 4)])
def test_ecp5_banks_as_many_block_rams(width, stages, bits, ppc):
    """``bram="ecp5"``: the banks are DP16KD instances with the output register in use,
    as many as the banks' cheapest DP16KD modes (127 / 128 / 128 at the reference
    parameters) and no ``lib.memory`` memory left; one read stage more."""
    kw = dict(width=width, stages=stages, pixel_bits=bits, ppc=ppc)
    gen, ecp5 = TdiAccumulator(**kw), TdiAccumulator(**kw, bram="ecp5")
    prims = _dp16kd(ecp5)
    assert _memories(ecp5) == []
    assert len(prims) == _block_rams(_bank_memories(ecp5))
    if (width, stages) == (1280, 96):
        assert len(prims) == (127 if ppc == 1 else 128)
    assert all(regmode == "OUTREG" for *_, regmode in prims)
    assert (ecp5.latency, gen.latency) == (10, 9)       # the output register: one stage more
    assert ecp5.row_cycles == max(width // ppc, 7) and gen.row_cycles == max(width // ppc, 6)


def test_stages_one_has_no_memory():
    assert _memories(TdiAccumulator(width=16, stages=1)) == []


# ---- Amaranth simulation

def _simulate(dut, pixels, first, last, sa, dr, *, idle=0.0, bp=0.0, seed=0, reset_at=None,
              trace=None):
    """Drive beats with random idle/backpressure; return (output beats, frame_errors).

    ``trace`` (list) receives (cycle, event) for input transfers and output valid rises.
    """
    rng = np.random.default_rng(seed)
    n, ppc = len(first), dut.ppc
    got, state = [], {"done": False, "errors": None, "cycle": 0}

    async def source(ctx):
        for k in range(n):
            while rng.random() < idle:
                await ctx.tick()
            data = dut.i_stream.payload.data
            if ppc == 1:
                ctx.set(data, int(pixels[k, 0]))
            else:
                for j in range(ppc):
                    ctx.set(data[j], int(pixels[k, j]))
            ctx.set(dut.i_stream.payload.first, bool(first[k]))
            ctx.set(dut.i_stream.payload.last, bool(last[k]))
            ctx.set(dut.stages_active, int(sa[k]))
            ctx.set(dut.direction, int(dr[k]))
            ctx.set(dut.i_stream.valid, 1)
            await ctx.tick().until(dut.i_stream.ready)
            ctx.set(dut.i_stream.valid, 0)
        for _ in range(40):
            await ctx.tick()
        state["errors"] = ctx.get(dut.frame_errors)
        state["done"] = True

    async def sink(ctx):
        while not state["done"]:
            ctx.set(dut.o_stream.ready, int(rng.random() >= bp))
            await ctx.tick()

    async def monitor(ctx):
        cycle = 0
        async for _, _, iv, ir, ov, orr, data, fst, lst in ctx.tick().sample(
                dut.i_stream.valid, dut.i_stream.ready, dut.o_stream.valid,
                dut.o_stream.ready, dut.o_stream.payload.data, dut.o_stream.payload.first,
                dut.o_stream.payload.last):
            if trace is not None:
                if iv and ir:
                    trace.append((cycle, "in"))
                if ov:
                    trace.append((cycle, "out_valid"))
            if ov and orr:
                got.append(([int(data)] if ppc == 1 else [int(x) for x in data], fst, lst))
            cycle += 1
            if state["done"]:
                break

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    for tb in (source, sink, monitor):
        sim.add_testbench(tb)
    sim.run()
    data = np.array([g[0] for g in got], np.int64).reshape(-1, ppc)
    return (data, np.array([bool(g[1]) for g in got], bool),
            np.array([bool(g[2]) for g in got], bool)), state["errors"]


def _check_sim(params, a, **kw):
    dut = TdiAccumulator(**params)
    (data, fst, lst), errors = _simulate(dut, a["pixels"].reshape(len(a["first"]), -1),
                                         a["first"], a["last"], a["stages_active"],
                                         a["direction"], **kw)
    want = tdi_stream(a["pixels"], a["first"], a["last"], a["stages_active"], a["direction"],
                      **params)
    assert data.shape == want.data.shape, (data.shape, want.data.shape)
    np.testing.assert_array_equal(data, want.data)
    np.testing.assert_array_equal(fst, want.first)
    np.testing.assert_array_equal(lst, want.last)
    assert errors == want.frame_errors
    return want


@pytest.mark.parametrize("case", ["stages_64x4_p4_sat", "errors_64x4_p4_sat",
                                  "mixed_48x5_p2_14b", "mixed_64x3_p8_8b_sat"])
def test_amaranth_sim_golden_cases(case):
    """Golden cases through the Python simulator with random idle and backpressure, output
    beats and the frame_errors port compared with the stored expectation."""
    arrays, params = golden.load("tdi", case)
    want = _check_sim(params, arrays, idle=0.3, bp=0.4, seed=5)
    np.testing.assert_array_equal(want.data, arrays["out"])
    assert want.frame_errors == int(arrays["frame_errors"])


class _FixedSettings(wiring.Component):
    """The accumulator with constant run-time settings: a plain stream component for the
    shared driver (:func:`tdicam.cosim.streamsim.run_stream_component`)."""

    def __init__(self, dut, stages_active, direction):
        self.dut, self._settings = dut, (stages_active, direction)
        self.latency = dut.latency
        super().__init__({"i_stream": In(dut.i_stream.signature.flip()),
                          "o_stream": Out(dut.o_stream.signature),
                          "frame_errors": Out(16)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.dut = d = self.dut
        wiring.connect(m, wiring.flipped(self.i_stream), d.i_stream)
        wiring.connect(m, d.o_stream, wiring.flipped(self.o_stream))
        m.d.comb += [d.stages_active.eq(self._settings[0]), d.direction.eq(self._settings[1]),
                     self.frame_errors.eq(d.frame_errors)]
        return m


@pytest.mark.parametrize("case", ["random_64x4_p4_sat", "fullscale_64x4_p4_sat",
                                  "fullscale_64x3_p8_8b_sat"])
def test_amaranth_sim_shared_driver(case):
    """Golden cases with constant settings through the shared stream driver (random idle
    and backpressure): output beats and frame_errors as stored, and the first output beat
    valid exactly ``latency`` cycles after the input beat that completes it."""
    arrays, params = golden.load("tdi", case)
    (m_set,), (d_set,) = np.unique(arrays["stages_active"]), np.unique(arrays["direction"])
    dut = _FixedSettings(TdiAccumulator(**params), int(m_set), int(d_set))
    stim = Beats(arrays["pixels"], arrays["first"], arrays["last"])
    n_out = len(arrays["out_first"])
    first_out = (int(m_set) - 1) * int(m_set) * params["width"] // params["ppc"]
    out, lat, final = run_stream_component(dut, stim, n_out, seed=4, p_valid=0.7,
                                           p_ready=0.6, status=("frame_errors",),
                                           latency_from=first_out,
                                           timeout=1e-8 * (3 * len(stim) + 500))
    np.testing.assert_array_equal(np.array([o[0] for o in out]), arrays["out"])
    assert [o[1] for o in out] == arrays["out_first"].tolist()
    assert [o[2] for o in out] == arrays["out_last"].tolist()
    assert final["frame_errors"] == int(arrays["frame_errors"])
    assert lat == [dut.latency]


def _fuzz_stream(rng, W, M, ppc, nframes, pbad=0.3):
    """Random frames with random settings (some invalid) and random malformations."""
    from tdicam.blocks.tdi import stream_arrays
    params = {"width": W, "ppc": ppc, "pixel_bits": 12}
    parts = []
    if rng.random() < 0.3:
        a = stream_arrays([rng.integers(0, 4096, (1, W))], [(1, 0)], params)
        c = int(rng.integers(1, 5))
        parts.append({k: v[:c] for k, v in a.items()})
        parts[-1]["first"] = np.zeros_like(parts[-1]["first"])
    m, d = int(rng.integers(1, M + 1)), 0
    for _ in range(nframes):
        if rng.random() < 0.25:
            m, d = int(rng.integers(0, M + 2)), int(rng.integers(0, 2))
        a = stream_arrays([rng.integers(0, 4096, (max(m, 1), W))], [(m, d)], params)
        if rng.random() < pbad:
            k, n = int(rng.integers(0, 4)), len(a["first"])
            if k == 0:
                c = int(rng.integers(1, n))
                a = {key: v[:c] for key, v in a.items()}
            elif k == 1:
                j = int(rng.integers(0, n))
                a["last"][j] = ~a["last"][j]
            elif k == 2:
                x = stream_arrays([rng.integers(0, 4096, (1, W))], [(m, d)], params)
                c = int(rng.integers(1, 4))
                x = {key: v[:c] for key, v in x.items()}
                x["first"] = np.zeros_like(x["first"])
                a = {key: np.concatenate([a[key], x[key]]) for key in a}
            else:
                a["first"][0] = False
        parts.append(a)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


@pytest.mark.parametrize("seed", range(12))
def test_amaranth_sim_fuzz_malformed_streams(seed):
    """Random settings (incl. invalid), cut/long frames, wrong tlast, missing tuser,
    random idle and backpressure: the gateware equals the beat-level model."""
    rng = np.random.default_rng(seed)
    W = int(rng.choice([4, 6, 8]))
    M = int(rng.integers(1, 6))
    ppc = int(rng.choice([p for p in (1, 2) if W // p >= 2]))
    a = _fuzz_stream(rng, W, M, ppc, int(rng.integers(8, 25)))
    _check_sim({"width": W, "stages": M, "pixel_bits": 12, "out_bits": None, "ppc": ppc}, a,
               idle=0.3, bp=0.4, seed=seed)


def test_latency_and_full_throughput():
    """No stalls: every input beat is accepted back to back (ppc pixels per clock), and each
    output beat is valid exactly `latency` cycles after its output-row input beat."""
    from tdicam.blocks.tdi import stream_arrays
    rng = np.random.default_rng(9)
    params = {"width": 16, "stages": 3, "pixel_bits": 12, "out_bits": None, "ppc": 2}
    a = stream_arrays([rng.integers(0, 4096, (3, 16)) for _ in range(6)], [(3, 0)] * 6,
                      params)
    dut = TdiAccumulator(**params)
    trace = []
    (data, _, _), _ = _simulate(dut, a["pixels"].reshape(-1, 2), a["first"], a["last"],
                                a["stages_active"], a["direction"], trace=trace)
    ins = [c for c, e in trace if e == "in"]
    outs = [c for c, e in trace if e == "out_valid"]
    n = len(a["first"])
    assert len(ins) == n and ins == list(range(ins[0], ins[0] + n))   # one beat per clock
    wb, per_frame = 8, 3 * 8
    # output rows are row 1 of frames 2..5: input beats 2*24 .. 2*24+7, etc.
    out_beats = [ins[f * per_frame + c] for f in range(2, 6) for c in range(wb)]
    assert outs == [c + dut.latency for c in out_beats]
    assert len(data) == 4 * wb


def test_nonoutput_rows_flow_while_output_stalled():
    """With o_stream.ready held low, frames that produce no output stream in at one beat per
    clock; an output row stalls the input once its output credits (read pipeline, output
    register and FIFO), the decode register and the input register are full — and nothing is lost
    when ready returns."""
    from tdicam.blocks.tdi import stream_arrays
    rng = np.random.default_rng(2)
    params = {"width": 8, "stages": 4, "pixel_bits": 12, "out_bits": None, "ppc": 1}
    a = stream_arrays([rng.integers(0, 4096, (4, 8)) for _ in range(5)], [(4, 0)] * 5,
                      params)
    dut = TdiAccumulator(**params)
    n = len(a["first"])
    accepted, got = [], []

    async def bench(ctx):
        k = cycle = 0
        while cycle < 400:
            if k < n:
                ctx.set(dut.i_stream.payload.data, int(a["pixels"][k, 0]))
                ctx.set(dut.i_stream.payload.first, bool(a["first"][k]))
                ctx.set(dut.i_stream.payload.last, bool(a["last"][k]))
                ctx.set(dut.stages_active, 4)
            ctx.set(dut.i_stream.valid, k < n)
            ctx.set(dut.o_stream.ready, cycle >= 200)
            _, _, iv, ir, ov, orr, d = await ctx.tick().sample(
                dut.i_stream.valid, dut.i_stream.ready, dut.o_stream.valid,
                dut.o_stream.ready, dut.o_stream.payload.data)
            if iv and ir:
                accepted.append(cycle)
                k += 1
            if ov and orr:
                got.append(int(d))
            cycle += 1

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    stalled = [c for c in accepted if c < 200]
    # the 8 output credits (5 read-pipeline stages, the output register, 2 in the output
    # FIFO) take frame 3's whole 8-beat output row; then frame 4's output row stalls with
    # 2 beats in (input register, decode register)
    assert stalled == list(range(4 * 32 + 2))
    assert len(accepted) == n
    want = tdi_stream(a["pixels"], a["first"], a["last"], 4, 0, **params)
    assert got == want.data[:, 0].tolist() and len(got) == 2 * 8


def test_reset_mid_frame_amaranth():
    """Synchronous reset in the middle of an output row, then clean output after refill:
    before the reset a prefix of the expected lines, after it exactly the model applied to
    the beats that follow the reset."""
    arrays, params = golden.load("tdi", "reset_64x4_p1")
    cut = int(arrays["reset_before"][0])
    before = int(arrays["exp_before"][0])
    dut = TdiAccumulator(**params)
    rng = np.random.default_rng(0)
    n = len(arrays["first"])
    got, marks = [], []

    async def bench(ctx):
        k, drain = 0, 0
        while drain < 40:
            if k == cut and not marks:
                ctx.set(dut.i_stream.valid, 0)
                ctx.set(cd.rst, 1)
                for _ in range(6):                 # 3 rising edges (tick() refuses in reset)
                    await ctx.changed(cd.clk)
                ctx.set(cd.rst, 0)
                marks.append(len(got))
                continue
            present = k < n and rng.random() > 0.2
            if present:
                ctx.set(dut.i_stream.payload.data, int(arrays["pixels"][k, 0]))
                ctx.set(dut.i_stream.payload.first, bool(arrays["first"][k]))
                ctx.set(dut.i_stream.payload.last, bool(arrays["last"][k]))
                ctx.set(dut.stages_active, int(arrays["stages_active"][k]))
                ctx.set(dut.direction, int(arrays["direction"][k]))
            ctx.set(dut.i_stream.valid, present)
            ctx.set(dut.o_stream.ready, rng.random() > 0.3)
            _, _, iv, ir, ov, orr, d, fst, lst = await ctx.tick().sample(
                dut.i_stream.valid, dut.i_stream.ready, dut.o_stream.valid,
                dut.o_stream.ready, dut.o_stream.payload.data, dut.o_stream.payload.first,
                dut.o_stream.payload.last)
            k += bool(iv and ir)
            if ov and orr:
                got.append((int(d), bool(fst), bool(lst)))
            drain = drain + 1 if k >= n else 0
        marks.append(ctx.get(dut.frame_errors))

    top = Module()
    top.domains.sync = cd = ClockDomain("sync")
    top.submodules.dut = dut
    sim = Simulator(top)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    seg0, seg1 = got[:marks[0]], got[marks[0]:]
    assert 0 < len(seg0) <= before
    assert [g[0] for g in seg0] == arrays["out"][:len(seg0), 0].tolist()
    tail = {k: arrays[k][cut:] for k in ("pixels", "first", "last", "stages_active",
                                         "direction")}
    want = tdi_stream(tail["pixels"], tail["first"], tail["last"], tail["stages_active"],
                      tail["direction"], **params)
    assert len(seg1) == len(arrays["out"]) - before == len(want.first) > 0
    assert [g[0] for g in seg1] == want.data[:, 0].tolist() == arrays["out"][before:, 0].tolist()
    assert [g[1] for g in seg1] == want.first.tolist()
    assert [g[2] for g in seg1] == want.last.tolist()
    assert marks[1] == want.frame_errors == 1   # the tail of the cut frame was dropped
