"""``tdicam golden regen|check [BLOCK ...]``"""

from tdicam import blocks as _blocks
from tdicam.cosim import golden


def register(sub):
    p = sub.add_parser("golden", help="regenerate or check the golden vectors",
                       description="Regenerate (regen) or verify (check) golden/<block>/*.npz "
                                   "and golden/manifest.json against the golden models.")
    p.add_argument("action", choices=("regen", "check"))
    p.add_argument("blocks", nargs="*", metavar="BLOCK",
                   help=f"blocks (default: all): {', '.join(_blocks.names())}")
    p.set_defaults(func=_run)


def _run(args):
    if args.action == "regen":
        n = golden.regen(args.blocks)
        print(f"golden: regenerated {n} cases")
        return 0
    results = golden.check(args.blocks)
    bad = [r for r in results if not r.ok]
    for r in results:
        print(f"{'ok  ' if r.ok else 'FAIL'} {r.key}" + ("" if r.ok else f": {r.message}"))
    print(f"golden: {len(results) - len(bad)} of {len(results)} cases match the models")
    return 1 if bad else 0
