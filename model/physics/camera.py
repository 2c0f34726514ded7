"""Rate budget of a whole area camera: lanes, processing, DDR traffic, NAND load, output links.

The camera of Ning et al. 2019 (Ning Yonghui et al., "Design of a large-array high-frame-rate
CMOS imaging electronics system", Optics and Precision Engineering 27(5), 2019): a GMAX0504
(5144 x 3800, two gain channels, off-chip CDS: a reset frame before each signal frame) read
through 80 LVDS lanes (§3.1, 24 Gbit/s), an XC7K325T with 4 DDR3 SDRAMs on one address bus
(§3.2: 64-bit data, 16 Gbit, the HP banks rated for 1.6 GHz) of which 2 take the 72 data
channels through a 256-bit MIG user interface at 100 MHz with > 80 % efficiency (§4.2,
Table 2: 24 10-bit pixels a word, lines 4096 addresses apart), per-pixel coefficients in a
4 G NAND flash (§4.3, 4 coefficients a 64-bit word, 64/72 SECDED) and 2 TLK2711 output links,
3.2 Gbit/s (§3.2, §5: 5 frame/s full frame).

This module holds the ``[camera]`` keys (:data:`KEYS`, defaults the paper's) and the integer
and rate arithmetic of each part, every part also as the highest frame rate it carries;
:mod:`tdicam.planning.camera` turns them into the plan's table. Everything is per second of
the sensor's frame rate ``F``; ``k`` = 2 frames read per frame with reset frames (off-chip
CDS), 1 without.

Arithmetic (``C`` columns, ``R`` rows, ``G`` gain channels)

* lanes: lane ``k`` of a gain carries columns ``k, k+L, ...`` (interleaved): every lane sends
  ``ceil(C / L)`` pixel words a line (a lane with one column fewer pads its last slot) plus
  the sync and header words; need ``k R F (ceil(C/L) + 2)`` words a second a lane against
  ``bit_rate / word_bits``.
* samples: ``k C R F`` a gain channel a second; the processing clock ``f`` carries ``f ppc``
  with the fewest ``ppc`` of :data:`tdicam.beats.PPC_CHOICES` that suffice.
* DDR, in 256-bit words (Table 2): a reset line is ``ceil(C / floor(256 / bits))`` words
  (at most 24 pixels a word), written once and read once a frame for each gain; a
  coefficient line is ``ceil(2 C / floor(256 / coeff_bits))`` words (gain and offset a
  pixel), read once a frame for each channel corrected (both gains, or one after the HDR
  merge). The traffic is shared evenly by ``ddr_interfaces`` interfaces, each of peak
  ``min(data_bits x data_rate, 8 data_bits x user_clock)`` (a MIG user word of BL8 = 8
  data words) times the measured efficiency.
* frame buffer: when the sensor's frames come faster than the links carry them (``F`` above
  the links' frame rate ``F_l``), each image sent waits in DDR: written as the chain makes it
  (``R`` lines of ``ceil(C / min(256 / link_pixel_bits, 24))`` words, at ``F``: while it
  arrives), read at the links' pace (the same words at ``F_l``); one image of room when its
  read (``1 / F_l``) ends before the next image sent begins (``F / F_o`` frames later:
  :func:`frame_buffer_words`), two else. The paper stores whole frames in its SDRAM (§4.2)
  and sends a full frame at 5 frame/s (§5).
* NAND: :func:`tdicam.model.nand_store.timing` of each coefficient image (its scan once a
  part); images of one part load one after the other.
* links: :func:`tdicam.model.tlk2711.frame_rate_limit` (framing included).
"""

from __future__ import annotations

from dataclasses import dataclass

from tdicam.model import ddr as _ddr, ddr_efficiency as _ddr_efficiency
from tdicam.model import lvds_front, nand_store, tlk2711
from tdicam.beats import PPC_CHOICES

__all__ = ["KEYS", "NUC_PLACES", "Camera", "lane_words_per_line", "lane_figures",
           "processing_figures", "ddr_words_per_frame", "ddr_peak_bps", "ddr_efficiency",
           "nand_figures", "link_figures", "frame_buffer_words", "frame_buffer_of"]

#: where the per-pixel coefficients are applied: on each gain channel before the HDR
#: merge (the paper's and the golden chain's order) or on the merged image (one channel)
NUC_PLACES = ("per_gain", "merged")

