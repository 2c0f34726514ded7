"""Verilog simulation models of the ECP5 input primitives of the ``ecp5`` LVDS PHY.

yosys ships DELAYF, DELAYG, IDDRX1F, IDDRX2F, ECLKSYNCB and CLKDIVF only as black boxes
(``cells_bb_ecp5.v``), so co-simulating :class:`tdicam.hdl.lvds_ecp5.LvdsEcp5` from serial
bits needs models: :data:`MODEL`, written from Lattice's "ECP5 and ECP5-5G High-Speed I/O
Interface" technical note (FPGA-TN-02035, formerly TN1265: the generic DDR building blocks,
the edge clock tree, the input delay) and the port lists of yosys' black boxes. Timed:
the file sets ``timescale 1ps/1fs`` and restores the project's ``1ns/1ps`` at its end.
Modelled:

``DELAYF``
    ``Z`` = ``A`` delayed by ``count x STEP_PS`` (model parameter, 25 ps: the ECP5 input
    delay step the technical note's "input delay" section and the data sheet quote as about
    25 ps); ``count`` 0..127 starts at ``DEL_VALUE`` (``DEL_MODE = "USER_DEFINED"``).
    ``LOADN`` low returns it to ``DEL_VALUE`` (and holds it there); a ``MOVE`` pulse moves it
    one step at ``MOVE``'s falling edge, where ``DIRECTION`` is sampled: 0 one step more
    delay, 1 one step less. The count saturates at 0 and 127; ``CFLAG`` is high when it is
    at the limit the current ``DIRECTION`` moves to (127 with ``DIRECTION = 0``, 0 with 1).
    A transport delay (:func:`tdicam.cosim.xilinx7_io.transport_delay`): a new count
    delays the transitions that follow.
``DELAYG``
    ``Z`` = ``A`` delayed by ``DEL_VALUE x STEP_PS`` (``DEL_MODE = "USER_DEFINED"``).
``IDDRX1F``
    ``D`` sampled at both ``SCLK`` edges; at each rising edge ``Q0`` = the sample of the
    previous rising edge (the earlier bit), ``Q1`` = the sample of the falling edge
    between. ``RST`` (asynchronous, active high) clears both.
``IDDRX2F``
    x2 gearing: ``D`` sampled at both ``ECLK`` edges; at each rising ``SCLK`` edge
    (``SCLK = ECLK / 2``, from ``CLKDIVF`` ``DIV = "2.0"`` on the same ``ECLK``) ``Q0`` ..
    ``Q3`` = the last four samples, ``Q0`` the earliest; a sample taken at the ``ECLK`` edge
    ``SCLK`` rises from belongs to the word that ends there (``CLKDIVF``'s output follows
    its ``ECLK`` edge by a delta cycle). ``ALIGNWD`` high at a rising ``SCLK`` edge moves
    the word boundary one bit earlier in the stream from that edge's word on (four
    pulses return it; the technical note: "used for word alignment, shifts the word by one
    bit"; the direction is the model's). ``RST`` clears outputs, words and alignment. Two
    ``ECLK`` rising edges per ``SCLK`` period are checked: another ratio stops the run.
``ECLKSYNCB``
    ``ECLKO`` = ``ECLKI`` while ``STOP`` is low; ``STOP`` is sampled at the falling edge of
    ``ECLKI`` so the output stops and restarts low, without a glitch.
``CLKDIVF``
    ``DIV = "2.0"``: ``CDIVX`` toggles at every rising ``CLKI`` edge (rising with the first
    ``CLKI`` rising edge after ``RST`` falls; low while ``RST`` is high); ``ALIGNWD`` high at
    a rising ``CLKI`` edge holds ``CDIVX`` for that edge: its phase slips one ``CLKI``
    cycle.

What stops the simulation with ``$fatal``: ``DEL_MODE`` other than ``USER_DEFINED``
(the preset alignment modes), ``DEL_VALUE`` outside 0..127, ``CLKDIVF`` ``DIV`` other than
``"2.0"`` (``"3.5"`` is the 7:1 gearing), an ``IDDRX2F`` whose ``SCLK`` is not ``ECLK / 2``.
Not modelled: the delay's insertion delay and its process/voltage/temperature variation,
GSR, the DQS paths (``DQSBUFM``), ``IDDR71B``.
"""

from tdicam.cosim.xilinx7_io import transport_delay

__all__ = ["MODEL", "FILE", "STEP_PS", "N_STEPS"]

#: File name the co-simulation build gives :data:`MODEL`.
FILE = "ecp5_io_sim.v"

#: The DELAYF/DELAYG step the model uses (ps), and the number of counts (0..127).
STEP_PS = 25.0
N_STEPS = 128


