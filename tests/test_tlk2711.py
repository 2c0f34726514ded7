"""Golden model, decoder, plan figures and Amaranth simulation of the output links
(``tlk2711``)."""

import numpy as np
import pytest
from amaranth.hdl import Fragment
from hypothesis import given, settings
from hypothesis import strategies as st

from tdicam import blocks
from tdicam.beats import Beats
from tdicam.cli import main
from tdicam.cosim import run_golden_case
from tdicam.cosim.tlk2711 import SCENARIOS, PinsCase, check, run_amaranth, scenario
from tdicam.cosim.streamsim import run_stream_component
from tdicam.errors import TdicamError
from tdicam.hdl.tlk2711 import Tlk2711, Tlk2711Framer, Widener, crc16_matrix, entry_pixels
from tdicam.blocks.tlk2711 import BUILDS, case_beats, stream_case
from tdicam.model import tlk2711
from tdicam.beats import PPC_CHOICES

BLOCK = blocks.get("tlk2711")
IDLE = 0x1C5BC                           # K28.5 (K) low byte, D5.6 high byte


def _crc_bitwise(words):
    """CRC-16/CCITT-FALSE, bit by bit from its definition (not binascii)."""
    crc = 0xFFFF
    for w in words:
        for bit in range(15, -1, -1):
            fb = ((crc >> 15) ^ (int(w) >> bit)) & 1
            crc = ((crc << 1) & 0xFFFF) ^ (0x1021 if fb else 0)
    return crc


# ------------------------------------------------------------------------ golden model


def test_character_values():
    assert tlk2711.IDLE == IDLE
    assert (tlk2711.K28_5, tlk2711.D5_6, tlk2711.K27_7, tlk2711.K28_0, tlk2711.K29_7) == \
        (0xBC, 0xC5, 0xFB, 0x1C, 0xFD)
    assert tlk2711.marker(tlk2711.K27_7, 1) == 0x101FB


def test_framing_of_one_row_by_hand():
    w = tlk2711.tlk2711(np.array([[[0x1234, 0xABCD]]]), pixel_bits=16, links=1)
    crc = _crc_bitwise([0, 0x1234, 0xABCD])
    assert w.dtype == np.uint32 and w.shape == (1, 12)
    assert w[0].tolist() == [IDLE, IDLE, 0x100FB, 0, IDLE, IDLE, 0x1001C, 0, 0x1234, 0xABCD,
                             0x100FD, crc]


def test_two_links_interleave_columns_and_name_their_link():
    """Two frames of one row of 8-bit pixels: link 0 the even columns, link 1 the odd
    ones, two pixels a word (the left one low), each link's index in its markers; the
    second frame is number 1 and restarts its rows at 0."""
    f = np.array([[[1, 2, 3, 4]], [[5, 6, 7, 8]]])
    w = tlk2711.tlk2711(f, pixel_bits=8, links=2)
    n = tlk2711.frame_words(1, 4, pixel_bits=8, links=2)
    assert n == 11 and w.shape == (2, 22)
    for link, (a, b) in enumerate([((0x0301,), (0x0705,)), ((0x0402,), (0x0806,))]):
        for frame, px in enumerate((a, b)):
            body = w[link, frame * n:(frame + 1) * n].tolist()
            assert body == [IDLE, IDLE, 0x100FB | link << 8, frame, IDLE, IDLE,
                            0x1001C | link << 8, 0, *px, 0x100FD | link << 8,
                            _crc_bitwise([0, *px])]


def test_pack_by_hand():
    assert tlk2711.pack([0xABC, 0x123, 0x456, 0x789], 12).tolist() == [0x3ABC, 0x5612, 0x7894]
    assert tlk2711.pack([0x11, 0x22, 0x33], 8).tolist() == [0x2211, 0x0033]
    assert tlk2711.pack([1] * 16, 1).tolist() == [0xFFFF]
    assert tlk2711.pack([1] * 17, 1).tolist() == [0xFFFF, 0x0001]
    assert tlk2711.pack(np.arange(8) + 1000, 10).shape == (5,)
    assert tlk2711.pack([0xFFFF, 0], 16).tolist() == [0xFFFF, 0]


