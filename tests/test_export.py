"""``tdicam export``: FuseSoC core + self-checking testbench that runs with no tdicam.

The exported testbench is run straight from the export folder with plain ``iverilog`` /
``vvp``, ``verilator --binary`` and ``fusesoc run``: no tdicam import in those processes.
"""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tdicam import blocks
from tdicam.beats import Beats
from tdicam.cosim import codec, tool_env
from tdicam.errors import TdicamError
from tdicam.export.chain import STAGES
from tdicam.export.harness import export_block

FULL = os.environ.get("TDICAM_FULL") == "1"
ROOT = Path(__file__).resolve().parents[1]
CHAIN = str(ROOT / "scenes" / "ning2019_chain.toml")


def cli(*args):
    return subprocess.run([sys.executable, "-m", "tdicam", *args], capture_output=True,
                          text=True)


def icarus(folder):
    """Compile and run the exported testbench with Icarus from its vectors folder."""
    vec = Path(folder) / "vectors"
    rtl = sorted(str(p) for p in (Path(folder) / "rtl").glob("*.v"))
    subprocess.run(["iverilog", "-g2005", "-o", "tb.vvp", "../tb/tdicam_tb.v", *rtl],
                   cwd=vec, check=True, capture_output=True)
    return subprocess.run(["vvp", "-n", "tb.vvp"], cwd=vec, capture_output=True, text=True)


def passed(stdout, n_exp):
    """Beats checked by a passing stream testbench with ``n_exp`` expected transfers: its
    PASS line, 0 < n <= n_exp, names the expected beats a reset dropped when n < n_exp."""
    m = re.search(r"^PASS (\d+) beats \((.*)\)$", stdout, re.M)
    assert m, stdout[-2000:]
    n = int(m.group(1))
    assert 0 < n <= n_exp, m.group(0)
    dropped = f"{n_exp - n} of {n_exp} expected beats dropped by mid-stream resets; "
    assert m.group(2).startswith(dropped) if n < n_exp else "dropped" not in m.group(2), \
        m.group(0)
    return n


def flip(path, index, bit):
    """Flip one bit of word ``index`` of a memory file (one hex word a line)."""
    words = path.read_text().splitlines()
    words[index] = f"{int(words[index], 16) ^ (1 << bit):0{len(words[index])}x}"
    path.write_text("\n".join(words) + "\n")


def verilator_binary(folder, module):
    tool_env("verilator")
    vec = Path(folder) / "vectors"
    b = subprocess.run(["verilator", "--binary", "--timing", "-Wno-fatal", "-Wno-lint",
                        "-Wno-style", "-CFLAGS", "-std=c++20 -fcoroutines", "--top-module",
                        "tdicam_tb", "-Mdir", "obj_dir", "../tb/tdicam_tb.v",
                        f"../rtl/{module}.v"], cwd=vec, capture_output=True, text=True)
    assert b.returncode == 0, b.stderr[-2000:]
    return subprocess.run(["./obj_dir/Vtdicam_tb"], cwd=vec, capture_output=True, text=True)


