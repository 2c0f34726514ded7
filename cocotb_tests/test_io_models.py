"""The vendor I/O primitive models (:mod:`tdicam.cosim.xilinx7_io`, :mod:`tdicam.cosim.ecp5_io`)
against their documented behaviour, on Icarus and Verilator (fixture ``sim``), and shown
able to fail: each mutant below changes one documented behaviour of a model and must fail
the test of that behaviour (Icarus: a build is a second; the Verilator builds of the
mutants run with ``TDICAM_FULL=1``).
"""

import functools
import os

import pytest

from tdicam.cosim import io_models
from tdicam.cosim.io_models import mutate, run_tests
from tdicam.cosim import ecp5_io, xilinx7_io

FULL = os.environ.get("TDICAM_FULL") == "1"

TESTS = {
    "xilinx7": ["test_ibufds", "test_ibufds_diff_out", "test_idelayctrl_rdy", "test_idelay_tap_delay",
                "test_idelay_var_load", "test_iserdes_bit_order", "test_iserdes_latency",
                "test_iserdes_bitslip", "test_iserdes_reset"],
    "ecp5": ["test_delayf_step", "test_delayf_limits", "test_delayg", "test_iddrx1f",
             "test_iddrx2f_order", "test_iddrx2f_latency", "test_iddrx2f_alignwd",
             "test_clkdivf_ratio", "test_eclksyncb"],
}

#: (name, vendor, text in the model, its replacement, the test that must fail)
MUTANTS = [
    ("tap_32", "xilinx7", "1.0e6 / (64.0 * REFCLK_FREQUENCY)",
     "1.0e6 / (32.0 * REFCLK_FREQUENCY)", "test_idelay_tap_delay"),
    ("load_off_by_one", "xilinx7", "? CNTVALUEIN :", "? CNTVALUEIN + 5'd1 :",
     "test_idelay_var_load"),
    ("no_wrap", "xilinx7", "tap <= INC ? tap + 5'd1 : tap - 5'd1;",
     "tap <= INC ? (tap == 5'd31 ? tap : tap + 5'd1) : tap - 5'd1;", "test_idelay_var_load"),
    ("ibufds_inverted", "xilinx7",             # IBUFDS's own (IBUFDS_DIFF_OUT has one too)
     "IFD_DELAY_VALUE = \"AUTO\";\n  assign O = (I === 1'b1 && IB === 1'b0) ? 1'b1",
     "IFD_DELAY_VALUE = \"AUTO\";\n  assign O = (I === 1'b1 && IB === 1'b0) ? 1'b0",
     "test_ibufds"),
    ("diff_out_same", "xilinx7", "assign OB = ~O;", "assign OB = O;",
     "test_ibufds_diff_out"),
    ("rdy_early", "xilinx7", "n + 1 >= RDY_CYCLES", "n + 2 >= RDY_CYCLES",
     "test_idelayctrl_rdy"),
    ("bit_order_reversed", "xilinx7", "word[i - 1] = hh[o + i - BASE];",
     "word[i - 1] = hh[o + TOP - i];", "test_iserdes_bit_order"),
    ("latency_one", "xilinx7", "q <= st;", "q <= word(h, off_n);", "test_iserdes_latency"),
    ("slip_left_one", "xilinx7", "((o >= 3) ? o - 3 : o + W - 3)",
     "((o >= 1) ? o - 1 : o + W - 1)", "test_iserdes_bitslip"),
    ("slip_late", "xilinx7", "st <= word(h, off_n);", "st <= word(h, off);",
     "test_iserdes_bitslip"),
    ("reset_keeps_slip", "xilinx7", "      off <= 5'd0;\n      odd <= 1'b0;\n", "",
     "test_iserdes_reset"),
    ("delayg_plus_one", "ecp5", "$realtime + (DEL_VALUE * STEP_PS)",
     "$realtime + ((DEL_VALUE + 1) * STEP_PS)", "test_delayg"),
    ("step_26ps", "ecp5", "$realtime + (cnt * STEP_PS)", "$realtime + (cnt * (STEP_PS + 1.0))",
     "test_delayf_step"),
    ("direction_swapped", "ecp5", "    else if (DIRECTION) begin",
     "    else if (!DIRECTION) begin", "test_delayf_step"),
    ("no_saturation", "ecp5", "if (cnt != 7'd0) cnt <= cnt - 7'd1;", "cnt <= cnt - 7'd1;",
     "test_delayf_limits"),
    ("cflag_wrong_end", "ecp5", "assign CFLAG = DIRECTION ?", "assign CFLAG = !DIRECTION ?",
     "test_delayf_limits"),
    ("iddrx1f_swapped", "ecp5", "      Q0 <= r;\n      Q1 <= f;", "      Q0 <= f;\n      Q1 <= r;",
     "test_iddrx1f"),
    ("iddrx2f_reversed", "ecp5",
     "q <= {h[off_n], h[off_n + 1], h[off_n + 2], h[off_n + 3]};",
     "q <= {h[off_n + 3], h[off_n + 2], h[off_n + 1], h[off_n]};", "test_iddrx2f_order"),
    ("iddrx2f_late", "ecp5",
     "q <= {h[off_n], h[off_n + 1], h[off_n + 2], h[off_n + 3]};",
     "q <= {h[off_n + 4], h[off_n + 5], h[off_n + 6], h[off_n + 7]};",
     "test_iddrx2f_latency"),
    ("alignwd_ignored", "ecp5", "wire [1:0] off_n = ALIGNWD ? off + 2'd1 : off;",
     "wire [1:0] off_n = off;", "test_iddrx2f_alignwd"),
    ("clkdivf_no_slip", "ecp5", "else if (!ALIGNWD) CDIVX <= !CDIVX;",
     "else CDIVX <= !CDIVX;", "test_clkdivf_ratio"),
    ("eclksyncb_no_stop", "ecp5", "assign ECLKO = ECLKI & !stop;", "assign ECLKO = ECLKI;",
     "test_eclksyncb"),
]


@functools.lru_cache(maxsize=None)
def _run(vendor, sim):
    return run_tests(vendor, sim)


@pytest.mark.parametrize("vendor", sorted(TESTS))
def test_models_pass(vendor, sim):
    """Every documented behaviour of every model holds."""
    verdicts, _ = _run(vendor, sim)
    assert {t: verdicts.get(t) for t in TESTS[vendor]} == {t: True for t in TESTS[vendor]}


@pytest.mark.parametrize("name,vendor,old,new,test", MUTANTS, ids=[m[0] for m in MUTANTS])
def test_mutant_fails(name, vendor, old, new, test, tmp_path):
    """A model changed in one documented behaviour fails that behaviour's test."""
    model = {"xilinx7": xilinx7_io, "ecp5": ecp5_io}[vendor].MODEL
    sims = ("icarus", "verilator") if FULL else ("icarus",)
    for sim in sims:
        verdicts, _ = run_tests(vendor, sim, model=mutate(model, old, new),
                                rundir=tmp_path / sim, tests=[test])
        assert verdicts.get(test) is not True, f"{sim}: mutant {name} passes {test}"


def test_mutants_cover_every_test():
    """Each behaviour test has a mutant that must fail it."""
    for vendor, tests in TESTS.items():
        assert {m[4] for m in MUTANTS if m[1] == vendor} == set(tests)


def test_wrappers_name_their_tests():
    """The list above is the cocotb modules' list."""
    import importlib
    for vendor, tests in TESTS.items():
        mod = importlib.import_module(f"tdicam.simtb.{io_models.VENDORS[vendor][2]}")
        assert sorted(n for n in dir(mod) if n.startswith("test_")) == sorted(tests)
