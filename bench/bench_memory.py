"""Memory estimate of ``tdicam run`` against the measured peak: one row per scene.

Each scene runs as ``tdicam run SCENE --no-rtl`` in a child process of its own, which
reports its peak resident set (``resource.getrusage(RUSAGE_SELF).ru_maxrss``) when done;
beside it, the estimate :func:`tdicam.engine.budget.estimate` makes from the scene before
any work, and their ratio. By default the bundled scenes (``scenes/*.toml``) as they are,
then a few larger variants (``--lines``, ``--fidelity``) where the arrays, not the
libraries, dominate. The RTL co-simulation (``[run.rtl]``) runs its simulator in processes
of its own and is left out.

    python bench/bench_memory.py [--quick] [SCENE[:LINES[:FIDELITY]] ...]
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from tdicam.bench.util import machine, print_table

ROOT = Path(__file__).resolve().parents[1]
#: Larger variants: (scene, lines, fidelity).
LARGE = [("orbit_600km_1m_96", 8192, "fast"), ("orbit_600km_1m_96", 512, "exact"),
         ("ning2019_chain", 1024, None), ("zhou2008_interline_ccd_charge_4", 4096, None),
         ("yuan2013_lab_turntable_8", 2048, "exact")]

_CHILD = r"""
import json, resource, sys
from tdicam.cli import main
scene, out, lines, fid = sys.argv[1:5]
argv = ["run", scene, "-o", out, "--no-rtl"]
argv += ["--lines", lines] if lines != "-" else []
argv += ["--fidelity", fid] if fid != "-" else []
code = main(argv)
print(json.dumps({"code": code,
                  "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}))
"""


def measure(scene, lines=None, fidelity=None):
    """(estimate, measured peak RSS) in bytes of ``tdicam run SCENE`` in a child process."""
    from tdicam.engine.budget import estimate
    from tdicam.scene.loader import load_scene
    over = {} if lines is None else {"run": {"lines": lines}}
    est = estimate(load_scene(scene, overrides=over), fidelity=fidelity, rtl=False).peak_bytes
    with tempfile.TemporaryDirectory() as tmp:
        r = subprocess.run([sys.executable, "-c", _CHILD, str(scene), f"{tmp}/o",
                            "-" if lines is None else str(lines), fidelity or "-"],
                           capture_output=True, text=True, check=False)
    if r.returncode != 0:
        raise SystemExit(f"{scene}: the run failed: {r.stderr.strip().splitlines()[-1:]}")
    got = json.loads(r.stdout.strip().splitlines()[-1])
    return est, got["peak"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", metavar="SCENE[:LINES[:FIDELITY]]",
                    help="scenes to measure (default: every bundled scene, then larger "
                         "variants)")
    ap.add_argument("--quick", action="store_true", help="the bundled scenes only")
    a = ap.parse_args()
    if a.cases:
        cases = []
        for c in a.cases:
            parts = c.split(":")
            cases.append((Path(parts[0]), int(parts[1]) if len(parts) > 1 and parts[1] else None,
                          parts[2] if len(parts) > 2 else None))
    else:
        cases = [(p, None, None) for p in sorted((ROOT / "scenes").glob("*.toml"))]
        if not a.quick:
            cases += [(ROOT / "scenes" / f"{s}.toml", n, f) for s, n, f in LARGE]
    print(machine())
    load0 = os.getloadavg()[0]
    rows = []
    for scene, lines, fid in cases:
        est, got = measure(scene, lines, fid)
        rows.append({"scene": scene.stem, "lines": str(lines or "default"),
                     "fidelity": fid or "scene's", "est": est / 2**20, "got": got / 2**20,
                     "ratio": est / got})
        print(f"  {scene.stem} {lines or ''} {fid or ''}: estimate {est / 2**20:.0f} MiB, "
              f"measured {got / 2**20:.0f} MiB", file=sys.stderr)
    print_table(rows, [("scene", "scene", "s"), ("lines", "lines", "s"),
                       ("fidelity", "fidelity", "s"), ("est", "estimate (MiB)", ".0f"),
                       ("got", "peak RSS (MiB)", ".0f"), ("ratio", "estimate / peak", ".2f")])
    print(f"load average (1 min) {load0:.2f} at the start, {os.getloadavg()[0]:.2f} at the end "
          f"(peak RSS does not depend on it); estimate / peak from "
          f"{min(r['ratio'] for r in rows):.2f} to {max(r['ratio'] for r in rows):.2f}")


if __name__ == "__main__":
    main()
