"""``tdicam synth BLOCK [--PARAM VALUE ...]``: LUTs, FFs, block RAM, multipliers, Fmax.

``tdicam synth --reference [BLOCK|LABEL ...]``: every block at its reference parameters
(:data:`tdicam.hw.synth.REFERENCE`) in one table (``--markdown`` for docs/guide/silicon.md, ``--json``).
"""

import datetime
import json
import sys

from tdicam import blocks
from tdicam.errors import TdicamError, check_range
from tdicam.hw import record
from tdicam.hw.synth import REFERENCE, reference_table, synth, tool_versions
from tdicam.commands.verilog import parse_block_params


def register(sub):
    p = sub.add_parser("synth", help="synthesize a block for ECP5 (+ Xilinx 7 cell counts)",
                       description="yosys synth_ecp5 + nextpnr-ecp5 (LFE5U-85F, speed 8, out "
                                   "of context, ports registered by a timing harness; median "
                                   "Fmax over placement seeds) and yosys synth_xilinx cell "
                                   "counts. --reference: every block at its reference "
                                   "parameters. Needs pip install '.[synth]'.")
    p.add_argument("block", nargs="?",
                   help=f"one of: {', '.join(blocks.names())} (with --reference: optional "
                        f"block names or row labels to run)")
    p.add_argument("--reference", action="store_true",
                   help="run the reference table: "
                        + "; ".join(f"{r.label}" for r in REFERENCE))
    p.add_argument("--seeds", type=int, default=3, help="placement seeds, 1..100 (3)")
    p.add_argument("--freq", type=float, default=150,
                   help="target MHz for nextpnr, 1..2000 (150; --reference uses each row's "
                        "target)")
    p.add_argument("--no-xilinx", action="store_true", help="skip the synth_xilinx count")
    p.add_argument("--no-harness", action="store_true",
                   help="place and route the bare top (port paths are then not timed)")
    p.add_argument("--no-abc9", action="store_true",
                   help="map LUTs with synth_ecp5 -noabc9 (the older ABC; for a netlist on "
                        "which ABC9 fails)")
    p.add_argument("--no-pnr", action="store_true",
                   help="pipeline only: the cell counts of yosys (ECP5 and xc7) without "
                        "place and route, for a top too large to place (no Fmax; no "
                        "--record)")
    p.add_argument("--markdown", action="store_true", help="print a markdown table")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument("--record", nargs="?", const="", default=None, metavar="FILE",
                   help="add the results to the synthesis record that tdicam plan reads "
                        "(default FILE: the bundled tdicam/hw/silicon.json of a checkout; a "
                        "row with the same label is replaced)")
    p.set_defaults(func=_run, _raw=True)


def _record(rows, args):
    """Write ``rows`` (:class:`tdicam.hw.record.Row`) into ``--record``'s file, and say so."""
    if args.record is None:
        return
    dest = record.update(rows, args.record or None)
    print(f"recorded {', '.join(r.label for r in rows)} in {dest}", file=sys.stderr)


def _tools_text():
    return ", ".join(tool_versions().values())


def _xc7(r):
    x = r.xilinx
    return (x.get("LUT", 0), x.get("FF", 0), x.get("RAMB36", 0), x.get("RAMB18", 0),
            x.get("DSP48", 0), x.get("LUTRAM", 0) + x.get("SRL", 0)) if x else None


def _xc7_lut(x):
    return f"{x[0]}" + (f" +{x[5]} LUTRAM/SRL" if x[5] else "")


def format_row(r, label=None):
    x = _xc7(r)
    return (f"{(label or r.block):22s} {r.comb:6d} {r.lut4:6d} {r.ccu2c:5d} {r.ff:6d} "
            f"{r.dp16kd:6d} {r.mult18:5d} {r.fmax_mhz:7.1f}  "
            + (f"{x[0]:6d} {x[1]:6d} {x[2]:6d} {x[3]:6d} {x[4]:4d}" if x else ""))