def tree(folder):
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(Path(folder).rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def cds_export(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "cds"
    r = cli("export", "cds", "-o", str(out))
    assert r.returncode == 0, r.stderr
    return out


def test_export_is_deterministic_and_path_free(cds_export, tmp_path):
    again = tmp_path / "again"
    assert cli("export", "cds", "-o", str(again)).returncode == 0
    a, b = tree(cds_export), tree(again)
    assert a == b
    assert {"README.md", "tdicam_cds.core", "rtl/cds.v", "tb/tdicam_tb.v",
            "vectors/expected.hex", "vectors/stim_000000.bin"} <= set(a)
    for name, data in a.items():
        assert not re.search(rb"(/work|/tmp|/home|/root)", data), name
    # the RTL is exactly what `tdicam verilog` writes
    assert a["rtl/cds.v"] == cli("verilog", "cds").stdout.encode()
    assert re.search(r"^name: tdicam:blocks:cds:0\.1\.0\.\d+$",
                     a["tdicam_cds.core"].decode(), re.M)


def test_exported_testbench_passes_and_names_the_first_bad_beat(cds_export, tmp_path):
    r = icarus(cds_export)
    assert r.returncode == 0, r.stdout + r.stderr
    # its last golden case, reset_mid_frame_12b, drops the beats in flight at the reset
    n_exp = len((cds_export / "vectors" / "expected.hex").read_text().split())
    assert passed(r.stdout, n_exp) < n_exp
    bad = tmp_path / "bad"
    shutil.copytree(cds_export, bad)
    k = 37
    flip(bad / "vectors" / "expected.hex", k, 0)    # the LSB of one expected pixel
    r = icarus(bad)
    assert r.returncode != 0
    assert f"FAIL beat {k} " in r.stdout, r.stdout
    m = re.search(r"expected .* tdata ([0-9a-f]+), got .* tdata ([0-9a-f]+)", r.stdout)
    assert m and int(m.group(1), 16) ^ int(m.group(2), 16) == 1
    stim = bad / "vectors" / "stim_000000.bin"     # a stimulus chunk one byte short
    stim.write_bytes(stim.read_bytes()[:-1])
    r = icarus(bad)
    assert r.returncode != 0
    assert "FAIL stimulus file stim_000000.bin: " in r.stdout, r.stdout


def test_binary_stimulus_is_the_hex_words_in_whole_bytes():
    """encode_stimulus_bin: each hex word zero-extended to whole bytes, MSB first."""
    rng = np.random.default_rng(3)
    for ctrl_bits, padded, count in [(1, 16, 1), (5, 12, 1), (8, 16, 8), (2, 12, 3)]:
        n = 50
        beats = Beats(rng.integers(0, 1 << padded, (n, count), dtype=np.uint64),
                      rng.random(n) < 0.5, rng.random(n) < 0.5,
                      ctrl=rng.integers(0, 1 << ctrl_bits, n, dtype=np.uint64),
                      rst=rng.random(n) < 0.1)
        kw = dict(elem_padded_bits=padded, ctrl_bits=ctrl_bits)
        words = codec.encode_stimulus(beats, **kw).decode().split()
        rec = codec.stimulus_word_bytes(count=count, **kw)
        want = b"".join(int(w, 16).to_bytes(rec, "big") for w in words)
        assert codec.encode_stimulus_bin(beats, **kw) == want
        assert codec.stimulus_words_bin(want, rec) == [int(w, 16) for w in words]
        assert rec * 2 - 1 <= len(words[0]) <= rec * 2


def test_seed_plusarg_changes_stalls_not_results(cds_export):
    vec = cds_export / "vectors"
    icarus(cds_export)
    cycles = set()
    for seed in (1, 6, 7):          # 6 and 7: each seed its own stalls (issue 18)
        r = subprocess.run(["vvp", "-n", "tb.vvp", f"+seed={seed}", "+idle=80", "+bp=80"],
                           cwd=vec, capture_output=True, text=True)
        assert r.returncode == 0 and "PASS" in r.stdout, r.stdout
        cycles.add(re.search(r"(\d+) cycles", r.stdout).group(1))
    assert len(cycles) == 3


def verilator_passes_then_fails(folder, module, expected, index):
    """Build the export with ``verilator --binary``: it passes, and fails at beat ``index``
    once one bit of that word of memory file ``expected`` is flipped."""
    r = verilator_binary(folder, module)
    assert r.returncode == 0 and re.search(r"^PASS \d+ beats", r.stdout, re.M), r.stdout
    flip(Path(folder) / "vectors" / expected, index, 1)
    r = subprocess.run(["./obj_dir/Vtdicam_tb"], cwd=Path(folder) / "vectors",
                       capture_output=True, text=True)
    assert r.returncode != 0 and f"FAIL beat {index} " in r.stdout, r.stdout
    stim = Path(folder) / "vectors" / "stim_000000.bin"
    if stim.exists():               # a stimulus chunk one byte short is refused
        stim.write_bytes(stim.read_bytes()[:-1])
        r = subprocess.run(["./obj_dir/Vtdicam_tb"], cwd=Path(folder) / "vectors",
                           capture_output=True, text=True)
        assert r.returncode != 0 and "FAIL stimulus file stim_000000.bin" in r.stdout, r.stdout


def test_verilator_binary_runs_the_export(cds_export, tmp_path):
    work = tmp_path / "v"
    shutil.copytree(cds_export, work)
    verilator_passes_then_fails(work, "cds", "expected.hex", 3)


def test_fusesoc_runs_the_core_on_icarus(cds_export, tmp_path):
    fusesoc = shutil.which("fusesoc", path=str(Path(sys.executable).parent)) \
        or shutil.which("fusesoc")
    if fusesoc is None:
        pytest.skip("fusesoc is not installed (pip install '.[test]')")
    r = subprocess.run([fusesoc, "--cores-root", str(cds_export), "run", "--target",
                        "sim_icarus", "tdicam:blocks:cds"], cwd=tmp_path,
                       capture_output=True, text=True)
    assert r.returncode == 0, (r.stdout + r.stderr)[-2000:]
    assert re.search(r"^PASS \d+ beats", r.stdout, re.M), r.stdout[-2000:]


@pytest.mark.parametrize("name", blocks.names())
def test_every_registered_block_exports_and_passes_on_icarus(name, tmp_path, request):
    """Every registered block at its reference parameters (those of most of its golden
    cases): a short stimulus in the default run (stream blocks: up to 20,000 input beats;
    lvds: every golden case, the run of the lvds_export fixture), every case up to the
    export limit with TDICAM_FULL=1."""
    if name == "lvds":
        ex, r = request.getfixturevalue("lvds_export")[1:3]
    else:
        ex = export_block(name, {}, tmp_path / name, max_beats=None if FULL else 20_000)
        r = icarus(tmp_path / name)
    assert ex.n_in > 0 and ex.cases and ex.n_out > 0
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    if name == "lvds":
        m = re.search(r"^PASS (\d+) beats", r.stdout, re.M)
        assert m and int(m.group(1)) == ex.n_out, r.stdout[-2000:]
    else:
        # (a segment cut short by a mid-stream reset may end early: data in flight is dropped)
        passed(r.stdout, ex.n_out)


@pytest.mark.parametrize("given", [
    {"width": 64, "stages": 4}, {"width": 16, "stages": 1},
    {"width": 48, "stages": 5, "ppc": 2, "pixel_bits": 14},
    {"width": 64, "stages": 3, "ppc": 8, "out_bits": 9, "pixel_bits": 8},
])
def test_streamed_case_is_the_beat_level_model(given):
    """tdi's streamed case (made a frame at a time, each line from the whole-array model)
    equals what the beat-level model of the golden cases gives for the same stimulus."""
    from tdicam.blocks.tdi import _finish, _to_beats
    blk = blocks.get("tdi")
    params = blk.resolve(given)
    bs = blk.streams.streamed_case(params)
    parts = list(bs.pieces())
    stim = Beats.concat([a for a, _ in parts])
    exp = Beats.concat([b for _, b in parts])
    assert (len(stim), len(exp)) == (bs.n_in, bs.n_out) and bs.n_out > 0
    arrays = {"pixels": stim.data, "first": stim.first, "last": stim.last,
              "stages_active": (stim.ctrl >> np.uint64(1)).astype(np.uint8),
              "direction": (stim.ctrl & np.uint64(1)).astype(np.uint8)}
    _finish(arrays, params)
    model = _to_beats(arrays, params)[1]
    assert int(arrays["frame_errors"]) == 0
    for f in ("data", "first", "last"):
        np.testing.assert_array_equal(getattr(exp, f), getattr(model, f))


#: tdi exports run on Icarus: stages x ppc (every stage count to 8 with TDICAM_FULL=1). At a
#: small --stages the golden cases made for larger ones set stages_active above what the
#: port carries: those cases are left out (they spilled into the records' reset bit).
TDI_STAGES = range(1, 9) if FULL else (1, 3, 8)


@pytest.mark.parametrize("ppc", [1, 8])
@pytest.mark.parametrize("stages", TDI_STAGES)
def test_tdi_export_passes_at_every_small_stage_count(stages, ppc, tmp_path):
    ex = export_block("tdi", {"width": 16, "stages": stages, "ppc": ppc}, tmp_path / "tdi",
                      max_beats=None if FULL else 20_000)
    r = icarus(tmp_path / "tdi")
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    passed(r.stdout, ex.n_out)
    assert ex.cases


#: Stream blocks exported at the ends of their legal ranges (tdi's largest, 8192 x 128, is
#: the streamed case of 136 M beats: test_largest_tdi_export_fits_8_gb_of_address_space).
#: Every block the export streams (the registry's, so a new block is in), at the smallest
#: legal parameters (and the largest with TDICAM_FULL=1; tdi's largest is
#: test_largest_tdi_export_fits_8_gb_of_address_space).
ENDS = [(b.name, e) for b in blocks.all_blocks() if b.streams.to_beats is not None
        for e in (("smallest", "largest") if FULL else ("smallest",))
        if (b.name, e) != ("tdi", "largest")]


def _ends(blk, largest):
    """Every ranged parameter of ``blk`` at one end of its range (choices: the first or the
    last) over its small example's (the secded blocks' stream form); those that the block's
    cross checks refuse there dropped, last first."""
    out = {**blk.streams.small[1], **{p.name: (p.choices[-1] if largest else p.choices[0]) if p.choices is not None
           else (p.hi if largest else p.lo) for p in blk.params
           if p.choices is not None or (p.type is int and p.lo is not None
                                        and p.hi is not None)}}
    for name in list(out)[::-1]:
        try:
            return blk.resolve(out)
        except TdicamError:
            out.pop(name)
    return blk.resolve(out)


@pytest.mark.parametrize("name,end", ENDS)
def test_export_at_the_ends_of_the_legal_ranges(name, end, tmp_path):
    """The export at the smallest (and with TDICAM_FULL=1 the largest) legal parameters
    passes on Icarus, or is refused in one line (over the export's beat limit)."""
    blk = blocks.get(name)
    params = _ends(blk, end == "largest")
    try:
        ex = export_block(name, params, tmp_path / name, max_beats=20_000)
    except TdicamError as exc:
        assert "\n" not in str(exc) and "export limit" in str(exc), str(exc)
        return
    r = icarus(tmp_path / name)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    passed(r.stdout, ex.n_out)


def test_stimulus_settings_wider_than_the_ports_are_refused():
    """A run-time setting that does not fit the settings ports' bits would spill into the
    record's reset bit: refused in one line, not written."""
    b = Beats(np.zeros((2, 1), np.uint64), np.array([True, False]), np.array([False, True]),
              ctrl=np.array([3, 4], np.uint64))
    codec.encode_stimulus(b.select(np.array([True, False])), elem_padded_bits=16, ctrl_bits=2)
    with pytest.raises(TdicamError, match="beat 1: run-time settings 4 do not fit the 2 bit"):
        codec.encode_stimulus(b, elem_padded_bits=16, ctrl_bits=2)


def test_export_over_the_beat_limit_is_streamed_in_chunks(tmp_path, monkeypatch):
    """One frame over the beat limit: tdi exports its streamed case, written chunk by chunk
    (here 100-beat chunks, so frames straddle chunks) with the size stated first; the
    folder equals the export of the same beats held whole, and passes on Icarus."""
    from tdicam.cosim import tbgen
    from tdicam.export.block import _stream_top, export_files
    monkeypatch.setattr(tbgen, "DEPTH", 100)
    said = []
    out = tmp_path / "tdi"
    ex = export_block("tdi", {"width": 64, "stages": 4}, out, max_beats=200, say=said.append)
    assert ex.cases == ["stream_64x4_p1"] and (ex.n_in, ex.n_out) == (6 * 4 * 64, 3 * 64)
    assert "one frame is 256 input beats, over the export limit of 200: exporting the case " \
           "stream_64x4_p1 instead, 1,536 input beats written in chunks" in said[0], said
    written = tree(out)
    assert sum(k.startswith("vectors/stim_") for k in written) == 16
    size = sum(len(v) for v in written.values())
    assert f"{size / 1e6:.1f} MB in all" in said[1] and "1,536 input beats" in said[1]
    blk = blocks.get("tdi")
    params = blk.resolve({"width": 64, "stages": 4})
    parts = list(blk.streams.streamed_case(params).pieces())
    whole = export_files(blk, params, _stream_top(blk, params),
                         Beats.concat([a for a, _ in parts]), Beats.concat([b for _, b in parts]),
                         cases=ex.cases)
    assert written == {k: v.encode() if isinstance(v, str) else v for k, v in whole.items()}
    r = icarus(out)
    assert r.returncode == 0 and passed(r.stdout, ex.n_out) == ex.n_out, r.stdout[-2000:]


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="exports ~550 MB in several minutes (TDICAM_FULL=1)")
def test_largest_tdi_export_fits_8_gb_of_address_space(tmp_path):
    """tdicam export tdi at the largest legal parameters (8192 x 128) under ulimit -v 8 GB:
    streamed, its stated size what it writes."""
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (8_000_000 * 1024, 8_000_000 * 1024))
    out = tmp_path / "big"
    r = subprocess.run([sys.executable, "-m", "tdicam", "export", "tdi", "--width", "8192",
                        "--stages", "128", "-o", str(out)], capture_output=True, text=True,
                       preexec_fn=limit)
    assert r.returncode == 0, r.stderr[-2000:]
    m = re.search(r"export: ([\d,]+) input beats, ([\d,]+) expected beats, (\d+) vector "
                  r"file\(s\), ([\d.]+) MB in all", r.stderr)
    assert m, r.stderr
    assert int(m.group(1).replace(",", "")) == 130 * 128 * 8192
    files = [p for p in out.rglob("*") if p.is_file()]
    assert len(list((out / "vectors").iterdir())) == int(m.group(3))
    assert f"{sum(p.stat().st_size for p in files) / 1e6:.1f}" == m.group(4)


