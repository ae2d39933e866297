"""T1 events and topological defects: how close are they? (the paper's Fig. 3e).

For every T1 event we measure the displacement from the event (the centre of
its quartet at ``frame_start``) to the nearest elementary defect (charge
``±1/p``, default p = 6) present in the same frame.  The control draws cells
at random from the same frames (interior cells only) and measures the same
distance from their centroids.  If T1s happen near defects, the event
distances are stochastically smaller than the control's; a two-sample
Kolmogorov–Smirnov test (:func:`scipy.stats.ks_2samp`) says how significant
the difference is.

Positions follow the package convention: ``x`` = column, ``y`` = row, px,
origin at the centre of pixel (0, 0).  In a periodic box every displacement
is the minimum image.
"""
from __future__ import annotations

import warnings

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.spatial import cKDTree

from ..box import as_box
from ..defects import charge_mask
from ..errors import InputError, as_generator, check_p, check_positive
from ..schema import interior_mask, require_columns, rows_by_frame, track_ids

__all__ = ["nearest_defect", "t1_defect_distances", "random_cell_distances", "random_vertex_distances",
           "t1_defect_proximity", "compare_distances", "ProximityResult", "DISTANCE_COLUMNS"]

DISTANCE_COLUMNS = {
    "defect": "id of the nearest defect in its frame (-1 when the frame has none)",
    "charge": "charge of that defect (multiple of 1/p; NaN when none)",
    "dx": "x_defect - x_point, px (minimum image in a periodic box)",
    "dy": "y_defect - y_point, px (minimum image in a periodic box)",
    "dr": "|(dx, dy)|, px",
}


def nearest_defect(frames, xy, defects, p=6, box=None):
    """Displacement from each point to the nearest ``±1/p`` defect of the same frame.

    Parameters
    ----------
    frames : (n,) int array
        Frame of each query point.  Ignored (all points match every defect)
        when ``defects`` has no ``frame`` column.
    xy : (n, 2) float array
        Query positions (x, y), px; x = column, y = row.
    defects : pandas.DataFrame
        Defects table: ``x``, ``y``, ``charge``, ``defect``, optionally
        ``frame`` and ``p`` (rows of other orders are ignored).
    p : int
        Symmetry order: only defects of charge ``±1/p`` count.
    box : Box, optional
        Periodic box: distances are minimum-image.

    Returns
    -------
    pandas.DataFrame
        One row per query point, in input order: ``defect``, ``charge``,
        ``dx``, ``dy``, ``dr`` (see :data:`DISTANCE_COLUMNS`; px).  Points in
        frames without any defect get ``defect = -1`` and NaN elsewhere.
    """
    p = check_p(p)
    box = as_box(box)
    require_columns(defects, ("x", "y", "charge", "defect"), "defects")
    xy = np.asarray(xy, float).reshape(-1, 2)
    frames = np.asarray(frames, np.int64).reshape(-1)
    if len(frames) != len(xy):
        raise InputError(f"frames and xy must have the same length; got {len(frames)} and {len(xy)}")
    keep = charge_mask(defects["charge"], p)
    if "p" in defects.columns:
        keep &= defects["p"].to_numpy(np.int64) == p
    d = defects[keep]
    out = {"defect": np.full(len(xy), -1, np.int64), "charge": np.full(len(xy), np.nan),
           "dx": np.full(len(xy), np.nan), "dy": np.full(len(xy), np.nan)}
    has_time = "frame" in d.columns
    d_frames = d["frame"].to_numpy(np.int64) if has_time else np.zeros(len(d), np.int64)
    q_frames = frames if has_time else np.zeros(len(xy), np.int64)
    d_xy, d_id, d_q = d[["x", "y"]].to_numpy(float), d["defect"].to_numpy(np.int64), d["charge"].to_numpy(float)
    query_rows, defect_rows = rows_by_frame(q_frames), rows_by_frame(d_frames)
    for t in query_rows.keys() & defect_rows.keys():
        qi, di = query_rows[t], defect_rows[t]
        k = _nearest(xy[qi], d_xy[di], box)
        delta = d_xy[di][k] - xy[qi]
        if box is not None:
            delta = box.min_image(delta)
        out["defect"][qi], out["charge"][qi] = d_id[di][k], d_q[di][k]
        out["dx"][qi], out["dy"][qi] = delta[:, 0], delta[:, 1]
    out["dr"] = np.hypot(out["dx"], out["dy"])
    return pd.DataFrame(out)


def _nearest(points, targets, box):
    """Index into ``targets`` of the nearest target of each point (minimum image when periodic)."""
    if box is None:
        return cKDTree(targets).query(points)[1]
    # cKDTree's periodic mode needs coordinates in [0, L)
    return cKDTree(box.wrap(targets), boxsize=box.lengths).query(box.wrap(points))[1]


