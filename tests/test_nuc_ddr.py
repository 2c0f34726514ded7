"""``nuc_ddr``: the coefficient image's DDR packing, its exact round trip, the golden model
against :func:`tdicam.model.nuc.nuc`, the core's latency at every ppc and its one-line
refusals. Gateware == golden: cocotb_tests/test_nuc_ddr.py (both simulators) and the
hypothesis property in tests/test_properties.py (every ppc, random idle, backpressure and
MIG stalls)."""

import numpy as np
import pytest

from tdicam.beats import PPC_CHOICES
from tdicam.errors import TdicamError
from tdicam.model.ddr import WORD_BITS, words_to_ints
from tdicam.model.nuc import NucFormat, identity_coeffs, nuc
from tdicam.model.nuc_ddr import (COEFF_BITS, COEFFS_PER_WORD, coeff_layout, coeff_readback,
                                  coeff_words, nuc_ddr_frames)


def test_packing_is_16_bit_slots_first_value_most_significant():
    """8 pixels' (gain, offset) a 256-bit word, g0 at [255:240], o0 at [239:224], ...; each
    64-bit quarter 4 coefficients (2 pixels); the offset as its two's complement."""
    fmt = NucFormat()
    lay = coeff_layout(10)
    g = np.arange(1, 11)[None] * 0x101
    o = -np.arange(1, 11)[None]
    (w0, w1), = [words_to_ints(line) for line in coeff_words(g, o, fmt, lay)]
    assert COEFFS_PER_WORD == 16 and COEFF_BITS == 16 and lay.words_per_line == 2
    slots = [(w0 >> (WORD_BITS - 16 * (j + 1))) & 0xFFFF for j in range(16)]
    assert slots[0::2] == (g[0, :8]).tolist()
    assert slots[1::2] == [(1 << 16) - k for k in range(1, 9)]
    quarter = (w0 >> 192) & ((1 << 64) - 1)         # the most significant 64 bits
    assert quarter == (0x101 << 48) | (0xFFFF << 32) | (0x202 << 16) | 0xFFFE
    assert w1 >> 128 == (((0x909 << 16 | 0xFFF7) << 16 | 0xA0A) << 16 | 0xFFF6) << 64
    assert w1 & ((1 << 128) - 1) == 0                # a line's last word zero-padded


@pytest.mark.parametrize("fmt", [NucFormat(), NucFormat(1, 7, 10, 3), NucFormat(2, 14, 16, 8),
                                 NucFormat(4, 12, 2, 0)])
def test_round_trip_is_exact(fmt):
    """What the DDR adds to the coefficients: nothing (every code, the extremes included)."""
    rng = np.random.default_rng(1)
    shape = (5, 37)
    g = rng.integers(0, fmt.gain_max + 1, shape)
    o = rng.integers(fmt.offset_min, fmt.offset_max + 1, shape)
    g[0, :2], o[0, :2] = (0, fmt.gain_max), (fmt.offset_min, fmt.offset_max)
    lay = coeff_layout(37, line_stride=128, base=64)
    g2, o2 = coeff_readback(coeff_words(g, o, fmt, lay), fmt, lay)
    assert (g2 == g).all() and (o2 == o).all()


def test_golden_is_nuc_with_the_last_stored_coefficients():
    rng = np.random.default_rng(2)
    fmt = NucFormat()
    n, shape = 5, (3, 16)
    x = rng.integers(0, 4096, (n, *shape))
    g = rng.integers(0, fmt.gain_max + 1, (n, *shape))
    o = rng.integers(fmt.offset_min, fmt.offset_max + 1, (n, *shape))
    kinds = [0, 1, 0, 1, 0]
    got = nuc_ddr_frames(x, g, o, kinds)
    want = [nuc(x[0], *identity_coeffs(shape)), nuc(x[2], g[1], o[1]), nuc(x[4], g[3], o[3])]
    assert got.shape == (3, *shape) and (got == np.stack(want)).all()
    assert nuc_ddr_frames(x[:1], g[:1], o[:1], [1]).shape == (0, *shape)


@pytest.mark.parametrize("ppc", PPC_CHOICES)
def test_latency_is_the_nuc_cores(ppc):
    from tdicam.cosim.streamsim import probe_latency
    from tdicam.hdl.nuc import Nuc
    from tdicam.hdl.nuc_ddr import NucDdr
    dut = NucDdr(width=8, rows=2, ppc=ppc)
    core = Nuc(ppc=ppc)
    core._MustUse__silence = True
    assert dut.ppc == ppc and dut.latency == core.latency == (3 if ppc == 1 else 4)
    seen = probe_latency(dut, [1234] * (2 * ppc), cycles=6)
    # before any coefficient frame: the defaults (gain 1.0, offset 0), so y = x
    assert seen.index((1, 1234)) == dut.latency - 1
    assert [v for v, _ in seen].count(1) == 1