@pytest.mark.parametrize("args, message", [
    (["export", "nosuch", "-o", "X"], "unknown block 'nosuch'"),
    (["export", "cds", "--nope", "1", "-o", "X"], "block cds has no parameter --nope"),
    (["export", "cds", "--pixel-bits", "99", "-o", "X"], "--pixel-bits = 99 is out of range"),
    (["export", "cds"], "export needs -o DIR"),
    (["export", "lvds", "--phy", "xilinx7", "-o", "X"], "lvds --phy xilinx7 instantiates"),
    (["export", "pipeline", "-o", "X"], "tdicam export pipeline: one of the arguments --scene "
                                        "--example is required"),
    (["export", "pipeline", "--scene", "X/none.toml", "-o", "X"], "none.toml"),
    (["export", "pipeline", "--scene", CHAIN, "--width", "0", "-o", "X"],
     "--width = 0 is out of range"),
    (["export", "pipeline", "--scene", CHAIN, "--lines", "0", "-o", "X"],
     "--lines = 0 is out of range"),
    (["export", "pipeline", "--scene", CHAIN, "--stages", "99", "-o", "X"],
     "takes 4105728 input beats (162 frames of 99 x 256), over the export limit of 400000"),
    (["export", "cds", "--seed", "0", "-o", "X"], "--seed = 0 is out of range"),
])
def test_bad_input_is_one_line(args, message, tmp_path):
    args = [str(tmp_path / a[2:]) if a.startswith("X/") else
            str(tmp_path / a) if a == "X" else a for a in args]
    r = cli(*args)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and message in r.stderr, r.stderr


