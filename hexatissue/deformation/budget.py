"""The budget of a movie (:func:`deformation_budget`): the terms of each interval and region as the
``deformation`` table's columns.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ..options import T1_SOURCES
from ..schema import DEFORMATION_TERMS, ISOTROPIC_TERMS, empty_table, require_columns
from .interval import _pair
from .movie import _Candidates, _Frames, _Lineage, _runs
from .regions import _Layers, _Membership, _grid_nodes, roi_tracks
from .triangulation import frame_contacts, frame_triangles, triangle_edges


def _columns():
    names = []
    for term in DEFORMATION_TERMS:
        names.extend([f"{term}_xx", f"{term}_xy"] + ([f"{term}_iso"] if term in ISOTROPIC_TERMS else []))
    return names + ["rotation"]


def deformation_budget(cells, vertices, cell_vertices, lineage, t1=None, *, box=None, grid=None, roi=None,
                       roi_frame=0, t1_events="quartets", tolerance=1e-12, progress=None):
    """The tissue's deformation budget between consecutive frames (the triangle method).

    Parameters
    ----------
    cells, vertices, cell_vertices : pandas.DataFrame
        The movie's tables (``cells`` with ``track``).
    lineage : pandas.DataFrame
        ``track``, ``frame_start``, ``parent``, ``end`` (divisions and
        extrusions).
    t1 : pandas.DataFrame, optional
        The ``events`` table (``t1_events="quartets"``) or the
        ``neighbour_events`` table (``"neighbours"``) that names the kind of
        each T1; without it every retriangulation is a ``rearrangement``.
    box : Box, optional
        The periodic box, or None for an open image.
    grid : pandas.DataFrame, optional
        The Gamma_p grid (``frame``, ``node``, ``x``, ``y``): adds a budget per
        grid node (its Voronoi region; a triangle belongs to the node nearest
        its centre).
    roi : (rows, cols) int or bool array, optional
        Regions of interest drawn on frame ``roi_frame`` that follow their
        cells (:func:`roi_tracks`): adds a budget per region.
    t1_events : {"quartets", "neighbours"}
        Whether ``t1`` is the quartet table or the per-cell one.
    tolerance : float
        The closure the quadrature is refined to, relative to the size of the
        terms.
    progress : callable, optional
        ``progress(done, total)`` after each frame pair.

    Returns
    -------
    table : pandas.DataFrame
        ``hexatissue.schema.TABLES["deformation"]``: per frame pair and
        region, each term's ``_xx``, ``_xy`` (shear, 1/frame) and, for the
        terms that change areas, ``_iso`` (1/frame, the rate of log area).
    event_shear : pandas.DataFrame
        ``event``, ``shear_xx``, ``shear_xy``: each T1's share of the T1 terms
        times the tissue's triangulated area (px^2), summed over the frames
        its triangulation changes (forward and, for a cycle, back).
    """
    if t1_events not in T1_SOURCES:
        raise InputError(f"t1_events must be one of {T1_SOURCES}; got {t1_events!r}")
    require_columns(cells, ("frame", "cell", "track", "x", "y"), "cells")
    require_columns(vertices, ("frame", "vertex", "x", "y", "is_border"), "vertices")
    require_columns(cell_vertices, ("frame", "cell", "vertex"), "cell_vertices")
    require_columns(lineage, ("track", "frame_start", "parent", "end"), "lineage")
    frames = _Frames(cells, box)
    members = None
    if roi is not None:
        members = _Membership(roi_tracks(cells, lineage, roi, roi_frame))
        members = (members, int(members.values.max()) + 1 if len(members.values) else 1)
    if grid is not None and len(grid):
        require_columns(grid, ("frame", "node", "x", "y", "row", "col"), "grid")
    layers = _Layers(_grid_nodes(grid) if grid is not None and len(grid) else None, members, box)
    lin = _Lineage(lineage)
    times = sorted(frames.bounds)
    v_rows, cv_rows = _frame_index(vertices), _frame_index(cell_vertices)
    rows, events = [], []
    candidates = _Candidates(t1, t1_events)
    previous, tri_prev = None, None
    K = int(frames.track.max(initial=0)) + 1

    def triangles(t, before, after=None):
        sl = frames.rows(t)
        return frame_triangles(frames.track[sl], frames.xy[sl], frames.cell[sl], _part(vertices, v_rows, t),
                               _part(cell_vertices, cv_rows, t), box, before, frames.interior[sl], K, after)

    # backwards first: the contacts each four-fold vertex or rosette resolves into, for those whose past says
    # nothing (held since the first frame, or formed from other contacts); otherwise resolving into them later
    # would be a retriangulation no event explains
    later, following = {}, None
    for i in range(len(times) - 1, -1, -1):
        if i + 1 < len(times) and times[i + 1] != times[i] + 1:
            following = None
        later[times[i]] = following
        following = triangle_edges(triangles(times[i], following)[0], K)
    contacts_prev = None
    for i, t in enumerate(times):
        tri = triangles(t, previous, later[t])
        previous = triangle_edges(tri[0], K)
        sl = frames.rows(t)
        contacts = frame_contacts(frames.track[sl], frames.cell[sl], _part(cell_vertices, cv_rows, t), K)
        if tri_prev is not None and t == times[i - 1] + 1:
            blocks, ev, info = _pair(frames, lin, layers, t - 1, tri_prev, tri, candidates, tolerance, K,
                                     (contacts_prev, contacts))
            rows.append(_rows(t - 1, blocks, layers, info))
            events.extend(ev)
        tri_prev, contacts_prev = tri, contacts
        if progress is not None:
            progress(i + 1, len(times))
    table = _table(rows)
    ids, sxx, sxy = (np.array(v, dtype) for v, dtype in zip(zip(*events) if events else ((), (), ()),
                                                            (np.int64, float, float)))
    shear = pd.DataFrame({"event": ids, "shear_xx": sxx, "shear_xy": sxy}).groupby("event", as_index=False).sum()
    return table, shear


def _frame_index(table):
    frame = table["frame"].to_numpy(np.int64)
    order = np.argsort(frame, kind="stable")
    return order, {int(f): (a, b) for f, a, b in _runs(frame[order])}


def _part(table, index, t):
    order, bounds = index
    a, b = bounds.get(t, (0, 0))
    return table.iloc[order[a:b]]


def _rows(t, blocks, layers, info):
    """The interval's rows, as per-layer dicts of numpy columns (one DataFrame is made at the end)."""
    names = _columns()
    parts = []
    for i, (layer, block) in enumerate(zip(layers.names(), blocks)):
        present = info["complete"][i]
        n = int(present.sum())
        if layer == "grid":
            region_id = layers.grid[t][0]
        else:
            region_id = np.arange(block.shape[1]) if layer == "roi" else np.full(block.shape[1], -1)
        columns = {"frame": np.full(n, t, np.int64), "region": np.full(n, layer, object),
                   "region_id": region_id[present].astype(np.int64), "area": info["area"][i][present]}
        columns.update(zip(names, block[:, present]))
        columns["n_triangles"] = np.full(n, info["n_triangles"] if layer == "tissue" else -1, np.int64)
        columns["n_flipped"] = np.full(n, info["n_flipped"] if layer == "tissue" else -1, np.int64)
        parts.append(columns)
    return parts


def _table(rows):
    """The ``deformation`` table from the intervals' column dicts."""
    parts = [part for interval in rows for part in interval]
    if not parts:
        return empty_table("deformation")
    table = pd.DataFrame({name: np.concatenate([p[name] for p in parts]) for name in parts[0]})
    table["region"] = table["region"].astype("string")
    return table
