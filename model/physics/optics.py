"""Image formation of a push-broom TDI camera: where each exposure looks and what it integrates.

Yuan et al. 2013: Yuan Gaobin, Li Binqiao, Xu Jiangtao, Nie Kaiming, "MTF velocity-mismatch model of
TDI area-array CMOS image sensors", 2013. Tao et al. 2012: Tao Shuping, Jin Guang, Qu Hongsong, He
Xiaojun, Yang Xiubin, "Design and analysis of a digital-domain TDI CMOS camera for
high-resolution space imaging", 2012.

Kinematics (first principles; Yuan et al. 2013 and Tao et al. 2012)
-------------------------------------------------------
Lengths are in sensor pixel pitches on the focal plane and times in line periods ``T``.
The TDI clock moves the charge (or, in digital TDI, the addressing) by one row per line
period; the image of the ground moves along track at ``v = 1 - dV/V`` rows per line period
(Yuan et al. 2013 eq 5 with ``dV = V - V_m``: a positive mismatch is an image slower than the clock)
and across track at ``v tan(theta)`` for a drift (crab) angle ``theta``. Consequences, all
modelled exactly by :class:`Geometry`:

* output line ``g`` looks at ground position ``y = g v`` (lines are ``v`` pitches apart on
  the ground: a mismatch also rescales the image along track) and, with drift, at a cross-track
  shift ``g v tan(theta)`` (shear);
* within one exposure the image moves ``v`` pitches along track and ``v tan(theta)`` across
  (the temporal-sampling blur; Yuan et al. 2013 writes it ``sinc(f T_int/T_L)``);
* between two successive exposures of the same ground line the image moves ``v (1 - e)``
  while the row moves 1, so each stage lags by ``Delta = 1 - v (1 - e)`` (velocity mismatch;
  Yuan et al. 2013 eq 7's line-spread of width ``M dV/V`` is the first-order form). ``e`` is the
  rolling-shutter row skew: row ``k`` of the window is read ``k T_row`` after row 0, so two
  successive stages are ``T (1 - T_row/T)`` apart in the forward scan (``e = +T_row/T``) and
  ``T (1 + T_row/T)`` in the reverse scan (``e = -T_row/T``); ``e = 0`` for a global shutter.
  Across track each stage moves ``v tan(theta) (1 - e)``;
* every pixel integrates over its active area, a ``q/p = sqrt(fill factor)`` square, and
  the optics blur with a Gaussian PSF of standard deviation ``psf_sigma_px``.

The stage offsets are centred on the middle stage, so with no mismatch and no skew the output
is registered exactly on the line grid.

Rendering
---------
:class:`Renderer` evaluates the continuous target on a fine grid (``K`` samples per pitch
along each axis the target varies on), filters it with the static footprint (aperture x
exposure motion x PSF, separable: the diagonal exposure motion of a drifting image is taken
as the product of its along- and cross-track boxes, exact when ``tan(theta) = 0`` and a
second-order error of ``tan(theta)`` otherwise), and samples it at each exposure's offset by
linear interpolation. Boxes of non-integer width on the fine grid use fractional end weights
(trapezoidal quadrature), so widths are not rounded.

Model MTF
---------
:meth:`Geometry.mtf_along` / :meth:`Geometry.mtf_cross` give the transfer function of that
footprint summed over the M stages: ``sinc(f q/p) * sinc(f v) * exp(-2 pi^2 sigma^2 f^2) *
D_M(f Delta)`` with the discrete-stage kernel ``D_M(u) = sin(pi M u) / (M sin(pi u))``
(``-> sinc(M u)`` for small ``u``, Yuan et al. 2013 eq 8). ``f`` is in cycles per pitch. The along-track
form is :func:`tdicam.model.physics.mtf.transfer_along`, the same model ``tdicam plan`` prints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from tdicam.model.physics.mtf import check_dv_over_v, dirichlet, transfer_along

__all__ = ["Geometry", "Renderer", "box_kernel", "gauss_kernel", "dirichlet"]


@dataclass(frozen=True)
class Geometry:
    """Exposure geometry of one TDI configuration (see the module docstring).

    Attributes
    ----------
    stages : int
        M, >= 1.
    dv_over_v : float
        Velocity mismatch, in (-1, 1) (checked: anything else raises
        :class:`~tdicam.errors.TdicamError`).
    drift_deg : float
        Drift angle, degrees.
    skew : float
        Rolling-shutter row skew per stage, ``+T_row/T`` (forward scan), ``-T_row/T``
        (reverse) or 0 (global shutter, or row timing unknown).
    q_over_p : float
        Active width over pitch.
    psf_sigma_px : float
        Optics Gaussian PSF standard deviation in pitches (0: none).
    """

    stages: int
    dv_over_v: float = 0.0
    drift_deg: float = 0.0
    skew: float = 0.0
    q_over_p: float = 1.0
    psf_sigma_px: float = 0.0

    def __post_init__(self):
        check_dv_over_v(self.dv_over_v)

    @property
    def speed(self) -> float:
        """Image speed along track, rows per line period: ``1 - dV/V``."""
        return 1.0 - self.dv_over_v

    @property
    def tan_drift(self) -> float:
        return math.tan(math.radians(self.drift_deg))

    @property
    def stage_lag(self) -> float:
        """Along-track lag per stage ``Delta = 1 - v (1 - e)``, pitches."""
        return 1.0 - self.speed * (1.0 - self.skew)

    @property
    def stage_cross(self) -> float:
        """Cross-track shift per stage, ``v tan(theta) (1 - e)``, pitches."""
        return self.speed * self.tan_drift * (1.0 - self.skew)

    @property
    def line_shear(self) -> float:
        """Cross-track shift per output line, ``v tan(theta)``, pitches."""
        return self.speed * self.tan_drift

    @property
    def effective_dv_over_v(self) -> float:
        """The velocity mismatch that alone would give the same stage lag (for Yuan et al. 2013's
        ``sinc(f M dV/V)``): ``Delta``."""
        return self.stage_lag

    def stage_offsets(self):
        """Along- and cross-track offsets ``(a_s, b_s)`` of stages ``s = 0..M-1`` (first
        exposure first), centred on the middle stage; float64 arrays."""
        s = np.arange(self.stages, dtype=np.float64) - (self.stages - 1) / 2.0
        return s * self.stage_lag, s * self.stage_cross

    @property
    def moving(self) -> bool:
        """True when the stages do not all look at the same place (smear or skew)."""
        return self.stages > 1 and (self.stage_lag != 0.0 or self.stage_cross != 0.0)

    def mtf_along(self, f, *, stages=True):
        """Model along-track MTF at ``f`` cycles/pitch (signed transfer; take ``abs``): the
        camera model :func:`tdicam.model.physics.mtf.transfer_along` with a full-period exposure."""
        return transfer_along(f, self.stages, self.dv_over_v, self.skew, self.q_over_p, 1.0,
                              self.psf_sigma_px, include_stages=stages)

    def mtf_cross(self, f, *, stages=True):
        """Model cross-track MTF at ``f`` cycles/pitch (signed transfer; take ``abs``)."""
        f = np.asarray(f, np.float64)
        h = (np.sinc(f * self.q_over_p) * np.sinc(f * self.speed * self.tan_drift)
             * np.exp(-2.0 * np.pi ** 2 * self.psf_sigma_px ** 2 * f * f))
        if stages:
            h = h * dirichlet(f * self.stage_cross, self.stages)
        return h


def box_kernel(width, k):
    """Fine-grid weights (sum 1) of a box ``width`` pitches wide sampled ``k`` per pitch.

    Sample ``j`` (at ``j/k``) gets the overlap of ``[j - 1/2, j + 1/2]`` with
    ``[-width k / 2, width k / 2]``: the trapezoidal rule, exact widths. Width 0 is ``[1]``.
    """
    w = float(width) * k
    if w <= 1e-12:
        return np.ones(1)
    half = w / 2.0
    n = int(math.ceil(half + 0.5))
    j = np.arange(-n, n + 1, dtype=np.float64)
    lo = np.maximum(j - 0.5, -half)
    hi = np.minimum(j + 0.5, half)
    wts = np.clip(hi - lo, 0.0, None)
    wts = wts[wts > 0] if wts.sum() > 0 else np.ones(1)
    return wts / wts.sum()


def gauss_kernel(sigma, k):
    """Fine-grid Gaussian weights (sum 1), ``sigma`` pitches, ``k`` samples per pitch."""
    s = float(sigma) * k
    if s <= 1e-12:
        return np.ones(1)
    n = int(math.ceil(4.0 * s))
    j = np.arange(-n, n + 1, dtype=np.float64)
    w = np.exp(-0.5 * (j / s) ** 2)
    return w / w.sum()


class _Grid:
    __slots__ = ("data", "y0", "ky", "x0", "kx")

    def __init__(self, data, y0, ky, x0, kx):
        self.data, self.y0, self.ky, self.x0, self.kx = data, y0, ky, x0, kx


class Renderer:
    """Expected relative signal of every exposure: the target seen through the footprint.

    Parameters
    ----------
    target : tdicam.model.physics.targets.Target
    geometry : Geometry
    columns : int
        Output width W (columns ``col0 .. col0 + W - 1`` of the sensor).
    col0 : int
        First sensor column rendered (a crop; the target keeps its full-sensor geometry).
    optics : bool
        Apply the PSF (the ``optics`` effect).
    aperture : bool
        Integrate over the pixel's active area and the exposure's motion (always on in a real
        camera; off only to measure what it changes).
    """

    def __init__(self, target, geometry, columns, *, col0=0, optics=True, aperture=True):
        self.target = target
        self.geom = geometry
        self.columns = int(columns)
        self.col0 = int(col0)
        self.ky = target.oversample if "y" in target.axes else 1
        self.kx = target.oversample if "x" in target.axes else 1
        g = geometry
        sig = g.psf_sigma_px if optics else 0.0
        q = g.q_over_p if aperture else 0.0
        along = [box_kernel(q, self.ky), box_kernel(g.speed if aperture else 0.0, self.ky),
                 gauss_kernel(sig, self.ky)]
        cross = [box_kernel(q, self.kx),
                 box_kernel(abs(g.speed * g.tan_drift) if aperture else 0.0, self.kx),
                 gauss_kernel(sig, self.kx)]
        self.kern_y = _conv_all(along)
        self.kern_x = _conv_all(cross)
        self._a, self._b = g.stage_offsets()

    @property
    def constant(self) -> bool:
        return self.target.axes == ""

    def grid(self, g_lo, g_hi):
        """Filtered fine grid covering output lines ``g_lo..g_hi`` (inclusive) for every
        stage offset."""
        t, g = self.target, self.geom
        hy = (len(self.kern_y) // 2 + 2) / self.ky
        hx = (len(self.kern_x) // 2 + 2) / self.kx
        if "y" in t.axes:
            lo = min(g_lo * g.speed, g_hi * g.speed) + self._a.min() - hy
            hi = max(g_lo * g.speed, g_hi * g.speed) + self._a.max() + hy
            y0 = math.floor(lo * self.ky) / self.ky
            ny = int(math.ceil((hi - y0) * self.ky)) + 2
            ys = y0 + np.arange(ny) / self.ky
        else:
            y0, ys = 0.0, np.zeros(1)
        if "x" in t.axes:
            shears = np.array([g_lo, g_hi], np.float64) * g.line_shear
            lo = self.col0 + shears.min() + self._b.min() - hx
            hi = self.col0 + self.columns - 1 + shears.max() + self._b.max() + hx
            x0 = math.floor(lo * self.kx) / self.kx
            nx = int(math.ceil((hi - x0) * self.kx)) + 2
            xs = x0 + np.arange(nx) / self.kx
        else:
            x0, xs = 0.0, np.zeros(1)
        data = np.asarray(t(ys[:, None], xs[None, :]), np.float64)
        data = np.broadcast_to(data, (len(ys), len(xs))).astype(np.float64, copy=True)
        if "y" in t.axes and len(self.kern_y) > 1:
            data = ndimage.convolve1d(data, self.kern_y, axis=0, mode="nearest")
        if "x" in t.axes and len(self.kern_x) > 1:
            data = ndimage.convolve1d(data, self.kern_x, axis=1, mode="nearest")
        return _Grid(data, y0, self.ky, x0, self.kx)

    def sample(self, grid, lines, stage=None):
        """Expected relative signal of output ``lines`` (int array) at ``stage`` (None: the
        unshifted centre position, used when the stages do not move).

        Returns an array broadcastable to ``(len(lines), columns)``: ``(n, 1)`` for a target
        constant across track, ``(n, W)`` otherwise.
        """
        lines = np.asarray(lines, np.int64)
        n = len(lines)
        t, g = self.target, self.geom
        a = 0.0 if stage is None else float(self._a[stage])
        b = 0.0 if stage is None else float(self._b[stage])
        if t.axes == "":
            return np.ones((n, 1))
        d = grid.data
        if "y" in t.axes:
            pos = (lines * g.speed + a - grid.y0) * grid.ky
            i0 = np.floor(pos).astype(np.int64)
            fr = (pos - i0)[:, None]
            rows = d[i0] * (1.0 - fr) + d[i0 + 1] * fr
        else:
            rows = np.broadcast_to(d[0:1], (n, d.shape[1]))
        if "x" not in t.axes:
            return rows
        cols = np.arange(self.columns, dtype=np.float64) + self.col0
        shift = lines * g.line_shear + b
        posx = ((cols[None, :] + shift[:, None]) - grid.x0) * grid.kx
        i0 = np.floor(posx).astype(np.int64)
        fr = posx - i0
        if np.all(fr == 0.0):
            return np.take_along_axis(rows, i0, axis=1)
        r = np.arange(n)[:, None]
        return rows[r, i0] * (1.0 - fr) + rows[r, i0 + 1] * fr

    def stage_mean(self, grid, lines):
        """Mean over the M stages of :meth:`sample` (vectorized for targets that vary along
        track only; a loop otherwise)."""
        lines = np.asarray(lines, np.int64)
        if self.target.axes == "y":
            d = grid.data[:, 0]
            pos = ((lines * self.geom.speed)[:, None] + self._a[None, :] - grid.y0) * grid.ky
            i0 = np.floor(pos).astype(np.int64)
            fr = pos - i0
            vals = d[i0] * (1.0 - fr) + d[i0 + 1] * fr
            return vals.mean(axis=1)[:, None]
        acc = None
        for s in range(self.geom.stages):
            v = self.sample(grid, lines, s)
            acc = v.copy() if acc is None else acc + v
        return acc / self.geom.stages

    def ideal(self, lines):
        """The target point-sampled at the output pixel centres (no blur): a read-only
        array broadcast to ``(n, W)``."""
        lines = np.asarray(lines, np.float64)
        g = self.geom
        y = (lines * g.speed)[:, None]
        if "x" not in self.target.axes:
            x = np.zeros((1, 1))
        else:
            x = (np.arange(self.columns, dtype=np.float64)[None, :] + self.col0
                 + (lines * g.line_shear)[:, None])
        return np.broadcast_to(np.asarray(self.target(y, x), np.float64),
                               (len(lines), self.columns))


def _conv_all(kernels):
    out = np.ones(1)
    for k in kernels:
        out = np.convolve(out, k)
    return out
