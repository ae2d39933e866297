"""Cell polygons -> the junction network: the tables the mesh makes from labels, without a label image.

:func:`polygon_network` turns one frame of polygons (:class:`Polygons`: the
cells' vertices back to back, as the readers of
:mod:`hexatissue.readers.polygons` give them) into the four tables the mesh
makes from labels (``cells``, ``vertices``, ``edges``, ``cell_vertices``;
same schema); :func:`mesh_from_polygons` gives them as a
:class:`~hexatissue.Frame`.  Coordinates are taken as given: x = column, y =
row, px (the files' own origin, no half-pixel shift).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .._components import components
from ..errors import HexatissueWarning, InputError
from ..frame import Frame
from ..geometry import next_vertex, pack_polygons, polygon_area_centroid, polygon_cells
from ..schema import validate

__all__ = ["Polygons", "as_polygons", "SHARED_TOLERANCE", "polygon_network", "mesh_from_polygons", "polygon_shape"]

#: Polygon vertices closer than this (px) are one vertex of the network (shared by the polygons).
SHARED_TOLERANCE = 1e-6

@dataclass(frozen=True, eq=False)
class Polygons:
    """The cell polygons of one frame, back to back, in the file's cell order.

    Attributes
    ----------
    cell : (N,) int64 array
        Cell ids (positive, distinct).
    xy : (M, 2) float array
        Vertices (x = column, y = row, px), polygon after polygon, not closed.
    starts : (N,) int64 array
        First row in ``xy`` of each polygon.
    """

    cell: np.ndarray
    xy: np.ndarray
    starts: np.ndarray

    def __len__(self):
        return len(self.cell)


def as_polygons(polygons, name="polygons") -> Polygons:
    """:class:`Polygons` from ``{cell: (n, 2) array}`` or a sequence of arrays (cells numbered from 1)."""
    if isinstance(polygons, Polygons):
        return polygons
    if isinstance(polygons, dict):
        ids, polys = list(polygons), list(polygons.values())
    else:
        polys = list(polygons)
        ids = list(range(1, len(polys) + 1))
    xy, starts = pack_polygons(polys, name)
    return Polygons(np.asarray(ids, np.int64), xy, starts)


# ---------------------------------------------------------------------------------------------------------
# polygons -> network tables
# ---------------------------------------------------------------------------------------------------------
def polygon_network(polygons, frame=0, tolerance=SHARED_TOLERANCE, where="") -> dict:
    """The junction network of cell polygons: the tables :func:`hexatissue.mesh_from_labels` makes.

    Polygon vertices closer than ``tolerance`` are one network vertex (at
    their mean position); a polygon side used by two polygons is the
    junction between them, a side used by one only is a junction with the
    outside (cell 0), so its cell and vertices are on the border.  Every
    polygon vertex is a network vertex and every side an edge (a vertex
    shared by two cells only has degree 2).  Polygons are made
    counter-clockwise in (x, y); repeated consecutive vertices are dropped.

    Parameters
    ----------
    polygons : Polygons, dict or sequence
        One frame of polygons (see :func:`as_polygons`); x = column, y = row, px.
    frame : int
        Frame number written in every table.
    tolerance : float
        Distance (px) within which vertices are shared.  A vertex of one
        polygon lying on a side of another without being its vertex is not
        detected (that side stays a border side of both).
    where : str
        Where the polygons come from, for error messages.

    Returns
    -------
    dict of pandas.DataFrame
        ``cells``: ``frame``, ``cell``, ``x``, ``y`` (area centroid of the
        polygon, px), ``area`` and ``polygon_area`` (polygon area, px^2),
        ``perimeter`` (px), ``n_sides``, ``n_boundaries`` (1), ``is_border``
        (a side not shared with another polygon), in the input's cell order;
        ``vertices``: ``frame``, ``vertex``, ``x``, ``y`` (px), ``degree``,
        ``is_border``; ``edges``: ``frame``, ``edge``, ``vertex_a``,
        ``vertex_b``, ``cell_a`` < ``cell_b`` (0 = outside), ``length`` (px);
        ``cell_vertices``: ``frame``, ``cell``, ``rank`` (counter-clockwise),
        ``vertex``, ``image_x``, ``image_y`` (0).

    Raises
    ------
    InputError
        Ids not positive or repeated, coordinates not finite, a polygon with
        fewer than 3 distinct vertices, of zero area, passing through one
        vertex twice or crossing itself.

    Warns
    -----
    HexatissueWarning
        Polygons that overlap along a side (a side used by three polygons, or
        by two on the same side of it: digitisation errors occur in published
        polygon data); such a side is a junction between the first two cells
        using it.
    """
    polys = as_polygons(polygons)
    at = f" ({where})" if where else ""
    cell, xy = polys.cell, polys.xy
    _check_ids(cell, at)
    owner = _owner(polys)
    bad = ~np.isfinite(xy).all(axis=1)
    if bad.any():
        raise InputError(f"polygon of cell {cell[owner[bad][0]]}{at} has a NaN or infinite vertex; expected finite "
                         f"x, y (px)")
    vid, position = _shared_vertices(xy, tolerance)
    keep = vid != vid[next_vertex(len(xy), polys.starts)]  # drops repeats, including a closing vertex
    vid, owner = vid[keep], owner[keep]
    lengths = np.bincount(owner, minlength=len(cell))
    starts = (np.cumsum(lengths) - lengths).astype(np.int64)
    _check_polygons(cell, vid, owner, lengths, at)
    _check_simple(cell, position[vid], starts, lengths, at)
    area, _ = polygon_area_centroid(position[vid], starts)
    flat = np.abs(area) <= 1e-12 * np.maximum(1.0, _extent(position) ** 2)
    if flat.any():
        raise InputError(f"polygon of cell {cell[np.flatnonzero(flat)[0]]}{at} has zero area (its vertices are "
                         f"collinear); expected a closed polygon enclosing the cell")
    vid = _counter_clockwise(vid, starts, lengths, area < 0)
    cells, vertices, edges, cell_vertices = _tables(cell, vid, owner, starts, position)
    out = {}
    for name, table in (("cells", cells), ("vertices", vertices), ("edges", edges), ("cell_vertices", cell_vertices)):
        table.insert(0, "frame", np.full(len(table), frame, dtype=np.int64))
        out[name] = validate(table, name)
    return out


def mesh_from_polygons(polygons, tolerance=SHARED_TOLERANCE, frame=0):
    """The junction network of cell polygons as a :class:`~hexatissue.Frame` (see :func:`polygon_network`).

    Parameters
    ----------
    polygons : Polygons, dict or sequence
        ``{cell: (n, 2) array of (x, y)}`` or a sequence (cells numbered from
        1); x = column, y = row, px.  A repeated closing vertex is dropped.
    tolerance : float
        Vertices closer than this (px) are shared.
    frame : int
        Frame number of the tables.

    Returns
    -------
    Frame
        ``cells``, ``vertices``, ``edges``, ``cell_vertices`` as
        :func:`polygon_network` describes; shape from the largest
        coordinates, open image (no box).
    """

    polys = as_polygons(polygons)
    return Frame(**polygon_network(polys, frame, tolerance), frame=frame, shape=polygon_shape([polys]))


def polygon_shape(frames) -> tuple:
    """``(rows, cols)`` of the image the polygons lie in: the pixels holding their largest y and x (at least 1)."""
    top = np.zeros(2)
    for polys in frames:
        if len(polys.xy):
            top = np.maximum(top, np.floor(polys.xy.max(axis=0) + 0.5) + 1)
    return int(max(top[1], 1)), int(max(top[0], 1))


def _owner(polys):
    return np.repeat(np.arange(len(polys.cell)), np.diff(np.r_[polys.starts, len(polys.xy)]))


def _extent(position):
    return float(np.ptp(position, axis=0).max()) if len(position) else 1.0


def _check_ids(cell, at):
    if (cell <= 0).any():
        raise InputError(f"cell ids{at} must be positive (0 is the outside); got {int(cell[cell <= 0][0])}")
    ids, counts = np.unique(cell, return_counts=True)
    if (counts > 1).any():
        raise InputError(f"cell ids{at} must be distinct within a frame (one polygon per cell); cell "
                         f"{int(ids[counts > 1][0])} has {int(counts.max())} polygons")


def _shared_vertices(xy, tolerance):
    """Network vertex of every polygon vertex (numbered in order of first appearance) and their positions."""
    from scipy.spatial import cKDTree


    if isinstance(tolerance, (bool, np.bool_)) or not np.isscalar(tolerance) or not tolerance >= 0:
        raise InputError(f"tolerance must be a distance >= 0 in px; got {tolerance!r}")
    points, group = np.unique(xy, axis=0, return_inverse=True)
    group = group.ravel()
    merged = np.arange(len(points))
    if tolerance > 0 and len(points) > 1:
        pairs = cKDTree(points).query_pairs(tolerance, output_type="ndarray")
        merged = components(len(points), pairs[:, 0], pairs[:, 1])
    group = merged[group]
    # renumber by first appearance, so vertex ids follow the file
    n = int(merged.max()) + 1 if len(merged) else 0
    first = np.full(n, len(group))
    np.minimum.at(first, group, np.arange(len(group)))
    rank = np.empty(n, np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(n)
    # a vertex sits at the mean of its distinct points: exactly the shared point when sharing is exact
    owner = rank[merged]
    count = np.bincount(owner, minlength=n)
    position = np.stack([np.bincount(owner, points[:, k], minlength=n) for k in (0, 1)], axis=1)
    return rank[group], position / np.maximum(count, 1)[:, None]


def _check_simple(cell, xy, starts, lengths, at):
    """Refuse a polygon two of whose sides cross (a bow-tie: its shoelace area is not the cell's)."""
    for n in np.unique(lengths[lengths >= 4]):
        polys = np.flatnonzero(lengths == n)
        i, j = np.triu_indices(n, 2)
        keep = ~((i == 0) & (j == n - 1))  # the first and the last side meet at vertex 0
        i, j = i[keep], j[keep]
        base = starts[polys][:, None]
        p, q = xy[base + i], xy[base + (i + 1) % n]
        r, s = xy[base + j], xy[base + (j + 1) % n]

        def turn(a, b, c):
            return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])

        cross = (turn(p, q, r) * turn(p, q, s) < 0) & (turn(r, s, p) * turn(r, s, q) < 0)
        if cross.any():
            k, m = np.argwhere(cross)[0]
            raise InputError(f"polygon of cell {cell[polys[k]]}{at} crosses itself (its sides {i[m]} and {j[m]}, "
                             f"counted from its first vertex); expected a simple polygon, its vertices in order "
                             f"around the cell")


