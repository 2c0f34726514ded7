"""Serial-bit co-simulation of the LVDS receiver behind its vendor PHYs (``xilinx7``,
``ecp5``): the link model drives every lane's pins at the bit rate, the generated receiver
with the primitive models (:mod:`tdicam.cosim.xilinx7_io`, :mod:`tdicam.cosim.ecp5_io`)
trains, locks and delivers words.

The pins (testbench, timescale 1 fs)
------------------------------------
Bit ``n`` of a lane (the sender's bits, most significant bit of each word first:
:func:`tdicam.model.lvds.sent_words`) occupies ``[T0 + skew + n UI, T0 + skew + (n+1) UI)``
(``T0``: the start of port cycle 0, the first word clock after reset; ``UI`` a whole number
of fs: :func:`ui_fs`). Its value is on the pins only inside its eye ``[lo + jl + d, hi - jr
+ d')`` of the bit (``lo, hi = (UI -/+ eye) / 2``); before and after, the pins show a
random level (the closed eye: what a sampler captures there is random). ``jl``, ``jr``
(random jitter) are drawn per bit, uniform in ``[0, jitter)`` (the lowbias32 hash of the
bit index and the lane's jitter key: 16 bits each); duty-cycle distortion ``dcd`` widens
the eye of a 1 by ``dcd / 2`` on each side and narrows that of a 0 as much (``d = -dcd/2,
d' = +dcd/2`` for a 1, the opposite for a 0). The P pin carries the level, N its
complement (the ECP5 PHY has the P pin only). The clocks are exact: tick ``j`` at ``j UI``;
the bit clock (``CLK`` / ``ECLK``, half the bit rate) rises at even ticks, the word clock
``clk`` at ticks ``j % W == 0`` (7-series 12-bit: ``clk_div`` at ``j % 6 == 0``), so sample
``m`` is taken at ``T0 + m UI`` as in :mod:`tdicam.model.lvds`. A drifting lane
(``drift_taps``, ``drift_from``, ``drift_words`` of :class:`tdicam.model.lvds.Lane`) has
the skew of the link model's drift for its bits of sender word ``n`` (the link model's
raw word ``n``: the two differ by the lane's word delay, a few words of a drift over
hundreds): ``skew - tap x floor(steps x clip((n - from) / words)) / 8`` (``steps`` = 8 x
``drift_taps`` rounded towards zero, the quotient too).

The sensor sends the link's schedule, walking-1/0 segments included (``"walk"``: the eye
status' check after lock).

What it must give (:func:`predict`)
-----------------------------------
With ``dcd`` and jitter 0 a lane's capture at tap ``t`` is the link model's with
``eye - dcd`` (the eye of the zeros) and the PHY's tap (:func:`tdicam.hdl.lvds_phy.tap_ps`):
every lane locks or fails as :func:`tdicam.model.lvds.train_lane` says, at its tap, with
its bitslip once the PHY's word phase (``c``: the raw words are samples ``(k - L) W + c``
..; the PHY's pipeline) is accounted for; a jittered lane's run may lose taps at the edges
of its eye (their captures are random), so its tap may be above the prediction by at most
the taps of the random band. Every locked lane delivers, from the data start, exactly the
words sent (the deskewed output: no word lost, repeated or changed); a lane with no eye
reports ``lane_error``. With the eye status (``eye``) every lane's published training is
the prediction's, the rule of :func:`eye_problems` (a jittered lane's pass mask free only
inside the random band). With tracking (``track``, ``xilinx7`` with 12-bit words) the
corrections are the golden tracker's (:mod:`tdicam.model.lvds_track`) for the drifting
lanes of the tests: count, final tap and each one's effect word (the pin drift's indexing
above may move a decision by one probe pair in other cases).
"""

import json
import math
import os
import shutil
import time
from dataclasses import dataclass, field, replace

