"""The tissue's motion between two frames, for tracking that follows it.

A displacement field on a regular grid (:class:`Field`) is estimated either
from the cells already linked with confidence (:func:`fit_field`: a gridded
median of their centroid displacements) or, when too few cells overlap their
own successor to be linked (motion of half a cell or more per frame), by
cross-correlating the two frames' cell outlines window by window
(:func:`outline_piv`: particle image velocimetry on the label boundaries).
The previous frame's cells are then carried along the field
(:func:`warp`) and linked by their overlap after warping.

Coordinates: x = column, y = row, px; a displacement carries a point of the
earlier frame to the later one.
"""
from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np

from . import _kernels
from .._dispatch import Kernels

K = Kernels(_kernels, "hexatissue.track._reference", names={"_cell_moments": "_cell_moments_reference",
                                                            "_warp_index": "_warp_index_reference"})


class Field(NamedTuple):
    """A displacement field on the grid nodes ``(x0 + j * step, y0 + i * step)``: ``ux[i, j]``, ``uy[i, j]`` (px)."""

    x0: float
    y0: float
    step: float
    ux: np.ndarray
    uy: np.ndarray

    def at(self, xy: np.ndarray) -> np.ndarray:
        """The displacement (px) at points ``xy`` ((n, 2), x and y), bilinear between nodes, clamped at the edge."""
        ny, nx = self.ux.shape
        fx = np.clip((xy[:, 0] - self.x0) / self.step, 0, nx - 1)
        fy = np.clip((xy[:, 1] - self.y0) / self.step, 0, ny - 1)
        j0 = np.minimum(fx.astype(np.int64), max(nx - 2, 0))
        i0 = np.minimum(fy.astype(np.int64), max(ny - 2, 0))
        j1, i1 = np.minimum(j0 + 1, nx - 1), np.minimum(i0 + 1, ny - 1)
        wx, wy = fx - j0, fy - i0
        out = np.empty((len(xy), 2))
        for k, u in enumerate((self.ux, self.uy)):
            out[:, k] = ((1 - wy) * ((1 - wx) * u[i0, j0] + wx * u[i0, j1]) +
                         wy * ((1 - wx) * u[i1, j0] + wx * u[i1, j1]))
        return out

    def still(self) -> bool:
        """Whether the field moves no pixel (every node under half a pixel: warping is the identity)."""
        return bool((np.abs(self.ux) < 0.5).all() and (np.abs(self.uy) < 0.5).all())


def centroids(index: np.ndarray, shape, n: int) -> np.ndarray:
    """Pixel centroid (x, y), px, of each of the ``n`` cells of a flat compact index (-1 = background)."""
    count, sx, sy = K._cell_moments(index, int(shape[1]), int(n))
    count = np.maximum(count, 1)
    return np.c_[sx / count, sy / count]


def warp(index: np.ndarray, shape, field: Field, periodic: bool = False) -> np.ndarray:
    """A frame's flat compact index carried forward along ``field`` (-1 where nothing lands, unless periodic)."""
    return K._warp_index(index, int(shape[0]), int(shape[1]), float(field.x0), float(field.y0), float(field.step),
                       np.ascontiguousarray(field.ux, float), np.ascontiguousarray(field.uy, float), bool(periodic))


def _grid(shape, step):
    """Node counts and origin of a grid of pitch ``step`` covering an image of ``shape``."""
    rows, cols = shape
    nx, ny = max(1, int(np.ceil((cols - 1) / step)) + 1), max(1, int(np.ceil((rows - 1) / step)) + 1)
    return nx, ny, (cols - 1 - (nx - 1) * step) / 2, (rows - 1 - (ny - 1) * step) / 2


