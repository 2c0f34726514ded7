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

from amaranth.hdl import ClockSignal, Const, Elaboratable, Instance, Module, Signal, Value, signed

__all__ = ["DSPS", "MAX_BITS", "REGISTERS", "fits", "mult"]

#: How a block describes its multipliers (its ``dsp=`` parameter): ``"generic"`` (``*``
#: between fabric registers, what ``tdicam verilog`` writes; the synthesis tool maps it) or
#: ``"ecp5"`` (MULT18X18D instances keeping a register stage in the block, :func:`mult`:
#: the same values and cycles).
DSPS = ("generic", "ecp5")

#: Widest operand of one MULT18X18D (unsigned product; a signed product takes signed
#: operands of at most 18 bits and unsigned ones of at most 17).
MAX_BITS = 18


#: Which of the block's registers :func:`mult` uses: ``"input"`` (A and B) or ``"output"``
#: (the product).
REGISTERS = ("input", "output")


def mult(m, tag, a, b, en, registers="input"):
    """``a * b`` through one of the block's register stages, loading at a rising edge of the
    ``sync`` clock when ``en`` is high (``en`` low: it holds); no reset, the registers start
    at zero. ``registers="input"``: the operands are registered in the block; returns the
    product of the registered operands, ``len(a) + len(b)`` bits, combinational after them
    (one clock edge after the operands: the caller registers it). ``registers="output"``:
    the operands go straight into the multiplier (the caller's registers) and the product
    register is the block's; returns it (one clock edge after the operands, like a fabric
    register of ``a * b``).

    Both operands unsigned (at most :data:`MAX_BITS` bits each): an unsigned multiply
    (``SIGNEDA`` = ``SIGNEDB`` = 0), an unsigned product. Either signed: a signed multiply
    (``SIGNEDA`` = ``SIGNEDB`` = 1), each operand extended to 18 bits as its own shape says
    (an unsigned one of at most 17 bits), a signed product.

    The instance sits in a submodule of ``m`` named ``tag``, every output port of it
    connected (yosys 0.70's ABC9 asserted in ``ABC_OPS_REINTEGRATE`` on NUC at ppc 2, 4
    or 8, depending on the netlist, while the cascade outputs were left open)."""
    a, b = Value.cast(a), Value.cast(b)
    if not fits(a.shape(), b.shape()):
        raise ValueError(f"operands of {len(a)} and {len(b)} bits: at most {MAX_BITS} "
                         f"each (an unsigned one of a signed product at most {MAX_BITS - 1})")
    if registers not in REGISTERS:
        raise ValueError(f"registers = {registers!r}; valid: {', '.join(REGISTERS)}")
    sgn = a.shape().signed or b.shape().signed
    u = m.submodules[tag] = _Mult(a.shape(), b.shape(), sgn, registers)
    m.d.comb += [u.a.eq(a), u.b.eq(b), u.en.eq(en)]
    return u.p


def fits(sa, sb):
    """Whether operands of shapes ``sa`` and ``sb`` fit one MULT18X18D (:func:`mult`)."""
    sgn = sa.signed or sb.signed
    return all(s.width <= MAX_BITS - (sgn and not s.signed) for s in (sa, sb))


class _Mult(Elaboratable):
    def __init__(self, sa, sb, sgn, registers):
        self.a, self.b, self.en = Signal(sa), Signal(sb), Signal()
        w = sa.width + sb.width
        self.p = Signal(signed(w) if sgn else w)
        self._sgn, self._regs = sgn, registers

    def elaborate(self, platform):
        m = Module()
        m.d.comb += self.p.eq(_instance(m, self.a, self.b, self.en, self._sgn, self._regs))
        return m


def _instance(m, a, b, en, sgn, registers):
    p = Signal(len(a) + len(b), name="p")
    full = Signal(2 * MAX_BITS, name="p36")
    if sgn:  # each operand sign- or zero-extended to 18 bits, as its shape says
        a18, b18 = Signal(MAX_BITS, name="a18"), Signal(MAX_BITS, name="b18")
        m.d.comb += [a18.eq(a), b18.eq(b)]
        a, b = a18, b18
    ports = {"i_CLK0": ClockSignal(), "i_CE0": en, "i_RST0": Const(0),
             "i_SIGNEDA": Const(int(sgn)), "i_SIGNEDB": Const(int(sgn)),
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
    inp = "CLK0" if registers == "input" else "NONE"
    m.submodules.dsp = Instance(
        "MULT18X18D",
        p_REG_INPUTA_CLK=inp, p_REG_INPUTA_CE="CE0", p_REG_INPUTA_RST="RST0",
        p_REG_INPUTB_CLK=inp, p_REG_INPUTB_CE="CE0", p_REG_INPUTB_RST="RST0",
        p_REG_INPUTC_CLK="NONE", p_REG_PIPELINE_CLK="NONE",
        p_REG_OUTPUT_CLK="NONE" if registers == "input" else "CLK0", p_REG_OUTPUT_CE="CE0",
        p_REG_OUTPUT_RST="RST0",
        p_GSR="DISABLED", p_RESETMODE="SYNC", p_SOURCEB_MODE="B_SHIFT",
        p_MULT_BYPASS="DISABLED", p_CAS_MATCH_REG="FALSE", p_HIGHSPEED_CLK="NONE",
        p_CLK0_DIV="ENABLED", p_CLK1_DIV="ENABLED", p_CLK2_DIV="ENABLED", p_CLK3_DIV="ENABLED",
        **ports)
    return p
