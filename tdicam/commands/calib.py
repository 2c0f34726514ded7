"""``tdicam calib write|read|check|inject``: the ECC-protected calibration store.

``write`` packs gain/offset maps into a flash image (format: :mod:`tdicam.model.calib`);
``read`` decodes an image, reports corrected and uncorrectable words and can save the
decoded maps; ``check`` only reports (exit 1 if any word was uncorrectable or the payload
CRC does not match); ``inject`` flips random bits in an image (to test a reader).
With ``--nand`` the image is the NAND part as the camera stores it (:mod:`tdicam.model.nand_store`:
pages with spare areas, bad blocks skipped and marked, block map in block 0); ``read`` and
``check`` recognise NAND images by their magic and also report the bad-block scan and the
power-up scan and load times of the gateware; ``inject`` adds bad blocks to a NAND image.
"""

import zipfile

import numpy as np

from tdicam.errors import TdicamError, check_range
from tdicam.files import check_file, open_output
from tdicam.model import calib, nand_store as nand
from tdicam.model.nuc import DEFAULT_FORMAT, NucFormat


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
                        f"times ({nand.CONTROLLER_CLOCK_HZ / 1e6:g} MHz)")


def _nand_args(p):
    g = nand.MT29F4G08
    p.add_argument("--nand", action="store_true",
                   help="write a NAND image (pages + spare, bad blocks, block map) instead "
                        "of a plain word image")
    p.add_argument("--blocks", type=int, default=None,
                   help=f"NAND: blocks of the part ({g.blocks}: 4 Gb x8, MT29F4G08)")
    p.add_argument("--pages-per-block", type=int, default=None,
                   help=f"NAND: pages per block ({g.pages_per_block})")
    _clock_arg(p)


#: What np.load raises on a file that is not (or no longer, truncated) a numpy file.
_NOT_NUMPY = (ValueError, EOFError, zipfile.BadZipFile)


def _why(exc):
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


def _load_array(path, what):
    try:
        with open(path, "rb") as fh:
            a = np.load(fh, allow_pickle=False)
            if isinstance(a, np.lib.npyio.NpzFile):
                raise TdicamError(f"{path}: expected a .npy array for {what}, got an .npz")
            return a
    except TdicamError:
        raise
    except OSError as exc:
        raise TdicamError(f"{path}: cannot read ({exc.strerror})") from None
    except _NOT_NUMPY as exc:
        raise TdicamError(f"{path}: not a numpy array file ({_why(exc)})") from None


def _load_maps(args):
    if args.maps and (args.gain or args.offset):
        raise TdicamError("give either MAPS.npz or --gain/--offset, not both")
    if args.maps:
        try:
            z = np.load(args.maps, allow_pickle=False)
            if not isinstance(z, np.lib.npyio.NpzFile):     # a .npy: one array
                raise TdicamError(f"{args.maps}: expected an .npz with arrays 'gain' and "
                                  f"'offset', got one array (give two .npy files as --gain "
                                  f"G.npy --offset O.npy)")
            with z:
                missing = [k for k in ("gain", "offset") if k not in z.files]
                if missing:
                    raise TdicamError(f"{args.maps}: no array {missing[0]!r} (has: "
                                      f"{', '.join(z.files) or 'none'})")
                return z["gain"], z["offset"]
        except TdicamError:
            raise
        except OSError as exc:
            raise TdicamError(f"{args.maps}: cannot read ({exc.strerror})") from None
        except _NOT_NUMPY as exc:
            raise TdicamError(f"{args.maps}: not a numpy .npz file ({_why(exc)})") from None
    if not (args.gain and args.offset):
        raise TdicamError("give MAPS.npz, or both --gain G.npy and --offset O.npy")
    return _load_array(args.gain, "gain"), _load_array(args.offset, "offset")