def _delay_common():
    return f"""  parameter DEL_MODE = "USER_DEFINED";
  parameter integer DEL_VALUE = 0;
  parameter real STEP_PS = {STEP_PS};
  initial begin
    if (DEL_MODE != "USER_DEFINED")
      $fatal(1, "DELAYF/DELAYG model: DEL_MODE USER_DEFINED only");
    if (DEL_VALUE < 0 || DEL_VALUE > {N_STEPS - 1})
      $fatal(1, "DELAYF/DELAYG model: DEL_VALUE 0..{N_STEPS - 1}");
  end
"""


#: The model's Verilog text.
MODEL = f"""// ECP5 input primitive models (tdicam.cosim.ecp5_io): the subset tdicam uses
`timescale 1ps/1fs
module DELAYF (input A, input LOADN, input MOVE, input DIRECTION, output reg Z,
               output CFLAG);
{_delay_common()}  reg [6:0] cnt = DEL_VALUE;
  initial Z = 1'b0;
  always @(negedge MOVE or negedge LOADN)
    if (!LOADN)
      cnt <= DEL_VALUE;
    else if (DIRECTION) begin
      if (cnt != 7'd0) cnt <= cnt - 7'd1;
    end else if (cnt != 7'd{N_STEPS - 1})
      cnt <= cnt + 7'd1;
  assign CFLAG = DIRECTION ? (cnt == 7'd0) : (cnt == 7'd{N_STEPS - 1});
{transport_delay("Z", "A", "cnt * STEP_PS")}endmodule

module DELAYG (input A, output reg Z);
{_delay_common()}  initial Z = 1'b0;
{transport_delay("Z", "A", "DEL_VALUE * STEP_PS")}endmodule

module IDDRX1F (input D, input SCLK, input RST, output reg Q0, output reg Q1);
  parameter GSR = "ENABLED";
  reg r = 1'b0, f = 1'b0;
  initial begin
    Q0 = 1'b0;
    Q1 = 1'b0;
  end
  always @(negedge SCLK or posedge RST)
    if (RST) f <= 1'b0; else f <= D;
  always @(posedge SCLK or posedge RST)
    if (RST) begin
      r <= 1'b0;
      Q0 <= 1'b0;
      Q1 <= 1'b0;
    end else begin
      r <= D;
      Q0 <= r;
      Q1 <= f;
    end
endmodule

module IDDRX2F (input D, input SCLK, input ECLK, input RST, input ALIGNWD,
                output Q3, output Q2, output Q1, output Q0);
  parameter GSR = "ENABLED";
  reg [7:0] h = 8'd0;     // samples, h[0] the newest
  reg [1:0] off = 2'd0;   // word boundary this many bits earlier
  reg [3:0] q = 4'd0;     // q[i] = Q_i
  integer ne = 0;         // ECLK rising edges since the last SCLK rising edge
  reg seen = 1'b0;
  always @(posedge ECLK or negedge ECLK or posedge RST)
    if (RST) h <= 8'd0; else h <= {{h[6:0], D}};
  always @(posedge ECLK) ne = ne + 1;
  wire [1:0] off_n = ALIGNWD ? off + 2'd1 : off;
  always @(posedge SCLK or posedge RST) begin
    if (RST) begin
      off <= 2'd0;
      q <= 4'd0;
      seen <= 1'b0;
    end else begin
      if (seen && ne != 2)
        $fatal(1, "IDDRX2F model: %0d ECLK rising edges in an SCLK period (SCLK = ECLK / 2)",
               ne);
      seen <= 1'b1;
      off <= off_n;
      q <= {{h[off_n], h[off_n + 1], h[off_n + 2], h[off_n + 3]}};
    end
    ne = 0;
  end
  assign {{Q3, Q2, Q1, Q0}} = q;
endmodule

module ECLKSYNCB (input ECLKI, input STOP, output ECLKO);
  reg stop = 1'b0;
  always @(negedge ECLKI) stop <= STOP;
  assign ECLKO = ECLKI & !stop;
endmodule

module CLKDIVF (input CLKI, input RST, input ALIGNWD, output reg CDIVX);
  parameter GSR = "DISABLED";
  parameter DIV = "2.0";
  initial begin
    CDIVX = 1'b0;
    if (DIV != "2.0")
      $fatal(1, "CLKDIVF model: DIV 2.0 only");
  end
  always @(posedge CLKI or posedge RST)
    if (RST) CDIVX <= 1'b0;
    else if (!ALIGNWD) CDIVX <= !CDIVX;
endmodule
`timescale 1ns/1ps
"""