#: ``[camera]`` keys: ``key: (default, lo, hi, doc)``, defaults the camera of Ning et al.
#: 2019 (``frame_rate_hz`` None: ``[sensor].max_frame_rate_hz``; ``nuc`` a choice of
#: :data:`NUC_PLACES`).
KEYS = {
    "frame_rate_hz": (None, 1e-3, 1e6, "frame rate the camera must read the sensor at "
                      "(default [sensor].max_frame_rate_hz)"),
    "output_frame_rate_hz": (None, 1e-3, 1e6, "full frames a second sent on the output "
                             "links (default frame_rate_hz)"),
    "clock_mhz": (100.0, 1.0, 1000.0, "processing clock of the blocks (the paper's 100 MHz)"),
    "nuc": ("per_gain", None, None, "per_gain: coefficients for each gain channel before "
            "the HDR merge (the paper's); merged: one set after it"),
    "coeff_bits": (16, 4, 16, "bits of a gain or offset coefficient in DDR (the paper's "
                   "16: 4 a 64-bit word)"),
    "ddr_interfaces": (2, 1, 8, "independent DDR interfaces (the paper's 2 x16 pairs, one "
                       "a gain channel)"),
    "ddr_data_bits": (32, 8, 128, "data bits of an interface (the paper's 2 SDRAMs x16)"),
    "ddr_data_rate_mts": (1600.0, 100.0, 6400.0, "transfers a second on the data pins, "
                          "MT/s (the paper's HP banks: 1.6 GHz)"),
    "ddr_user_clock_mhz": (100.0, 10.0, 800.0, "MIG user-interface clock, MHz (the "
                           "paper's 100)"),
    "nand_parts": (1, 1, 8, "NAND parts loaded in parallel (the paper's one 4 G part)"),
    "links": (2, 1, 2, "TLK2711 output links (the paper's 2)"),
    "link_clock_mhz": (100.0, 80.0, 135.0, "the links' word clock, MHz (the paper's 100)"),
    "link_pixel_bits": (16, 1, 16, "bits a pixel on the links (the paper's 16-bit words)"),
}


@dataclass(frozen=True)
class Camera:
    """``[camera]``: the whole camera's configuration for the plan's budget (see
    :data:`KEYS`); ``frame_rate_hz`` and ``output_frame_rate_hz`` resolved."""

    frame_rate_hz: float
    output_frame_rate_hz: float
    clock_mhz: float = 100.0
    nuc: str = "per_gain"
    coeff_bits: int = 16
    ddr_interfaces: int = 2
    ddr_data_bits: int = 32
    ddr_data_rate_mts: float = 1600.0
    ddr_user_clock_mhz: float = 100.0
    nand_parts: int = 1
    links: int = 2
    link_clock_mhz: float = 100.0
    link_pixel_bits: int = 16


def lane_words_per_line(columns, lanes_per_gain):
    """Words a lane sends a line: ``ceil(columns / lanes_per_gain)`` pixel words (a lane
    with one column fewer pads its last slot) plus the sync and header words
    (:func:`tdicam.model.lvds_front.line_words`)."""
    return lvds_front.line_words(columns, lanes_per_gain)


def lane_figures(columns, rows, frames_per_s, lanes_per_gain, gains, word_bits, bit_rate_bps):
    """``(need_bps, capacity_bps, frame_rate_limit)`` of the sensor's lanes, all gains;
    ``frames_per_s`` = frames read a second (reset frames included)."""
    n = int(lanes_per_gain) * int(gains)
    per_frame = rows * lane_words_per_line(columns, lanes_per_gain) * word_bits   # a lane
    return n * per_frame * frames_per_s, n * bit_rate_bps, bit_rate_bps / per_frame


def processing_figures(samples_per_s, clock_hz):
    """``(ppc, capacity, ok)``: the fewest pixels per clock of ``PPC_CHOICES`` whose
    ``clock_hz x ppc`` carries ``samples_per_s`` (the largest when none does)."""
    ppc = next((p for p in PPC_CHOICES if p * clock_hz >= samples_per_s), PPC_CHOICES[-1])
    return ppc, ppc * clock_hz, ppc * clock_hz >= samples_per_s


