"""The control bus in a generated Verilog testbench (:func:`tdicam.cosim.tbgen.stream_testbench`
``bus``): an AXI4-Lite master as two Verilog-2005 tasks, ``axil_write`` and ``axil_read``,
on the top's ``s_axil_*`` slave (:mod:`tdicam.hdl.csr`), or a Wishbone B4 classic master
(``wb_write``, ``wb_read`` on ``wb_*``), and the configuration they run.

Once the testbench's engine has released the reset, the configuration writes every
setting (:class:`BusConfig` ``writes``: the scene's values, the registers' reset values, so
the frames in flight see no change) and reads back every register of ``reads`` (the
identity, the settings written), ``$fatal`` on a value other than the one expected; the
self-check passes only when the configuration finished.
"""

from dataclasses import dataclass

from tdicam.hdl.csr import AXIL_PORTS, WB_PORTS, bus_names

__all__ = ["BusConfig", "bus_text", "bus_connections"]


@dataclass(frozen=True)
class BusConfig:
    """``writes``: ((byte address, value, name), ...) in order; ``reads``: ((byte
    address, expected value, name), ...) after them; ``bus``: the top's, one of
    :data:`tdicam.hdl.csr.BUSES`."""

    writes: tuple
    reads: tuple
    bus: str = "axi4-lite"


#: Each bus's (DUT port prefix, ports, testbench signal prefix, write task, read task).
_MASTERS = {bus: (bus_names(bus)[1], ports, tb) + bus_names(bus)[2:] for bus, ports, tb in
            (("axi4-lite", AXIL_PORTS, "axil_"), ("wishbone", WB_PORTS, "wbm_"))}


def bus_connections(cfg=None):
    """The DUT instance's bus and ``irq`` connections (Verilog lines) for ``cfg``'s bus."""
    dut, ports, tb, _, _ = _MASTERS["axi4-lite" if cfg is None else cfg.bus]
    return "".join(f"    .{dut}{n}({tb}{n}),\n" for n, _, _ in ports) + \
        f"    .irq({tb}irq),\n"


def bus_text(cfg):
    """The master's signals, tasks and the configuration of ``cfg`` (Verilog text, inside
    the testbench module; the module's ``clk``, ``rst`` and ``running``)."""
    _, ports, tb, write, read = _MASTERS[cfg.bus]
    decl = []
    for n, w, d in ports:
        rng = f"[{w - 1}:0] " if w > 1 else ""
        decl.append(f"  reg {rng}{tb}{n} = 0;" if d == "in" else f"  wire {rng}{tb}{n};")
    ops = [f'      {write}(12\'h{a:03x}, 32\'h{v:08x});  // {name}' for a, v, name in cfg.writes]
    ops += [f'      {read}(12\'h{a:03x}, 32\'h{v:08x}, "{name}");' for a, v, name in cfg.reads]
    tasks = _AXIL_TASKS if cfg.bus == "axi4-lite" else _WB_TASKS
    return "\n".join(decl) + f"""
  wire {tb}irq;
  reg bus_done = 1'b0;
{tasks}  initial begin
    wait (running && !rst);
{chr(10).join(ops)}
    bus_done = 1'b1;
  end
"""


_AXIL_TASKS = """  reg [31:0] axil_got;
  // ---- the control bus: an AXI4-Lite master (signals set after a falling edge)
  task axil_write(input [11:0] a, input [31:0] d);
    begin
      @(negedge clk);
      axil_awaddr = a; axil_wdata = d; axil_wstrb = 4'hf; axil_awvalid = 1; axil_wvalid = 1;
      #1;
      while (!(axil_awready && axil_wready)) begin @(negedge clk); #1; end
      @(posedge clk); #1;
      axil_awvalid = 0; axil_wvalid = 0; axil_bready = 1;
      while (!axil_bvalid) begin @(posedge clk); #1; end
      @(posedge clk); #1;
      axil_bready = 0;
    end
  endtask
  task axil_read(input [11:0] a, input [31:0] want, input [8*32-1:0] name);
    begin
      @(negedge clk);
      axil_araddr = a; axil_arvalid = 1;
      #1;
      while (!axil_arready) begin @(negedge clk); #1; end
      @(posedge clk); #1;
      axil_arvalid = 0; axil_rready = 1;
      while (!axil_rvalid) begin @(posedge clk); #1; end
      axil_got = axil_rdata;
      @(posedge clk); #1;
      axil_rready = 0;
      if (axil_got !== want) begin
        $display("FAIL control bus: %0s at 0x%h reads %h, expected %h", name, a, axil_got, want);
        $fatal(1);
      end
    end
  endtask
"""

_WB_TASKS = """  reg [31:0] wbm_got;
  // ---- the control bus: a Wishbone B4 classic master (strobe held until ack)
  task wb_write(input [11:0] a, input [31:0] d);
    begin
      @(negedge clk);
      wbm_adr = a[11:2]; wbm_dat_w = d; wbm_sel = 4'hf; wbm_we = 1; wbm_cyc = 1; wbm_stb = 1;
      @(posedge clk); #1;
      while (!wbm_ack) begin @(posedge clk); #1; end
      wbm_cyc = 0; wbm_stb = 0; wbm_we = 0;
    end
  endtask
  task wb_read(input [11:0] a, input [31:0] want, input [8*32-1:0] name);
    begin
      @(negedge clk);
      wbm_adr = a[11:2]; wbm_we = 0; wbm_cyc = 1; wbm_stb = 1;
      @(posedge clk); #1;
      while (!wbm_ack) begin @(posedge clk); #1; end
      wbm_got = wbm_dat_r;
      wbm_cyc = 0; wbm_stb = 0;
      if (wbm_got !== want) begin
        $display("FAIL control bus: %0s at 0x%h reads %h, expected %h", name, a, wbm_got, want);
        $fatal(1);
      end
    end
  endtask
"""
