"""Particle image velocimetry of a raw channel on the nodes of the Gamma_p grid.

The displacement of the image texture in a square interrogation window centred on each node, from the
peak of the FFT cross-correlation of the window in frame ``t - 1`` with the same window in frame
``t + 1``, located to a fraction of a pixel by a three-point Gaussian fit in x and in y; half of it is
the velocity at frame ``t`` (px/frame), the centred difference the cell velocities use
(:func:`hexatissue.flow.cell_velocities`), so the two fields compare node by node.  All windows of a
frame pair go through one batched numpy FFT (no per-window Python loop, no kernel to keep beside a
reference).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import ndimage

from ..box import as_box
from ..errors import InputError, check_positive
from ..schema import require_columns

__all__ = ["piv_displacements", "piv_fields", "piv_agreement"]

#: Refinement passes stop when no window moves by more than this, px.
TOLERANCE = 0.005


def _windows(image, cx, cy, size, periodic):
    """``(n, size, size)`` windows of ``image`` whose centre pixel is ``(cy, cx)``; None rows leave the image."""
    h = size // 2
    offsets = np.arange(size) - h
    rows = cy[:, None] + offsets[None, :]
    cols = cx[:, None] + offsets[None, :]
    ny, nx = image.shape
    if periodic:
        rows, cols = rows % ny, cols % nx
        inside = np.ones(len(cx), bool)
    else:
        inside = (rows.min(1) >= 0) & (rows.max(1) < ny) & (cols.min(1) >= 0) & (cols.max(1) < nx)
        rows, cols = np.clip(rows, 0, ny - 1), np.clip(cols, 0, nx - 1)
    return image[rows[:, :, None], cols[:, None, :]].astype(float), inside


def _gaussian_peak(lo, mid, hi):
    """Sub-pixel offset of a peak from three samples (Gaussian fit; parabola where a sample is not positive)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        positive = (lo > 0) & (mid > 0) & (hi > 0)
        llo, lmid, lhi = (np.log(np.where(positive, v, 1.0)) for v in (lo, mid, hi))
        gauss = (llo - lhi) / (2 * (llo - 2 * lmid + lhi))
        parabola = (lo - hi) / (2 * (lo - 2 * mid + hi))
        d = np.where(positive, gauss, parabola)
    return np.where(np.isfinite(d), np.clip(d, -0.5, 0.5), 0.0)


