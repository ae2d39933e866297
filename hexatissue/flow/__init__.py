"""Tissue flow: cell velocities, velocity-gradient fields on the Gamma_p grid, and their statistics.

- :func:`cell_velocities`: every tracked cell's velocity by centred differences in time;
- :func:`flow_fields`: velocity, vorticity, divergence and strain rate on the nodes of the
  coarse-grained order field (:func:`hexatissue.coarse_grain`), from a least-squares affine fit
  to the cells within each node's disk;
- :func:`velocity_statistics`, :func:`velocity_correlation`, :func:`mean_squared_displacement`,
  :func:`flow_summary`: mean speed, polar order, spatial velocity correlation and its length, MSD
  and its exponent;
- :func:`t1_flow`, :func:`defect_flow`, :func:`angular_harmonics` (:mod:`hexatissue.flow.centred`):
  the flow averaged around T1 events and around ±1/p defects in their own axes, and its angular
  harmonics.

Tables stay in px and frames (velocities in px/frame, rates in 1/frame); :func:`velocity_unit`
and :func:`in_units` give them in a calibration's units (µm/min) for figures and reports.
Positions are (x, y) = (column, row), so y grows downwards: a positive vorticity
``dvy/dx - dvx/dy`` turns clockwise on the image as displayed.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..box import as_box
from ..errors import InputError, check_positive
from ..schema import interior_mask, require_columns, track_ids, validate
from ..units import as_calibration
from . import _kernels as K
from .centred import angular_harmonics, defect_flow, t1_flow

__all__ = ["cell_velocities", "flow_fields", "velocity_statistics", "velocity_correlation", "correlation_length",
           "mean_squared_displacement", "msd_exponent", "flow_summary", "velocity_unit", "in_units", "MIN_CELLS",
           "t1_flow", "defect_flow", "angular_harmonics", "reliable_bins", "SPARSE_BIN"]

#: Fewest cells an affine fit takes (three non-collinear points fix a 2-D affine map).
MIN_CELLS = 3


def _sorted_by_track(track, frame):
    """Row order by (track, frame): one stable argsort of ``track`` when ``frame`` is already sorted."""
    if len(frame) < 2 or bool(np.all(frame[1:] >= frame[:-1])):
        return np.argsort(track, kind="stable")
    return np.lexsort((frame, track))


def cell_velocities(cells, box=None):
    """Velocity of every cell, px/frame, by centred differences along its track.

    ``v(t) = (r(t + 1) - r(t - 1)) / 2`` of the cell's centroid ``r = (x, y)``
    (minimum image in a periodic box), for a cell whose track is present in
    both frames ``t - 1`` and ``t + 1``.  A track starts at a division and
    ends at one (the daughters are new tracks), so the velocity is NaN on the
    first and last frame of every track (movie ends, divisions, cells
    entering or leaving the field of view) and beside a gap closed by the
    tracker (a missing neighbouring frame).  Untracked frames (tracking
    ``off``: every cell its own track) have no velocities.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table: ``frame``, ``x``, ``y`` (px) and ``track`` (or ``cell``,
        whose ids are then the tracks).
    box : Box, optional
        Periodic box (minimum-image displacements); None for an open image.

    Returns
    -------
    vx, vy : numpy.ndarray of float
        Velocity along x (columns) and y (rows) of every row of ``cells``, in
        row order, px/frame (NaN where undefined, see above).
    """
    require_columns(cells, ["frame", "x", "y"], "cells")
    box = as_box(box)
    track, frame = track_ids(cells), cells["frame"].to_numpy(np.int64)
    order = _sorted_by_track(track, frame)
    t, f = track[order], frame[order]
    xy = cells[["x", "y"]].to_numpy(float)[order]
    # row k (in track order) is followed by the same track one frame later
    step = (t[1:] == t[:-1]) & (f[1:] == f[:-1] + 1)
    centred = np.zeros(len(t), bool)
    centred[1:-1] = step[1:] & step[:-1]
    v = np.full((len(t), 2), np.nan)
    inner = np.flatnonzero(centred)
    d = xy[inner + 1] - xy[inner - 1]
    v[inner] = 0.5 * (d if box is None else box.min_image(d))
    out = np.empty_like(v)
    out[order] = v
    return out[:, 0].copy(), out[:, 1].copy()


def _period(box):
    """``(Lx, Ly)`` of a periodic box, ``(0, 0)`` for an open image (the kernels' convention)."""
    return np.zeros(2) if box is None else box.lengths


def _frame_rows(frames, blocks):
    """``(start, end)`` of the rows of each of the frames ``blocks`` in the sorted ``frames`` (empty if absent)."""
    return np.c_[np.searchsorted(frames, blocks, "left"), np.searchsorted(frames, blocks, "right")].astype(np.int64)


def flow_fields(cells, grid, box=None, radius_factor=2.0, min_cells=MIN_CELLS):
    """Velocity, vorticity, divergence and strain rate on the nodes of a coarse-grained grid.

    For every node, the velocities ``v`` of the cells within a disk of radius
    ``radius_factor x`` the node's coarse-graining radius (centroid distance,
    minimum image in a periodic box) are fitted by least squares, with equal
    weights (the coarse-grained order field weighs the cells of its disk
    equally), by the affine field ``v(r) = v0 + L (r - r_node)``;
    ``L_ij = d v_i / d x_j`` is the velocity gradient.  Border cells do not
    enter the fits (their centroids move as they are cut by the image edge),
    as they do not enter Gamma_p.

    The default disk (twice the order field's, 3 R_cell) holds ~9 cells: the
    order field's own disk of 1.5 R_cell holds 2.25 cells on average, too few
    for a gradient at most nodes.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``frame``, ``x``, ``y`` (px), ``vx``, ``vy``
        (px/frame, e.g. from :func:`cell_velocities`; NaN rows are left out)
        and optionally ``is_border``.
    grid : pandas.DataFrame
        Grid table of :func:`hexatissue.coarse_grain`: ``frame``, ``node``,
        ``x``, ``y``, ``radius`` (px), ``valid``.
    box : Box, optional
        Periodic box; None for an open image.
    radius_factor : float
        Disk radius of the fits in units of the grid's ``radius``.
    min_cells : int
        Fewest cells a fit takes (at least 3).  A fit also needs its cells
        spread across the disk: their root-mean-square distance from their
        mean, in the narrowest direction, at least
        ``hexatissue.flow._kernels.MIN_SPREAD`` (0.1) x the radius.

    Returns
    -------
    pandas.DataFrame
        The ``flow`` table, one row per row of ``grid``, in its order:
        ``frame``, ``node`` (the grid's), ``x``, ``y`` (node position, px),
        ``radius`` (disk radius of the fit, px), ``vx``, ``vy`` (fitted
        velocity at the node, px/frame), ``vorticity`` (``dvy/dx - dvx/dy``,
        1/frame; positive is clockwise on the displayed image, whose y axis
        points down), ``divergence`` (``dvx/dx + dvy/dy``, 1/frame),
        ``strain_xx`` (``(dvx/dx - dvy/dy) / 2``, 1/frame), ``strain_xy``
        (``(dvx/dy + dvy/dx) / 2``, 1/frame; the traceless symmetric strain
        rate is ``[[strain_xx, strain_xy], [strain_xy, -strain_xx]]``; with
        the vorticity and the divergence they give the whole gradient,
        ``dvx/dy = strain_xy - vorticity / 2``, ...), ``n_cells`` (cells with a
        velocity in the disk) and ``valid`` (the grid node is valid and the fit
        exists).  Fields are NaN where there is no fit.
    """
    require_columns(cells, ["frame", "x", "y", "vx", "vy"], "cells")
    require_columns(grid, ["frame", "node", "x", "y", "radius", "valid"], "grid")
    box = as_box(box)
    radius_factor = check_positive(radius_factor, "radius_factor")
    if isinstance(min_cells, bool) or not isinstance(min_cells, (int, np.integer)) or min_cells < 3:
        raise InputError(f"min_cells must be an integer >= 3 (an affine fit needs three cells); got {min_cells!r}")
    xy = cells[["x", "y"]].to_numpy(float)
    uv = cells[["vx", "vy"]].to_numpy(float)
    use = interior_mask(cells) & np.isfinite(xy).all(axis=1) & np.isfinite(uv).all(axis=1)
    frame = cells["frame"].to_numpy(np.int64)[use]
    c_order = np.argsort(frame, kind="stable")
    xy, uv, frame = xy[use][c_order], uv[use][c_order], frame[c_order]
    if box is not None:
        xy = box.wrap(xy)
    g_frame = grid["frame"].to_numpy(np.int64)
    # the grid of analyze is in frame order: then its rows go to the kernel as they are
    g_order = None if bool(np.all(g_frame[1:] >= g_frame[:-1])) else np.argsort(g_frame, kind="stable")

    def sorted_(values):
        return values if g_order is None else values[g_order]

    blocks = np.unique(g_frame)
    names = ["x", "y", "radius", "vx", "vy", "vorticity", "divergence", "strain_xx", "strain_xy"]
    # one float block whose rows are the columns (as coarse_grain's grid): no copy into the DataFrame
    block = np.empty((len(names), len(grid)))
    columns = dict(zip(names, block))
    columns["x"][:], columns["y"][:] = grid["x"].to_numpy(float), grid["y"].to_numpy(float)
    np.multiply(grid["radius"].to_numpy(float), radius_factor, out=columns["radius"])
    fits = np.empty((6, len(grid)))
    counts = np.empty(len(grid), np.int64)
    K.affine_fits(np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1]), np.ascontiguousarray(uv[:, 0]),
                  np.ascontiguousarray(uv[:, 1]), _frame_rows(frame, blocks),
                  np.ascontiguousarray(sorted_(columns["x"])), np.ascontiguousarray(sorted_(columns["y"])),
                  np.ascontiguousarray(sorted_(columns["radius"])), _frame_rows(sorted_(g_frame), blocks), _period(box),
                  int(min_cells), fits, counts)
    if g_order is not None:
        fits[:, g_order], counts[g_order] = fits.copy(), counts.copy()
    v0x, v0y, lxx, lxy, lyx, lyy = fits
    columns["vx"][:], columns["vy"][:] = v0x, v0y
    np.subtract(lyx, lxy, out=columns["vorticity"])
    np.add(lxx, lyy, out=columns["divergence"])
    np.multiply(np.subtract(lxx, lyy, out=columns["strain_xx"]), 0.5, out=columns["strain_xx"])
    np.multiply(np.add(lxy, lyx, out=columns["strain_xy"]), 0.5, out=columns["strain_xy"])
    valid = grid["valid"].to_numpy(bool) & np.isfinite(lxx)
    table = pd.DataFrame({"frame": g_frame, "node": grid["node"].to_numpy(np.int64), **columns, "n_cells": counts,
                          "valid": valid}, copy=False)
    return validate(table, "flow")