HEADER = (f"{'block':22s} {'COMB':>6s} {'LUT4':>6s} {'CCU2C':>5s} {'FF':>6s} {'DP16KD':>6s} "
          f"{'MULT':>5s} {'Fmax':>7s}  {'xc7LUT':>6s} {'xc7FF':>6s} {'RAMB36':>6s} "
          f"{'RAMB18':>6s} {'DSP':>4s}")


def critical_summary(steps):
    """One line from a :attr:`SynthResult.critical` path: ends, levels, logic/route ns."""
    if not steps:
        return "no critical path reported"
    logic = sum(s[3] for s in steps if s[0] in ("logic", "clk-to-q", "setup"))
    route = sum(s[3] for s in steps if s[0] == "routing")
    levels = sum(1 for s in steps if s[0] == "logic")
    return (f"{steps[0][1]} -> {steps[-1][2]}: {levels} logic steps, "
            f"{logic:.2f} ns cells + {route:.2f} ns routing")


def _params_text(params, block):
    blk = blocks.get(block)
    defaults = {p.name: p.default for p in blk.params}
    shown = {k: v for k, v in params.items() if v is not None}
    text = " ".join(f"{k}={int(v) if isinstance(v, bool) else v}" for k, v in shown.items()
                    if k in ("width", "stages", "pixel_bits", "ppc", "lanes", "pipelined")
                    or v != defaults.get(k))
    return text or "defaults"


def _sum(label, a, b):
    xa, xb = _xc7(a), _xc7(b)
    return {"label": label, "lut4": a.lut4 + b.lut4, "ccu2c": a.ccu2c + b.ccu2c,
            "comb": a.comb + b.comb, "ff": a.ff + b.ff, "dp16kd": a.dp16kd + b.dp16kd,
            "mult18": a.mult18 + b.mult18, "fmax_mhz": min(a.fmax_mhz, b.fmax_mhz),
            "xc7": [p + q for p, q in zip(xa, xb)] if xa and xb else None}


def _sums(rows):
    """The summed rows (a row whose reference names ``sum_with``, plus that row), with the
    summing row's target."""
    by = {ref.label: res for ref, res in rows}
    return [{**_sum(ref.sum_label, by[ref.sum_with], res), "target_mhz": ref.target_mhz}
            for ref, res in rows if ref.sum_with in by]