import numpy as np

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.hdl.lvds import RUN_BITS, SLIP_BITS, TAP_BITS
from tdicam.hdl.lvds_phy import tap_ps
from tdicam.hw.verilog import convert
from tdicam.model import lvds
from tdicam.model.lvds_track import COUNT_BITS
from tdicam.cosim import ecp5_io, tbgen, xilinx7_io
from tdicam.cosim.build import build_sources, run_cocotb
from tdicam.cosim.lvds import (_BIASW, _NSCHED, _hex_lines, _link_functions, _parse, _ports,
                               _settings_args, sched_words)

__all__ = ["PinRun", "run_pins", "predict", "seen_link", "run_phase", "judged_phase",
           "band_taps", "band_mask", "eye_problems", "word_problems", "trained_tap", "ui_fs",
           "rate_for_ui", "PIN_PHYS", "WORD_PHASE"]

#: The PHYs simulated from pins: {phy: primitive model module}.
PIN_PHYS = {"xilinx7": xilinx7_io, "ecp5": ecp5_io}
#: The word phases of each PHY's deserializer (bits), {(phy, word_bits): phases}: the
#: PHY's raw words are samples ``(k - L) W + phase ..`` of the link model's sample
#: numbering, the same phase on every lane. The 7-series 12-bit path has two: its 2:1
#: fabric gearbox pairs the ``clk_div`` words at a free-running toggle whose phase against
#: the word clock is not set by anything (a board's start-up; Icarus gives 6, Verilator 0):
#: training's bitslip takes either.
WORD_PHASE = {("xilinx7", 10): (0,), ("xilinx7", 12): (6, 0), ("ecp5", 10): (1,),
              ("ecp5", 12): (1,)}
_RST = 4             # word clocks in reset at the start
_PRM = 12            # 64-bit parameters per lane


def ui_fs(rate_mbps):
    """The bit period in fs; the rate must give a whole number of them (within 0.001 fs)."""
    ui = 1e9 / float(rate_mbps)
    if abs(ui - round(ui)) > 1e-3:
        raise TdicamError(f"bit rate {rate_mbps} Mb/s is not a whole number of fs a bit "
                          f"({ui:.3f} fs); use rate_for_ui({round(ui)}) = "
                          f"{rate_for_ui(round(ui))!r} Mb/s")
    return int(round(ui))


def rate_for_ui(ui):
    """The bit rate (Mb/s) whose bit is ``ui`` fs (300 Mb/s: ``rate_for_ui(3333333)``)."""
    return 1e9 / int(ui)


@dataclass
class PinRun:
    """What the pin-level testbench reported: ``final`` per lane dict (tap, slip, locked,
    error, run, scan); ``outputs`` (k, sync, data[lanes]) of every deskewed output cycle;
    ``wall``, ``build_time`` (s); ``cycles`` (word clocks simulated); ``corrections``:
    ``(effect word, lane, new tap)`` of every tap change of a locked lane (the first raw
    word sampled with it: the cycle the tap shows + :data:`tdicam.model.lvds.LINK_LATENCY`,
    as :func:`tdicam.model.lvds.train_lane` lists a tracker's corrections)."""

    final: list
    outputs: tuple
    wall: float
    build_time: float
    cycles: int
    corrections: list = field(default_factory=list)


def _padded(expr, bits, digits):
    """Verilog of ``expr`` (``bits`` wide) zero-extended to ``digits`` hex digits."""
    pad = 4 * digits - bits
    return f"{{{pad}'b0, {expr}}}" if pad else expr


#: Hex digits of each lane's eye status in the testbench's status line (``eye``):
#: chosen tap, slip mask, walking-1/0 patterns, walk ok.
_EYE_DIGITS = [2, 3, 6, 1]


