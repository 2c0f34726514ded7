"""The whole camera of Ning et al. 2019 (``scenes/ning2019_gmax0504_full.toml``) through its
generated top against the golden chain (:mod:`tdicam.bench.camera`): both gains, each line a
reset frame (written to the channel's DDR model and read back) and a signal frame, the NAND
model's coefficient image (a line a sensor row of the cut: every pixel its own gain and
offset) loaded into DDR at power-up and row r's line read back with row r, both DDR
users of a channel behind its DdrArbiter, at the camera plan's 8 pixels a clock; the top's
input the sensor's lanes (the scene's ``[sensor.lvds]``), driven with the lines' words by
the chain's own lane model (training, then sync, header and pixel words on every lane, the
padded last slots of the lanes a column short), the word clock at 25 MHz, the processing
clock at 200 MHz. Every block's output (tap) is compared, the front's included; a mismatch
names its block, frame, line and column. The top ends in the camera's 2 TLK2711 links
(``[pipeline].output = "links"``, their own clock ``link_clk``): their words are compared
with the golden chain's output through the frame selector and ``model.tlk2711``, and
decoded here with ``model.tlk2711.decode`` back into the golden image.

Default run: a 40-column, 8-line cut of the camera on 16 lanes a gain (3 words a line, the
last word clock 8 columns and 8 padded slots a gain, as the whole camera's 40 lanes have
16; 16-block NAND parts: a short scan) on Icarus, and the same run compared with one golden
pixel changed (the check fails, naming it); its links keep up with its lanes, so its top
has no frame buffer. A 48-column cut on 24 lanes a gain with 80 MHz links sends a row
slower than its lanes bring one: its top has the DDR frame buffer before the links
(:func:`tdicam.chain.design.link_plan`) and the run checks the buffer's words in its MIG
model. With ``TDICAM_FULL=1``: all 5144 columns from the 80 lanes, 8 lines, the scene's
4096-block NAND parts, on Verilator, to the links behind the whole camera's frame buffer
(a kept row 25.8 us on the links against the lanes' 10.5 us a line pair).
"""

import math

import numpy as np
import pytest

from tdicam.bench.camera import camera_cut, camera_run, extrapolate
from tdicam.chain.cosim import OVERFLOW
from tdicam.cosim.testing import FULL
from tdicam.errors import TdicamError
from tdicam.model import tlk2711

_CUT = {"lines": 8, "columns": 40, "nand_blocks": 16, "lanes_per_gain": 16}


@pytest.fixture(scope="module")
def one_icarus_run():
    """The short cut's simulator run made once for the module: the match and the mutation
    check compare the same RTL output (``tdicam.chain.cosim.run_top`` memoised by its plan
    and its arguments), each with its own golden chain (the mutant's with a pixel
    changed)."""
    from tdicam.chain import cosim
    runs, real = {}, cosim.run_top

    def once(p, data, sim, **kw):
        key = (sim, p.source, repr([(s.block, s.params) for s in p.steps]), repr(kw))
        if key not in runs:
            runs[key] = real(p, data, sim, **kw)
        return runs[key]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(cosim, "run_top", once)
        yield runs


