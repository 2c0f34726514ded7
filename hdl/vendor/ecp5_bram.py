"""Block-RAM banks and ROMs as Lattice ECP5 DP16KD instances, output register in the block RAM.

yosys' ECP5 block-RAM mapping always sets ``REGMODE = NOREG``, so a register after the
block RAM sits in the fabric and the block RAM's ~4.1-4.3 ns clock-to-out plus the routing to
it becomes the design's critical path. The ECP5 synthesis tops build their memories here
instead, the register being the DP16KD's own output register (``REGMODE_B = "OUTREG"``):

* :func:`bank` (:class:`tdicam.hdl.tdi.TdiAccumulator`, ``bram="ecp5"``): output register
  always enabled, a fabric register after it with no logic in between: one read stage more
  than the generic memory (:data:`EXTRA_STAGES`);
* :func:`pipe_bank` (:class:`tdicam.hdl.median3.Median3`'s line buffers, ``bram="ecp5"``):
  both read stages on one clock enable, the output register *is* the second stage of a
  generic read-plus-register, no stage added;
* :func:`rom` (:class:`tdicam.hdl.calib_rom.CalibRom`, ``bram="ecp5"``): the contents as
  ``INITVAL``, both read stages on one clock enable.

The Verilog this gives instantiates ``DP16KD`` cells: yosys/nextpnr (and Lattice's tools)
take it as is; a simulator needs a DP16KD model (yosys ships only a black box;
:mod:`tdicam.cosim.dp16kd` models the subset used here). ``tdicam verilog`` and every
simulation keep the generic description unless asked.
"""

from amaranth.hdl import Cat, ClockSignal, Const, Instance, Mux, Signal

__all__ = ["PRIM_WIDTH", "EXTRA_STAGES", "bank", "pipe_bank", "prim_depth", "prims_per_bank", "rom",
           "rom_initvals", "ROM_DEPTH"]

#: Read stages a bank adds to the generic memory's (address edge, data, registers): the
#: DP16KD output register between the data and the fabric register.
EXTRA_STAGES = 1

#: DP16KD configurations, depth: data width (one 18 kbit block each)
PRIM_WIDTH = {1024: 18, 2048: 9, 4096: 4, 8192: 2, 16384: 1}
_ABITS = 14       # DP16KD address bits; a x(18432/depth) port uses the top log2(depth)


