"""``tdicam export BLOCK [--PARAM VALUE ...] -o DIR``: a block as a FuseSoC core with a
self-checking Verilog testbench and its golden vectors (see :mod:`tdicam.export`)."""

import sys

from .. import blocks
from ..errors import TdicamError
from ..export import export_block
from ..pauses import SEED_MAX, check_seed
from .verilog import parse_block_params, pick_block


def register(sub):
    p = sub.add_parser(
        "export", add_help=False,
        help="write a block as a FuseSoC core with a self-checking testbench",
        description="Write DIR/rtl/BLOCK.v, a self-checking Verilog-2005 testbench "
                    "(tb/tdicam_tb.v) with the block's golden vectors (vectors/*.hex), a "
                    "FuseSoC core (tdicam_BLOCK.core) and a README. The testbench runs in "
                    "any Verilog simulator with no tdicam, cocotb or Python: it prints "
                    "'PASS n beats' or 'FAIL' with the first bad beat and exits non-zero. "
                    "'tdicam export BLOCK --help' lists the block's parameters.")
    p.add_argument("block", nargs="?", help=f"one of: {', '.join(blocks.names())}")
    p.add_argument("-o", "--output", help="export folder (created)")
    p.add_argument("--force", action="store_true",
                   help="replace a folder that holds something else")
    p.add_argument("--seed", type=int, default=1,
                   help=f"seed of the testbench's idle/backpressure generator, 1..{SEED_MAX} "
                        "(default 1)")
    p.add_argument("-h", "--help", action="store_true", help="show the block's parameters")
    p.set_defaults(func=_run, _parser=p, _raw=True)


def _run(args):
    blk = pick_block(args, "without parameters: those of most of the block's golden cases")
    if blk is None:
        return 0
    if not args.output:
        raise TdicamError("export needs -o DIR (the export folder)")
    check_seed("--seed", args.seed)
    params = parse_block_params(blk, args.extra) if args.extra else {}
    ex = export_block(blk, params, args.output, force=args.force, seed=args.seed)
    print(f"wrote {ex.path}: {ex.block} ({', '.join(f'{k}={v}' for k, v in ex.params.items())}"
          f"), {ex.n_in} stimulus beats, {ex.n_out} expected beats from golden cases "
          f"{', '.join(ex.cases)}", file=sys.stderr)
    return 0