def velocity_unit(calibration=None) -> str:
    """Unit of a velocity in ``calibration``: ``"µm/min"``, or ``"px/frame"`` when uncalibrated."""
    cal = as_calibration(calibration)
    time = cal.time_unit if cal.has_time else "frame"
    return f"{cal.length_label}/{time}"


def in_units(values, calibration=None, length_power=1, time_power=-1):
    """``values`` in px^length_power frame^time_power converted to ``calibration``'s units.

    Velocities are ``(1, -1)`` (px/frame -> µm/min), rates ``(0, -1)``,
    mean squared displacements ``(2, 0)``.
    """
    cal = as_calibration(calibration)
    return np.asarray(values, float) * cal.pixel_size ** length_power * cal.frame_interval ** time_power


# ----------------------------------------------------------------------------
# Statistics
# ----------------------------------------------------------------------------

def _moving_cells(cells):
    """Rows that enter the statistics: interior cells with a finite position and velocity."""
    require_columns(cells, ["frame", "x", "y", "vx", "vy"], "cells")
    xy = cells[["x", "y"]].to_numpy(float)
    uv = cells[["vx", "vy"]].to_numpy(float)
    return interior_mask(cells) & np.isfinite(xy).all(axis=1) & np.isfinite(uv).all(axis=1)


