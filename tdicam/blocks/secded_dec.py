"""Block ``secded_dec``: the SECDED (72,64) Hsiao decoder (Ning et al. 2019 §4.3; ``hdl/ecc.py``,
``model/ecc.py``): corrects one flipped bit, flags two. Plain ports for ``tdicam verilog``;
``--stream 1`` wraps it on AXI4-Stream byte lanes (9 code bytes in; 8 data bytes, the
syndrome and the flags out: :mod:`tdicam.blocks._secded`).
"""

import numpy as np

from tdicam.beats import Beats
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.ecc import SecdedDecoder, SecdedDecoderStream
from tdicam.model import ecc
from tdicam.blocks import Bench, StreamWork, SynthRef
from tdicam.blocks._bench import WORDS, WORDS_QUICK
from tdicam.blocks import Block, Case, Param, SideInput, Streams
from tdicam.blocks._secded import PARAMS, markers, word_bytes

__all__ = ["BLOCK", "dec_beats", "sweep_codes"]


# ---- top
def _top(*, registered, pipelined, stream):
    if stream:
        return AxisTop(SecdedDecoderStream(registered=registered, pipelined=pipelined))
    return SecdedDecoder(registered=registered, pipelined=pipelined)


# ---- cases
def dec_beats(data, check):
    """(stimulus, expected) beats of the decoder stream for received words ``(data, check)``:
    9 code bytes in; out 8 data bytes, the syndrome, flags (bit 0 corrected, bit 1
    uncorrectable), all from :func:`tdicam.model.ecc.decode`."""
    data = np.asarray(data, np.uint64)
    check = np.asarray(check, np.uint8)
    first, last = markers(len(data))
    res = ecc.decode(data, check)
    flags = res.corrected.astype(np.uint64) | (res.uncorrectable.astype(np.uint64) << 1)
    exp = np.concatenate([word_bytes(res.data, 8), res.syndrome.astype(np.uint64)[:, None],
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


def _sweep(n_words):
    def make(params, rng):
        d, c, n = sweep_codes(ecc.sweep_words(n_words, seed=int(rng.integers(1 << 30))))
        res = ecc.decode(d, c)
        return {"data_in": d, "check_in": c, "n_flips": n.astype(np.uint8),
                "data": res.data, "syndrome": res.syndrome, "corrected": res.corrected,
                "uncorrectable": res.uncorrectable}
    return make


def _multi(params, rng):
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


def _golden(arrays, params):
    res = ecc.decode(np.asarray(arrays["data_in"], np.uint64),
                     np.asarray(arrays["check_in"], np.uint8))
    return {"data": res.data, "syndrome": res.syndrome, "corrected": res.corrected,
            "uncorrectable": res.uncorrectable}


def _unstream(out, arrays, params):
    d = out.data
    data = np.zeros(len(d), np.uint64)
    for k in range(8):
        data |= d[:, k] << np.uint64(8 * k)
    flags = d[:, 9]
    return {"data": data, "syndrome": d[:, 8].astype(np.uint8),
            "corrected": (flags & np.uint64(1)) == 1,
            "uncorrectable": (flags >> np.uint64(1) & np.uint64(1)) == 1}


def _example(rng, n, shape, params):
    """Random code words with 0, 1 or 2 flipped bits (a third each)."""
    data = rng.integers(0, 1 << 64, n, dtype=np.uint64)
    k = rng.integers(0, 3, n)
    first = rng.integers(0, 72, n)
    second = (first + rng.integers(1, 72, n)) % 72
    pos = np.stack([np.where(k >= 1, first, -1), np.where(k >= 2, second, -1)], axis=1)
    d, c = ecc.flip(data, ecc.encode(data), pos)
    return {"data_in": d, "check_in": c}


# ---- entry
BLOCK = Block(
    name="secded_dec",
    module="ecc",
    summary="SECDED (72,64) Hsiao decoder: corrects 1 flipped bit, flags 2 (Ning et al. 2019 §4.3)",
    params=PARAMS[:1] + (Param("pipelined", False, "register the syndrome before the "
                               "correction (latency +1, for >= 200 MHz)", type=bool),)
    + PARAMS[1:],
    top=_top,
    cases=lambda: [
        Case("sweep_4words", {"stream": True}, _sweep(4), seed=3,
             tags=("single", "double")),
        Case("sweep_2words_registered", {"stream": True, "registered": True},
             _sweep(2), seed=4, tags=("single", "double")),
        Case("multi_flips", {"stream": True}, _multi, seed=5, tags=("multi",)),
    ],
    model_version="secded-1",
    streams=Streams(
        to_beats=lambda arrays, params: dec_beats(arrays["data_in"], arrays["check_in"]),
        stream="data_in",
        side_inputs=(SideInput("check_in", "pixel", "the received word's 8 check bits (byte 8 "
                               "of each input beat)"),),
        golden=_golden,
        to_case=lambda arrays, params: {"data_in": np.asarray(arrays["data_in"], np.uint64),
                                        "check_in": np.asarray(arrays["check_in"], np.uint8),
                                        **_golden(arrays, params)},
        unstream=_unstream,
        example=_example,
        small=((), {"stream": True}),
    ),
    order=61,
    bench=Bench("secded", StreamWork("secded_dec", "secded_dec", {"stream": True}, "word",
                                     "72-bit code words with 0/1/2 flips", (), WORDS,
                                     WORDS_QUICK)),
    synth=(SynthRef("secded_dec", target_mhz=200, note="decoder, single stage",
                    sum_with="secded_enc", sum_label="secded enc + dec"),
           SynthRef("secded_dec pipelined", {"pipelined": True}, target_mhz=200,
                    note="decoder, --pipelined (latency +1)", sum_with="secded_enc",
                    sum_label="secded enc + dec pipelined")),
)
