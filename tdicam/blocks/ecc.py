"""Blocks ``secded_enc`` and ``secded_dec``: the SECDED (72,64) Hsiao code (SPEC 3.6).

Both are plain-port components (``data``/``code``/flags) for ``tdicam verilog``; with
``--stream 1`` the same core is wrapped on AXI4-Stream byte lanes, which is what the golden
cases and the co-simulation use (``hdl/ecc.py``, ``model/ecc.py``,
``cocotb_tests/test_ecc.py``, ``golden/secded_enc/``, ``golden/secded_dec/``).
"""

import numpy as np

from ..cosim.codec import Beats
from ..hdl.axis import AxisTop
from ..hdl.ecc import (SecdedDecoder, SecdedDecoderStream, SecdedEncoder,
                       SecdedEncoderStream)
from ..model import ecc
from . import Block, Case, Param

__all__ = ["BLOCKS", "enc_beats", "dec_beats", "sweep_codes"]

_PARAMS = (
    Param("registered", False, "add one output register to the core (latency +1)", type=bool),
    Param("stream", False, "wrap the core on AXI4-Stream byte lanes (co-simulation, stream "
                           "designs) instead of plain data/code/flag ports", type=bool),
)


def _enc_top(*, registered, stream):
    if stream:
        return AxisTop(SecdedEncoderStream(registered=registered))
    return SecdedEncoder(registered=registered)


def _dec_top(*, registered, pipelined, stream):
    if stream:
        return AxisTop(SecdedDecoderStream(registered=registered, pipelined=pipelined))
    return SecdedDecoder(registered=registered, pipelined=pipelined)


def _markers(n, line=16):
    idx = np.arange(n)
    return idx == 0, (idx % line == line - 1) | (idx == n - 1)


def _bytes(words, nbytes):
    w = np.asarray(words, np.uint64)
    return np.stack([(w >> np.uint64(8 * k)) & np.uint64(0xFF) for k in range(nbytes)], axis=1)


def enc_beats(data):
    """(stimulus, expected) beats of the encoder stream: 8 data bytes in, 9 code bytes out."""
    data = np.asarray(data, np.uint64)
    first, last = _markers(len(data))
    exp = ecc.pack_code(data, ecc.encode(data)).astype(np.uint64)
    return Beats(_bytes(data, 8), first, last), Beats(exp, first, last)


def dec_beats(data, check):
    """(stimulus, expected) beats of the decoder stream for received words ``(data, check)``:
    9 code bytes in; out 8 data bytes, the syndrome, flags (bit 0 corrected, bit 1
    uncorrectable), all from :func:`tdicam.model.ecc.decode`."""
    data = np.asarray(data, np.uint64)
    check = np.asarray(check, np.uint8)
    first, last = _markers(len(data))
    res = ecc.decode(data, check)
    flags = res.corrected.astype(np.uint64) | (res.uncorrectable.astype(np.uint64) << 1)
    exp = np.concatenate([_bytes(res.data, 8), res.syndrome.astype(np.uint64)[:, None],
                          flags[:, None]], axis=1)
    return Beats(ecc.pack_code(data, check).astype(np.uint64), first, last), \
        Beats(exp, first, last)


def sweep_codes(words):
    """Every word error-free, with each of its 72 single flips and each of its 2,556 double
    flips: (data, check, n_flips) arrays of ``len(words) * 2629`` received words, word by
    word in that order."""
    words = np.asarray(words, np.uint64)
    pos = np.concatenate([np.full((1, 2), -1),
                          np.stack([np.arange(72), np.full(72, -1)], axis=1),
                          ecc.double_flip_pairs()])
    per = len(pos)
    d = np.repeat(words, per)
    c = ecc.encode(d)
    p = np.tile(pos, (len(words), 1))
    d, c = ecc.flip(d, c, p)
    n_flips = np.tile((pos >= 0).sum(axis=1), len(words))
    return d, c, n_flips


def _enc_case(n_random):
    def make(params, rng):
        data = np.concatenate([ecc.sweep_words(130),
                               rng.integers(0, 1 << 64, n_random, dtype=np.uint64)])
        return {"data": data, "check": ecc.encode(data)}
    return make


def _dec_sweep(n_words):
    def make(params, rng):
        d, c, n = sweep_codes(ecc.sweep_words(n_words, seed=int(rng.integers(1 << 30))))
        res = ecc.decode(d, c)
        return {"data_in": d, "check_in": c, "n_flips": n.astype(np.uint8),
                "data": res.data, "syndrome": res.syndrome, "corrected": res.corrected,
                "uncorrectable": res.uncorrectable}
    return make


def _dec_multi(params, rng):
    """Random words with 0..8 random flips: the >= 3-flip syndromes (odd ones that are no
    column, even ones, and the aliases that look like a single error)."""
    n = 3000
    data = rng.integers(0, 1 << 64, n, dtype=np.uint64)
    k = rng.integers(0, 9, n)
    pos = np.full((n, 8), -1)
    for i in range(n):
        pos[i, :k[i]] = rng.choice(72, k[i], replace=False)
    d, c = ecc.flip(data, ecc.encode(data), pos)
    res = ecc.decode(d, c)
    return {"data_in": d, "check_in": c, "n_flips": k.astype(np.uint8), "data": res.data,
            "syndrome": res.syndrome, "corrected": res.corrected,
            "uncorrectable": res.uncorrectable}


def _enc_to_beats(arrays, params):
    return enc_beats(arrays["data"])


def _dec_to_beats(arrays, params):
    return dec_beats(arrays["data_in"], arrays["check_in"])


BLOCKS = [
    Block(
        name="secded_enc",
        summary="SECDED (72,64) Hsiao encoder: 64 data bits -> 72-bit code word (SPEC 3.6)",
        params=_PARAMS,
        top=_enc_top,
        cases=lambda: [
            Case("words", {"stream": True}, _enc_case(400), seed=1),
            Case("words_registered", {"stream": True, "registered": True}, _enc_case(100),
                 seed=2),
        ],
        to_beats=_enc_to_beats,
        model_version="secded-1",
    ),
    Block(
        name="secded_dec",
        summary="SECDED (72,64) Hsiao decoder: corrects 1 flipped bit, flags 2 (SPEC 3.6)",
        params=_PARAMS[:1] + (Param("pipelined", False, "register the syndrome before the "
                                    "correction (latency +1, for >= 200 MHz)", type=bool),)
        + _PARAMS[1:],
        top=_dec_top,
        cases=lambda: [
            Case("sweep_4words", {"stream": True}, _dec_sweep(4), seed=3,
                 tags=("single", "double")),
            Case("sweep_2words_registered", {"stream": True, "registered": True},
                 _dec_sweep(2), seed=4, tags=("single", "double")),
            Case("multi_flips", {"stream": True}, _dec_multi, seed=5, tags=("multi",)),
        ],
        to_beats=_dec_to_beats,
        model_version="secded-1",
    ),
]