def _write(args):
    fmt = NucFormat(args.gain_int_bits, args.gain_frac_bits, args.offset_bits,
                    args.offset_frac_bits)
    fmt._check_slots()
    if not args.nand:               # NAND geometry without --nand was ignored silently
        for opt, v in (("--blocks", args.blocks), ("--pages-per-block", args.pages_per_block),
                       ("--clock-mhz", args.clock_mhz)):
            if v is not None:
                raise TdicamError(f"{opt}: only with --nand (a NAND image)")
    check_file(args.output)
    gain, offset = _load_maps(args)
    for what, a in (("gain", gain), ("offset", offset)):
        if a.dtype.kind not in "iuf":
            raise TdicamError(f"the {what} map must hold real numbers, got dtype {a.dtype}")
    if gain.ndim != 2 or gain.shape != offset.shape:
        raise TdicamError(f"gain and offset must be 2-D maps of one shape; got {gain.shape} "
                          f"and {offset.shape}")
    if args.codes:
        g, o = fmt.check_coeffs(gain, offset)
    else:
        g, o = calib.codes_from_values(gain, offset, fmt)
    rows, cols = g.shape
    if args.nand:
        return _write_nand(args, calib.encode_image(g, o, fmt), rows, cols)
    words = calib.encode_image(g, o, fmt)
    with open_output(args.output) as fh:
        fh.write(words.tobytes())
    n = words.nbytes
    print(f"wrote {args.output}: {rows} x {cols} pixels, gain Q{fmt.gain_int_bits}."
          f"{fmt.gain_frac_bits}, offset {fmt.offset_bits} bits ({fmt.offset_frac_bits} "
          f"fraction), {n // calib.WORD_BYTES} flash words of 72 bits, {n} bytes")
    return 0


def _clock(args):
    if args.clock_mhz is None:
        return nand.CONTROLLER_CLOCK_HZ
    return check_range("--clock-mhz", args.clock_mhz, 1, 1000, integer=False) * 1e6


def _timing_line(rows, cols, geometry, clock_hz):
    t = nand.timing(rows, cols, geometry, clock_hz=clock_hz)
    return (f"gateware at {clock_hz / 1e6:g} MHz (t_R {geometry.t_r_s * 1e6:g} us = "
            f"{t.busy_cycles} clocks): power-up scan of {geometry.blocks} blocks "
            f"{t.scan_s * 1e3:.1f} ms, calibration load of {t.pages} pages in {t.blocks} "
            f"blocks {t.load_s * 1e3:.1f} ms")


def _write_nand(args, words, rows, cols):
    try:
        g = nand.MT29F4G08
        geo = nand.Geometry(
            pages_per_block=g.pages_per_block if args.pages_per_block is None
            else args.pages_per_block, blocks=g.blocks if args.blocks is None else args.blocks)
    except TdicamError as exc:
        raise TdicamError(f"--nand geometry: {exc}") from None
    clock = _clock(args)
    dev = nand.write_store(words, geo)
    n = nand.save_image(dev, args.output)
    print(f"wrote {args.output}: NAND image, {rows} x {cols} pixels, {len(words)} flash words "
          f"in {-(-len(words) // geo.words_per_page)} pages of {geo.page_bytes}+"
          f"{geo.spare_bytes} bytes, part of {geo.blocks} blocks x {geo.pages_per_block} "
          f"pages, block map in block 0, {n} bytes")
    print(_timing_line(rows, cols, geo, clock))
    return 0


def _load_any(args):
    """(CalibImage, StoreResult or None, geometry or None) of a plain or NAND image."""
    raw = calib.read_file(args.image)
    if raw[:len(nand.FILE_MAGIC)] == nand.FILE_MAGIC:
        dev = nand.read_image_bytes(raw, name=args.image)
        res = nand.read_store(dev, name=args.image)
        return res.image, res, dev.geometry
    return calib.read_image(raw, name=args.image), None, None


def _nand_summary(args, img, res, geo, clock):
    rows, cols = img.shape
    sr = res.scan
    print(f"{args.image}: NAND, {geo.blocks} blocks x {geo.pages_per_block} pages: "
          f"{sr.bad_count} bad blocks (markers), data in {nand.blocks_needed(res.words, geo)} "
          f"blocks, {res.pages} pages, the stored block map agrees with the scan")
    print(_timing_line(rows, cols, geo, clock))


def _summary(path, res):
    rows, cols = res.shape
    return (f"{path}: {rows} x {cols} pixels, {calib.HEADER_WORDS + calib.payload_words(rows, cols)}"
            f" words: {res.corrected} corrected, {res.uncorrectable} uncorrectable "
            f"({int(res.defaulted.sum())} pixels with default coefficients), payload CRC "
            f"{'ok' if res.crc_ok else 'MISMATCH'}")