def velocity_statistics(cells):
    """Mean speed and polar order of the cell velocities, per frame.

    Interior cells (not ``is_border``) with a finite velocity enter.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``frame``, ``x``, ``y``, ``vx``, ``vy`` (px/frame) and
        optionally ``is_border``.

    Returns
    -------
    pandas.DataFrame
        One row per frame with at least one such cell: ``frame``, ``n_cells``,
        ``mean_speed`` (mean of ``|v|``, px/frame), ``mean_vx``, ``mean_vy``
        (the mean velocity, px/frame), ``polar_order`` (``|mean of v / |v||``,
        dimensionless, 0 for random directions and 1 when all cells move the
        same way; cells at rest do not count in it).
    """
    use = _moving_cells(cells)
    frame = cells["frame"].to_numpy(np.int64)[use]
    uv = cells[["vx", "vy"]].to_numpy(float)[use]
    frames, index = np.unique(frame, return_inverse=True)
    speed = np.hypot(uv[:, 0], uv[:, 1])
    moving = speed > 0
    unit = np.zeros_like(uv)
    unit[moving] = uv[moving] / speed[moving, None]
    n = np.bincount(index, minlength=len(frames))
    n_moving = np.bincount(index, moving, minlength=len(frames))
    sums = [np.bincount(index, w, minlength=len(frames)) for w in (speed, uv[:, 0], uv[:, 1], unit[:, 0], unit[:, 1])]
    with np.errstate(invalid="ignore", divide="ignore"):
        polar = np.where(n_moving > 0, np.hypot(sums[3], sums[4]) / n_moving, np.nan)
    return pd.DataFrame({"frame": frames, "n_cells": n, "mean_speed": sums[0] / n, "mean_vx": sums[1] / n,
                         "mean_vy": sums[2] / n, "polar_order": polar})


