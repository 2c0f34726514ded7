"""``tdicam demo``: the end-to-end path on one block, as a smoke run of the whole tool."""

from tdicam import blocks
from tdicam.demo import demo


def register(sub):
    p = sub.add_parser("demo", help="generate, lint and co-simulate a block against golden",
                       description="Generate a block's Verilog, lint it, check its golden "
                                   "vectors and co-simulate it on Icarus and Verilator.")
    p.add_argument("block", nargs="?", default="cds",
                   help=f"one of: {', '.join(blocks.names())} (cds)")
    p.add_argument("-o", "--outdir", default="out", help="where the Verilog goes (out/)")
    p.set_defaults(func=_run)


def _run(args):
    return demo(args.block, args.outdir)
