"""A Verilog simulation model of the Lattice ECP5 MULT18X18D multiplier (the configuration
tdicam uses).

yosys ships MULT18X18D only as a black box, so co-simulating an ECP5 synthesis top whose
multipliers keep their registers in the DSP block (:mod:`tdicam.hdl.vendor.ecp5_dsp`)
needs a model: :data:`MODEL`, written from Lattice's "ECP5 and ECP5-5G sysDSP Usage Guide"
(FPGA-TN-02205) port and attribute description. Modelled:

* an unsigned or a signed 18 x 18 multiply (``SIGNEDA`` = ``SIGNEDB`` = 0: ``P[35:0] =
  A * B``; both 1: two's complement operands and product), operands from ``A`` and ``B``
  (``SOURCEA`` = ``SOURCEB`` = 0);
* the input registers (``REG_INPUTA_CLK``, ``REG_INPUTB_CLK``) and the output register
  (``REG_OUTPUT_CLK``), each ``"NONE"`` (bypassed) or ``"CLK0"`` with ``CE0`` and
  ``RST0`` (``RESETMODE = SYNC``: zeroed at the clock edge, whatever ``CE0``); they start
  at zero.

Anything else (a pipeline register, another clock, enable or reset, ``SIGNEDA`` and
``SIGNEDB`` different, ``SOURCEA`` or ``SOURCEB`` high) stops the simulation with
``$fatal``.
"""

__all__ = ["MODEL", "FILE"]

#: File name the co-simulation build gives :data:`MODEL`.
FILE = "mult18x18d_sim.v"


def _bus(name, n):
    return ", ".join(f"{name}{i}" for i in range(n - 1, -1, -1))


#: The model's Verilog text (module ``MULT18X18D``; every parameter of the primitive
#: accepted, the cascade ports left open).
MODEL = f"""// MULT18X18D simulation model (tdicam.cosim.mult18x18d): the configuration tdicam uses
module MULT18X18D (
  input {_bus("A", 18)},
  input {_bus("B", 18)},
  input {_bus("C", 18)},
  input SIGNEDA, SIGNEDB, SOURCEA, SOURCEB,
  input CLK3, CLK2, CLK1, CLK0, CE3, CE2, CE1, CE0, RST3, RST2, RST1, RST0,
  input {_bus("SRIA", 18)},
  input {_bus("SRIB", 18)},
  output {_bus("SROA", 18)},
  output {_bus("SROB", 18)},
  output {_bus("ROA", 18)},
  output {_bus("ROB", 18)},
  output {_bus("ROC", 18)},
  output {_bus("P", 36)},
  output SIGNEDP
);
  parameter REG_INPUTA_CLK = "NONE";
  parameter REG_INPUTA_CE = "CE0";
  parameter REG_INPUTA_RST = "RST0";
  parameter REG_INPUTB_CLK = "NONE";
  parameter REG_INPUTB_CE = "CE0";
  parameter REG_INPUTB_RST = "RST0";
  parameter REG_INPUTC_CLK = "NONE";
  parameter REG_INPUTC_CE = "CE0";
  parameter REG_INPUTC_RST = "RST0";
  parameter REG_PIPELINE_CLK = "NONE";
  parameter REG_PIPELINE_CE = "CE0";
  parameter REG_PIPELINE_RST = "RST0";
  parameter REG_OUTPUT_CLK = "NONE";
  parameter REG_OUTPUT_CE = "CE0";
  parameter REG_OUTPUT_RST = "RST0";
  parameter CLK0_DIV = "ENABLED";
  parameter CLK1_DIV = "ENABLED";
  parameter CLK2_DIV = "ENABLED";
  parameter CLK3_DIV = "ENABLED";
  parameter HIGHSPEED_CLK = "NONE";
  parameter GSR = "ENABLED";
  parameter CAS_MATCH_REG = "FALSE";
  parameter SOURCEB_MODE = "B_SHIFT";
  parameter MULT_BYPASS = "DISABLED";
  parameter RESETMODE = "SYNC";
  localparam RA = REG_INPUTA_CLK == "CLK0", RB = REG_INPUTB_CLK == "CLK0",
             RP = REG_OUTPUT_CLK == "CLK0";
  initial begin
    if ((REG_INPUTA_CLK != "NONE" && !RA) || (REG_INPUTB_CLK != "NONE" && !RB)
        || (REG_OUTPUT_CLK != "NONE" && !RP) || REG_PIPELINE_CLK != "NONE"
        || (RA && (REG_INPUTA_CE != "CE0" || REG_INPUTA_RST != "RST0"))
        || (RB && (REG_INPUTB_CE != "CE0" || REG_INPUTB_RST != "RST0"))
        || (RP && (REG_OUTPUT_CE != "CE0" || REG_OUTPUT_RST != "RST0"))
        || RESETMODE != "SYNC" || MULT_BYPASS != "DISABLED")
      $fatal(1, "MULT18X18D model: registers NONE or CLK0/CE0/RST0, no pipeline register, SYNC reset only");
  end
  wire [17:0] a = {{{_bus("A", 18)}}};
  wire [17:0] b = {{{_bus("B", 18)}}};
  reg [17:0] ra = 18'd0, rb = 18'd0;
  reg [35:0] rp = 36'd0;
  wire [17:0] ia = RA ? ra : a;
  wire [17:0] ib = RB ? rb : b;
  wire signed [35:0] sprod = $signed(ia) * $signed(ib);
  wire [35:0] uprod = ia * ib;
  wire [35:0] prod = SIGNEDA ? sprod : uprod;
  always @(posedge CLK0) begin
    if (SIGNEDA != SIGNEDB || SOURCEA || SOURCEB)
      $fatal(1, "MULT18X18D model: operands from A and B, both unsigned or both signed");
    if (RST0) begin
      ra <= 18'd0; rb <= 18'd0; rp <= 36'd0;
    end else if (CE0) begin
      ra <= a; rb <= b; rp <= prod;
    end
  end
  assign {{{_bus("P", 36)}}} = RP ? rp : prod;
  assign SIGNEDP = SIGNEDA;
  assign {{{_bus("SROA", 18)}}} = 18'd0;
  assign {{{_bus("SROB", 18)}}} = 18'd0;
  assign {{{_bus("ROA", 18)}}} = 18'd0;
  assign {{{_bus("ROB", 18)}}} = 18'd0;
  assign {{{_bus("ROC", 18)}}} = 18'd0;
endmodule
"""