def _sampled_frames(frames, max_frames):
    """At most ``max_frames`` of the sorted distinct ``frames``, evenly spread."""
    if len(frames) <= max_frames:
        return frames
    return frames[np.unique(np.linspace(0, len(frames) - 1, max_frames).round().astype(np.int64))]


def velocity_correlation(cells, box=None, r_max=None, bins=30, max_frames=20):
    """Spatial correlation of the velocity fluctuations, averaged over frames.

    ``C(r) = <dv_i . dv_j> / <|dv|^2>`` over the pairs of cells at centroid
    distance ``r`` (minimum image in a periodic box) in the same frame, with
    ``dv = v - <v>`` the velocity minus its frame mean (a uniform drift does
    not count as correlation).  Interior cells with a finite velocity enter.
    Frames are pooled: the pair sums and counts of every frame, and the
    variance over every cell.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``frame``, ``x``, ``y`` (px), ``vx``, ``vy``
        (px/frame) and optionally ``is_border``.
    box : Box, optional
        Periodic box; None for an open image.
    r_max : float, optional
        Largest distance, px.  Default: half the shorter side of the box, or
        of the cells' extent on an open image.
    bins : int
        Number of distance bins of equal width in ``(0, r_max]``.
    max_frames : int
        At most this many frames, evenly spread over the movie, enter (the
        cost grows with the frames and the pairs; 20 frames of 440 cells
        give ~2 million pairs, smooth curves).

    Returns
    -------
    pandas.DataFrame
        One row per bin: ``r`` (bin centre, px), ``correlation`` (C(r),
        dimensionless; NaN for an empty bin), ``n_pairs`` (pairs in the bin,
        every frame).
    """
    from scipy.spatial import cKDTree

    box = as_box(box)
    use = _moving_cells(cells)
    bins = int(check_positive(bins, "bins", integer=True))
    max_frames = int(check_positive(max_frames, "max_frames", integer=True))
    frame = cells["frame"].to_numpy(np.int64)[use]
    xy = cells[["x", "y"]].to_numpy(float)[use]
    uv = cells[["vx", "vy"]].to_numpy(float)[use]
    if r_max is None:
        extent = box.lengths if box is not None else (np.ptp(xy, axis=0) if len(xy) else np.zeros(2))
        r_max = 0.5 * float(np.min(extent))
    if not r_max > 0:
        return pd.DataFrame({"r": np.zeros(0), "correlation": np.zeros(0), "n_pairs": np.zeros(0, np.int64)})
    r_max = check_positive(r_max, "r_max", unit="px")
    edges = np.linspace(0.0, r_max, bins + 1)
    total, count, variance, n_cells = np.zeros(bins), np.zeros(bins, np.int64), 0.0, 0
    order = np.argsort(frame, kind="stable")
    frame, xy, uv = frame[order], xy[order], uv[order]
    distinct = np.unique(frame)
    starts = np.searchsorted(frame, distinct)
    ends = np.searchsorted(frame, distinct, "right")
    for k in np.searchsorted(distinct, _sampled_frames(distinct, max_frames)):
        p, dv = xy[starts[k]:ends[k]], uv[starts[k]:ends[k]]
        dv = dv - dv.mean(axis=0)
        variance, n_cells = variance + float((dv ** 2).sum()), n_cells + len(dv)
        tree = cKDTree(box.wrap(p), boxsize=box.lengths) if box is not None else cKDTree(p)
        pairs = tree.query_pairs(r_max, output_type="ndarray")
        if not len(pairs):
            continue
        d = p[pairs[:, 1]] - p[pairs[:, 0]]
        r = np.hypot(*(d if box is None else box.min_image(d)).T)
        which = np.clip(np.searchsorted(edges, r, "left") - 1, 0, bins - 1)  # r = 0 (two cells at one spot): bin 0
        total += np.bincount(which, (dv[pairs[:, 0]] * dv[pairs[:, 1]]).sum(axis=1), minlength=bins)
        count += np.bincount(which, minlength=bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = np.where(count > 0, total / np.maximum(count, 1), np.nan) / (variance / max(n_cells, 1))
    return pd.DataFrame({"r": 0.5 * (edges[1:] + edges[:-1]), "correlation": correlation, "n_pairs": count})


#: Bins of a velocity correlation holding fewer than this fraction of the pairs of its fullest bin are too
#: few to trust: below a cell size they hold the odd pair of tiny or dividing cells.
SPARSE_BIN = 0.01


def reliable_bins(correlation):
    """Bins of :func:`velocity_correlation` with a finite C(r) and at least :data:`SPARSE_BIN` x the pairs of
    the fullest bin (a boolean array)."""
    require_columns(correlation, ["correlation", "n_pairs"], "correlation")
    pairs = correlation["n_pairs"].to_numpy(float)
    top = pairs.max() if len(pairs) else 0.0
    return np.isfinite(correlation["correlation"].to_numpy(float)) & (pairs > 0) & (pairs >= SPARSE_BIN * top)


def correlation_length(correlation, level=np.exp(-1.0)):
    """Distance at which a velocity correlation first falls to ``level`` (1/e), px.

    Linear interpolation between the bins of :func:`velocity_correlation`
    (from C(0) = 1), over the :func:`reliable_bins`; NaN when it never falls
    that low within its ``r_max``.
    """
    require_columns(correlation, ["r", "correlation", "n_pairs"], "correlation")
    keep = reliable_bins(correlation)
    r = np.r_[0.0, correlation["r"].to_numpy(float)[keep]]
    c = np.r_[1.0, correlation["correlation"].to_numpy(float)[keep]]
    below = np.flatnonzero(c < level)
    if not len(below):
        return float("nan")
    k = below[0]
    return float(r[k - 1] + (c[k - 1] - level) / (c[k - 1] - c[k]) * (r[k] - r[k - 1]))


def _default_lags(n_frames, count=12):
    """About ``count`` log-spaced lags from 1 to half the movie, frames."""
    top = max(1, n_frames // 2)
    return np.unique(np.geomspace(1, top, count).round().astype(np.int64))


def mean_squared_displacement(cells, box=None, lags=None):
    """Mean squared displacement of the cells' centroids against the time lag.

    ``MSD(tau) = <|r(t + tau) - r(t)|^2>`` over every track and every ``t``
    at which the track is present in all of ``t .. t + tau`` (a gap closed by
    the tracker, or a division, which ends the track, breaks the pairs over
    it) and interior (not ``is_border``) at both ends.  In a periodic box a
    track is unwrapped by its minimum-image steps, so displacements may
    exceed the box.  The mean drift of the tissue is not removed.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``frame``, ``x``, ``y`` (px), ``track`` (or
        ``cell``) and optionally ``is_border``.
    box : Box, optional
        Periodic box; None for an open image.
    lags : sequence of int, optional
        Lags, frames (default: ~12 log-spaced lags up to half the movie).

    Returns
    -------
    pandas.DataFrame
        One row per lag: ``lag`` (frames), ``msd`` (px^2; NaN without pairs),
        ``n_pairs``.
    """
    require_columns(cells, ["frame", "x", "y"], "cells")
    box = as_box(box)
    track, frame = track_ids(cells), cells["frame"].to_numpy(np.int64)
    if lags is None:
        lags = _default_lags(int(frame.max() - frame.min()) + 1 if len(frame) else 1)
    lags = np.asarray([check_positive(v, "lags", integer=True) for v in np.atleast_1d(lags)], np.int64)
    order = _sorted_by_track(track, frame)
    t, f = track[order], frame[order]
    xy = cells[["x", "y"]].to_numpy(float)[order]
    inner = interior_mask(cells)[order] & np.isfinite(xy).all(axis=1)
    if box is not None and len(xy):  # unwrap: each track's path from minimum-image steps
        step = box.min_image(np.diff(xy, axis=0))
        step[t[1:] != t[:-1]] = 0.0
        path = np.vstack([xy[:1], xy[:1] + np.cumsum(step, axis=0)])
        # each track starts at its own (wrapped) position; only differences within a track are used
        xy = path
    msd, n_pairs = np.full(len(lags), np.nan), np.zeros(len(lags), np.int64)
    for k, lag in enumerate(lags):
        if lag >= len(t):
            continue
        # rows are sorted by (track, frame) with one row per frame: row i + lag is frame f + lag of the same
        # track exactly when the track has no gap between them
        ok = (t[lag:] == t[:-lag]) & (f[lag:] == f[:-lag] + lag) & inner[lag:] & inner[:-lag]
        d = xy[lag:][ok] - xy[:-lag][ok]
        n_pairs[k] = len(d)
        if len(d):
            msd[k] = float((d ** 2).sum(axis=1).mean())
    return pd.DataFrame({"lag": lags, "msd": msd, "n_pairs": n_pairs})


def msd_exponent(msd):
    """Exponent alpha of ``MSD ~ lag^alpha``: least-squares slope of log MSD against log lag.

    Lags with a finite positive MSD enter (1: diffusive, 2: ballistic); NaN with fewer than two.
    """
    require_columns(msd, ["lag", "msd"], "msd")
    lag, value = msd["lag"].to_numpy(float), msd["msd"].to_numpy(float)
    keep = np.isfinite(value) & (value > 0) & (lag > 0)
    if keep.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(lag[keep]), np.log(value[keep]), 1)[0])


