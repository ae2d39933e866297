"""Flow averaged around events: every T1 (centred on its quartet, its junction along x) and its angular harmonics.

Each event gives one *sample* per cell near it: the cell's position and
velocity relative to the event centre, in the event's own axes, and minus the
event centre's velocity (the mean of its four cells), so the tissue's drift
does not enter.  The samples of every event of a kind, at one time offset,
are averaged on a square grid of bins and fitted by angular harmonics.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..box import as_box
from ..errors import InputError, check_positive
from ..schema import interior_mask, require_columns, track_ids

__all__ = ["t1_flow", "angular_harmonics", "MAX_HARMONIC"]

#: Highest angular harmonic fitted (the paper's quadrupole flow has sin 6, 8 and 10 phi modes).
MAX_HARMONIC = 8


def _row_lookup(cells):
    """``find(track, frame)``: row of each (track, frame) pair in ``cells``, -1 when absent."""
    track, frame = track_ids(cells), cells["frame"].to_numpy(np.int64)
    span = int(frame.max()) + 2 if len(frame) else 1
    key = track * span + frame
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]

    def find(t, f):
        f = np.asarray(f, np.int64)
        k = np.asarray(t, np.int64) * span + f
        if not len(sorted_key):
            return np.full(k.shape, -1, np.int64)
        at = np.minimum(np.searchsorted(sorted_key, k), len(sorted_key) - 1)
        # frames outside 0 .. span - 2 would alias another track's keys
        found = (f >= 0) & (f < span - 1) & (sorted_key[at] == k)
        return np.where(found, order[at], -1)

    return find


def _offsets(offsets):
    values = np.atleast_1d(np.asarray(offsets))
    if values.size == 0 or values.dtype.kind not in "iu" and not np.all(values == np.round(values)):
        raise InputError(f"offsets must be integers (frames from the event's frame_start); got {offsets!r}")
    return values.astype(np.int64)


def t1_flow(cells, events, box=None, offsets=(-4, 0, 4), extent=None, bin_size=None, kinds=("cycle",
                                                                                              "intercalation")):
    """The flow around T1 events, averaged per kind and time offset, in each event's own axes.

    For every T1 of ``kinds`` and every offset ``tau``, at frame
    ``t = frame_start + tau``: the centre is the mean position of its four
    cells a, b, c, d (minimum image in a periodic box) and the reference
    velocity their mean velocity; the axes are rotated so that the c -> d
    direction at ``frame_start`` (the direction of the vanishing a-b junction,
    whose ends touch c and d) lies along +x.  Every interior cell with a
    velocity within ``extent`` of the centre then gives a sample: its
    position and its velocity minus the reference, in those axes.  An event
    is left out at an offset where one of its four cells is missing or has
    no velocity.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table: ``frame``, ``x``, ``y`` (px), ``vx``, ``vy`` (px/frame,
        :func:`hexatissue.flow.cell_velocities`), ``track`` (or ``cell``) and
        optionally ``is_border`` and ``area`` (px^2).
    events : pandas.DataFrame
        The ``events`` table (:func:`hexatissue.detect_t1`): ``event``,
        ``kind``, ``frame_start``, ``cell_a`` .. ``cell_d`` (track ids).
    box : Box, optional
        Periodic box; None for an open image.
    offsets : sequence of int
        Frames from ``frame_start`` (negative: before the T1).
    extent : float, optional
        Radius of the averaged disk, px (default 4 R_cell,
        ``R_cell = sqrt(mean interior area / pi)``).
    bin_size : float, optional
        Side of a bin, px (default R_cell / 2).
    kinds : sequence of str
        Event kinds averaged, each on its own.

    Returns
    -------
    average : pandas.DataFrame
        One row per kind, offset and non-empty bin: ``kind``, ``offset``
        (frames), ``x``, ``y`` (bin centre in the event's axes, px), ``vx``,
        ``vy`` (mean relative velocity, px/frame), ``n_samples``,
        ``n_events`` (events of that kind averaged at that offset).
    samples : pandas.DataFrame
        Every sample: ``kind``, ``offset``, ``event``, ``x``, ``y`` (px),
        ``vx``, ``vy`` (px/frame), in the event's axes (for
        :func:`angular_harmonics`).
    """
    require_columns(cells, ["frame", "x", "y", "vx", "vy"], "cells")
    require_columns(events, ["event", "kind", "frame_start", "cell_a", "cell_b", "cell_c", "cell_d"], "events")
    box = as_box(box)
    offsets = _offsets(offsets)
    kinds = tuple(kinds)
    r_cell = None
    if extent is None or bin_size is None:
        if "area" not in cells.columns:
            raise InputError("cells needs an 'area' column (px^2) for the default extent and bin_size; or pass both")
        area = cells["area"].to_numpy(float)[interior_mask(cells)]
        area = area[np.isfinite(area)]
        if not len(area):
            raise InputError("cells has no interior cell with a finite area for the default extent and bin_size")
        r_cell = float(np.sqrt(area.mean() / np.pi))
    extent = check_positive(4 * r_cell if extent is None else extent, "extent", unit="px")
    bin_size = check_positive(0.5 * r_cell if bin_size is None else bin_size, "bin_size", unit="px")
    xy = cells[["x", "y"]].to_numpy(float)
    uv = cells[["vx", "vy"]].to_numpy(float)
    frame = cells["frame"].to_numpy(np.int64)
    usable = interior_mask(cells) & np.isfinite(xy).all(axis=1) & np.isfinite(uv).all(axis=1)
    find = _row_lookup(cells)
    chosen = events[events["kind"].astype(str).isin(kinds)]
    quartet = chosen[["cell_a", "cell_b", "cell_c", "cell_d"]].to_numpy(np.int64)
    start = chosen["frame_start"].to_numpy(np.int64)
    kind_code = np.array([kinds.index(k) for k in chosen["kind"].astype(str)], np.int64)

    def displacement(d):
        return d if box is None else box.min_image(d)

    # the axes of each event: the c -> d direction at frame_start
    rc, rd = find(quartet[:, 2], start), find(quartet[:, 3], start)
    has_axis = (rc >= 0) & (rd >= 0)
    axis = np.full((len(chosen), 2), np.nan)
    axis[has_axis] = displacement(xy[rd[has_axis]] - xy[rc[has_axis]])
    angle = np.arctan2(axis[:, 1], axis[:, 0])
    cos, sin = np.cos(angle), np.sin(angle)

    by_frame = np.argsort(frame, kind="stable")
    frame_sorted = frame[by_frame]
    parts = []
    for o, tau in enumerate(offsets):
        t = start + tau
        rows = np.stack([find(quartet[:, k], t) for k in range(4)], axis=1)
        ok = has_axis & (rows >= 0).all(axis=1)
        ok[ok] = usable[rows[ok]].all(axis=1)
        for e in np.flatnonzero(ok):
            first = xy[rows[e, 0]]
            centre = first + displacement(xy[rows[e]] - first).mean(axis=0)
            reference = uv[rows[e]].mean(axis=0)
            lo, hi = np.searchsorted(frame_sorted, [t[e], t[e] + 1])
            near = by_frame[lo:hi]
            near = near[usable[near]]
            d = displacement(xy[near] - centre)
            keep = (d ** 2).sum(axis=1) <= extent ** 2  # a disk: the same cells whatever the event's axes
            d, v = d[keep], uv[near[keep]] - reference
            # rotate by -angle: the event's c -> d axis becomes +x
            parts.append((np.full(len(d), kind_code[e]), np.full(len(d), o), np.full(len(d), e),
                          cos[e] * d[:, 0] + sin[e] * d[:, 1], -sin[e] * d[:, 0] + cos[e] * d[:, 1],
                          cos[e] * v[:, 0] + sin[e] * v[:, 1], -sin[e] * v[:, 0] + cos[e] * v[:, 1]))
    if parts:
        k, o, e, x, y, vx, vy = (np.concatenate(column) for column in zip(*parts))
    else:
        k = o = e = np.zeros(0, np.int64)
        x = y = vx = vy = np.zeros(0)
    samples = pd.DataFrame({"kind": pd.array(np.array(kinds, dtype=object)[k] if len(k) else [], dtype="string"),
                            "offset": offsets[o], "event": chosen["event"].to_numpy(np.int64)[e],
                            "x": x, "y": y, "vx": vx, "vy": vy})
    return _binned(samples, k, o, e, kinds, offsets, extent, bin_size), samples


def _binned(samples, k, o, e, kinds, offsets, extent, bin_size):
    """Mean of the samples per kind, offset and square bin (bins centred on the event: one bin holds 0)."""
    half = int(np.ceil(extent / bin_size - 0.5))
    n_side = 2 * half + 1
    ix = np.clip(np.rint(samples["x"].to_numpy() / bin_size).astype(np.int64) + half, 0, n_side - 1)
    iy = np.clip(np.rint(samples["y"].to_numpy() / bin_size).astype(np.int64) + half, 0, n_side - 1)
    cell = ((k * len(offsets) + o) * n_side + iy) * n_side + ix
    size = len(kinds) * len(offsets) * n_side * n_side
    count = np.bincount(cell, minlength=size)
    sums = [np.bincount(cell, samples[c].to_numpy(), minlength=size) for c in ("vx", "vy")]
    events = np.zeros(len(kinds) * len(offsets), np.int64)
    group = k * len(offsets) + o
    if len(group):
        pairs = np.unique(np.c_[group, e], axis=0)
        events = np.bincount(pairs[:, 0], minlength=len(events))
    full = np.flatnonzero(count)
    gk, rest = np.divmod(full, len(offsets) * n_side * n_side)
    go, rest = np.divmod(rest, n_side * n_side)
    gy, gx = np.divmod(rest, n_side)
    return pd.DataFrame({"kind": pd.array(np.array(kinds, dtype=object)[gk] if len(gk) else [], dtype="string"),
                         "offset": offsets[go], "x": (gx - half) * bin_size, "y": (gy - half) * bin_size,
                         "vx": sums[0][full] / count[full], "vy": sums[1][full] / count[full],
                         "n_samples": count[full], "n_events": events[gk * len(offsets) + go]})


def angular_harmonics(samples, r_min=0.0, r_max=np.inf, max_harmonic=MAX_HARMONIC):
    """Angular harmonics of the radial and tangential velocity of event-centred samples.

    Per kind and offset, the samples with ``r_min <= r <= r_max`` (``r``,
    ``phi`` their polar coordinates in the event's axes) are fitted by least
    squares with ``v(phi) = a_0 + sum_n (a_n cos n phi + b_n sin n phi)``,
    ``n = 1 .. max_harmonic``, for the radial velocity ``v_r`` and the
    tangential one ``v_phi`` (counter-clockwise in x, y).

    Parameters
    ----------
    samples : pandas.DataFrame
        ``kind``, ``offset``, ``x``, ``y`` (px), ``vx``, ``vy`` (px/frame),
        e.g. the samples of :func:`t1_flow`.
    r_min, r_max : float
        Annulus of the fit, px.
    max_harmonic : int
        Highest harmonic.

    Returns
    -------
    pandas.DataFrame
        One row per kind, offset and ``n = 0 .. max_harmonic``: ``kind``,
        ``offset``, ``n``, ``radial_cos``, ``radial_sin``, ``tangential_cos``,
        ``tangential_sin`` (``a_n``, ``b_n``, px/frame), ``radial_amplitude``,
        ``tangential_amplitude`` (``sqrt(a_n^2 + b_n^2)``, px/frame) and
        ``n_samples``; NaN where the samples are fewer than the
        ``2 max_harmonic + 1`` coefficients.
    """
    require_columns(samples, ["kind", "offset", "x", "y", "vx", "vy"], "samples")
    max_harmonic = int(check_positive(max_harmonic, "max_harmonic", integer=True))
    rows = []
    n = np.arange(max_harmonic + 1)
    for (kind, offset), group in samples.groupby(["kind", "offset"], sort=True):
        x, y = group["x"].to_numpy(float), group["y"].to_numpy(float)
        r, phi = np.hypot(x, y), np.arctan2(y, x)
        keep = (r >= r_min) & (r <= r_max) & (r > 0)
        phi = phi[keep]
        vx, vy = group["vx"].to_numpy(float)[keep], group["vy"].to_numpy(float)[keep]
        radial = np.cos(phi) * vx + np.sin(phi) * vy
        tangential = -np.sin(phi) * vx + np.cos(phi) * vy
        coef = np.full((2, 2, len(n)), np.nan)  # (radial, tangential), (cos, sin), n
        if len(phi) >= 2 * max_harmonic + 1:
            design = np.c_[np.cos(np.outer(phi, n)), np.sin(np.outer(phi, n[1:]))]
            fit = np.linalg.lstsq(design, np.c_[radial, tangential], rcond=None)[0]
            coef[:, 0, :] = fit[:len(n)].T
            coef[:, 1, 0] = 0.0
            coef[:, 1, 1:] = fit[len(n):].T
        for j in n:
            rows.append((kind, offset, j, coef[0, 0, j], coef[0, 1, j], coef[1, 0, j], coef[1, 1, j],
                         np.hypot(coef[0, 0, j], coef[0, 1, j]), np.hypot(coef[1, 0, j], coef[1, 1, j]),
                         int(keep.sum())))
    return pd.DataFrame(rows, columns=["kind", "offset", "n", "radial_cos", "radial_sin", "tangential_cos",
                                       "tangential_sin", "radial_amplitude", "tangential_amplitude", "n_samples"])