def test_output_folder_errors(tmp_path, cds_export):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    r = cli("export", "cds", "-o", str(blocker / "sub"))
    assert r.returncode == 2 and "cannot write the export" in r.stderr, r.stderr
    r = cli("export", "cds", "-o", str(blocker))
    assert r.returncode == 2 and "exists and is not a folder" in r.stderr
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    r = cli("export", "cds", "-o", str(other))
    assert r.returncode == 2 and "holds no tdicam export" in r.stderr
    assert (other / "notes.txt").read_text() == "mine"
    prev = tmp_path / "prev"
    shutil.copytree(cds_export, prev)
    r = cli("export", "nuc", "-o", str(prev))
    assert r.returncode == 2 and "holds the export of cds" in r.stderr, r.stderr
    assert cli("export", "cds", "-o", str(prev)).returncode == 0      # same export: refresh
    r = cli("export", "nuc", "-o", str(prev), "--force")
    assert r.returncode == 0, r.stderr
    assert not (prev / "tdicam_cds.core").exists() and (prev / "tdicam_nuc.core").exists()
    assert not (prev / "rtl" / "cds.v").exists()


# ---- lvds: the link testbench in its self-checking form


@pytest.fixture(scope="module")
def lvds_export(tmp_path_factory):
    """(folder, Export, Icarus run, folder tree before the run) of lvds at its reference
    parameters; the folder keeps the compiled ``vectors/tb.vvp``."""
    out = tmp_path_factory.mktemp("export") / "lvds"
    ex = export_block("lvds", {}, out)
    before = tree(out)
    r = icarus(out)
    return out, ex, r, before


