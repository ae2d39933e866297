"""Flow averaged around events: every T1 (centred on its quartet, its junction along x), every ±1/p defect
(rotated by its orientation), and the angular harmonics of the averages.

Each event gives one *sample* per cell near it: the cell's position relative
to the event centre and its velocity minus a reference velocity (a T1's: the
mean of its four cells; a defect's: the mean of the cells around it, so the
tissue's drift does not enter), both in the event's own axes.  The samples of every event of a kind, at one time offset,
are averaged on a square grid of bins and fitted by angular harmonics.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..box import as_box
from ..errors import InputError, check_p, check_positive
from ..schema import interior_mask, require_columns, track_ids

__all__ = ["t1_flow", "defect_flow", "angular_harmonics", "MAX_HARMONIC"]

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
    """``offsets`` as an int64 array; :class:`InputError` unless they are one or more whole numbers."""
    values = np.atleast_1d(np.asarray(offsets, dtype=object))
    whole = values.size > 0 and all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in values)
    if not whole:
        raise InputError(f"offsets must be one or more integers (frames from the event's frame_start); "
                         f"got {offsets!r}")
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
    extent, bin_size = _extent_and_bins(cells, extent, bin_size)
    near = _Neighbourhoods(cells, box)
    find = _row_lookup(cells)
    chosen = events[events["kind"].astype(str).isin(kinds)]
    quartet = chosen[["cell_a", "cell_b", "cell_c", "cell_d"]].to_numpy(np.int64)
    start = chosen["frame_start"].to_numpy(np.int64)
    kind_code = np.array([kinds.index(k) for k in chosen["kind"].astype(str)], np.int64)
    xy, uv = near.xy, near.uv
    # the axes of each event: the c -> d direction at frame_start
    rc, rd = find(quartet[:, 2], start), find(quartet[:, 3], start)
    has_axis = (rc >= 0) & (rd >= 0)
    axis = np.full((len(chosen), 2), np.nan)
    axis[has_axis] = near.displacement(xy[rd[has_axis]] - xy[rc[has_axis]])
    angle = np.arctan2(axis[:, 1], axis[:, 0])
    parts = []
    for o, tau in enumerate(offsets):
        t = start + tau
        rows = np.stack([find(quartet[:, k], t) for k in range(4)], axis=1)
        ok = has_axis & (rows >= 0).all(axis=1)
        ok[ok] = near.usable[rows[ok]].all(axis=1)
        for e in np.flatnonzero(ok):
            first = xy[rows[e, 0]]
            centre = first + near.displacement(xy[rows[e]] - first).mean(axis=0)
            parts.append((kind_code[e], o, e, *near.samples(t[e], centre, uv[rows[e]].mean(axis=0), angle[e],
                                                             extent)))
    samples, codes = _sample_table(parts, kinds, offsets, chosen["event"].to_numpy(np.int64))
    return _binned(samples, *codes, kinds, offsets, extent, bin_size), samples


def defect_flow(cells, defects, grid, p=6, box=None, extent=None, bin_size=None):
    """The flow around the +1/p and -1/p defects, averaged per charge, in each defect's own axes.

    Near a defect of charge ``s`` the orientation of the field is
    ``theta = arg(Gamma_p) / p = s phi + theta_0``; ``theta_0`` is measured
    from the valid grid nodes within 1.5 grid spacings of the defect
    (``arg sum Gamma_p / |Gamma_p| exp(-i p s phi)`` / p, ``phi`` the node's
    direction from the defect), and the defect's axes are rotated by
    ``theta_0 / (1 - s)``: a direction along which the orientation is radial
    (a +1/6 defect has 5 such directions, a -1/6 defect 7, so the average
    keeps that symmetry).  Every interior cell with a velocity within
    ``extent`` gives a sample: its position and its velocity minus the mean
    velocity of those cells, in the defect's axes.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``frame``, ``x``, ``y`` (px), ``vx``, ``vy``
        (px/frame) and optionally ``is_border`` and ``area`` (px^2).
    defects : pandas.DataFrame
        The ``defects`` table: ``frame``, ``defect``, ``x``, ``y`` (px),
        ``charge`` and ``p``.
    grid : pandas.DataFrame
        The ``grid`` table: ``frame``, ``x``, ``y`` (px), ``Gamma{p}_re``,
        ``Gamma{p}_im``, ``valid``.
    p : int
        Symmetry order; its ±1/p defects enter.
    box : Box, optional
        Periodic box; None for an open image.
    extent, bin_size : float, optional
        As for :func:`t1_flow` (defaults 4 R_cell and R_cell / 2).

    Returns
    -------
    average, samples : pandas.DataFrame
        As for :func:`t1_flow`, with ``kind`` ``"+1/p"`` or ``"-1/p"`` (e.g.
        ``"+1/6"``), ``offset`` 0 and ``event`` the defect id.
    """
    require_columns(cells, ["frame", "x", "y", "vx", "vy"], "cells")
    require_columns(defects, ["frame", "defect", "x", "y", "charge", "p"], "defects")
    p = check_p(p)
    require_columns(grid, ["frame", "x", "y", f"Gamma{p}_re", f"Gamma{p}_im", "valid"], "grid")
    box = as_box(box)
    extent, bin_size = _extent_and_bins(cells, extent, bin_size)
    near = _Neighbourhoods(cells, box)
    kinds = (f"+1/{p}", f"-1/{p}")
    units = np.rint(defects["charge"].to_numpy(float) * p)
    chosen = defects[(defects["p"].to_numpy() == p) & (np.abs(units) == 1)]
    charge = np.rint(chosen["charge"].to_numpy(float) * p) / p
    g_frame = grid["frame"].to_numpy(np.int64)
    g_xy = grid[["x", "y"]].to_numpy(float)
    gamma = grid[f"Gamma{p}_re"].to_numpy(float) + 1j * grid[f"Gamma{p}_im"].to_numpy(float)
    g_ok = grid["valid"].to_numpy(bool) & np.isfinite(gamma) & (np.abs(gamma) > 0)
    spacing = float(grid["spacing"].iloc[0]) if "spacing" in grid.columns and len(grid) else np.nan
    g_order = np.argsort(g_frame, kind="stable")
    g_sorted = g_frame[g_order]
    parts = []
    for e, (t, x, y, s) in enumerate(zip(chosen["frame"].to_numpy(np.int64), chosen["x"].to_numpy(float),
                                         chosen["y"].to_numpy(float), charge)):
        nodes = g_order[np.searchsorted(g_sorted, t):np.searchsorted(g_sorted, t, "right")]
        nodes = nodes[g_ok[nodes]]
        d = near.displacement(g_xy[nodes] - [x, y])
        r = np.hypot(d[:, 0], d[:, 1])
        step = spacing if np.isfinite(spacing) else (np.min(r) * 2 if len(r) else np.nan)
        close = r <= 1.5 * step
        if not close.any():
            continue
        phi = np.arctan2(d[close, 1], d[close, 0])
        g = gamma[nodes[close]]
        theta0 = np.angle(np.sum(g / np.abs(g) * np.exp(-1j * p * s * phi))) / p
        parts.append((0 if s > 0 else 1, 0, e, *near.samples(t, np.array([x, y]), None, theta0 / (1 - s), extent)))
    samples, codes = _sample_table(parts, kinds, np.zeros(1, np.int64), chosen["defect"].to_numpy(np.int64))
    return _binned(samples, *codes, kinds, np.zeros(1, np.int64), extent, bin_size), samples


def _extent_and_bins(cells, extent, bin_size):
    """``extent`` and ``bin_size`` checked, px; the defaults 4 R_cell and R_cell / 2 from the cells' areas."""
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
    return extent, bin_size