def _check(rep, columns, lines, lanes_per_gain):
    assert not rep["timeout"], rep["message"]
    assert rep["mismatches"] == 0 and rep["tap_mismatches"] == 0, rep["message"]
    p = rep["plan"]
    assert [s.block for s in p.steps] == ["lvds", "cds_ddr", "nuc_ddr", "hdr", "tdi",
                                          "median3"]
    assert p.ppc == 8 and p.width == columns and p.lanes == 2 and p.stages == 1
    assert p.steps[0].params["lanes"] == 2 * lanes_per_gain
    assert rep["pixels_compared"] == lines * columns
    for t in rep["taps"]:
        assert t["mismatches"] == 0 and t["received"] == t["beats"], t
        # the front's taps carry the reset frames too (a reset and a signal line a line)
        assert t["pixels"] == lines * columns * (2 if t["tap"].startswith("lvds") else 1)
    # every lane trained and locked, every frame the sensor sent released whole, nothing
    # lost in the crossing (the lane words were the padded line format)
    assert rep["lanes"]["problems"] == []
    st = rep["status_outputs"]
    n = 2 * lanes_per_gain
    assert st["lvds_lane_locked"] == (1 << n) - 1 and st["lvds_lane_error"] == 0
    assert st["lvds_frames_out"] == 2 * lines and st["lvds_frames_dropped"] == 0
    assert st[OVERFLOW] == 0
    # each channel's DDR: the coefficient image (a line a sensor row: gain and offset, 16 a
    # word) written once, row r's line read with row r; the reset line (24 pixels a word)
    # written and read every line; where the links are slower than the lanes, the frame
    # buffer's rows in turn (row y on channel y mod 2's DDR, 16 pixels a word), each
    # written once and read once, behind the same arbiter
    coeff, reset = math.ceil(2 * columns / 16), math.ceil(columns / 24)
    buffered = p.links.buffer_rows
    assert buffered in (0, lines)
    assert rep.get("frame_buffer") is None          # (no MIG model of its own)
    for k, sfx in enumerate(("", "_1")):
        image = len(range(k, lines, 2)) * math.ceil(columns / 16) if buffered else 0
        assert st[f"nuc_ddr_calib_loaded{sfx}"] == 1 and st[f"nuc_ddr_calib_error{sfx}"] == 0
        assert st[f"ddr_writes{sfx}"] == lines * (coeff + reset) + image
        assert st[f"ddr_reads{sfx}"] == lines * (coeff + reset) + image
        assert st[f"ddr_error{sfx}"] == 0
    _check_links(rep, columns, lines, lanes_per_gain)


def test_a_cut_whose_links_are_slower_than_its_lanes_runs_through_the_frame_buffer():
    """48 columns on 24 lanes a gain, the links at 80 MHz: a kept row takes 30 words (0.375
    us) against the lanes' 0.32 us a line pair, so the top buffers the image in DDR before
    the links, its rows in turn on the two channels' DDR interfaces beside cds_ddr and
    nuc_ddr; every tap and link word matches, each channel's MIG model saw its 4 rows' 3
    words written and read once besides the blocks' words, and the front lost no word."""
    rep = camera_run(sim="icarus", lines=8, columns=48, nand_blocks=16, lanes_per_gain=24,
                     link_clock_mhz=80.0)
    assert rep["plan"].links.buffer_rows == 8 and rep["plan"].links.clock_mhz == 80.0
    _check(rep, 48, 8, 24)


