"""``verilator --lint-only -Wall`` of generated Verilog, with every waiver explained.

Amaranth's Verilog (through yosys' ``write_verilog``) trips three ``-Wall`` style rules that
say nothing about the design; they are waived here, each with its reason. Anything else
Verilator reports is a finding.
"""

import os
import subprocess
import tempfile
from pathlib import Path

from tdicam.hw.tools import tool_env

__all__ = ["WAIVERS", "lint"]

WAIVERS = {
    "DECLFILENAME": "the user names the output file (-o FILE.v); the module is named after "
                    "the block, not the file",
    "UNUSEDSIGNAL": "Amaranth emits a named wire for every struct field (data, first, last, "
                    "data[k]) as a debugging view, and tdata carries zero padding bits up to "
                    "a byte boundary (AXI4-Stream video); both are unused by design",
    "PROCASSINIT": "yosys declares registers with their reset value as initializer "
                   "(reg x = 0) and assigns them in always blocks: the FPGA power-up value",
    "WIDTHEXPAND": "yosys' write_verilog prints each arithmetic/compare operand at its own "
                   "width (constants shrunk to their minimal width) and relies on Verilog's "
                   "standard context extension; Amaranth has already fixed every width and "
                   "signedness, so the extension is the intended one",
}


def lint(verilog_path):
    """Lint one file; returns the list of remaining warning/error lines (empty = clean)."""
    tool_env("verilator")
    with tempfile.TemporaryDirectory() as tmp:
        vlt = Path(tmp) / "waivers.vlt"
        vlt.write_text("`verilator_config\n" + "".join(
            f"lint_off -rule {rule}\n" for rule in sorted(WAIVERS)))
        proc = subprocess.run(
            ["verilator", "--lint-only", "-Wall", str(vlt), str(verilog_path)],
            capture_output=True, text=True, env=os.environ)
    return [line for line in (proc.stdout + proc.stderr).splitlines()
            if line.startswith("%")]
