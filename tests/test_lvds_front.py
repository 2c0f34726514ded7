"""The camera's front end: sensor frames -> LVDS lanes -> pixel stream (issue 30).

Golden model (:mod:`tdicam.model.lvds_front`), the ``[sensor.lvds]`` scene section and its
effect row, and :class:`tdicam.hdl.lvds_front.LvdsFront` in Amaranth's simulator with two
clocks (:mod:`tdicam.cosim.lvds_front`): the clock-domain crossing at the worst rate ratio
the format allows (word clock faster and slower than the processing clock's share), a lane
whose eye is too narrow to train, a lane that dies mid-run and the retrain after it.
"""

import os

import numpy as np
import pytest

from tdicam.cosim.lvds_front import (GEOMETRY, SCENARIOS, FrontCase, check, frames_of,
                                     run_amaranth, scenario, scenario_frames, scenario_lanes)
from tdicam.errors import TdicamError
from tdicam.model.lvds import Link, default_train_word, sent_words
from tdicam.model import lvds_front

L, G, C, R = (GEOMETRY[k] for k in ("lanes_per_gain", "gains", "columns", "rows"))
_frames = scenario_frames
_lanes = scenario_lanes


# ---------------------------------------------------------------- golden model, format
def test_lane_payload_is_the_line_format():
    fr = _frames(2, 3)
    pay = lvds_front.lane_payload(fr, L, 12)
    assert len(pay) == G * L and all(len(p) == 2 * R * (C // L + 2) for p in pay)
    lw = C // L + 2
    for g in range(G):
        for k in range(L):
            words = pay[g * L + k].reshape(2, R, lw)
            assert (words[:, :, 0] == 0xFFF).all()
            assert (words[:, :, 1] == np.arange(R)).all()       # signal frames: kind bit 0
            assert np.array_equal(words[:, :, 2:], lvds_front.wire_code(fr[g][:, :, k::L], 12))
    assert lvds_front.wire_code([4095, 4094, 0], 12).tolist() == [4094, 4094, 0]
    # a reset frame's headers carry the kind in their top bit
    kinds = lvds_front.lane_payload(fr, L, 12, kinds=[1, 0])[3].reshape(2, R, lw)[:, :, 1]
    assert kinds.tolist() == [[0x800, 0x801, 0x802], [0, 1, 2]]
    assert lvds_front.header_word(2, 1, 10) == 0x202
    # the link model carries the payload in its data segments, sync words included
    link = Link(_lanes(), word_bits=12, line_words=lw, schedule=((50, "data"),),
                payload=pay)
    n = np.arange(50, 50 + 2 * R * lw)
    assert np.array_equal(sent_words(link, 5, n), pay[5])
    assert (sent_words(link, 5, np.arange(50)) == link.train_word).all()
    # past the payload: the link model's own data, sync every line
    after = sent_words(link, 5, np.arange(50 + 2 * R * lw, 50 + 4 * R * lw))
    assert (after[::lw] == 0xFFF).all()


def test_golden_front_from_the_lanes_round_trip():
    """frames_from_lanes on the words the link model sends (data segments, blank lines
    between) gives back the frames as the wire carries them, bad lanes' columns 0."""
    case = scenario("lane_dies")
    words = [lvds_front.data_words(case.link, i) for i in range(G * L)]
    assert all(len(w) == (8 * R + 2) * (C // L + 2) for w in words)
    for bad in ([], [3, 6]):
        px, inv, kinds = lvds_front.frames_from_lanes(words, L, R, 12, bad)
        exp, inv2 = lvds_front.receive(case.frames, bad, L, 12)
        assert np.array_equal(px, exp) and np.array_equal(inv, inv2)
        assert kinds.tolist() == [1, 0, 1, 0, 1, 0, 1, 0]      # reset, signal, ... in turn
    words[4] = words[4].copy()
    words[4][1] = 1                         # a header the other lanes do not send
    with pytest.raises(TdicamError, match="lanes disagree on the header"):
        lvds_front.frames_from_lanes(words, L, R, 12)


def test_invalid_columns_follow_the_convention():
    inv = lvds_front.invalid_columns([1, 6], C, L, G)
    assert np.flatnonzero(inv[0]).tolist() == [1, 5, 9, 13]
    assert np.flatnonzero(inv[1]).tolist() == [2, 6, 10, 14]
    px, inv2 = lvds_front.receive(_frames(1, 3), [6], L, 12)
    assert (px[1][..., 2::4] == 0).all() and np.array_equal(inv2, lvds_front.invalid_columns(
        [6], C, L, G))


def test_fifo_depth_from_the_rates():
    # P = 4: the processing side must take >= 4/6 of the word rate's entries
    assert lvds_front.fifo_depth(4, 1, 16, 25.0, 100.0) == 8         # r = 1: slack only
    assert lvds_front.fifo_depth(40, 8, 5120, 25.0, 130.0) == 8       # GMAX0504, r = 1.04
    assert lvds_front.fifo_depth(40, 8, 5120, 25.0, 124.0) == 16      # r = 0.992: 128 x 0.008
    assert lvds_front.fifo_depth(4, 2, 16, 25.0, 100.0 / 3) == 16     # r = 4/6: 2 + 8 -> 16
    with pytest.raises(TdicamError, match="needs >= 123.1 MHz"):
        lvds_front.fifo_depth(40, 8, 5120, 25.0, 120.0)                # below P / (P + 2)
    with pytest.raises(TdicamError, match="needs >= 33.33 MHz"):
        lvds_front.fifo_depth(4, 2, 16, 25.0, 33.0)
    with pytest.raises(TdicamError, match="is more lanes than the 3 columns"):
        lvds_front.check_geometry(3, 4, 4, 12, 12)
    lvds_front.check_geometry(18, 4, 4, 12, 12)         # padded: 5 words a lane, 2 slots
    with pytest.raises(TdicamError, match="its top bit the frame kind\\) counts to 2045"):
        lvds_front.check_geometry(16, 2046, 4, 12, 12)
    lvds_front.check_geometry(16, 2045, 4, 12, 12)


def test_padded_last_word_clock():
    """Lanes that do not divide the columns: every lane sends P = ceil(C / L) words a line,
    the lanes above the last word clock's R = C - (P - 1) L columns a padded slot (0); the
    golden front drops them. The GMAX0504's 5144 columns on 40 lanes: 129 words, 24
    columns in the last word clock, 16 padded slots a gain, 131 words a line."""
    assert (lvds_front.line_words(5144, 40), lvds_front.last_word_columns(5144, 40),
            lvds_front.padded_slots(5144, 40)) == (131, 24, 16)
    assert (lvds_front.line_words(16, 4), lvds_front.last_word_columns(16, 4),
            lvds_front.padded_slots(16, 4)) == (6, 4, 0)
    frames = _frames(2, 5)
    fr = [f[..., :14] for f in frames]                  # 14 columns on 4 lanes: 4 words, R 2
    pay = lvds_front.lane_payload(fr, L, 12)
    lw = lvds_front.line_words(14, L)
    assert lw == 6 and all(len(w) == 2 * R * lw for w in pay)
    for i, w in enumerate(pay):
        line = w[:lw]
        g, k = divmod(i, L)
        want = lvds_front.wire_code(fr[g][0, 0, k::L], 12)
        assert np.array_equal(line[2:2 + len(want)], want)
        assert (len(want), line[-1] if len(want) < lw - 2 else None) == \
            ((4, None) if k < 2 else (3, 0))            # lanes 2, 3 pad their last slot
    link = Link(_lanes(), word_bits=12, schedule=((0, "data"),), payload=pay, line_words=lw)
    words = [lvds_front.data_words(link, i) for i in range(G * L)]
    px, inv, _ = lvds_front.frames_from_lanes(words, L, R, 12, (), columns=14)
    assert px.shape == (G, 2, R, 14) and inv.shape == (G, 14)
    assert np.array_equal(px, np.stack([lvds_front.wire_code(f, 12) for f in fr]))
    with pytest.raises(TdicamError, match="carry 13 to 16 columns, not 12"):
        lvds_front.frames_from_lanes(words, L, R, 12, (), columns=12)
    # the processing side needs C / ppc clocks a line in its P + 2 word clocks
    assert lvds_front.min_proc_mhz(40, 8, 5144, 25.0) == pytest.approx(25 * 5144 / 131 / 8)
    assert lvds_front.min_proc_mhz(4, 2, 16, 25.0) == 25.0 * 16 / 6 / 2


@pytest.mark.parametrize("columns, ppc", [(14, 2), (13, 1), (10, 2)])
def test_padded_front_in_amaranth(columns, ppc):
    """The gateware front with a padded last word clock: every frame whole and exact (the
    golden front's, i.e. the sent wire codes), ``last`` on each line's last real column,
    no padded slot in the stream; at ppc 2 with backpressure."""
    from tdicam.hdl.lvds_front import LvdsFront
    fr = [f[..., :columns] for f in _frames(3, 9)]
    case = FrontCase(fr, _lanes(), L, ppc=ppc, word_ns=40.0, proc_ns=10.0, ready=0.7)
    dut = LvdsFront(lanes_per_gain=L, gains=G, word_bits=12, bits=12, columns=columns,
                    ppc=ppc, fifo_depth=case.fifo_depth, settle=case.settle)
    res = run_amaranth(case, dut=dut)
    got = frames_of(res["beats"], R, columns, ppc, G)
    assert np.array_equal(got, np.stack([lvds_front.wire_code(f, 12) for f in fr])), got.shape
    lasts = [i for i, (_f, last, _e) in enumerate(res["beats"]) if last]
    assert np.array_equal(np.diff([-1] + lasts), [columns // ppc] * (3 * R))


def test_padded_front_refuses_a_last_word_clock_ppc_does_not_divide():
    """ppc must divide the last word clock's columns too: one line naming both."""
    from tdicam.hdl.lvds_front import LvdsFront
    with pytest.raises(TdicamError, match=r"ppc = 2 does not divide the 1 columns of a line's "
                                          r"last word clock \(columns = 13 on 4 lanes\)"):
        LvdsFront(lanes_per_gain=4, gains=2, columns=13, ppc=2)
    with pytest.raises(TdicamError, match="more lanes than columns = 3"):
        LvdsFront(lanes_per_gain=4, gains=2, columns=3, ppc=1)


# ---------------------------------------------------------------- gateware, two clocks
@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_in_amaranth(name):
    """The must-show scenarios (:data:`tdicam.cosim.lvds_front.SCENARIOS`, ppc 2): the
    crossing at r = P / (P + 2) (word clock faster) and r = 5.6 with backpressure (slower),
    no pixel lost or duplicated; a narrow-eye lane reported, its columns invalid, the other
    lanes exact; a lane dying mid-frame, the frame filled and counted, frames held until the
    retrain."""
    case = scenario(name)
    assert check(name, case, run_amaranth(case)) == []


def test_steady_lane_table_drives_the_front_as_the_whole_table():
    """The whole camera's lane table is cut to every tap during the training and the
    trained tap after it (:func:`tdicam.cosim.lvds_front.driver_tables`): the front driven
    from it passes the scenario as from the whole table, its words at the trained taps are
    the whole table's, and a table whose trained tap is wrong is refused (the lane sampled
    at another tap after the training is named)."""
    from tdicam.cosim.lvds_front import driver_tables, raw_table
    case = scenario("cdc_fast")
    raw, steady = driver_tables(case, steady_above=0)
    assert steady is not None and driver_tables(case)[1] is None    # small: the whole table
    k0, taps, words = steady
    assert raw.shape[2] == k0 < case.cycles
    whole = raw_table(case.link, case.cycles)
    assert (whole[:, :, :k0] == raw).all()
    assert all((whole[i, t, k0:] == words[i]).all() for i, t in enumerate(taps))
    res = run_amaranth(case, steady=(raw, steady))
    assert check("cdc_fast", case, res) == [] and "steady_miss" not in res
    wrong = (raw, (k0, [taps[0] ^ 1] + taps[1:], words))
    assert run_amaranth(case, steady=wrong)["steady_miss"][1:] == [0, taps[0], taps[0] ^ 1]
    assert driver_tables(scenario("lane_dies"), steady_above=0)[1] is None   # a retrain


def test_golden_front_of_a_lane_death():
    """The golden front when a lane dies mid-frame: the cut frame healthy up to the death,
    the dead lane's words as seen until the fill, 0s from the fill (the first word from
    which every lane reads 0); the frames held until the retrain dropped; after it the dead
    lane's columns 0; the frame status of each released frame (with ``pairs``, released
    from the next reset frame on)."""
    rng = np.random.default_rng(3)
    frames = [rng.integers(1, 4000, (8, 3, 8)) for _ in range(2)]      # L = 2: P = 4
    healthy = lvds_front.receive(frames, [3], 2, 12)[0][:, 3]
    seen = healthy.copy()
    seen[0, 1, 3::2][1:] = 77                 # lane 1 (gain 0, odd columns) dead from word 5
    seen[:, 2, :] = 0                         # filled from word 8 (row 2)
    cut, fill = lvds_front.cut_frame(healthy, seen, 2, 1, 5)
    assert fill == 8 and np.array_equal(cut, seen)
    seen[1, 1, 0] += 1                        # another lane wrong: not what the model gives
    assert not np.array_equal(lvds_front.cut_frame(healthy, seen, 2, 1, 5)[0], seen)
    kinds = [1, 0] * 4
    px, k, status, dropped = lvds_front.lane_death(frames, 2, 12, bad_lanes=[3], lane=1, frame=3,
                                                   cut=cut, kinds=kinds, pairs=True)
    assert dropped == 2 and list(k) == [1, 0, 1, 0, 1, 0]
    assert status == [8, 8, 8, 15, 10, 10]
    after = lvds_front.receive(frames, [1, 3], 2, 12)[0]
    assert np.array_equal(px[:, 4:], after[:, 6:]) and (px[0, 4:, :, 1::2] == 0).all()
    # a reset frame cut: with pairs the signal frame after the held ones is dropped too
    _, k, status, dropped = lvds_front.lane_death(frames, 2, 12, bad_lanes=[], lane=1, frame=2,
                                                  cut=cut, kinds=kinds, pairs=True)
    assert dropped == 3 and list(k) == [1, 0, 1, 1, 0] and status == [0, 0, 15, 2, 2]


def test_fifo_depth_has_a_ddr_stall_margin():
    """A block behind the front that holds the stream (cds_ddr on the DDR model's worst
    stall: refresh cycles + the longest read latency) adds its entries to the depth."""
    from tdicam.model.dram import DEFAULT_STALLS, worst_stall
    assert worst_stall({}) == worst_stall(DEFAULT_STALLS) == 44 + 60
    # r = 1 at 4 lanes x 25 M words/s, 100 MHz: 104 clocks are 26 entries
    assert lvds_front.fifo_depth(4, 1, 16, 25.0, 100.0, stall_cycles=104) == 64    # 26 + 8
    assert lvds_front.fifo_depth(4, 1, 16, 25.0, 100.0, stall_cycles=96) == 32     # 24 + 8


@pytest.mark.parametrize("pairs", [0, 1])
def test_frames_before_release_are_dropped_whole_and_counted(pairs):
    """The top releases the front only when its start-up is done (the calibration loaded):
    the sensor may start before. Frames whose first line arrives while ``release`` is low
    are dropped whole and counted (``frames_dropped``); the released frames are whole and
    exact, the first the next frame to start after the release (with ``pairs``, the next
    reset frame: the CDS stage never gets a signal frame without its reset)."""
    from tdicam.cosim.lvds_front import cds_kinds
    from tdicam.hdl.lvds_front import LvdsFront
    nf = 6
    case = FrontCase(_frames(nf, 7), _lanes(), L, ppc=2, word_ns=40.0, proc_ns=10.0,
                     kinds=cds_kinds(nf))
    dut = LvdsFront(lanes_per_gain=L, gains=G, word_bits=12, bits=12, columns=C, ppc=2,
                    fifo_depth=case.fifo_depth, settle=case.settle, pairs=pairs)
    lw = case.p + 2
    # released in the middle of frame 0's second line (1 + blank: frame 1 starts next)
    at = case.segment_starts[0] + lw + 3

    def hook(ctx, d, k):
        ctx.set(d.release, int(k >= at))
    res = run_amaranth(case, dut=dut, hook=hook)
    first = 2 if pairs else 1                   # frame 1 is a signal frame
    st = res["status"]
    assert (st["frames_out"], st["frames_dropped"], st["fifo_overflow"]) == \
        (nf - first, first, 0)
    got = frames_of(res["beats"], R, C, 2, G)
    words = [lvds_front.data_words(case.link, i) for i in range(G * L)]
    exp, _, kinds = lvds_front.frames_from_lanes(words, L, R, 12)
    assert np.array_equal(got, exp[:, first:])
    assert res["kinds"] == list(kinds[first:])


def test_cdc_at_one_pixel_per_clock():
    case = FrontCase(_frames(5, 3), _lanes(), L, ppc=1, word_ns=60.0, proc_ns=10.0, ready=0.8)
    assert check("cdc_slow", case, run_amaranth(case)) == []


# ---------------------------------------------------------------- scene section and effect
def _scene(lvds=None, **sensor):
    from tdicam.scene.loader import scene_from_dict
    sen = {"columns": 16, "rows": 8, "bits": 12, "full_well_e": 4000.0,
           "gains": [2.0, 1.0], **sensor}
    if lvds is not None:
        sen["lvds"] = lvds
    return scene_from_dict({"orbit": {"altitude_km": 600, "gsd_m": 1.0},
                            "target": {"kind": "flat", "signal_e": 900.0},
                            "sensor": sen, "tdi": {"stages": 2},
                            "pipeline": {"blocks": ["hdr", "tdi"]},
                            "run": {"lines": 6, "fidelity": "exact"}})


@pytest.mark.parametrize("lvds,match", [
    ({"lanes_per_gain": 17}, r"\[sensor.lvds\].lanes_per_gain: 17 is more lanes than \[sensor\].columns = 16"),
    ({"word_bits": 10}, r"\[sensor.lvds\].word_bits: 10 is narrower than the 12-bit"),
    ({"train_word": 0x555}, r"\[sensor.lvds\].train_word: 0x555 repeats under rotation"),
    ({"eye_width_taps": [10, 12]}, r"eye_width_taps: must be one number or one per lane \(8"),
    ({"eye_centre_taps": 32}, r"eye_centre_taps = 32 is out of range; valid: 0..31"),
    ({"jitter_ps": -1}, r"jitter_ps = -1 is out of range"),
    ({"mapping": "blocks"}, r"mapping: must be one of 'interleaved', got 'blocks'"),
    ({"lanes": 4}, r"\[sensor.lvds\].lanes: unknown key"),
])
def test_scene_section_errors_are_one_line(lvds, match):
    with pytest.raises(TdicamError, match=match) as e:
        _scene({"lanes_per_gain": 4, **lvds})
    assert "\n" not in str(e.value)


def test_scene_defaults_gmax0504_and_no_section_is_ideal():
    sc = _scene({}, columns=80)
    lv = sc.sensor.lvds
    assert (lv.lanes_per_gain, lv.word_bits, lv.bit_rate_mbps, lv.simulate) == (40, 12, 300.0,
                                                                              False)
    assert lv.train_word == default_train_word(12)
    plain = _scene()
    assert plain.sensor.lvds is None and "lvds" not in plain.to_dict()["sensor"]


def test_effect_row_and_invalid_columns_in_the_simulator():
    from tdicam.engine import simulate
    base = simulate(_scene(), impact=False, keep_raw=True)
    row = {e.name: e for e in base.effects}["sensor_lanes"]
    assert not row.ran and row.why == "no [sensor.lvds]: ideal lanes, no link simulated"
    # ideal lanes: the same pixels (no code reaches the sync word at this light level)
    ideal = simulate(_scene({"lanes_per_gain": 4}), impact=False)
    assert np.array_equal(ideal.output, base.output)
    assert "no eye given: the link is ideal" in {e.name: e for e in ideal.effects}[
        "sensor_lanes"].why
    # lane 1 (high gain) 6 taps wide: it cannot train, columns 1, 5, 9, 13 of HG are 0
    widths = [14.0] * 8
    widths[1] = 6.0
    sim = simulate(_scene({"lanes_per_gain": 4, "eye_width_taps": widths}), impact=False,
                   keep_raw=True)
    row = {e.name: e for e in sim.effects}["sensor_lanes"]
    assert row.ran and "lanes 1 fail" in row.why
    assert any("lanes 1 did not train" in n for n in sim.notes)
    assert (sim.single[:, 1::4] == 0).all() and (base.single[:, 1::4] > 0).all()
    keep = np.ones(16, bool)
    keep[1::4] = False
    assert np.array_equal(sim.single[:, keep], base.single[:, keep])


# ---------------------------------------------------------------- the front in a pipeline
def _chain_scene(lvds=True, ppc=2):
    from tdicam.scene.loader import scene_from_dict
    sen = {"columns": C, "rows": 8, "bits": 12, "gains": [2.0, 1.0]}
    if lvds:
        sen["lvds"] = {"lanes_per_gain": L}
    return scene_from_dict({"orbit": {"altitude_km": 600, "gsd_m": 1.0}, "sensor": sen,
                            "tdi": {"stages": R}, "pipeline": {"blocks": ["hdr", "tdi"]},
                            "run": {"lines": 4, "rtl": {"pixels_per_clock": ppc}}})


def _inspected(top):
    """Mark a top built only to read its ports, and everything in it (no
    UnusedElaboratable warnings)."""
    parts = [top, top.core] + [c for cs in top.core.cores for c in cs]
    for c in parts + [getattr(c, "_rx", None) for c in parts]:
        if c is not None:
            c._MustUse__silence = True
    return top


def test_plan_puts_the_front_first_and_the_top_takes_lanes():
    from tdicam.chain import design
    p = design.chain_plan(_chain_scene())
    assert [s.block for s in p.steps] == ["lvds", "hdr", "tdi"]
    assert p.steps[0].params == {"lanes": 8, "word_bits": 12, "lanes_per_gain": 4,
                                 "columns": 16, "bits": 12, "fifo_depth": 16, "ppc": 2}
    assert p.steps[0].ports["frame_rows"] == R
    top = _inspected(design.top(p))
    names = set(top.signature.members)
    assert {"lvds_lane_raw", "lvds_lane_tap", "lvds_frame_invalid", "lvds_frames_dropped",
            "m_axis_tdata"} <= names
    assert not {n for n in names if n.startswith("s_axis")}
    # without [sensor.lvds] the chain and its top are those of before
    plain = design.chain_plan(_chain_scene(lvds=False))
    assert [s.block for s in plain.steps] == ["hdr", "tdi"]
    assert "s_axis_tdata" in _inspected(design.top(plain)).signature.members
    padded = design.chain_plan(_chain_scene(), width=18, ppc=2)   # 5 words a lane, 2 padded
    assert padded.steps[0].params["columns"] == 18
    with pytest.raises(TdicamError, match=r"lvds \(the chain's source\): \[sensor.lvds\]"
                                          r".lanes_per_gain = 4 is more lanes than the 3 "
                                          r"columns"):
        design.chain_plan(_chain_scene(), width=3, ppc=1)


def test_pipeline_from_lanes_to_tdi_output_is_bit_exact():
    """The scene's whole top (front -> hdr -> tdi) in Amaranth's simulator, two clocks, from
    the serial lanes to TDI's lines, equals the golden chain."""
    from tdicam.blocks.steps import SceneData
    from tdicam.chain import design
    p = design.chain_plan(_chain_scene())
    frames = _frames(p.frames, seed=9)
    case = FrontCase(frames, _lanes(), L, ppc=2, word_ns=40.0, proc_ns=10.0)
    settings = {f"{s.block}_{k}": v for s in p.steps[1:] for k, v in s.ports.items()}
    top = design.top(p)
    top._MustUse__silence = True        # its core is simulated
    res = run_amaranth(case, dut=top.core, prefix="lvds_", settings=settings, elems=2)
    assert res["status"]["frames_out"] == p.frames
    exp = design.golden(p, SceneData(signal=frames))[-1][2]
    got = frames_of(res["beats"], 1, C, 2, 1)[0]
    assert exp.shape == (p.lines, 1, C) and np.array_equal(got, exp)


def test_verilog_pipeline_command_takes_lanes_and_phy(tmp_path, capsys):
    """``tdicam verilog pipeline --scene`` of a scene with [sensor.lvds]: the top's input is
    the lanes (generic PHY), or the 7-series pins with ``--phy xilinx7``; deterministic."""
    from tdicam.cli import main
    text = (f"[orbit]\naltitude_km = 600\ngsd_m = 1.0\n[sensor]\ncolumns = {C}\nrows = 8\n"
            f"bits = 12\ngains = [2.0, 1.0]\n[tdi]\nstages = {R}\n[pipeline]\n"
            f"blocks = [\"hdr\", \"tdi\"]\n[run]\nlines = 4\n")
    f = tmp_path / "s.toml"
    f.write_text(text + f"[sensor.lvds]\nlanes_per_gain = {L}\n")
    outs = {}
    for phy in ("none", "xilinx7", "none"):
        out = tmp_path / f"{phy}.v"
        assert main(["verilog", "pipeline", "--no-csr", "--scene", str(f), "--phy", phy,
                     "-o", str(out)]) == 0
        outs.setdefault(phy, []).append(out.read_text())
    generic, xil = outs["none"][0], outs["xilinx7"][0]
    assert outs["none"][0] == outs["none"][1]
    head = generic.split("module pipeline(")[1].split(")")[0]
    assert "lvds_lane_raw" in head and "word_clk" in head and "s_axis_tdata" not in head
    assert "IDELAYE2" not in generic
    xhead = xil.split("module pipeline(")[1].split(")")[0]
    assert "lvds_lane_p" in xhead and "lvds_clk_div" in xhead and "lvds_lane_raw" not in xhead
    assert xil.count("IDELAYE2 #(") == 2 * L and xil.count("ISERDESE2 #(") == 2 * L
    plain = tmp_path / "plain.toml"
    plain.write_text(text)
    capsys.readouterr()
    assert main(["verilog", "pipeline", "--no-csr", "--scene", str(plain), "--phy", "xilinx7"]) != 0
    err = capsys.readouterr().err.strip()
    assert err == ("tdicam: error: pipeline: --phy = xilinx7 needs the sensor's lanes in the "
                   "chain (a [sensor.lvds] section in the scene)")


def test_lvds_testbench_refuses_a_payload_link():
    """The lvds block's HDL testbench makes its own data: a link carrying frames is refused
    (one line), not silently simulated without them."""
    from tdicam.cosim import lvds
    with pytest.raises(TdicamError, match="not a payload; a link carrying frames runs in"):
        lvds.run_link(scenario("cdc_fast").link, params={"lanes": 8, "word_bits": 12},
                      cycles=10)


# ---------------------------------------------------------------- eye status (issue 46 step 4)
def test_front_publishes_the_eyes_the_golden_model_predicts(tmp_path):
    """LvdsFront(eye=True) with the sensor's walking-1/0 round before the frames: per lane
    the tap pass mask, the widest run, chosen tap, slip and slip mask and the walking
    patterns equal the golden link model's; the narrow lane (6 taps) reports its error in
    one line; the frames still arrive bit-exact; the picture is written."""
    from tdicam.cosim.lvds_front import GOOD_LANES, lane_eyes
    from tdicam.run.eyes import eye_figure
    spec = list(GOOD_LANES)
    spec[5] = (12, 6, 0)
    case = FrontCase(_frames(2, 3), _lanes(spec), L, ppc=2, word_ns=40.0, proc_ns=10.0,
                     walk=True)
    res = run_amaranth(case)
    assert check("narrow_eye", case, res) == []
    eyes = lane_eyes(case.golden_run().final, res["status"], 12, tap_ps=156.25,
                     eye_taps=[w for _, w, _ in spec])
    assert all(e["agree"] for e in eyes), [e["text"] for e in eyes if not e["agree"]]
    assert [e["walk_ok"] for e in eyes] == [i != 5 for i in range(8)]
    assert [e["error"] for e in eyes] == [int(i == 5) for i in range(8)]
    assert eyes[5]["text"].startswith("lane 5: error: no eye (widest run ")
    assert "\n" not in eyes[5]["text"] and "(scene: 6)" in eyes[5]["text"]
    for e, (c, w, _) in zip(eyes[:5], spec):
        assert e["locked"] and abs(e["eye_taps_found"] - w) <= 1
        assert e["tap"] == e["golden"]["tap"] and sum(e["taps"]) >= e["eye_taps_found"]
    eye_figure(eyes, tmp_path / "eyes.png")
    assert (tmp_path / "eyes.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ---------------------------------------------------------------- property: every geometry
FULL = os.environ.get("TDICAM_FULL") == "1"


def _front_geometry(data):
    """A legal front geometry: lanes a gain, gains, ppc dividing the lanes, a width >= the
    lanes and a multiple of ppc (so the last, maybe padded, word clock is one too)."""
    from hypothesis import strategies as st
    lpg = data.draw(st.sampled_from([1, 2, 4, 8]), "lanes_per_gain")
    ppc = data.draw(st.sampled_from([p for p in (1, 2, 4, 8) if lpg % p == 0]), "ppc")
    cols = data.draw(st.sampled_from([c for c in range(lpg, 3 * lpg + 1) if c % ppc == 0
                                      and c >= 2 * ppc]), "columns")
    gains = data.draw(st.sampled_from([1, 2]), "gains")
    rows = data.draw(st.integers(1, 3), "rows")
    return lpg, ppc, cols, gains, rows


def test_front_equals_golden_over_its_geometries():
    """Hypothesis: any legal geometry (padded or not, 1 or 2 gains, ppc 1..8), random
    frames, lanes with whole-word delays, backpressure: the Amaranth front delivers the
    golden front's frames (:func:`tdicam.model.lvds_front.frames_from_lanes`) exactly."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from tdicam.hdl.lvds_front import LvdsFront

    def check_one(data):
        lpg, ppc, cols, gains, rows = _front_geometry(data)
        seed = data.draw(st.integers(0, 2**16), "seed")
        rng = np.random.default_rng(seed)
        fr = [rng.integers(0, 1 << 12, (2, rows, cols)) for _ in range(gains)]
        lanes = [lvds_front.eye_lane(float(rng.uniform(9, 22)), float(rng.uniform(12, 20)),
                                     word_delay=int(rng.integers(0, 2)), seed=i)
                 for i in range(lpg * gains)]
        case = FrontCase(fr, lanes, lpg, ppc=ppc, word_ns=40.0 * ppc / 2, proc_ns=10.0,
                         ready=data.draw(st.sampled_from([1.0, 0.6]), "ready"))
        dut = LvdsFront(lanes_per_gain=lpg, gains=gains, word_bits=12, bits=12, columns=cols,
                        ppc=ppc, fifo_depth=case.fifo_depth, settle=case.settle)
        res = run_amaranth(case, dut=dut)
        words = [lvds_front.data_words(case.link, i) for i in range(lpg * gains)]
        exp = lvds_front.frames_from_lanes(words, lpg, rows, 12, (), cols)[0]
        got = frames_of(res["beats"], rows, cols, ppc, gains)
        assert np.array_equal(got, exp), (lpg, ppc, cols, gains, rows)
        assert np.array_equal(exp, np.stack([lvds_front.wire_code(f, 12) for f in fr]))
    settings(max_examples=40 if FULL else 6, deadline=None, derandomize=not FULL,
             database=None, print_blob=True, suppress_health_check=[HealthCheck.too_slow])(
        given(data=st.data())(check_one))()
