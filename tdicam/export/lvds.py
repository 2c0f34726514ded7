"""``tdicam export lvds``: the LVDS receiver with a self-checking form of its link testbench.

The receiver is not a video stream: its co-simulation testbench
(:func:`tdicam.cosim.lvds.testbench`) plays the serial link in HDL from the link model's
per-lane tables (:func:`tdicam.cosim.lvds.link_files`: bit delay and capture-failure
threshold per tap, the model's counter-based hashes for jitter and data), for the tap the
receiver loaded two word clocks earlier, exactly as :func:`tdicam.model.lvds.raw_words`
defines the captured words. The export takes that testbench text unchanged and adds, at
fixed places, what makes it run on its own and check itself:

* every golden case at the exported parameters runs in one simulation, its lanes in groups
  of the receiver's lane count (padded with dead lanes), a reset between groups; each
  group's link settings (word clocks, schedule, retrain requests, training/sync words,
  ``n_check``, line length) come from ``groups.hex``;
* each lane's status events (cycle, locked, error, tap, slip, run) are compared as they
  happen with the golden model's (``exp_events.hex``); at the end of a group every lane's
  final status (tap, slip, locked, error, run, passing taps) and the lane mask / trained
  flags; every deskewed output word (cycle, sync, each lane's word, or 0 for a lane that is
  not locked or failed) with the words the sensor sent (``exp_out.hex``) -- the checks of
  :func:`tdicam.cosim.lvds.check_run`, in HDL;
* ``PASS <n> beats`` (n = deskewed output words checked) and ``$finish``, or ``FAIL`` with
  the first difference (output word index, case, lane, cycle, expected, got) and
  ``$fatal(1)``.

The golden model (:func:`tdicam.model.lvds.run`) is run on each case's link and checked
against the stored golden vectors (``golden/lvds/``) before anything is written.
"""

from __future__ import annotations

import numpy as np

from tdicam.blocks.lvds import link_from_arrays
from tdicam.cosim import tbgen
from tdicam.cosim.lvds import TbParts, dead_lane, expected_outputs, link_files, testbench
from tdicam.errors import TdicamError
from tdicam.export.block import Design, block_rows, golden_case_arrays
from tdicam.hdl.lvds import RUN_BITS, SLIP_BITS, TAP_BITS
from tdicam.model import lvds
from tdicam.hw.verilog import convert, header

__all__ = ["lvds_export", "lvds_vectors"]

_NSCHED = 8          # schedule entries / retrain requests a group holds (as the testbench)


def _layout(fields):
    """{name: (lo bit, bits)} of hex fields given MSB first as (name, hex digits)."""
    out, lo = {}, 4 * sum(d for _, d in fields)
    for name, digits in fields:
        lo -= 4 * digits
        out[name] = (lo, 4 * digits)
    return out


def _hex(values, fields):
    return "".join(f"{int(values.get(n, 0)) & ((1 << 4 * d) - 1):0{d}x}"
                   for n, d in fields) + "\n"


def _sl(mem, layout, name, bits=None):
    lo, width = layout[name]
    return f"{mem}[{lo + (bits or width) - 1}:{lo}]"


