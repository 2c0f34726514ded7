"""``tdicam export BLOCK [--PARAM VALUE ...] -o DIR``: a block as a FuseSoC core with a
self-checking Verilog testbench and its golden vectors (see :mod:`tdicam.export.block`)."""

import sys

from tdicam import blocks
from tdicam.commands._parsing import ArgsParser
from tdicam.errors import TdicamError
from tdicam.export.harness import export_block
from tdicam.cosim.pauses import SEED_MAX, check_seed
from tdicam.commands.verilog import parse_block_params, pick_block


def register(sub):
    p = sub.add_parser(
        "export", add_help=False,
        help="write a block as a FuseSoC core with a self-checking testbench",
        description="Write DIR/rtl/BLOCK.v, a self-checking Verilog-2005 testbench "
                    "(tb/tdicam_tb.v) with the block's golden vectors (vectors/*.hex), a "
                    "FuseSoC core (tdicam_BLOCK.core) and a README. The testbench runs in "
                    "any Verilog simulator with no tdicam, cocotb or Python: it prints "
                    "'PASS n beats' or 'FAIL' with the first bad beat and exits non-zero. "
                    "'tdicam export BLOCK --help' lists the block's parameters; "
                    "'tdicam export pipeline --scene S.toml -o DIR' exports a scene's "
                    "whole chain ('tdicam export pipeline --help').")
    p.add_argument("block", nargs="?",
                   help=f"one of: {', '.join(blocks.names())}, or pipeline")
    p.add_argument("-o", "--output", help="export folder (created)")
    p.add_argument("--force", action="store_true",
                   help="replace a folder that holds something else")
    p.add_argument("--seed", type=int, default=1,
                   help=f"seed of the testbench's idle/backpressure generator, 1..{SEED_MAX} "
                        "(default 1)")
    p.add_argument("-h", "--help", action="store_true", help="show the block's parameters")
    p.set_defaults(func=_run, _parser=p, _raw=True)


def _pipeline(args):
    """``tdicam export pipeline --scene S.toml [--stages N] [--lines N] [--width N]
    [--memory auto|chip|ddr] [--device D] [--ppc N] [--no-csr] [--bus B] -o DIR``."""
    from tdicam.commands._parsing import source_path
    from tdicam.commands._pipeline import add_pipeline_options
    from tdicam.export.chain import export_pipeline
    ap = ArgsParser(
        prog="tdicam export pipeline",
        description="A scene's whole [pipeline] as one exported design: the top as "
                    "'tdicam verilog pipeline --scene' writes it, and a self-checking "
                    "testbench whose stimulus is the scene's raw frames and whose expected "
                    "output is the golden chain's.",
        epilog="-o DIR, --force and --seed as for a block (tdicam export --help).")
    add_pipeline_options(ap, width=True)
    if args.help:
        ap.print_help()
        return 0
    ns = ap.parse_args(list(args.extra))
    if not args.output:
        raise TdicamError("export needs -o DIR (the export folder)")
    from tdicam.export.chain import STAGES
    from tdicam.progress import Progress
    if ns.csr:
        from tdicam.chain.registers import require
        require()                                  # the tools, before the work
    with Progress("export pipeline", stages=len(STAGES)) as bar:
        ex = export_pipeline(source_path(ns), args.output, force=args.force, seed=args.seed,
                             stages=ns.stages, lines=ns.lines, width=ns.width,
                             memory=ns.memory, device=ns.device, ppc=ns.ppc, csr=ns.csr,
                             bus=ns.bus,
                             progress=bar)
    print(f"wrote {ex.path}: pipeline {ex.params['blocks']} ({ex.params['width']} columns, "
          f"{ex.params['lines']} lines), {ex.n_in} stimulus beats, {ex.n_out} expected beats",
          file=sys.stderr)
    return 0


def _run(args):
    check_seed("--seed", args.seed)
    if args.block == "pipeline":       # a scene's whole chain: tdicam.export.chain
        return _pipeline(args)
    blk = pick_block(args, "without parameters: those of most of the block's golden cases")
    if blk is None:
        return 0
    if not args.output:
        raise TdicamError("export needs -o DIR (the export folder)")
    params = parse_block_params(blk, args.extra) if args.extra else {}
    ex = export_block(blk, params, args.output, force=args.force, seed=args.seed,
                      say=lambda text: print(text, file=sys.stderr, flush=True))
    print(f"wrote {ex.path}: {ex.block} ({', '.join(f'{k}={v}' for k, v in ex.params.items())}"
          f"), {ex.n_in} input beats (lvds: word clocks), {ex.n_out} expected beats from golden "
          f"cases "
          f"{', '.join(ex.cases)}", file=sys.stderr)
    return 0
