"""Benchmark: HG/LG HDR merge at every fidelity level (`tdicam bench hdr`).

numpy golden model, Amaranth Python simulator, Icarus and Verilator per-beat and fast, on the
same input, every simulator row compared bit for bit with the golden model; the generic
implementation (driven by the block registry) is :mod:`tdicam.bench`.

    python bench/bench_hdr.py [--quick] [--repeat 3] [--sims icarus,verilator] [--json FILE]
"""

import sys

from tdicam.bench import script

run, main = script("hdr")

if __name__ == "__main__":
    sys.exit(main())
