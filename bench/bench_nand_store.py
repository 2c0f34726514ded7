"""NAND calibration store: power-up scan and calibration load times of the gateware (from
its cycle model, :func:`tdicam.model.nand_store.timing`, exact against the Amaranth simulation in
tests/test_nand_store.py) for a 4 Gb x8 part (2,048 + 64-byte pages, 64 pages per block, 4,096
blocks, t_R = 25 us), and the wall time of the numpy model storing and reading back a
1280 x 1024 calibration with 100 bad blocks.

Run: ``python bench/bench_nand_store.py [--clock-mhz 50 100]``.
"""

import argparse
import time

import numpy as np

from tdicam.blocks.calib import random_codes
from tdicam.model import calib, nand_store
from tdicam.model.nuc import DEFAULT_FORMAT

SENSORS = (("1280 x 1024", 1024, 1280), ("GMAX0504 3800 x 5144 (19.5 Mpixel)", 3800, 5144),
           ("5120 x 5120 (26.2 Mpixel)", 5120, 5120))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clock-mhz", type=float, nargs="+", default=[50.0, 100.0])
    args = ap.parse_args(argv)
    geo = nand_store.MT29F4G08
    print(f"part: {geo.blocks} blocks x {geo.pages_per_block} pages x {geo.page_bytes}+"
          f"{geo.spare_bytes} bytes, t_R {geo.t_r_s * 1e6:g} us; {geo.words_per_page} "
          f"ECC words (9 bytes) per page; a bus cycle = 2 controller clocks")
    print(f"{'sensor':38s} {'clock':>7s} {'words':>11s} {'pages':>7s} {'blocks':>6s} "
          f"{'scan ms':>8s} {'load s':>8s} {'total s':>8s}")
    for label, rows, cols in SENSORS:
        for mhz in args.clock_mhz:
            t = nand_store.timing(rows, cols, geo, clock_hz=mhz * 1e6)
            n = calib.HEADER_WORDS + calib.payload_words(rows, cols)
            print(f"{label:38s} {mhz:5g}MHz {n:11,d} {t.pages:7,d} {t.blocks:6d} "
                  f"{t.scan_s * 1e3:8.1f} {t.load_s:8.3f} {t.scan_s + t.load_s:8.3f}")
    rng = np.random.default_rng(1)
    g, o = random_codes(rng, 1024, 1280, DEFAULT_FORMAT)
    words = calib.encode_image(g, o, DEFAULT_FORMAT)
    bad = rng.choice(np.arange(1, geo.blocks), 100, replace=False)
    t0 = time.perf_counter()
    dev = nand_store.write_store(words, geo, bad_blocks=bad)
    t1 = time.perf_counter()
    res = nand_store.read_store(dev)
    t2 = time.perf_counter()
    ok = bool((res.image.gain == g).all() and (res.image.offset == o).all())
    print(f"numpy model, 1280 x 1024 with 100 bad blocks: write {t1 - t0:.2f} s, power-up scan "
          f"+ read {t2 - t1:.2f} s, {len(dev.pages):,d} pages stored, maps back exact: {ok}")


if __name__ == "__main__":
    main()