def _testbench(top, phy, w):
    n = top.lanes if phy == "none" else top.core.lanes
    core = top if phy == "none" else top.core
    eye, track = core.eye, core.track
    ins = {"lane_p", "lane_n", "clk_bit", "clk_ref", "clk_div", "clk_eclk", "retrain",
           "train_word", "sync_word", "n_check", "line_words"}
    ports = _ports(top)
    wires = "\n".join(f"  wire [{wd - 1}:0] d_{p};" for p, flow, wd in ports if flow == "Out")
    conns = ",\n".join(f"    .{p}({p if p in ins else 'd_' + p})" for p, _, _ in ports)
    out_fields = " ".join(["%h"] * n)
    out_args = ", ".join(f"d_o_data[{i * w} +: {w}]" for i in range(n))
    st_lines = []
    for i in range(n):
        fields = [f"8'd{i}", _padded(f"d_lane_tap_q[{i * TAP_BITS} +: {TAP_BITS}]", TAP_BITS, 2),
                  _padded(f"d_lane_slip[{i * SLIP_BITS} +: {SLIP_BITS}]", SLIP_BITS, 2),
                  _padded(f"d_lane_locked[{i}]", 1, 1), _padded(f"d_lane_error[{i}]", 1, 1),
                  _padded(f"d_lane_run[{i * RUN_BITS} +: {RUN_BITS}]", RUN_BITS, 2),
                  f"d_lane_scan[{i * 32} +: 32]"]
        if eye:
            fields += [_padded(f"d_lane_chosen_tap[{i * TAP_BITS} +: {TAP_BITS}]", TAP_BITS, 2),
                       _padded(f"d_lane_slip_pass[{i * w} +: {w}]", w, 3),
                       _padded(f"d_lane_walk[{2 * i * w} +: {2 * w}]", 2 * w, 6),
                       f"d_lane_walk_ok[{i}]"]
        if track:
            fields.append(f"d_lane_corrections[{i * COUNT_BITS} +: {COUNT_BITS}]")
        fmt = " ".join(["%h"] * len(fields))
        st_lines.append(f'        $fwrite(fd_st, "{fmt}\\n", {", ".join(fields)});')
    st_lines = "\n".join(st_lines)
    # every tap change of a locked lane (tracking): the first cycle showing the new tap
    tap_lines = "".join(
        f'      if (d_lane_locked[{i}] && lk_q[{i}] && '
        f'd_lane_tap_q[{i * TAP_BITS} +: {TAP_BITS}] != tap_q[{i * TAP_BITS} +: {TAP_BITS}])\n'
        f'        $fwrite(fd_tap, "%h %h %h\\n", k, 8\'d{i}, '
        f'{_padded(f"d_lane_tap_q[{i * TAP_BITS} +: {TAP_BITS}]", TAP_BITS, 2)});\n'
        for i in range(n))
    return f"""\
// Generated by tdicam: LVDS receiver pin-level testbench ({phy}). Not synthesizable.
`timescale 1fs/1fs
module {tbgen.TB_TOP};
  localparam N = {n};
  localparam W = {w};
  localparam BIASW = {_BIASW};
  reg signed [63:0] ui = 0, t0 = 0;
  // lane: skew, lo, hi, jitter, dcd (fs), jkey, dkey, 0, drift: from, words, steps, tap (fs)
  reg [63:0] prm [0:N*{_PRM}-1];
  reg [33:0] sched [0:{_NSCHED - 1}];    // {{walk, data, first sender word}}
  reg [31:0] n_sched = 0, cycles = 0, v_train = 0, v_sync = 0, v_ncheck = 0, v_line = 0;
  reg [W-1:0] train_word = 0, sync_word = 0;
  reg [7:0] n_check = 0;
  reg [15:0] line_words = 0;
  reg retrain = 1'b0;
  reg start = 1'b0, done = 1'b0, ready = 1'b0;
  // the clocks' levels at tick 0 (the first edges come at ticks 1 and later)
  reg clk = 1'b1, clk_bit = 1'b1, clk_div = 1'b1, clk_ref = 1'b0, clk_eclk = 1'b1;
  reg rst = 1'b1;
  reg [N-1:0] lane_p = 0, lane_n = {{N{{1'b1}}}};
  integer fd_st, fd_out, fd_tap;
  reg [31:0] k = 0;
  reg [63:0] j = 0;
{_link_functions(_NSCHED, walk=True)}
  initial begin
    if (!$value$plusargs("ui=%d", ui)) ui = 3333333;
    if (!$value$plusargs("cycles=%d", cycles)) cycles = 1000;
    if (!$value$plusargs("n_sched=%d", n_sched)) n_sched = 0;
{_settings_args('    ')}    $readmemh("pins.hex", prm);
    if (n_sched != 0) $readmemh("sched.hex", sched);
    fd_st = $fopen("status.hex", "w");
    fd_tap = $fopen("taps.hex", "w");
    fd_out = $fopen("out.hex", "w");
    t0 = ({_RST} + 1) * W * ui;     // word clock edges at ticks W, 2W, ..: reset for {_RST}
    ready = 1'b1;
    // the clocks: tick j at j UI
    forever begin
      #(ui);
      j = j + 1;
      clk_bit = (j % 2 == 0);
      clk_eclk = (j % 2 == 0);
      clk_div = (j % 6) < 3;
      clk = (j % W) < W / 2;
    end
  end
  always #2500000 clk_ref = ~clk_ref;

  genvar gi;
  generate
    for (gi = 0; gi < N; gi = gi + 1) begin : ln
      reg signed [63:0] sk, lo, hi, jt, dc, base, ts, te, now, jl, jr, hd;
      reg signed [63:0] df, dw, d8, tf, qd, dsh;
      reg [31:0] jk, dk, h, hz;
      reg [63:0] nbb;
      reg [W-1:0] wd;
      reg b;
      initial begin
        wait (ready);
        sk = prm[gi*{_PRM}]; lo = prm[gi*{_PRM}+1]; hi = prm[gi*{_PRM}+2];
        jt = prm[gi*{_PRM}+3]; dc = prm[gi*{_PRM}+4];
        jk = prm[gi*{_PRM}+5]; dk = prm[gi*{_PRM}+6];
        df = prm[gi*{_PRM}+8]; dw = prm[gi*{_PRM}+9]; d8 = prm[gi*{_PRM}+10];
        tf = prm[gi*{_PRM}+11];
        // first bit: the one whose eye is open at time 0 or later
        nbb = BIASW * W - (t0 + sk) / ui - 2;
        forever begin
          wd = sent(nbb / W, dk);
          b = wd[W - 1 - nbb % W];
          h = mix(nbb[31:0] ^ jk);
          hz = mix(nbb[31:0] ^ ~jk);
          // drift: the skew less steps x clip((word - from) / words) drift steps
          qd = $signed(nbb / W) - BIASW - df;
          if (qd < 0) qd = 0;
          if (qd > dw) qd = dw;
          dsh = (dw > 0) ? ((d8 * qd) / dw) * tf / {lvds.DRIFT_STEPS} : 0;
          base = t0 + sk - dsh + ($signed(nbb) - BIASW * W) * ui;
          // (every term a signed 64-bit register: no unsigned division of a negative)
          jl = (jt * $signed({{1'b0, h[31:16]}})) >>> 16;
          jr = (jt * $signed({{1'b0, h[15:0]}})) >>> 16;
          hd = b ? -(dc >>> 1) : (dc >>> 1);
          ts = base + lo + jl + hd;
          te = base + hi - jr - hd;
          now = $time;
          if (ts > now) #(ts - now);
          lane_p[gi] = b;
          lane_n[gi] = !b;
          now = $time;
          if (te > now) #(te - now);
          lane_p[gi] = hz[0];
          lane_n[gi] = !hz[0];
          nbb = nbb + 1;
        end
      end
    end
  endgenerate

  wire [N*{TAP_BITS}-1:0] d_lane_tap_q;
{wires}

  lvds dut (
    .clk(clk),
    .rst(rst),
{conns}
  );

  // the lanes' taps: the core's, whatever the PHY
  assign d_lane_tap_q = dut.{"" if phy == "none" else "core."}lane_tap;

  reg [7:0] rcnt = {_RST};
  reg [N*{TAP_BITS}-1:0] tap_q = 0;
  reg [N-1:0] lk_q = 0;
  always @(posedge clk) begin
    if (rcnt != 0) begin
      rcnt <= rcnt - 1;
      if (rcnt == 1) rst <= 1'b0;
    end else if (!done) begin
      tap_q <= d_lane_tap_q;
      lk_q <= d_lane_locked;
{tap_lines}      if (d_o_valid)
        $fwrite(fd_out, "%h %h {out_fields}\\n", k, {{3'b0, d_o_sync}}, {out_args});
      if (k + 1 == cycles) begin
{st_lines}
        $fclose(fd_st);
        $fclose(fd_out);
        $fclose(fd_tap);
        done <= 1'b1;
      end
      k <= k + 1;
    end
  end
endmodule
"""


