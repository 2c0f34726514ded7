"""Registered multipliers as Lattice ECP5 MULT18X18D instances, registers in the DSP block.

yosys' ECP5 multiplier mapping (``mul2dsp`` to ``MULT18X18D``) leaves every register of the
block unused (``REG_* = "NONE"``): a pipelined multiply's input and product registers sit
in the fabric, and the routing from them into the DSP block and back (2 ns each way in the
orbit chain at ppc 8, beside the block's 3.1 ns multiply) became the chain's critical
path. The ECP5 synthesis tops build their multipliers here instead, with the block's own
input registers (A, B) on the stage's clock enable; the product register stays in the
fabric beside what adds to it (with the block's output register too, its 0.6 ns
clock-to-out and the route into the adder were NUC's slowest path).

The Verilog this gives instantiates ``MULT18X18D`` cells: yosys/nextpnr take it as is; a
simulator needs a model (yosys ships only a black box; :mod:`tdicam.cosim.mult18x18d`
models the configuration used here). ``tdicam verilog`` and every simulation keep the
generic description unless asked.
"""

from amaranth.hdl import ClockSignal, Const, Elaboratable, Instance, Module, Signal

__all__ = ["MAX_BITS", "mult"]

#: Widest unsigned operand of one MULT18X18D.
MAX_BITS = 18


def mult(m, tag, a, b, en):
    """``a * b`` (unsigned, each at most :data:`MAX_BITS` bits) of the operands registered
    in the block: they load at a rising edge of the ``sync`` clock when ``en`` is high
    (``en`` low: they hold). Returns the product of the registered operands,
    ``len(a) + len(b)`` bits, combinational after them (one clock edge after the
    operands: the caller registers it). No reset: the registers start at zero.

    The instance sits in a submodule of ``m`` named ``tag``, every output port of it
    connected (yosys 0.70's ABC9 asserted in ``ABC_OPS_REINTEGRATE`` on NUC at ppc 2, 4
    or 8, depending on the netlist, while the cascade outputs were left open)."""
    if max(len(a), len(b)) > MAX_BITS:
        raise ValueError(f"operands of {len(a)} and {len(b)} bits: at most {MAX_BITS} each")
    u = m.submodules[tag] = _Mult(len(a), len(b))
    m.d.comb += [u.a.eq(a), u.b.eq(b), u.en.eq(en)]
    return u.p


class _Mult(Elaboratable):
    def __init__(self, wa, wb):
        self.a, self.b, self.en = Signal(wa), Signal(wb), Signal()
        self.p = Signal(wa + wb)

    def elaborate(self, platform):
        m = Module()
        m.d.comb += self.p.eq(_instance(m, self.a, self.b, self.en))
        return m


def _instance(m, a, b, en):
    p = Signal(len(a) + len(b), name="p")
    full = Signal(2 * MAX_BITS, name="p36")
    ports = {"i_CLK0": ClockSignal(), "i_CE0": en, "i_RST0": Const(0),
             "i_SIGNEDA": Const(0), "i_SIGNEDB": Const(0),
             "i_SOURCEA": Const(0), "i_SOURCEB": Const(0)}
    for n in range(1, 4):
        ports.update({f"i_CLK{n}": Const(0), f"i_CE{n}": Const(0), f"i_RST{n}": Const(0)})
    for n in range(MAX_BITS):
        ports[f"i_A{n}"] = a[n] if n < len(a) else Const(0)
        ports[f"i_B{n}"] = b[n] if n < len(b) else Const(0)
        ports[f"i_C{n}"] = Const(0)
    for n in range(2 * MAX_BITS):
        ports[f"o_P{n}"] = full[n]
    for name in ("ROA", "ROB", "ROC", "SROA", "SROB"):     # unused, connected (see mult)
        out = Signal(MAX_BITS, name=name.lower())
        ports.update({f"o_{name}{n}": out[n] for n in range(MAX_BITS)})
    ports["o_SIGNEDP"] = Signal(name="signedp")
    m.d.comb += p.eq(full)
    m.submodules.dsp = Instance(
        "MULT18X18D",
        p_REG_INPUTA_CLK="CLK0", p_REG_INPUTA_CE="CE0", p_REG_INPUTA_RST="RST0",
        p_REG_INPUTB_CLK="CLK0", p_REG_INPUTB_CE="CE0", p_REG_INPUTB_RST="RST0",
        p_REG_INPUTC_CLK="NONE", p_REG_PIPELINE_CLK="NONE",
        p_REG_OUTPUT_CLK="NONE", p_REG_OUTPUT_CE="CE0",
        p_REG_OUTPUT_RST="RST0",
        p_GSR="DISABLED", p_RESETMODE="SYNC", p_SOURCEB_MODE="B_SHIFT",
        p_MULT_BYPASS="DISABLED", p_CAS_MATCH_REG="FALSE", p_HIGHSPEED_CLK="NONE",
        p_CLK0_DIV="ENABLED", p_CLK1_DIV="ENABLED", p_CLK2_DIV="ENABLED", p_CLK3_DIV="ENABLED",
        **ports)
    return p