def _median_filter(u: np.ndarray) -> np.ndarray:
    """3 x 3 median of a grid ignoring NaN (a node with no value around stays NaN)."""
    padded = np.pad(u, 1, constant_values=np.nan)
    ny, nx = u.shape
    stack = np.sort(np.stack([padded[a:a + ny, b:b + nx] for a in range(3) for b in range(3)]), axis=0)  # NaN last
    k = np.isfinite(stack).sum(axis=0)
    lo = np.take_along_axis(stack, np.maximum((k - 1) // 2, 0)[None], 0)[0]
    hi = np.take_along_axis(stack, np.maximum(k // 2, 0)[None], 0)[0]
    return np.where(k > 0, (lo + hi) / 2, np.nan)


def _fill(u: np.ndarray) -> np.ndarray:
    """NaN nodes filled from their nearest node with a value (all zero when none has one)."""
    bad = ~np.isfinite(u)
    if not bad.any():
        return u
    if bad.all():
        return np.zeros_like(u)
    from scipy.ndimage import distance_transform_edt

    idx = distance_transform_edt(bad, return_distances=False, return_indices=True)
    return u[tuple(idx)]


def fit_field(xy: np.ndarray, d: np.ndarray, shape, step: float) -> Field:
    """A smooth field through displacements ``d`` measured at points ``xy`` (both (n, 2), px).

    The median of the displacements in each grid square (pitch ``step``),
    then a 3 x 3 median over the squares (one wrong link among its
    neighbours moves no node), squares without a link filled from the
    nearest with one.
    """
    nx, ny, x0, y0 = _grid(shape, step)
    j = np.clip(np.floor((xy[:, 0] - x0) / step + 0.5).astype(np.int64), 0, nx - 1)
    i = np.clip(np.floor((xy[:, 1] - y0) / step + 0.5).astype(np.int64), 0, ny - 1)
    key = i * nx + j
    order = np.argsort(key, kind="stable")
    key, d = key[order], d[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if len(key) else np.empty(0, np.int64)
    out = []
    for k in range(2):
        u = np.full(nx * ny, np.nan)
        if len(key):
            # per-square medians from one sort: each square's values are contiguous after sorting by (key, value)
            vals = d[:, k]
            o2 = np.lexsort((vals, key))
            sv, sk = vals[o2], key[o2]
            ends = np.r_[starts[1:], len(sk)]
            lo, hi = starts + (ends - starts - 1) // 2, starts + (ends - starts) // 2
            u[sk[starts]] = (sv[lo] + sv[hi]) / 2
        out.append(_fill(_median_filter(u.reshape(ny, nx))))
    return Field(x0, y0, float(step), out[0], out[1])


def _outlines(index: np.ndarray, shape, factor: int) -> np.ndarray:
    """Cell outlines (pixels whose right or lower neighbour is another cell), summed in ``factor`` blocks."""
    img = index.reshape(shape)
    edge = np.zeros(shape, np.float32)
    edge[:, :-1] += img[:, :-1] != img[:, 1:]
    edge[:-1, :] += img[:-1, :] != img[1:, :]
    rows, cols = shape[0] // factor * factor, shape[1] // factor * factor
    return edge[:rows, :cols].reshape(rows // factor, factor, cols // factor, factor).sum(axis=(1, 3))


def outline_piv(a_index: np.ndarray, b_index: np.ndarray, shape, spacing: float, periodic: bool = False) -> Field:
    """The displacement from frame a to frame b by cross-correlating their cell outlines in windows.

    Outlines are summed in blocks of about ``spacing / 8`` px; windows of
    about four cell spacings (at least 16 blocks), every half window; each
    window of a is searched in a region of b twice its size, so a motion up
    to about two cell spacings is found.  The peak is refined to sub-block
    by a parabola on each axis; windows whose peak is not clearly above the
    rest (highest correlation < 1.5 x the median of the positive ones) are
    dropped, then a 3 x 3 median over the windows rejects the odd one out.
    """
    factor = max(1, int(spacing // 8))
    ea, eb = _outlines(a_index, shape, factor), _outlines(b_index, shape, factor)
    win = max(16, int(np.ceil(4 * spacing / factor / 4)) * 4)
    half = win // 2
    rows, cols = ea.shape
    ys = np.arange(half, max(rows - half, half) + 1, half)
    xs = np.arange(half, max(cols - half, half) + 1, half)
    edge = 2 * win  # padding: a window centred up to half a window past a small image still lies inside
    mode = "wrap" if periodic else "constant"
    pa, pb = np.pad(ea, edge, mode=mode), np.pad(eb, edge, mode=mode)
    n = win - 1  # displacements -(half - 1) .. half - 1 blocks on each axis
    flat = np.empty((len(ys), len(xs), n * n), np.float32)
    A = np.zeros((len(xs), 2 * win, 2 * win), np.float32)
    B = np.empty((len(xs), 2 * win, 2 * win), np.float32)
    for p, y in enumerate(ys + edge):  # one row of windows at a time: memory of one row, whatever the image
        for q, x in enumerate(xs + edge):
            wa = pa[y - half:y + half, x - half:x + half]
            A[q, half:half + win, half:half + win] = wa - wa.mean()
            wb = pb[y - win:y + win, x - win:x + win]
            B[q] = wb - wb.mean()
        corr = np.fft.irfft2(np.conj(np.fft.rfft2(A)) * np.fft.rfft2(B), s=(2 * win, 2 * win))
        corr = np.fft.fftshift(corr, axes=(1, 2))  # zero displacement at the centre (win, win)
        flat[p] = corr[:, win - half + 1:win + half, win - half + 1:win + half].reshape(len(xs), -1)
    best = flat.argmax(axis=-1)
    peak = np.take_along_axis(flat, best[..., None], -1)[..., 0]
    positive = np.where(flat > 0, flat, np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a blank window has no positive correlation: NaN, dropped
        typical = np.nanmedian(positive, axis=-1)
    bi, bj = np.divmod(best, n)

    def refine(c, lo, mid, hi):
        den = lo - 2 * mid + hi
        with np.errstate(all="ignore"):
            return np.where((c > 0) & (c < n - 1) & (den < 0), c + 0.5 * (lo - hi) / np.where(den < 0, den, -1), c)

    si = np.clip(bi, 1, n - 2)
    sj = np.clip(bj, 1, n - 2)
    at = lambda a, b: np.take_along_axis(flat, (a * n + b)[..., None], -1)[..., 0]  # noqa: E731
    fi = refine(bi, at(si - 1, bj), peak, at(si + 1, bj))
    fj = refine(bj, at(bi, sj - 1), peak, at(bi, sj + 1))
    uy = (fi - (half - 1)) * factor
    ux = (fj - (half - 1)) * factor
    weak = ~(peak > 1.5 * typical)
    ux[weak], uy[weak] = np.nan, np.nan
    for u in (ux, uy):
        med = _median_filter(u)
        u[np.abs(u - med) > 0.25 * spacing] = np.nan
    ux, uy = _fill(_median_filter(ux)), _fill(_median_filter(uy))
    # window (p, q) spans blocks ys[p] - half .. ys[p] + half - 1: its centre is at ys[p] * factor - 0.5 px
    step = half * factor
    x0 = xs[0] * factor - 0.5
    y0 = ys[0] * factor - 0.5
    return Field(float(x0), float(y0), float(step), ux, uy)