def _check_links(rep, columns, lines, lanes_per_gain):
    """The links' words decode (every row's number, length and CRC checked) into the golden
    chain's last image: the cut's ``lines`` rows, one image (the first of K = 5 is kept)."""
    from tdicam.chain import design
    p = rep["plan"]
    lk = p.links
    assert (lk.links, lk.pixel_bits, lk.keep, lk.image_rows) == (2, 16, 5, lines)
    words = rep["link_words"]
    assert words.shape == (2, rep["words_compared"] // 2)
    got = tlk2711.decode(words, width=columns, pixel_bits=16, links=2)
    narrow = columns != 5144
    _, data = camera_cut(lines, columns=columns if narrow else None,
                         nand_blocks=_CUT["nand_blocks"] if narrow else None,
                         lanes_per_gain=lanes_per_gain if narrow else None)
    want = design.golden(p, data)[-1][2]
    assert got.numbers == [0] and len(got.frames) == 1
    assert np.array_equal(got.frames[0], want.reshape(lines, columns))


def test_a_cut_of_the_full_camera_matches_the_golden_chain_on_icarus(one_icarus_run):
    rep = camera_run(sim="icarus", **_CUT)
    _check(rep, _CUT["columns"], _CUT["lines"], _CUT["lanes_per_gain"])


def test_every_row_is_corrected_with_its_own_coefficients():
    """The cut's coefficient image has a distinct line a sensor row (per-pixel NUC, Ning et
    al. 2019), and the golden chain with row 0's coefficients for every row differs from
    the real one at nuc_ddr's tap in every later row: the gateware, bit-exact with the real
    golden chain at that tap (the test above), reads row r's line for row r, and a golden
    chain that reused row 0 would fail it."""
    from dataclasses import replace
    from tdicam.chain import design
    p, data = camera_cut(**_CUT)
    lines = _CUT["lines"]
    step = next(s for s in p.steps if s.block == "nuc_ddr")
    assert step.params["image_rows"] == lines
    for gain, offset in data.coeffs:
        assert gain.shape == (lines, _CUT["columns"]) == offset.shape
        assert len({g.tobytes() for g in gain}) == lines     # no two rows alike
    row0 = replace(data, coeffs=[tuple(np.repeat(a[:1], lines, 0) for a in c)
                                 for c in data.coeffs])

    def nuc_tap(d):
        return next(a for _, block, a in design.golden(p, d) if block == "nuc_ddr")
    real, mutant = nuc_tap(data), nuc_tap(row0)
    assert (real[0] == mutant[0]).all()                          # row 0 is row 0
    assert all((real[r] != mutant[r]).any() for r in range(1, lines)), \
        "a row corrected with row 0's coefficients went unnoticed"


def test_a_changed_golden_pixel_is_named_by_block_frame_line_and_column(one_icarus_run):
    """The checks can fail (the match's run): hdr's golden output with one pixel changed is
    named by block, frame, line and column; median3's (the links' image) with one pixel
    changed makes its tap and two of the links' words differ (the pixel's and its row's
    CRC); a changed received word fails its row's CRC in the decoder."""
    def corrupt(gold):
        hdr = next(i for i, (_, block, _) in enumerate(gold) if block == "hdr")
        for k, at in ((hdr, (5, 0, 17)), (-1, (0, 3, 17))):     # hdr, median3
            name, block, a = gold[k]
            a = a.copy()
            a[at] ^= 1
            gold[k] = (name, block, a)
    rep = camera_run(sim="icarus", corrupt=corrupt, **_CUT)
    assert rep["tap_mismatches"] == 2 and rep["mismatches"] == 2
    first = rep["first_mismatch"]
    assert (first["block"], first["frame"], first["line"], first["column"]) == ("hdr", 5, 0, 17)
    assert "block hdr" in rep["message"] and "frame 5, line 0, column 17" in rep["message"]
    w = rep["link_words"].copy()
    w[1, 40] ^= 1                                   # a payload word of row 1 on link 1
    with pytest.raises(TdicamError, match="CRC"):
        tlk2711.decode(w, width=_CUT["columns"], pixel_bits=16, links=2)


def test_a_processing_clock_too_slow_for_the_lanes_is_refused():
    """The lanes' co-simulation refuses, in one line and before the conversion, a processing
    clock that cannot take a line's beats in the line's word clocks (here words at 200 MHz
    on 16 lanes a gain, a line of 40 columns at 8 pixels a clock in 5 word clocks: 200 MHz
    needed, 100 given)."""
    from tdicam.chain.cosim import cosimulate
    from tdicam.errors import TdicamError
    p, data = camera_cut(**_CUT)
    with pytest.raises(TdicamError, match=r"processing clock .*\(10 ns\) cannot take 32 "
                                          r"lanes' words at 5 ns: .*>= 200 MHz"):
        cosimulate(p, data, "icarus", front={"word_ns": 5.0, "proc_ns": 10.0})


def test_the_whole_frame_is_extrapolated_linearly_in_the_lines():
    a = {"lines": 8, "cycles": 1000, "run_seconds": 1.0}
    b = {"lines": 32, "cycles": 3400, "run_seconds": 2.2}
    cyc, secs = extrapolate(a, b, 3800)
    assert cyc == pytest.approx(1000 + 100 * 3792) and secs == pytest.approx(1.0 + 0.05 * 3792)


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="full width from the 80 lanes on Verilator (the build "
                    "~12 min, the run ~2 min): TDICAM_FULL=1")
def test_the_full_width_camera_matches_the_golden_chain_on_verilator():
    rep = camera_run(8, "verilator")
    _check(rep, 5144, 8, 40)
    assert rep["startup_cycles"] > 0
    assert np.isfinite(rep["cycles"] / rep["run_seconds"])
