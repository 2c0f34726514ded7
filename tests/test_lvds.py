"""LVDS receiver: link model, golden training policies, Amaranth simulation, Verilog."""

import os
import re
import subprocess
import sys

import numpy as np
import pytest

from tdicam import blocks
from tdicam.cli import main
from tdicam.cosim.lvds import expected_outputs, run_amaranth
from tdicam.errors import TdicamError
from tdicam.hdl.lvds import Deskew, LaneTrainer, LvdsRx, LvdsXilinx
from tdicam.hw.lint import lint
from tdicam.model import lvds
from tdicam.hw.verilog import convert


def _quiet(elaboratable):
    """Mark a component built only to read its properties (no UnusedElaboratable warning)."""
    elaboratable._MustUse__silence = True
    core = getattr(elaboratable, "core", None)
    if core is not None:
        core._MustUse__silence = True
    return elaboratable


# ---------------------------------------------------------------- link model
def _mix32_ref(x):
    x &= 0xFFFFFFFF
    x ^= x >> 16
    x = (x * 0x7FEB352D) & 0xFFFFFFFF
    x ^= x >> 15
    x = (x * 0x846CA68B) & 0xFFFFFFFF
    return x ^ (x >> 16)


def test_mix32_matches_reference():
    xs = [0, 1, 2, 0xFFFFFFFF, 0x12345678, -1, -5]
    assert lvds.mix32(np.array(xs)).tolist() == [_mix32_ref(x) for x in xs]


def test_training_words_are_rotation_unique():
    for w in (10, 12):
        word = lvds.default_train_word(w)
        assert len(set(lvds.rotations(word, w))) == w
    with pytest.raises(TdicamError, match="repeats under rotation"):
        lvds.check_train_word(0x155, 10)
    with pytest.raises(TdicamError, match="train_word = 4096 is out of range"):
        lvds.check_train_word(4096, 12)


@pytest.mark.parametrize("kw,match", [
    ({"skew_ps": 0, "eye_ps": 4000}, "eye_ps = 4000 is out of range"),
    ({"skew_ps": -1, "eye_ps": 100}, "skew_ps and jitter_ps must be >= 0"),
    ({"skew_ps": 0, "eye_ps": 100, "change_at": 5}, "change_at and after go together"),
])
def test_lane_errors(kw, match):
    with pytest.raises(TdicamError, match=match):
        lvds.Lane(**kw)


def test_link_errors():
    lane = lvds.Lane(skew_ps=0, eye_ps=2000)
    with pytest.raises(TdicamError, match="sync_word must not be a rotation"):
        lvds.Link([lane], sync_word=lvds.rotations(0x2E4, 10)[3])
    with pytest.raises(TdicamError, match="strictly increasing"):
        lvds.Link([lane], schedule=((10, "data"), (5, "train")))
    with pytest.raises(TdicamError, match="word_bits = 11"):
        lvds.Link([lane], word_bits=11)


def test_tables_follow_the_eye():
    """Taps inside the eye by more than the jitter are never random, outside always."""
    ui = 1e6 / 300
    lane = lvds.Lane(skew_ps=1000.0, eye_ps=2000.0, jitter_ps=300.0)
    delay, thresh = lvds.lane_tables(lane)
    t = np.arange(32)
    u = np.mod(-(1000.0 + t * lvds.PAPER_TAP_PS), ui)
    lo, hi = (ui - 2000) / 2, (ui + 2000) / 2
    solid = (u >= lo + 300) & (u <= hi - 300)
    outside = (u < lo) | (u >= hi)
    assert (thresh[0][solid] == 0).all() and (thresh[0][outside] == 65536).all()
    band = ~solid & ~outside
    assert band.any() and ((thresh[0][band] > 0) & (thresh[0][band] < 65536)).all()
    assert np.array_equal(delay[0], np.ceil((1000.0 + t * lvds.PAPER_TAP_PS) / ui))


def test_gearbox_definition():
    """lane_words(k, slip) is raw(k-1)|raw(k) shifted by slip, first bit in the MSB."""
    rng = np.random.default_rng(2)
    link = lvds.Link([lvds.random_lane(rng)], schedule=((5, "data"),))
    k = np.arange(1, 60)
    raw = lvds.raw_words(link, 0, 7, np.arange(0, 60))
    for s in range(10):
        both = (raw[:-1] << 10) | raw[1:]
        exp = (both >> (10 - s)) & 0x3FF
        assert np.array_equal(lvds.lane_words(link, 0, 7, s, k), exp)


