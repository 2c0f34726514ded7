"""Benchmark: SECDED (72,64) encoder/decoder words/s in the golden model and co-simulation.

Golden model: numpy ``encode``/``decode`` of random words (decoder input with 0, 1 or 2
flipped bits). Co-simulation: the generated Verilog of the stream wrappers
(``secded_enc``/``secded_dec --stream 1``) in fast mode, no stalls, bit-exact comparison
with the golden model included in every row; the decoder runs the exhaustive sweep
(every single and double flip of sweep words). Wall time includes simulator start-up
(~0.5-1 s); build time is reported separately (cached after the first run).

    python bench/bench_ecc.py [--words 1000000] [--sweep-words 64] [--repeat 3]
"""

import argparse
import resource

import numpy as np

from tdicam import blocks, cosim
from tdicam.bench.util import machine, median_time, print_table
from tdicam.blocks.secded_dec import dec_beats, sweep_codes
from tdicam.blocks.secded_enc import enc_beats
from tdicam.model import ecc


def _random(n, seed=1):
    rng = np.random.default_rng(seed)
    data = rng.integers(0, 1 << 64, n, dtype=np.uint64)
    k = rng.integers(0, 3, n)
    pos = np.where(np.arange(2)[None, :] < k[:, None], rng.integers(0, 72, (n, 2)), -1)
    pos[:, 1] = np.where(pos[:, 1] == pos[:, 0], (pos[:, 0] + 1) % 72, pos[:, 1])
    pos[k < 2, 1] = -1
    return data, *ecc.flip(data, ecc.encode(data), pos)


def _child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(words=1_000_000, sweep_words=64, enc_words=200_000, repeat=3, sims=("verilator",),
        registered=False):
    """Rows of {unit, engine, words, seconds, words_s, cpu_s, words_cpu_s, mismatches,
    build_s}: wall time and simulator CPU time (child processes; robust on a shared machine;
    numpy rows: wall time)."""
    out = []
    data, d, c = _random(words)
    t, _ = median_time(lambda: ecc.encode(data), repeat)
    out.append({"unit": "encoder", "engine": "numpy golden", "words": words, "seconds": t,
                "words_s": words / t, "cpu_s": t, "words_cpu_s": words / t, "mismatches": 0})
    t, _ = median_time(lambda: ecc.decode(d, c), repeat)
    out.append({"unit": "decoder", "engine": "numpy golden", "words": words, "seconds": t,
                "words_s": words / t, "cpu_s": t, "words_cpu_s": words / t, "mismatches": 0})
    sd, sc, _ = sweep_codes(ecc.sweep_words(sweep_words))
    jobs = (("encoder", "secded_enc", enc_beats(data[:enc_words])),
            ("decoder", "secded_dec", dec_beats(sd, sc)))
    for sim in sims:
        for unit, block, (stim, exp) in jobs:
            params = blocks.get(block).resolve({"stream": True, "registered": registered})
            runs, cpu = [], []
            for k in range(repeat):
                c0 = _child_cpu()
                runs.append(cosim.run_stream(block, params, stim, n_out=len(exp), sim=sim,
                                             mode="fast", seed=k + 1))
                cpu.append(_child_cpu() - c0)
            cmp = cosim.compare(runs[-1].out, exp)
            t = float(np.median([r.wall for r in runs]))
            c = float(np.median(cpu[1:] if len(cpu) > 1 else cpu))  # first may build
            out.append({"unit": unit, "engine": f"{sim} fast", "words": len(exp),
                        "seconds": t, "words_s": len(exp) / t, "cpu_s": c,
                        "words_cpu_s": len(exp) / c, "mismatches": cmp.mismatches,
                        "build_s": max(r.build_time for r in runs),
                        "cycles": runs[-1].cycles})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--words", type=int, default=1_000_000)
    ap.add_argument("--sweep-words", type=int, default=64)
    ap.add_argument("--enc-words", type=int, default=200_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--icarus", action="store_true", help="also co-simulate on Icarus")
    a = ap.parse_args(argv)
    sims = ("verilator", "icarus") if a.icarus else ("verilator",)
    rows = run(words=a.words, sweep_words=a.sweep_words, enc_words=a.enc_words,
               repeat=a.repeat, sims=sims)
    print(machine())
    print_table(rows, [("unit", "unit", "s"), ("engine", "engine", "s"),
                       ("words", "words", ",d"), ("seconds", "median s", ".3f"),
                       ("words_s", "words/s", ",.0f"), ("cpu_s", "sim CPU s", ".3f"),
                       ("words_cpu_s", "words/CPU s", ",.0f"), ("mismatches", "mismatches", "d"),
                       ("build_s", "build s", ".1f")],
                title=f"SECDED (72,64): golden on {a.words:,} random words; co-simulation "
                      f"fast mode, no stalls, encoder on {a.enc_words:,} words, decoder on "
                      f"the {a.sweep_words}-word exhaustive sweep; medians of {a.repeat} runs "
                      f"(sim wall time incl. start-up)")


if __name__ == "__main__":
    main()