class _Neighbourhoods:
    """The usable cells of a movie (interior, finite position and velocity), found by frame and distance."""

    def __init__(self, cells, box):
        self.box = box
        self.xy = cells[["x", "y"]].to_numpy(float)
        self.uv = cells[["vx", "vy"]].to_numpy(float)
        frame = cells["frame"].to_numpy(np.int64)
        self.usable = interior_mask(cells) & np.isfinite(self.xy).all(axis=1) & np.isfinite(self.uv).all(axis=1)
        self.by_frame = np.argsort(frame, kind="stable")
        self.frame_sorted = frame[self.by_frame]

    def displacement(self, d):
        return d if self.box is None else self.box.min_image(d)

    def samples(self, t, centre, reference, angle, extent):
        """``(x, y, vx, vy)`` of the usable cells of frame ``t`` within ``extent`` of ``centre``, relative
        to it and to the ``reference`` velocity (None: their mean), rotated by ``-angle``."""
        lo, hi = np.searchsorted(self.frame_sorted, [t, t + 1])
        rows = self.by_frame[lo:hi]
        rows = rows[self.usable[rows]]
        d = self.displacement(self.xy[rows] - centre)
        keep = (d ** 2).sum(axis=1) <= extent ** 2  # a disk: the same cells whatever the axes
        d, v = d[keep], self.uv[rows[keep]]
        if len(v):  # a defect on the first or last frame has no cell with a velocity around it
            v = v - (v.mean(axis=0) if reference is None else reference)
        c, s = np.cos(angle), np.sin(angle)
        return c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], c * v[:, 0] + s * v[:, 1], \
            -s * v[:, 0] + c * v[:, 1]


def _sample_table(parts, kinds, offsets, ids):
    """The samples table from ``(kind code, offset index, centre index, x, y, vx, vy)`` parts, and the codes."""
    if parts:
        k, o, e = (np.concatenate([np.full(len(part[3]), part[j]) for part in parts]).astype(np.int64)
                   for j in range(3))
        x, y, vx, vy = (np.concatenate([part[j] for part in parts]) for j in range(3, 7))
    else:
        k = o = e = np.zeros(0, np.int64)
        x = y = vx = vy = np.zeros(0)
    samples = pd.DataFrame({"kind": pd.array(np.array(kinds, dtype=object)[k] if len(k) else [], dtype="string"),
                            "offset": offsets[o], "event": ids[e], "x": x, "y": y, "vx": vx, "vy": vy})
    return samples, (k, o, e)


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