def prim_depth(depth, bits):
    """The :data:`PRIM_WIDTH` depth holding ``depth`` words of ``bits`` in the fewest
    primitives (the narrowest of those: x18 only for a bank of at most 1024 words whose
    width it packs better, e.g. the last, partly used bank of an 18-bit part)."""
    fits = [d for d in PRIM_WIDTH if d >= depth]
    return min(fits, key=lambda d: (-(-bits // PRIM_WIDTH[d]), -d))


def prims_per_bank(depth, bits):
    """DP16KD primitives of a bank of ``depth`` words of ``bits``."""
    return -(-bits // PRIM_WIDTH[prim_depth(depth, bits)])


def _prims(m, tag, *, depth, bits, ra, ceb, oceb, wa, wd, we):
    """The DP16KD primitives of a ``depth`` x ``bits`` bank side by side (port A writes
    ``wd`` at ``wa`` when ``we``, port B reads ``ra`` with clock enable ``ceb`` into its
    output register, clock enable ``oceb``): ``[(DOB signal, lo, hi)]``, primitive ``i``
    holding bits ``lo`` .. ``hi - 1`` of a word in its DOB bits ``0`` .. ``hi - lo - 1``."""
    pd = prim_depth(depth, bits)
    pw = PRIM_WIDTH[pd]
    lg = pd.bit_length() - 1
    shift = _ABITS - lg
    out = []
    for i in range(-(-bits // pw)):
        lo, hi = i * pw, min((i + 1) * pw, bits)
        do = Signal(pw, name=f"do_{tag}_{i}")
        out.append((do, lo, hi))
        ports = {"i_CLKA": ClockSignal(), "i_CEA": Const(1), "i_OCEA": Const(1),
                 "i_WEA": we, "i_RSTA": Const(0),
                 "i_CLKB": ClockSignal(), "i_CEB": ceb, "i_OCEB": oceb,
                 "i_WEB": Const(0), "i_RSTB": Const(0)}
        for n in range(3):
            ports[f"i_CSA{n}"] = ports[f"i_CSB{n}"] = Const(0)
        for n in range(_ABITS):
            k = n - shift        # x18: AD[1:0] are the write's byte enables, both on
            ports[f"i_ADA{n}"] = wa[k] if 0 <= k < len(wa) else Const(int(n < 2 and pw == 18))
            ports[f"i_ADB{n}"] = ra[k] if 0 <= k < len(ra) else Const(int(n < 2 and pw == 18))
        for n in range(18):
            ports[f"i_DIA{n}"] = wd[lo + n] if lo + n < hi else Const(0)
            ports[f"i_DIB{n}"] = Const(0)
            if n < pw:
                ports[f"o_DOB{n}"] = do[n]
        m.submodules[f"ram_{tag}_{i}"] = Instance(
            "DP16KD", p_DATA_WIDTH_A=pw, p_DATA_WIDTH_B=pw, p_REGMODE_A="NOREG",
            p_REGMODE_B="OUTREG", p_RESETMODE="SYNC", p_ASYNC_RESET_RELEASE="SYNC",
            p_CSDECODE_A="0b000", p_CSDECODE_B="0b000", p_WRITEMODE_A="NORMAL",
            p_WRITEMODE_B="NORMAL", p_GSR="AUTO", **ports)
    return out


def bank(m, tag, *, depth, bits, ra, re, rh, wa, wd, we):
    """A bank of ``depth`` x ``bits`` built from DP16KD primitives side by side.

    Parameters
    ----------
    m : Module
        Where the primitives and registers go (``sync`` domain).
    tag : str
        Name stem of the instances (``ram_<tag>_<i>``) and registers.
    depth : int
        Words of the bank, 1..16384; the primitives' configuration is :func:`prim_depth`.
    bits : int
        Word width; the last primitive's unused data bits are tied to zero.
    ra, re : Value
        Read address (its low ``log2(depth)`` bits; narrower: zero-extended) and read
        enable, sampled at a clock edge (the DP16KD's port B address register, clock enable
        ``CEB``).
    rh : Value
        ``re`` one cycle later (high in the cycle the read data would leave a block RAM
        without output register).
    wa, wd, we : Value
        Write address, data and enable (port A, ``WRITEMODE_A = NORMAL``), sampled at a
        clock edge.

    Returns
    -------
    Signal
        ``bits`` wide, registered: the word read three clock edges earlier (the address
        edge, the DP16KD output register, ``REGMODE_B = "OUTREG"`` with ``OCEB`` = 1, then a
        fabric register, :data:`EXTRA_STAGES` more than the generic memory's) when it was
        read, else zero (the fabric register's synchronous reset, from a register of ``rh``
        per primitive; the block RAM's data reaches a flip-flop with no logic in between,
        its 0.7 ns clock-to-out in place of 4.3 ns without the output register). A read of
        the address written at the same edge is undefined (the design never uses one). No
        reset: the words start undefined; ``RSTA``/``RSTB`` are tied low.
    """
    outs = []
    for i, (do, lo, hi) in enumerate(_prims(m, tag, depth=depth, bits=bits, ra=ra, ceb=re,
                                            oceb=Const(1), wa=wa, wd=wd, we=we)):
        sel = Signal(name=f"rq_{tag}_{i}")     # data valid at DOB: one register per primitive
        m.d.sync += sel.eq(rh)
        outs.append(Mux(sel, do[:hi - lo], 0))
    q = Signal(bits, name=f"q_{tag}")
    m.d.sync += q.eq(Cat(*outs))
    return q


def pipe_bank(m, tag, *, depth, bits, ra, wa, wd, we, en):
    """A bank of ``depth`` x ``bits`` (DP16KD primitives side by side, as :func:`bank`)
    whose read is a two-stage pipeline moving on ``en``: the address register (``CEB``)
    and the DP16KD output register (``OCEB``, ``REGMODE_B = "OUTREG"``), nothing after it.

    The read behaves as a generic memory's read port with enable ``en`` followed by a
    register on ``en`` (what :class:`tdicam.hdl.median3.Median3`'s line buffers are), with
    the block RAM's short output-register clock-to-out in place of the 4.1 ns of a read
    without it.

    Parameters
    ----------
    m : Module
        Where the primitives go.
    tag : str
        Name stem of the instances (``ram_<tag>_<i>``).
    depth, bits : int
        As :func:`bank`.
    ra : Value
        Read address, sampled at a clock edge with ``en`` high.
    wa, wd, we : Value
        Write address, data and enable (port A), sampled at a clock edge.
    en : Value
        Clock enable of both read stages.

    Returns
    -------
    Value
        ``bits`` wide: the word addressed at the edge with ``en`` before the last edge with
        ``en`` (the DP16KD output registers, no fabric logic). Undefined before two such
        edges and for a word never written (no reset, no initial contents); a read of the
        address written at the same edge is undefined (the caller never makes one).
    """
    return Cat(*(do[:hi - lo] for do, lo, hi in _prims(m, tag, depth=depth, bits=bits,
                                                        ra=ra, ceb=en, oceb=en, wa=wa, wd=wd,
                                                        we=we)))


#: Deepest :func:`rom`: one DP16KD at 9 bits (a ROM of at most 1024 words uses x18).
ROM_DEPTH = 2048


def _rom_width(depth):
    if not 1 <= depth <= ROM_DEPTH:
        raise ValueError(f"ECP5 ROM depth {depth}: 1..{ROM_DEPTH}")
    return 18 if depth <= 1024 else 9


def rom_initvals(columns, depth):
    """The ``INITVAL_00`` .. ``INITVAL_3F`` parameters (name -> 320-bit int) of a DP16KD
    holding ``columns`` (the primitive's word ``w`` = ``columns[w]``, ``depth`` words) at
    the data width :func:`rom` gives it (x18 up to 1024 words, else x9).

    The array is 1024 rows of 18 bits (two bytes of 9), row ``r`` at bits ``20 (r mod 16)``
    .. ``+ 17`` of ``INITVAL_<r // 16>`` (the 2 bits above each row unused); an x9 word
    ``w`` is byte ``w mod 2`` (byte 0 the low 9 bits) of row ``w // 2``. This is the layout
    yosys gives an inferred memory's contents (``brams_map_16kd.v``; a test compares the
    two)."""
    pw = _rom_width(depth)
    rows = [0] * 1024
    for w, v in enumerate(columns):
        if pw == 18:
            rows[w] = v
        else:
            rows[w >> 1] |= v << (9 * (w & 1))
    out = {}
    for i in range(64):
        out[f"INITVAL_{i:02X}"] = sum(rows[16 * i + j] << (20 * j) for j in range(16))
    return out


def rom(m, tag, *, words, bits, addr, en):
    """A ROM of ``words`` (ints of ``bits`` bits, at most :data:`ROM_DEPTH`) as DP16KD
    primitives with their output register (``REGMODE_B = "OUTREG"``).

    Only the bits that differ between words are stored, packed side by side into as few
    primitives as hold them (x18 for up to 1024 words, else x9); a bit equal in every word
    is a constant (what yosys does with an inferred memory's constant bits).

    Parameters
    ----------
    m : Module
        Where the primitives go.
    tag : str
        Name stem of the instances (``rom_<tag>_<i>``).
    words : list of int
        The contents, word 0 first.
    bits : int
        Word width.
    addr : Value
        Read address (its low bits address the words), sampled at a clock edge with ``en``
        high (the port B address register, clock enable ``CEB``).
    en : Value
        Clock enable of both read stages: the address register (``CEB``) and the output
        register (``OCEB``). The ROM is then a two-stage pipeline moving on ``en``.

    Returns
    -------
    Value
        ``bits`` wide: the word addressed at the edge with ``en`` before the last edge with
        ``en`` (the block RAM's output register: a flip-flop, its short clock-to-out in
        place of the 4.1 ns of a read without it). Before two such edges: undefined (zero
        on the device, the output register's reset value).
    """
    depth = len(words)
    pw = _rom_width(depth)
    vary = [j for j in range(bits) if any((w >> j) & 1 != (words[0] >> j) & 1 for w in words)]
    const = words[0] if words else 0
    out = [Const((const >> j) & 1, 1) for j in range(bits)]
    lg = {18: 4, 9: 3}[pw]
    for i in range(-(-len(vary) // pw)):
        cols = vary[i * pw:(i + 1) * pw]
        data = [sum(((w >> j) & 1) << k for k, j in enumerate(cols)) for w in words]
        do = Signal(pw, name=f"rom_{tag}_{i}_do")
        ports = {"i_CLKA": ClockSignal(), "i_CEA": Const(0), "i_OCEA": Const(0),
                 "i_WEA": Const(0), "i_RSTA": Const(0),
                 "i_CLKB": ClockSignal(), "i_CEB": en, "i_OCEB": en,
                 "i_WEB": Const(0), "i_RSTB": Const(0)}
        for n in range(3):
            ports[f"i_CSA{n}"] = ports[f"i_CSB{n}"] = Const(0)
        for n in range(_ABITS):
            k = n - lg
            ports[f"i_ADA{n}"] = Const(0)
            ports[f"i_ADB{n}"] = addr[k] if 0 <= k < len(addr) else Const(0)
        for n in range(18):
            ports[f"i_DIA{n}"] = ports[f"i_DIB{n}"] = Const(0)
            if n < pw:
                ports[f"o_DOB{n}"] = do[n]
        init = {f"p_{k}": Const(v, 320) for k, v in rom_initvals(data, depth).items()}
        m.submodules[f"rom_{tag}_{i}"] = Instance(
            "DP16KD", p_DATA_WIDTH_A=pw, p_DATA_WIDTH_B=pw, p_REGMODE_A="NOREG",
            p_REGMODE_B="OUTREG", p_RESETMODE="SYNC", p_ASYNC_RESET_RELEASE="SYNC",
            p_CSDECODE_A="0b000", p_CSDECODE_B="0b000", p_WRITEMODE_A="NORMAL",
            p_WRITEMODE_B="NORMAL", p_GSR="AUTO", **init, **ports)
        for k, j in enumerate(cols):
            out[j] = do[k]
    return Cat(*out)