@pytest.mark.parametrize("kw, words", [
    ({"gain_int_bits": 3, "gain_frac_bits": 14}, "gain 17 and offset 16 bits"),
    ({"offset_bits": 18}, "gain 16 and offset 18 bits"),
    ({"width": 12, "ppc": 8}, "not a multiple"),
    ({"width": 5144, "rows": 3800, "capacity_bytes": 64 << 20}, "address space too small"),
    ({"ppc": 3}, "ppc"),
    ({"image_rows": 3}, "image_rows = 3 is not a multiple of the frame's rows = 2"),
    ({"width": 5144, "rows": 1, "image_rows": 3800, "capacity_bytes": 64 << 20},
     "address space too small"),
])
def test_bad_parameters_are_one_line(kw, words):
    from tdicam.hdl.nuc_ddr import NucDdr
    with pytest.raises(TdicamError) as e:
        NucDdr(**{"width": 16, "rows": 2, **kw})
    assert words in str(e.value) and "\n" not in str(e.value)


def test_gmax0504_image_fits_and_its_size():
    """The full GMAX0504 coefficient image: 643 words a row (5144 pixels x 2 / 16), rows at a
    stride of 8192 address units, 3800 rows in 124.5 MB of the 1 GiB part."""
    lay = coeff_layout(5144)
    assert lay.words_per_line == 643 and lay.line_stride == 8192
    assert lay.end_addr(3800) * 4 == 3799 * 8192 * 4 + 643 * 32


def test_an_image_of_more_lines_gives_each_frame_its_own():
    """image_rows = 3 x rows: pixel frame j after the coefficient frame is corrected with
    image lines (j mod 3) * rows .., and a new coefficient frame starts again at line 0."""
    rng = np.random.default_rng(3)
    fmt = NucFormat()
    rows, w = 2, 8
    g = rng.integers(0, fmt.gain_max + 1, (9, 3 * rows, w))
    o = rng.integers(fmt.offset_min, fmt.offset_max + 1, (9, 3 * rows, w))
    x = rng.integers(0, 4096, (9, rows, w))
    kinds = [1, 0, 0, 0, 0, 1, 0, 0, 0]
    got = nuc_ddr_frames(x, g, o, kinds, image_rows=3 * rows)
    seg = [(0, 0), (0, 1), (0, 2), (0, 0), (5, 0), (5, 1), (5, 2)]      # (image, segment)
    pix = [i for i, k in enumerate(kinds) if not k]
    want = [nuc(x[i], g[c][2 * s:2 * s + 2], o[c][2 * s:2 * s + 2]) for i, (c, s) in zip(pix, seg)]
    assert (got == np.stack(want)).all()
    with pytest.raises(TdicamError, match="give image_rows = 6"):
        nuc_ddr_frames(x, g, o, kinds)


@pytest.mark.filterwarnings("ignore:.*created but never used")   # inspected only
@pytest.mark.parametrize("ppc", [1, 8])
def test_ecp5_multipliers_are_dsp_blocks_with_their_input_registers(ppc):
    """``dsp="ecp5"`` (the ECP5 synthesis tops): one MULT18X18D a lane with its input
    registers on CLK0 and no output register, the same latency and ports as the generic
    description; the block's ECP5 top (what ``tdicam synth nuc_ddr`` places) has them, its
    plain top none; an unknown ``dsp`` is one line naming it and the valid values."""
    from amaranth.back import rtlil
    from tdicam import blocks
    from tdicam.hdl.nuc_ddr import NucDdr
    dut = NucDdr(width=16, rows=2, ppc=ppc, dsp="ecp5")
    plain = NucDdr(width=16, rows=2, ppc=ppc)
    assert dut.dsp == "ecp5" and plain.dsp == "generic"
    assert dut.latency == plain.latency and dut.signature == plain.signature
    text = rtlil.convert(dut)
    assert text.count("cell \\MULT18X18D") == ppc
    assert text.count('parameter \\REG_INPUTA_CLK "CLK0"') == ppc
    assert text.count('parameter \\REG_OUTPUT_CLK "NONE"') == ppc
    blk = blocks.get("nuc_ddr")
    params = {"width": 16, "rows": 2, "ppc": ppc}
    assert rtlil.convert(blk.build(params, ecp5=True)).count("cell \\MULT18X18D") == ppc
    assert "MULT18X18D" not in rtlil.convert(blk.build(params))
    with pytest.raises(TdicamError, match=r"dsp.*'xilinx'.*generic, ecp5") as e:
        NucDdr(width=16, rows=2, dsp="xilinx")
    assert "\n" not in str(e.value)
