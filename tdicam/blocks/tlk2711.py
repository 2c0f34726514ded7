"""Block ``tlk2711``: the camera's output links, the parallel side of one or two TLK2711s
(Ning et al. 2019 §3.2).

The registry's top is the word stream (``--pins false``): the framed words of every link on
``m_axis`` (each link's word an element: ``TXD | TKLSB << 16 | TKMSB << 17``, zero-padded
to 24 bits), one beat a word slot, so the golden cases co-simulate through the standard
stream testbench with random idle cycles and backpressure (``tready`` low = the links send
fill IDLEs). ``--pins true`` is the transmitter as a board has it (each link's TXD, TKLSB,
TKMSB, IDLE fill), ``--crossing true`` adds the link clock (``link_clk``) and the crossing
FIFO: co-simulated with two clocks by ``cocotb_tests/test_tlk2711.py``
(:mod:`tdicam.cosim.tlk2711`).

Golden cases hold a stream of frames of one width and possibly different heights:
``frames`` (all rows, concatenated), ``heights`` (rows per frame), ``keep`` (pixels of each
frame actually sent: fewer means a reset cuts the frame; rounded up to whole entries of
``max(ppc, links)`` pixels), ``reset_after`` (1 = reset the block before the next frame) and
``out`` (``(words, links)``: every frame's words, whole, frame numbers restarting at 0 after
each reset).
"""

import numpy as np

from tdicam.beats import Beats, cut_frames_beats
from tdicam.errors import TdicamError
from tdicam.hdl.interfaces.axis import AxisTop
from tdicam.hdl.tlk2711 import Tlk2711
from tdicam.model import tlk2711
from tdicam.model.cds import pixel_dtype
from tdicam.blocks import PPC_PARAM, Block, Case, Param, Stalls, Streams, Suite, frame_stack

__all__ = ["BLOCK", "BUILDS", "VERILATOR_BUILDS", "stream_case", "case_beats",
           "frame_word_beats"]


# ---- top
def _check(params):
    if params["crossing"] and not params["pins"]:
        raise TdicamError("--crossing true needs --pins true (the word stream has one clock)")


def _top(**params):
    return AxisTop(Tlk2711(**params))


# ---- cases
def _entry(params):
    return max(params.get("ppc", 1), params["links"])


def _check_width(width, params):
    e = _entry(params)
    if width < e or width % e:
        raise TdicamError(f"frames are {width} pixels wide: the width must be a multiple of "
                          f"{e} (ppc = {params.get('ppc', 1)}, links = {params['links']})")


def _split(out, heights, params, width):
    """``out`` (words, links) cut into each frame's words."""
    n = [tlk2711.frame_words(h, width, pixel_bits=params["pixel_bits"], links=params["links"])
         for h in heights]
    return np.split(out, np.cumsum(n)[:-1]) if n else []


def stream_case(frames, params, *, keep=None, reset_after=None):
    """Arrays of a case from a list of 2-D frames (one width, any heights)."""
    if not frames:
        raise TdicamError("a case needs at least one frame")
    w = frames[0].shape[-1]
    _check_width(w, params)
    b, links = params["pixel_bits"], params["links"]
    n = len(frames)
    reset_after = np.zeros(n, np.uint8) if reset_after is None else \
        np.asarray(reset_after, np.uint8)
    # the golden model per segment between resets: frame numbers restart at 0 after each
    cuts = [0] + [f + 1 for f in range(n - 1) if reset_after[f]] + [n]
    words = [tlk2711.tlk2711(list(frames[a:z]), pixel_bits=b, links=links).T
             for a, z in zip(cuts, cuts[1:])]
    heights = np.array([f.shape[0] for f in frames], np.int64)
    keep = heights * w if keep is None else np.asarray(keep, np.int64)
    return {"frames": np.concatenate(frames).astype(pixel_dtype(b)), "heights": heights,
            "keep": keep, "reset_after": reset_after,
            "out": np.concatenate(words).astype(np.uint32)}