def _lane_files(link, phy, dcd, ui):
    tap = tap_ps(phy)
    rows = []
    for i, lane in enumerate(link.lanes):
        if abs(lane.tap_ps - tap) > 1e-9:
            raise TdicamError(f"lane {i}: tap_ps = {lane.tap_ps} is not the {phy} PHY's tap "
                              f"({tap} ps)")
        if ui_fs(lane.bit_rate_mbps) != ui:
            raise TdicamError(f"lane {i}: every lane of a pin-level run has one bit rate")
        d = int(round(dcd[i] * 1000)) // 2 * 2
        eye = int(round(lane.eye_ps * 1000))
        if d < 0 or eye + d > ui or d > eye and eye > 0:
            raise TdicamError(f"lane {i}: dcd = {dcd[i]} ps must be in 0..eye_ps and "
                              f"eye_ps + dcd <= UI")
        jkey, dkey = lvds._keys(lane)
        lo, hi = (ui - eye) // 2, (ui - eye) // 2 + eye
        steps = int(math.copysign(math.floor(lvds.DRIFT_STEPS * abs(lane.drift_taps)),
                                  lane.drift_taps))
        drift = [lane.drift_from, lane.drift_words, steps, int(round(tap * 1000))]
        rows.append([int(round(lane.skew_ps * 1000)), lo, hi,
                     int(round(lane.jitter_ps * 1000)), d, jkey, dkey, 0] + drift)
        if lane.change_at is not None:
            raise TdicamError(f"lane {i}: a lane that changes (change_at) is not simulated "
                              f"from pins")
    prm = np.array(rows, dtype=np.int64).reshape(-1).astype(np.uint64)
    files = {"pins.hex": _hex_lines([prm], [16])}
    if link.schedule:
        files["sched.hex"] = _hex_lines([sched_words(link.schedule)], [9])
    return files