def piv_displacements(first, second, x, y, window, box=None, passes=10):
    """Displacement of the texture of ``first`` into ``second`` in a window around each point.

    Parameters
    ----------
    first, second : (Ly, Lx) array
        Two images of one channel (any real dtype).
    x, y : array_like of float
        Window centres, px (column, row); each window is centred on the
        nearest pixel.
    window : int
        Side of the square interrogation window, px (even, >= 8).
    box : Box, optional
        Periodic box (windows wrap around the image); None for an open image,
        where a window that leaves the image gives NaN.
    passes : int
        Most correlation passes: the first with the windows on whole pixels,
        each further one with the two windows moved apart by the displacement
        found so far (cubic-spline sampling, Hann-tapered), adding the
        residual, until no residual exceeds ``TOLERANCE`` (0.005 px).

    Returns
    -------
    dx, dy : numpy.ndarray of float
        Displacement along x (columns) and y (rows), px (NaN where the
        window leaves the image, is flat, or the peak is on the edge of the
        correlation plane, i.e. displacements of window / 2 or more).
    peak : numpy.ndarray of float
        Height of the correlation peak over the window's standard deviations
        (the normalised cross-correlation, 1 for an exact copy).
    """
    first, second = np.asarray(first), np.asarray(second)
    if first.ndim != 2 or first.shape != second.shape:
        raise InputError(f"first, second: expected two 2-D images of one shape; got shapes {first.shape} and "
                         f"{second.shape}")
    window = int(check_positive(window, "window", integer=True))
    if window < 8 or window % 2:
        raise InputError(f"window: expected an even number of px >= 8; got {window}")
    passes = int(check_positive(passes, "passes", integer=True))
    box = as_box(box)
    x, y = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float))
    cx, cy = np.rint(x).astype(np.int64), np.rint(y).astype(np.int64)
    a, inside = _windows(first, cx, cy, window, box is not None)
    b, _ = _windows(second, cx, cy, window, box is not None)
    dx, dy, peak = _correlate(a, b)
    if passes > 1:
        # a finite window biases the peak towards zero displacement, in proportion to the displacement (the
        # texture cut by its edges does not move; 25-30 % on the tests' spots): sampling the two windows at
        # -d/2 and +d/2 (cubic splines), tapered, and adding the residual each pass drives the biased part to
        # zero (window offset, Westerweel et al. 1997)
        mode = "grid-wrap" if box is not None else "mirror"
        ca, cb = (ndimage.spline_filter(np.asarray(im, float), order=3, mode=mode) for im in (first, second))
        offsets = np.arange(window) - window // 2
        for _ in range(passes - 1):
            if not np.any(np.isfinite(dx)):
                break
            ok = np.isfinite(dx)
            sx, sy = np.where(ok, dx, 0.0) / 2, np.where(ok, dy, 0.0) / 2
            rows = cy[:, None, None] + offsets[None, :, None] + np.zeros((1, 1, window))
            cols = cx[:, None, None] + offsets[None, None, :] + np.zeros((1, window, 1))
            a = ndimage.map_coordinates(ca, [rows - sy[:, None, None], cols - sx[:, None, None]], order=3,
                                        mode=mode, prefilter=False)
            b = ndimage.map_coordinates(cb, [rows + sy[:, None, None], cols + sx[:, None, None]], order=3,
                                        mode=mode, prefilter=False)
            rx, ry, peak = _correlate(a, b, taper=True)
            dx, dy = dx + rx, dy + ry
            if not np.nanmax(np.abs(np.r_[rx, ry]), initial=0.0) > TOLERANCE:
                break
        if box is None:  # the shifted windows must stay inside the image
            ny, nx = first.shape
            h = window // 2 + np.ceil(np.maximum(np.abs(dx), np.abs(dy)) / 2)
            inside &= (cx - h >= 0) & (cx + h < nx) & (cy - h >= 0) & (cy + h < ny)
    bad = ~inside | ~np.isfinite(dx)
    dx[bad], dy[bad], peak[bad] = np.nan, np.nan, np.nan
    return dx, dy, peak


def _correlate(a, b, taper=False):
    """Peak of the circular cross-correlation of each pair of windows: ``dx, dy`` (px), normalised height.

    ``taper``: both windows weighted by a Hann window, so that the texture cut by their edges weighs little.
    """
    n_win, window = len(a), a.shape[1]
    a = a - a.mean(axis=(1, 2), keepdims=True)
    b = b - b.mean(axis=(1, 2), keepdims=True)
    if taper:
        t = np.hanning(window + 2)[1:-1]
        a, b = a * np.outer(t, t), b * np.outer(t, t)
    norm = np.sqrt((a**2).sum(axis=(1, 2)) * (b**2).sum(axis=(1, 2)))
    # c[s] = sum_r a(r) b(r + s): its peak at the displacement s of b's texture from a's
    c = np.fft.irfft2(np.conj(np.fft.rfft2(a)) * np.fft.rfft2(b), s=(window, window))
    c = np.fft.fftshift(c, axes=(1, 2))  # zero displacement at index window // 2
    py, px = np.unravel_index(c.reshape(n_win, -1).argmax(axis=1), (window, window))
    n = np.arange(n_win)
    edge = (px == 0) | (px == window - 1) | (py == 0) | (py == window - 1)
    pxi, pyi = np.clip(px, 1, window - 2), np.clip(py, 1, window - 2)
    dx = pxi - window // 2 + _gaussian_peak(c[n, pyi, pxi - 1], c[n, pyi, pxi], c[n, pyi, pxi + 1])
    dy = pyi - window // 2 + _gaussian_peak(c[n, pyi - 1, pxi], c[n, pyi, pxi], c[n, pyi + 1, pxi])
    with np.errstate(divide="ignore", invalid="ignore"):
        peak = c[n, py, px] / norm
    bad = edge | ~(norm > 0)
    dx, dy = dx.astype(float), dy.astype(float)
    dx[bad], dy[bad], peak[bad] = np.nan, np.nan, np.nan
    return dx, dy, peak


