"""The ECC-protected calibration store as files: write gain/offset maps into a flash image,
read and check an image, inject faults (``tdicam calib write|read|check|inject``).

An image is either the plain word image of :mod:`tdicam.model.calib` (header, payload of
72-bit SECDED words, CRC) or the NAND part as the camera stores it
(:mod:`tdicam.model.nand_store`: pages with spare areas, bad blocks skipped and marked,
block map in block 0), recognised by its magic. Every function returns the lines it has to
say (the command prints them) and raises :class:`~tdicam.errors.TdicamError` with one line
naming the file or option for bad input.

Layer: a service; imports the block registry (the nuc block's parameter checks), the golden
models and the leaves.
"""

import contextlib
import os
import zipfile

import numpy as np

from tdicam import blocks
from tdicam.errors import TdicamError, check_range
from tdicam.files import check_file, open_output
from tdicam.model import calib, nand_store
from tdicam.model.nuc import NucFormat

__all__ = ["load_maps", "write", "load_image", "report", "save_maps", "inject",
           "check_not_input", "controller_clock_hz"]

#: What np.load raises on a file that is not (or no longer, truncated) a numpy file.
_NOT_NUMPY = (ValueError, EOFError, zipfile.BadZipFile)
#: The first bytes of a .npy file and of a .npz (a zip archive; an empty one: PK\x05\x06).
_NUMPY_MAGIC = (b"\x93NUMPY", b"PK\x03\x04", b"PK\x05\x06")


def _why(exc):
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    if "pickle" in text:            # numpy's advice to load untrusted pickles: never given
        return "it holds pickled Python objects, which tdicam never loads"
    return text


def _check_numpy_file(fh, path):
    """A one-line error unless the open file ``fh`` starts as a .npy or .npz file does
    (numpy would try a text file as a pickle and suggest loading it unsafely)."""
    head = fh.read(6)
    fh.seek(0)
    if not head.startswith(_NUMPY_MAGIC):
        raise TdicamError(f"{path}: not a numpy .npz or .npy file (it does not start with "
                          f"either signature)")


@contextlib.contextmanager
def _numpy_file(path, kind):
    """Reading numpy file ``path``: an unreadable file or one numpy cannot parse is a
    one-line error naming it as not a ``kind``."""
    try:
        yield
    except TdicamError:             # a ValueError too: ours, already one line
        raise
    except OSError as exc:
        raise TdicamError(f"{path}: cannot read ({exc.strerror})") from None
    except _NOT_NUMPY as exc:
        raise TdicamError(f"{path}: not a {kind} ({_why(exc)})") from None


def _load_array(path, what):
    with _numpy_file(path, "numpy array file"), open(path, "rb") as fh:
        _check_numpy_file(fh, path)
        a = np.load(fh, allow_pickle=False)
        if isinstance(a, np.lib.npyio.NpzFile):
            raise TdicamError(f"{path}: expected a .npy array for {what}, got an .npz")
        return a


def load_maps(maps=None, gain=None, offset=None):
    """(gain, offset) arrays from ``maps`` (an .npz with arrays ``gain`` and ``offset``) or
    from two .npy files ``gain`` and ``offset``; never unpickles."""
    if maps and (gain or offset):
        raise TdicamError("give either MAPS.npz or --gain/--offset, not both")
    if maps:
        with _numpy_file(maps, "numpy .npz file"):
            with open(maps, "rb") as fh:
                _check_numpy_file(fh, maps)
            z = np.load(maps, allow_pickle=False)
            if not isinstance(z, np.lib.npyio.NpzFile):     # a .npy: one array
                raise TdicamError(f"{maps}: expected an .npz with arrays 'gain' and "
                                  f"'offset', got one array (give two .npy files as --gain "
                                  f"G.npy --offset O.npy)")
            with z:
                missing = [k for k in ("gain", "offset") if k not in z.files]
                if missing:
                    raise TdicamError(f"{maps}: no array {missing[0]!r} (has: "
                                      f"{', '.join(z.files) or 'none'})")
                return z["gain"], z["offset"]
    if not (gain and offset):
        raise TdicamError("give MAPS.npz, or both --gain G.npy and --offset O.npy")
    return _load_array(gain, "gain"), _load_array(offset, "offset")


def check_not_input(output, *inputs):
    """-o must not name a file being read: it would be replaced by what is made from it."""
    for name in inputs:
        try:
            same = name is not None and os.path.samefile(output, name)
        except OSError:                 # one of them does not exist (yet)
            same = False
        if same:
            raise TdicamError(f"-o {output}: is the input file {name}; give another file "
                              f"name")


def controller_clock_hz(clock_mhz=None):
    """The NAND controller clock in Hz: ``clock_mhz`` (checked, 1..1000) or the default."""
    if clock_mhz is None:
        return nand_store.CONTROLLER_CLOCK_HZ
    return check_range("--clock-mhz", clock_mhz, 1, 1000, integer=False) * 1e6


