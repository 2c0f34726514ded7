"""Unit-test harness of the vendor I/O primitive models (:mod:`tdicam.cosim.xilinx7_io`,
:mod:`tdicam.cosim.ecp5_io`): a wrapper top per vendor that instantiates every modelled
primitive, and :func:`run_tests`, which builds it with a model text (the model, or a
mutant of it) and runs the cocotb tests of :mod:`tdicam.simtb.xilinx7_io_tb` /
:mod:`tdicam.simtb.ecp5_io_tb`, returning each test's verdict.

The wrappers generate the serial stream and the fast clocks in HDL, one timed process per
wrapper, so sample and clock edges are exact: tick ``k`` is at ``k * UI`` after ``go``;
the serial input carries ``stream[k]`` from ``(k - 1/2) UI`` to ``(k + 1/2) UI`` (sampled in
the middle of its bit at tick ``k``); the bit clock(s) change at the ticks (Xilinx: ``CLK``
rises at even ticks, ``CLKB`` at odd ones, ``CLKDIV_W`` rises at ticks ``k % W == 0``;
ECP5: ``ECLK`` rises at even ticks). ``k`` is readable, so each test knows which bits a
word must hold. cocotb drives everything else (delay controls, ``BITSLIP``, resets).
"""

import hashlib
import re
import xml.etree.ElementTree as ET

from tdicam.errors import TdicamError
from tdicam.cosim import ecp5_io, xilinx7_io
from tdicam.cosim.build import build_sources, run_cocotb

__all__ = ["UI_PS", "STREAM_BITS", "VENDORS", "wrapper", "run_tests", "mutate"]

#: The wrappers' bit period (ps): 500 Mb/s.
UI_PS = 2000
#: Bits of the wrappers' ``stream`` register (the stream repeats with this period).
STREAM_BITS = 4096

_TICKS = f"""  reg [{STREAM_BITS - 1}:0] stream = {STREAM_BITS}'d0;
  reg go = 1'b0;
  integer k = 0;
  reg ser = 1'b0;
"""

def _iserdes(w):
    def inst(name, mode, q, extra):
        qs = ", ".join(f".Q{i}({q}[{i - 1}])" for i in range(1, 9))
        return (f"  ISERDESE2 #(.DATA_RATE(\"DDR\"), .DATA_WIDTH({w}), "
                f".INTERFACE_TYPE(\"NETWORKING\"), .NUM_CE(2), .SERDES_MODE(\"{mode}\"), "
                f".IOBDELAY(\"{'IFD' if mode == 'MASTER' else 'NONE'}\")) {name} (\n"
                f"    .D(1'b0), .DDLY(ser), .CLK(clk), .CLKB(clkb), .CLKDIV(cd{w}), "
                f".CLKDIVP(1'b0), .OCLK(1'b0), .OCLKB(1'b0), .RST(rst), .CE1(1'b1), "
                f".CE2(1'b1), .BITSLIP({bs}), .DYNCLKDIVSEL(1'b0), .DYNCLKSEL(1'b0), "
                f".OFB(1'b0), {extra}, .O(), {qs});\n")
    bs = {8: "bs8", 10: "bs10"}.get(w, "1'b0")
    if w < 10:
        return inst(f"m{w}", "MASTER", f"q{w}",
                    ".SHIFTIN1(1'b0), .SHIFTIN2(1'b0), .SHIFTOUT1(), .SHIFTOUT2()")
    return (inst(f"im{w}", "MASTER", f"m{w}",
                 f".SHIFTIN1(1'b0), .SHIFTIN2(1'b0), .SHIFTOUT1(so{w}), .SHIFTOUT2()")
            + inst(f"is{w}", "SLAVE", f"s{w}",
                   f".SHIFTIN1(so{w}), .SHIFTIN2(so{w}), .SHIFTOUT1(), .SHIFTOUT2()"))


_XILINX = f"""`timescale 1ps/1fs
module tdicam_tb;
{_TICKS}  reg clk = 1'b0, clkb = 1'b1;
  reg cd4 = 1'b0, cd6 = 1'b0, cd8 = 1'b0, cd10 = 1'b0, cd14 = 1'b0;
  initial begin
    wait (go);
    forever begin
      ser = stream[k % {STREAM_BITS}];
      #({UI_PS // 2});
      clk = (k % 2 == 0);
      clkb = !clk;
      cd4 = (k % 4) < 2;
      cd6 = (k % 6) < 3;
      cd8 = (k % 8) < 4;
      cd10 = (k % 10) < 5;
      cd14 = (k % 14) < 7;
      #({UI_PS // 2});
      k = k + 1;
    end
  end
  // differential input, delay line, delay controller
  reg p = 1'b0, n = 1'b1, refclk = 1'b0, ctl_rst = 1'b1;
  reg c = 1'b0, ld = 1'b0, ce = 1'b0, inc = 1'b0;
  reg [4:0] cntin = 5'd0;
  wire pad, dly, dlyf, rdy;
  wire [4:0] cntout, cntoutf;
  IBUFDS #(.DIFF_TERM("TRUE"), .IOSTANDARD("LVDS_25")) ib (.I(p), .IB(n), .O(pad));
  wire pad_o, pad_ob;
  IBUFDS_DIFF_OUT #(.DIFF_TERM("TRUE"), .IOSTANDARD("LVDS_25")) ibd (.I(p), .IB(n),
    .O(pad_o), .OB(pad_ob));
  IDELAYCTRL ctl (.REFCLK(refclk), .RST(ctl_rst), .RDY(rdy));
  IDELAYE2 #(.IDELAY_TYPE("VAR_LOAD"), .DELAY_SRC("IDATAIN"), .IDELAY_VALUE(0),
             .REFCLK_FREQUENCY(200.0)) dl (
    .C(c), .REGRST(1'b0), .LD(ld), .CE(ce), .INC(inc), .CINVCTRL(1'b0),
    .CNTVALUEIN(cntin), .IDATAIN(pad), .DATAIN(1'b0), .LDPIPEEN(1'b0), .DATAOUT(dly),
    .CNTVALUEOUT(cntout));
  IDELAYE2 #(.IDELAY_TYPE("FIXED"), .IDELAY_VALUE(5), .REFCLK_FREQUENCY(300.0)) dlf (
    .C(1'b0), .REGRST(1'b0), .LD(1'b0), .CE(1'b0), .INC(1'b0), .CINVCTRL(1'b0),
    .CNTVALUEIN(5'd0), .IDATAIN(pad), .DATAIN(1'b0), .LDPIPEEN(1'b0), .DATAOUT(dlyf),
    .CNTVALUEOUT(cntoutf));
  // deserializers of every width on the serial stream
  reg rst = 1'b1, bs8 = 1'b0, bs10 = 1'b0;
  wire [7:0] q4, q6, q8, m10, s10, m14, s14;
  wire so10, so14, nc;
{"".join(_iserdes(w) for w in (4, 6, 8, 10, 14))}  wire [3:0] word4 = q4[3:0];
  wire [5:0] word6 = q6[5:0];
  wire [7:0] word8 = q8;
  wire [9:0] word10 = {{s10[3:2], m10}};
  wire [13:0] word14 = {{s14[7:2], m14}};
endmodule
"""


