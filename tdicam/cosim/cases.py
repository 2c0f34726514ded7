"""Co-simulate a block's golden cases (``tdicam sim``, ``tdicam demo``)."""

from tdicam import blocks
from tdicam.errors import TdicamError
from tdicam.cosim.run import run_golden_case

__all__ = ["run_cases"]


def run_cases(block, *, sim, mode, idle, backpressure, seed, cases=None, report=print,
              wave_dir=None):
    """Co-simulate golden cases of ``block`` (all, or the names in ``cases``; per-beat mode
    skips ``fast-only`` ones); returns a list of row dicts (one per case), each also passed
    to ``report``. ``wave_dir``: where a mismatching case's waveform goes (its row's
    ``waveform`` and ``message`` give the path)."""
    blk = blocks.get(block)
    if blk.to_beats is None:
        raise TdicamError(f"block {block} has no stream co-simulation; run its cocotb tests "
                          f"(pytest cocotb_tests/test_{block}.py)")
    names = [c.name for c in blk.cases()]
    for c in cases or []:
        if c not in names:
            raise TdicamError(f"block {block} has no golden case {c!r}; valid: "
                              f"{', '.join(names)}")
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