def _timing_line(rows, cols, geometry, clock_hz):
    t = nand_store.timing(rows, cols, geometry, clock_hz=clock_hz)
    return (f"gateware at {clock_hz / 1e6:g} MHz (t_R {geometry.t_r_s * 1e6:g} us = "
            f"{t.busy_cycles} clocks): power-up scan of {geometry.blocks} blocks "
            f"{t.scan_s * 1e3:.1f} ms, calibration load of {t.pages} pages in {t.blocks} "
            f"blocks {t.load_s * 1e3:.1f} ms")


def write(output, *, maps=None, gain=None, offset=None, codes=False, gain_int_bits,
          gain_frac_bits, offset_bits, offset_frac_bits, nand_image=False, blocks_=None,
          pages_per_block=None, clock_mhz=None):
    """Pack gain/offset maps (real values, or the format's integer codes with ``codes``)
    into the flash image ``output`` (a NAND image with ``nand_image``, geometry
    ``blocks_`` x ``pages_per_block`` of the MT29F4G08 by default); returns the lines
    describing what was written."""
    # the format is the nuc block's: its parameters check the flags under their names
    blocks.get("nuc").resolve({"gain_int_bits": gain_int_bits, "gain_frac_bits": gain_frac_bits,
                               "offset_bits": offset_bits, "offset_frac_bits": offset_frac_bits})
    fmt = NucFormat(gain_int_bits, gain_frac_bits, offset_bits, offset_frac_bits)
    fmt._check_slots()
    if not nand_image:              # NAND geometry without --nand was ignored silently
        for opt, v in (("--blocks", blocks_), ("--pages-per-block", pages_per_block),
                       ("--clock-mhz", clock_mhz)):
            if v is not None:
                raise TdicamError(f"{opt}: only with --nand (a NAND image)")
    check_not_input(output, maps, gain, offset)
    check_file(output)
    g_map, o_map = load_maps(maps, gain, offset)
    for what, a in (("gain", g_map), ("offset", o_map)):
        if a.dtype.kind not in "iuf":
            raise TdicamError(f"the {what} map must hold real numbers, got dtype {a.dtype}")
    if g_map.ndim != 2 or g_map.shape != o_map.shape:
        raise TdicamError(f"gain and offset must be 2-D maps of one shape; got {g_map.shape} "
                          f"and {o_map.shape}")
    if not g_map.size:
        raise TdicamError(f"the gain and offset maps are empty ({g_map.shape[0]} x "
                          f"{g_map.shape[1]} pixels)")
    if codes:
        g, o = fmt.check_coeffs(g_map, o_map)
    else:
        g, o = calib.codes_from_values(g_map, o_map, fmt)
    rows, cols = g.shape
    words = calib.encode_image(g, o, fmt)
    if nand_image:
        return _write_nand(output, words, rows, cols, blocks_, pages_per_block, clock_mhz)
    with open_output(output) as fh:
        fh.write(words.tobytes())
    n = words.nbytes
    return [f"wrote {output}: {rows} x {cols} pixels, gain Q{fmt.gain_int_bits}."
            f"{fmt.gain_frac_bits}, offset {fmt.offset_bits} bits ({fmt.offset_frac_bits} "
            f"fraction), {n // calib.WORD_BYTES} flash words of 72 bits, {n} bytes"]


def _write_nand(output, words, rows, cols, blocks_, pages_per_block, clock_mhz):
    try:
        g = nand_store.MT29F4G08
        geo = nand_store.Geometry(
            pages_per_block=g.pages_per_block if pages_per_block is None else pages_per_block,
            blocks=g.blocks if blocks_ is None else blocks_)
    except TdicamError as exc:
        raise TdicamError(f"--nand geometry: {exc}") from None
    clock = controller_clock_hz(clock_mhz)
    dev = nand_store.write_store(words, geo)
    n = nand_store.save_image(dev, output)
    return [f"wrote {output}: NAND image, {rows} x {cols} pixels, {len(words)} flash words "
            f"in {-(-len(words) // geo.words_per_page)} pages of {geo.page_bytes}+"
            f"{geo.spare_bytes} bytes, part of {geo.blocks} blocks x {geo.pages_per_block} "
            f"pages, block map in block 0, {n} bytes",
            _timing_line(rows, cols, geo, clock)]


def load_image(path):
    """(CalibImage, StoreResult or None, geometry or None) of a plain or NAND image."""
    raw = calib.read_file(path)
    if raw[:len(nand_store.FILE_MAGIC)] == nand_store.FILE_MAGIC:
        dev = nand_store.read_image_bytes(raw, name=path)
        res = nand_store.read_store(dev, name=path)
        return res.image, res, dev.geometry
    return calib.read_image(raw, name=path), None, None


