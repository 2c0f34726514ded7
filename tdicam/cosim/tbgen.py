"""The HDL side of the stream co-simulation testbench (generated Verilog, not synthesizable).

One testbench serves both drive modes, so a simulator build is made once per parameter set:

* ``beat_mode = 1`` (per-beat): cocotb writes the ``b_*`` registers at each falling clock
  edge and samples the handshake in the read-only phase before the rising edge.
* ``beat_mode = 0`` (fast): an HDL engine presents stimulus held in a memory loaded with
  ``$fread`` (in chunks of ``DEPTH`` beats, binary files ``stim_NNNNNN.bin`` in the run
  folder written by :func:`tdicam.cosim.codec.encode_stimulus_bin`: each word zero-extended
  to whole bytes, most significant byte first; the last chunk may be short; a chunk that
  cannot be opened or holds fewer or more bytes than its beats ends the run with ``FAIL``
  and ``$fatal``),
  draws idle cycles and backpressure from the two xorshift32 generators of
  :class:`tdicam.cosim.pauses.Pauses` (the same pattern as per-beat mode and the Amaranth driver for
  the same seed), pulses reset where a stimulus word asks for it, writes every output
  transfer to ``out.hex`` (and, with ``+trace=1``, the cycle of every input and output
  transfer to ``trace.txt``) and raises ``done``. cocotb only starts it and awaits ``done``.

A reset asked for before beat ``k`` holds ``rst`` for ``RST_CYCLES`` cycles, from the cycle
beat ``k`` would be presented. A run ends when every stimulus beat was accepted and no output transfer happened for
``drain`` cycles (so missing and extra outputs both show), or at ``max_cycles``.

The clock is generated in HDL (10 ns period) in both modes. While reset is asserted the
testbench drives ``s_axis_tvalid = 0`` and ``m_axis_tready = 0``.
"""

from dataclasses import dataclass

from tdicam.cosim.pauses import SEED_MAX, XOR_R, ZERO_SEED_STATE
from tdicam.cosim import codec

__all__ = ["stream_testbench", "stimulus_files", "SelfCheck", "TB_TOP", "RST_CYCLES", "DEPTH"]

TB_TOP = "tdicam_tb"
RST_CYCLES = 3
DEPTH = 1 << 16


@dataclass(frozen=True)
class SelfCheck:
    """Settings of a stand-alone, self-checking run of the fast-mode testbench.

    The testbench reads the binary stimulus chunks ``stim_NNNNNN.bin`` and ``expected.hex`` (one
    hex word ``{2'b00, seg[7:0], tuser, tlast, tdata}`` per expected output transfer: the
    stimulus word layout of :func:`tdicam.cosim.codec.encode_stimulus` with the segment as
    an 8-bit ``ctrl``) from
    the simulator's working folder, compares each output transfer as it happens, prints
    ``PASS <n> beats (<i> input beats, <c> cycles)`` and ends with ``$finish`` (exit status
    0), or prints ``FAIL`` with the first bad beat (index, segment, expected and received
    tuser/tlast/tdata) and ends with ``$fatal(1)`` (non-zero exit status).

    Acceptance: ``0 < n <= N`` for ``N`` expected transfers. A segment cut short by a
    mid-stream reset (the stimulus asks for one, or the reset between golden cases) may end
    early: the data in flight when the reset hit is dropped, never reordered or changed.
    Every received transfer must equal the next expected one of its segment, the last
    segment must be complete and nothing may be added. When ``n < N`` the PASS line says
    so: ``PASS <n> beats (<N - n> of <N> expected beats dropped by mid-stream resets;
    ...)``.

    Every field is also a plusarg (``+seed=``, ``+idle=``, ``+bp=`` in 1/256 units,
    ``+max_cycles=``, ``+drain=``); ``+dump`` writes ``tdicam_tb.vcd``.
    """

    n_in: int
    n_out: int
    max_cycles: int
    drain: int = 2000
    idle: int = 26
    bp: int = 26
    seed: int = 1