def test_lvds_export_checks_every_golden_case(lvds_export, tmp_path):
    folder, ex, r, a = lvds_export
    names = ["random8_10b", "random8_nc1", "windows_10b", "deskew_8lanes", "retrain_10b"]
    assert ex.cases == names
    readme = (folder / "README.md").read_text()
    assert all(n in readme for n in names)
    n_out = len((folder / "vectors" / "exp_out.hex").read_text().splitlines())
    assert n_out == ex.n_out > 2000
    assert r.returncode == 0 and f"PASS {n_out} beats (66 status events" in r.stdout, \
        r.stdout[-2000:]
    again = tmp_path / "again"
    assert cli("export", "lvds", "-o", str(again)).returncode == 0
    assert a == tree(again)
    for name, data in a.items():
        assert not re.search(rb"(/work|/tmp|/home|/root)", data), name


@pytest.mark.parametrize("file, index, bit, message", [
    ("exp_out.hex", 700, 0, "FAIL beat 700 (case "),              # one deskewed word
    ("exp_events.hex", 3, 20, "FAIL lane "),                       # one event's tap
    ("exp_status.hex", 9, 0, "FAIL lane 1 of case random8_nc1: final status"),  # scan
])
def test_lvds_export_fails_on_one_changed_expected_word(lvds_export, tmp_path, file, index,
                                                        bit, message):
    bad = tmp_path / "bad"
    shutil.copytree(lvds_export[0], bad)
    flip(bad / "vectors" / file, index, bit)
    r = subprocess.run(["vvp", "-n", "tb.vvp"], cwd=bad / "vectors", capture_output=True,
                       text=True)
    assert r.returncode != 0 and message in r.stdout, r.stdout[-2000:]
    assert "PASS" not in r.stdout


