"""Co-simulation of the ``lvds`` receiver against the link model and the golden training model.

The receiver is not a video stream, so it has its own HDL testbench (generated here, built
and run through :func:`tdicam.cosim.build_sources` / :func:`tdicam.cosim.run_cocotb`, cocotb
module :mod:`tdicam.simtb.lvds_tb`). Python stays out of the per-cycle loop:

* the *link* is evaluated in the testbench from the link model's per-lane tables
  (:func:`tdicam.model.lvds.lane_tables`: bit delay and capture-failure threshold per tap and
  epoch) and the model's counter-based hashes, for the tap the DUT loaded (``lane_ld``) two
  word clocks earlier, exactly as :func:`tdicam.model.lvds.raw_words` defines it. A full
  (tap, bitslip, word) table would need 32 x W x words entries per lane (about 4 M per lane
  for 10^4 words); the tables are 64 entries per lane. :func:`run_link` with
  ``linkcheck=True`` makes the testbench drive the taps itself and dump every raw word, which
  the tests compare with the Python model word for word;
* many lanes are simulated in groups of the DUT's lane count, one simulator run: the
  testbench resets the DUT between groups;
* the testbench writes status changes (``events.hex``), the final status of every lane
  (``status.hex``, ``global.hex``) and every deskewed output word (``out.hex``).

:func:`check_run` compares all of it with :func:`tdicam.model.lvds.run` and the sent words.
"""

import json
import os
import shutil
import time
from dataclasses import dataclass

import numpy as np
from amaranth.hdl import Shape

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.hdl.lvds import RUN_BITS, SLIP_BITS, TAP_BITS
from tdicam.model import lvds
from tdicam.hw.verilog import convert
from tdicam.cosim import tbgen
from tdicam.cosim.build import build_sources, run_cocotb
from tdicam.cosim.codec import _digits, _undigits

__all__ = ["LinkRun", "run_link", "run_amaranth", "check_run", "expected_outputs", "testbench", "LMAX",
           "linkcheck_tap", "link_files", "dead_lane", "sched_words"]

LMAX = 1024          # lanes the testbench tables hold (all groups of one run)
_NSCHED = 8
_NRETRAIN = 8
_BIASW = 256         # sender word bias keeping indices positive in the testbench
_RST_CYCLES = tbgen.RST_CYCLES


def _settings_args(indent):
    """Verilog statements reading the receiver's run-time settings from the plusargs
    (``+train_word=``, ``+sync_word=``, ``+n_check=``, ``+line_words=``) into their registers."""
    lines = ['if (!$value$plusargs("train_word=%d", v_train)) v_train = 0;',
             'if (!$value$plusargs("sync_word=%d", v_sync)) v_sync = 0;',
             'if (!$value$plusargs("n_check=%d", v_ncheck)) v_ncheck = 1;',
             'if (!$value$plusargs("line_words=%d", v_line)) v_line = 2;',
             "train_word = v_train[W-1:0];", "sync_word = v_sync[W-1:0];",
             "n_check = v_ncheck[7:0];", "line_words = v_line[15:0];"]
    return "".join(f"{indent}{line}\n" for line in lines)


def _link_functions(nsched, walk=False):
    """Verilog of the testbench functions ``mix`` (the link model's hash) and ``sent`` (the
    word the sensor sends, from the schedule registers ``sched``/``n_sched`` and the run-time
    words), shared by the word-level and the pin-level testbenches. ``walk``: the schedule
    entries are 34 bits (:func:`sched_words`) and a
    walk segment sends the walking-1/0 patterns (:func:`tdicam.model.lvds.walk_words`)."""
    text = _LINK_FUNCTIONS.replace("%NSCHED%", str(nsched))
    for old, new in _WALK if walk else ():
        assert old in text
        text = text.replace(old, new)
    return text


def sched_words(schedule):
    """The schedule entries of a walk-capable testbench (:func:`_link_functions` with
    ``walk``) for a link's ``schedule``: ``{walk, data, first sender word}`` (uint64)."""
    return np.array([(int(m == "walk") << 33) | (int(m == "data") << 32) | s
                     for s, m in schedule], np.uint64)


