"""Statistics of a movie's cell velocities: speed and polar order per frame, the spatial velocity
correlation C(r) and its length, the mean squared displacement and its exponent, and the summary the
report shows.

Tables stay in px and frames (velocities in px/frame); :func:`hexatissue.flow.in_units` converts.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

from ..box import as_box
from ..errors import check_positive
from ..schema import interior_mask, require_columns, track_ids


def _sorted_by_track(track, frame):
    """Row order by (track, frame): one stable argsort of ``track`` when ``frame`` is already sorted."""
    if len(frame) < 2 or bool(np.all(frame[1:] >= frame[:-1])):
        return np.argsort(track, kind="stable")
    return np.lexsort((frame, track))


def _track_rows(cells):
    """The rows of ``cells`` by (track, frame): their order, and track, frame and (x, y) in that order."""
    require_columns(cells, ["frame", "x", "y"], "cells")
    track, frame = track_ids(cells), cells["frame"].to_numpy(np.int64)
    order = _sorted_by_track(track, frame)
    return order, track[order], frame[order], cells[["x", "y"]].to_numpy(float)[order]


def _centred_rows(cells):
    """The rows of ``cells`` by (track, frame), their (x, y) in that order, and the places ``k`` in that order whose
    track is also in the frames before (place ``k - 1``) and after (``k + 1``): the rows of a centred difference."""
    order, t, f, xy = _track_rows(cells)
    step = (t[1:] == t[:-1]) & (f[1:] == f[:-1] + 1)
    centred = np.zeros(len(t), bool)
    centred[1:-1] = step[1:] & step[:-1]
    return order, xy, np.flatnonzero(centred)


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


def _pair_sums(cells, box, r_max, bins, max_frames):
    """Per sampled frame and distance bin: the sums over cell pairs of ``dv_i . dv_j`` and of
    ``(|dv_i|^2 + |dv_j|^2) / 2``, and the pair counts (three arrays of shape (frames, bins)), with the
    bin edges (px)."""
    from scipy.spatial import cKDTree

    use = _moving_cells(cells)
    frame = cells["frame"].to_numpy(np.int64)[use]
    xy = cells[["x", "y"]].to_numpy(float)[use]
    uv = cells[["vx", "vy"]].to_numpy(float)[use]
    if r_max is None:
        extent = box.lengths if box is not None else (np.ptp(xy, axis=0) if len(xy) else np.zeros(2))
        r_max = 0.5 * float(np.min(extent))
    if not r_max > 0:
        return np.zeros((0, bins)), np.zeros((0, bins)), np.zeros((0, bins), np.int64), np.zeros(bins + 1)
    r_max = check_positive(r_max, "r_max", unit="px")
    edges = np.linspace(0.0, r_max, bins + 1)
    order = np.argsort(frame, kind="stable")
    frame, xy, uv = frame[order], xy[order], uv[order]
    distinct = np.unique(frame)
    starts = np.searchsorted(frame, distinct)
    ends = np.searchsorted(frame, distinct, "right")
    sampled = np.searchsorted(distinct, _sampled_frames(distinct, max_frames))
    dot, norm = np.zeros((len(sampled), bins)), np.zeros((len(sampled), bins))
    count = np.zeros((len(sampled), bins), np.int64)
    for row, k in enumerate(sampled):
        p, dv = xy[starts[k]:ends[k]], uv[starts[k]:ends[k]]
        dv = dv - dv.mean(axis=0)  # a uniform drift of the frame is not correlation
        tree = cKDTree(box.wrap(p), boxsize=box.lengths) if box is not None else cKDTree(p)
        pairs = tree.query_pairs(r_max, output_type="ndarray")  # i < j: no self-pairs
        if not len(pairs):
            continue
        d = p[pairs[:, 1]] - p[pairs[:, 0]]
        r = np.hypot(*(d if box is None else box.min_image(d)).T)
        which = np.clip(np.searchsorted(edges, r, "left") - 1, 0, bins - 1)  # r = 0 (two cells at one spot): bin 0
        a, b = dv[pairs[:, 0]], dv[pairs[:, 1]]
        dot[row] = np.bincount(which, (a * b).sum(axis=1), minlength=bins)
        norm[row] = np.bincount(which, 0.5 * ((a ** 2).sum(axis=1) + (b ** 2).sum(axis=1)), minlength=bins)
        count[row] = np.bincount(which, minlength=bins)
    return dot, norm, count, edges


def velocity_correlation(cells, box=None, r_max=None, bins=30, max_frames=20, n_boot=200, seed=0):
    """Spatial correlation of the velocity fluctuations, averaged over frames.

    ``C(r) = sum dv_i . dv_j / sum (|dv_i|^2 + |dv_j|^2) / 2`` over the pairs
    ``i != j`` of cells at centroid distance ``r`` (minimum image in a
    periodic box) in the same frame, with ``dv = v - <v>`` the velocity minus
    its frame mean (a uniform drift does not count as correlation).  Each
    bin is normalised by its own pairs' fluctuations, so ``|C| <= 1``, a
    field that is smooth on the scale of a bin gives C = 1 there, and
    ``C(0) = 1`` (a cell with itself) is the limit, not a bin: no self-pairs
    enter.  Interior cells with a finite velocity enter; frames are pooled.

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
    n_boot : int
        Bootstrap resamplings of the frames for ``correlation_sd`` (0: none).
    seed : int
        Seed of the bootstrap.

    Returns
    -------
    pandas.DataFrame
        One row per bin: ``r`` (bin centre, px), ``correlation`` (C(r),
        dimensionless; NaN for an empty bin), ``correlation_sd`` (its
        standard error from resampling the frames, dimensionless; NaN with
        fewer than two frames), ``n_pairs`` (pairs in the bin, every frame).
    """
    box = as_box(box)
    bins = int(check_positive(bins, "bins", integer=True))
    max_frames = int(check_positive(max_frames, "max_frames", integer=True))
    if n_boot != 0:
        n_boot = int(check_positive(n_boot, "n_boot", integer=True))
    dot, norm, count, edges = _pair_sums(cells, box, r_max, bins, max_frames)
    if not len(dot):
        return pd.DataFrame({"r": np.zeros(0), "correlation": np.zeros(0), "correlation_sd": np.zeros(0),
                             "n_pairs": np.zeros(0, np.int64)})
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = np.where(norm.sum(axis=0) > 0, dot.sum(axis=0) / norm.sum(axis=0), np.nan)
        sd = np.full(bins, np.nan)
        if len(dot) >= 2 and n_boot:
            # frames are the independent samples (pairs of one frame share its cells): resample them
            draw = np.random.default_rng(seed).integers(0, len(dot), size=(n_boot, len(dot)))
            weight = np.stack([np.bincount(d, minlength=len(dot)) for d in draw]).astype(float)
            filled = norm.sum(axis=0) > 0
            sd[filled] = np.nanstd((weight @ dot[:, filled]) / (weight @ norm[:, filled]), axis=0, ddof=1)
    sd[~np.isfinite(correlation)] = np.nan
    return pd.DataFrame({"r": 0.5 * (edges[1:] + edges[:-1]), "correlation": correlation, "correlation_sd": sd,
                         "n_pairs": count.sum(axis=0)})


#: Bins of a velocity correlation holding fewer than this fraction of the pairs of its fullest bin are too
#: few to trust: below a cell size they hold the odd pair of tiny or dividing cells.
SPARSE_BIN = 0.01

#: ... and bins of fewer pairs than this, however few the fullest holds (a short movie of a small field).
MIN_BIN_PAIRS = 10

#: Fewest bins an exponential fit of C(r) takes (three parameters and one degree of freedom).
MIN_FIT_BINS = 4


def reliable_bins(correlation):
    """Bins of :func:`velocity_correlation` with a finite C(r), at least :data:`SPARSE_BIN` x the pairs of
    the fullest bin and at least :data:`MIN_BIN_PAIRS` pairs (a boolean array)."""
    require_columns(correlation, ["correlation", "n_pairs"], "correlation")
    pairs = correlation["n_pairs"].to_numpy(float)
    top = pairs.max() if len(pairs) else 0.0
    return (np.isfinite(correlation["correlation"].to_numpy(float)) & (pairs >= MIN_BIN_PAIRS)
            & (pairs >= SPARSE_BIN * top))


class CorrelationLength(NamedTuple):
    """The decay length of a velocity correlation (:func:`correlation_length`).

    ``length`` and ``sd`` in px (NaN with ``reason`` when refused),
    ``amplitude`` A of ``C(r) = A exp(-r / length) + offset`` (dimensionless:
    the share of the velocity fluctuations correlated between neighbours;
    1 - A does not correlate, e.g. centroid jitter), ``offset`` (<= 0: the
    frame mean taken off every velocity), ``n_bins`` fitted, ``r_fit``
    (largest r fitted, px).
    """

    length: float
    sd: float
    amplitude: float
    offset: float
    n_bins: int
    r_fit: float
    reason: str


def correlation_length(correlation, spacing=None):
    """Decay length of a velocity correlation: a fit of ``C(r) = A exp(-r / xi) + B``.

    The fit runs over the :func:`reliable_bins` from the first one up to the
    last before C(r) first falls below 0 by more than its standard error
    (below 0 at all without ``correlation_sd``; anticorrelation further out,
    e.g. of vortices, is not an exponential decay), weighted by the bins'
    ``correlation_sd`` when the table has it.  The amplitude A is free, so
    velocity noise that does not correlate between neighbours (A < 1) does
    not shorten xi; so is the offset ``B <= 0``, which taking each frame's
    mean velocity off lowers C(r) by (about the variance of that mean over
    the field): without it xi comes out short, by 8 % for xi = 0.06 x the
    field's side.

    Parameters
    ----------
    correlation : pandas.DataFrame
        :func:`velocity_correlation` (``r``, ``correlation``, ``n_pairs``,
        optionally ``correlation_sd``).
    spacing : float, optional
        The cell spacing, px (e.g. the square root of the median cell area):
        a length below it is refused, since no pair of cells is that close.

    Returns
    -------
    CorrelationLength
        ``length`` and ``sd`` (px), ``amplitude``, ``n_bins``, ``r_fit``
        (px), ``reason`` ("" when measured; else why ``length`` is NaN: fewer
        than :data:`MIN_FIT_BINS` bins before C(r) reaches 0, a decay within
        one cell spacing, none within the fitted range, or an uncertainty as
        large as the length itself).
    """
    from scipy.optimize import curve_fit

    require_columns(correlation, ["r", "correlation", "n_pairs"], "correlation")
    keep = np.flatnonzero(reliable_bins(correlation))
    r = correlation["r"].to_numpy(float)[keep]
    c = correlation["correlation"].to_numpy(float)[keep]
    sd = (correlation["correlation_sd"].to_numpy(float)[keep] if "correlation_sd" in correlation.columns
          else np.full(len(keep), np.nan))
    # C's first zero: the first bin below 0 by more than its standard error (a noisy bin of few pairs near 0,
    # whose error bar reaches above it, does not end the fit); without standard errors, the first bin <= 0
    stop = np.flatnonzero(c + np.where(np.isfinite(sd), sd, 0.0) <= 0)
    n = int(stop[0]) if len(stop) else len(c)
    r_all, c_all = r, c
    r, c, sd = r[:n], c[:n], sd[:n]

    def refused(reason, amplitude=np.nan):
        return CorrelationLength(float("nan"), float("nan"), float(amplitude), float("nan"), n,
                                 float(r[-1]) if n else float("nan"), reason)

    if n < MIN_FIT_BINS:
        where = (f"falls to {c_all[n]:.2g} at r = {r_all[n]:.3g} px" if n < len(c_all)
                 else f"has only {n} reliable bin{'s' * (n != 1)}")
        return refused(f"C(r) {where}, with {n} bin{'s' * (n != 1)} before it and {MIN_FIT_BINS} needed for a "
                       f"fit: the velocities hardly correlate between cells")
    weighted = bool(np.all(np.isfinite(sd) & (sd > 0)))
    if weighted:  # a bin whose few pairs every resampling repeats would otherwise weigh without bound
        sd = np.maximum(sd, 0.1 * np.median(sd))
    # the start: a straight line through log C of the positive bins
    positive = c > 0
    if positive.sum() < 2:
        return refused("C(r) has fewer than 2 positive bins before its first zero: the velocities hardly correlate "
                       "between cells")
    slope, offset = np.polyfit(r[positive], np.log(c[positive]), 1)
    start = (min(float(np.exp(offset)), 1.0), -1.0 / slope if slope < 0 else 10.0 * float(r[-1]))
    model = lambda x, a, xi, b: a * np.exp(-x / xi) + b  # noqa: E731
    try:
        (amplitude, xi, offset), cov = curve_fit(model, r, c, p0=start + (0.0,), sigma=sd if weighted else None,
                                                 absolute_sigma=weighted, maxfev=10000,
                                                 bounds=([0.0, 1e-9, -1.0], [np.inf, np.inf, 0.0]))
    except (RuntimeError, ValueError) as err:
        return refused(f"the exponential fit did not converge ({err})")
    resid = (c - model(r, amplitude, xi, offset)) / (sd if weighted else 1.0)
    dof = n - 3
    chi2 = float(resid @ resid) / dof if dof else 1.0
    # bins scattered beyond their standard errors (or unweighted ones): the residuals set the scale
    scale = max(chi2, 1.0) if weighted else chi2
    xi_sd = float(np.sqrt(cov[1, 1] * (scale if weighted else 1.0))) if np.isfinite(cov[1, 1]) else float("nan")
    if spacing is not None and np.isfinite(spacing) and xi < spacing:
        return refused(f"C(r) decays over {xi:.3g} px, below one cell spacing ({spacing:.3g} px): no flow is "
                       f"correlated beyond a cell's neighbours", amplitude)
    if not xi_sd < xi:
        return refused(f"C(r) is too noisy to fix a length (the fit gives {xi:.3g} ± {xi_sd:.3g} px)", amplitude)
    if xi > r[-1]:
        return refused(f"C(r) hardly decays within the fitted range ({r[-1]:.3g} px; the fit's amplitude A = "
                       f"{amplitude:.2g} and decay length {xi:.3g} px): the correlation is longer than the field "
                       f"measures", amplitude)
    return CorrelationLength(float(xi), xi_sd, float(amplitude), float(offset), n, float(r[-1]), "")


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
    box = as_box(box)
    order, t, f, xy = _track_rows(cells)
    if lags is None:
        lags = _default_lags(int(f.max() - f.min()) + 1 if len(f) else 1)
    lags = np.asarray([check_positive(v, "lags", integer=True) for v in np.atleast_1d(lags)], np.int64)
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


def rms_step(cells, box=None):
    """Root mean square of the frame-to-frame centroid steps of interior cells, px/frame.

    Steps between consecutive frames of one track, both ends interior (minimum image in a periodic box).
    It exceeds the rms of :func:`hexatissue.flow.cell_velocities`' centred differences by the motion that
    reverses within a frame (centroid jitter of the segmentation, fluctuations), which a difference over
    two frames averages out.
    """
    box = as_box(box)
    order, t, f, xy = _track_rows(cells)
    inner = interior_mask(cells)[order] & np.isfinite(xy).all(axis=1)
    ok = (t[1:] == t[:-1]) & (f[1:] == f[:-1] + 1) & inner[1:] & inner[:-1]
    step = xy[1:][ok] - xy[:-1][ok]
    if box is not None and len(step):
        step = box.min_image(step)
    return float(np.sqrt((step ** 2).sum(axis=1).mean())) if len(step) else float("nan")


def cell_spacing(cells):
    """The cell spacing, px: the square root of the median area of the interior cells (NaN without ``area``)."""
    if "area" not in cells.columns:
        return float("nan")
    area = cells["area"].to_numpy(float)[interior_mask(cells)]
    area = area[np.isfinite(area) & (area > 0)]
    return float(np.sqrt(np.median(area))) if len(area) else float("nan")


def flow_summary(cells, box=None, correlation=None, msd=None):
    """The key numbers of a movie's flow, px and frames (see :func:`hexatissue.flow.in_units` for physical units).

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
        (px/frame, over every such cell-frame), ``rms_velocity`` (px/frame,
        of the centred differences over two frames), ``rms_step`` (px/frame,
        :func:`rms_step`: frame-to-frame steps, larger by the motion that
        reverses within a frame), ``polar_order`` (mean over frames,
        dimensionless), ``cell_spacing`` (px, :func:`cell_spacing`),
        ``correlation_length``, ``correlation_length_sd`` (px),
        ``correlation_amplitude``, ``correlation_bins`` and
        ``correlation_reason`` (:func:`correlation_length`; the reason is ""
        when the length is measured), ``msd_exponent`` (:func:`msd_exponent`).
    """
    use = _moving_cells(cells)
    uv = cells[["vx", "vy"]].to_numpy(float)[use]
    per_frame = velocity_statistics(cells)
    correlation = velocity_correlation(cells, box) if correlation is None else correlation
    msd = mean_squared_displacement(cells, box) if msd is None else msd
    spacing = cell_spacing(cells)
    length = correlation_length(correlation, spacing)
    return {"n_velocities": int(len(uv)),
            "mean_speed": float(np.hypot(*uv.T).mean()) if len(uv) else float("nan"),
            "rms_velocity": float(np.sqrt((uv ** 2).sum(axis=1).mean())) if len(uv) else float("nan"),
            "rms_step": rms_step(cells, box),
            "polar_order": float(per_frame["polar_order"].mean()) if len(per_frame) else float("nan"),
            "cell_spacing": spacing,
            "correlation_length": length.length, "correlation_length_sd": length.sd,
            "correlation_amplitude": length.amplitude, "correlation_bins": length.n_bins,
            "correlation_reason": length.reason,
            "msd_exponent": msd_exponent(msd)}