# ---- the pipeline of a scene


@pytest.fixture(scope="module")
def chain_export(tmp_path_factory):
    """ning2019_chain on its first 24 columns, 6 output lines (the full scene: slow test)."""
    out = tmp_path_factory.mktemp("export") / "chain"
    r = cli("export", "pipeline", "--scene", CHAIN, "--width", "24", "--lines", "6",
            "-o", str(out))
    assert r.returncode == 0, r.stderr
    return out


def test_pipeline_export_passes_and_is_deterministic(chain_export, tmp_path):
    again = tmp_path / "again"
    r = cli("export", "pipeline", "--scene", CHAIN, "--width", "24", "--lines", "6",
            "-o", str(again))
    assert r.returncode == 0, r.stderr
    # long work shows where it is: a stage line per stage off a terminal
    assert [ln.rsplit(" (", 1)[0] for ln in r.stderr.splitlines()[:4]] == [
        f"export pipeline: [{k}/4] {s}" for k, s in enumerate(STAGES, 1)]
    a = tree(chain_export)
    assert a == tree(again)
    assert {"README.md", "tdicam_pipeline.core", "rtl/pipeline.v", "tb/tdicam_tb.v",
            "vectors/expected.hex", "vectors/stim_000000.bin"} <= set(a)
    for name, data in a.items():
        assert not re.search(rb"(/work|/tmp|/home|/root)", data), name
    assert re.search(r"^name: tdicam:pipeline:ning2019_chain:0\.1\.0\.\d+$",
                     a["tdicam_pipeline.core"].decode(), re.M)
    r = icarus(chain_export)
    assert r.returncode == 0 and passed(r.stdout, 144) == 144, r.stdout[-2000:]
    bad = tmp_path / "bad"
    shutil.copytree(chain_export, bad)
    flip(bad / "vectors" / "expected.hex", 77, 3)
    r = icarus(bad)
    assert r.returncode != 0 and "FAIL beat 77 " in r.stdout, r.stdout