def report(path, clock_mhz=None):
    """Decode image ``path``: (the decoded CalibImage, the lines reporting corrected and
    uncorrectable words, the payload CRC and, for a NAND image, the bad-block scan and the
    gateware's power-up scan and load times at ``clock_mhz``)."""
    clock = controller_clock_hz(clock_mhz)     # checked before anything is read
    img, store, geo = load_image(path)
    if store is None and clock_mhz is not None:
        raise TdicamError(f"--clock-mhz: only for NAND images ({path} is a plain "
                          f"calibration image)")
    rows, cols = img.shape
    lines = [f"{path}: {rows} x {cols} pixels, "
             f"{calib.HEADER_WORDS + calib.payload_words(rows, cols)} words: "
             f"{img.corrected} corrected, {img.uncorrectable} uncorrectable "
             f"({int(img.defaulted.sum())} pixels with default coefficients), payload CRC "
             f"{'ok' if img.crc_ok else 'MISMATCH'}"]
    if store is not None:
        lines += [f"{path}: NAND, {geo.blocks} blocks x {geo.pages_per_block} pages: "
                  f"{store.scan.bad_count} bad blocks (markers), data in "
                  f"{nand_store.blocks_needed(store.words, geo)} blocks, {store.pages} pages, the "
                  f"stored block map agrees with the scan",
                  _timing_line(rows, cols, geo, clock)]
    return img, lines


def save_maps(img, output):
    """Write the decoded maps of ``img`` to ``output`` (exactly this name, .npz content):
    gain/offset codes and values and the defaulted mask; returns the line saying so."""
    f = img.fmt
    with open_output(output) as fh:    # exactly this name (savez adds .npz)
        np.savez_compressed(
            fh, gain_code=img.gain, offset_code=img.offset,
            gain=img.gain / f.gain_one, offset=img.offset / (1 << f.offset_frac_bits),
            defaulted=img.defaulted)
    return f"wrote {output}: gain_code, offset_code, gain, offset, defaulted"


def inject(image, output, *, single=0.01, double=0.0, header=False, bad_blocks=0,
           fail_program="", seed=1):
    """Flip random bits in image ``image`` (probability ``single`` / ``double`` per word of
    one / two flips; ``header`` words too) and, in a NAND image, mark ``bad_blocks`` more
    random blocks bad and fail the programs of blocks ``fail_program`` (comma-separated)
    while re-laying the data out; writes ``output`` and returns the line describing it."""
    for name, p in (("single", single), ("double", double)):
        if not 0 <= p <= 1:
            raise TdicamError(f"--{name} = {p} is out of range; valid: 0..1")
    if single + double > 1:
        raise TdicamError(f"--single {single:g} + --double {double:g} must be at "
                          f"most 1 (probabilities of one word; --single defaults to 0.01)")
    check_range("--seed", seed, 0, 2**63 - 1)
    check_range("--bad-blocks", bad_blocks, 0, 65535)
    check_not_input(output, image)
    check_file(output)
    rng = np.random.default_rng(seed)
    raw = calib.read_file(image)
    if raw[:len(nand_store.FILE_MAGIC)] == nand_store.FILE_MAGIC:
        dev = nand_store.read_image_bytes(raw, name=image)
        return _inject_nand(dev, image, output, rng, single, double, header, bad_blocks,
                            fail_program)
    if bad_blocks or fail_program:
        raise TdicamError(f"{image}: --bad-blocks and --fail-program need a NAND image "
                          f"(calib write --nand)")
    words = calib.image_words(raw, image)
    calib.read_image(words, name=image)    # refuse an image the reader would refuse
    out, k = calib.inject_flips(rng, words, p_single=single, p_double=double,
                                skip_header=not header)
    with open_output(output) as fh:
        fh.write(out.tobytes())
    return (f"wrote {output}: {int((k == 1).sum())} words with 1 flipped bit, "
            f"{int((k == 2).sum())} with 2, of {len(words)}")


def _block_list(text, geo):
    try:
        out = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise TdicamError(f"--fail-program must be comma-separated block numbers, got "
                          f"{text!r}") from None
    for b in out:
        check_range("--fail-program block", b, 1, geo.blocks - 1)
    return out


def _inject_nand(dev, image, output, rng, single, double, header, bad_blocks, fail_program):
    geo = dev.geometry
    if header:
        raise TdicamError("--header is for plain images; a NAND image's header words stay "
                          "clean")
    fail = _block_list(fail_program, geo)
    free = [b for b in range(1, geo.blocks) if not dev.is_bad(b)]
    if bad_blocks > len(free):
        raise TdicamError(f"--bad-blocks {bad_blocks}: only {len(free)} good blocks "
                          f"left after block 0")
    new_bad = rng.choice(free, bad_blocks, replace=False) if bad_blocks else []
    flips = (single, double) if single or double else None
    out, k = nand_store.relayout(dev, bad_blocks=new_bad, fail_program=fail, flips=flips, rng=rng,
                                 name=image)
    nand_store.save_image(out, output)
    return (f"wrote {output}: NAND image, {len(new_bad)} more bad blocks "
            f"({len(out.bad_blocks())} in all, {len(out.grown)} grown by program failures), "
            f"{int((k == 1).sum())} words with 1 flipped bit, {int((k == 2).sum())} with 2, "
            f"of {len(k)}")
