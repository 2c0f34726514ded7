"""A Verilog simulation model of the Lattice ECP5 DP16KD block RAM (the subset tdicam uses).

yosys ships DP16KD only as a black box (``cells_sim_ecp5.v`` in its ``share/lattice``), so
co-simulating the ECP5 variant of the TDI accumulator (:mod:`tdicam.hdl.vendor.ecp5_bram`,
``bram="ecp5"``) needs a model: :data:`MODEL`, written from Lattice's "ECP5 and ECP5-5G
Memory Usage Guide" (FPGA-TN-02204) port description. Modelled:

* ``DATA_WIDTH_A == DATA_WIDTH_B`` in 1, 2, 4, 9, 18 (x18: ``AD[1:0]`` are byte enables);
  word address ``AD[13:log2]`` (x1 ``[13:0]``, x2 ``[13:1]``, x4 ``[13:2]``, x9 ``[13:3]``,
  x18 ``[13:4]``).
* Per port, at the rising clock with ``CE`` high and chip select ``CS == CSDECODE``: a write
  (``WE``) stores ``DI``, the data output holding (``WRITEMODE = NORMAL``, the only mode
  modelled); a read loads the output latch. ``REGMODE = OUTREG`` adds the output register,
  loaded from the latch when ``OCE`` is high. ``RST`` (``RESETMODE = SYNC``) zeroes latch
  and register at the clock edge, whatever ``CE``/``OCE`` (yosys' view of the block).
* A read of the word the other port writes at the same edge returns x (undefined): a
  design that used one would show x in its output.
* The contents start as the ``INITVAL_00`` .. ``INITVAL_3F`` parameters say at x9 and x18
  (1024 rows of 18 bits, row ``r`` at bits ``20 (r mod 16)`` .. ``+ 17`` of
  ``INITVAL_<r // 16>``, an x9 word ``w`` the low / high 9 bits of row ``w // 2`` for
  even / odd ``w``: :func:`tdicam.hdl.vendor.ecp5_bram.rom_initvals`, yosys' layout), and
  x when every ``INITVAL`` is zero (a RAM whose words are written before they are read:
  a read of a word never written shows x); a nonzero ``INITVAL`` at x1, x2 or x4 stops the
  simulation (not modelled).

Anything else (other widths or modes, ``CSDECODE`` other than ``0b000``) stops the
simulation at time 0 with ``$fatal``.
"""

__all__ = ["MODEL", "FILE"]

#: File name the co-simulation build gives :data:`MODEL`.
FILE = "dp16kd_sim.v"


def _port(x):
    """Verilog of one port's (``A`` or ``B``) behaviour."""
    o = "B" if x == "A" else "A"
    return f"""
  wire [13:0] ad{x} = {{AD{x}13, AD{x}12, AD{x}11, AD{x}10, AD{x}9, AD{x}8, AD{x}7, AD{x}6,
                        AD{x}5, AD{x}4, AD{x}3, AD{x}2, AD{x}1, AD{x}0}};
  wire [17:0] di{x} = {{DI{x}17, DI{x}16, DI{x}15, DI{x}14, DI{x}13, DI{x}12, DI{x}11, DI{x}10,
                        DI{x}9, DI{x}8, DI{x}7, DI{x}6, DI{x}5, DI{x}4, DI{x}3, DI{x}2, DI{x}1,
                        DI{x}0}};
  wire on{x} = CE{x} && {{CS{x}2, CS{x}1, CS{x}0}} == 3'b000;
  wire [13:0] w{x} = word(ad{x});
  reg [17:0] lat{x}, reg{x};
  wire wr{x} = on{x} && WE{x};
  always @(posedge CLK{x}) begin
    if (wr{x}) begin
      if (W == 18) begin
        if (ad{x}[0]) mem[w{x}][8:0] <= di{x}[8:0];
        if (ad{x}[1]) mem[w{x}][17:9] <= di{x}[17:9];
      end else
        mem[w{x}] <= di{x};
    end
    if (RST{x})
      lat{x} <= 18'd0;
    else if (on{x} && !WE{x})
      lat{x} <= (wr{o} && w{o} == w{x}) ? 18'bx : mem[w{x}];
    if (RST{x})
      reg{x} <= 18'd0;
    else if (OCE{x})
      reg{x} <= lat{x};
  end
  wire [17:0] do{x} = (REGMODE_{x} == "OUTREG") ? reg{x} : lat{x};
  assign {{DO{x}17, DO{x}16, DO{x}15, DO{x}14, DO{x}13, DO{x}12, DO{x}11, DO{x}10, DO{x}9,
          DO{x}8, DO{x}7, DO{x}6, DO{x}5, DO{x}4, DO{x}3, DO{x}2, DO{x}1, DO{x}0}} =
         do{x} & mask;
"""


