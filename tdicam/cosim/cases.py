"""Co-simulate a block's golden cases (``tdicam sim``, ``tdicam demo``), and say which cases
a run leaves out and which simulator suits each.

The simulator for ``tdicam sim --sim auto`` (:func:`pick_simulators`): Icarus for a case of
at most :data:`AUTO_ICARUS_VALUES` input values (it starts at once and runs a few hundred to
a few thousand pixels a second per beat), Verilator above (a model build of about a minute
on this project's 2-core machine, cached per parameter set, then tens to hundreds of times
Icarus's speed).
"""

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.cosim.run import run_golden_case

__all__ = ["run_cases", "check_cases", "AUTO_ICARUS_VALUES", "case_values", "pick_simulators", "skipped"]

#: Largest case (input values) ``--sim auto`` gives Icarus: at ~500 values a second per
#: beat, about the 40 s a Verilator build takes.
AUTO_ICARUS_VALUES = 20_000


def check_cases(blk, cases):
    """Every name in ``cases`` is one of ``blk``'s golden cases, or a one-line
    :class:`TdicamError` listing them."""
    names = [c.name for c in blk.cases()]
    for c in cases or []:
        if c not in names:
            raise TdicamError(f"block {blk.name} has no golden case {c!r}; valid: "
                              f"{', '.join(names)}")


def case_values(block, case) -> int:
    """Input values of a stored golden case (its largest array that is not an output), from
    the manifest's shapes (no case file is read)."""
    import math
    from tdicam.cosim import golden
    shapes = golden.case_shapes(block, case)
    return max((math.prod(sh) for k, sh in shapes.items() if not k.startswith("out")),
               default=0)


def skipped(block, mode, cases=None) -> list[str]:
    """The golden cases a run in ``mode`` leaves out: per beat, the ``fast-only`` ones
    (fast mode runs them)."""
    blk = blocks.get(block)
    return [c.name for c in blk.cases() if (not cases or c.name in cases)
            and mode == "beat" and "fast-only" in c.tags]


def pick_simulators(block, mode, cases=None) -> dict[str, list[str]]:
    """``{simulator: [case, ...]}`` for ``--sim auto``: Icarus for a case of at most
    :data:`AUTO_ICARUS_VALUES` input values, Verilator above (in the cases' order; the
    cases ``mode`` leaves out are in none)."""
    blk = blocks.get(block)
    check_cases(blk, cases)
    out = {"icarus": [], "verilator": []}
    left = set(skipped(block, mode, cases))
    for c in blk.cases():
        if (cases and c.name not in cases) or c.name in left:
            continue
        out["icarus" if case_values(blk, c.name) <= AUTO_ICARUS_VALUES
            else "verilator"].append(c.name)
    return {k: v for k, v in out.items() if v}


def run_cases(block, *, sim, mode, idle, backpressure, seed, cases=None, report=print,
              wave_dir=None):
    """Co-simulate golden cases of ``block`` (all, or the names in ``cases``; per-beat mode
    skips ``fast-only`` ones); returns a list of row dicts (one per case), each also passed
    to ``report``. ``wave_dir``: where a mismatching case's waveform goes (its row's
    ``waveform`` and ``message`` give the path)."""
    blk = blocks.get(block)
    if blk.streams.to_beats is None:
        raise TdicamError(f"block {block} has no stream co-simulation; run its cocotb tests "
                          f"(pytest cocotb_tests/test_{block}.py)")
    check_cases(blk, cases)
    rows = []
    for case in blk.cases():
        if cases and case.name not in cases:
            continue
        if mode == "beat" and "fast-only" in case.tags:
            continue
        run = run_golden_case(blk, case.name, sim=sim, mode=mode, idle=idle,
                              backpressure=backpressure, seed=seed, wave_dir=wave_dir)
        row = {"case": case.name, **run.row()}
        rows.append(row)
        report(row)
    return rows