def _fields(n, w):
    gcfg = [("cycles", 8), ("n_sched", 2), ("n_rt", 2), ("train", 4), ("sync", 4),
            ("n_check", 2), ("line", 4), ("case", 2), ("cg0", 4), ("out_end", 8),
            ("mask", -(-n // 4))]
    ev = [("k", 8), ("locked", 1), ("error", 1), ("tap", 2), ("slip", 2), ("run", 2)]
    st = [("tap", 2), ("slip", 2), ("locked", 1), ("error", 1), ("run", 2), ("scan", 8)]
    out = [("g", 4), ("k", 8), ("sync", 1), ("care", -(-n // 4)), ("data", -(-n * w // 4))]
    return gcfg, ev, st, out


def lvds_vectors(blk, params):
    """The link and expected-result memory files of every golden case of ``lvds`` at
    ``params``: ({file name: text}, case names, counts: groups, slots (lanes with the
    pads), events, outputs and word clocks of every group)."""
    found = golden_case_arrays(blk, params)
    if not found:
        raise TdicamError("block lvds has no golden vectors at these parameters; choose "
                          "parameters of one of its golden cases (tdicam golden check lvds "
                          "lists them)")
    n, w = params["lanes"], params["word_bits"]
    gcfg_f, ev_f, st_f, out_f = _fields(n, w)
    lanes_all, gtext, ev_lines, ev_first, st_lines, out_lines = [], [], [], [0], [], []
    sched, rts, names = [], [], []
    cycles_total = 0
    for ci, (name, arrays) in enumerate(found):
        link, cycles, retrains, n_check = link_from_arrays(arrays)
        if len(link.schedule) > _NSCHED or len(retrains) > _NSCHED:
            raise TdicamError(f"lvds case {name}: at most {_NSCHED} schedule entries and "
                              f"retrains")
        n_link = len(link.lanes)
        groups = -(-n_link // n)
        pads = [dead_lane(10_000 + i) for i in range(groups * n - n_link)]
        kw = dict(cycles=cycles, retrains=retrains, n_check=n_check, settle=params["settle"],
                  min_run=params["min_run"], pick=params["pick"])
        gold = lvds.run(link, **kw)
        _check_golden(name, arrays, gold)
        evs, finals = list(gold.events), list(gold.final)
        if pads:
            pad_link = lvds.Link(pads, word_bits=w, train_word=link.train_word,
                                 sync_word=link.sync_word, line_words=link.line_words,
                                 schedule=link.schedule)
            pg = lvds.run(pad_link, **kw)
            evs += [(e[0], e[1] + n_link) + tuple(e[2:]) for e in pg.events]
            finals += pg.final
        expected = expected_outputs(link, gold, lanes=n, cycles=cycles, retrains=retrains)
        g0 = len(gtext)
        for grp in range(groups):
            g = g0 + grp
            for i in range(grp * n, (grp + 1) * n):
                for e in sorted((e for e in evs if e[1] == i), key=lambda e: e[0]):
                    ev_lines.append(_hex(dict(zip(("k", "lane", "locked", "error", "tap",
                                                   "slip", "run"), e)), ev_f))
                ev_first.append(len(ev_lines))
                st_lines.append(_hex(finals[i], st_f))
            mask = sum(1 << (i - grp * n) for i in range(grp * n, min((grp + 1) * n, n_link))
                       if finals[i]["locked"])
            out_lines += _out_records(g, expected[grp], link, out_f, n, w)
            gtext.append(_hex({"cycles": cycles, "n_sched": len(link.schedule),
                               "n_rt": len(retrains), "train": link.train_word,
                               "sync": link.sync_word, "n_check": n_check,
                               "line": link.line_words, "case": ci, "cg0": g0,
                               "out_end": len(out_lines), "mask": mask}, gcfg_f))
            s_rows = [(int(m == "data") << 32) | s for s, m in link.schedule]
            sched += [f"{v:09x}\n" for v in s_rows + [0] * (_NSCHED - len(s_rows))]
            r_rows = sorted(retrains)
            rts += [f"{v:08x}\n" for v in r_rows + [0] * (_NSCHED - len(r_rows))]
        lanes_all += list(link.lanes) + pads
        cycles_total += groups * cycles
        names.append(name)
    tables = link_files(lanes_all, lvds.Link(lanes_all[:1], word_bits=w))
    files = {"tab.hex": tables["tab.hex"].decode(), "info.hex": tables["info.hex"].decode(),
             "groups.hex": "".join(gtext), "sched_all.hex": "".join(sched),
             "retrain_all.hex": "".join(rts), "ev_first.hex": "".join(
                 f"{v:08x}\n" for v in ev_first),
             "exp_events.hex": "".join(ev_lines) or _hex({}, ev_f),
             "exp_status.hex": "".join(st_lines), "exp_out.hex": "".join(out_lines)
             or _hex({"g": 0xFFFF}, out_f)}
    counts = {"groups": len(gtext), "slots": len(lanes_all), "events": len(ev_lines),
              "outputs": len(out_lines), "cycles": cycles_total}
    return files, names, counts


def _check_golden(name, arrays, gold):
    events = np.array(gold.events, np.int64).reshape(-1, 7)
    same = np.array_equal(events, arrays["events"]) and all(
        np.array_equal(np.array([f[k] for f in gold.final]), arrays[k].astype(np.int64))
        for k in ("tap", "slip", "locked", "error", "run", "scan"))
    if not same:
        raise TdicamError(f"golden/lvds/{name}: the stored vectors differ from the golden "
                          f"model; run 'tdicam golden check lvds'")


def _out_records(g, segments, link, fields, n, w):
    """Expected deskewed output words of group ``g``, one record per output cycle (the
    segments of :func:`tdicam.cosim.lvds.expected_outputs`)."""
    lines = []
    for k_first, n_words, cols, dying in segments:
        j = np.arange(n_words)
        for jj in j.tolist():
            k = k_first + jj
            data = care = 0
            for i, col in enumerate(cols):
                if col is None:
                    care |= 1 << i                     # not locked: reads 0
                elif i in dying:
                    care |= int(k >= dying[i]) << i    # failed: 0 from its error on
                else:
                    care |= 1 << i
                    data |= int(col[jj]) << (i * w)
            lines.append(_hex({"g": g, "k": k, "sync": int(jj % link.line_words == 0),
                               "care": care, "data": data}, fields))
    return lines


def _case_name_function(names):
    width = max(len(s) for s in names)
    rows = "\n".join(f'      {i}: case_name = "{s}";' for i, s in enumerate(names))
    return f"""
  function [8*{width}-1:0] case_name(input [7:0] c);
    case (c)
{rows}
      default: case_name = "?";
    endcase
  endfunction
"""


def selfcheck_testbench(top, names, counts):
    """The link testbench of :func:`tdicam.cosim.lvds.testbench` around ``top`` in its
    stand-alone, self-checking form (see the module docstring)."""
    n, w = top.lanes, top.word_bits
    gcfg_f, ev_f, st_f, out_f = _fields(n, w)
    G, E, S, O = (_layout(f) for f in (gcfg_f, ev_f, st_f, out_f))
    gw, ew, sw, ow = (4 * sum(d for _, d in f) for f in (gcfg_f, ev_f, st_f, out_f))
    ng, slots = counts["groups"], counts["slots"]
    nev, nout = counts["events"], counts["outputs"]
    lane_ev = (f"{{k, 3'b0, d_lane_locked[gi], 3'b0, d_lane_error[gi], "
               f"{8 - TAP_BITS}'b0, d_lane_tap[gi*{TAP_BITS} +: {TAP_BITS}], "
               f"{8 - SLIP_BITS}'b0, d_lane_slip[gi*{SLIP_BITS} +: {SLIP_BITS}], "
               f"{8 - RUN_BITS}'b0, d_lane_run[gi*{RUN_BITS} +: {RUN_BITS}]}}")
    decl = f"""
  // ---- self-check (tdicam export): every golden case, group by group
  localparam NG = {ng};
  localparam NEV = {nev};
  localparam NOUT = {nout};
  reg [{gw - 1}:0] gcfg [0:NG-1];
  reg [32:0] sched_all [0:NG*{_NSCHED}-1];
  reg [31:0] rt_all [0:NG*{_NSCHED}-1];
  reg [31:0] ev_first [0:LMAX];
  reg [{ew - 1}:0] exp_ev [0:{max(nev, 1) - 1}];
  reg [{sw - 1}:0] exp_st [0:LMAX-1];
  reg [{ow - 1}:0] exp_out [0:{max(nout, 1) - 1}];
  reg [{gw - 1}:0] gc;
  reg [{ow - 1}:0] eo;
  reg [{sw - 1}:0] es;
  reg [31:0] optr = 0, total = 0;
  integer sc_i, sc_lane;
  reg finished = 1'b0;
{_case_name_function(names)}
  initial begin
    $readmemh("groups.hex", gcfg);
    $readmemh("sched_all.hex", sched_all);
    $readmemh("retrain_all.hex", rt_all);
    $readmemh("ev_first.hex", ev_first);
    $readmemh("exp_events.hex", exp_ev);
    $readmemh("exp_status.hex", exp_st);
    $readmemh("exp_out.hex", exp_out);
    if ($test$plusargs("dump")) begin
      $dumpfile("tdicam_tb.vcd");
      $dumpvars(0, {tbgen.TB_TOP});
    end
    repeat (2) @(negedge clk);
    start = 1'b1;
  end

  // the link settings of group gg (they take effect during its reset)
  task load_group(input [31:0] gg);
    integer q;
    begin
      gc = gcfg[gg];
      cycles <= {_sl("gc", G, "cycles")};
      n_sched <= {_sl("gc", G, "n_sched")};
      n_rt <= {_sl("gc", G, "n_rt")};
      train_word <= {_sl("gc", G, "train", w)};
      sync_word <= {_sl("gc", G, "sync", w)};
      n_check <= {_sl("gc", G, "n_check")};
      line_words <= {_sl("gc", G, "line")};
      for (q = 0; q < {_NSCHED}; q = q + 1) begin
        sched[q] <= sched_all[gg * {_NSCHED} + q];
        rt_at[q] <= rt_all[gg * {_NSCHED} + q];
      end
    end
  endtask
"""
    lane_check = f"""
      // self-check: this lane's status events, as they happen
      reg [31:0] eptr = 0;
      wire ev_now = {{pl, pe}} != {{d_lane_locked[gi], d_lane_error[gi]}};
      wire [{ew - 1}:0] ev_got = {lane_ev};
      wire [{ew - 1}:0] ev_exp = exp_ev[eptr < NEV ? eptr : 0];
      wire [7:0] ci = {_sl("gcfg[g]", G, "case")};
      wire [31:0] case_lane = li - {_sl("gcfg[g]", G, "cg0")} * N;
      always @(posedge clk) begin
        if (rst)
          eptr <= ev_first[li];
        else if (running) begin
          if (ev_now) begin
            if (eptr >= ev_first[li + 1] || ev_got != ev_exp) begin
              if (eptr >= ev_first[li + 1])
                $display("FAIL lane %0d of case %0s: a status event at cycle %0d (locked %0d error %0d tap %0d slip %0d run %0d) beyond the expected %0d",
                         case_lane, case_name(ci), k, d_lane_locked[gi], d_lane_error[gi],
                         d_lane_tap[gi*{TAP_BITS} +: {TAP_BITS}], d_lane_slip[gi*{SLIP_BITS} +: {SLIP_BITS}],
                         d_lane_run[gi*{RUN_BITS} +: {RUN_BITS}], ev_first[li + 1] - ev_first[li]);
              else
                $display("FAIL lane %0d of case %0s: status event %0d: expected cycle %0d locked %0d error %0d tap %0d slip %0d run %0d, got cycle %0d locked %0d error %0d tap %0d slip %0d run %0d",
                         case_lane, case_name(ci), eptr - ev_first[li], {_sl("ev_exp", E, "k")},
                         {_sl("ev_exp", E, "locked")}, {_sl("ev_exp", E, "error")}, {_sl("ev_exp", E, "tap")},
                         {_sl("ev_exp", E, "slip")}, {_sl("ev_exp", E, "run")}, k, d_lane_locked[gi],
                         d_lane_error[gi], d_lane_tap[gi*{TAP_BITS} +: {TAP_BITS}],
                         d_lane_slip[gi*{SLIP_BITS} +: {SLIP_BITS}], d_lane_run[gi*{RUN_BITS} +: {RUN_BITS}]);
              $fatal(1);
            end
            eptr <= eptr + 1;
          end
          if (rcnt == 0 && k + 1 == cycles && eptr + ev_now != ev_first[li + 1]) begin
            $display("FAIL lane %0d of case %0s: %0d status events by cycle %0d, expected %0d",
                     case_lane, case_name(ci), eptr + ev_now - ev_first[li], k,
                     ev_first[li + 1] - ev_first[li]);
            $fatal(1);
          end
        end
      end
"""
    care_lo, data_lo = O["care"][0], O["data"][0]
    main = f"""
  // self-check: deskewed output words, final lane status, lane mask
  always @(posedge clk) begin
    if (running && rcnt == 0) begin
      total <= total + 1;
      if (d_o_valid) begin
        eo = exp_out[optr < NOUT ? optr : 0];
        if (optr >= {_sl("gcfg[g]", G, "out_end")} || {_sl("eo", O, "g")} != g[15:0]
            || {_sl("eo", O, "k")} != k) begin
          if (optr < {_sl("gcfg[g]", G, "out_end")} && {_sl("eo", O, "g")} == g[15:0] && {_sl("eo", O, "k")} < k)
            $display("FAIL beat %0d (case %0s, group %0d): no output word at cycle %0d (the next one came at cycle %0d)",
                     optr, case_name({_sl("gcfg[g]", G, "case")}), g - {_sl("gcfg[g]", G, "cg0")},
                     {_sl("eo", O, "k")}, k);
          else
            $display("FAIL beat %0d (case %0s, group %0d): an output word at cycle %0d where the golden model has none",
                     optr, case_name({_sl("gcfg[g]", G, "case")}), g - {_sl("gcfg[g]", G, "cg0")}, k);
          $fatal(1);
        end
        if (d_o_sync != {_sl("eo", O, "sync", 1)}) begin
          $display("FAIL beat %0d (case %0s, group %0d, cycle %0d): expected o_sync %0d, got %0d",
                   optr, case_name({_sl("gcfg[g]", G, "case")}), g - {_sl("gcfg[g]", G, "cg0")}, k,
                   {_sl("eo", O, "sync", 1)}, d_o_sync);
          $fatal(1);
        end
        sc_lane = -1;
        for (sc_i = N - 1; sc_i >= 0; sc_i = sc_i - 1)
          if (eo[{care_lo} + sc_i] && d_o_data[sc_i*W +: W] != eo[{data_lo} + sc_i*W +: W])
            sc_lane = sc_i;
        if (sc_lane >= 0) begin
          $display("FAIL beat %0d (case %0s, group %0d, cycle %0d): lane %0d: expected %h, got %h",
                   optr, case_name({_sl("gcfg[g]", G, "case")}), g - {_sl("gcfg[g]", G, "cg0")}, k,
                   sc_lane, eo[{data_lo} + sc_lane*W +: W], d_o_data[sc_lane*W +: W]);
          $fatal(1);
        end
        optr <= optr + 1;
      end
      if (k + 1 == cycles) begin
        if (optr + d_o_valid != {_sl("gcfg[g]", G, "out_end")}) begin
          $display("FAIL beat %0d (case %0s, group %0d): the output stopped at cycle %0d; expected %0d more words",
                   optr + d_o_valid, case_name({_sl("gcfg[g]", G, "case")}), g - {_sl("gcfg[g]", G, "cg0")}, k,
                   {_sl("gcfg[g]", G, "out_end")} - optr - d_o_valid);
          $fatal(1);
        end
        for (sc_i = 0; sc_i < N; sc_i = sc_i + 1) begin
          es = exp_st[g * N + sc_i];
          if ({{{8 - TAP_BITS}'b0, d_lane_tap[sc_i*{TAP_BITS} +: {TAP_BITS}], {8 - SLIP_BITS}'b0,
               d_lane_slip[sc_i*{SLIP_BITS} +: {SLIP_BITS}], 3'b0, d_lane_locked[sc_i], 3'b0,
               d_lane_error[sc_i], {8 - RUN_BITS}'b0, d_lane_run[sc_i*{RUN_BITS} +: {RUN_BITS}],
               d_lane_scan[sc_i*32 +: 32]}} != es) begin
            $display("FAIL lane %0d of case %0s: final status expected tap %0d slip %0d locked %0d error %0d run %0d scan %h, got tap %0d slip %0d locked %0d error %0d run %0d scan %h",
                     (g - {_sl("gcfg[g]", G, "cg0")}) * N + sc_i, case_name({_sl("gcfg[g]", G, "case")}),
                     {_sl("es", S, "tap")}, {_sl("es", S, "slip")}, {_sl("es", S, "locked")}, {_sl("es", S, "error")},
                     {_sl("es", S, "run")}, {_sl("es", S, "scan")}, d_lane_tap[sc_i*{TAP_BITS} +: {TAP_BITS}],
                     d_lane_slip[sc_i*{SLIP_BITS} +: {SLIP_BITS}], d_lane_locked[sc_i], d_lane_error[sc_i],
                     d_lane_run[sc_i*{RUN_BITS} +: {RUN_BITS}], d_lane_scan[sc_i*32 +: 32]);
            $fatal(1);
          end
        end
        if (d_lane_mask != {_sl("gcfg[g]", G, "mask", n)} || d_trained != 1'b1) begin
          $display("FAIL group %0d of case %0s: lane mask %h trained %0d, expected mask %h trained 1",
                   g - {_sl("gcfg[g]", G, "cg0")}, case_name({_sl("gcfg[g]", G, "case")}), d_lane_mask,
                   d_trained, {_sl("gcfg[g]", G, "mask", n)});
          $fatal(1);
        end
      end
    end
    if (done && !finished) begin
      finished = 1'b1;
      if (optr != NOUT) begin
        $display("FAIL beat %0d: %0d output words, expected %0d", optr, optr, NOUT);
        $fatal(1);
      end
      $display("PASS %0d beats (%0d status events, %0d lanes' final status, %0d groups, %0d cycles)",
               optr, NEV, LMAX, NG, total);
      $finish;
    end
  end
"""
    # the tables hold exactly the exported lanes (LMAX = slots)
    parts = TbParts(title="self-checking", lmax=slots, decls=decl, lane=lane_check,
                    start="      groups = NG;\n      load_group(0);\n",
                    next_group="            load_group(g + 1);\n", body=main)
    return testbench(top, parts=parts)[0]


def lvds_export(blk, params, *, seed=1, idle=0.1, backpressure=0.1, max_beats=None):
    """(:class:`~tdicam.export.block.Design`, case names, word clocks of all groups, expected
    deskewed output words) of
    ``lvds`` at ``params`` (``seed``, ``idle``, ``backpressure``, ``max_beats``: unused, the
    sensor cannot be stalled; every golden case runs)."""
    if params["phy"] != "none":
        prims = {"xilinx7": "7-series primitives (IBUFDS, IDELAYE2, ISERDESE2)",
                 "ecp5": "ECP5 primitives (DELAYF, IDDRX2F, ECLKSYNCB, CLKDIVF)"}
        raise TdicamError(f"lvds --phy {params['phy']} instantiates {prims[params['phy']]} "
                          f"that no open simulator has; export --phy none, the core that "
                          f"wrapper contains")
    files, names, counts = lvds_vectors(blk, params)
    top = blk.build(params)
    tb = selfcheck_testbench(top, names, counts)
    n, w = params["lanes"], params["word_bits"]
    ports = "\n".join(f"| `{pn}` | {m.flow.name.lower()} | {_width(m)} | {_PORTS.get(pn, '')} |"
                      for pn, m in top.signature.members.items())
    ports = ("| `clk` | in | 1 | word clock |\n| `rst` | in | 1 | synchronous reset, active "
             "high |\n" + ports + "\n")
    checks = (
        f"`tb/tdicam_tb.v` (module `{tbgen.TB_TOP}`, plain Verilog-2005 + `$readmemh`) plays "
        f"the serial link of every golden case ({', '.join(names)}) in HDL: per lane the bit "
        f"delay and capture-failure threshold of each delay tap (`vectors/tab.hex`, from "
        f"the link model's skew, eye, jitter and tap size) and counter-based hashes for "
        f"jitter and data (`vectors/info.hex`), sampled at the tap the receiver loaded; "
        f"the lanes run {n} at a time, {counts['groups']} groups with a reset between them "
        f"(`vectors/groups.hex`: word clocks, sensor schedule, retrain requests). It "
        f"compares every lane's status events ({counts['events']}, cycle exact), every "
        f"lane's final status, and each of the {counts['outputs']} deskewed output words "
        f"with the golden model and prints `PASS {counts['outputs']} beats`, or `FAIL` "
        f"with the first difference (output word index or lane, case, cycle, expected, "
        f"got) and exits non-zero through `$fatal`.")
    d = Design(name="lvds", core="tdicam:blocks:lvds", summary=blk.summary, params=params,
               param_rows=block_rows(blk, params), rtl=convert(top, "lvds", header=header("lvds", params)),
               tb=tb,
               vectors=files, ports=ports,
               latency=f"{top.latency} word clocks from the raw word carrying the last lane's "
                       f"first sync word to `o_valid`; no backpressure (the sensor cannot be "
                       f"stalled); training takes about "
                       f"{lvds.training_words(w, 16, params['settle'])} word clocks",
               checks=checks, plusargs="The link is fixed by the vectors and the receiver cannot be "
                        "stalled: there are no run-setting plusargs.")
    return d, names, counts["cycles"], counts["outputs"]


def _width(member):
    from amaranth.hdl import Shape
    return Shape.cast(member.shape).width


_PORTS = {
    "lane_raw": "deserializer words, lane 0 in the LSBs, first received bit in each MSB",
    "lane_tap": "delay tap per lane (5 bits each; IDELAYE2 CNTVALUEIN)",
    "lane_ld": "tap load strobe per lane (IDELAYE2 LD, VAR_LOAD mode)",
    "train_word": "training word (its rotations all differ)",
    "sync_word": "sync word (line start in data mode)",
    "n_check": "words checked per tap and bitslip (0 counts as 1)",
    "line_words": "sync word period in data mode",
    "retrain": "retrain request: every lane restarts training next cycle",
    "lane_slip": "bitslip per lane (4 bits each)",
    "lane_locked": "lane locked", "lane_error": "lane failed (no eye, no word match, or broke "
    "the training/sync rules after lock)",
    "lane_run": "widest run of passing taps per lane (6 bits each)",
    "lane_scan": "passing taps per lane (32 bits each)",
    "lane_mask": "lanes taking part in the deskew (locked)",
    "all_locked": "every lane locked", "trained": "every lane finished training",
    "o_valid": "deskewed words valid", "o_sync": "every lane's word is the sync word",
    "o_data": "deskewed words, lane 0 in the LSBs; unlocked lanes read 0",
    "aligned": "lanes released together", "deskew_error": "deskew FIFO overflow or lost "
    "alignment",
}