def _markdown(rows):
    head = ("| block | parameters | LUT4 | CCU2C | COMB | FF | DP16KD | MULT18X18D "
            "| Fmax MHz (min–max) | target | xc7 LUT | xc7 FF | xc7 RAMB36/18 | xc7 DSP48 "
            "| run s |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for ref, r in rows:
        x = _xc7(r)
        met = "met" if r.fmax_mhz >= ref.target_mhz else "**not met**"
        lines.append(
            f"| {ref.label} | {_params_text(r.params, ref.block)} | {r.lut4} | {r.ccu2c} "
            f"| {r.comb} | {r.ff} | {r.dp16kd} | {r.mult18} "
            f"| {r.fmax_mhz:.1f} ({min(r.fmax_seeds):.1f}–{max(r.fmax_seeds):.1f}) "
            f"| {ref.target_mhz:.0f}: {met} "
            + (f"| {_xc7_lut(x)} | {x[1]} | {x[2]}/{x[3]} | {x[4]} " if x else "| | | | ")
            + f"| {r.tool_seconds:.0f} |")
    for s in _sums(rows):
        x = s["xc7"]
        met = "met" if s["fmax_mhz"] >= s["target_mhz"] else "**not met**"
        lines.append(
            f"| {s['label']} | sum | {s['lut4']} | {s['ccu2c']} | {s['comb']} | {s['ff']} "
            f"| {s['dp16kd']} | {s['mult18']} | {s['fmax_mhz']:.1f} (slower of the two) "
            f"| {s['target_mhz']:.0f}: {met} "
            + (f"| {_xc7_lut(x)} | {x[1]} | {x[2]}/{x[3]} | {x[4]} " if x else "| | | | ")
            + "| |")
    return "\n".join(lines)


def _run(args):
    check_range("--seeds", args.seeds, 1, 100)
    check_range("--freq", args.freq, 1, 2000, integer=False)
    if args.no_pnr and (args.block != "pipeline" or args.record is not None):
        raise TdicamError("--no-pnr counts a pipeline's cells without an Fmax: use it with "
                          "'tdicam synth pipeline' and without --record (a record row "
                          "needs its place and route)")
    if args.record is not None:        # before the tools' minutes, not after them
        record.check_destination(args.record or None)
    if args.reference:
        return _run_reference(args)
    if args.block == "pipeline":       # a scene's whole chain: tdicam.chain.design
        from tdicam.commands._pipeline import synth_command
        return synth_command(args.extra, seeds=args.seeds, freq_mhz=args.freq,
                             as_json=args.json, xilinx=not args.no_xilinx,
                             abc9=not args.no_abc9, pnr=not args.no_pnr,
                             record=None if args.record is None else
                             lambda rows: _record(rows, args))
    if args.block is None:
        raise TdicamError(f"which block? valid: {', '.join(blocks.names())} (or --reference)")
    blk = blocks.get(args.block)
    params = parse_block_params(blk, args.extra)
    if args.record is not None and args.no_harness:
        raise TdicamError("--record keeps results with their ports registered: drop "
                          "--no-harness")
    res = synth(blk.name, params, seeds=args.seeds, freq_mhz=args.freq,
                xilinx=not args.no_xilinx, harness=not args.no_harness,
                abc9=not args.no_abc9)
    _record([record.row_of(f"{blk.name} {_params_text(params, blk.name)}", blk.name, params,
                           res, target_mhz=args.freq, tools=_tools_text())], args)
    if args.json:
        print(json.dumps(res.to_dict(), indent=1))
        return 0
    print(f"{blk.name} " + " ".join(f"{k}={v}" for k, v in params.items()))
    print(HEADER)
    print(format_row(res))
    print(f"Fmax per seed: {res.fmax_seeds} MHz (ECP5-85F speed 8, out of context, "
          f"{'ports registered' if res.harness else 'bare top: port paths not timed'}); "
          f"COMB = LUT4 slots after packing (logic + carry + distributed RAM); "
          f"{res.tool_seconds} s of yosys + nextpnr")
    print(f"critical path (slowest seed): {critical_summary(res.critical)}")
    return 0


def _run_reference(args):
    only = [args.block] + list(args.extra) if args.block else list(args.extra)
    if args.no_harness or args.freq != 150 or args.no_abc9:
        raise TdicamError("--reference always uses the timing harness, ABC9 and each row's "
                          "target; drop --no-harness / --no-abc9 / --freq")
    rows = reference_table(seeds=args.seeds, xilinx=not args.no_xilinx, only=only or None,
                           progress=lambda t: print(t, file=sys.stderr, flush=True))
    versions = tool_versions()
    _record([record.row_of(ref.label, ref.block, res.params, res, target_mhz=ref.target_mhz,
                           tools=", ".join(versions.values()), note=ref.note)
             for ref, res in rows], args)
    if args.json:
        print(json.dumps({"tools": versions, "rows": [
            {"label": ref.label, "target_mhz": ref.target_mhz, "note": ref.note,
             **res.to_dict()} for ref, res in rows], "sums": _sums(rows)}, indent=1))
        return 0
    if args.markdown:
        print(_markdown(rows))
    else:
        print(HEADER)
        for ref, res in rows:
            print(format_row(res, ref.label))
    print(f"\n{versions['yosys']}, {versions['nextpnr']}; LFE5U-85F speed 8 CABGA381, out of "
          f"context, every port registered; Fmax = median of {args.seeds} placement seeds "
          f"(min–max); {datetime.date.today().isoformat()}")
    for ref, res in rows:
        if res.fmax_mhz < ref.target_mhz:
            print(f"{ref.label}: {res.fmax_mhz} MHz < {ref.target_mhz:.0f}; critical path: "
                  f"{critical_summary(res.critical)}")
    return 0