def frame_word_beats(words, rows, width, params):
    """Expected beats of one frame's words ``(n, links)``: ``first`` on the frame's first
    word, ``last`` on each row's CRC word."""
    lw = tlk2711.line_words(width, pixel_bits=params["pixel_bits"], links=params["links"])
    idx = np.arange(len(words))
    last = (idx >= tlk2711.FRAME_HEADER) & ((idx - tlk2711.FRAME_HEADER) % lw == lw - 1)
    return Beats(words, idx == 0, last)


def case_beats(arrays, params):
    """(stimulus, expected) Beats of a case: ``ppc`` pixels a beat (element 0 the
    leftmost), the expected beats one word of every link each."""
    if params.get("pins"):
        raise TdicamError("tlk2711 --pins true has no output stream: its two-clock "
                          "co-simulation is cocotb_tests/test_tlk2711.py")
    img, heights = arrays["frames"], arrays["heights"].tolist()
    w = img.shape[1]
    _check_width(w, params)
    words = _split(arrays["out"], heights, params, w)
    return cut_frames_beats(img, heights, arrays["keep"], arrays["reset_after"],
                            ppc=params.get("ppc", 1), unit=_entry(params),
                            expected=lambda f, row, h: frame_word_beats(words[f], h, w, params))


def _golden(arrays, params):
    return {"out": tlk2711.tlk2711(arrays["frames"], pixel_bits=params["pixel_bits"],
                                 links=params["links"])}


def _to_case(arrays, params):
    return stream_case(list(frame_stack(arrays["frames"])), params)


def _unstream(out, arrays, params):
    return {"out": np.ascontiguousarray(out.data.T.astype(np.uint32))}


def _example(rng, n, shape, params):
    b = params["pixel_bits"]
    return {"frames": rng.integers(0, 1 << b, (n, *shape), dtype=pixel_dtype(b))}


def _width(params, per_entry=5):
    """A width that leaves a partial last word on each link at most pixel widths."""
    return per_entry * _entry(params) if _entry(params) > 1 else 7


def _random(heights):
    def make(params, rng):
        b, w = params["pixel_bits"], _width(params)
        return stream_case([rng.integers(0, 1 << b, (h, w)) for h in heights], params)
    return make