def t1_defect_distances(events, defects, p=6, box=None, kinds=("cycle", "intercalation", "unresolved"),
                        include_border=False):
    """Displacement from every T1 event to the nearest ``±1/p`` defect at its ``frame_start``.

    Parameters
    ----------
    events : pandas.DataFrame
        Events table (``event``, ``kind``, ``frame_start``, ``x``, ``y``;
        optional ``is_border``).
    defects : pandas.DataFrame
        Defects table with ``frame``.
    p : int
        Symmetry order of the defects.
    box : Box, optional
        Periodic box (minimum image).
    kinds : sequence of str
        Event kinds to keep.
    include_border : bool
        Keep events whose quartet touches a border cell (open images).

    Returns
    -------
    pandas.DataFrame
        ``event``, ``kind``, ``frame`` (= ``frame_start``), ``x``, ``y``
        (event position, px), then :data:`DISTANCE_COLUMNS`.
    """
    require_columns(events, ("event", "kind", "frame_start", "x", "y"), "events")
    use = events["kind"].isin(list(kinds)).to_numpy(bool) & np.isfinite(events[["x", "y"]].to_numpy(float)).all(axis=1)
    if not include_border and "is_border" in events.columns:
        use = use & ~events["is_border"].to_numpy(bool)
    ev = events[use]
    frames = ev["frame_start"].to_numpy(np.int64)
    xy = ev[["x", "y"]].to_numpy(float)
    head = pd.DataFrame({"event": ev["event"].to_numpy(np.int64), "kind": ev["kind"].astype(str).to_numpy(),
                         "frame": frames, "x": xy[:, 0], "y": xy[:, 1]})
    return pd.concat([head, nearest_defect(frames, xy, defects, p, box)], axis=1)


def random_cell_distances(cells, frames, defects, p=6, box=None, n_per_frame=1, seed=0, include_border=False):
    """Control: displacement from randomly drawn cells to the nearest ``±1/p`` defect.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table: ``frame``, ``x``, ``y`` (centroid, px), ``track`` or
        ``cell``; optional ``is_border`` (border cells are not drawn unless
        ``include_border``).
    frames : array_like of int
        One entry per draw request, e.g. the ``frame_start`` of every event:
        ``n_per_frame`` cells are drawn for each entry, from that frame.
        Draws for the same frame are without replacement while the frame has
        enough cells.
    defects : pandas.DataFrame
        Defects table with ``frame``.
    p, box
        As in :func:`nearest_defect`.
    n_per_frame : int
        Cells drawn per entry of ``frames``.
    seed : int or numpy.random.Generator

    Returns
    -------
    pandas.DataFrame
        ``frame``, ``track`` (of the drawn cell), ``x``, ``y`` (px), then
        :data:`DISTANCE_COLUMNS`.
    """
    require_columns(cells, ("frame", "x", "y"), "cells")
    use = interior_mask(cells) if not include_border else np.ones(len(cells), bool)
    return _random_point_distances(cells, track_ids(cells), "track", use, frames, defects, p, box, n_per_frame,
                                   seed)


def random_vertex_distances(vertices, frames, defects, p=6, box=None, n_per_frame=1, seed=0, include_border=False):
    """Control at junction level: displacement from randomly drawn vertices to the nearest defect.

    T1 events sit where four cells meet (their ``x, y`` is the quartet's
    centre), random cells at cell centres; drawing vertices instead compares
    like with like.  Only vertices with three or more junctions are drawn
    (not the degree-2 image corners of open images).

    Parameters
    ----------
    vertices : pandas.DataFrame
        Vertices table: ``frame``, ``vertex``, ``x``, ``y`` (px), ``degree``;
        optional ``is_border`` (not drawn unless ``include_border``).
    frames, defects, p, box, n_per_frame, seed
        As in :func:`random_cell_distances`.

    Returns
    -------
    pandas.DataFrame
        ``frame``, ``vertex``, ``x``, ``y`` (px), then :data:`DISTANCE_COLUMNS`.
    """
    require_columns(vertices, ("frame", "vertex", "x", "y", "degree"), "vertices")
    use = vertices["degree"].to_numpy(np.int64) >= 3
    if not include_border:
        use &= interior_mask(vertices)
    return _random_point_distances(vertices, vertices["vertex"].to_numpy(np.int64), "vertex", use, frames, defects,
                                   p, box, n_per_frame, seed)


def _random_point_distances(points, ids, id_name, use, frames, defects, p, box, n_per_frame, seed):
    """Draw ``n_per_frame`` rows of ``points[use]`` per entry of ``frames`` and measure them."""
    n_per_frame = check_positive(n_per_frame, "n_per_frame", integer=True)
    gen = as_generator(seed)
    use = use & np.isfinite(points[["x", "y"]].to_numpy(float)).all(axis=1)
    c_frame = points["frame"].to_numpy(np.int64)[use]
    c_xy = points[["x", "y"]].to_numpy(float)[use]
    c_id = ids[use]
    want, counts = np.unique(np.asarray(frames, np.int64), return_counts=True)
    rows_of = rows_by_frame(c_frame)
    picks = []
    for t, k in zip(want.tolist(), counts * n_per_frame):
        pool = rows_of.get(t)
        if pool is None:
            continue
        picks.append(gen.choice(pool, size=k, replace=k > len(pool)))
    idx = np.concatenate(picks) if picks else np.zeros(0, np.int64)
    head = pd.DataFrame({"frame": c_frame[idx], id_name: c_id[idx], "x": c_xy[idx, 0], "y": c_xy[idx, 1]})
    return pd.concat([head, nearest_defect(c_frame[idx], c_xy[idx], defects, p, box)], axis=1)