def run_pins(link, phy, *, dcd=None, params=None, cycles, n_check=16, sim="icarus",
             eye=False, track=0, keep=False):
    """Simulate ``link`` (one lane per receiver lane) through the generated ``lvds``
    receiver with ``phy`` from its pins (see the module docstring).

    ``dcd``: per-lane duty-cycle distortion (ps), default 0; ``params``: block parameters;
    ``eye``: the receiver with the eye-status ports (:func:`tdicam.hdl.lvds.eye_ports`):
    each lane's ``final`` gains ``chosen_tap``, ``slip_pass``, ``walk`` and ``walk_ok``
    (the link's schedule may send the walking-1/0 patterns: a ``"walk"`` segment);
    ``track`` > 0: the receiver tracks the eyes with that probe margin (``xilinx7`` with
    12-bit words: its monitor sampler in the N pin), each lane's ``final`` gains
    ``corrections`` (the tracker's counter). Returns a :class:`PinRun`.
    """
    if phy not in PIN_PHYS:
        raise TdicamError(f"phy = {phy} is not simulated from pins; valid: "
                          f"{', '.join(PIN_PHYS)}")
    if link.payload or len(link.schedule) > _NSCHED:
        raise TdicamError(f"a pin-level run takes the link model's own data and at most "
                          f"{_NSCHED} schedule entries")
    blk = blocks.get("lvds")
    params = blk.resolve(dict(params or {}, phy=phy, lanes=len(link.lanes),
                              word_bits=link.word_bits, **({"eye": 1} if eye else {}),
                              **({"track": int(track)} if track else {})))
    dcd = tuple(dcd) if dcd is not None else (0.0,) * len(link.lanes)
    ui = ui_fs(link.lanes[0].bit_rate_mbps)
    files = _lane_files(link, phy, dcd, ui)
    top = blk.build(params)
    dut = convert(top, "lvds")
    tb = _testbench(top, phy, link.word_bits)
    mod = PIN_PHYS[phy]
    bdir, build_time = build_sources("lvds_pins", params, sim,
                                     {mod.FILE: mod.MODEL, "lvds.v": dut, "tb.v": tb})
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    for name, text in files.items():
        (rundir / name).write_bytes(text)
    plusargs = [f"+ui={ui}", f"+cycles={int(cycles)}", f"+n_sched={len(link.schedule)}",
                f"+train_word={link.train_word}", f"+sync_word={link.sync_word}",
                f"+n_check={n_check}", f"+line_words={link.line_words}"]
    (rundir / "job.json").write_text(json.dumps({"groups": 1, "cycles": int(cycles)}))
    ok, wall = run_cocotb(bdir, sim, "lvds_tb", rundir, plusargs)
    if not ok or not (rundir / "status.hex").exists():
        raise TdicamError(f"{sim} pin-level simulation of lvds --phy {phy} failed; see "
                          f"{rundir / 'sim.log'}")
    n, wd = len(link.lanes), -(-link.word_bits // 4)
    names = ["tap", "slip", "locked", "error", "run", "scan"]
    digits = [2, 2, 2, 1, 1, 2, 8]
    if eye:
        names += ["chosen_tap", "slip_pass", "walk", "walk_ok"]
        digits += _EYE_DIGITS
    if track:
        names.append("corrections")
        digits.append(-(-COUNT_BITS // 4))
    st = _parse((rundir / "status.hex").read_bytes(), digits)
    final = [None] * n
    for lane, *vals in zip(*(a.astype(np.int64).tolist() for a in st)):
        final[lane] = dict(zip(names, vals))
    out = _parse((rundir / "out.hex").read_bytes(), [8, 1] + [wd] * n)
    outputs = (out[0].astype(np.int64), out[1].astype(bool),
               np.stack(out[2:], axis=1).astype(np.int64) if n else np.zeros((0, 0)))
    taps = _parse((rundir / "taps.hex").read_bytes(), [8, 2, 2])
    corrections = [(k + lvds.LINK_LATENCY, lane, t)
                   for k, lane, t in zip(*(a.astype(np.int64).tolist() for a in taps))]
    if not keep:
        shutil.rmtree(rundir, ignore_errors=True)
    return PinRun(final, outputs, wall, build_time, int(cycles), corrections)


def predict(link, phy, *, dcd=None, word_phase=0, jitter=True, n_check=16, settle=8,
            min_run=9, pick=5, eye=False, k_stop=None, track=0):
    """The golden outcome of each lane of a pin-level run: a list of
    :class:`tdicam.model.lvds.LaneResult` of :func:`tdicam.model.lvds.train_lane` on the
    lane seen through the PHY: its eye less ``dcd``, its samples shifted by the PHY's word
    phase ``word_phase`` (bits; the PHY's words are samples ``(k - L) W + word_phase`` ..;
    :data:`WORD_PHASE`); ``jitter=False``: as if the lanes had none. ``eye``, ``k_stop``:
    the receiver with the eye status, judged until cycle ``k_stop`` (the run's cycles: the
    ``walk`` it records; the ECP5 PHY trains later than the golden step count, which
    changes no status as long as the lanes lock before the walking patterns come);
    ``track``: with eye tracking of that margin (:mod:`tdicam.model.lvds_track`)."""
    eq = seen_link(link, dcd=dcd, word_phase=word_phase, jitter=jitter)
    return [lvds.train_lane(eq, i, 0, n_check=n_check, settle=settle, min_run=min_run,
                            pick=pick, eye=eye, k_stop=k_stop, track=track)
            for i in range(len(eq.lanes))]


def seen_link(link, *, dcd=None, word_phase=0, jitter=True):
    """``link`` as the PHY's deserializer sees it (:func:`predict`): each lane's eye less its
    ``dcd``, its samples shifted by the PHY's ``word_phase``; ``jitter=False``: none. Its
    port cycle ``k`` is the PHY's."""
    dcd = tuple(dcd) if dcd is not None else (0.0,) * len(link.lanes)
    w = link.word_bits
    lanes = []
    for lane, d in zip(link.lanes, dcd):
        shift = ((w - word_phase) % w) * lane.ui_ps
        lanes.append(replace(lane, eye_ps=max(lane.eye_ps - d, 0.0),
                             skew_ps=lane.skew_ps + shift,
                             jitter_ps=lane.jitter_ps if jitter else 0.0))
    return replace(link, lanes=tuple(lanes))


def run_phase(link, phy, run, *, dcd=None, n_check=16):
    """The word phase (:data:`WORD_PHASE`) of ``phy`` under which every locked lane of
    ``run`` has the predicted bitslip (the first such), or None."""
    for phase in WORD_PHASE[phy, link.word_bits]:
        pred = predict(link, phy, dcd=dcd, word_phase=phase, jitter=False, n_check=n_check)
        if all(p.slip == f["slip"] for p, f in zip(pred, run.final) if f["locked"]):
            return phase
    return None


def judged_phase(link, phy, run, *, dcd=None, n_check=16):
    """The word phase ``run`` is judged at: :func:`run_phase`'s, else the PHY's first (the
    slips then show as the run's problems)."""
    phase = run_phase(link, phy, run, dcd=dcd, n_check=n_check)
    return WORD_PHASE[phy, link.word_bits][0] if phase is None else phase


def band_taps(lane):
    """Taps of the random band at each edge of ``lane``'s eye (its jitter in taps, rounded
    up): how far below the jitter-free prediction a jittered lane's tap may be."""
    return math.ceil(lane.jitter_ps / lane.tap_ps) if lane.jitter_ps else 0


def band_mask(scan, band):
    """The taps of ``scan`` (a pass mask) within ``band`` taps of either end of one of its
    runs of consecutive passing taps."""
    out, t = 0, 0
    while t < lvds.N_TAPS:
        if not scan >> t & 1:
            t += 1
            continue
        end = t
        while end < lvds.N_TAPS and scan >> end & 1:
            end += 1
        for u in range(t, end):
            if u < t + band or u >= end - band:
                out |= 1 << u
        t = end
    return out


def eye_problems(link, phy, run, *, dcd=None, n_check=16, settle=8, min_run=9, pick=5,
                 track=0, pred=None):
    """What differs between a pin-level run with the eye status (:func:`run_pins` ``eye``)
    and the golden link model (empty: every lane as predicted).

    The prediction is :func:`predict` for ``phy`` (its tap size, its word phase in the run:
    :func:`run_phase`, the eye less ``dcd``) without jitter, judged over the run's cycles.
    The rule, lane by lane (``b`` = :func:`band_taps`, 0 without jitter):

    * pass mask (``scan``): equal to the predicted one except, on a jittered lane, at the
      taps within ``b`` taps of either end of a predicted run (inside it: the random band,
      where the lane's random eye edges make a tap fail or pass); outside a predicted run
      no tap passes, since jitter only narrows the pin-level eye;
    * eye width (``run``) and chosen tap (``tap`` and ``chosen_tap``): what the golden
      decision (:func:`tdicam.model.lvds.decide`) makes of the mask the lane reported (with
      ``b = 0``: the predicted ones; 0 for a lane that never locked; a lane in error after
      its lock keeps its tap), moved by the predicted corrections with tracking (``track``:
      the ports show the tap at the end);
    * ``locked``, ``error``, ``slip``, ``slip_pass``, ``walk`` equal to the prediction;
      ``walk_ok`` = ``walk`` has all ``2 W`` patterns. A lane with no eye must report
      ``error`` (its eye width below ``min_run``, tap, slip and masks 0).

    ``pred``: the per-lane predictions to judge against instead (each with ``eye``; e.g.
    the tie of an eye edge on a tap's sample that agrees with the run,
    :func:`tdicam.chain.phy_check.judge`).
    """
    w = link.word_bits
    if pred is None:
        phase = judged_phase(link, phy, run, dcd=dcd, n_check=n_check)
        pred = predict(link, phy, dcd=dcd, word_phase=phase, jitter=False,
                       n_check=n_check, settle=settle, min_run=min_run, pick=pick, eye=True,
                       k_stop=run.cycles, track=track)
    full = (1 << 2 * w) - 1
    problems = []
    for i, (lane, p, f) in enumerate(zip(link.lanes, pred, run.final)):
        b = band_taps(lane)
        free = band_mask(p.scan_mask, b)
        if (f["scan"] ^ p.scan_mask) & ~free:
            problems.append(f"lane {i}: pass mask {f['scan']:#010x}, predicted "
                            f"{p.scan_mask:#010x} (random band {free:#010x})")
        mask = [f["scan"] >> t & 1 for t in range(lvds.N_TAPS)]
        _, run_len, tap = lvds.decide(mask, p.words, min_run=min_run, pick=pick)
        if p.lock_k is None or tap is None:
            tap = 0
        else:
            tap += p.tap - trained_tap(p)
        exp = {"locked": int(p.locked), "error": int(p.error), "run": run_len,
               "tap": tap, "chosen_tap": tap,
               "slip": p.slip, "slip_pass": p.slip_pass, "walk": p.walk,
               "walk_ok": int(p.walk == full)}
        bad = {k: (f[k], v) for k, v in exp.items() if f[k] != v}
        if bad:
            problems.append(f"lane {i}: " + ", ".join(f"{k} {got} (predicted {v})"
                                                     for k, (got, v) in bad.items()))
        if lane.eye_ps == 0 and not (f["error"] and not f["locked"]):
            problems.append(f"lane {i}: no eye, and no error reported")
    return problems


def trained_tap(p):
    """The tap training chose for a :class:`tdicam.model.lvds.LaneResult` ``p`` (its lock's;
    ``p.tap`` is the tap at the end, moved by tracking), None when it never locked."""
    return next((ev[3] for ev in p.events if ev[1]), None)


def word_problems(link, run, nd, until=None):
    """``(mismatches, problems)`` of a pin-level run's delivered words (``run.outputs``),
    data from link word ``nd``: the receiver must deliver one run of consecutive words
    from the data start (else one mismatch and its problem line), and every locked lane
    the words :func:`tdicam.model.lvds.sent_words` sent (an unlocked lane 0s); each lane
    that differs a problem line with its count. ``until``: {lane: n}, a lane whose first
    ``n`` delivered words only are judged, as sent (a lane in error after its lock: its
    words up to its predicted first wrong one). ``(0, [])`` when all is as sent."""
    ks, syncs, data = run.outputs
    problems, mism = [], 0
    until = until or {}
    if len(ks) == 0 or not syncs[0] or not np.array_equal(ks, ks[0] + np.arange(len(ks))):
        problems.append("the receiver delivered no run of consecutive words from the data "
                        "start")
        mism += 1
    for i, f in enumerate(run.final):
        n = min(max(until.get(i, len(ks)), 0), len(ks))
        exp = lvds.sent_words(link, i, nd + np.arange(n)) if f["locked"] or i in until \
            else 0
        bad = int(np.count_nonzero(data[:n, i] != exp)) if n else 0
        if bad:
            problems.append(f"lane {i}: {bad} words differ from those sent")
        mism += bad
    return mism, problems