def test_pipeline_export_with_the_bus_configures_the_top_over_it(tmp_path):
    """``--csr``: the top with its AXI4-Lite control bus, the register map's files under
    ``regs/`` (the C header's and the driver's offsets the map's), and a testbench that
    writes every setting over the bus and reads back the identity and each setting before
    it passes; a wrong value read back (the identity expected off by one) fails it."""
    pytest.importorskip("peakrdl_ipxact")
    from tdicam.chain import design
    out = tmp_path / "csr"
    r = cli("export", "pipeline", "--scene", CHAIN, "--width", "24", "--lines", "6", "--csr",
            "-o", str(out))
    assert r.returncode == 0, r.stderr
    a = tree(out)
    assert {f"regs/ning2019_chain{x}" for x in (".rdl", ".h", ".xml", "_registers.md",
                                                "_regs.py")} <= set(a)
    for name, data in a.items():
        assert not re.search(rb"(/work|/tmp|/home|/root)", data), name
    rtl, tb = a["rtl/pipeline.v"].decode(), a["tb/tdicam_tb.v"].decode()
    assert "csr=axi4-lite" in rtl and ".s_axil_awaddr(axil_awaddr)" in tb
    rm = design.register_map(design.chain_plan(design.load_pipeline_scene(CHAIN), width=24,
                                               lines=6))
    rw = [r for r in rm.registers if r.access == "rw" and r.block != "camera"]
    assert rw and all(f"axil_write(12'h{r.offset:03x}, 32'h{r.reset:08x});" in tb
                      for r in rw)
    assert "axil_read(12'h000, 32'h54444943" in tb
    res = icarus(out)
    assert res.returncode == 0 and passed(res.stdout, 144) == 144, res.stdout[-2000:]
    bad = tmp_path / "bad"
    shutil.copytree(out, bad)
    path = bad / "tb" / "tdicam_tb.v"
    path.write_text(path.read_text().replace("32'h54444943", "32'h54444944"))
    res = icarus(bad)
    assert res.returncode != 0 and "FAIL control bus: camera.id" in res.stdout, res.stdout
    assert "PASS" not in res.stdout


def test_pipeline_export_bad_scenes_are_one_line(tmp_path):
    text = Path(CHAIN).read_text()
    scenes = {"garbage.toml": ("garbage = [\n", "invalid TOML"),
              "charge.toml": (text.replace("stages = 8\n", 'stages = 8\ndomain = "charge"\n'),
                              "needs [tdi].domain = 'digital'")}
    for name, (body, message) in scenes.items():
        (tmp_path / name).write_text(body)
        r = cli("export", "pipeline", "--scene", str(tmp_path / name), "-o",
                str(tmp_path / "out"))
        assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
        assert message in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()


def test_pipeline_export_rtl_is_what_tdicam_verilog_writes(tmp_path):
    out = tmp_path / "chain"
    r = cli("export", "pipeline", "--scene", CHAIN, "--lines", "2", "-o", str(out))
    assert r.returncode == 0, r.stderr
    v = cli("verilog", "pipeline", "--scene", CHAIN, "--lines", "2")
    assert v.returncode == 0, v.stderr
    assert (out / "rtl" / "pipeline.v").read_text() == v.stdout