def piv_fields(images, grid, box=None, window=None):
    """PIV velocity of a raw channel at every node of the Gamma_p grid, px/frame.

    At frame ``t``: the displacement from frame ``t - 1`` to ``t + 1`` in a
    window around each node (:func:`piv_displacements`), halved; NaN on the
    first and last frame.

    Parameters
    ----------
    images : sequence of (Ly, Lx) arrays, or a (T, Ly, Lx) array
        The raw channel, one image per frame of ``grid``.
    grid : pandas.DataFrame
        The ``grid`` table (:func:`hexatissue.coarse_grain`): ``frame``,
        ``node``, ``x``, ``y``, ``radius`` (px).
    box : Box, optional
        Periodic box; None for an open image.
    window : int, optional
        Interrogation window side, px (default: the even number nearest to
        twice the grid's radius, the diameter of the nodes' disk).

    Returns
    -------
    pandas.DataFrame
        One row per row of ``grid``: ``frame``, ``node``, ``x``, ``y`` (px),
        ``piv_vx``, ``piv_vy`` (px/frame), ``piv_peak`` (normalised
        correlation peak, dimensionless, 1 for an exact copy), ``window``
        (px).
    """
    require_columns(grid, ["frame", "node", "x", "y", "radius"], "grid")
    n_frames = len(images)
    frames = grid["frame"].to_numpy(np.int64)
    if len(frames) and frames.max() >= n_frames:
        raise InputError(f"images: expected one image per frame of grid (up to frame {frames.max()}); got "
                         f"{n_frames}")
    if window is None:
        radius = float(np.nanmedian(grid["radius"].to_numpy(float))) if len(grid) else 8.0
        window = max(8, 2 * int(round(radius)))
    vx = np.full(len(grid), np.nan)
    vy, peak = vx.copy(), vx.copy()
    x, y = grid["x"].to_numpy(float), grid["y"].to_numpy(float)
    for t in np.unique(frames):
        if t == 0 or t == n_frames - 1:
            continue
        rows = np.flatnonzero(frames == t)
        dx, dy, pk = piv_displacements(images[t - 1], images[t + 1], x[rows], y[rows], window, box)
        vx[rows], vy[rows], peak[rows] = dx / 2, dy / 2, pk
    return pd.DataFrame({"frame": frames, "node": grid["node"].to_numpy(np.int64), "x": x, "y": y,
                         "piv_vx": vx, "piv_vy": vy, "piv_peak": peak, "window": float(window)})


def piv_agreement(flow):
    """How the PIV field agrees with the track-based one, at the nodes where both exist.

    Parameters
    ----------
    flow : pandas.DataFrame
        The ``flow`` table with its PIV columns: ``valid``, ``vx``, ``vy``,
        ``piv_vx``, ``piv_vy`` (px/frame).

    Returns
    -------
    dict
        ``nodes`` (node-frames with both fields), ``rms_tracks`` and
        ``rms_piv`` (rms velocity of each field there, px/frame),
        ``rms_difference`` (rms of the vector difference, px/frame),
        ``relative_difference`` (``rms_difference / rms_tracks``,
        dimensionless), ``r_vx`` and ``r_vy`` (Pearson correlation of each
        component, dimensionless; NaN with fewer than 3 nodes).
    """
    require_columns(flow, ["valid", "vx", "vy", "piv_vx", "piv_vy"], "flow")
    both = flow["valid"].to_numpy(bool) & np.isfinite(flow[["vx", "vy", "piv_vx", "piv_vy"]].to_numpy(float)).all(1)
    v = flow.loc[both, ["vx", "vy"]].to_numpy(float)
    w = flow.loc[both, ["piv_vx", "piv_vy"]].to_numpy(float)
    out = {"nodes": int(both.sum())}
    if not both.any():
        return out | dict.fromkeys(["rms_tracks", "rms_piv", "rms_difference", "relative_difference", "r_vx", "r_vy"],
                                   float("nan"))
    rms = [float(np.sqrt(np.mean(np.sum(a**2, axis=1)))) for a in (v, w, v - w)]
    out |= {"rms_tracks": rms[0], "rms_piv": rms[1], "rms_difference": rms[2],
            "relative_difference": rms[2] / rms[0] if rms[0] > 0 else float("nan")}
    for k, name in enumerate(("r_vx", "r_vy")):
        constant = len(v) < 3 or v[:, k].std() == 0 or w[:, k].std() == 0
        out[name] = float("nan") if constant else float(np.corrcoef(v[:, k], w[:, k])[0, 1])
    return out