@pytest.mark.parametrize("bits", range(1, 17))
def test_pack_round_trip_and_word_count(bits):
    rng = np.random.default_rng(bits)
    px = rng.integers(0, 1 << bits, (5, 23))
    px[0] = (1 << bits) - 1
    w = tlk2711.pack(px, bits)
    assert w.shape == (5, -(-23 * bits // 16)) and w.dtype == np.uint16
    np.testing.assert_array_equal(tlk2711.unpack(w, bits, 23), px)


def test_crc_matches_its_definition_and_the_gateware_matrix():
    rng = np.random.default_rng(1)
    words = rng.integers(0, 1 << 16, 40)
    assert tlk2711.crc16(words) == _crc_bitwise(words)
    assert tlk2711.crc16([0x3132, 0x3334, 0x3536, 0x3738]) == 0xA12B
    from_crc, from_word = crc16_matrix()
    for c, w in rng.integers(0, 1 << 16, (50, 2)).tolist():
        got = sum((bin(c & a).count("1") + bin(w & b).count("1")) % 2 << o
                  for o, (a, b) in enumerate(zip(from_crc, from_word)))
        assert got == tlk2711.crc16_update(c, w)


def _fill(words, rng, p=0.3):
    """Each link's words with random IDLEs inserted (a link's own fill)."""
    out = []
    for row in words:
        n = rng.binomial(3, p, len(row) + 1)
        parts = []
        for k, x in enumerate(row.tolist()):
            parts += [IDLE] * int(n[k]) + [x]
        out.append(np.array(parts + [IDLE] * int(n[-1]), np.int64))
    return out


@pytest.mark.parametrize("links", [1, 2])
@pytest.mark.parametrize("bits", [1, 7, 8, 10, 12, 16])
def test_decode_round_trip_with_fill(links, bits):
    rng = np.random.default_rng(bits * links)
    frames = [rng.integers(0, 1 << bits, (h, 6)) for h in (3, 1, 5)]
    frames[1][:] = (1 << bits) - 1
    w = tlk2711.tlk2711(frames, pixel_bits=bits, links=links)
    d = tlk2711.decode(_fill(w, rng), width=6, pixel_bits=bits, links=links)
    assert d.numbers == [0, 1, 2]
    for a, b in zip(d.frames, frames):
        np.testing.assert_array_equal(a, b)
    assert d.frames[0].dtype == (np.uint8 if bits <= 8 else np.uint16)


def _broken(mutate, links=2):
    rng = np.random.default_rng(4)
    frames = rng.integers(0, 4096, (2, 3, 8))
    w = tlk2711.tlk2711(frames, pixel_bits=12, links=links).astype(np.int64)
    lw = tlk2711.line_words(8, pixel_bits=12, links=links)
    return mutate(w, lw)


def _at(w, lw, frame, row, k):
    """Index of word ``k`` of row ``row`` of frame ``frame`` (3 rows a frame)."""
    return frame * (4 + 3 * lw) + 4 + row * lw + k


def _flip(w, lw):
    w[1, _at(w, lw, 1, 2, 5)] ^= 0x0400
    return w


def _drop(w, lw):
    return [w[0], np.delete(w[1], _at(w, lw, 0, 1, 6))]


def _extra(w, lw):
    return [np.insert(w[0], _at(w, lw, 0, 1, 6), 0x1234), w[1]]


def _swap(w, lw):
    return w[::-1]


def _k_in_row(w, lw):
    w[0, _at(w, lw, 1, 0, 5)] = 0x100F7              # K23.7
    return w


def _lost_row(w, lw):
    keep = np.ones(w.shape[1], bool)
    keep[_at(w, lw, 0, 1, 0):_at(w, lw, 0, 2, 0)] = False
    return w[:, keep]


def _cut(w, lw):
    return w[:, :_at(w, lw, 1, 1, 5)]


def _tkmsb(w, lw):
    w[0, _at(w, lw, 0, 0, 4)] |= tlk2711.TKMSB
    return w


def _no_sof(w, lw):
    return w[:, 4:]


@pytest.mark.parametrize("mutate,message", [
    (_flip, "link 1 word 61 (frame 1 line 2): CRC 0x6876 received, 0xA287 computed over "
            "the row (a corrupted word)"),
    (_drop, "link 1 word 19 (frame 0 line 1): the row has 2 payload words, expected 3 "
            "(4 pixels of 12 bits)"),
    (_extra, "link 0 word 20 (frame 0 line 1): EOL (end of row) expected, found a data "
             "word (the row is longer than 3 payload words, 4 pixels of 12 bits)"),
    (_swap, "link 0 word 2: the SOF of link 1 (are the links swapped?)"),
    (_k_in_row, "link 0 word 40 (frame 1 line 0): unexpected K character 0x00F7 (K23.7 in "
                "the low byte, D0.0 in the high byte); the framing sends only IDLE, SOF, "
                "SOL and EOL"),
    (_lost_row, "link 0 word 16 (frame 0 line 1): row number 2, expected 1 (a row lost or "
                "repeated)"),
    (_cut, "link 0 word 48 (frame 1 line 1): the stream ends inside the row"),
    (_tkmsb, "link 0 word 8 (frame 0 line 0): unexpected K character 0x"),
    (_no_sof, "link 0 word 2: a row before the first SOF (start of frame)"),
])
def test_decoder_names_what_is_wrong(mutate, message):
    with pytest.raises(TdicamError) as info:
        tlk2711.decode(_broken(mutate), width=8, pixel_bits=12, links=2)
    assert message in str(info.value), str(info.value)
    assert "\n" not in str(info.value)


def test_decoder_counts_fill_in_positions():
    """The position named is the word's in the link's stream as captured, IDLEs
    included."""
    w = tlk2711.tlk2711(np.zeros((1, 2, 4), int), pixel_bits=16, links=1).astype(np.int64)
    w[0, -1] ^= 1                                   # the last CRC
    captured = [np.concatenate([[IDLE] * 7, w[0]])]
    with pytest.raises(TdicamError, match=f"link 0 word {7 + w.shape[1] - 1} "):
        tlk2711.decode(captured, width=4, pixel_bits=16, links=1)


@pytest.mark.parametrize("call,match", [
    (lambda: tlk2711.tlk2711(np.zeros((2, 3)), pixel_bits=12), "integer array"),
    (lambda: tlk2711.tlk2711(np.full((2, 3), 4096), pixel_bits=12), "outside 0..4095"),
    (lambda: tlk2711.tlk2711(np.zeros((2, 3), int), links=2), "multiple of links = 2"),
    (lambda: tlk2711.tlk2711(np.zeros((2, 4), int), links=3), "links = 3"),
    (lambda: tlk2711.tlk2711(np.zeros((2, 4), int), pixel_bits=17), "pixel_bits = 17"),
    (lambda: tlk2711.tlk2711([np.zeros((2, 4), int), np.zeros((2, 6), int)]),
     "different widths"),
    (lambda: tlk2711.tlk2711(np.zeros(4, int)), "rows, cols"),
    (lambda: tlk2711.decode(np.zeros((1, 3), int), width=4, links=2), "1 link"),
    (lambda: tlk2711.frame_rate_limit(10, 10, word_clock_hz=150e6), "word_clock_hz = 150000000"),
    (lambda: tlk2711.frame_rate_limit(10, 11, links=2), "width = 11 is not a multiple"),
    (lambda: tlk2711.link_payload_bps(links=0), "links = 0"),
])
def test_bad_input_is_one_line(call, match):
    with pytest.raises(TdicamError, match=match) as info:
        call()
    assert "\n" not in str(info.value)


def test_plan_figures():
    """The paper's links: 2 at 100 MHz carry 3.2 Gbit/s; its 5144 x 3800 frame at 16 bits
    goes 10.2 times a second, twice as one image a gain channel (its 5 frame/s); packed 12-bit
    pixels go 4/3 as often; the figures vectorize."""
    assert tlk2711.link_payload_bps(links=2, word_clock_hz=100e6) == 3.2e9
    assert tlk2711.line_words(5144, pixel_bits=16, links=2) == 6 + 2572
    assert tlk2711.frame_words(3800, 5144, pixel_bits=16, links=2) == 4 + 3800 * 2578
    one = tlk2711.frame_rate_limit(3800, 5144, pixel_bits=16, links=2, word_clock_hz=100e6)
    assert one == pytest.approx(1e8 / 9_796_404)
    assert tlk2711.frame_rate_limit(3800, 5144, images=2) == pytest.approx(one / 2)
    assert 5.0 < one / 2 < 5.2
    twelve = tlk2711.frame_rate_limit(3800, 5144, pixel_bits=12)
    assert twelve / one == pytest.approx(2578 / (6 + 1929))
    f = tlk2711.frame_rate_limit(3800, 5144, word_clock_hz=np.array([80e6, 100e6, 135e6]))
    assert f.shape == (3,) and f[1] == pytest.approx(one)
    # the model's count is the words the block sends: the golden model agrees
    w = tlk2711.tlk2711(np.zeros((2, 3, 10), int), pixel_bits=11, links=2)
    assert w.shape[1] == 2 * tlk2711.frame_words(3, 10, pixel_bits=11, links=2)


# ----------------------------------------------------------------------- gateware


def test_component_params_and_errors():
    t = Tlk2711(pixel_bits=12, ppc=4, links=2)
    pins = Tlk2711(ppc=1, links=2, pins=True)
    cross = Tlk2711(pins=True, crossing=True, links=2)
    f = Tlk2711Framer(pixel_bits=11, pixels=8, links=2)
    narrow = Tlk2711(pixel_bits=12, ppc=1, links=2)
    for dut in (t, pins, cross, f, narrow):
        Fragment.get(dut, None)             # elaborates
    assert (t.pixel_bits, t.ppc, t.links, t.entry_pixels, t.latency) == (12, 4, 2, 4, 2)
    assert pins.latency == 3 and cross.latency is None
    assert cross.port_domains == {
        "link0_txd": "link", "link0_tklsb": "link", "link0_tkmsb": "link",
        "link1_txd": "link", "link1_tklsb": "link", "link1_tkmsb": "link"}
    assert (f.chunk_bits, f.acc_bits, f.latency) == (44, 64, 1)
    assert narrow.entry_pixels == 4
    for kw, match in [({"crossing": True}, "crossing needs pins"),
                      ({"fifo_depth": 6}, "fifo_depth = 6"), ({"links": 3}, "links = 3"),
                      ({"pixel_bits": 0}, "pixel_bits = 0"), ({"ppc": 3}, "ppc")]:
        with pytest.raises(TdicamError, match=match):
            Tlk2711(**kw)
    with pytest.raises(TdicamError, match="not a multiple of links"):
        Tlk2711Framer(pixels=3, links=2)


@pytest.mark.parametrize("args,expect", [
    (["--crossing", "true"], "--crossing true needs --pins true"),
    (["--links", "3"], "--links = 3 is not valid"),
    (["--pixel-bits", "17"], "--pixel-bits = 17 is out of range"),
])
def test_cli_bad_params_one_line(args, expect, capsys, tmp_path):
    assert main(["verilog", "tlk2711", *args, "-o", str(tmp_path / "x.v")]) == 2
    err = capsys.readouterr().err
    assert expect in err and err.count("\n") == 1, err


def test_pins_have_no_stream_cosimulation():
    arrays = stream_case([np.zeros((2, 4), int)], BLOCK.resolve({"pins": True}))
    with pytest.raises(TdicamError, match="two-clock co-simulation is cocotb_tests/test_"):
        case_beats(arrays, BLOCK.resolve({"pins": True}))


@pytest.mark.parametrize("build", sorted(BUILDS))
def test_golden_cases_amaranth_with_stalls(build):
    """Every golden case of the parameter set (random, hard values, narrowest rows, reset
    mid-frame) through the Verilog top in Amaranth's simulator, random idle cycles and
    backpressure, bit-exact."""
    for case in BLOCK.cases():
        if case.params != BUILDS[build]:
            continue
        run = run_golden_case(BLOCK, case.name, sim="amaranth", idle=0.3, backpressure=0.4,
                              seed=5)
        assert run.ok, run.message()


def _simulate(params, frames, *, idle=0.0, bp=0.0, seed=1, trace=None, latency_from=None):
    p = BLOCK.resolve(params)
    stim, exp = case_beats(stream_case(frames, p), p)
    dut = Tlk2711(**{k: p[k] for k in ("pixel_bits", "ppc", "links", "fifo_depth")})
    out, lat, fin = run_stream_component(
        dut, stim, len(exp), seed=seed, p_valid=1 - idle, p_ready=1 - bp, timeout=1e-2,
        drain=30, latency_from=latency_from, trace=trace)
    return out, exp, lat, fin


def _assert_equal(out, exp):
    got = np.array([o[0] for o in out], np.uint64).reshape(len(out), -1)
    assert len(out) == len(exp), (len(out), len(exp))
    bad = np.flatnonzero((got != exp.data).any(axis=1))
    assert not len(bad), f"word {bad[0]}: {got[bad[0]]} != {exp.data[bad[0]]}"
    assert [o[1] for o in out] == exp.first.tolist()
    assert [o[2] for o in out] == exp.last.tolist()


@pytest.mark.parametrize("ppc", PPC_CHOICES)
@pytest.mark.parametrize("links", [1, 2])
def test_full_rate_a_word_every_clock(ppc, links):
    """No stalls, 16-bit pixels: latency 2; when the input brings at least a word a link a
    clock (ppc >= links) the links send a word on every clock from the first to the last
    (no bubble between rows, frames or header and payload)."""
    rng = np.random.default_rng(ppc)
    w = 4 * max(ppc, links)
    frames = [rng.integers(0, 1 << 16, (h, w)) for h in (3, 1, 2)]
    trace = []
    out, exp, lat, fin = _simulate({"pixel_bits": 16, "ppc": ppc, "links": links}, frames,
                                   trace=trace, latency_from=0 if ppc >= links else None)
    _assert_equal(out, exp)
    if ppc >= links:
        assert lat == [2]
        outs = [c for k, c in trace if k == "o"]
        assert outs == list(range(outs[0], outs[0] + len(exp)))


@pytest.mark.parametrize("ppc,links,bits", [(1, 2, 16), (1, 1, 12), (2, 2, 12), (4, 2, 7)])
def test_slower_input_keeps_its_rate(ppc, links, bits):
    """An input of fewer bits a clock than the links take (``ppc * bits < 16 * links``) is
    taken on every clock, across rows and frames: the FIFO holds it while each row's
    header and trailer leave."""
    rng = np.random.default_rng(bits)
    frames = [rng.integers(0, 1 << bits, (h, 64)) for h in (3, 1, 2)]
    trace = []
    out, exp, _, _ = _simulate({"pixel_bits": bits, "ppc": ppc, "links": links}, frames,
                               trace=trace, latency_from=None)
    _assert_equal(out, exp)
    ins = [c for k, c in trace if k == "i"]
    assert ins == list(range(ins[0], ins[0] + len(ins)))


@pytest.mark.parametrize("idle,bp", [(0.0, 0.9), (0.9, 0.0), (0.5, 0.5)])
def test_extreme_stalls(idle, bp):
    rng = np.random.default_rng(7)
    frames = [rng.integers(0, 1 << 12, (h, 12)) for h in (2, 1, 3)]
    for ppc, links in [(1, 2), (4, 1), (2, 2)]:
        out, exp, _, _ = _simulate({"pixel_bits": 12, "ppc": ppc, "links": links}, frames,
                                   idle=idle, bp=bp, seed=ppc)
        _assert_equal(out, exp)


def test_entries_give_every_link_16_bits():
    assert entry_pixels(1, 1, 16) == 1 and entry_pixels(8, 2, 16) == 8
    assert entry_pixels(1, 2, 16) == 2 and entry_pixels(1, 1, 12) == 2
    assert entry_pixels(2, 2, 12) == 4 and entry_pixels(8, 2, 1) == 32
    for ppc in PPC_CHOICES:
        for links in (1, 2):
            for bits in range(1, 17):
                p = entry_pixels(ppc, links, bits)
                assert p % ppc == 0 and p % links == 0 and p // links * bits >= 16
                assert p == ppc or (p // 2) // links * bits < 16 or p // 2 < links


def test_widener_gathers_and_closes_at_a_row_end():
    """4 beats of 2 pixels an entry; rows of 12 and 4 pixels: the second entry of a row
    closes early with its 2 beats, zeros after them and its count."""
    k = np.arange(8)
    last = np.isin(k, [5, 7])
    stim = Beats(np.stack([2 * k + 10, 2 * k + 11], axis=1), k == 0, last)
    out, _, _ = run_stream_component(Widener(pixel_bits=8, ppc=2, beats=4, links=2), stim, 3,
                                     seed=2, latency_from=None, status=())
    assert [o[0] for o in out] == [list(range(10, 18)), [18, 19, 20, 21, 0, 0, 0, 0],
                                   [22, 23, 24, 25, 0, 0, 0, 0]]
    assert [o[1] for o in out] == [True, False, False]
    assert [o[2] for o in out] == [False, True, True]


@settings(max_examples=8, deadline=None)
@given(data=st.data())
@pytest.mark.parametrize("ppc", PPC_CHOICES)
def test_gateware_equals_golden_property(ppc, data):
    """Legal parameter sets at every ppc (links, pixel width 1..16, input FIFO depth, a
    width of 1..5 beats of max(ppc, links) pixels, 1..4 frames of 1..4 rows of random, zero
    or full-scale pixels, stall rates): the gateware's words equal the golden model's."""
    links = data.draw(st.sampled_from([1, 2]), "links")
    depth = data.draw(st.sampled_from([4, 16]), "fifo_depth")
    bits = data.draw(st.integers(1, 16), "bits")
    width = max(ppc, links) * data.draw(st.integers(1, 5), "entries")
    full = (1 << bits) - 1
    seed = data.draw(st.integers(0, 2**16), "seed")
    rng = np.random.default_rng(seed)
    frames = []
    for h in data.draw(st.lists(st.integers(1, 4), min_size=1, max_size=4), "heights"):
        kind = data.draw(st.sampled_from(["random", "zeros", "full"]))
        frames.append({"random": rng.integers(0, full + 1, (h, width)),
                       "zeros": np.zeros((h, width), int),
                       "full": np.full((h, width), full)}[kind])
    idle = data.draw(st.sampled_from([0.0, 0.3, 0.7]), "idle")
    bp = data.draw(st.sampled_from([0.0, 0.3, 0.7]), "bp")
    out, exp, _, _ = _simulate({"pixel_bits": bits, "ppc": ppc, "links": links,
                                "fifo_depth": depth}, frames, idle=idle, bp=bp,
                               seed=seed + 1)
    _assert_equal(out, exp)


# ------------------------------------------------------------- the pins, two clocks


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_pins_amaranth(name):
    """The transmitter as a board has it, in Amaranth's simulator (two clock domains with
    --crossing): the links' words at the pins, IDLEs dropped, are the golden words (a cut
    segment: a prefix), every marker follows two IDLEs, the links idle together, and the
    decoder gives the frames back."""
    case = scenario(name)
    check(case, run_amaranth(case))


def test_pins_check_catches_a_wrong_word_and_a_lone_idle():
    case = scenario("one_clock")
    cap = run_amaranth(case)
    words = [list(w) for w in cap["words"]]
    k = next(i for i, w in enumerate(words) if w[1] < 0x10000 and w[1])
    words[k][1] ^= 1
    with pytest.raises(AssertionError, match=r"one_clock: segment 0 link 1 frame \d line \d: "
                       r"non-IDLE word \d+ at link clock \d+ "):
        check(case, {**cap, "words": words})
    words = [list(w) for w in cap["words"]]
    k = next(i for i, w in enumerate(words) if w[0] == tlk2711.marker(tlk2711.K28_0, 0))
    words[k - 1] = [0x1234, words[k - 1][1]]
    with pytest.raises(AssertionError, match="lockstep"):
        check(case, {**cap, "words": words})


def test_pins_are_idle_in_reset_and_without_input():
    case = PinsCase("quiet", [np.zeros((1, 2), int)], {"pixel_bits": 8, "links": 2},
                         idle=0.0)
    cap = run_amaranth(case)
    assert cap["words"][0] == [IDLE, IDLE]           # the first clock after reset
    assert all(w == [IDLE, IDLE] for w in cap["words"][-30:])


def test_reset_scenario_really_cuts_a_frame_with_words_in_flight():
    case = scenario("reset_mid_frame")
    cap = run_amaranth(case)
    words, seg = np.array(cap["words"]), np.array(cap["seg"])
    gold = case.segments()
    sent0 = int((words[seg == 0, 0] != IDLE).sum())
    assert 4 < sent0 < int((gold[0][0] != IDLE).sum())
    assert int((words[seg == 1, 0] != IDLE).sum()) == int((gold[1][0] != IDLE).sum())
    assert case.stim.rst.sum() == 1


def test_block_cases_cover_what_the_issue_asks():
    """Both link counts, every ppc, pixel widths 1..16 with 16, 12, 10 and 8; random,
    full-scale/zero/constant, narrowest rows and a reset mid-frame at every build."""
    params = [BLOCK.resolve(p) for p in BUILDS.values()]
    assert {p["links"] for p in params} == {1, 2}
    assert {p["ppc"] for p in params} == set(PPC_CHOICES)
    assert {16, 12, 10, 8, 1} <= {p["pixel_bits"] for p in params}
    tags = {}
    for c in BLOCK.cases():
        tags.setdefault(tuple(sorted(c.params.items())), set()).update(c.tags)
    assert all({"reset", "fullscale", "zeros", "smallest"} <= t for t in tags.values())
