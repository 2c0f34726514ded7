"""Verilog simulation models of the 7-series input primitives of the ``xilinx7`` LVDS PHY.

No open simulator ships IBUFDS, IBUFDS_DIFF_OUT, IDELAYCTRL, IDELAYE2 or ISERDESE2 (yosys
knows them as black boxes), so co-simulating :class:`tdicam.hdl.lvds.LvdsXilinx` from serial
bits needs models: :data:`MODEL`, written from AMD's "7 Series FPGAs SelectIO Resources" user guide
(UG471, chapters 2-3) and the libraries guide (UG953) port tables. Timed: the file sets
``timescale 1ps/1fs`` (delays in ps, exact to 1 fs: a 78.125 ps tap is 78125 fs) and
restores the project's ``1ns/1ps`` at its end. Modelled:

``IBUFDS``
    ``O = 1`` for ``I = 1, IB = 0``, ``O = 0`` for ``I = 0, IB = 1``, x otherwise (equal or
    unknown inputs). Zero delay; ``DIFF_TERM``, ``IOSTANDARD`` ... accepted, not modelled.
``IBUFDS_DIFF_OUT``
    ``O`` as ``IBUFDS``'s, ``OB`` its complement (x when ``O`` is x): the pair's two
    outputs, ``O`` to the P (master) pin's IOLOGIC, ``OB`` to the N (slave) pin's (UG471
    "IBUFDS_DIFF_OUT"; the second input path of a pair, e.g. a monitor sampler's).
``IDELAYCTRL``
    ``RDY`` low while ``RST`` is high and until the ``RDY_CYCLES``-th (model parameter,
    32) ``REFCLK`` rising edge after it falls (the data sheet gives a time, not modelled).
    A ``REFCLK`` period outside 190-210, 290-310 or 390-410 MHz stops the simulation.
``IDELAYE2``
    ``DATAOUT`` = ``IDATAIN`` (``DELAY_SRC = "IDATAIN"``) or ``DATAIN`` (``"DATAIN"``)
    delayed by ``tap x 1 / (32 x 2 x REFCLK_FREQUENCY)`` (78.125 ps at 200 MHz; UG471
    "IDELAY tap resolution"); no insertion delay at tap 0. ``IDELAY_TYPE``:
    ``FIXED`` (tap = ``IDELAY_VALUE``), ``VARIABLE`` (at a rising ``C`` edge: ``LD`` loads
    ``IDELAY_VALUE``, else ``CE`` steps the tap up (``INC = 1``) or down, wrapping 31 <-> 0)
    and ``VAR_LOAD`` (``LD`` loads ``CNTVALUEIN``, ``CE``/``INC`` as ``VARIABLE``).
    ``CNTVALUEOUT`` is the tap. A transport delay (:func:`transport_delay`): a new tap
    delays the input transitions that follow it; transitions already in the line keep
    their delay and their order (after a shorter tap the next ones wait behind them: the
    receiver ignores words for ``settle`` cycles after a load).
``ISERDESE2``
    ``INTERFACE_TYPE = "NETWORKING"``, ``DATA_RATE = "DDR"``, ``DATA_WIDTH`` 4, 6, 8 (a
    ``MASTER``) or 10, 14 (width expansion: a ``MASTER`` and a ``SLAVE`` whose ``SHIFTIN1``
    is the master's ``SHIFTOUT1``). Input ``DDLY`` (``IOBDELAY = "IFD"`` or ``"BOTH"``) or
    ``D``; ``O`` = ``DDLY`` for ``IOBDELAY = "IBUF"``/``"BOTH"``, else ``D``. The input is
    sampled at every rising ``CLK`` and ``CLKB`` edge (``CLKB = ~CLK``). Bit order (UG471,
    "ISERDESE2 ... width expansion"): the first bit received is the highest output: ``Q4``
    / ``Q6`` / ``Q8`` of the master for 4, 6, 8 bits; with width expansion the slave's
    ``Q4`` (10 bits) or ``Q8`` (14 bits), then down to the slave's ``Q3``, then the master's
    ``Q8`` .. ``Q1`` (``Q1`` the last bit received). Latency: the word whose bits were
    sampled in the ``CLKDIV`` period ending at a ``CLKDIV`` rising edge is captured at that
    edge and shows on ``Q`` from the next one (two ``CLKDIV`` edges from the word's start;
    a sample taken at the same instant as a ``CLKDIV`` edge belongs to the next word).
    ``BITSLIP`` (sampled at a rising ``CLKDIV`` edge; UG471 "Bitslip submodule"): in DDR
    mode the slips alternate between a shift right by one (the word boundary one bit
    earlier in the stream) and a shift left by three (three bits later), so ``DATA_WIDTH``
    slips visit every alignment once and return to the first; the slipped word is
    captured at the edge that samples ``BITSLIP`` high and is on ``Q`` one ``CLKDIV`` cycle
    later (the fabric samples it two ``CLKDIV`` edges after asserting ``BITSLIP``).
    ``RST`` (sampled at ``CLKDIV``; the history at ``CLK``/``CLKB``) clears the outputs,
    the word registers and the bitslip state. The master/slave chain is modelled at the
    sample rate on ``SHIFTOUT1``/``SHIFTIN1`` (``SHIFTOUT2`` carries the same bit): the
    device's internal chain is not documented, only its result on ``Q``.

What stops the simulation with ``$fatal``: another ``INTERFACE_TYPE``, ``DATA_RATE`` or
``DATA_WIDTH``, a slave below 10 bits, ``OFB_USED``, dynamic clock inversion,
``IDELAY_TYPE = "VAR_LOAD_PIPE"`` or ``PIPE_SEL``/``CINVCTRL_SEL = "TRUE"``, a
``REFCLK_FREQUENCY`` outside the legal bands, ``BITSLIP`` high on two consecutive
``CLKDIV`` edges (UG471 forbids it), ``CE1`` (or ``CE2`` with ``NUM_CE = 2``) low while
``CLKDIV`` runs out of reset. Not modelled: the IDELAY's insertion delay, its jitter and
its tap-to-tap variation, IDELAYCTRL's effect on the taps (the tap is always the nominal
one), INIT_Q/SRVAL_Q values (outputs reset to 0), the OCLK (memory) paths, SDR mode.
"""