def test_sent_words_format():
    link = lvds.Link([lvds.Lane(skew_ps=0, eye_ps=3000, seed=3)], line_words=5,
                     schedule=((10, "data"), (40, "train")))
    n = np.arange(-5, 60)
    words = lvds.sent_words(link, 0, n)
    data = (n >= 10) & (n < 40)
    assert (words[~data] == link.train_word).all()
    sync = data & ((n - 10) % 5 == 0)
    assert (words[sync] == link.sync_word).all()
    assert (words[data & ~sync] != link.sync_word).all()


# ---------------------------------------------------------------- golden training policy
def _decide(pattern, words=None, **kw):
    passes = [c != "." for c in pattern]
    words = words or [0 if c in "#." else ord(c) for c in pattern]
    return lvds.decide(passes, words, **kw)


@pytest.mark.parametrize("pattern,expect", [
    ("#########" + "." * 23, (0, 9, 4)),               # clipped at tap 0: taken as measured
    ("." * 23 + "#########", (23, 9, 27)),             # clipped at tap 31
    ("." * 20 + "########" + "....", (20, 8, None)),   # 8 taps: no lock
    (".##########......############......", (17, 12, 21)),  # widest wins
    (".##########.....##########.....", (1, 10, 5)),   # tie: the first
    ("." * 32, (0, 0, None)),
    ("#" * 32, (0, 32, 4)),
])
def test_decide_policies(pattern, expect):
    assert _decide(pattern[:32]) == expect


def test_run_needs_the_same_word():
    """Consecutive passing taps capturing different rotations are two runs."""
    pattern = "aaaaaaaaabbbbbbbbb" + "." * 14
    assert _decide(pattern) == (0, 9, 4)
    assert _decide(pattern, min_run=10) == (0, 9, None)


def test_pick_and_min_run_are_parameters():
    assert _decide("." * 3 + "#" * 6 + "." * 23, min_run=5, pick=3) == (3, 6, 5)


def test_flickering_tap_fails():
    """A tap passes only if all its checked words match: one bad word fails it."""
    lane = lvds.Lane(skew_ps=900.0, eye_ps=2000.0, jitter_ps=600.0, seed=4)
    link = lvds.Link([lane])
    res = lvds.train_lane(link, 0, 0, n_check=64, settle=8)
    p = lvds.step_words(64, 8)
    ks = np.arange(32)[:, None] * p + 8 + np.arange(64)
    words = lvds.lane_words(link, 0, np.arange(32)[:, None], 0, ks)
    flicker = [(w != w[0]).any() for w in words]
    assert any(flicker)
    assert not any(res.passes[t] for t in range(32) if flicker[t])


def test_fifth_tap_of_a_run_is_clear_of_jitter():
    """With jitter up to 4 taps, the 5th tap of any run of >= 9 taps is never random: a
    locked lane then receives error-free words (the guarantee the co-simulation checks)."""
    rng = np.random.default_rng(8)
    checked = 0
    for _ in range(300):
        lane = lvds.random_lane(rng, jitter=True)
        link = lvds.Link([lane])
        res = lvds.train_lane(link, 0, 0, n_check=4, settle=8)
        if res.locked:
            assert lvds.lane_tables(lane)[1][0, res.tap] == 0
            checked += 1
    assert checked > 50


def test_run_errors_are_one_line():
    link = lvds.Link([lvds.Lane(skew_ps=0, eye_ps=2000)])
    with pytest.raises(TdicamError, match="settle = 3 is out of range"):
        lvds.run(link, cycles=5000, settle=3)
    with pytest.raises(TdicamError, match="cannot end before cycle 100"):
        lvds.run(link, cycles=100)


# ---------------------------------------------------------------- Amaranth simulation
def _amaranth_run(link, cycles, retrains=(), n_check=4, settle=4):
    events, outs, _ = run_amaranth(link, cycles, retrains=retrains, n_check=n_check,
                                   settle=settle)
    return events, outs