def _selfcheck_text(sc, bus=False):
    return f"""
  // ---- self-check: compare each output transfer with expected.hex
  localparam N_EXP = {sc.n_out};
  localparam EW = 12 + OW;
  reg [EW-1:0] exp_mem [0:{max(sc.n_out, 1) - 1}];
  reg [EW-1:0] e;
  integer exp_ptr = 0, checked = 0;
  reg finished = 1'b0;
  initial begin
    if (N_EXP > 0) $readmemh("expected.hex", exp_mem);
    if ($test$plusargs("dump")) begin
      $dumpfile("tdicam_tb.vcd");
      $dumpvars(0, {TB_TOP});
    end
    repeat (2) @(negedge clk);
    start = 1'b1;
  end
  always @(posedge clk) begin
    if (running && m_fire) begin
      while (exp_ptr < N_EXP && exp_mem[exp_ptr][OW+9:OW+2] < seg)
        exp_ptr = exp_ptr + 1;
      e = exp_mem[exp_ptr < N_EXP ? exp_ptr : 0];
      if (exp_ptr >= N_EXP || e[OW+9:OW+2] != seg) begin
        $display("FAIL beat %0d (segment %0d): an output transfer beyond the expected %0d",
                 checked, seg, N_EXP);
        $fatal(1);
      end
      if (e[OW+1:0] != {{m_tuser, m_tlast, m_tdata}}) begin
        $display("FAIL beat %0d (segment %0d): expected tuser %0d tlast %0d tdata %h, got tuser %0d tlast %0d tdata %h",
                 checked, seg, e[OW+1], e[OW], e[OW-1:0], m_tuser, m_tlast, m_tdata);
        $fatal(1);
      end
      exp_ptr = exp_ptr + 1;
      checked = checked + 1;
    end
    if (done && !finished) begin
      finished = 1'b1;
      if (timeout) begin
        $display("FAIL timeout after %0d cycles: %0d of %0d input beats accepted, %0d of %0d outputs",
                 cycles, in_idx, n_in, checked, N_EXP);
        $fatal(1);
      end
      if (exp_ptr != N_EXP) begin
        $display("FAIL beat %0d: %0d output transfers, expected %0d", checked, checked, N_EXP);
        $fatal(1);
      end
{_BUS_DONE if bus else ""}      if (checked < N_EXP)
        $display("PASS %0d beats (%0d of %0d expected beats dropped by mid-stream resets; %0d input beats, %0d cycles)",
                 checked, N_EXP - checked, N_EXP, in_idx, cycles);
      else
        $display("PASS %0d beats (%0d input beats, %0d cycles)", checked, in_idx, cycles);
      $finish;
    end
  end
"""


_BUS_DONE = """\
      if (!bus_done) begin
        $display("FAIL control bus: its configuration did not finish");
        $fatal(1);
      end
"""

_HDL_CLOCK = """\
  reg clk = 1'b0;
  always #5 clk = ~clk;
"""

#: A standalone testbench (clock from the C++ loop; ``start`` is 1 from time 0): at done the
#: summary cocotb's ``stream_tb`` would write, then ``$finish``.
_STANDALONE_TEXT = """\
  // ---- standalone run: the summary, then the end
  integer fd_sum;
  always @(posedge clk) begin
    if (done) begin
      fd_sum = $fopen("summary.json", "w");
      $fwrite(fd_sum, "{\\"cycles\\": %0d, \\"accepted\\": %0d, \\"timeout\\": %0d}\\n",
              cycles, in_idx, timeout);
      $fclose(fd_sum);
      $finish;
    end
  end
"""

