"""Co-simulation of the generated ``cds`` Verilog against its golden model.

The standard runs of the golden cases (per beat, fast mode, extreme stalls, on the
simulators and with the short forms the block's registry entry states in ``Block.suite``)
are cocotb_tests/test_streams.py's; this file holds what is particular to the block.
"""

import re
import struct
from pathlib import Path

import numpy as np
import pytest

from tdicam import blocks
from tdicam.beats import mark_resets
from tdicam.cosim import golden, WAVE_WINDOW
from tdicam.cosim.codec import frames_to_beats
from tdicam.cosim.testing import check_beats, check_case, WIDE_PPC
from tdicam.model.cds import cds


def test_long_stream_crosses_memory_chunks():
    """More beats than the fast testbench's stimulus memory holds (65,536)."""
    rng = np.random.default_rng(5)
    sig = rng.integers(0, 1 << 10, (2, 40, 1000), dtype=np.uint16)
    rst = rng.integers(0, 1 << 10, (2, 40, 1000), dtype=np.uint16)
    params = blocks.get("cds").resolve({"pixel_bits": 10})
    stim = frames_to_beats(np.stack([sig, rst], -1), channels=2)
    exp = frames_to_beats(cds(sig, rst, pixel_bits=10))
    assert len(stim) > 65536
    check_beats("cds", params, stim, exp, sim="verilator", mode="fast", idle=0.1,
                backpressure=0.1)


def test_reset_mid_frame_case_is_really_cut():
    arrays, _ = golden.load("cds", "reset_mid_frame_12b")
    assert 0 < int(arrays["reset_before"][0]) < arrays["signal"][0].size


def _fst_times(path):
    """Start and end time (ps) from an FST file's header block."""
    raw = Path(path).read_bytes()
    assert raw[0] == 0                                     # header block first
    _, start, end = struct.unpack(">QQQ", raw[1:25])
    return start, end


@pytest.mark.parametrize("mode", ["beat", "fast"])
def test_mismatch_names_the_pixel_and_leaves_a_waveform(mode, tmp_path):
    """A corrupted expected pixel fails the check with block, frame/line/column, expected
    and received values and the path of an FST window around the mismatching cycle."""
    hit = (1, 5, 7)                                        # frame, line, column

    def corrupt(arrays):
        arrays["out"][hit] ^= 1

    with pytest.raises(AssertionError) as info:
        check_case("cds", "random_12b", sim="icarus", mode=mode, idle=0.3, backpressure=0.3,
                   seed=5, corrupt=corrupt, wave_dir=tmp_path)
    msg = str(info.value).splitlines()[0]
    arrays, _ = golden.load("cds", "random_12b")
    good = int(arrays["out"][hit])
    assert msg.startswith(f"cds icarus {mode}: 1 mismatches; first at frame 1 line 5 "
                          f"column 7 (segment 0 beat {(1 * 16 + 5) * 24 + 7}): expected "
                          f"{good ^ 1}, received {good} "), msg
    m = re.search(r"waveform (\S+) \(cycles (\d+)\.\.(\d+), mismatch at cycle (\d+), Icarus\)",
                  msg)
    assert m, msg
    wave, lo, hi, cycle = Path(m[1]), int(m[2]), int(m[3]), int(m[4])
    assert wave.parent == tmp_path and wave.exists()
    assert (lo, hi) == (cycle - WAVE_WINDOW, cycle + WAVE_WINDOW)
    # the output transfer of that beat is cycle ~ beat / (1 - 0.3)^2 after the reset
    assert (1 * 16 + 5) * 24 + 7 < cycle < 4 * ((1 * 16 + 5) * 24 + 7)
    start, end = _fst_times(wave)
    t = cycle * 10_000                                     # 10 ns clock, ps
    assert 0 < start <= t <= end                           # a window, not from time 0
    assert t - (WAVE_WINDOW + 10) * 10_000 <= start and end <= t + (WAVE_WINDOW + 10) * 10_000


def test_sim_command_prints_the_mismatch_and_its_waveform(monkeypatch, capsys, tmp_path):
    """``tdicam sim`` on a case whose expected output is wrong: exit 1, the row names the
    pixel and the waveform, which exists."""
    from tdicam.cli import main
    real = golden.load

    def corrupted(block, case):
        arrays, params = real(block, case)
        arrays["out"][0, 2, 3] ^= 1
        return arrays, params

    monkeypatch.setattr(golden, "load", corrupted)
    assert main(["sim", "cds", "--sim", "icarus", "--fast", "--case", "random_12b",
                 "--wave-dir", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "first at frame 0 line 2 column 3 (segment 0 beat 51)" in out, out
    wave = tmp_path / "cds-random_12b-icarus-fast.fst"
    assert f"waveform {wave} (cycles " in out and wave.exists()


# ---- pixels per clock (ppc 2, 4, 8; the golden cases above cover every ppc)


@pytest.mark.parametrize("ppc", WIDE_PPC)
def test_widest_rows(sim, ppc):
    """Rows of 8192 pixels (the widest line any tdicam block takes; cds itself has no width
    limit), full-scale and zero rows among random ones, a reset in the middle of a row."""
    rng = np.random.default_rng(ppc)
    sig = rng.integers(0, 1 << 12, (2, 4, 8192), dtype=np.uint16)
    rst = rng.integers(0, 1 << 12, (2, 4, 8192), dtype=np.uint16)
    sig[0, 1], rst[0, 1], sig[1, 2], rst[1, 2] = 4095, 0, 0, 4095
    params = blocks.get("cds").resolve({"ppc": ppc})
    stim = frames_to_beats(np.stack([sig, rst], -1), ppc=ppc, channels=2)
    exp = frames_to_beats(cds(sig, rst, pixel_bits=12), ppc=ppc)
    mark_resets(stim, exp, [(4 * 8192 + 4100) // ppc])
    check_beats("cds", params, stim, exp, sim=sim, mode="fast", idle=0.1, backpressure=0.1)