def _report(args):
    clock = _clock(args)                # checked before anything is printed
    res, store, geo = _load_any(args)
    if store is None and args.clock_mhz is not None:
        raise TdicamError(f"--clock-mhz: only for NAND images ({args.image} is a plain "
                          f"calibration image)")
    print(_summary(args.image, res))
    if store is not None:
        _nand_summary(args, res, store, geo, clock)
    return res


def _read(args):
    if args.output is not None:
        check_file(args.output)
    res = _report(args)
    if args.output is not None:
        f = res.fmt
        with open_output(args.output) as fh:    # exactly this name (savez adds .npz)
            np.savez_compressed(
                fh, gain_code=res.gain, offset_code=res.offset,
                gain=res.gain / f.gain_one, offset=res.offset / (1 << f.offset_frac_bits),
                defaulted=res.defaulted)
        print(f"wrote {args.output}: gain_code, offset_code, gain, offset, defaulted")
    return 0


def _check(args):
    res = _report(args)
    return 1 if res.uncorrectable or not res.crc_ok else 0


def _inject(args):
    for name in ("single", "double"):
        p = getattr(args, name)
        if not 0 <= p <= 1:
            raise TdicamError(f"--{name} = {p} is out of range; valid: 0..1")
    if args.single + args.double > 1:
        raise TdicamError(f"--single {args.single:g} + --double {args.double:g} must be at "
                          f"most 1 (probabilities of one word; --single defaults to 0.01)")
    check_range("--seed", args.seed, 0, 2**63 - 1)
    check_range("--bad-blocks", args.bad_blocks, 0, 65535)
    check_file(args.output)
    rng = np.random.default_rng(args.seed)
    raw = calib.read_file(args.image)
    if raw[:len(nand.FILE_MAGIC)] == nand.FILE_MAGIC:
        return _inject_nand(args, nand.read_image_bytes(raw, name=args.image), rng)
    if args.bad_blocks or args.fail_program:
        raise TdicamError(f"{args.image}: --bad-blocks and --fail-program need a NAND image "
                          f"(calib write --nand)")
    words = calib.image_words(raw, args.image)
    calib.read_image(words, name=args.image)    # refuse an image the reader would refuse
    out, k = calib.inject_flips(rng, words, p_single=args.single,
                                p_double=args.double, skip_header=not args.header)
    with open_output(args.output) as fh:
        fh.write(out.tobytes())
    print(f"wrote {args.output}: {int((k == 1).sum())} words with 1 flipped bit, "
          f"{int((k == 2).sum())} with 2, of {len(words)}")
    return 0


def _block_list(text, geo):
    try:
        out = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise TdicamError(f"--fail-program must be comma-separated block numbers, got "
                          f"{text!r}") from None
    for b in out:
        check_range("--fail-program block", b, 1, geo.blocks - 1)
    return out


def _inject_nand(args, dev, rng):
    geo = dev.geometry
    if args.header:
        raise TdicamError("--header is for plain images; a NAND image's header words stay "
                          "clean")
    fail = _block_list(args.fail_program, geo)
    free = [b for b in range(1, geo.blocks) if not dev.is_bad(b)]
    if args.bad_blocks > len(free):
        raise TdicamError(f"--bad-blocks {args.bad_blocks}: only {len(free)} good blocks "
                          f"left after block 0")
    new_bad = rng.choice(free, args.bad_blocks, replace=False) if args.bad_blocks else []
    flips = (args.single, args.double) if args.single or args.double else None
    out, k = nand.relayout(dev, bad_blocks=new_bad, fail_program=fail, flips=flips, rng=rng,
                           name=args.image)
    nand.save_image(out, args.output)
    print(f"wrote {args.output}: NAND image, {len(new_bad)} more bad blocks "
          f"({len(out.bad_blocks())} in all, {len(out.grown)} grown by program failures), "
          f"{int((k == 1).sum())} words with 1 flipped bit, {int((k == 2).sum())} with 2, "
          f"of {len(k)}")
    return 0