#: C++ (Verilator ``$c``) of a standalone build's stimulus read: what ``$fread(mem, fd)``
#: does (records of ``@SB@`` bytes, most significant first, into at most ``@DEPTH@`` elements;
#: the bytes read) in one ``fread`` instead of Verilator's ``fgetc`` a byte (~70
#: instructions a byte: 17 % of a ppc-8 pipeline run). A wide record's 32-bit words are
#: put together four bytes at a time, whole words from the record's end (the compiler
#: makes each one load and byte swap), the partial top word from its first bytes: ~50
#: instructions a 20-byte record instead of ~190 byte by byte (3 % of a ppc-8 run).
_BULK_READ = (
    "[](IData fdi, auto& m) -> IData { FILE* const fp = VL_CVT_I_FP(fdi); if (!fp) return 0; "
    "constexpr size_t SB = @SB@, DEPTH = @DEPTH@; "
    "static std::vector<unsigned char> buf(SB * DEPTH); "
    "const size_t n = std::fread(buf.data(), 1, buf.size(), fp); "
    "for (size_t r = 0; r < n / SB; ++r) { const unsigned char* b = &buf[r * SB]; "
    "auto& e = m[r]; using T = std::decay_t<decltype(e)>; "
    "if constexpr (std::is_integral_v<T>) { T v = 0; "
    "for (size_t j = 0; j < SB; ++j) v = (v << 8) | b[j]; e = v; } "
    "else { for (size_t k = 0; k < SB / 4; ++k) { const unsigned char* p = b + SB - 4 * k - 4; "
    "e[k] = (static_cast<EData>(p[0]) << 24) | (static_cast<EData>(p[1]) << 16) "
    "| (static_cast<EData>(p[2]) << 8) | static_cast<EData>(p[3]); } "
    "if constexpr (SB % 4 != 0) { EData v = 0; "
    "for (size_t j = 0; j < SB % 4; ++j) v = (v << 8) | b[j]; e[SB / 4] = v; } } } "
    "return static_cast<IData>(n); }(")


def _fread(standalone, sb, depth):
    """The stimulus read of ``load_chunk``: ``$fread``, or in a standalone (Verilator)
    build the same read in one C++ ``fread`` (:data:`_BULK_READ`)."""
    if not standalone:
        return "$fread(mem, fd_s)"
    code = _BULK_READ.replace("@SB@", str(sb)).replace("@DEPTH@", str(depth))
    return f'$c32("{code}", fd_s, ", ", mem, ")")'


_PER_BEAT_REGS = """\
  reg b_rst = 1'b1;
  reg [IW-1:0] b_tdata = 0;
  reg b_tvalid = 1'b0, b_tuser = 1'b0, b_tlast = 1'b0, b_tready = 1'b0;
  reg [CW-1:0] b_ctrl = 0;
"""

def _connections(per_beat):
    """The DUT's input wires: the per-beat registers or the engine (``beat_mode``), or
    the engine alone."""
    wires = (("rst", "", "b_rst", "f_rst"), ("s_tdata", "[IW-1:0] ", "b_tdata", "cur[IW-1:0]"),
             ("s_tvalid", "", "b_tvalid", "f_tvalid"), ("s_tuser", "", "b_tuser", "cur[IW+1]"),
             ("s_tlast", "", "b_tlast", "cur[IW]"),
             ("ctrl", "[CW-1:0] ", "b_ctrl", "cur[IW+2+CW-1:IW+2]"),
             ("m_tready", "", "b_tready", "f_tready"))
    return "".join(f"  wire {w}{name} = {f'beat_mode ? {b} : ' if per_beat else ''}{f};\n"
                   for name, w, b, f in wires)


def stimulus_files(stim, *, elem_padded_bits, ctrl_bits, depth=DEPTH):
    """(file name, bytes) of each stimulus chunk the fast-mode engine reads: ``depth``
    beats of :func:`tdicam.cosim.codec.encode_stimulus_bin` records per ``stim_NNNNNN.bin``
    (the last one short; one empty chunk for no beats), encoded chunk by chunk (bounded
    memory)."""
    for k in range(0, max(len(stim), 1), depth):
        yield f"stim_{k // depth:06d}.bin", codec.encode_stimulus_bin(
            stim.select(slice(k, k + depth)), elem_padded_bits=elem_padded_bits,
            ctrl_bits=ctrl_bits)


def _chunk_name_expr():
    # "stim_NNNNNN.bin" from the chunk number, without string functions (portable).
    digits = ", ".join(f"digit(chunk, {10 ** k})" for k in range(5, -1, -1))
    return f'{{"stim_", {digits}, ".bin"}}'