def _ports(x):
    bits = lambda n, k: ", ".join(f"{n}{x}{i}" for i in range(k - 1, -1, -1))  # noqa: E731
    return (f"  input {bits('DI', 18)},\n  input {bits('AD', 14)},\n"
            f"  input CE{x}, OCE{x}, CLK{x}, WE{x}, RST{x}, CS{x}2, CS{x}1, CS{x}0,\n"
            f"  output {bits('DO', 18)}")


#: The INITVAL parameters, a function ``iv(i)`` giving ``INITVAL_<i>`` and ``IV_ANY`` (one
#: of them is nonzero).
_INITVAL = "".join(f"  parameter [319:0] INITVAL_{i:02X} = 320'h0;\n" for i in range(64)) + \
    "  function [319:0] iv(input integer i);\n    case (i)\n" + \
    "".join(f"      {i}: iv = INITVAL_{i:02X};\n" for i in range(64)) + \
    "      default: iv = 320'h0;\n    endcase\n  endfunction\n" + \
    "  localparam IV_ANY = " + \
    " || ".join(f"INITVAL_{i:02X} != 0" for i in range(64)) + ";\n"

#: The model's Verilog text (module ``DP16KD``; every parameter of the primitive accepted).
MODEL = f"""// DP16KD simulation model (tdicam.cosim.dp16kd): the subset tdicam uses
module DP16KD (
{_ports("A")},
{_ports("B")}
);
  parameter DATA_WIDTH_A = 18;
  parameter DATA_WIDTH_B = 18;
  parameter REGMODE_A = "NOREG";
  parameter REGMODE_B = "NOREG";
  parameter RESETMODE = "SYNC";
  parameter ASYNC_RESET_RELEASE = "SYNC";
  parameter CSDECODE_A = "0b000";
  parameter CSDECODE_B = "0b000";
  parameter WRITEMODE_A = "NORMAL";
  parameter WRITEMODE_B = "NORMAL";
  parameter GSR = "ENABLED";
{_INITVAL}  localparam W = DATA_WIDTH_A;
  localparam LG = W == 18 ? 4 : W == 9 ? 3 : W == 4 ? 2 : W == 2 ? 1 : 0;
  localparam [17:0] mask = (18'd1 << W) - 1;
  initial begin
    if (DATA_WIDTH_A != DATA_WIDTH_B || (W != 1 && W != 2 && W != 4 && W != 9 && W != 18))
      $fatal(1, "DP16KD model: DATA_WIDTH_A = DATA_WIDTH_B in 1, 2, 4, 9, 18 only");
    if (RESETMODE != "SYNC" || CSDECODE_A != "0b000" || CSDECODE_B != "0b000"
        || WRITEMODE_A != "NORMAL" || WRITEMODE_B != "NORMAL"
        || (REGMODE_A != "NOREG" && REGMODE_A != "OUTREG")
        || (REGMODE_B != "NOREG" && REGMODE_B != "OUTREG"))
      $fatal(1, "DP16KD model: RESETMODE SYNC, CSDECODE 0b000, WRITEMODE NORMAL only");
  end
  function [13:0] word(input [13:0] ad);
    word = ad >> LG;
  endfunction
  reg [17:0] mem [0:16383];
  integer r;
  reg [319:0] ivr;
  initial if (IV_ANY) begin
    if (W != 9 && W != 18)
      $fatal(1, "DP16KD model: INITVAL at DATA_WIDTH 9 and 18 only");
    for (r = 0; r < 1024; r = r + 1) begin
      if (r % 16 == 0)
        ivr = iv(r / 16);
      if (W == 18)
        mem[r] = ivr[20 * (r % 16) +: 18];
      else begin
        mem[2 * r] = {{9'd0, ivr[20 * (r % 16) +: 9]}};
        mem[2 * r + 1] = {{9'd0, ivr[20 * (r % 16) + 9 +: 9]}};
      end
    end
  end
{_port("A")}{_port("B")}endmodule
"""