def _per_word(bits):
    return min(_ddr.WORD_BITS // int(bits), _ddr.PIXELS_PER_WORD)


def ddr_words_per_frame(columns, rows, *, pixel_bits, gains, reset, coeff_bits,
                        coeff_channels):
    """256-bit words moved a frame, ``{"coefficients", "reset write", "reset read"}``, and
    the words of a reset line and of a coefficient line (Table 2 packing)."""
    reset_line = -(-columns // _per_word(pixel_bits))
    coeff_line = -(-2 * columns // (_ddr.WORD_BITS // int(coeff_bits)))
    traffic = {"coefficients": coeff_channels * rows * coeff_line,
               "reset write": gains * rows * reset_line if reset else 0,
               "reset read": gains * rows * reset_line if reset else 0}
    return traffic, reset_line, coeff_line


def ddr_peak_bps(data_bits, data_rate_mts, user_clock_mhz):
    """``(peak, pins, user)`` bit/s of one interface: the data pins ``data_bits x rate``
    and the MIG user interface ``8 data_bits x user_clock`` (BL8: a user word is 8 data
    words); the peak is the lower."""
    pins = data_bits * data_rate_mts * 1e6
    user = 8 * data_bits * user_clock_mhz * 1e6
    return min(pins, user), pins, user


def ddr_efficiency(shared=False):
    """``(efficiency, source text)`` counted on for an interface's mixed traffic, the
    lower of the memory model's and LiteDRAM's figures less
    :data:`tdicam.model.ddr_efficiency.PLAN_MARGIN`: with ``shared`` (the coefficient reads
    and the reset frames on one interface, behind the top's DdrArbiter with the output
    links' frame buffer) the arbiter's measured order (:data:`~tdicam.model.ddr_efficiency.SHARED_EFFICIENCY`); else the DDR
    block whose measured order is closest to a line written and lines read, CDS with its
    reset frame in DDR at 4096 columns."""
    if shared:
        (model, lite), what = _ddr_efficiency.SHARED_EFFICIENCY, (
            "the DdrArbiter's shared order (coefficient reads beside the reset frames and the "
            "frame buffer's lines)")
    else:
        (model, lite), what = _ddr_efficiency.MEASURED_EFFICIENCY["cds_ddr_wide"], \
            "cds_ddr_wide's"
    low = min(model, lite if lite is not None else model)
    src = "LiteDRAM" if lite is not None and lite < model else "memory model"
    return low / 100 - _ddr_efficiency.PLAN_MARGIN, (
        f"{what} measured {low:g} % ({src}, 4 refresh intervals) less the "
        f"{_ddr_efficiency.PLAN_MARGIN:.0%} plan margin")


def nand_figures(rows, columns, images, parts, geometry=nand_store.MT29F4G08):
    """``(seconds, blocks_used, blocks_available, one)``: the power-up scan and load of
    ``images`` coefficient images (each ``rows x columns``) over ``parts`` NAND parts in
    parallel (a part scans once, then loads its images one after the other);
    ``one`` the :class:`tdicam.model.nand_store.Timing` of one image."""
    one = nand_store.timing(rows, columns, geometry)
    per_part = -(-int(images) // int(parts))
    seconds = one.scan_s + per_part * one.load_s
    return seconds, per_part * one.blocks, geometry.blocks - 1, one


def link_figures(rows, columns, *, frames_per_s, pixel_bits, links, clock_hz):
    """``(need_bps, payload_bps, frame_rate_limit)``: the output image rate
    ``rows x columns x pixel_bits x frames_per_s``, the links' payload
    (:func:`tdicam.model.tlk2711.link_payload_bps`) and the frame rate they carry with
    their framing (:func:`tdicam.model.tlk2711.frame_rate_limit`)."""
    need = rows * columns * pixel_bits * frames_per_s
    payload = tlk2711.link_payload_bps(links=links, word_clock_hz=clock_hz)
    limit = tlk2711.frame_rate_limit(rows, columns, pixel_bits=pixel_bits, links=links,
                                     word_clock_hz=clock_hz)
    return need, payload, float(limit)


def frame_buffer_words(columns, rows, *, pixel_bits, frame_rate_hz, output_frame_rate_hz,
                       link_frame_rate_hz):
    """``(line_words, write, read, images)`` of the frame buffer before the output links:
    the 256-bit words of an image line (``ceil(columns / min(256 // pixel_bits, 24))``),
    the words written and read a sensor frame while an image is sent (``rows x line_words``
    written, at the frame rate; ``rows x line_words x link_frame_rate / frame_rate`` read,
    at the links' pace) and the images of room (1 when an image's read, ``1 /
    link_frame_rate``, ends within the ``frame_rate / output_frame_rate`` frames before the
    next image sent, else 2); all 0 when the links keep up with the sensor's frames
    (``frame_rate <= link_frame_rate``: no image waits)."""
    if frame_rate_hz <= link_frame_rate_hz * (1 + 1e-12):
        return 0, 0, 0.0, 0
    line = -(-int(columns) // _per_word(pixel_bits))
    write = int(rows) * line
    read = write * link_frame_rate_hz / frame_rate_hz
    images = 1 if 1 / link_frame_rate_hz <= 1 / output_frame_rate_hz * (1 + 1e-12) else 2
    return line, write, read, images


def frame_buffer_of(columns, rows, *, pixel_bits, frame_rate_hz, output_frame_rate_hz, links,
                    link_clock_hz):
    """:func:`frame_buffer_words` of a camera whose ``links`` run at ``link_clock_hz``
    (their frame rate :func:`link_figures`'s), and that frame rate last:
    ``(line_words, write, read, images, link_frame_rate_hz)``: the generated top's buffer
    (:func:`tdicam.chain.link_rates.link_buffer_images`); the plan's budget calls the same
    two functions with the same figures."""
    _, _, limit = link_figures(rows, columns, frames_per_s=output_frame_rate_hz,
                               pixel_bits=pixel_bits, links=links, clock_hz=link_clock_hz)
    return (*frame_buffer_words(columns, rows, pixel_bits=pixel_bits,
                                frame_rate_hz=frame_rate_hz,
                                output_frame_rate_hz=output_frame_rate_hz,
                                link_frame_rate_hz=limit), limit)
