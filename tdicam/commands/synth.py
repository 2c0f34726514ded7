"""``tdicam synth BLOCK [--PARAM VALUE ...]``: LUTs, FFs, block RAM, multipliers, Fmax."""

import json

from .. import blocks
from ..synth import synth
from .verilog import parse_block_params


def register(sub):
    p = sub.add_parser("synth", help="synthesize a block for ECP5 (+ Xilinx 7 cell counts)",
                       description="yosys synth_ecp5 + nextpnr-ecp5 (LFE5U-85F, speed 8, out "
                                   "of context; median Fmax over placement seeds) and yosys "
                                   "synth_xilinx cell counts. Needs pip install '.[synth]'.")
    p.add_argument("block", help=f"one of: {', '.join(blocks.names())}")
    p.add_argument("--seeds", type=int, default=3, help="placement seeds (3)")
    p.add_argument("--freq", type=float, default=150, help="target MHz for nextpnr (150)")
    p.add_argument("--no-xilinx", action="store_true", help="skip the synth_xilinx count")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_run, _raw=True)


def format_row(r):
    x = r.xilinx
    return (f"{r.block:12s} {r.comb:6d} {r.lut4:6d} {r.ccu2c:5d} {r.ff:6d} {r.dp16kd:6d} "
            f"{r.mult18:5d} {r.fmax_mhz:7.1f}  " +
            (f"{x.get('LUT', 0):6d} {x.get('FF', 0):6d} {x.get('RAMB18', 0) + 2 * x.get('RAMB36', 0):6d} "
             f"{x.get('DSP48', 0):4d}" if x else ""))


HEADER = (f"{'block':12s} {'COMB':>6s} {'LUT4':>6s} {'CCU2C':>5s} {'FF':>6s} {'DP16KD':>6s} "
          f"{'MULT':>5s} {'Fmax':>7s}  {'xc7LUT':>6s} {'xc7FF':>6s} {'RAMB18':>6s} {'DSP':>4s}")


def _run(args):
    blk = blocks.get(args.block)
    params = parse_block_params(blk, args.extra)
    res = synth(blk.name, params, seeds=args.seeds, freq_mhz=args.freq,
                xilinx=not args.no_xilinx)
    if args.json:
        print(json.dumps(res.to_dict(), indent=1))
        return 0
    print(f"{blk.name} " + " ".join(f"{k}={v}" for k, v in params.items()))
    print(HEADER)
    print(format_row(res))
    print(f"Fmax per seed: {res.fmax_seeds} MHz (ECP5-85F speed 8, out of context); "
          f"COMB = LUT4 slots after packing (logic + carry + distributed RAM); {res.seconds} s")
    return 0