def _hard(params, rng):
    """Zeros, full scale, a constant, a 0 / full-scale checkerboard, random 0 / full
    pixels, and one frame at the smallest width (one entry a row) is a case of its own."""
    b, w = params["pixel_bits"], _width(params)
    full = (1 << b) - 1
    yy, xx = np.mgrid[0:4, 0:w]
    frames = [np.zeros((3, w), np.int64), np.full((2, w), full), np.full((3, w), full // 3),
              ((yy + xx) % 2) * full, rng.integers(0, 2, (5, w)) * full]
    return stream_case(frames, params)


def _narrow(params, rng):
    """Rows of one entry (the smallest width), random and full scale."""
    b, w = params["pixel_bits"], _entry(params)
    full = (1 << b) - 1
    return stream_case([rng.integers(0, 1 << b, (4, w)), np.full((1, w), full),
                        rng.integers(0, 1 << b, (3, w))], params)


def _reset_mid_frame(params, rng):
    """Frame 0 cut by a reset after 2.5 rows (rounded up to a whole entry); frame 1 clean;
    frame 2 cut after its last pixel, while its words are still leaving; frame 3 clean
    (numbered 0 again after each reset)."""
    b, w, e = params["pixel_bits"], _width(params), _entry(params)
    frames = [rng.integers(0, 1 << b, (h, w)) for h in (4, 3, 3, 2)]
    keep = [-(-(5 * w // 2) // e) * e, 3 * w, 3 * w, 2 * w]
    return stream_case(frames, params, keep=keep, reset_after=[1, 0, 1, 0])


def _build(ppc, links, bits):
    return {"pixel_bits": bits, "ppc": ppc, "links": links}


#: Parameter sets of the golden cases (each one is a simulator build): both link counts,
#: every ppc, 16-bit pixels (one a word), 12 and 10 (packed across words), 8 (two a word)
#: and odd widths (1, 7, 11 bits).
BUILDS = {
    "p1_l2_12b": _build(1, 2, 12),      # two beats an entry (one pixel for each link)
    "p1_l1_16b": _build(1, 1, 16),
    "p1_l1_1b": _build(1, 1, 1),
    "p2_l2_16b": _build(2, 2, 16),
    "p2_l1_7b": _build(2, 1, 7),
    "p4_l2_10b": _build(4, 2, 10),
    "p4_l1_8b": _build(4, 1, 8),
    "p8_l2_16b": _build(8, 2, 16),
    "p8_l1_12b": _build(8, 1, 12),
    "p8_l2_11b": _build(8, 2, 11),
}


def _cases():
    out = []
    for k, (name, p) in enumerate(BUILDS.items()):
        s = 10 * k + 1
        out += [
            Case(f"{name}_random", p, _random([3, 1, 2, 4]), seed=s,
                 tags=("height-change",)),
            Case(f"{name}_hard", p, _hard, seed=s + 1, tags=("fullscale", "zeros",
                                                              "constant")),
            Case(f"{name}_narrow", p, _narrow, seed=s + 2, tags=("smallest",)),
            Case(f"{name}_reset", p, _reset_mid_frame, seed=s + 3, tags=("reset",)),
        ]
    return out


#: Parameter sets Verilator runs in every run (each a build): the two-link ones at every ppc
#: and 12-bit pixels into one link at 8 pixels a clock; all with TDICAM_FULL=1.
VERILATOR_BUILDS = ("p1_l2_12b", "p2_l2_16b", "p4_l2_10b", "p8_l2_16b", "p8_l2_11b", "p8_l1_12b")


def _full_only(case, sim, mode):
    return sim == "verilator" and not any(case.params == BUILDS[b] for b in VERILATOR_BUILDS)


# ---- entry
BLOCK = Block(
    name="tlk2711",
    summary="Output links: 1-2 TLK2711 transmitters' parallel side (16-bit words at the "
            "link clock, K-character frame and row markers, a CRC a row), 1-8 pixels/clock "
            "(Ning et al. 2019 §3.2)",
    params=(
        Param("pixel_bits", 16, "pixel width, packed densely into the 16-bit words",
              lo=tlk2711.PIXEL_BITS[0], hi=tlk2711.PIXEL_BITS[1]),
        PPC_PARAM,
        Param("links", 2, "links (TLK2711s); with 2, link L carries the columns L, L+2, ...",
              choices=tlk2711.LINKS),
        Param("pins", False, "each link's TXD/TKLSB/TKMSB pins (IDLE fill) instead of the "
              "word stream on m_axis", type=bool),
        Param("crossing", False, "with --pins: the links on their own clock (link_clk), the "
              "pixels crossing through an async FIFO", type=bool),
        Param("fifo_depth", 16, "input FIFO entries (across the clocks with --crossing; it "
              "holds the input while a row's header and trailer leave)",
              choices=(4, 8, 16, 32, 64, 128, 256)),
    ),
    top=_top,
    cases=_cases,
    check=_check,
    model_version="tlk2711-1",
    streams=Streams(
        to_beats=case_beats,
        stream="frames",
        golden=_golden,
        to_case=_to_case,
        unstream=_unstream,
        example=_example,
        small=((4, 8), {"pixel_bits": 12, "links": 2}),
    ),
    order=95,
    # fast mode: a build's cases as one stream (cocotb_tests/test_tlk2711.py); at full rate
    # with 8 pixels of 16 bits a clock into 2 links the links limit (a word a clock)
    suite=Suite(fast=False, full_only=_full_only, stalls=Stalls("p8_l2_16b_random")),
)