_LINK_FUNCTIONS = """  function [31:0] mix(input [31:0] x);
    reg [31:0] y;
    begin
      y = x ^ (x >> 16);
      y = y * 32'h7feb352d;
      y = y ^ (y >> 15);
      y = y * 32'h846ca68b;
      mix = y ^ (y >> 16);
    end
  endfunction

  // word the sensor sends at biased sender index nb (sender word nb - BIASW)
  function [W-1:0] sent(input [31:0] nb, input [31:0] dkey);
    integer q;
    reg isd;
    reg [31:0] st, d;
    begin
      isd = 1'b0;
      st = 0;
      for (q = 0; q < %NSCHED%; q = q + 1)
        if (q < n_sched && nb >= sched[q][31:0] + BIASW) begin
          isd = sched[q][32];
          st = sched[q][31:0] + BIASW;
        end
      if (!isd)
        sent = train_word;
      else if ((nb - st) % {16'd0, line_words} == 0)
        sent = sync_word;
      else begin
        d = mix((nb - BIASW) ^ dkey);
        sent = d[W-1:0];
        if (sent == sync_word) sent = sent ^ 1;
      end
    end
  endfunction

"""

#: (text, with walk segments) pairs turning ``sent`` into its walk-capable form.
_WALK = (
    ("    reg isd;\n", "    reg isd, iswk;\n"),
    ("      isd = 1'b0;\n", "      isd = 1'b0;\n      iswk = 1'b0;\n"),
    ("          isd = sched[q][32];\n",
     "          isd = sched[q][32];\n          iswk = sched[q][33];\n"),
    ("      if (!isd)\n        sent = train_word;\n",
     "      if (iswk) begin\n"
     "        q = (nb - st) % (2 * W);\n"
     "        sent = (q < W) ? ({{(W-1){1'b0}}, 1'b1} << (W - 1 - q))\n"
     "                       : ~({{(W-1){1'b0}}, 1'b1} << (2 * W - 1 - q));\n"
     "      end else if (!isd)\n        sent = train_word;\n"),
)


def linkcheck_tap(k, lane):
    """Tap the testbench drives on ``lane`` at cycle ``k`` in link-check mode."""
    return ((np.asarray(k) >> 2) * 5 + lane * 11) & 31


def _ports(top):
    return [(name, member.flow.name, Shape.cast(member.shape).width)
            for name, member in top.signature.members.items()]


@dataclass(frozen=True)
class TbParts:
    """The parts a variant adds to the link testbench (:func:`testbench`): its ``title``,
    the lane-table size ``lmax`` (None: :data:`LMAX`), declarations before the random
    functions (``decls``), per-lane logic in the lane generate block (``lane``), statements
    when the run starts (``start``) and when it moves to the next group (``next_group``),
    and module-level logic before ``endmodule`` (``body``)."""

    title: str = "co-simulation"
    lmax: int | None = None
    decls: str = ""
    lane: str = ""
    start: str = ""
    next_group: str = ""
    body: str = ""