def test_amaranth_sim_matches_golden_with_retrain():
    """Three lanes (one jumps skew, one dies after lock) through a retrain; events exact,
    deskewed output starts exactly `latency` cycles after the last lane's sync word."""
    lanes = [
        lvds.Lane(skew_ps=800, eye_ps=2500, seed=5, change_at=700,
                  after=lvds.Lane(skew_ps=2300, eye_ps=2500)),
        lvds.Lane(skew_ps=300, eye_ps=2600, jitter_ps=300, seed=6, change_at=650,
                  after=lvds.Lane(skew_ps=300, eye_ps=0)),
        lvds.Lane(skew_ps=3300 * 2 + 400, eye_ps=2200, seed=7),
    ]
    nc, st = 4, 4
    tw = lvds.training_words(10, nc, st)
    kr = tw + 330
    link = lvds.Link(lanes, line_words=16,
                     schedule=((tw + 20, "data"), (kr, "train"), (kr + tw + 30, "data")))
    cycles = kr + tw + 30 + 120
    gold = lvds.run(link, cycles=cycles, retrains=(kr,), n_check=nc, settle=st)
    events, outs = _amaranth_run(link, cycles, (kr,), nc, st)
    assert events == gold.events
    assert any(e[1] == 0 and e[3] == 1 and e[0] < kr for e in events)  # skew jump reported
    segs = expected_outputs(link, gold, lanes=3, cycles=cycles, retrains=(kr,))[0]
    assert len(segs) == 2
    for k_first, n_words, cols, dying in segs:
        got = [o for o in outs if k_first <= o[0] < k_first + n_words]
        assert [o[0] for o in got] == list(range(k_first, k_first + n_words))
        assert got[0][1] == 1
        for i, col in enumerate(cols):
            if col is not None and i not in dying:
                assert [(o[2] >> (10 * i)) & 0x3FF for o in got] == col.tolist()
    assert not [o for o in outs if not any(s[0] <= o[0] < s[0] + s[1] for s in segs)]
    assert _quiet(LvdsRx(lanes=3)).latency == 4


def test_component_params():
    t = LaneTrainer(word_bits=12, settle=6)
    assert (t.word_bits, t.settle, t.latency, t.step_words(16)) == (12, 6, 2, 25)
    assert t.step_words(0) == lvds.step_words(0, 6)
    assert _quiet(Deskew(lanes=4)).latency == 2
    _quiet(t)
    with pytest.raises(TdicamError, match="pick = 10 must not exceed min_run = 9"):
        LvdsRx(pick=10)
    with pytest.raises(TdicamError, match="settle = 3 is out of range"):
        LaneTrainer(settle=3)
    with pytest.raises(TdicamError, match="word_bits = 8 is not valid"):
        LvdsRx(word_bits=8)


# ---------------------------------------------------------------- Verilog
def _run(*args):
    return subprocess.run([sys.executable, "-m", "tdicam", *args], capture_output=True,
                          text=True)


@pytest.fixture(scope="module")
def verilog80(tmp_path_factory):
    path = tmp_path_factory.mktemp("lvds80") / "lvds80.v"
    assert main(["verilog", "lvds", "--lanes", "80", "--word-bits", "12", "-o",
                 str(path)]) == 0
    return path


def test_80_lane_configuration_generates_verilog(verilog80):
    """80 lanes (40 HG + 40 LG), 12-bit words: elaborates and generates Verilog."""
    text = verilog80.read_text()
    assert re.search(r"^module lvds\(", text, re.M)
    assert re.search(r"output \[959:0\] o_data;", text)
    assert re.search(r"output \[399:0\] lane_tap;", text)
    assert re.search(r"input \[959:0\] lane_raw;", text)
    assert len(re.findall(r"^module ", text, re.M)) >= 80


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("TDICAM_FULL") != "1",
                    reason="80-lane lint takes minutes: set TDICAM_FULL=1")
def test_80_lane_configuration_lints_clean(verilog80):
    assert lint(verilog80) == []


def test_cli_errors_are_one_line():
    for args, expect in [
        (["verilog", "lvds", "--word-bits", "11"], "--word-bits = 11 is not valid; valid: 10, 12"),
        (["verilog", "lvds", "--pick", "10"], "--pick = 10 must not exceed --min-run = 9"),
        (["verilog", "lvds", "--phy", "altera"], "--phy = altera is not valid"),
        (["verilog", "lvds", "--lanes", "0"], "--lanes = 0 is out of range; valid: 1..128"),
    ]:
        proc = _run(*args)
        assert proc.returncode == 2
        assert len(proc.stderr.strip().splitlines()) == 1 and expect in proc.stderr