@dataclass
class ProximityResult:
    """T1–defect distances, the random-cell control and their comparison.

    Attributes
    ----------
    events : pandas.DataFrame
        :func:`t1_defect_distances` (rows without a defect in their frame dropped).
    control : pandas.DataFrame
        :func:`random_cell_distances` or :func:`random_vertex_distances` (same).
    ks_statistic, ks_pvalue : float
        Two-sided two-sample Kolmogorov–Smirnov test of ``events.dr`` vs
        ``control.dr`` (NaN when either sample is empty).
    ks_pvalue_closer : float
        One-sided p-value of the alternative "T1s are closer to defects than
        random cells" (the events' distance CDF lies above the control's).
    control_kind : str
        ``"cells"`` or ``"vertices"``: what the control draws.
    """

    events: pd.DataFrame
    control: pd.DataFrame
    ks_statistic: float
    ks_pvalue: float
    ks_pvalue_closer: float
    control_kind: str = "cells"

    def summary(self) -> dict:
        """Key numbers: sample sizes, medians and means of ``dr`` (px) and the KS test."""
        def _stat(fn, x):
            return float(fn(x)) if len(x) else float("nan")

        e, c = self.events["dr"].to_numpy(float), self.control["dr"].to_numpy(float)
        return {"n_events": len(e), "n_control": len(c),
                "median_dr_events": _stat(np.median, e), "median_dr_control": _stat(np.median, c),
                "mean_dr_events": _stat(np.mean, e), "mean_dr_control": _stat(np.mean, c),
                "ks_statistic": self.ks_statistic, "ks_pvalue": self.ks_pvalue,
                "ks_pvalue_closer": self.ks_pvalue_closer}


def t1_defect_proximity(events, cells, defects, p=6, box=None, kinds=("cycle", "intercalation", "unresolved"),
                        n_control=5, seed=0, include_border=False, control="cells", vertices=None) -> ProximityResult:
    """T1–defect distances against a random-cell (or random-vertex) control, with a two-sample KS test (Fig. 3e).

    Parameters
    ----------
    events, cells, defects : pandas.DataFrame
        Events, cells and defects tables of one movie.
    p : int
        Defect order (charges ``±1/p``).
    box : Box, optional
        Periodic box (minimum image).
    kinds : sequence of str
        Event kinds included.
    n_control : int
        Random cells (or vertices) drawn per event, from the event's frame.
    seed : int or numpy.random.Generator
        Seeds the control draw.
    include_border : bool
        Include border events and border cells (open images).
    control : {"cells", "vertices"}
        Draw random cells (the paper's control) or random vertices of degree
        >= 3 from ``vertices`` (:func:`random_vertex_distances`).
    vertices : pandas.DataFrame, optional
        Vertices table; required for ``control="vertices"``.

    Returns
    -------
    ProximityResult
    """
    if control not in ("cells", "vertices"):
        raise InputError(f"control must be 'cells' or 'vertices'; got {control!r}")
    if control == "vertices" and vertices is None:
        raise InputError("control='vertices' needs the vertices table (vertices=...)")
    ev = t1_defect_distances(events, defects, p, box, kinds, include_border)
    ev = ev[ev["defect"] >= 0].reset_index(drop=True)
    draw = random_cell_distances if control == "cells" else random_vertex_distances
    ctrl = draw(cells if control == "cells" else vertices, ev["frame"].to_numpy(np.int64), defects, p, box,
                n_control, seed, include_border)
    ctrl = ctrl[ctrl["defect"] >= 0].reset_index(drop=True)
    return compare_distances(ev, ctrl, control)


def compare_distances(events, control, control_kind="cells") -> ProximityResult:
    """Two-sample KS tests of ``events.dr`` against ``control.dr`` (NaN when either is empty)."""
    if len(events) and len(control):
        from scipy import stats  # here, not at the top: ~18 MB and 0.3 s that every CLI call paid
        with warnings.catch_warnings():
            # scipy's exact p-value can fail on large tied samples; it then falls back to the asymptotic one,
            # which is what such samples call for, and says so in a RuntimeWarning the user cannot act on
            warnings.filterwarnings("ignore", "ks_2samp: Exact calculation unsuccessful", RuntimeWarning)
            two = stats.ks_2samp(events["dr"], control["dr"])
            # alternative="greater": the first sample's CDF lies above the second's, i.e. smaller distances
            one = stats.ks_2samp(events["dr"], control["dr"], alternative="greater")
        values = float(two.statistic), float(two.pvalue), float(one.pvalue)
    else:
        values = (float("nan"),) * 3
    return ProximityResult(events, control, *values, control_kind=control_kind)
