"""Block ``secded_enc``: the SECDED (72,64) Hsiao encoder (Ning et al. 2019 §4.3; ``hdl/ecc.py``,
``model/ecc.py``). Plain ports for ``tdicam verilog``; ``--stream 1`` wraps it on
AXI4-Stream byte lanes (8 data bytes in, 9 code bytes out: :mod:`tdicam.blocks._secded`).
"""

import numpy as np

from tdicam.beats import Beats
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.ecc import SecdedEncoder, SecdedEncoderStream
from tdicam.model import ecc
from tdicam.blocks import Bench, StreamWork, SynthRef
from tdicam.blocks._bench import WORDS, WORDS_QUICK
from tdicam.blocks import Block, Case, Streams
from tdicam.blocks._secded import PARAMS, markers, word_bytes

__all__ = ["BLOCK", "enc_beats"]


# ---- top
def _top(*, registered, stream):
    if stream:
        return AxisTop(SecdedEncoderStream(registered=registered))
    return SecdedEncoder(registered=registered)


# ---- cases
def enc_beats(data):
    """(stimulus, expected) beats of the encoder stream: 8 data bytes in, 9 code bytes out."""
    data = np.asarray(data, np.uint64)
    first, last = markers(len(data))
    exp = ecc.pack_code(data, ecc.encode(data)).astype(np.uint64)
    return Beats(word_bytes(data, 8), first, last), Beats(exp, first, last)


def _case(n_random):
    def make(params, rng):
        data = np.concatenate([ecc.sweep_words(130),
                               rng.integers(0, 1 << 64, n_random, dtype=np.uint64)])
        return {"data": data, "check": ecc.encode(data)}
    return make


def _golden(arrays, params):
    """The code word: the data (passed through) and its 8 check bits."""
    data = np.asarray(arrays["data"], np.uint64)
    return {"data": data, "check": ecc.encode(data)}


def _unstream(out, arrays, params):
    data, check = ecc.unpack_code(out.data)
    return {"data": data, "check": check}


def _example(rng, n, shape, params):
    return {"data": rng.integers(0, 1 << 64, n, dtype=np.uint64)}


# ---- entry
BLOCK = Block(
    name="secded_enc",
    module="ecc",
    summary="SECDED (72,64) Hsiao encoder: 64 data bits -> 72-bit code word (Ning et al. 2019 §4.3)",
    params=PARAMS,
    top=_top,
    cases=lambda: [
        Case("words", {"stream": True}, _case(400), seed=1),
        Case("words_registered", {"stream": True, "registered": True}, _case(100),
             seed=2),
    ],
    model_version="secded-1",
    streams=Streams(
        to_beats=lambda arrays, params: enc_beats(arrays["data"]),
        stream="data",
        golden=_golden,
        to_case=_golden,
        unstream=_unstream,
        example=_example,
        small=((), {"stream": True}),
    ),
    order=60,
    bench=Bench("secded", StreamWork("secded_enc", "secded_enc", {"stream": True}, "word",
                                     "random 64-bit words", (), WORDS, WORDS_QUICK)),
    synth=(SynthRef("secded_enc", target_mhz=200, note="(72,64) encoder"),),
)
