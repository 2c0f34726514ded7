"""Deterministic Verilog (and RTLIL) generation for registered blocks.

Two memory attributes of ``amaranth.lib.memory.Memory`` (``attrs=``) are applied here, in
the one netlist that ``tdicam verilog`` writes, ``tdicam synth`` synthesizes and the
simulators run:

* :data:`NO_RW_CHECK` (yosys' own ``no_rw_check``): the design never uses a read of an
  address written in the same cycle, so a read/write collision may return anything. Kept on
  the memory (yosys ``memory_dff`` honours it when it reads the Verilog) and set on the
  memory's synchronous read ports (``COLLISION_X_MASK``), so yosys' block RAM mapping adds
  no collision-emulation logic (a comparator, a bypass register and a multiplexer per read
  port) between the block RAM's data output and the logic it feeds.
* :data:`NO_INIT`: the design never uses a word before writing it, so the memory has no
  initial value: no ``initial`` block spelling out zeros word by word (a 121,600-line block
  for the TDI partial sums, which yosys' Verilog reader did not finish in 15 minutes).
  Simulators start such a memory undefined (Icarus: x; Verilator: its ``--x-initial``
  value) and the design's outputs do not depend on it.
"""

import re
from pathlib import Path

from amaranth.back import rtlil as _rtlil
from amaranth.back import verilog as _verilog

from . import blocks

__all__ = ["generate", "write", "convert", "rtlil", "NO_RW_CHECK", "NO_INIT"]

NO_RW_CHECK = "no_rw_check"
NO_INIT = "tdicam.no_init"

_MEMORY = re.compile(r"((?:  attribute \\\S+ [^\n]*\n)*)  memory width \d+ size \d+ (\S+)\n")
_CELL = re.compile(r"  cell \$(meminit_v2|memrd_v2) \S+\n(.*?)\n  end\n", re.S)


def _apply_memory_attrs(text):
    """``text`` (RTLIL) with :data:`NO_RW_CHECK` and :data:`NO_INIT` applied per module."""
    out = []
    for chunk in re.split(r"(?m)^(?=module )", text):
        rw, no_init = set(), set()
        for attrs, name in _MEMORY.findall(chunk):
            memid = '"' + name.replace("\\", "\\\\") + '"'
            if f"attribute \\{NO_RW_CHECK} " in attrs:
                rw.add(memid)
            if f"attribute \\{NO_INIT} " in attrs:
                no_init.add(memid)
        if rw or no_init:
            def cell(mo):
                memid = re.search(r"parameter \\MEMID (\S+)", mo[2])[1]
                if mo[1] == "meminit_v2":
                    return "" if memid in no_init else mo[0]
                if memid not in rw:
                    return mo[0]
                return re.sub(r"(parameter \\COLLISION_X_MASK )(\d+)'[01]+",
                              lambda p: f"{p[1]}{p[2]}'{'1' * int(p[2])}", mo[0])
            chunk = _CELL.sub(cell, chunk)
            chunk = re.sub(rf"  attribute \\{re.escape(NO_INIT)} [^\n]*\n", "", chunk)
        out.append(chunk)
    return "".join(out)


def rtlil(top, name):
    """RTLIL text of an elaboratable ``top`` as module ``name``: the netlist that
    :func:`convert` writes out as Verilog and ``tdicam synth`` synthesizes (deterministic,
    memory attributes applied, see the module notes)."""
    return _apply_memory_attrs(_rtlil.convert(top, name=name, emit_src=False))


def generate(block, params=None):
    """Verilog text of ``block``'s top with checked ``params``; top module named after it.

    Byte-identical for the same tool versions and parameters: no source locations
    (``emit_src=False``), hence no absolute paths.
    """
    blk = blocks.get(block) if isinstance(block, str) else block
    return convert(blk.build(params), blk.name)


def convert(top, name):
    """Verilog text of an elaboratable ``top`` as module ``name`` (deterministic)."""
    return _verilog._convert_rtlil_text(rtlil(top, name), strip_internal_attrs=True)


def write(block, path, params=None):
    text = generate(block, params)
    Path(path).write_text(text)
    return text