__all__ = ["MODEL", "FILE", "TAP_PS", "transport_delay"]

#: File name the co-simulation build gives :data:`MODEL`.
FILE = "xilinx7_io_sim.v"


def TAP_PS(refclk_mhz=200.0):
    """The IDELAYE2 tap in ps: ``1e6 / (32 * 2 * refclk_mhz)`` (78.125 at 200 MHz)."""
    return 1e6 / (64.0 * refclk_mhz)


def transport_delay(out, src, delay):
    """Verilog of a transport delay line: every change of ``src`` reaches the ``reg`` ``out``
    ``delay`` (a real expression, time units) after it, with the delay in force when it
    entered; changes leave in the order they entered (a shorter delay waits behind the
    changes in flight). A queue of 64 changes and one process: ``out <= #(delay) src``
    would be inertial in some simulators and swallow pulses shorter than the delay."""
    return f"""  realtime q_t [0:63];
  reg q_v [0:63];
  reg [6:0] q_w = 7'd0, q_r = 7'd0;
  realtime q_due, q_last = 0.0;
  always @({src}) begin
    if (q_w - q_r == 7'd64)
      $fatal(1, "delay line model: more than 64 changes in flight");
    q_t[q_w[5:0]] = $realtime + ({delay});
    q_v[q_w[5:0]] = {src};
    q_w = q_w + 7'd1;
  end
  always begin
    if (q_r == q_w)
      @(q_w);
    else begin
      q_due = q_t[q_r[5:0]] > q_last ? q_t[q_r[5:0]] : q_last;
      if (q_due > $realtime)
        #(q_due - $realtime);
      {out} = q_v[q_r[5:0]];
      q_last = q_due;
      q_r = q_r + 7'd1;
    end
  end
"""


def _q_assign(name):
    return ", ".join(f"{name}{i}" for i in range(8, 0, -1))


