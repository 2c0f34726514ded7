"""Deterministic Verilog (and RTLIL) generation for registered blocks.

:func:`generate` (``tdicam verilog BLOCK``, ``tdicam demo``) starts the text with a comment
header (:func:`header`) naming the tdicam version, the block and its parameters, so a file
found later says what made it; the header holds no paths and no timestamps, so the text
stays byte-identical for the same tool versions and parameters. :func:`convert` (the
co-simulation harnesses' tops) emits the bare text unless given a header.

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
from amaranth.hdl import _ir

from tdicam import blocks
from tdicam.version import __version__
from tdicam.files import write_file
from tdicam.hdl.util import NO_INIT, NO_RW_CHECK

__all__ = ["generate", "write", "convert", "header", "rtlil", "NO_RW_CHECK", "NO_INIT"]


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


def _create_missing_domains(self, missing_domain, *, platform=None):
    # Amaranth 0.5's Fragment._create_missing_domains, with the missing domains taken in
    # name order: it iterates a set of names, so a design with two undefined domains (the
    # lanes' word clock and the processing clock) had its clock ports in an order that
    # changed with PYTHONHASHSEED from one run to the next
    from amaranth.hdl import _cd
    from amaranth.hdl._xfrm import DomainCollector
    collector = DomainCollector()
    collector(self)
    new_domains = []
    for domain_name in sorted(collector.used_domains - collector.defined_domains):
        if domain_name == "comb":
            continue
        value = missing_domain(domain_name)
        if value is None:
            raise _cd.DomainError(f"Domain '{domain_name}' is used but not defined")
        if type(value) is _cd.ClockDomain:
            self.add_domains(value)
            new_domains.append(value)
        else:
            new_fragment = _ir.Fragment.get(value, platform=platform)
            if domain_name not in new_fragment.domains:
                defined = new_fragment.domains.keys()
                raise _cd.DomainError(
                    "Fragment returned by missing domain callback does not define "
                    "requested domain '{}' (defines {})."
                    .format(domain_name, ", ".join(f"'{n}'" for n in defined)))
            self.add_subfragment(new_fragment, f"cd_{domain_name}")
            self.add_domains(new_fragment.domains.values())
    return new_domains


_ir.Fragment._create_missing_domains = _create_missing_domains


def rtlil(top, name):
    """RTLIL text of an elaboratable ``top`` as module ``name``: the netlist that
    :func:`convert` writes out as Verilog and ``tdicam synth`` synthesizes (deterministic,
    memory attributes applied, see the module notes)."""
    return _apply_memory_attrs(_rtlil.convert(top, name=name, emit_src=False))


def header(name, params):
    """Comment lines naming the tdicam version, the block ``name`` and its ``params``.

    ``params`` is a mapping, printed in its order as ``key=value``; a value that is itself
    a mapping (a pipeline step's parameters) gets a line of its own, ``// key: k=v, ...``.
    Nothing that depends on the machine, the path or the time goes in.
    """
    params = dict(params or {})
    flat = {k: v for k, v in params.items() if not isinstance(v, dict)}
    lines = [f"// Generated by tdicam {__version__}: block {name}",
             "// parameters: " + (_items(flat) if flat else "(none)")]
    lines += [f"// {k}: {_items(v)}" for k, v in params.items() if isinstance(v, dict)]
    return "\n".join(lines) + "\n"


def _items(mapping):
    return ", ".join(f"{k}={_show(v)}" for k, v in mapping.items())


def _show(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_show(x) for x in v) + "]"
    return str(v).replace("\n", " ")


def generate(block, params=None):
    """Verilog text of ``block``'s top with checked ``params``; top module named after it.

    Starts with :func:`header`. Byte-identical for the same tool versions and parameters:
    no source locations (``emit_src=False``), hence no absolute paths, and no timestamps.
    """
    blk = blocks.get(block) if isinstance(block, str) else block
    resolved = blk.resolve(params)
    # a parameter added later is named only away from its default (``ppc=1`` is not), so
    # the text of a design that predates it stays byte-identical
    return convert(blk.build(resolved), blk.name,
                   header=header(blk.name, blk.recorded(resolved)))


def convert(top, name, *, header=None):
    """Verilog text of an elaboratable ``top`` as module ``name`` (deterministic; the netlist
    of :func:`rtlil`), after the comment ``header`` when one is given (see :func:`header`)."""
    text = _verilog._convert_rtlil_text(rtlil(top, name), strip_internal_attrs=True)
    return (header or "") + text


def write(block, path, params=None):
    """Write :func:`generate`'s text to ``path`` (one-line error if it cannot be written)."""
    text = generate(block, params)
    write_file(Path(path), text)
    return text