def flow_summary(cells, box=None, correlation=None, msd=None):
    """The key numbers of a movie's flow, px and frames (see :func:`in_units` for physical units).

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with velocities (``vx``, ``vy``, px/frame) and tracks.
    box : Box, optional
        Periodic box; None for an open image.
    correlation, msd : pandas.DataFrame, optional
        :func:`velocity_correlation` and :func:`mean_squared_displacement`
        of ``cells`` (computed with their defaults when not given).

    Returns
    -------
    dict
        ``n_velocities`` (cell-frames with a velocity entering), ``mean_speed``
        (px/frame, over every such cell-frame), ``rms_velocity`` (px/frame),
        ``polar_order`` (mean over frames, dimensionless),
        ``correlation_length`` (px, :func:`correlation_length`),
        ``msd_exponent`` (:func:`msd_exponent`).
    """
    use = _moving_cells(cells)
    uv = cells[["vx", "vy"]].to_numpy(float)[use]
    per_frame = velocity_statistics(cells)
    correlation = velocity_correlation(cells, box) if correlation is None else correlation
    msd = mean_squared_displacement(cells, box) if msd is None else msd
    return {"n_velocities": int(len(uv)),
            "mean_speed": float(np.hypot(*uv.T).mean()) if len(uv) else float("nan"),
            "rms_velocity": float(np.sqrt((uv ** 2).sum(axis=1).mean())) if len(uv) else float("nan"),
            "polar_order": float(per_frame["polar_order"].mean()) if len(per_frame) else float("nan"),
            "correlation_length": correlation_length(correlation),
            "msd_exponent": msd_exponent(msd)}
