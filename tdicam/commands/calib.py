"""``tdicam calib write|read|check|inject``: the ECC-protected calibration store.

``write`` packs gain/offset maps into a flash image (format: :mod:`tdicam.model.calib`);
``read`` decodes an image, reports corrected and uncorrectable words and can save the
decoded maps; ``check`` only reports (exit 1 if any word was uncorrectable or the payload
CRC does not match); ``inject`` flips random bits in an image (to test a reader).
With ``--nand`` the image is the NAND part as the camera stores it (:mod:`tdicam.model.nand_store`:
pages with spare areas, bad blocks skipped and marked, block map in block 0); ``read`` and
``check`` recognise NAND images by their magic and also report the bad-block scan and the
power-up scan and load times of the gateware; ``inject`` adds bad blocks to a NAND image.
The work is :mod:`tdicam.flash`'s; this module parses the arguments and prints.
"""

from tdicam import flash
from tdicam.files import check_file
from tdicam.model import nand_store
from tdicam.model.nuc import DEFAULT_FORMAT


def register(sub):
    p = sub.add_parser("calib", help="write, read or check an ECC-protected calibration image",
                       description=__doc__.splitlines()[2].strip() + " " + " ".join(
                           line.strip() for line in __doc__.splitlines()[3:6]))
    csub = p.add_subparsers(dest="action", metavar="ACTION", parser_class=type(p))
    csub.required = True

    w = csub.add_parser("write", help="gain/offset maps (.npz or two .npy) -> flash image")
    w.add_argument("maps", nargs="?", help=".npz holding arrays 'gain' and 'offset'")
    w.add_argument("--gain", help=".npy gain map (instead of MAPS)")
    w.add_argument("--offset", help=".npy offset map (instead of MAPS)")
    w.add_argument("-o", "--output", required=True, help="image file to write")
    w.add_argument("--codes", action="store_true",
                   help="the maps hold integer codes of the format, not real values")
    d = DEFAULT_FORMAT
    w.add_argument("--gain-int-bits", type=int, default=d.gain_int_bits,
                   help=f"integer bits of the unsigned gain ({d.gain_int_bits})")
    w.add_argument("--gain-frac-bits", type=int, default=d.gain_frac_bits,
                   help=f"fraction bits of the gain, 1.0 = 2**frac ({d.gain_frac_bits})")
    w.add_argument("--offset-bits", type=int, default=d.offset_bits,
                   help=f"width of the signed offset ({d.offset_bits})")
    w.add_argument("--offset-frac-bits", type=int, default=d.offset_frac_bits,
                   help=f"fraction bits of the offset ({d.offset_frac_bits})")
    _nand_args(w)
    w.set_defaults(func=_write)

    r = csub.add_parser("read", help="decode an image: counts, and the maps with -o")
    r.add_argument("image")
    r.add_argument("-o", "--output", help=".npz to write (this exact name): gain/offset "
                                          "codes and values, defaulted mask")
    _clock_arg(r)
    r.set_defaults(func=_read)

    c = csub.add_parser("check", help="decode an image and report; exit 1 if damaged")
    c.add_argument("image")
    _clock_arg(c)
    c.set_defaults(func=_check)

    j = csub.add_parser("inject", help="flip random bits in an image (reader testing)")
    j.add_argument("image")
    j.add_argument("-o", "--output", required=True)
    j.add_argument("--single", type=float, default=0.01,
                   help="probability that a word gets one flipped bit (0.01)")
    j.add_argument("--double", type=float, default=0.0,
                   help="probability that a word gets two flipped bits (0)")
    j.add_argument("--header", action="store_true", help="also flip bits in the header")
    j.add_argument("--bad-blocks", type=int, default=0,
                   help="NAND images: mark this many more random blocks bad (never block 0) "
                        "and re-lay the data out around them (0)")
    j.add_argument("--fail-program", default="",
                   help="NAND images: comma-separated blocks whose programs fail while the "
                        "image is re-laid out (grown bad blocks)")
    j.add_argument("--seed", type=int, default=1, help="random seed, >= 0 (1)")
    j.set_defaults(func=_inject)


def _clock_arg(p):
    p.add_argument("--clock-mhz", type=float, default=None,
                   help=f"NAND images only: controller clock of the reported scan and load "
                        f"times ({nand_store.CONTROLLER_CLOCK_HZ / 1e6:g} MHz)")


def _nand_args(p):
    g = nand_store.MT29F4G08
    p.add_argument("--nand", action="store_true",
                   help="write a NAND image (pages + spare, bad blocks, block map) instead "
                        "of a plain word image")
    p.add_argument("--blocks", type=int, default=None,
                   help=f"NAND: blocks of the part ({g.blocks}: 4 Gb x8, MT29F4G08)")
    p.add_argument("--pages-per-block", type=int, default=None,
                   help=f"NAND: pages per block ({g.pages_per_block})")
    _clock_arg(p)


def _print(lines):
    print("\n".join([lines] if isinstance(lines, str) else lines))
    return 0


def _write(args):
    return _print(flash.write(
        args.output, maps=args.maps, gain=args.gain, offset=args.offset, codes=args.codes,
        gain_int_bits=args.gain_int_bits, gain_frac_bits=args.gain_frac_bits,
        offset_bits=args.offset_bits, offset_frac_bits=args.offset_frac_bits,
        nand_image=args.nand, blocks_=args.blocks, pages_per_block=args.pages_per_block,
        clock_mhz=args.clock_mhz))


def _read(args):
    if args.output is not None:
        flash.check_not_input(args.output, args.image)
        check_file(args.output)
    img, lines = flash.report(args.image, args.clock_mhz)
    _print(lines)
    if args.output is not None:
        _print(flash.save_maps(img, args.output))
    return 0


def _check(args):
    img, lines = flash.report(args.image, args.clock_mhz)
    _print(lines)
    return 1 if img.uncorrectable or not img.crc_ok else 0


def _inject(args):
    return _print(flash.inject(args.image, args.output, single=args.single,
                               double=args.double, header=args.header,
                               bad_blocks=args.bad_blocks, fail_program=args.fail_program,
                               seed=args.seed))