#: Waveform window of a run: ``wave.fst`` in the run folder holds every signal of the
#: testbench from cycle ``+wave_from`` to ``+wave_to`` (the fast engine's cycle count).
_WAVE_TEXT = """\
  // ---- waveform window (+wave_from .. +wave_to)
  reg [31:0] wave_from = 0, wave_to = 0;
  reg wave_on = 1'b0;
  initial begin
    if ($value$plusargs("wave_from=%d", wave_from) && $value$plusargs("wave_to=%d", wave_to))
    begin
      wave_on = 1'b1; $dumpfile("wave.fst"); $dumpvars(0, {top}); $dumpoff;
    end
  end
  always @(posedge clk) begin
    if (wave_on && running && cycles == wave_from) $dumpon;
    if (wave_on && running && cycles == wave_to) begin $dumpoff; $dumpflush; end
  end
"""


def stream_testbench(dut_name, *, in_bits, out_bits, ctrl_ports, depth=DEPTH, selfcheck=None,
                     wave=False, per_beat=True, standalone=False, bus=None):
    """Verilog text of the testbench around module ``dut_name``.

    Parameters
    ----------
    in_bits, out_bits : int
        ``s_axis_tdata`` and ``m_axis_tdata`` widths (multiples of 8).
    ctrl_ports : list of (name, width)
        DUT input ports besides the streams; their values ride with each stimulus beat
        (concatenated in list order, first port in the most significant bits).
    selfcheck : SelfCheck or None
        None: the cocotb-driven testbench. Otherwise the same fast-mode engine runs on its
        own from time 0 with the run settings of ``selfcheck`` as plusarg defaults, and
        compares every output transfer in HDL with ``expected.hex`` (see :class:`SelfCheck`).
    wave : bool
        Add the waveform window: with plusargs ``+wave_from=A +wave_to=B`` the simulator
        dumps cycles A..B of the fast engine to ``wave.fst`` (Icarus with the runner's
        ``WAVES=1``). A separate build: the plain testbench dumps nothing.
    per_beat : bool
        Keep the per-beat mode (the ``b_*`` registers cocotb writes). False: fast mode
        only, the DUT's inputs driven by the engine alone.
    standalone : bool
        Fast mode with no cocotb and no timing (Verilator without ``--timing``, see
        :func:`tdicam.cosim.build.build_sources` ``standalone``): ``clk`` is an input
        of the testbench, toggled by a C++ loop; the engine starts at the first clock
        edge (``start`` is 1 from time 0), and at ``done`` writes
        ``summary.json`` (``cycles``, ``accepted`` input beats, ``timeout``: what
        :mod:`tdicam.simtb.stream_tb` writes) and ends with ``$finish``. Needs
        ``per_beat=False`` and no ``selfcheck``; the same stimulus, engine and output
        files.
    bus : :class:`tdicam.cosim.tbbus.BusConfig` or None
        A top with the control bus (``--csr``): the testbench configures it through its
        AXI4-Lite (or Wishbone) slave once the reset is released (:mod:`tdicam.cosim.tbbus`); with
        ``selfcheck`` it passes only once the configuration finished.
    """
    sc = selfcheck
    d = (dict(n_in=0, n_out=0, max_cycles=1000000, drain=1000, idle=0, bp=0, seed=1)
         if sc is None else dict(n_in=sc.n_in, n_out=sc.n_out, max_cycles=sc.max_cycles,
                                 drain=sc.drain, idle=sc.idle, bp=sc.bp, seed=sc.seed))
    out_file = sc is None  # the cocotb run reads out.hex; a self-checking run compares in HDL
    cw = max(1, sum(w for _, w in ctrl_ports))
    hdr = -(-(cw + 3) // 4) * 4
    sw = hdr + in_bits
    ctrl_conn = []
    lo = cw
    for name, w in ctrl_ports:
        lo -= w
        ctrl_conn.append(f"    .{name}(ctrl[{lo + w - 1}:{lo}]),")
    ctrl_conn = "\n".join(ctrl_conn)
    from tdicam.cosim import tbbus
    bus_conn = "" if bus is None else tbbus.bus_connections(bus)
    bus_body = "" if bus is None else tbbus.bus_text(bus)
    if standalone and (per_beat or sc is not None):
        raise ValueError("a standalone testbench is fast mode only (per_beat=False, no "
                         "selfcheck)")
    return f"""\
// Generated by tdicam: co-simulation testbench for {dut_name}. Not synthesizable.
`timescale 1ns/1ps
module {TB_TOP}{"(input clk)" if standalone else ""};
  localparam IW = {in_bits};
  localparam OW = {out_bits};
  localparam CW = {cw};
  localparam SW = {sw};
  localparam SB = (SW + 7) / 8;  // bytes per binary stimulus record
  localparam DEPTH = {depth};
  localparam RST_CYCLES = {RST_CYCLES};

{"" if standalone else _HDL_CLOCK}
  function [7:0] digit(input [31:0] v, input [31:0] p);
    digit = 8'd48 + ((v / p) % 10);
  endfunction

  function [31:0] xorshift(input [31:0] s);
    reg [31:0] t;
    begin
      t = s ^ (s << 13);
      t = t ^ (t >> 17);
      xorshift = t ^ (t << 5);
    end
  endfunction

  // ---- per-beat mode: written by cocotb
  reg beat_mode = 1'b{int(sc is None and per_beat)};
{_PER_BEAT_REGS if per_beat else ""}
  // ---- fast mode engine
  reg start = 1'b{int(standalone)};
  reg running = 1'b0;
  reg done = 1'b0;
  reg timeout = 1'b0;
  reg [8*SB-1:0] mem [0:DEPTH-1];
  reg [8*15-1:0] fname;
  integer fd, fd_s;
  reg [31:0] n_in = 0, n_out = 0, max_cycles = 0, drain = 0;
  reg [31:0] in_idx = 0, out_count = 0, cycles = 0, chunk = 0, drain_cnt = 0;
  reg [31:0] idle_thr = 0, bp_thr = 0, lv = 32'h1, lr = 32'h2;
  reg [7:0] seg = 0;
  reg [3:0] rst_cnt = 0;
  reg rst_served = 1'b0, held = 1'b0, tracing = 1'b0;
  integer fd_t;
  // past the last beat the last beat's record stays on the wires: its run-time port values
  // (ctrl) hold for the frames still in the chain (a block sampling them at a frame start
  // after the stimulus ended saw the memory's next, never-written word)
  wire [31:0] rec_idx = (in_idx < n_in || n_in == 0) ? in_idx : n_in - 1;
  wire [8*SB-1:0] cur_rec = mem[rec_idx % DEPTH];
  wire [SW-1:0] cur = cur_rec[SW-1:0];

  // chunk `chunk` of the stimulus (stim_NNNNNN.bin) into mem; a bad file ends the run
  task load_chunk;
    integer want, got;
    begin
      fname = {_chunk_name_expr()};
      want = (n_in - chunk * DEPTH < DEPTH ? n_in - chunk * DEPTH : DEPTH) * SB;
      fd_s = $fopen(fname, "rb");
      if (fd_s == 0) begin
        $display("FAIL cannot open the stimulus file %0s", fname);
        $fatal(1);
      end
      got = {_fread(standalone, -(-sw // 8), depth)};
      $fclose(fd_s);
      if (got != want) begin
        $display("FAIL stimulus file %0s: %0d bytes read, %0d expected", fname, got, want);
        $fatal(1);
      end
    end
  endtask
  wire cur_rst = cur[IW+2+CW];
  wire rst_now = running && in_idx < n_in && cur_rst && !rst_served;
  wire f_rst = !running || rst_cnt != 0 || rst_now;
  wire f_present = running && !f_rst && in_idx < n_in;
  // tdicam.cosim.pauses.Pauses: offer when v & 0xff >= idle_thr; valid held until the transfer
  wire f_tvalid = f_present && (held || lv[7:0] >= idle_thr[7:0]);
  wire f_tready = running && !f_rst && (lr[7:0] >= bp_thr[7:0]);

  // ---- DUT connections
{_connections(per_beat)}  wire s_tready, m_tvalid, m_tuser, m_tlast;
  wire [OW-1:0] m_tdata;

  {dut_name} dut (
    .clk(clk),
    .rst(rst),
{ctrl_conn}
{bus_conn}    .s_axis_tdata(s_tdata),
    .s_axis_tvalid(s_tvalid),
    .s_axis_tready(s_tready),
    .s_axis_tuser(s_tuser),
    .s_axis_tlast(s_tlast),
    .m_axis_tdata(m_tdata),
    .m_axis_tvalid(m_tvalid),
    .m_axis_tready(m_tready),
    .m_axis_tuser(m_tuser),
    .m_axis_tlast(m_tlast)
  );

  wire s_fire = s_tvalid && s_tready && !rst;
  wire m_fire = m_tvalid && m_tready && !rst;

  always @(posedge clk) begin
    if (start && !running && !done) begin
      if (!$value$plusargs("n_in=%d", n_in)) n_in = {d["n_in"]};
      if (!$value$plusargs("n_out=%d", n_out)) n_out = {d["n_out"]};
      if (!$value$plusargs("max_cycles=%d", max_cycles)) max_cycles = {d["max_cycles"]};
      if (!$value$plusargs("drain=%d", drain)) drain = {d["drain"]};
      if (!$value$plusargs("idle=%d", idle_thr)) idle_thr = {d["idle"]};
      if (!$value$plusargs("bp=%d", bp_thr)) bp_thr = {d["bp"]};
      if (!$value$plusargs("seed=%d", lv)) lv = {d["seed"]};
      if ($test$plusargs("trace")) tracing = 1'b1;
      lv = lv & 32'h{SEED_MAX:08x};   // tdicam.cosim.pauses.start_state
      if (lv == 0) lv = 32'h{ZERO_SEED_STATE:08x};
      lr = lv ^ 32'h{XOR_R:08x};
      chunk = 0;
      if (n_in != 0) load_chunk;
{'      fd = $fopen("out.hex", "w");' + chr(10) if out_file else ""}      if (tracing) fd_t = $fopen("trace.txt", "w");
      running <= 1'b1;
    end else if (running) begin
      cycles <= cycles + 1;
      lv <= xorshift(lv);
      lr <= xorshift(lr);
      held <= f_tvalid && !s_tready;
      if (rst_cnt != 0)
        rst_cnt <= rst_cnt - 1;
      else if (rst_now) begin
        rst_cnt <= RST_CYCLES - 1;
        rst_served <= 1'b1;
        seg <= seg + 1;
      end
      if (tracing && s_fire) $fwrite(fd_t, "i %0d\\n", cycles);
      if (tracing && m_fire) $fwrite(fd_t, "o %0d\\n", cycles);
      if (s_fire) begin
        in_idx <= in_idx + 1;
        rst_served <= 1'b0;
        if ((in_idx + 1) % DEPTH == 0 && in_idx + 1 < n_in) begin
          chunk = chunk + 1;
          load_chunk;
        end
      end
      if (m_fire) begin
{f'        $fwrite(fd, "%h %h %h{chr(92)}n", seg, {{2{chr(39)}b00, m_tuser, m_tlast}}, m_tdata);' + chr(10) if out_file else ""}        out_count <= out_count + 1;
        drain_cnt <= 0;
      end else if (in_idx >= n_in)
        drain_cnt <= drain_cnt + 1;
      if (drain_cnt >= drain || cycles >= max_cycles) begin
        timeout <= (cycles >= max_cycles);
{'        $fclose(fd);' + chr(10) if out_file else ""}        if (tracing) $fclose(fd_t);
        running <= 1'b0;
        done <= 1'b1;
      end
    end
  end
{_WAVE_TEXT.format(top=TB_TOP) if wave else ""}{_STANDALONE_TEXT if standalone else ""}{bus_body}{"" if sc is None else _selfcheck_text(sc, bus is not None)}endmodule
"""
