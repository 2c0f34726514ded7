"""Scene targets as continuous radiance maps: charts, bundled photographs, user images.

A target is a function ``f(y, x)`` of ground position that returns the relative radiance in
[0, 1] (1 = the scene's ``[target].signal_e`` electrons per pixel per exposure). Positions are
in **sensor pixel pitches** on the focal plane: ``y`` along track (the direction the image
moves, output line index at nominal speed), ``x`` cross track (column index); pixel ``(g, c)``
is centred on ``(g, c)``. Arguments broadcast: a column vector of ``y`` and a row vector of
``x`` give a 2-D map. One-dimensional charts (``flat``, ``bars``) depend on one coordinate
only and return an array that broadcasts along the other (shape ``(ny, 1)`` or ``(1, nx)``),
which lets the renderer skip the constant axis.

Charts
------
``flat``
    1 everywhere.
``bars``
    period ``P`` pixels, Michelson contrast ``c``: bright level 1, dark level
    ``(1 - c) / (1 + c)``. ``profile = "square"``: bright where ``cos(2 pi u / P) >= 0``
    (bar edges at ``u = +-P/4``, so a period-2 chart puts one bar on each pixel);
    ``"sine"``: ``mid + amp cos(2 pi u / P)``, a single spatial frequency, which is what an
    MTF at one frequency is measured with. ``u`` is ``y`` (``along_track``) or ``x``.
``edge``
    a straight edge through the image centre, slanted ``angle_deg`` from the cross-track axis
    (so it measures the along-track edge response); bright on the ``y > y_c`` side.
``siemens``
    ``spokes`` bright/dark sector pairs around the centre (square-wave in angle).
``image``
    a grey-level picture (scikit-image's bundled samples, or a PNG/TIFF file) scaled to the
    sensor width (``columns`` pixels across), tiled along track with mirror symmetry, and
    interpolated bilinearly between its pixel centres.

Pictures (:func:`load_image`, :func:`grey_levels`)
--------------------------------------------------
At least :data:`MIN_IMAGE_SIDE` pixels on each side; one 2-D picture with its channels
last: grey, grey + alpha, RGB or RGBA (a palette PNG is expanded to its colours first).
RGB becomes grey with the Rec. 601 luma weights ``0.299 R + 0.587 G + 0.114 B``; an alpha
channel must be opaque everywhere (it is then dropped: there is no background to blend a
transparent pixel onto). Integer codes are divided by their type's full scale (255 for
8 bits, 65,535 for 16 bits, a 16-bit PNG included), booleans are 0 / 1, floating-point
values are used as they are when the largest is at most 1.0 and divided by the largest
otherwise. Refused, with a one-line error naming the file: a side under 8 pixels,
another channel count, a stack of pages or planar channels, a partly transparent alpha,
negative, NaN or infinite values, complex numbers.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["MIN_IMAGE_SIDE", "Target", "make_target", "load_image", "grey_levels",
           "bundled_image"]

#: Smallest picture side, pixels: a smaller picture is a few bilinear ramps at the sensor's
#: scale (and a 1-pixel side cannot be interpolated at all).
MIN_IMAGE_SIDE = 8
#: PIL modes that are not grey / grey+alpha / RGB / RGBA codes as they stand -> the mode
#: they are converted to first (palette indices are not grey levels).
_PIL_CONVERT = {"P": "RGBA", "PA": "RGBA", "CMYK": "RGB", "YCbCr": "RGB", "LAB": "RGB",
                "HSV": "RGB", "La": "LA", "RGBa": "RGBA", "RGBX": "RGB"}


class Target:
    """A continuous target ``f(y, x) -> relative radiance``.

    Attributes
    ----------
    kind : str
    axes : str
        ``"y"`` or ``"x"`` for a map that depends on that coordinate only, ``"yx"`` for a 2-D
        map, ``""`` for a constant.
    oversample : int
        Fine-grid samples per pixel the renderer should use along each varying axis (sharp
        charts need more than smooth photographs).
    """

    def __init__(self, kind, func, axes, oversample, *, dark_level=None):
        self.kind = kind
        self._func = func
        self.axes = axes
        self.oversample = oversample
        self.dark_level = dark_level

    def __call__(self, y, x):
        """Relative radiance at ``(y, x)`` (broadcasting; constant axes broadcast)."""
        return self._func(np.asarray(y, np.float64), np.asarray(x, np.float64))


def bundled_image(name):
    """A scikit-image sample picture as float64 grey levels in [0, 1].

    Raises
    ------
    TdicamError
        When scikit-image is missing or the name is unknown.
    """
    try:
        import skimage.data as data
    except ImportError:
        raise TdicamError("[target].image: bundled pictures need scikit-image "
                          "(pip install scikit-image)") from None
    fn = getattr(data, str(name), None)
    if fn is None or not callable(fn):
        raise TdicamError(f"[target].image: scikit-image has no sample picture {name!r}")
    try:
        img = fn()
    except Exception as exc:  # noqa: BLE001 - third-party loader, report in one line
        raise TdicamError(f"[target].image: cannot load scikit-image picture {name!r}: "
                          f"{type(exc).__name__}") from None
    return grey_levels(img)


def load_image(path):
    """A PNG or TIFF file as float64 grey levels in [0, 1] (:func:`grey_levels`; the rules
    are in the module docstring). The result is read-only and cached by path, size and
    modification time, so validating a scene per sweep point decodes the file once.

    Raises
    ------
    TdicamError
        One line naming ``[target].path``, the file and the problem.
    """
    p = Path(path)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise TdicamError(f"[target].path: file not found: {str(p)!r}") from None
    except OSError as exc:
        raise TdicamError(f"[target].path: cannot read image {str(p)!r}: {exc.strerror}"
                          ) from None
    return _load_image(str(p), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=4)
def _load_image(path, size, mtime_ns):
    p = Path(path)
    try:
        if p.suffix.lower() in (".tif", ".tiff"):
            import tifffile
            img = tifffile.imread(p)
        else:
            from PIL import Image
            with Image.open(p) as im:
                if im.mode in _PIL_CONVERT:
                    im = im.convert(_PIL_CONVERT[im.mode])
                img = np.asarray(im)
                if im.mode == "I" and im.format == "PNG":   # a 16-bit PNG read as int32
                    img = img.astype(np.uint16)
    except FileNotFoundError:
        raise TdicamError(f"[target].path: file not found: {str(p)!r}") from None
    except Exception as exc:  # noqa: BLE001 - any decoder failure is a corrupt file
        raise TdicamError(f"[target].path: cannot read image {str(p)!r}: "
                          f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
                          ) from None
    a = grey_levels(img, source=f"[target].path {str(p)!r}")
    a.setflags(write=False)
    return a


def _scale(a):
    """Codes -> [0, 1] floats (module docstring); no channel handling."""
    if a.dtype == bool:
        return a.astype(np.float64)
    if np.issubdtype(a.dtype, np.integer):
        return a.astype(np.float64) / float(np.iinfo(a.dtype).max)
    a = a.astype(np.float64)
    hi = float(a.max()) if a.size else 0.0
    return a / hi if hi > 1.0 else a


def grey_levels(img, source="[target].image"):
    """A picture (2-D, or channels last) as float64 grey levels in [0, 1]: the rules of the
    module docstring; errors are one line starting with ``source``."""
    a = np.asarray(img)
    shape = " x ".join(str(n) for n in a.shape)
    if a.dtype.kind not in "biuf":
        raise TdicamError(f"{source}: pixels of type {a.dtype} are not grey levels; need "
                          f"integer or real values")
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[-1] > 4):
        raise TdicamError(f"{source}: shape {shape} (several pages, planar channels or more "
                          f"than 4 channels); need one 2-D picture with its channels last: "
                          f"grey, grey + alpha, RGB or RGBA")
    if min(a.shape[:2]) < MIN_IMAGE_SIDE:
        raise TdicamError(f"{source}: {a.shape[0]} x {a.shape[1]} pixels; need at least "
                          f"{MIN_IMAGE_SIDE} x {MIN_IMAGE_SIDE}")
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise TdicamError(f"{source}: picture contains NaN or infinite values")
    n = int((a < 0).sum()) if a.dtype.kind in "if" else 0
    if n:
        raise TdicamError(f"{source}: {n} negative value{'s' * (n > 1)} (smallest "
                          f"{a.min():g}); a radiance is >= 0")
    if a.ndim == 3:
        if a.shape[-1] in (2, 4):
            alpha = _scale(a[..., -1])
            n = int((alpha < 1.0).sum())
            if n:
                raise TdicamError(f"{source}: the alpha channel is not opaque in {n} "
                                  f"pixel{'s' * (n > 1)}; flatten the picture onto a "
                                  f"background first")
            a = a[..., :-1]
        a = _scale(a)
        a = a @ np.array([0.299, 0.587, 0.114]) if a.shape[-1] == 3 else a[..., 0]
    else:
        a = _scale(a)
    return np.clip(a, 0.0, 1.0)


def _mirror(u, n):
    """Fold coordinates ``u`` (pixel centres 0..n-1) into [0, n-1] by mirror tiling."""
    if n == 1:
        return np.zeros_like(u)
    period = 2.0 * (n - 1)
    v = np.mod(u, period)
    return np.where(v > n - 1, period - v, v)


def _image_func(img, width):
    scale = img.shape[1] / float(width)          # picture pixels per sensor pixel

    def interp(u, n):
        v = _mirror(u, n)
        i0 = np.minimum(np.floor(v).astype(np.int64), n - 2)
        return i0, v - i0

    def f(y, x):
        if y.ndim == 2 and y.shape[1] == 1 and x.ndim == 2 and x.shape[0] == 1:
            # separable grid: interpolate rows then columns (bilinear, fewer operations)
            iy, fy = interp((y[:, 0] + 0.5) * scale - 0.5, img.shape[0])
            ix, fx = interp((x[0] + 0.5) * scale - 0.5, img.shape[1])
            rows = img[iy] * (1 - fy)[:, None] + img[iy + 1] * fy[:, None]
            return rows[:, ix] * (1 - fx) + rows[:, ix + 1] * fx
        yy, xx = np.broadcast_arrays(y, x)
        iy, fy = interp((yy + 0.5) * scale - 0.5, img.shape[0])
        ix, fx = interp((xx + 0.5) * scale - 0.5, img.shape[1])
        return ((img[iy, ix] * (1 - fx) + img[iy, ix + 1] * fx) * (1 - fy)
                + (img[iy + 1, ix] * (1 - fx) + img[iy + 1, ix + 1] * fx) * fy)
    return f


def make_target(target, *, columns, lines):
    """Build the continuous :class:`Target` of a validated ``[target]`` table.

    Parameters
    ----------
    target : tdicam.scene.loader.TargetSpec
    columns : int
        Sensor width in pixels (pictures are scaled to it; charts are centred on it).
    lines : int
        Output lines (charts are centred on the middle line).

    Returns
    -------
    Target
    """
    kind = target.kind
    yc, xc = (lines - 1) / 2.0, (columns - 1) / 2.0
    if kind == "flat":
        return Target("flat", lambda y, x: np.ones(np.broadcast_shapes(np.shape(y),
                                                                       np.shape(x))), "", 1)
    if kind == "image":
        img = (bundled_image(target.image) if target.image is not None
               else load_image(target.path))
        return Target("image", _image_func(img, columns), "yx", 4)
    c = target.contrast
    dark = (1.0 - c) / (1.0 + c)
    if kind == "bars":
        period = target.period_px
        along = target.direction == "along_track"
        profile = getattr(target, "profile", "square") or "square"
        mid, amp = (1.0 + dark) / 2.0, (1.0 - dark) / 2.0

        def f(y, x):
            u = y if along else x
            ph = np.cos(2.0 * math.pi * u / period)
            if profile == "sine":
                return mid + amp * ph
            return np.where(ph >= 0.0, 1.0, dark)
        return Target("bars", f, "y" if along else "x", 16,
                      dark_level=dark)
    if kind == "edge":
        t = math.tan(math.radians(target.angle_deg))

        def f(y, x):
            return np.where((y - yc) - t * (x - xc) > 0.0, 1.0, dark)
        return Target("edge", f, "yx", 8, dark_level=dark)
    if kind == "siemens":
        n = target.spokes

        def f(y, x):
            ang = np.arctan2(y - yc, x - xc)
            return np.where(np.cos(n * ang) >= 0.0, 1.0, dark)
        return Target("siemens", f, "yx", 8, dark_level=dark)
    raise TdicamError(f"[target].kind: unknown kind {kind!r}")