def test_pipeline_export_at_ppc_8_passes_on_icarus(tmp_path):
    """``--ppc 8``: every block of the exported top up to TDI at 8 pixels per clock, the
    median after TDI's 8 stages at 1 (a width converter before it), the stimulus in beats
    of 8 pixels, the expected output in beats of 1 (144 for 24 x 6 output pixels); a width
    the ppc does not divide is a one-line error naming both."""
    out = tmp_path / "chain8"
    r = cli("export", "pipeline", "--scene", CHAIN, "--width", "24", "--lines", "6",
            "--ppc", "8", "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert "ppc=8" in (out / "rtl" / "pipeline.v").read_text().splitlines()[2]
    r = icarus(out)
    assert r.returncode == 0 and passed(r.stdout, 144) == 144, r.stdout[-2000:]
    r = cli("export", "pipeline", "--scene", CHAIN, "--width", "20", "--lines", "6",
            "--ppc", "8", "-o", str(tmp_path / "bad"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "--ppc = 8: the width 20 is not a multiple of it" in r.stderr


@pytest.mark.parametrize("which", ["lvds", "chain"])
def test_fusesoc_runs_lvds_and_the_pipeline_on_icarus(which, lvds_export, chain_export,
                                                      tmp_path):
    fusesoc = shutil.which("fusesoc", path=str(Path(sys.executable).parent)) \
        or shutil.which("fusesoc")
    if fusesoc is None:
        pytest.skip("fusesoc is not installed (pip install '.[test]')")
    folder, core = {"lvds": (lvds_export[0], "tdicam:blocks:lvds"),
                    "chain": (chain_export, "tdicam:pipeline:ning2019_chain")}[which]
    r = subprocess.run([fusesoc, "--cores-root", str(folder), "run", "--target",
                        "sim_icarus", core], cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 0, (r.stdout + r.stderr)[-2000:]
    assert re.search(r"^PASS \d+ beats", r.stdout, re.M), r.stdout[-2000:]


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="Verilator builds of lvds and the whole chain: set "
                                     "TDICAM_FULL=1")
def test_verilator_binary_runs_lvds_and_the_whole_chain(tmp_path):
    lv = tmp_path / "lvds"
    assert cli("export", "lvds", "-o", str(lv)).returncode == 0
    verilator_passes_then_fails(lv, "lvds", "exp_out.hex", 1234)
    chain = tmp_path / "chain"
    assert cli("export", "pipeline", "--scene", CHAIN, "-o", str(chain)).returncode == 0
    r = verilator_binary(chain, "pipeline")
    assert r.returncode == 0 and "PASS 16384 beats" in r.stdout, r.stdout


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="the whole Ning et al. 2019 chain on Icarus: set "
                                      "TDICAM_FULL=1")
def test_whole_ning2019_chain_on_icarus(tmp_path):
    chain = tmp_path / "chain"
    assert cli("export", "pipeline", "--scene", CHAIN, "-o", str(chain)).returncode == 0
    r = icarus(chain)
    assert r.returncode == 0 and "PASS 16384 beats" in r.stdout, r.stdout[-2000:]


@pytest.mark.slow
@pytest.mark.skipif(not FULL, reason="lvds at other parameters (15 lane groups): set "
                                     "TDICAM_FULL=1")
def test_lvds_export_at_other_parameters(tmp_path):
    """4 lanes a group, 12-bit words: every case regenerated at these parameters, dead pad
    lanes, a group whose locked lanes all fail (its deskewed output stops)."""
    ex = export_block("lvds", {"lanes": 4, "word_bits": 12}, tmp_path / "lvds")
    r = icarus(tmp_path / "lvds")
    assert r.returncode == 0 and f"PASS {ex.n_out} beats" in r.stdout, r.stdout[-2000:]


def test_tdi_ddr_export_over_the_beat_limit_is_streamed(tmp_path):
    """tdi_ddr (same stream and golden model as tdi, partial sums in the DDR model) exports
    tdi's streamed case over the beat limit too, and it passes on Icarus."""
    said = []
    out = tmp_path / "tdi_ddr"
    ex = export_block("tdi_ddr", {"width": 160, "stages": 3}, out, max_beats=400,
                      say=said.append)
    assert ex.cases == ["stream_160x3_p1"] and (ex.n_in, ex.n_out) == (5 * 3 * 160, 3 * 160)
    assert "exporting the case stream_160x3_p1 instead" in said[0], said
    r = icarus(out)
    assert r.returncode == 0 and passed(r.stdout, ex.n_out) == ex.n_out, r.stdout[-2000:]