# Lint-only blackbox stubs of the 7-series primitives (Verilator does not know them). They
# are concatenated with the generated wrapper for this test only; Vivado uses the real ones.
_STUBS = """
/* verilator lint_off UNUSEDPARAM */
module IBUFDS #(parameter DIFF_TERM = "FALSE", parameter IBUF_LOW_PWR = "TRUE",
                parameter IOSTANDARD = "DEFAULT") (input I, input IB, output O);
  assign O = I & ~IB;
endmodule
module IDELAYCTRL (input REFCLK, input RST, output RDY);
  assign RDY = REFCLK & ~RST;
endmodule
module IDELAYE2 #(parameter IDELAY_TYPE = "FIXED", parameter DELAY_SRC = "IDATAIN",
    parameter integer IDELAY_VALUE = 0, parameter HIGH_PERFORMANCE_MODE = "FALSE",
    parameter SIGNAL_PATTERN = "DATA", parameter real REFCLK_FREQUENCY = 200.0,
    parameter CINVCTRL_SEL = "FALSE", parameter PIPE_SEL = "FALSE")
  (input C, input REGRST, input LD, input CE, input INC, input CINVCTRL,
   input [4:0] CNTVALUEIN, input IDATAIN, input DATAIN, input LDPIPEEN,
   output DATAOUT, output [4:0] CNTVALUEOUT);
  reg [4:0] cnt = 5'd0;
  always @(posedge C) if (LD) cnt <= CNTVALUEIN;
  assign DATAOUT = IDATAIN ^ DATAIN ^ CE ^ INC ^ CINVCTRL ^ LDPIPEEN ^ REGRST;
  assign CNTVALUEOUT = cnt;
endmodule
module ISERDESE2 #(parameter DATA_RATE = "DDR", parameter integer DATA_WIDTH = 4,
    parameter INTERFACE_TYPE = "MEMORY", parameter IOBDELAY = "NONE",
    parameter integer NUM_CE = 2, parameter OFB_USED = "FALSE",
    parameter SERDES_MODE = "MASTER", parameter DYN_CLKDIV_INV_EN = "FALSE",
    parameter DYN_CLK_INV_EN = "FALSE", parameter [0:0] INIT_Q1 = 1'b0,
    parameter [0:0] INIT_Q2 = 1'b0, parameter [0:0] INIT_Q3 = 1'b0,
    parameter [0:0] INIT_Q4 = 1'b0, parameter [0:0] SRVAL_Q1 = 1'b0,
    parameter [0:0] SRVAL_Q2 = 1'b0, parameter [0:0] SRVAL_Q3 = 1'b0,
    parameter [0:0] SRVAL_Q4 = 1'b0)
  (input D, input DDLY, input CLK, input CLKB, input CLKDIV, input CLKDIVP, input OCLK,
   input OCLKB, input RST, input CE1, input CE2, input BITSLIP, input DYNCLKDIVSEL,
   input DYNCLKSEL, input OFB, input SHIFTIN1, input SHIFTIN2,
   output Q1, output Q2, output Q3, output Q4, output Q5, output Q6, output Q7, output Q8,
   output SHIFTOUT1, output SHIFTOUT2, output O);
  reg [7:0] sr = 8'd0;
  always @(posedge CLK) sr <= {sr[6:0], D ^ DDLY ^ SHIFTIN1 ^ SHIFTIN2};
  reg [7:0] q = 8'd0;
  always @(posedge CLKDIV) q <= RST ? 8'd0 : sr ^ {7'd0, CLKB ^ CLKDIVP ^ OCLK ^ OCLKB ^ CE1
                                 ^ CE2 ^ BITSLIP ^ DYNCLKDIVSEL ^ DYNCLKSEL ^ OFB};
  assign {Q8, Q7, Q6, Q5, Q4, Q3, Q2, Q1} = q;
  assign SHIFTOUT1 = sr[7];
  assign SHIFTOUT2 = sr[6];
  assign O = D;
endmodule
/* verilator lint_on UNUSEDPARAM */
"""


