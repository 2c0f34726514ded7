"""``tdicam calib write|read|check|inject``: the ECC-protected calibration store.

``write`` packs gain/offset maps into a flash image (format: :mod:`tdicam.model.calib`);
``read`` decodes an image, reports corrected and uncorrectable words and can save the
decoded maps; ``check`` only reports (exit 1 if any word was uncorrectable or the payload
CRC does not match); ``inject`` flips random bits in an image (to test a reader).
"""

import numpy as np

from ..errors import TdicamError
from ..model import calib
from ..model.nuc import DEFAULT_FORMAT, NucFormat


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
    w.set_defaults(func=_write)

    r = csub.add_parser("read", help="decode an image: counts, and the maps with -o")
    r.add_argument("image")
    r.add_argument("-o", "--output", help=".npz to write: gain/offset codes and values, "
                                          "defaulted mask")
    r.set_defaults(func=_read)

    c = csub.add_parser("check", help="decode an image and report; exit 1 if damaged")
    c.add_argument("image")
    c.set_defaults(func=_check)

    j = csub.add_parser("inject", help="flip random bits in an image (reader testing)")
    j.add_argument("image")
    j.add_argument("-o", "--output", required=True)
    j.add_argument("--single", type=float, default=0.01,
                   help="probability that a word gets one flipped bit (0.01)")
    j.add_argument("--double", type=float, default=0.0,
                   help="probability that a word gets two flipped bits (0)")
    j.add_argument("--header", action="store_true", help="also flip bits in the header")
    j.add_argument("--seed", type=int, default=1)
    j.set_defaults(func=_inject)


def _load_array(path, what):
    try:
        with open(path, "rb") as fh:
            a = np.load(fh, allow_pickle=False)
            if isinstance(a, np.lib.npyio.NpzFile):
                raise TdicamError(f"{path}: expected a .npy array for {what}, got an .npz")
            return a
    except OSError as exc:
        raise TdicamError(f"{path}: cannot read ({exc.strerror})") from None
    except ValueError as exc:
        raise TdicamError(f"{path}: not a numpy array file ({str(exc).splitlines()[0]})") \
            from None


def _load_maps(args):
    if args.maps and (args.gain or args.offset):
        raise TdicamError("give either MAPS.npz or --gain/--offset, not both")
    if args.maps:
        try:
            with np.load(args.maps, allow_pickle=False) as z:
                if not hasattr(z, "files"):
                    raise TdicamError(f"{args.maps}: expected an .npz with arrays 'gain' and "
                                      f"'offset'")
                missing = [k for k in ("gain", "offset") if k not in z.files]
                if missing:
                    raise TdicamError(f"{args.maps}: no array {missing[0]!r} (has: "
                                      f"{', '.join(z.files) or 'none'})")
                return z["gain"], z["offset"]
        except OSError as exc:
            raise TdicamError(f"{args.maps}: cannot read ({exc.strerror})") from None
        except ValueError as exc:
            raise TdicamError(f"{args.maps}: not a numpy .npz file "
                              f"({str(exc).splitlines()[0]})") from None
    if not (args.gain and args.offset):
        raise TdicamError("give MAPS.npz, or both --gain G.npy and --offset O.npy")
    return _load_array(args.gain, "gain"), _load_array(args.offset, "offset")


def _write(args):
    fmt = NucFormat(args.gain_int_bits, args.gain_frac_bits, args.offset_bits,
                    args.offset_frac_bits)
    fmt._check_slots()
    gain, offset = _load_maps(args)
    if gain.ndim != 2 or gain.shape != offset.shape:
        raise TdicamError(f"gain and offset must be 2-D maps of one shape; got {gain.shape} "
                          f"and {offset.shape}")
    if args.codes:
        g, o = fmt.check_coeffs(gain, offset)
    else:
        g, o = calib.codes_from_values(gain, offset, fmt)
    n = calib.write_image(args.output, g, o, fmt)
    rows, cols = g.shape
    print(f"wrote {args.output}: {rows} x {cols} pixels, gain Q{fmt.gain_int_bits}."
          f"{fmt.gain_frac_bits}, offset {fmt.offset_bits} bits ({fmt.offset_frac_bits} "
          f"fraction), {n // calib.WORD_BYTES} flash words of 72 bits, {n} bytes")
    return 0


def _summary(path, res):
    rows, cols = res.shape
    return (f"{path}: {rows} x {cols} pixels, {calib.HEADER_WORDS + calib.payload_words(rows, cols)}"
            f" words: {res.corrected} corrected, {res.uncorrectable} uncorrectable "
            f"({int(res.defaulted.sum())} pixels with default coefficients), payload CRC "
            f"{'ok' if res.crc_ok else 'MISMATCH'}")


def _read(args):
    res = calib.load_image(args.image)
    print(_summary(args.image, res))
    if args.output:
        f = res.fmt
        np.savez_compressed(
            args.output, gain_code=res.gain, offset_code=res.offset,
            gain=res.gain / f.gain_one, offset=res.offset / (1 << f.offset_frac_bits),
            defaulted=res.defaulted)
        print(f"wrote {args.output}: gain_code, offset_code, gain, offset, defaulted")
    return 0


def _check(args):
    res = calib.load_image(args.image)
    print(_summary(args.image, res))
    return 1 if res.uncorrectable or not res.crc_ok else 0


def _inject(args):
    for name in ("single", "double"):
        p = getattr(args, name)
        if not 0 <= p <= 1:
            raise TdicamError(f"--{name} = {p} is out of range; valid: 0..1")
    if args.single + args.double > 1:
        raise TdicamError("--single + --double must be at most 1")
    words = calib.image_words(calib.read_file(args.image), args.image)
    out, k = calib.inject_flips(np.random.default_rng(args.seed), words, p_single=args.single,
                                p_double=args.double, skip_header=not args.header)
    with open(args.output, "wb") as fh:
        fh.write(out.tobytes())
    print(f"wrote {args.output}: {int((k == 1).sum())} words with 1 flipped bit, "
          f"{int((k == 2).sum())} with 2, of {len(words)}")
    return 0
