"""Polygon geometry shared by the mesh, the order and the surface stages, and bilinear sampling of an image.

Polygons are stored back to back: one ``(M, 2)`` array of vertices (x, y)
plus the index of each polygon's first vertex (``starts``, ascending).  Each
polygon is contiguous (unwrapped in a periodic box) and not closed (the last
vertex is not repeated).  x = column, y = row, px, origin at the centre of
pixel (0, 0).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ._components import components
from .errors import InputError

__all__ = ["match_points", "segment_sum", "pack_polygons", "next_vertex", "polygon_area_centroid", "polygon_perimeter",
           "polygon_shape_tensor",
           "polygon_cells", "table_polygons", "bilinear", "mesh_order_polygons", "row_keys", "lookup", "distinct_count",
           "node_frames"]


def segment_sum(values, starts, n):
    """Sum of ``values`` over the consecutive segments beginning at ``starts`` (empty segments give 0)."""
    out = np.zeros((n,) + values.shape[1:], dtype=values.dtype)
    if n == 0 or len(values) == 0:
        return out
    nonempty = np.r_[starts[1:], len(values)] > starts
    if nonempty.any():
        out[nonempty] = np.add.reduceat(values, starts[nonempty], axis=0)
    return out


def bilinear(image, x, y, periodic=False):
    """``image`` at positions (x = column, y = row, px), by bilinear interpolation.

    Positions beyond the pixel centres are wrapped on a torus (``periodic``)
    and clamped on an open image (the nearest edge pixels' values).  Exact
    for an image linear in x and y.
    """
    rows, cols = image.shape
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    x1, y1 = x0 + 1, y0 + 1
    if periodic:
        x0, x1, y0, y1 = x0 % cols, x1 % cols, y0 % rows, y1 % rows
    else:
        x0, x1 = np.clip(x0, 0, cols - 1), np.clip(x1, 0, cols - 1)
        y0, y1 = np.clip(y0, 0, rows - 1), np.clip(y1, 0, rows - 1)
    top = image[y0, x0] * (1 - fx) + image[y0, x1] * fx
    bottom = image[y1, x0] * (1 - fx) + image[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


def pack_polygons(polygons, name="polygons"):
    """``(xy, starts)`` from a sequence of ``(n_i, 2)`` vertex arrays; a repeated closing vertex is dropped."""
    arrays = []
    for k, poly in enumerate(polygons):
        a = np.asarray(poly, dtype=float)
        if a.ndim != 2 or a.shape[1] != 2:
            raise InputError(f"{name}[{k}] must be an (n, 2) array of (x, y) vertices; got shape {a.shape}")
        arrays.append(a[:-1] if len(a) > 1 and np.array_equal(a[0], a[-1]) else a)
    if not arrays:
        return np.zeros((0, 2)), np.zeros(0, np.int64)
    lengths = np.array([len(a) for a in arrays], np.int64)
    return np.concatenate(arrays), (np.cumsum(lengths) - lengths).astype(np.int64)


def next_vertex(n_vertices, starts):
    """Index of each vertex's successor around its polygon (the last one wraps to the first)."""
    lengths = np.diff(np.r_[starts, n_vertices])
    nxt = np.arange(n_vertices) + 1
    closing = (starts + lengths)[lengths > 0] - 1
    nxt[closing] = starts[lengths > 0]
    return nxt


def polygon_area_centroid(xy, starts):
    """Signed shoelace area and area centroid of polygons stored back to back.

    Returns
    -------
    area : (N,) array
        Signed area, px^2 (positive = counter-clockwise in x, y).
    centroid : (N, 2) array
        Area centroid (x, y), px; NaN for polygons of zero area.
    """
    n = len(starts)
    nxt = next_vertex(len(xy), starts)
    x0, y0 = xy[:, 0], xy[:, 1]
    x1, y1 = xy[nxt, 0], xy[nxt, 1]
    cross = x0 * y1 - x1 * y0
    area = 0.5 * segment_sum(cross, starts, n)
    cx = segment_sum((x0 + x1) * cross, starts, n)
    cy = segment_sum((y0 + y1) * cross, starts, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = np.stack([cx, cy], axis=1) / (6.0 * area[:, None])
    return area, centroid


def polygon_shape_tensor(xy, starts):
    """Shape tensor of each polygon stored back to back: its second area moment about its centroid over its area.

    ``S = (1/A) * integral over the polygon of (r - c)(r - c)^T dA``, with
    ``c`` the area centroid: a square of side ``a`` has ``S = a^2/12 * I``,
    an ellipse of half-axes ``a``, ``b`` along x, y ``diag(a^2, b^2) / 4``.
    Exact for the polygon (Green's theorem over its edges), whatever its
    orientation.

    Returns
    -------
    (N, 3) float array
        ``S_xx``, ``S_xy``, ``S_yy``, px^2 (x = column, y = row); NaN for
        polygons of zero area (fewer than 3 vertices).
    """
    n = len(starts)
    area, centroid = polygon_area_centroid(xy, starts)
    lengths = np.diff(np.r_[starts, len(xy)])
    owner = np.repeat(np.arange(n), lengths)
    with np.errstate(invalid="ignore"):
        local = xy - centroid[owner]  # about the centroid: no cancellation of large terms
    nxt = next_vertex(len(xy), starts)
    x0, y0 = local[:, 0], local[:, 1]
    x1, y1 = local[nxt, 0], local[nxt, 1]
    cross = x0 * y1 - x1 * y0
    ixx = segment_sum(cross * (x0 * x0 + x0 * x1 + x1 * x1), starts, n) / 12.0
    iyy = segment_sum(cross * (y0 * y0 + y0 * y1 + y1 * y1), starts, n) / 12.0
    ixy = segment_sum(cross * (2 * x0 * y0 + x0 * y1 + x1 * y0 + 2 * x1 * y1), starts, n) / 24.0
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.stack([ixx, ixy, iyy], axis=1) / area[:, None]  # the signed area undoes the orientation
    out[area == 0] = np.nan
    return out


def polygon_perimeter(xy, starts):
    """Perimeter of each polygon stored back to back, px."""
    nxt = next_vertex(len(xy), starts)
    return segment_sum(np.hypot(*(xy[nxt] - xy).T), starts, len(starts))


def polygon_cells(ids, xy, starts):
    """The geometric columns of a cells table for cells known only by their polygons.

    Parameters
    ----------
    ids : (N,) int array
        Cell ids, one per polygon.
    xy, starts : arrays
        Polygons back to back (x = column, y = row, px).

    Returns
    -------
    pandas.DataFrame
        ``cell``; ``x``, ``y``: the polygon's area centroid (px); ``area`` and
        ``polygon_area``: both the polygon's area (px^2: there are no pixels);
        ``perimeter`` (px); ``n_sides``: vertices of the polygon;
        ``n_boundaries``: 1 (one polygon per cell).
    """
    area, centroid = polygon_area_centroid(xy, starts)
    n = len(starts)
    return pd.DataFrame({"cell": np.asarray(ids, np.int64), "x": centroid[:, 0], "y": centroid[:, 1],
                         "area": np.abs(area), "polygon_area": np.abs(area),
                         "perimeter": polygon_perimeter(xy, starts),
                         "n_sides": np.diff(np.r_[starts, len(xy)]).astype(np.int64),
                         "n_boundaries": np.ones(n, np.int64)})


def table_polygons(vertices, cell_vertices, box=None):
    """Every cell polygon of a network's tables, back to back.

    Parameters
    ----------
    vertices : pandas.DataFrame
        ``frame``, ``vertex``, ``x``, ``y`` (px; x = column, y = row).
    cell_vertices : pandas.DataFrame
        ``frame``, ``cell``, ``rank``, ``vertex``.
    box : Box, optional
        Periodic box: each polygon is made contiguous, from the periodic
        images the mesh recorded (``image_x``, ``image_y``) or else by
        minimum-image steps from its first vertex; coordinates may then
        leave ``[0, L)``.

    Returns
    -------
    keys : pandas.DataFrame
        ``frame``, ``cell`` of each polygon, in (frame, cell) order.
    xy : (M, 2) float array
        Vertices (x, y), px, polygon after polygon, in rank order.
    starts : (N,) int array
        First row in ``xy`` of each polygon.
    """
    cv = cell_vertices if _sorted_polygons(cell_vertices) else cell_vertices.sort_values(["frame", "cell", "rank"],
                                                                                          kind="stable")
    frame, cell = cv["frame"].to_numpy(np.int64), cv["cell"].to_numpy(np.int64)
    vkey = row_keys(vertices["frame"].to_numpy(np.int64), vertices["vertex"].to_numpy(np.int64))
    xy = lookup(vkey, _columns(vertices, "x", "y"), row_keys(frame, cv["vertex"].to_numpy(np.int64)),
                "cell_vertices names a vertex missing from the vertices table")
    first = np.r_[True, (frame[1:] != frame[:-1]) | (cell[1:] != cell[:-1])] if len(cv) else np.zeros(0, bool)
    starts = np.flatnonzero(first).astype(np.int64)
    if box is not None and len(xy) and {"image_x", "image_y"} <= set(cv.columns):
        xy = _with_images(xy, cv, box)
    elif box is not None and len(xy):  # tables without images: unwrap by minimum-image steps (junctions < L/2)
        step = box.min_image(np.diff(xy, axis=0))
        step = np.vstack([np.zeros((1, 2)), step])
        step[starts] = 0.0
        cum = np.cumsum(step, axis=0)
        owner = np.cumsum(first) - 1
        xy = xy[starts][owner] + cum - cum[starts][owner]
    keys = pd.DataFrame({"frame": frame[starts], "cell": cell[starts]})
    return keys, xy, starts


def _with_images(xy, cell_vertices, box):
    """Polygon vertices ``xy`` moved to the periodic image the mesh recorded for each (exact for any junction length)."""
    return xy + _columns(cell_vertices, "image_x", "image_y") * box.lengths


def mesh_order_polygons(cells, vertices, cell_vertices, box=None):
    """The polygons of one frame's tables in the row order of :func:`hexatissue.mesh_from_labels`, read without keys.

    In that order the vertices' rows are their ids, and the ``cell_vertices``
    rows hold the polygons of the ``cells`` rows with ``n_sides > 0``, one
    after the other in rank order (the caller knows it:
    :meth:`hexatissue.Frame.mesh_polygons`); the vertices are those
    :func:`table_polygons` reads back through the keys.

    Returns
    -------
    (xy, starts) or None
        Vertices (x, y), px, polygon after polygon, and the first row in
        ``xy`` of the polygon of each ``cells`` row with ``n_sides > 0``;
        None when the ``n_sides`` do not add up to the ``cell_vertices``
        rows (tables edited since).
    """
    sides = cells["n_sides"].to_numpy(np.int64)
    sides = sides[sides > 0]
    if sides.sum() != len(cell_vertices):
        return None
    xy = _columns(vertices, "x", "y")[cell_vertices["vertex"].to_numpy(np.int64)]
    if box is not None and len(xy):
        xy = _with_images(xy, cell_vertices, box)
    return xy, np.cumsum(sides) - sides


def _sorted_polygons(cell_vertices):
    """Whether the rows are in (frame, cell, rank) order already (as the mesh writes them): no sort needed."""
    key = row_keys(cell_vertices["frame"].to_numpy(np.int64), cell_vertices["cell"].to_numpy(np.int64))
    rank = cell_vertices["rank"].to_numpy(np.int64)
    step, same = np.diff(key), np.diff(rank)
    return bool(np.all((step > 0) | ((step == 0) & (same > 0))))


def row_keys(frame, ident):
    """One int64 key per (frame, id) pair, ordered like the pairs (ids below 2**40)."""
    return np.asarray(frame, np.int64) * (1 << 40) + np.asarray(ident, np.int64)


def _columns(table, *names):
    """``table[list(names)].to_numpy(float)`` without pandas' multi-column indexing (~0.5 ms a call)."""
    return np.column_stack([table[name].to_numpy(float) for name in names])


def in_sorted(values, sorted_keys):
    """Which ``values`` are in the sorted array ``sorted_keys`` (binary searches: no sort, no table over the ids)."""
    pos = np.minimum(np.searchsorted(sorted_keys, values), max(len(sorted_keys) - 1, 0))
    return sorted_keys[pos] == values if len(sorted_keys) else np.zeros(len(values), bool)


def distinct_count(ids) -> int:
    """How many distinct integers ``ids`` holds: ``Series.nunique`` without its hash table.

    Ids that are non-negative and not much larger than their number (label
    ids, track ids) are marked in a table of flags (one byte an id); others
    are counted by ``np.unique``.  On the 500,000 cell rows of a 200-frame
    movie ``nunique`` took 8.6 MB, ``np.unique`` 4 MB, the flags 2.5 kB.
    """
    ids = np.asarray(ids)
    if ids.size == 0:
        return 0
    top = int(ids.max())
    if ids.min() >= 0 and top <= 4 * ids.size + 1024:
        seen = np.zeros(top + 1, bool)
        seen[ids] = True
        return int(np.count_nonzero(seen))
    return len(np.unique(ids))


def lookup(keys, values, wanted, missing=None):
    """``values`` at the rows whose key is ``wanted`` (keys unique); rows not found raise (``missing``) or give -1."""
    if len(keys) == 0:
        if missing is not None and len(wanted):
            raise InputError(missing)
        return values[:0] if missing is not None else np.full(len(wanted), -1, np.int64)
    if np.all(keys[1:] > keys[:-1]):  # sorted already (tables in key order): no argsort, no indirect search
        if keys[-1] - keys[0] == len(keys) - 1:  # consecutive (ids 0..n-1 of one frame): the key is the row
            at = np.clip(wanted - keys[0], 0, len(keys) - 1)
        else:
            at = np.minimum(np.searchsorted(keys, wanted), len(keys) - 1)
    else:
        order = np.argsort(keys, kind="stable")
        at = order[np.minimum(np.searchsorted(keys, wanted, sorter=order), len(keys) - 1)]
    found = keys[at] == wanted
    if missing is not None:
        if not found.all():
            raise InputError(missing)
        return values[at]
    return np.where(found, at, -1)


def match_points(a, b, radius, box=None):
    """One-to-one matching of two point sets within ``radius`` px (x = column, y = row).

    The one matcher of the package: defects linked over frames and paired
    into creation / annihilation events (:mod:`hexatissue.defects`), vertices
    of a prediction matched to the truth (:mod:`hexatissue.benchmark.score`).

    The matching has the largest number of pairs closer than ``radius``
    and, among those, the least total distance: candidate pairs are found
    with a KD-tree (minimum-image distances in a periodic ``box``) and each
    cluster of mutually reachable points is solved exactly with
    :func:`scipy.optimize.linear_sum_assignment`.

    Returns
    -------
    (k, 3) array
        Rows ``(index in a, index in b, distance px)``.
    """
    from scipy.optimize import linear_sum_assignment
    from scipy.spatial import cKDTree


    a, b = np.asarray(a, float).reshape(-1, 2), np.asarray(b, float).reshape(-1, 2)
    if not len(a) or not len(b):
        return np.empty((0, 3))
    size = None
    if box is not None:
        a, b, size = box.wrap(a), box.wrap(b), box.lengths
    cand = cKDTree(a, boxsize=size).sparse_distance_matrix(cKDTree(b, boxsize=size), radius, output_type="ndarray")
    if not len(cand):
        return np.empty((0, 3))
    i, j, d = cand["i"], cand["j"], cand["v"]
    na = len(a)
    comp = components(na + len(b), i, na + j)[i]  # the cluster of each candidate pair
    order = np.argsort(comp, kind="stable")
    i, j, d, comp = i[order], j[order], d[order], comp[order]
    starts = np.flatnonzero(np.r_[True, comp[1:] != comp[:-1]])
    ends = np.r_[starts[1:], len(comp)]
    single = ends - starts == 1  # one candidate pair: it is the match
    out = [np.c_[i[starts[single]], j[starts[single]], d[starts[single]]]]
    for s, e in zip(starts[~single], ends[~single]):
        ui, ri = np.unique(i[s:e], return_inverse=True)
        uj, rj = np.unique(j[s:e], return_inverse=True)
        big = radius * (len(ui) + len(uj)) + 1.0  # more than any set of real pairs: maximise their number first
        cost = np.full((len(ui), len(uj)), big)
        cost[ri, rj] = d[s:e]
        r, c = linear_sum_assignment(cost)
        ok = cost[r, c] < big
        out.append(np.c_[ui[r[ok]], uj[c[ok]], cost[r[ok], c[ok]]])
    return np.concatenate(out)


def node_frames(normals):
    """``(e1, e2)`` of unit normals facing +z: ``e1`` the image x axis projected on the tangent plane, normalised
    (the cells' frame, :func:`hexatissue.surface.tangent_polygons`; the grid nodes' on a height map), ``e2 = n x e1``;
    NaN normals give NaN."""
    e1 = np.column_stack([1.0 - normals[:, 0] ** 2, -normals[:, 0] * normals[:, 1], -normals[:, 0] * normals[:, 2]])
    with np.errstate(invalid="ignore", divide="ignore"):
        e1 /= np.linalg.norm(e1, axis=1)[:, None]
    return e1, np.cross(normals, e1)
