"""``tdicam verilog BLOCK [--PARAM VALUE ...] -o FILE.v``: the block's deterministic Verilog
(:func:`tdicam.verilog`)."""

import sys

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.files import check_file, write_file
from tdicam.hw.verilog import generate


def register(sub):
    p = sub.add_parser("verilog", help="generate deterministic Verilog for a block",
                       description="Generate deterministic Verilog for a block. "
                                   "'tdicam verilog BLOCK --help' lists its parameters "
                                   "(--NAME VALUE; a true/false one also alone, as a flag).",
                       add_help=False)
    p.add_argument("block", nargs="?", help=f"one of: {', '.join(blocks.names())}")
    p.add_argument("-o", "--output", help="output file (default: stdout)")
    p.add_argument("-h", "--help", action="store_true", help="show the block's parameters")
    p.set_defaults(func=_run, _parser=p, _raw=True)


def parse_block_params(block, extra):
    """``--name value`` / ``--name=value`` pairs for ``block`` into a checked dict; a
    boolean parameter may also stand alone as a flag (``--stream`` = ``--stream 1``); a
    parameter given twice is an error."""
    flags = {p.name for p in block.params if p.type is bool}
    out = {}
    toks = list(extra)
    while toks:
        tok = toks.pop(0)
        if not tok.startswith("--"):
            raise TdicamError(f"unexpected argument {tok!r}; parameters are --NAME VALUE")
        name, eq, value = tok[2:].partition("=")
        key = name.replace("-", "_")
        if key not in {p.name for p in block.params}:
            block.resolve({key: value})     # the unknown-parameter error, before its value
        if not eq:
            if key in flags and (not toks or toks[0].startswith("--")):
                value = "true"
            elif not toks:
                raise TdicamError(f"--{name} needs a value")
            else:
                value = toks.pop(0)
        if key in out:                  # the last one would win silently
            raise TdicamError(f"--{name} given twice ({out[key]!r} and {value!r})")
        out[key] = value
    return block.resolve(out)


def pick_block(args, more_help=None):
    """The registered block named on the command line of ``args``, or None once the help
    asked for (the command's, or the block's parameters and ``more_help``) was printed."""
    if args.block is None:
        if args.help:
            args._parser.print_help()
            return None
        raise TdicamError(f"which block? valid: {', '.join(blocks.names())}")
    blk = blocks.get(args.block)
    if args.help:
        print(blk.describe())
        if more_help:
            print(more_help)
        return None
    return blk


def _run(args):
    if args.block == "pipeline":       # a scene's whole chain: tdicam.chain.design
        from tdicam.commands._pipeline import verilog_command
        return verilog_command(args.extra, args.output, show_help=args.help)
    blk = pick_block(args)
    if blk is None:
        return 0
    params = parse_block_params(blk, args.extra)
    if args.output is not None:
        check_file(args.output)
    text = generate(blk, params)
    if args.output is not None:
        write_file(args.output, text)
        print(f"wrote {args.output}: module {blk.name}, "
              + ", ".join(f"{k}={v}" for k, v in params.items()), file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
