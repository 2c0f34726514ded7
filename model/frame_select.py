"""Golden model of the frame selector before the camera's output links: the chain's frames
gathered into images of the sensor's rows, one image in ``K`` kept.

Ning et al. 2019 ("Design of a large-array high-frame-rate CMOS imaging electronics
system", Optics and Precision Engineering, 2019) read the GMAX0504 at 25 frame/s but send
full frames on their two TLK2711 links at 5 frame/s: the camera keeps one frame in ``K =
frame_rate / output_frame_rate`` (5) and drops the others (:func:`keep_every`).

The chain of an area camera (one TDI stage) hands out frames of one line each (tdicam's
frame is a line of the output): the selector counts them, ``image_frames`` of them (the
image's rows over the chain frame's rows: the sensor's 3800, or a cut's lines) make one
image, which starts at the frame start of its first (:func:`images`). Image ``i`` (from 0
after reset) is kept when ``i mod K == 0``: the first image, then every ``K``-th
(:func:`select`). A last image of fewer frames (a run that stops inside it) is an image
too, with the rows it has.

Gateware: :class:`tdicam.hdl.frame_select.FrameSelect`, bit-exact.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from tdicam.errors import TdicamError, check_range

__all__ = ["keep_every", "images", "select", "link_images", "MAX_KEEP_EVERY",
           "MAX_IMAGE_FRAMES"]

#: The largest ``K`` (frames read a frame sent) and ``image_frames`` the gateware counts
#: (16-bit counters).
MAX_KEEP_EVERY = MAX_IMAGE_FRAMES = (1 << 16) - 1


def keep_every(frame_rate_hz, output_frame_rate_hz):
    """``K``: frames read for each frame sent, ``frame_rate_hz / output_frame_rate_hz``
    (25 / 5 = 5 for Ning et al. 2019's camera).

    Raises
    ------
    TdicamError
        The ratio is not a whole number (the selector keeps one frame in ``K``), or out of
        1..:data:`MAX_KEEP_EVERY` (one line).
    """
    r = Fraction(str(float(frame_rate_hz))) / Fraction(str(float(output_frame_rate_hz)))
    if r.denominator != 1:
        raise TdicamError(f"[camera]: frame_rate_hz / output_frame_rate_hz = "
                          f"{frame_rate_hz:g} / {output_frame_rate_hz:g} = {float(r):.4g} is "
                          f"not a whole number: the output links send one frame in K; give "
                          f"an output_frame_rate_hz that divides frame_rate_hz")
    return check_range("[camera] frame_rate_hz / output_frame_rate_hz", int(r), 1,
                       MAX_KEEP_EVERY)


def images(frames, image_frames):
    """The chain's ``frames`` ``(n, rows, width)`` as images: a list of ``(r, width)``
    arrays, each of ``image_frames`` frames' rows (the last one of those left)."""
    a = np.asarray(frames)
    if a.ndim != 3:
        raise TdicamError(f"frames must be (n, rows, width), got shape {a.shape}")
    g = check_range("image_frames", image_frames, 1, MAX_IMAGE_FRAMES)
    return [a[i:i + g].reshape(-1, a.shape[2]) for i in range(0, len(a), g)]


def select(frames, *, image_frames, keep):
    """The images the selector passes: :func:`images` ``0, K, 2K, ...`` (``keep`` = ``K``)
    of ``frames`` ``(n, rows, width)``."""
    check_range("keep", keep, 1, MAX_KEEP_EVERY)
    return images(frames, image_frames)[::keep]


def link_images(frames, *, image_rows, keep):
    """:func:`select` with the image's height in rows: ``image_rows`` must be a multiple of
    the chain frame's rows (``frames.shape[1]``)."""
    rows = np.asarray(frames).shape[1]
    check_range("image_rows", image_rows, 1, None)
    if image_rows % rows:
        raise TdicamError(f"image_rows = {image_rows} is not a multiple of the chain's "
                          f"{rows}-row frames")
    return select(frames, image_frames=image_rows // rows, keep=keep)