_ECP5 = f"""`timescale 1ps/1fs
module tdicam_tb;
{_TICKS}  reg eclki = 1'b0;
  initial begin
    wait (go);
    forever begin
      ser = stream[k % {STREAM_BITS}];
      #({UI_PS // 2});
      eclki = (k % 2 == 0);
      #({UI_PS // 2});
      k = k + 1;
    end
  end
  // delay lines
  reg a = 1'b0, loadn = 1'b1, move = 1'b0, direction = 1'b0;
  wire z, zg, cflag;
  DELAYF #(.DEL_MODE("USER_DEFINED"), .DEL_VALUE(10)) df (
    .A(a), .LOADN(loadn), .MOVE(move), .DIRECTION(direction), .Z(z), .CFLAG(cflag));
  DELAYG #(.DEL_MODE("USER_DEFINED"), .DEL_VALUE(40)) dg (.A(a), .Z(zg));
  // edge clock, divided clock, x2 and x1 gearing on the serial stream
  reg stop = 1'b0, rst_div = 1'b1, align_div = 1'b0, rst = 1'b1, alignwd = 1'b0;
  wire eclk, sclk;
  wire [3:0] q2;
  wire [1:0] q1;
  ECLKSYNCB es (.ECLKI(eclki), .STOP(stop), .ECLKO(eclk));
  CLKDIVF #(.DIV("2.0")) cdv (.CLKI(eclk), .RST(rst_div), .ALIGNWD(align_div), .CDIVX(sclk));
  IDDRX2F ix2 (.D(ser), .SCLK(sclk), .ECLK(eclk), .RST(rst), .ALIGNWD(alignwd),
               .Q3(q2[3]), .Q2(q2[2]), .Q1(q2[1]), .Q0(q2[0]));
  IDDRX1F ix1 (.D(ser), .SCLK(eclki), .RST(rst), .Q0(q1[0]), .Q1(q1[1]));
endmodule
"""

#: {vendor: (model module, wrapper text, cocotb module)}
VENDORS = {
    "xilinx7": (xilinx7_io, _XILINX, "xilinx7_io_tb"),
    "ecp5": (ecp5_io, _ECP5, "ecp5_io_tb"),
}


def wrapper(vendor):
    """The wrapper top's Verilog text of ``vendor``."""
    return VENDORS[vendor][1]


def mutate(model, old, new):
    """``model`` with ``old`` (which must occur exactly once) replaced by ``new``."""
    if model.count(old) != 1:
        raise TdicamError(f"mutant: {old!r} occurs {model.count(old)} times in the model")
    return model.replace(old, new)


def _verdicts(xml_path):
    verdicts = {}
    try:
        root = ET.parse(xml_path).getroot()
    except (OSError, ET.ParseError):
        return verdicts
    for case in root.iter("testcase"):
        bad = any(child.tag in ("failure", "error") for child in case)
        verdicts[case.get("name")] = not bad
    return verdicts


def run_tests(vendor, sim, *, model=None, rundir=None, tests=None):
    """Build ``vendor``'s wrapper with ``model`` (default: the vendor's :data:`MODEL`) on
    ``sim`` and run its cocotb tests (``tests``: a list of names, default all).

    Returns ``({test name: passed}, wall seconds)``; a test missing from the result (the
    simulation stopped before it, e.g. by ``$fatal``) reads as failed.
    """
    mod, top, tb = VENDORS[vendor]
    text = mod.MODEL if model is None else model
    key = hashlib.sha256(text.encode()).hexdigest()[:10]
    bdir, _ = build_sources(f"io_{vendor}", {"model": key}, sim,
                            {mod.FILE: text, "wrapper.v": top})
    rundir = rundir or bdir / f"run-{key}"
    rundir.mkdir(parents=True, exist_ok=True)
    (rundir / "results.xml").unlink(missing_ok=True)
    plus = []
    if tests:
        import os
        os.environ["COCOTB_TEST_FILTER"] = "|".join(f"^{re.escape(t)}$" for t in tests)
    try:
        _, wall = run_cocotb(bdir, sim, tb, rundir, plus)
    finally:
        if tests:
            import os
            os.environ.pop("COCOTB_TEST_FILTER", None)
    return _verdicts(rundir / "results.xml"), wall