@pytest.mark.parametrize("word_bits", [10, 12])
def test_xilinx_wrapper_generates(word_bits, tmp_path):
    """``--phy xilinx7``: IDELAYE2 (VAR_LOAD) + ISERDESE2 (DDR) per lane, generated (not
    simulated); lints clean against blackbox stubs of the primitives."""
    path = tmp_path / "lvds_x7.v"
    assert main(["verilog", "lvds", "--phy", "xilinx7", "--lanes", "8", "--word-bits",
                 str(word_bits), "-o", str(path)]) == 0
    text = path.read_text()
    assert len(re.findall(r"^\s*IDELAYE2 #", text, re.M)) == 8
    assert len(re.findall(r"^\s*ISERDESE2 #", text, re.M)) == (16 if word_bits == 10 else 8)
    assert len(re.findall(r"^\s*IDELAYCTRL ", text, re.M)) == 1
    for param in ('.IDELAY_TYPE("VAR_LOAD")', '.DATA_RATE("DDR")',
                  '.INTERFACE_TYPE("NETWORKING")', '.IOBDELAY("IFD")'):
        assert param in text, param
    assert f".DATA_WIDTH(32'd{word_bits if word_bits == 10 else 6})" in text
    if word_bits == 10:
        assert '.SERDES_MODE("SLAVE")' in text
    both = tmp_path / "with_stubs.v"
    both.write_text(text + _STUBS)
    assert lint(both) == []


@pytest.mark.parametrize("word_bits", [10, 12])
def test_ecp5_wrapper_generates(word_bits, tmp_path):
    """``--phy ecp5``: per lane DELAYF (USER_DEFINED, moved by MOVE/DIRECTION) + IDDRX2F,
    one ECLKSYNCB and one CLKDIVF (DIV 2.0); the trainer held while a delay moves."""
    from tdicam.hdl.lvds_phy import LvdsEcp5
    path = tmp_path / "lvds_ecp5.v"
    assert main(["verilog", "lvds", "--phy", "ecp5", "--lanes", "8", "--word-bits",
                 str(word_bits), "-o", str(path)]) == 0
    text = path.read_text()
    assert len(re.findall(r"^\s*DELAYF #", text, re.M)) == 8
    assert len(re.findall(r"^\s*IDDRX2F ", text, re.M)) == 8
    assert len(re.findall(r"^\s*ECLKSYNCB ", text, re.M)) == 1
    assert len(re.findall(r"^\s*CLKDIVF #", text, re.M)) == 1
    assert '.DEL_MODE("USER_DEFINED")' in text and '.DIV("2.0")' in text
    top = _quiet(LvdsEcp5(lanes=2, word_bits=word_bits))
    assert set(top.signature.members) >= {"lane_p", "clk_eclk", "lane_locked", "o_data"}
    assert "lane_raw" not in top.signature.members and top.tap_ps == 100.0
    assert "lane_hold" in top.core.signature.members
    with pytest.raises(TdicamError, match="steps = 5 is out of range"):
        LvdsEcp5(lanes=2, steps=5)


def test_block_registry_params():
    blk = blocks.get("lvds")
    p = blk.resolve({})
    assert blk.recorded(p) == {"lanes": 8, "word_bits": 10, "settle": 8, "min_run": 9,
                               "pick": 5, "deskew_depth": 8, "phy": "none"}
    # the front-end parameters (issue 30) hold their defaults: golden cases do not record them
    assert {k: p[k] for k in set(p) - set(blk.recorded(p))} == {
        "lanes_per_gain": 0, "columns": 0, "bits": 12, "ppc": 1, "fifo_depth": 16, "pairs": 0,
        "eye": 0, "track": 0}
    from tdicam.hdl.lvds_phy import LvdsEcp5
    for phy, cls in (("none", LvdsRx), ("xilinx7", LvdsXilinx), ("ecp5", LvdsEcp5)):
        top = blk.build({"lanes": 2, "phy": phy})
        assert isinstance(_quiet(top), cls)
    from tdicam.hdl.lvds_front import LvdsFront
    front = blk.build({"lanes": 8, "lanes_per_gain": 4, "columns": 16, "word_bits": 12})
    assert isinstance(_quiet(front), LvdsFront)
    front._rx._MustUse__silence = True
    for bad, match in (({"lanes_per_gain": 3}, "--lanes = 8 must be --lanes-per-gain = 3"),
                       ({"lanes_per_gain": 4, "columns": 3}, "--columns = 3 must be at least "
                                                              "--lanes-per-gain = 4"),
                       ({"lanes_per_gain": 4, "columns": 17, "ppc": 2},
                        "--ppc = 2 does not divide the 1 columns of a line's last word clock"),
                       ({"lanes_per_gain": 4, "columns": 16, "ppc": 8},
                        "--ppc = 8 does not divide --lanes-per-gain = 4")):
        with pytest.raises(TdicamError, match=match):
            blk.resolve({"lanes": 8, **bad})