def _check_polygons(cell, vid, owner, lengths, at):
    few = lengths < 3
    if few.any():
        raise InputError(f"polygon of cell {cell[np.flatnonzero(few)[0]]}{at} has {lengths[few][0]} distinct "
                         f"vertices; expected a closed polygon of at least 3")
    pairs = pd.DataFrame({"owner": owner, "vid": vid})
    twice = pairs.duplicated()
    if twice.any():
        raise InputError(f"polygon of cell {cell[owner[twice.to_numpy()][0]]}{at} passes through one vertex twice "
                         f"(it touches or crosses itself); expected a simple polygon")


def _counter_clockwise(vid, starts, lengths, reverse):
    """Polygons reversed where ``reverse`` (counter-clockwise in x, y: positive shoelace area)."""
    if not reverse.any():
        return vid
    index = np.arange(len(vid))
    rows = np.repeat(reverse, lengths)
    begin = np.repeat(starts, lengths)
    end = np.repeat(starts + lengths - 1, lengths)
    index[rows] = (begin + end - index)[rows]
    return vid[index]


def _tables(cell, vid, owner, starts, position):
    """The four network tables of polygons given as network vertex ids (counter-clockwise)."""
    nxt = next_vertex(len(vid), starts)
    u, v = vid, vid[nxt]
    n_vertices = len(position)
    key = np.minimum(u, v) * n_vertices + np.maximum(u, v)
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    begin = np.flatnonzero(np.r_[True, sorted_key[1:] != sorted_key[:-1]])
    count = np.diff(np.r_[begin, len(key)])
    first = order[begin]
    second = np.where(count >= 2, order[np.minimum(begin + 1, len(order) - 1)], -1)
    paired = second >= 0
    overlap = (count > 2) | (paired & (u[first] == u[np.where(paired, second, 0)]))
    if overlap.any():
        k = int(np.flatnonzero(overlap)[0])
        users = sorted(int(c) for c in cell[owner[order[begin[k]:begin[k] + count[k]]]])
        warnings.warn(f"{int(overlap.sum())} polygon side(s) are not shared the way a tiling shares them (by "
                      f"more than two polygons, or by two on the same side of it): the polygons overlap, e.g. cells "
                      f"{users} along {_side(position, u[first[k]], v[first[k]])}; each such side is one junction "
                      f"between the first two cells that use it", HexatissueWarning, stacklevel=2)
    by_file = np.argsort(first, kind="stable")  # edges in order of first appearance
    first, second = first[by_file], second[by_file]
    left = cell[owner[first]]
    right = np.where(second >= 0, cell[owner[np.maximum(second, 0)]], 0)
    a, b = u[first], v[first]
    edges = pd.DataFrame({"edge": np.arange(len(first), dtype=np.int64), "vertex_a": a.astype(np.int64),
                          "vertex_b": b.astype(np.int64), "cell_a": np.minimum(left, right).astype(np.int64),
                          "cell_b": np.maximum(left, right).astype(np.int64),
                          "length": np.hypot(*(position[b] - position[a]).T)})
    outside = edges["cell_a"].to_numpy() == 0
    vborder = np.zeros(n_vertices, bool)
    vborder[a[outside]] = vborder[b[outside]] = True
    degree = np.bincount(a, minlength=n_vertices) + np.bincount(b, minlength=n_vertices)
    vertices = pd.DataFrame({"vertex": np.arange(n_vertices, dtype=np.int64), "x": position[:, 0],
                             "y": position[:, 1], "degree": degree.astype(np.int64), "is_border": vborder})
    border_ids = np.union1d(left[outside], right[outside])
    cells = polygon_cells(cell, position[vid], starts)
    cells["is_border"] = np.isin(cell, border_ids)
    cell_vertices = pd.DataFrame({"cell": cell[owner], "rank": (np.arange(len(vid)) - starts[owner]).astype(np.int64),
                                  "vertex": vid.astype(np.int64), "image_x": np.zeros(len(vid), np.int64),
                                  "image_y": np.zeros(len(vid), np.int64)})
    return cells, vertices, edges, cell_vertices


def _side(position, a, b):
    (x0, y0), (x1, y1) = position[a], position[b]
    return f"({x0:g}, {y0:g})-({x1:g}, {y1:g})"