def testbench(top, *, name="lvds", parts=None):
    """Verilog text of the testbench around module ``name`` (an :class:`LvdsRx`) and the
    digit count of its lane masks.

    ``parts`` (:class:`TbParts`) adds what a variant of the same testbench needs (the
    self-checking one of ``tdicam export``); None: the co-simulation testbench.
    """
    h = parts or TbParts()
    n, w = top.lanes, top.word_bits
    conns = []
    for pname, flow, width in _ports(top):
        if pname == "lane_raw":
            conns.append("    .lane_raw(lane_raw),")
        elif pname == "retrain":
            conns.append("    .retrain(retrain),")
        elif pname in ("train_word", "sync_word", "n_check", "line_words"):
            conns.append(f"    .{pname}({pname}),")
        else:
            conns.append(f"    .{pname}(d_{pname}),")
    wires = "\n".join(f"  wire [{width - 1}:0] d_{pname};" for pname, flow, width in _ports(top)
                      if flow == "Out")
    conns = "\n".join(conns)
    out_fields = " ".join(["%h"] * n)
    out_args = ", ".join(f"d_o_data[{i * w} +: {w}]" for i in range(n))
    st_lines = "\n".join(
        f'        $fwrite(fd_st, "%h %h %h %h %h %h %h %h\\n", g[15:0], 8\'d{i}, '
        f'{{{8 - TAP_BITS}\'b0, d_lane_tap[{i * TAP_BITS} +: {TAP_BITS}]}}, '
        f'{{{8 - SLIP_BITS}\'b0, d_lane_slip[{i * SLIP_BITS} +: {SLIP_BITS}]}}, '
        f'{{3\'b0, d_lane_locked[{i}]}}, {{3\'b0, d_lane_error[{i}]}}, '
        f'{{2\'b0, d_lane_run[{i * 6} +: 6]}}, d_lane_scan[{i * 32} +: 32]);'
        for i in range(n))
    raw_args = ", ".join(f"lane_raw[{i * w} +: {w}]" for i in range(n))
    mask_digits = -(-n // 4)
    return f"""\
// Generated by tdicam: LVDS receiver {h.title} testbench. Not synthesizable.
`timescale 1ns/1ps
module {tbgen.TB_TOP};
  localparam N = {n};
  localparam W = {w};
  localparam LMAX = {LMAX if h.lmax is None else h.lmax};
  localparam BIASW = {_BIASW};
  localparam RST_CYCLES = {_RST_CYCLES};

  reg clk = 1'b0;
  always #5 clk = ~clk;

  reg start = 1'b0;
  reg done = 1'b0;
  reg running = 1'b0;
  reg [24:0] tab [0:LMAX*64-1];   // (lane, epoch, tap): {{delay[7:0], thresh[16:0]}}
  reg [95:0] info [0:LMAX-1];     // lane: {{change_at, dkey, jkey}}
  reg [32:0] sched [0:{_NSCHED - 1}];       // {{is_data, first sender word}}
  reg [31:0] rt_at [0:{_NRETRAIN - 1}];     // retrain request cycles
  reg [31:0] n_sched = 0, n_rt = 0, groups = 0, cycles = 0, linkcheck = 0;
  reg [31:0] v_train = 0, v_sync = 0, v_ncheck = 0, v_line = 0;
  reg [W-1:0] train_word = 0, sync_word = 0;
  reg [7:0] n_check = 0;
  reg [15:0] line_words = 0;
  integer fd_ev, fd_st, fd_gl, fd_out;
  integer j;
  reg [31:0] g = 0;
  reg [31:0] k = 0;
  reg rst = 1'b1;
  reg [3:0] rcnt = 0;

{h.decls}{_link_functions(_NSCHED)}  function is_retrain(input [31:0] kk);
    integer q;
    begin
      is_retrain = 1'b0;
      for (q = 0; q < {_NRETRAIN}; q = q + 1)
        if (q < n_rt && rt_at[q] == kk) is_retrain = 1'b1;
    end
  endfunction

  wire live = running && !rst;
  wire retrain = live && linkcheck == 0 && is_retrain(k);
  wire [N*W-1:0] lane_raw;
{wires}

  lvds dut (
    .clk(clk),
    .rst(rst),
{conns[:-1]}
  );

  genvar gi;
  generate
    for (gi = 0; gi < N; gi = gi + 1) begin : ln
      wire [31:0] li = g * N + gi;
      reg [{TAP_BITS - 1}:0] tapq = {TAP_BITS}'d0, tap2 = {TAP_BITS}'d0;
      reg pl = 1'b0, pe = 1'b0;
      wire [{TAP_BITS - 1}:0] tap_src = (linkcheck != 0) ? ((((k >> 2) * 5) + gi * 11) & 31)
                                            : d_lane_tap[gi*{TAP_BITS} +: {TAP_BITS}];
      wire ld_src = (linkcheck != 0) ? 1'b1 : d_lane_ld[gi];
      wire [95:0] inf = info[li];
      wire ep = (k >= inf[95:64]);
      wire [24:0] ent = tab[li * 64 + ep * 32 + tap2];
      reg [W-1:0] raw;
      reg [31:0] h, base, n0b, pos;
      reg [W-1:0] w0, w1;
      reg [2*W-1:0] both;
      integer i;
      // evaluated once per change of cycle, tap or group (an @* block would also wake on
      // its own temporaries in Icarus)
      always @(k or tap2 or g or rst or start) begin
        base = k * W + BIASW * W - ent[24:17];  // biased index of the bit sample k*W sees
        n0b = base / W;
        pos = base - n0b * W;
        w0 = sent(n0b, inf[63:32]);
        w1 = sent(n0b + 1, inf[63:32]);
        both = {{w0, w1}} << pos;
        for (i = 0; i < W; i = i + 1) begin
          h = mix((k * W + i) ^ inf[31:0]);
          raw[W-1-i] = ({{1'b0, h[31:16]}} < ent[16:0]) ? h[0] : both[2*W-1-i];
        end
      end
      assign lane_raw[gi*W +: W] = raw;
{h.lane}      always @(posedge clk) begin
        if (rst) begin
          tapq <= {TAP_BITS}'d0;
          tap2 <= {TAP_BITS}'d0;
          pl <= 1'b0;
          pe <= 1'b0;
        end else if (running) begin
          if (ld_src) tapq <= tap_src;
          tap2 <= tapq;
          pl <= d_lane_locked[gi];
          pe <= d_lane_error[gi];
          if (linkcheck == 0 && {{pl, pe}} != {{d_lane_locked[gi], d_lane_error[gi]}})
            $fwrite(fd_ev, "%h %h %h %h %h %h %h %h\\n", g[15:0], k, li[15:0],
                    {{3'b0, d_lane_locked[gi]}}, {{3'b0, d_lane_error[gi]}},
                    {{{8 - TAP_BITS}'b0, d_lane_tap[gi*{TAP_BITS} +: {TAP_BITS}]}},
                    {{{8 - SLIP_BITS}'b0, d_lane_slip[gi*{SLIP_BITS} +: {SLIP_BITS}]}},
                    {{2'b0, d_lane_run[gi*6 +: 6]}});
        end
      end
    end
  endgenerate

  always @(posedge clk) begin
    if (start && !running && !done) begin
      if (!$value$plusargs("groups=%d", groups)) groups = 1;
      if (!$value$plusargs("cycles=%d", cycles)) cycles = 1000;
      if (!$value$plusargs("linkcheck=%d", linkcheck)) linkcheck = 0;
      if (!$value$plusargs("n_sched=%d", n_sched)) n_sched = 0;
      if (!$value$plusargs("n_rt=%d", n_rt)) n_rt = 0;
{_settings_args('      ')}      $readmemh("tab.hex", tab);
      $readmemh("info.hex", info);
      if (n_sched != 0) $readmemh("sched.hex", sched);
      if (n_rt != 0) $readmemh("retrain.hex", rt_at);
      fd_ev = $fopen("events.hex", "w");
      fd_st = $fopen("status.hex", "w");
      fd_gl = $fopen("global.hex", "w");
      fd_out = $fopen("out.hex", "w");
{h.start}      g <= 0;
      k <= 0;
      rst <= 1'b1;
      rcnt <= RST_CYCLES;
      running <= 1'b1;
    end else if (running) begin
      if (rcnt != 0) begin
        rcnt <= rcnt - 1;
        if (rcnt == 1) rst <= 1'b0;
      end else begin
        if (linkcheck != 0)
          $fwrite(fd_out, "%h %h 0 {out_fields}\\n", g[15:0], k, {raw_args});
        else if (d_o_valid)
          $fwrite(fd_out, "%h %h %h {out_fields}\\n", g[15:0], k, {{3'b0, d_o_sync}},
                  {out_args});
        if (k + 1 == cycles) begin
{st_lines}
          $fwrite(fd_gl, "%h %h %h %h %h %h %h\\n", g[15:0], {{3'b0, d_all_locked}},
                  {{3'b0, d_trained}}, {{3'b0, d_deskew_error}}, {{3'b0, d_aligned}},
                  {{3'b0, d_o_valid}}, d_lane_mask);
          k <= 0;
          if (g + 1 == groups) begin
            $fclose(fd_ev);
            $fclose(fd_st);
            $fclose(fd_gl);
            $fclose(fd_out);
            running <= 1'b0;
            done <= 1'b1;
          end else begin
            g <= g + 1;
{h.next_group}            rst <= 1'b1;
            rcnt <= RST_CYCLES;
          end
        end else
          k <= k + 1;
      end
    end
  end
{h.body}endmodule
""", mask_digits


@dataclass
class LinkRun:
    """What the testbench reported for every lane of a :class:`~tdicam.model.lvds.Link`.

    ``events``: (k, lane, locked, error, tap, slip, run) sorted by (k, lane), lane = index in
    the link; ``final``: per lane dict (tap, slip, locked, error, run, scan); ``globals``:
    per group dict (all_locked, trained, deskew_error, aligned, mask); ``outputs``: per group
    (k, sync, data[N]) arrays of every deskewed output cycle (link-check: raw words);
    ``groups``, ``lanes`` (DUT lanes per group); ``wall``, ``build_time``, ``cycles`` (DUT
    cycles simulated over all groups).
    """

    events: list
    final: list
    globals: list
    outputs: list
    groups: int
    lanes: int
    wall: float
    build_time: float
    cycles: int


def _hex_lines(values, digits):
    cols = [_digits(np.asarray(v, dtype=np.uint64), d) for v, d in zip(values, digits)]
    cols.append(np.full((len(cols[0]), 1), ord("\n"), np.uint8))
    return np.concatenate(cols, axis=1).tobytes()


def _parse(text, widths):
    """Fixed-width hex fields separated by single spaces, one record per line."""
    raw = np.frombuffer(text, dtype=np.uint8)
    line = sum(widths) + len(widths)
    if raw.size % line:
        raise TdicamError(f"simulator output is malformed: {raw.size} bytes is not a multiple "
                          f"of the {line}-byte line")
    rows = raw.reshape(-1, line)
    out, pos = [], 0
    for wd in widths:
        out.append(_undigits(rows[:, pos:pos + wd]) if len(rows) else np.zeros(0, np.uint64))
        pos += wd + 1
    return out


def link_files(lanes, link, retrains=()):
    """{file name: bytes} of the link the testbench evaluates: ``tab.hex`` (per lane, epoch
    and tap: bit delay and capture-failure threshold of :func:`tdicam.model.lvds.
    lane_tables`), ``info.hex`` (per lane: change word, data and jitter keys), and with a
    schedule / retrains ``sched.hex`` / ``retrain.hex``. ``lanes``: the link's lanes,
    padded to whole groups."""
    delay = np.zeros((len(lanes), 2, lvds.N_TAPS), np.uint64)
    thresh = np.zeros_like(delay)
    info = np.zeros((len(lanes), 3), np.uint64)
    for i, lane in enumerate(lanes):
        d, r = lvds.lane_tables(lane)
        if d.max() > 255 - 2 * link.word_bits:
            raise TdicamError(f"lane {i}: skew {lane.skew_ps} ps is beyond the testbench's "
                              f"255-bit delay range")
        delay[i], thresh[i] = d, r
        jkey, dkey = lvds._keys(lane)
        info[i] = (jkey, dkey, 0xFFFFFFFF if lane.change_at is None else lane.change_at)
    tab = (delay.reshape(-1) << np.uint64(17)) | thresh.reshape(-1)
    files = {"tab.hex": _hex_lines([tab], [7]),
             "info.hex": _hex_lines([info[:, 2], info[:, 1], info[:, 0]], [8, 8, 8])}
    if link.schedule:
        sched = np.array([(int(m == "data") << 32) | s for s, m in link.schedule], np.uint64)
        files["sched.hex"] = _hex_lines([sched], [9])
    if retrains:
        files["retrain.hex"] = _hex_lines([np.array(sorted(retrains))], [8])
    return files


def dead_lane(seed):
    """A pad lane (no eye): what fills a group of lanes up."""
    return lvds.Lane(skew_ps=0.0, eye_ps=0.0, seed=seed)


def run_link(link, *, params=None, cycles, retrains=(), n_check=16, sim="verilator",
             linkcheck=False, keep=False):
    """Simulate every lane of ``link`` through the generated ``lvds`` Verilog.

    ``params``: block parameters (``lanes`` = DUT lanes per group, ``word_bits`` must equal the
    link's, ``settle`` ...). The link's lanes run ``lanes`` at a time (padded with dead lanes).
    """
    blk = blocks.get("lvds")
    params = blk.resolve(dict(params or {}, phy="none"))
    if params["word_bits"] != link.word_bits:
        raise TdicamError(f"link has {link.word_bits}-bit words, the receiver "
                          f"{params['word_bits']}")
    n = params["lanes"]
    n_link = len(link.lanes)
    groups = max(1, -(-n_link // n))
    if groups * n > LMAX:
        raise TdicamError(f"{n_link} lanes is more than one testbench run holds ({LMAX})")
    if link.payload:
        raise TdicamError("the lvds testbench's link sends the link model's own data, not a "
                          "payload; a link carrying frames runs in tdicam.cosim.lvds_front")
    if len(link.schedule) > _NSCHED or len(retrains) > _NRETRAIN:
        raise TdicamError(f"at most {_NSCHED} schedule entries and {_NRETRAIN} retrains")
    if not 0 <= n_check <= 255:
        raise TdicamError(f"n_check = {n_check} is out of range; valid: 0..255")
    lanes = list(link.lanes) + [dead_lane(10_000 + i) for i in range(groups * n - n_link)]
    top = blk.build(params)
    dut = convert(top, "lvds")
    tb, mask_digits = testbench(top)
    bdir, build_time = build_sources("lvds", params, sim, {"lvds.v": dut, "tb.v": tb})
    rundir = bdir / f"run-{os.getpid()}-{time.monotonic_ns()}"
    rundir.mkdir(parents=True)
    for name, text in link_files(lanes, link, retrains).items():
        (rundir / name).write_bytes(text)
    plusargs = [f"+groups={groups}", f"+cycles={int(cycles)}", f"+linkcheck={int(linkcheck)}",
                f"+n_sched={len(link.schedule)}", f"+n_rt={len(retrains)}",
                f"+train_word={link.train_word}", f"+sync_word={link.sync_word}",
                f"+n_check={n_check}", f"+line_words={link.line_words}"]
    (rundir / "job.json").write_text(json.dumps({"groups": groups, "cycles": int(cycles)}))
    ok, wall = run_cocotb(bdir, sim, "lvds_tb", rundir, plusargs)
    if not ok or not (rundir / "summary.json").exists():
        raise TdicamError(f"{sim} simulation of lvds failed; see {rundir / 'sim.log'}")
    wd = -(-link.word_bits // 4)
    ev = _parse((rundir / "events.hex").read_bytes(), [4, 8, 4, 1, 1, 2, 2, 2])
    events = sorted(zip(*(a.astype(np.int64).tolist() for a in ev[1:])),
                    key=lambda e: (e[0], e[1]))
    events = [e for e in events if e[1] < n_link]
    st = _parse((rundir / "status.hex").read_bytes(), [4, 2, 2, 2, 1, 1, 2, 8])
    final = [None] * n_link
    for grp, lane, tap, slip, lk, er, rn, scan in zip(*(a.astype(np.int64).tolist()
                                                         for a in st)):
        li = grp * n + lane
        if li < n_link:
            final[li] = {"tap": tap, "slip": slip, "locked": lk, "error": er, "run": rn,
                         "scan": scan}
    gl = _parse((rundir / "global.hex").read_bytes(), [4, 1, 1, 1, 1, 1, mask_digits])
    globals_ = [{"all_locked": int(a), "trained": int(b), "deskew_error": int(c),
                 "aligned": int(d), "o_valid": int(e), "mask": int(f)}
                for _, a, b, c, d, e, f in zip(*gl)]
    out = _parse((rundir / "out.hex").read_bytes(), [4, 8, 1] + [wd] * n)
    outputs = []
    for grp in range(groups):
        sel = out[0] == grp
        outputs.append((out[1][sel].astype(np.int64), out[2][sel].astype(bool),
                        np.stack([o[sel] for o in out[3:]], axis=1).astype(np.int64)))
    info_s = json.loads((rundir / "summary.json").read_text())
    if not keep:
        shutil.rmtree(rundir, ignore_errors=True)
    return LinkRun(events, final, globals_, outputs, groups, n, wall, build_time,
                   int(info_s.get("cycles", groups * (cycles + _RST_CYCLES))))


def expected_outputs(link, golden, *, lanes, cycles, retrains=()):
    """Deskewed output the receiver must produce, per group of ``lanes`` lanes.

    Returns per group a list of segments ``(k_first, n_words, columns)``: from cycle
    ``k_first`` one output word per cycle; ``columns[i]`` is lane i's expected word at each
    cycle (sender word order from the data segment's first sync), or None for a lane that
    is not locked at the data start (its column must read 0). Lanes that stop being locked
    inside a segment are listed in the segment's ``dying`` set (checked only for 0 after
    their error shows); when every locked lane of a group fails, its segment ends at the
    cycle the last error shows.
    """
    starts = golden.starts
    stops = starts[1:] + [int(cycles)]
    data_starts = [n for n, m in link.schedule if m == "data"]
    n_link = len(link.lanes)
    groups = max(1, -(-n_link // lanes))
    per_group = [[] for _ in range(groups)]
    for e, (k0, k1) in enumerate(zip(starts, stops)):
        res = golden.trainings[e]
        done = max(ev[0] for r in res for ev in r.events[:1])
        for nd in data_starts:
            if not done < nd < k1:
                continue
            for grp in range(groups):
                ids = [i for i in range(grp * lanes, min((grp + 1) * lanes, n_link))]
                locked = [i for i in ids if res[i].lock_k is not None and res[i].lock_k <= nd]
                if not locked:
                    continue
                k_first = nd + max(res[i].word_delay for i in locked) + 4
                last = min(k1 - 1, cycles - 1)
                # a retrain at k1 - 1 clears the output from k1 on
                if k_first > last:
                    continue
                n_words = last - k_first + 1
                cols = []
                dying = {}
                for i in range(grp * lanes, (grp + 1) * lanes):
                    if i in locked:
                        cols.append(lvds.sent_words(link, i, nd + np.arange(n_words)))
                        errs = [ev[0] for ev in res[i].events if ev[2] == 1]
                        if errs:
                            dying[i - grp * lanes] = errs[0]
                    else:
                        cols.append(None)
                if len(dying) == len(locked):
                    # every lane of the deskew failed: its mask is empty from the last
                    # error on, and the output stops after that cycle
                    n_words = min(n_words, max(dying.values()) - k_first + 1)
                    cols = [c if c is None else c[:n_words] for c in cols]
                    if n_words <= 0:
                        continue
                per_group[grp].append((k_first, n_words, cols, dying))
    return per_group


def check_run(link, run, golden, *, cycles, retrains=()):
    """Problems found comparing a :class:`LinkRun` with the golden model (empty = pass).

    Checks events and final status lane by lane, and the deskewed output word by word.
    """
    problems = []
    if run.events != golden.events:
        got, exp = set(run.events), set(golden.events)
        extra = sorted(got - exp)[:3]
        missing = sorted(exp - got)[:3]
        problems.append(f"events differ: {len(got - exp)} unexpected (first {extra}), "
                        f"{len(exp - got)} missing (first {missing})")
    for i, (f, gf) in enumerate(zip(run.final, golden.final)):
        if f != gf:
            problems.append(f"lane {i}: final status {f} != golden {gf}")
            if len(problems) > 10:
                break
    exp = expected_outputs(link, golden, lanes=run.lanes, cycles=cycles, retrains=retrains)
    for grp, segs in enumerate(exp):
        ks, syncs, data = run.outputs[grp]
        covered = np.zeros(len(ks), bool)
        for k_first, n_words, cols, dying in segs:
            sel = (ks >= k_first) & (ks < k_first + n_words)
            covered |= sel
            got_k = ks[sel]
            if len(got_k) != n_words or (len(got_k) and
                                         not np.array_equal(got_k, k_first + np.arange(n_words))):
                problems.append(f"group {grp}: output segment from cycle {k_first} has "
                                f"{len(got_k)} words, expected {n_words} consecutive")
                continue
            d = data[sel]
            if not syncs[sel][0]:
                problems.append(f"group {grp}: segment at {k_first} does not start on sync")
            for i, col in enumerate(cols):
                if col is None:
                    if (d[:, i] != 0).any():
                        problems.append(f"group {grp} lane {i}: unlocked lane column not 0")
                elif i in dying:
                    after = got_k >= dying[i]
                    if (d[after, i] != 0).any():
                        problems.append(f"group {grp} lane {i}: column not 0 after the lane "
                                        f"failed at {dying[i]}")
                else:
                    bad = np.nonzero(d[:, i] != col)[0]
                    if len(bad):
                        b = int(bad[0])
                        problems.append(f"group {grp} lane {i}: {len(bad)} of {n_words} words "
                                        f"wrong, first at cycle {int(got_k[b])}: got "
                                        f"{int(d[b, i]):#x} expected {int(col[b]):#x}")
        if (~covered).any():
            problems.append(f"group {grp}: {int((~covered).sum())} output words outside the "
                            f"expected segments (first at cycle {int(ks[~covered][0])})")
    return problems


def _final_status(ctx, dut, n, w):
    """Each lane's status ports of ``dut`` (:class:`~tdicam.hdl.lvds.LvdsRx`) now, as
    :func:`tdicam.model.lvds.run`'s ``final`` lists them."""
    def field(port, i, bits):
        return (ctx.get(getattr(dut, port)) >> (i * bits)) & ((1 << bits) - 1)
    out = []
    for i in range(n):
        f = {"tap": field("lane_tap", i, TAP_BITS), "slip": field("lane_slip", i, SLIP_BITS),
             "locked": field("lane_locked", i, 1), "error": field("lane_error", i, 1),
             "run": field("lane_run", i, RUN_BITS), "scan": field("lane_scan", i, lvds.N_TAPS)}
        if dut.eye:
            f.update(slip_pass=field("lane_slip_pass", i, w), walk=field("lane_walk", i, 2 * w))
        if dut.track:
            f["corrections"] = field("lane_corrections", i, 8)
        out.append(f)
    return out


def run_amaranth(link, cycles, *, retrains=(), n_check=4, settle=4, final=None,
                 corrections=None, **rx_params):
    """Train ``link`` on :class:`~tdicam.hdl.lvds.LvdsRx` in Amaranth's Python simulator, the
    link's raw words evaluated by the golden model every cycle (the tap a load selects reaches
    the sampler 2 words later, as in the HDL testbench).

    Returns ``(events, outs, seconds)``: status events as :func:`tdicam.model.lvds.run` lists
    them ``(cycle, lane, locked, error, tap, slip, run)``, the aligned output words
    ``(cycle, sync, data)``, and the simulator's wall time. ``rx_params`` go to ``LvdsRx``
    (``min_run``, ``pick``, ``eye``, ...); ``retrains`` are the cycles ``retrain`` is high.
    ``final``: a list, filled with each lane's status at the end as
    :func:`tdicam.model.lvds.run`'s ``final`` has it (with ``eye``: ``slip_pass`` and
    ``walk`` too, from the eye-status ports; with ``track``: ``corrections``, the counter).
    ``corrections``: a list, filled with ``(effect word, lane, new tap)`` for every tap
    change of a locked lane (the first raw word sampled with the new tap); with ``track`` the
    monitor samplers' words come from the link model at their taps too.
    """
    from amaranth.sim import Simulator

    from tdicam.hdl.lvds import LvdsRx
    n, w = len(link.lanes), link.word_bits
    dut = LvdsRx(lanes=n, word_bits=w, settle=settle, **rx_params)
    events, outs = [], []
    tmask, smask, rmask = ((1 << b) - 1 for b in (TAP_BITS, SLIP_BITS, RUN_BITS))

    async def bench(ctx):
        for port, v in (("train_word", link.train_word), ("sync_word", link.sync_word),
                        ("n_check", n_check), ("line_words", link.line_words)):
            ctx.set(getattr(dut, port), v)
        tapq, tap2, prev = [0] * n, [0] * n, [(0, 0)] * n
        mq, m2, last_tap = [0] * n, [0] * n, [None] * n
        for k in range(cycles):
            ctx.set(dut.lane_raw, sum(int(lvds.raw_words(link, i, tap2[i], k)) << (i * w)
                                      for i in range(n)))
            if dut.track:
                ctx.set(dut.lane_mon_raw, sum(int(lvds.raw_words(link, i, m2[i], k))
                                              << (i * w) for i in range(n)))
                mld, mtap = ctx.get(dut.lane_mon_ld), ctx.get(dut.lane_mon_tap)
            ctx.set(dut.retrain, int(k in retrains))
            ld, tap = ctx.get(dut.lane_ld), ctx.get(dut.lane_tap)
            lk, er = ctx.get(dut.lane_locked), ctx.get(dut.lane_error)
            sl, rn = ctx.get(dut.lane_slip), ctx.get(dut.lane_run)
            for i in range(n):
                st = ((lk >> i) & 1, (er >> i) & 1)
                cur = (tap >> TAP_BITS * i) & tmask
                if st[0] and prev[i][0] and cur != last_tap[i] and corrections is not None:
                    corrections.append((k + lvds.LINK_LATENCY, i, cur))
                last_tap[i] = cur
                if st != prev[i]:
                    events.append((k, i, *st, (tap >> TAP_BITS * i) & tmask,
                                   (sl >> SLIP_BITS * i) & smask, (rn >> RUN_BITS * i) & rmask))
                    prev[i] = st
            if ctx.get(dut.o_valid):
                outs.append((k, ctx.get(dut.o_sync), ctx.get(dut.o_data)))
            await ctx.tick()
            for i in range(n):
                tap2[i] = tapq[i]
                if (ld >> i) & 1:
                    tapq[i] = (tap >> TAP_BITS * i) & tmask
                if dut.track:
                    m2[i] = mq[i]
                    if (mld >> i) & 1:
                        mq[i] = (mtap >> TAP_BITS * i) & tmask
        if final is not None:
            final.extend(_final_status(ctx, dut, n, w))

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    t0 = time.perf_counter()
    sim.run()
    return events, outs, time.perf_counter() - t0