def test_generated_verilog_is_deterministic():
    a = convert(LvdsRx(lanes=2), "lvds")
    b = convert(LvdsRx(lanes=2), "lvds")
    assert a == b


# ---------------------------------------------------------------- eye status (issue 46 step 4)
def _eye_link(word_bits=10):
    nc, st = 4, 4
    tw = lvds.training_words(word_bits, nc, st)
    walk_at, data_at = tw + 10, tw + 10 + 4 * word_bits
    lanes = [
        lvds.Lane(skew_ps=800, eye_ps=2500, seed=5),                       # wide open
        lvds.Lane(skew_ps=300, eye_ps=700, seed=6),                        # no eye: 4 taps
        lvds.Lane(skew_ps=3300 * 2 + 400, eye_ps=2000, jitter_ps=250, seed=7),
        lvds.Lane(skew_ps=1200, eye_ps=2400, seed=8, change_at=walk_at + 2 * word_bits,
                  after=lvds.Lane(skew_ps=1200, eye_ps=0)),              # dies in the walk
    ]
    link = lvds.Link(lanes, word_bits=word_bits, line_words=16,
                     schedule=((walk_at, "walk"), (data_at, "data")))
    return link, data_at + 100, nc, st


@pytest.mark.parametrize("word_bits", [10, 12])
def test_eye_status_matches_golden(word_bits):
    """LvdsRx(eye=True) in Amaranth's simulator: per lane the pass mask over the 32 taps,
    the widest run (the eye width found), the chosen tap, the slip mask and the walking-1/0
    patterns received after lock equal the golden model's (lvds.run(eye=True)): the open
    lanes see all 2W patterns, the lane with no eye reports error with its mask, the lane
    dying inside the walk stops short and errs."""
    link, cycles, nc, st = _eye_link(word_bits)
    gold = lvds.run(link, cycles=cycles, n_check=nc, settle=st, eye=True)
    final = []
    events, _, _ = run_amaranth(link, cycles, n_check=nc, settle=st, eye=True, final=final)
    assert events == gold.events
    assert final == gold.final
    full = (1 << 2 * word_bits) - 1
    assert [f["walk"] == full for f in final] == [True, False, True, False]
    assert [f["error"] for f in final] == [0, 1, 0, 1]
    assert final[1]["run"] < 9 and final[1]["slip_pass"] == 0 and final[1]["scan"] != 0
    assert 0 < final[3]["walk"] < full           # patterns before the death were counted
    assert final[0]["slip_pass"] == 1 << final[0]["slip"]


def test_walking_patterns_fail_a_receiver_without_the_eye_status():
    """The receiver of before (eye off) takes a walking pattern before the first sync word
    for a broken lane (the golden model says the same): the patterns need ``eye``."""
    link, cycles, nc, st = _eye_link(10)
    gold = lvds.run(link, cycles=cycles, n_check=nc, settle=st)
    events, _, _ = run_amaranth(link, cycles, n_check=nc, settle=st)
    assert events == gold.events
    assert gold.final[0]["error"] == 1 and gold.final[2]["error"] == 1


def test_walk_words_order():
    assert lvds.walk_words(10)[:2] == [0x200, 0x100] and lvds.walk_words(10)[10] == 0x1FF
    link = lvds.Link([lvds.Lane(skew_ps=0, eye_ps=3000)], schedule=((5, "walk"), (45, "data")))
    assert lvds.sent_words(link, 0, np.arange(5, 26)).tolist() == \
        lvds.walk_words(10) + [0x200]