#: The model's Verilog text (modules IBUFDS, IBUFDS_DIFF_OUT, IDELAYCTRL, IDELAYE2,
#: ISERDESE2).
MODEL = f"""// 7-series input primitive models (tdicam.cosim.xilinx7_io): the subset tdicam uses
`timescale 1ps/1fs
module IBUFDS (input I, input IB, output O);
  parameter DIFF_TERM = "FALSE";
  parameter IBUF_LOW_PWR = "TRUE";
  parameter IOSTANDARD = "DEFAULT";
  parameter DQS_BIAS = "FALSE";
  parameter CAPACITANCE = "DONT_CARE";
  parameter IBUF_DELAY_VALUE = "0";
  parameter IFD_DELAY_VALUE = "AUTO";
  assign O = (I === 1'b1 && IB === 1'b0) ? 1'b1 : (I === 1'b0 && IB === 1'b1) ? 1'b0 : 1'bx;
endmodule

module IBUFDS_DIFF_OUT (input I, input IB, output O, output OB);
  parameter DIFF_TERM = "FALSE";
  parameter IBUF_LOW_PWR = "TRUE";
  parameter IOSTANDARD = "DEFAULT";
  parameter DQS_BIAS = "FALSE";
  assign O = (I === 1'b1 && IB === 1'b0) ? 1'b1 : (I === 1'b0 && IB === 1'b1) ? 1'b0 : 1'bx;
  assign OB = ~O;
endmodule

module IDELAYCTRL (input REFCLK, input RST, output reg RDY);
  parameter SIM_DEVICE = "7SERIES";
  parameter RDY_CYCLES = 32;
  integer n = 0;
  realtime last = -1.0, per;
  initial RDY = 1'b0;
  always @(posedge REFCLK) begin
    if (last >= 0.0) begin
      per = $realtime - last;
      if (!((per >= 4761.9 && per <= 5263.2) || (per >= 3225.8 && per <= 3448.3)
            || (per >= 2439.0 && per <= 2564.2)))
        $fatal(1, "IDELAYCTRL model: REFCLK period %0.1f ps outside 190-210/290-310/390-410 MHz",
               per);
    end
    last = $realtime;
  end
  always @(posedge REFCLK or posedge RST)
    if (RST) begin
      n <= 0;
      RDY <= 1'b0;
    end else if (n + 1 >= RDY_CYCLES)
      RDY <= 1'b1;
    else
      n <= n + 1;
endmodule

module IDELAYE2 (
  input C, input REGRST, input LD, input CE, input INC, input CINVCTRL,
  input [4:0] CNTVALUEIN, input IDATAIN, input DATAIN, input LDPIPEEN,
  output reg DATAOUT, output [4:0] CNTVALUEOUT
);
  parameter IDELAY_TYPE = "FIXED";
  parameter DELAY_SRC = "IDATAIN";
  parameter integer IDELAY_VALUE = 0;
  parameter HIGH_PERFORMANCE_MODE = "FALSE";
  parameter SIGNAL_PATTERN = "DATA";
  parameter real REFCLK_FREQUENCY = 200.0;
  parameter CINVCTRL_SEL = "FALSE";
  parameter PIPE_SEL = "FALSE";
  parameter IS_C_INVERTED = 1'b0;
  parameter IS_DATAIN_INVERTED = 1'b0;
  parameter IS_IDATAIN_INVERTED = 1'b0;
  localparam real TAP = 1.0e6 / (64.0 * REFCLK_FREQUENCY);   // ps
  reg [4:0] tap = IDELAY_VALUE;
  initial begin
    DATAOUT = 1'b0;
    if (IDELAY_TYPE != "FIXED" && IDELAY_TYPE != "VARIABLE" && IDELAY_TYPE != "VAR_LOAD")
      $fatal(1, "IDELAYE2 model: IDELAY_TYPE FIXED, VARIABLE or VAR_LOAD only");
    if (PIPE_SEL != "FALSE" || CINVCTRL_SEL != "FALSE")
      $fatal(1, "IDELAYE2 model: PIPE_SEL and CINVCTRL_SEL FALSE only");
    if (!((REFCLK_FREQUENCY >= 190.0 && REFCLK_FREQUENCY <= 210.0)
          || (REFCLK_FREQUENCY >= 290.0 && REFCLK_FREQUENCY <= 310.0)
          || (REFCLK_FREQUENCY >= 390.0 && REFCLK_FREQUENCY <= 410.0)))
      $fatal(1, "IDELAYE2 model: REFCLK_FREQUENCY outside 190-210/290-310/390-410 MHz");
    if (IDELAY_VALUE < 0 || IDELAY_VALUE > 31)
      $fatal(1, "IDELAYE2 model: IDELAY_VALUE 0..31");
  end
  always @(posedge C)
    if (IDELAY_TYPE != "FIXED") begin
      if (LD)
        tap <= (IDELAY_TYPE == "VAR_LOAD") ? CNTVALUEIN : IDELAY_VALUE;
      else if (CE)
        tap <= INC ? tap + 5'd1 : tap - 5'd1;
    end
  assign CNTVALUEOUT = tap;
  wire src = (DELAY_SRC == "DATAIN") ? DATAIN : IDATAIN;
{transport_delay("DATAOUT", "src", "tap * TAP")}endmodule

module ISERDESE2 (
  input D, input DDLY, input CLK, input CLKB, input CLKDIV, input CLKDIVP, input OCLK,
  input OCLKB, input RST, input CE1, input CE2, input BITSLIP, input DYNCLKDIVSEL,
  input DYNCLKSEL, input OFB, input SHIFTIN1, input SHIFTIN2,
  output O, output Q1, Q2, Q3, Q4, Q5, Q6, Q7, Q8, output SHIFTOUT1, output SHIFTOUT2
);
  parameter DATA_RATE = "DDR";
  parameter integer DATA_WIDTH = 4;
  parameter INTERFACE_TYPE = "MEMORY";
  parameter integer NUM_CE = 2;
  parameter SERDES_MODE = "MASTER";
  parameter IOBDELAY = "NONE";
  parameter OFB_USED = "FALSE";
  parameter DYN_CLKDIV_INV_EN = "FALSE";
  parameter DYN_CLK_INV_EN = "FALSE";
  parameter INIT_Q1 = 1'b0, INIT_Q2 = 1'b0, INIT_Q3 = 1'b0, INIT_Q4 = 1'b0;
  parameter SRVAL_Q1 = 1'b0, SRVAL_Q2 = 1'b0, SRVAL_Q3 = 1'b0, SRVAL_Q4 = 1'b0;
  parameter IS_CLK_INVERTED = 1'b0, IS_CLKB_INVERTED = 1'b0, IS_CLKDIV_INVERTED = 1'b0;
  parameter IS_CLKDIVP_INVERTED = 1'b0, IS_D_INVERTED = 1'b0, IS_OCLK_INVERTED = 1'b0;
  parameter IS_OCLKB_INVERTED = 1'b0;
  localparam W = DATA_WIDTH;
  localparam SLAVE = SERDES_MODE == "SLAVE";
  // Q_i of this instance is history bit (offset + i - BASE): 1 in a master, 3 in a slave
  // (whose history is the master's, 8 samples older)
  localparam BASE = SLAVE ? 3 : 1;
  localparam TOP = SLAVE ? W - 8 + 2 : (W < 8 ? W : 8);   // highest Q in use
  initial begin
    if (INTERFACE_TYPE != "NETWORKING" || DATA_RATE != "DDR")
      $fatal(1, "ISERDESE2 model: INTERFACE_TYPE NETWORKING, DATA_RATE DDR only");
    if (W != 4 && W != 6 && W != 8 && W != 10 && W != 14)
      $fatal(1, "ISERDESE2 model: DATA_WIDTH 4, 6, 8, 10 or 14 in DDR mode");
    if (SLAVE && W < 10)
      $fatal(1, "ISERDESE2 model: a SLAVE expands DATA_WIDTH 10 or 14 only");
    if (OFB_USED != "FALSE" || DYN_CLKDIV_INV_EN != "FALSE" || DYN_CLK_INV_EN != "FALSE")
      $fatal(1, "ISERDESE2 model: OFB_USED and dynamic clock inversion FALSE only");
  end
  wire dly = (IOBDELAY == "IFD" || IOBDELAY == "BOTH");
  wire src = SLAVE ? SHIFTIN1 : (dly ? DDLY : D);
  assign O = (IOBDELAY == "IBUF" || IOBDELAY == "BOTH") ? DDLY : D;
  reg [31:0] h = 32'd0;           // sample history, h[0] the newest
  always @(posedge CLK or posedge CLKB)
    if (RST)
      h <= 32'd0;
    else
      h <= {{h[30:0], src}};
  assign SHIFTOUT1 = h[7];
  assign SHIFTOUT2 = h[7];
  reg [4:0] off = 5'd0;           // word boundary this many bits earlier (bitslip)
  reg odd = 1'b0;                 // the next slip is a shift right by one
  reg bs_q = 1'b0;
  reg [7:0] st = 8'd0, q = 8'd0;  // captured word, outputs (bit i-1 = Q_i)
  function [4:0] slip(input [4:0] o, input r);
    slip = r ? ((o + 1 >= W) ? o + 1 - W : o + 1) : ((o >= 3) ? o - 3 : o + W - 3);
  endfunction
  function [7:0] word(input [31:0] hh, input [4:0] o);
    integer i;
    begin
      word = 8'd0;
      for (i = BASE; i <= TOP; i = i + 1)
        word[i - 1] = hh[o + i - BASE];
    end
  endfunction
  wire [4:0] off_n = BITSLIP ? slip(off, !odd) : off;
  always @(posedge CLKDIV)
    if (RST) begin
      off <= 5'd0;
      odd <= 1'b0;
      bs_q <= 1'b0;
      st <= 8'd0;
      q <= 8'd0;
    end else begin
      if (CE1 !== 1'b1 || (NUM_CE == 2 && CE2 !== 1'b1))
        $fatal(1, "ISERDESE2 model: CE1/CE2 must be high");
      if (BITSLIP && bs_q)
        $fatal(1, "ISERDESE2 model: BITSLIP high on two consecutive CLKDIV cycles");
      bs_q <= BITSLIP;
      if (BITSLIP)
        odd <= !odd;
      off <= off_n;
      st <= word(h, off_n);
      q <= st;
    end
  assign {{{_q_assign("Q")}}} = {{q[7], q[6], q[5], q[4], q[3], q[2], q[1], q[0]}};
endmodule
`timescale 1ns/1ps
"""
