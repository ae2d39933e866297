"""The tissue's deformation budget: how much of its shear and growth each kind of cellular process makes.

The triangle method (Merkel et al., Phys. Rev. E 95, 032401, 2017; Etournay et
al., eLife 4, e07090, 2015): the cell centres around every interior vertex of
the junction network form a triangle (a four-fold vertex gives two,
:func:`frame_triangles`), and the area-weighted mean elongation ``Q`` of the
triangles measures the cells' shape.  Between two frames the tissue's
deformation is split exactly into the change of ``Q`` and the part that each
kind of cellular event takes (:func:`deformation_budget`):

1. cells leaving the analysed tissue (field of view, mask) are removed, at the
   positions of the first frame (``border``);
2. extruding cells move to the mean of their neighbours (``extrusion``);
3. the triangles move to the second frame's positions, a mother cell at the
   mean of its daughters: the tissue's total shear and growth, split into
   cell shape change, corotation, the nonlinear corotational term and the two
   correlation terms (:mod:`hexatissue.deformation.flow`);
4. the triangulation changes to the second frame's, daughters still merged:
   each connected retriangulation is an extrusion (it holds an extruding
   cell), a T1 of the ``events`` table (its kind: ``t1_cycle``,
   ``t1_intercalation``, ``t1_unresolved``), a ``resampling`` (no cell
   contact changes: the pixel network resampled, not an event) or another
   ``rearrangement``;
5. daughters split (``division``), then cells entering the tissue are added
   (``border``).

Each topological term is minus the jump of ``Q`` it makes; the total minus
the sum of the parts is the ``closure`` column (zero up to the quadrature's
error).  The order follows TissueMiner's intermediate triangulations.
"""
from __future__ import annotations

import os

import numpy as np
import pandas as pd
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import InputError
from ..geometry import in_sorted
from ..options import T1_SOURCES
from ..schema import DEFORMATION_TERMS, ISOTROPIC_TERMS, empty_table, require_columns
from .flow import integrate_flow
from ._kernels import triangle_shapes
from .triangles import REFERENCE_INVERSE, det2, edge_matrices, inv2

__all__ = ["frame_triangles", "frame_contacts", "deformation_budget", "roi_tracks", "read_roi"]

_T1_KINDS = {"cycle": "t1_cycle", "intercalation": "t1_intercalation", "unresolved": "t1_unresolved"}
# the order in which the retriangulations of step 4 are applied
_STEP4 = ("extrusion", "t1_cycle", "t1_intercalation", "t1_unresolved", "resampling", "rearrangement")


# ----------------------------------------------------------------------------
# Triangulations
# ----------------------------------------------------------------------------

def _min_image(d, box):
    return d if box is None else box.min_image(d)


def _orient(ids, xy):
    """Triangles ``ids`` (m, 3) with corners ``xy`` (m, 3, 2) made counter-clockwise in (x, y)."""
    R = edge_matrices(xy)
    clockwise = R[:, 0, 0] * R[:, 1, 1] - R[:, 0, 1] * R[:, 1, 0] < 0
    ids[clockwise] = ids[clockwise][:, [0, 2, 1]]
    xy[clockwise] = xy[clockwise][:, [0, 2, 1]]
    return ids, xy


def pair_keys(a, b, K):
    """One int64 per unordered cell pair ``(a, b)``: ``min * K + max`` (``K`` above every id)."""
    return np.minimum(a, b) * np.int64(K) + np.maximum(a, b)


def triangle_edges(ids, K):
    """The sorted keys (:func:`pair_keys`) of the cell pairs joined by the triangles ``ids`` (m, 3)."""
    return _sorted_unique(np.concatenate([pair_keys(ids[:, 0], ids[:, 1], K), pair_keys(ids[:, 1], ids[:, 2], K),
                                          pair_keys(ids[:, 0], ids[:, 2], K)]))


def _sorted_unique(values):
    """``np.unique`` of an int array by one sort (numpy's hash-based unique is slower on these sizes)."""
    v = np.sort(values)
    return v[np.r_[True, v[1:] != v[:-1]]] if len(v) else v


def _first_of_each(keys):
    """Indices of the first occurrence of each distinct key, in row order."""
    order = np.argsort(keys, kind="stable")
    k = keys[order]
    return np.sort(order[np.r_[True, k[1:] != k[:-1]]]) if len(k) else order


def _rings(rows, centre, track, xy, box):
    """Rings of ``k`` cells around vertices (``rows`` (n, k), ``centre`` (n, 2)) in angular order: ids, positions."""
    d = _min_image(xy[rows] - centre[:, None, :], box)
    order = np.argsort(np.arctan2(d[..., 1], d[..., 0]), axis=1, kind="stable")
    ids = np.take_along_axis(track[rows], order, axis=1)
    pos = np.take_along_axis(d, order[..., None], axis=1) + centre[:, None, :]
    return ids, pos


def _fans(ids, pos, previous, K, following=None):
    """Triangles (index triples into each ring) of rings of four or more cells, all of one size.

    A ring's triangulation is the fan (from one of its cells) with the most
    diagonals the previous frame's triangulation had (``previous``: its
    sorted pair keys), so a held four-fold vertex or rosette changes nothing
    and its T1 counts once, when the new contact forms (or never, when it
    reverts).  A ring the previous frame says nothing about (it is one from
    the first frame, or it has just formed from other contacts) takes the
    fan with the most diagonals of ``following`` (the triangulation it
    resolves into later, when given), else, for four cells, the shorter
    diagonal, and for more, the fan from the smallest id.
    """
    n, k = ids.shape
    # the fan from start s: triangles (s, s + j, s + j + 1), j = 1 .. k - 2; its diagonals (s, s + j), j = 2 .. k - 2
    diag = (np.arange(k)[:, None] + np.arange(2, k - 1)[None, :]) % k  # (k, k - 3)

    def votes(keys):
        if keys is None or len(keys) == 0:
            return np.zeros((n, k))
        a = np.broadcast_to(ids[:, :, None], (n, k, k - 3))
        b = ids[:, diag]
        return in_sorted(pair_keys(a.ravel(), b.ravel(), K), keys).reshape(n, k, k - 3).sum(axis=2)

    score = votes(previous)
    informed = score.max(axis=1) > score.min(axis=1)
    score = score + np.where(informed[:, None], 0, votes(following))
    if k == 4:  # both diagonals equally supported: the shorter one (starts 1 and 3 have the 1-3 diagonal)
        shorter13 = np.hypot(*(pos[:, 1] - pos[:, 3]).T) < np.hypot(*(pos[:, 0] - pos[:, 2]).T)
        tie = np.where(shorter13[:, None], [0.0, 1.0, 0.0, 1.0], [1.0, 0.0, 1.0, 0.0])
    else:  # the fan from the smallest id
        tie = (np.arange(k)[None, :] == np.argmin(ids, axis=1)[:, None]).astype(float)
    first = np.argmax(score * 2 + tie, axis=1)[:, None]
    step = np.arange(1, k - 1)[None, :]
    fan = np.stack([np.broadcast_to(first, (n, k - 2)), (first + step) % k, (first + step + 1) % k], axis=2)
    rows = np.arange(n)[:, None, None]
    return ids[rows, fan].reshape(-1, 3), pos[rows, fan].reshape(-1, 3, 2)


def frame_triangles(track, xy, cell, vertices, cell_vertices, box=None, previous=None, interior=None, K=None,
                    following=None):
    """The triangles of cell centres dual to one frame's interior vertices.

    Only vertices whose cells are all interior cells count: a border cell's
    centre is cut by the image edge or the background, so it does not move
    with the tissue.

    Parameters
    ----------
    track, xy, cell : arrays
        The frame's cells: track id, centre (x, y, px) and label id, aligned.
    vertices : pandas.DataFrame
        The frame's ``vertex``, ``x``, ``y``, ``is_border``.
    cell_vertices : pandas.DataFrame
        The frame's ``cell``, ``vertex``.
    box : Box, optional
        The periodic box (minimum-image geometry), or None.
    previous : int64 array, optional
        The sorted keys of the cell pairs joined in the previous frame's
        triangulation (:func:`triangle_edges`): a four-fold vertex takes the
        diagonal found there.
    interior : array of bool, optional
        Aligned with ``track``: the cells that are not border cells (all, by
        default).
    K : int, optional
        Above every track id (the pair keys' base; default: this frame's
        largest id + 1).
    following : int64 array, optional
        The sorted pair keys of a later triangulation: a four-fold vertex or
        rosette that ``previous`` says nothing about takes its diagonals
        from there (the contacts it resolves into).

    Returns
    -------
    ids : (m, 3) int64 array
        Track ids of each triangle's corners, counter-clockwise in (x, y).
    tri_xy : (m, 3, 2) float array
        The corners' positions, px, contiguous (a periodic triangle's
        corners are the images nearest its first corner).
    """
    track = np.asarray(track, np.int64)
    K = int(track.max(initial=0)) + 1 if K is None else int(K)
    previous = np.zeros(0, np.int64) if previous is None else previous
    v_ids = vertices["vertex"].to_numpy(np.int64)
    inside = ~vertices["is_border"].to_numpy(bool)
    cv_vertex = cell_vertices["vertex"].to_numpy(np.int64)
    cv_cell = cell_vertices["cell"].to_numpy(np.int64)
    order = np.argsort(cell, kind="stable")
    at = np.minimum(np.searchsorted(cell[order], cv_cell), len(cell) - 1)
    known = cell[order][at] == cv_cell
    row = np.where(known, order[at], len(cell))  # len(cell): an unknown cell
    v_order = np.argsort(v_ids, kind="stable")
    vat = np.minimum(np.searchsorted(v_ids[v_order], cv_vertex), len(v_ids) - 1)
    vrow = v_order[vat]  # the vertex's row; each (vertex, cell) pair once, grouped by vertex
    pair = _sorted_unique(vrow * np.int64(len(cell) + 1) + row)
    vrow, row = pair // (len(cell) + 1), pair % (len(cell) + 1)
    usable = np.r_[np.ones(len(track), bool) if interior is None else np.asarray(interior, bool), False]
    # a vertex with an unknown or border cell around it, or on the background, makes no triangle
    bad = np.zeros(len(v_ids), bool)
    bad[vrow[~usable[row]]] = True
    bad |= ~inside
    keep = ~bad[vrow]
    vrow, row = vrow[keep], row[keep]
    starts = np.flatnonzero(np.r_[True, vrow[1:] != vrow[:-1]])
    counts = np.diff(np.r_[starts, len(vrow)])
    three = starts[counts == 3]
    rows = np.stack([row[three], row[three + 1], row[three + 2]], axis=1)
    ids_parts, xy_parts = [track[rows]], [xy[rows]]
    xy_parts[0][:, 1:] = xy_parts[0][:, :1] + _min_image(xy_parts[0][:, 1:] - xy_parts[0][:, :1], box)
    vxy = vertices[["x", "y"]].to_numpy(float)
    for k in np.unique(counts[counts > 3]):
        at_k = starts[counts == k]
        ring_rows = row[at_k[:, None] + np.arange(k)[None, :]]
        ring_ids, ring_xy = _rings(ring_rows, vxy[vrow[at_k]], track, xy, box)
        fan_ids, fan_xy = _fans(ring_ids, ring_xy, previous, K, following)
        ids_parts.append(fan_ids)
        xy_parts.append(fan_xy)
    ids, tri_xy = np.concatenate(ids_parts), np.concatenate(xy_parts)
    ids, tri_xy = _orient(ids.astype(np.int64), tri_xy)
    R = edge_matrices(tri_xy)
    flat = R[:, 0, 0] * R[:, 1, 1] - R[:, 0, 1] * R[:, 1, 0] <= 1e-9  # three centres on a line: no shape
    ids, tri_xy = ids[~flat], tri_xy[~flat]
    # two vertices joining the same three cells (cells that share two junctions) give one triangle
    first = _first_of_each(_triple_keys(ids))
    return ids[first], tri_xy[first]


def frame_contacts(track, cell, cell_vertices, K):
    """The cell contacts of one frame as the triangulation sees them: every pair of cells sharing a vertex.

    A junction's two cells share its end vertices, and the cells around a
    four-fold vertex or rosette all share it: a contact held as a four-fold
    vertex (a junction shorter than ``merge_distance``) counts, and so do
    both diagonals of the four-fold vertex, either of which the triangles may
    take.

    Parameters
    ----------
    track, cell : arrays
        The frame's cells: track id and label id, aligned.
    cell_vertices : pandas.DataFrame
        The frame's ``cell``, ``vertex``.
    K : int
        Above every track id (the base of :func:`pair_keys`).

    Returns
    -------
    int64 array
        The sorted keys (:func:`pair_keys`, track ids) of the cell pairs
        that share a vertex.
    """
    track, cell = np.asarray(track, np.int64), np.asarray(cell, np.int64)
    cv_cell = cell_vertices["cell"].to_numpy(np.int64)
    vertex = cell_vertices["vertex"].to_numpy(np.int64)
    if len(cell) == 0 or len(cv_cell) == 0:
        return np.zeros(0, np.int64)
    order = np.argsort(cell, kind="stable")
    at = np.minimum(np.searchsorted(cell[order], cv_cell), len(cell) - 1)
    known = cell[order][at] == cv_cell
    ids, vertex = track[order][at][known], vertex[known]
    by_vertex = np.argsort(vertex, kind="stable")
    ids, vertex = ids[by_vertex], vertex[by_vertex]
    # each row with every later row of its vertex
    later = np.searchsorted(vertex, vertex, "right") - np.arange(len(vertex)) - 1
    first = np.repeat(np.arange(len(vertex)), later)
    second = np.arange(later.sum()) - np.repeat(np.cumsum(later) - later, later) + first + 1
    a, b = ids[first], ids[second]
    keep = a != b
    return _sorted_unique(pair_keys(a[keep], b[keep], K))


def _triple_keys(*tables):
    """One int64 per triangle of each ``(m, 3)`` table, equal for the same three cells in any order."""
    rows = [np.sort(t, axis=1) for t in tables]
    top = max((int(r.max()) for r in rows if r.size), default=0) + 1
    if top < 2 ** 21:  # the ids themselves make the key
        K, ranked = np.int64(top), rows
    else:  # ids ranked: the keys cannot overflow
        values = _sorted_unique(np.concatenate([r.ravel() for r in rows]))
        K, ranked = np.int64(len(values) + 1), [np.searchsorted(values, r) for r in rows]
    out = [(r[:, 0] * K + r[:, 1]) * K + r[:, 2] for r in ranked]
    return out if len(out) > 1 else out[0]


# ----------------------------------------------------------------------------
# States: triangulations with positions and region labels
# ----------------------------------------------------------------------------

class _State:
    """Triangles (ids, contiguous corners) with their shape, and their region labels per layer."""

    def __init__(self, ids, xy, labels, shape=None):
        self.ids, self.xy, self.labels = ids, xy, labels
        self.area, self.qxx, self.qxy = triangle_shapes(xy, REFERENCE_INVERSE) if shape is None else shape

    def take(self, keep):
        return _State(self.ids[keep], self.xy[keep], [lab[keep] for lab in self.labels],
                      (self.area[keep], self.qxx[keep], self.qxy[keep]))

    def sums(self, sizes, weight=None):
        """Per layer ``(4, n_regions)``: sum of area, of area x Q_xx, of area x Q_xy, and the count."""
        w = np.ones(len(self.ids)) if weight is None else weight
        out = []
        for labels, n in zip(self.labels, sizes):
            ok = labels >= 0
            lab = labels[ok]
            a, ww = self.area[ok] * w[ok], w[ok]
            out.append(np.array([np.bincount(lab, a, n), np.bincount(lab, a * self.qxx[ok], n),
                                 np.bincount(lab, a * self.qxy[ok], n), np.bincount(lab, ww, n)]))
        return out


def _means(sums):
    """Mean Q (xx, xy) and log mean area of per-region sums ``(4, n)``."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.array([sums[1] / sums[0], sums[2] / sums[0], np.log(sums[0] / sums[3])])


def _isin_rows(ids, other):
    """Rows of ``ids`` (m, 3) whose cell set is a row of ``other``."""
    if len(ids) == 0 or len(other) == 0:
        return np.zeros(len(ids), bool)
    a, b = _triple_keys(ids, other)
    return np.isin(a, b)


def _components(ids, K):
    """Connected groups of triangles ``ids`` (m, 3) that share an edge: labels (m,)."""
    m = len(ids)
    if m == 0:
        return np.zeros(0, np.int64)
    keys = np.concatenate([pair_keys(ids[:, 0], ids[:, 1], K), pair_keys(ids[:, 1], ids[:, 2], K),
                           pair_keys(ids[:, 0], ids[:, 2], K)])
    _, edge = np.unique(keys, return_inverse=True)
    owner = np.tile(np.arange(m), 3)
    graph = coo_matrix((np.ones(3 * m), (owner, edge.ravel())), shape=(m, edge.max() + 1)).tocsr()
    _, labels = connected_components(graph @ graph.T, directed=False)
    return labels


# ----------------------------------------------------------------------------
# The movie
# ----------------------------------------------------------------------------

class _Frames:
    """The cells' positions per frame, by track (a mother at the mean of its daughters on request)."""

    def __init__(self, cells, box):
        frame = cells["frame"].to_numpy(np.int64)
        order = np.lexsort((cells["track"].to_numpy(np.int64), frame))
        self.frame = frame[order]
        self.track = cells["track"].to_numpy(np.int64)[order]
        self.xy = cells[["x", "y"]].to_numpy(float)[order]
        self.cell = cells["cell"].to_numpy(np.int64)[order]
        border = cells["is_border"].to_numpy(bool) if "is_border" in cells else np.zeros(len(cells), bool)
        self.interior = ~border[order]
        self.bounds = {int(f): (int(a), int(b)) for f, a, b in _runs(self.frame)}
        self.box = box

    def rows(self, t):
        a, b = self.bounds[t]
        return slice(a, b)

    def positions(self, t, ids, merged=None):
        """Positions (k, 2) of tracks ``ids`` at frame ``t``; ``merged`` maps a mother to its daughters' rows."""
        sl = self.rows(t)
        tracks = self.track[sl]
        at = np.searchsorted(tracks, ids)
        at = np.minimum(at, len(tracks) - 1)
        found = tracks[at] == ids
        out = np.full((len(ids), 2), np.nan)
        out[found] = self.xy[sl][at[found]]
        if merged:
            for i in np.flatnonzero(~found):
                rows = merged.get(int(ids[i]))
                if rows is not None:
                    out[i] = _mean_position(self.xy[sl][rows], self.box)
        return out


def _runs(values):
    starts = np.flatnonzero(np.r_[True, values[1:] != values[:-1]])
    ends = np.r_[starts[1:], len(values)]
    return zip(values[starts], starts, ends)


def _mean_position(xy, box):
    return xy[0] + _min_image(xy - xy[0], box).mean(axis=0)


def _corners(ids, pos, box):
    """Contiguous corners (m, 3, 2) of triangles ``ids`` from positions ``pos`` (m, 3, 2)."""
    xy = pos.copy()
    xy[:, 1:] = xy[:, :1] + _min_image(xy[:, 1:] - xy[:, :1], box)
    return xy


def _lookup(ids, keys):
    """Positions of ``ids`` in the sorted ``keys``, and whether each was found there."""
    at = np.minimum(np.searchsorted(keys, ids), len(keys) - 1)
    return at, keys[at] == ids


class _Layers:
    """How triangles are assigned to regions: the whole tissue, the grid nodes, the user's regions."""

    def __init__(self, grid, roi, box):
        self.grid, self.roi, self.box = grid, roi, box

    def names(self):
        return ["tissue"] + (["grid"] if self.grid is not None else []) + (["roi"] if self.roi is not None else [])

    def sizes(self, t):
        out = [1]
        if self.grid is not None:
            out.append(len(self.grid[t][0]) if t in self.grid else 0)
        if self.roi is not None:
            out.append(self.roi[1])
        return out

    def labels(self, t, ids, xy):
        """Labels per layer of triangles ``ids`` with corners ``xy`` (grid nodes of frame ``t``)."""
        out = [np.zeros(len(ids), np.int64)]
        if self.grid is not None:
            out.append(self._nodes(t, xy))
        if self.roi is not None:
            member = self.roi[0]
            lab = np.stack([member.get_many(ids[:, j]) for j in range(3)], axis=1)
            same = (lab[:, 0] == lab[:, 1]) & (lab[:, 1] == lab[:, 2])
            out.append(np.where(same, lab[:, 0], -1))
        return out

    def _nodes(self, t, xy):
        """The grid node nearest each triangle's centre (its square of the lattice), -1 off the grid."""
        nodes = self.grid.get(t)
        if nodes is None:
            return np.full(len(xy), -1, np.int64)
        origin, step, table = nodes[1:]
        centre = xy.mean(axis=1)
        index = np.rint((centre - origin) / step).astype(np.int64)  # (col, row)
        shape = np.array(table.shape[::-1])
        if self.box is not None:
            index %= shape
        inside = (index >= 0).all(axis=1) & (index < shape).all(axis=1)
        out = np.full(len(xy), -1, np.int64)
        out[inside] = table[index[inside, 1], index[inside, 0]]
        return out


class _Membership:
    """Track -> region label (-1: none), vectorised."""

    def __init__(self, mapping):
        self.keys = np.array(sorted(mapping), np.int64)
        self.values = np.array([mapping[k] for k in self.keys], np.int64)

    def get_many(self, ids):
        if len(self.keys) == 0:
            return np.full(len(ids), -1, np.int64)
        at, found = _lookup(ids, self.keys)
        return np.where(found, self.values[at], -1)


def roi_tracks(cells, lineage, roi, frame=0):
    """The tracks of each region of interest, followed over the movie (daughters inherit their mother's).

    Parameters
    ----------
    cells : pandas.DataFrame
        ``frame``, ``track``, ``x``, ``y``.
    lineage : pandas.DataFrame
        ``track``, ``parent``.
    roi : (rows, cols) int or bool array
        Regions in the pixels of frame ``frame``: label ``k > 0`` is region
        ``k`` (True is region 1); a cell belongs to the region its centre
        falls in.
    frame : int
        The frame the regions are drawn on.

    Returns
    -------
    dict
        ``{track: region}``.
    """
    roi = np.asarray(roi)
    if roi.ndim != 2 or not (np.issubdtype(roi.dtype, np.integer) or roi.dtype == bool):
        raise InputError(f"roi must be a 2-D label image (ints, or a bool mask); got {roi.dtype} of shape {roi.shape}")
    at = cells[cells["frame"].to_numpy() == frame]
    if len(at) == 0:
        raise InputError(f"roi_frame {frame} has no cells; the movie's frames are "
                         f"{int(cells['frame'].min())}..{int(cells['frame'].max())}")
    if roi.dtype != bool and roi.size and roi.min() < 0:
        raise InputError(f"roi has negative labels ({int(roi.min())}); regions are the labels > 0 and 0 is outside "
                         f"every region")
    col = np.clip(np.rint(at["x"].to_numpy(float)).astype(int), 0, roi.shape[1] - 1)
    row = np.clip(np.rint(at["y"].to_numpy(float)).astype(int), 0, roi.shape[0] - 1)
    label = roi[row, col].astype(np.int64)
    members = {int(t): int(k) for t, k in zip(at["track"].to_numpy(np.int64), label) if k > 0}
    if not members:
        raise InputError(f"no cell of frame {frame} has its centre in a region of the roi (labels > 0 at "
                         f"{int(np.count_nonzero(roi))} of its {roi.size} pixels): is it drawn on frame {frame}?")
    # daughters inherit, in birth order (a daughter's mother is born before it)
    if len(lineage):
        parent = lineage.sort_values("frame_start")[["track", "parent"]].to_numpy(np.int64)
        for track, mother in parent:
            if mother > 0 and mother in members and track not in members:
                members[int(track)] = members[int(mother)]
    return members


def read_roi(roi):
    """A region-of-interest image: an array as given, or read from a ``.npy``, TIFF or PNG file."""
    if not isinstance(roi, (str, os.PathLike)):
        return np.asarray(roi)
    path = os.fspath(roi)
    suffix = os.path.splitext(path)[1].lower()
    try:
        if suffix == ".npy":
            return np.load(path)
        if suffix in (".tif", ".tiff"):
            import tifffile

            return tifffile.imread(path)
        if suffix == ".png":
            import cv2

            image = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            if image is None:
                raise OSError("not a readable PNG")
            return image
    except (OSError, ValueError) as exc:
        raise InputError(f"roi {path!r} cannot be read: {exc}") from None
    raise InputError(f"roi must be an array or a .npy, .tif or .png label image; got {path!r}")


def _grid_nodes(grid):
    """Per frame: node ids, the lattice's origin and step (x, y), and a (rows, cols) table of node rows."""
    out = {}
    for f, part in grid.groupby("frame", sort=True):
        xy = part[["x", "y"]].to_numpy(float)
        col, row = part["col"].to_numpy(np.int64), part["row"].to_numpy(np.int64)
        step = np.array([_lattice_step(xy[:, 0], col), _lattice_step(xy[:, 1], row)])
        origin = (xy - np.c_[col, row] * step).mean(axis=0)
        table = np.full((row.max() + 1, col.max() + 1), -1, np.int64)
        table[row, col] = np.arange(len(part))
        out[int(f)] = (part["node"].to_numpy(np.int64), origin, step, table)
    return out


def _lattice_step(position, index):
    span = index.max() - index.min()
    return (position.max() - position.min()) / span if span > 0 else 1.0


class _Lineage:
    """What becomes of each track: its end, its mother, its daughters."""

    def __init__(self, lineage):
        self.end = dict(zip(lineage["track"].to_numpy(np.int64).tolist(), lineage["end"].astype(str).tolist()))
        self.parent = dict(zip(lineage["track"].to_numpy(np.int64).tolist(),
                               lineage["parent"].to_numpy(np.int64).tolist()))


def _step4_kinds(removed, added, dying, candidates, K, contacts):
    """The kind of each connected retriangulation, as shares per kind: (n_components, len(_STEP4)), labels.

    ``contacts``: the sorted pair keys of the cells sharing a vertex before
    and after (:func:`frame_contacts`, daughters merged into their mother).
    A retriangulation with no extruding cell and no T1 of ``candidates``
    whose every triangle edge is a contact on both sides changes no contact:
    a ``resampling``; else a ``rearrangement``.
    """
    both = np.concatenate([removed, added])
    labels = _components(both, K)
    n = labels.max() + 1 if len(labels) else 0
    share = np.zeros((n, len(_STEP4)))
    matched = [[] for _ in range(n)]
    if n == 0:
        return share, labels, matched
    edges = np.concatenate([pair_keys(both[:, i], both[:, j], K) for i, j in ((0, 1), (1, 2), (0, 2))])
    flips = in_sorted(edges, contacts[0]) != in_sorted(edges, contacts[1])
    contact_changes = np.bincount(np.tile(labels, 3), flips, n) > 0
    ids_of = [set() for _ in range(n)]
    for lab, row in zip(labels, both):
        ids_of[lab].update(row.tolist())
    for c in range(n):
        if ids_of[c] & dying:
            share[c, 0] = 1.0
            continue
        hits = [(event, kind) for event, kind, quartet in candidates if quartet <= ids_of[c]]
        if hits:
            for event, kind in hits:
                share[c, _STEP4.index(kind)] += 1.0 / len(hits)
            matched[c] = [event for event, _ in hits]
        else:
            share[c, _STEP4.index("rearrangement" if contact_changes[c] else "resampling")] = 1.0
    return share, labels, matched


class _Candidates:
    """The T1s whose triangulation may change into a frame: (event id, term, set of tracks), by frame."""

    def __init__(self, t1, source):
        self.by_frame = {}
        if t1 is None or len(t1) == 0:
            return
        if source == "quartets":
            frames = [c for c in ("frame_start", "frame_gain", "frame_undo", "frame_end") if c in t1]
            cells = t1[["cell_a", "cell_b", "cell_c", "cell_d"]].to_numpy(np.int64)
        else:
            frames = ["frame_start", "frame_end"]
            cells = t1[["track"]].to_numpy(np.int64)
        events, kinds = t1["event"].to_numpy(np.int64), t1["kind"].astype(str).to_numpy()
        when = t1[frames].to_numpy(float)
        for e, k, c, f in zip(events.tolist(), kinds, cells.tolist(), when.tolist()):
            entry = (e, _T1_KINDS.get(k, "t1_unresolved"), set(c))
            for frame in {v for v in f if v == v}:  # its distinct frames, NaN left out
                self.by_frame.setdefault(int(frame), []).append(entry)

    def at(self, frame):
        return self.by_frame.get(frame, [])


def _pair(frames, lineage, layers, t, tri_t, tri_next, t1, tolerance, K, contacts):
    """The budget of the interval ``t`` -> ``t + 1``: per layer a (terms, n_regions) block, and per-event shares.

    ``contacts``: the two frames' :func:`frame_contacts`.
    """
    box = frames.box
    t_next = t + 1
    # the analysed tissue: the interior cells (a cell turning into a border cell leaves it)
    now = frames.track[frames.rows(t)][frames.interior[frames.rows(t)]]
    nxt = frames.track[frames.rows(t_next)][frames.interior[frames.rows(t_next)]]
    lost = np.setdiff1d(now, nxt)
    new = np.setdiff1d(nxt, now)
    mothers = {}
    for d in new.tolist():
        m = lineage.parent.get(d, 0)
        if m > 0 and m in set(lost.tolist()):
            mothers.setdefault(m, []).append(d)
    dying = {int(c) for c in lost.tolist() if lineage.end.get(int(c)) == "extrusion"}
    leaving = set(lost.tolist()) - dying - set(mothers)
    entering = set(new.tolist()) - {d for ds in mothers.values() for d in ds}
    sl_next = frames.rows(t_next)
    merged = {m: np.searchsorted(frames.track[sl_next], np.array(ds, np.int64)) for m, ds in mothers.items()}
    sizes = layers.sizes(t)

    ids0, xy0 = tri_t
    s0 = _State(ids0, xy0, layers.labels(t, ids0, xy0))
    sums = s0.sums(sizes)
    chain = [("start", sums)]
    # 1. cells leaving the tissue
    keep = ~np.isin(ids0, np.array(sorted(leaving), np.int64)).any(axis=1)
    s1 = s0.take(keep)
    chain.append(("border", s1.sums(sizes)))
    # 2. extruding cells to the mean of their neighbours (in this frame and the next), or out when they have none
    ghost_now, ghost_next = {}, {}
    for c in sorted(dying):
        rows = (s1.ids == c).any(axis=1)
        ring = np.setdiff1d(s1.ids[rows].ravel(), np.array(sorted(dying), np.int64))
        if len(ring) < 3:  # at the mean of two neighbours the ghost's triangles would be flat
            continue
        p_now = frames.positions(t, ring)
        p_next = frames.positions(t_next, ring, merged)
        if np.isnan(p_next).any():
            continue
        ghost_now[c], ghost_next[c] = _mean_position(p_now, box), _mean_position(p_next, box)
    out_dying = np.array(sorted(dying - set(ghost_now)), np.int64)
    s1b = s1.take(~np.isin(s1.ids, out_dying).any(axis=1))
    pos_now = frames.positions(t, s1b.ids.ravel()).reshape(-1, 3, 2)
    for c, g in ghost_now.items():
        pos_now[s1b.ids == c] = g
    xy2 = _corners(s1b.ids, pos_now, box)
    s2 = _State(s1b.ids, xy2, s1b.labels)
    s2 = s2.take(s2.area > 0)  # a ghost on its neighbours' line leaves a flat triangle: out, with the extrusion
    xy2 = s2.xy
    chain.append(("extrusion", s2.sums(sizes)))
    # 3. the continuous motion; triangles that would flip over on the way are retriangulated in step 4
    pos_next = frames.positions(t_next, s2.ids.ravel(), merged).reshape(-1, 3, 2)
    for c, g in ghost_next.items():
        pos_next[s2.ids == c] = g
    usable = ~np.isnan(pos_next).any(axis=(1, 2))
    xy3 = _corners(s2.ids, np.where(np.isnan(pos_next), 0.0, pos_next), box)
    usable &= _stays_positive(xy2, xy3)
    s2b = s2.take(usable)
    chain.append(("rearrangement", s2b.sums(sizes)))
    s3 = _State(s2b.ids, xy3[usable], s2b.labels)
    start, end = s2b.sums(sizes), s3.sums(sizes)
    change = [(_means(e) - _means(s))[:2] for s, e in zip(start, end)]
    layer_labels = [(lab, n) for lab, n in zip(s2b.labels, sizes)]
    flow, splits = integrate_flow(s2b.xy, s3.xy, layer_labels, change, tolerance) if len(s3.ids) else (None, 0)
    chain.append(("flow", end))
    # regions are fixed in space: a triangle now labelled by where it is in the next frame
    s3 = _State(s3.ids, s3.xy, layers.labels(t, s3.ids, s3.xy))
    chain.append(("advection", s3.sums(sizes)))
    # 4. the next frame's triangulation, daughters merged into their mother
    ids_n, xy_n = tri_next
    mapped = ids_n.copy()
    if mothers:  # each daughter's id replaced by its mother's
        daughters = np.array([d for ds in mothers.values() for d in ds], np.int64)
        mother_of = np.array([m for m, ds in mothers.items() for _ in ds], np.int64)
        at, found = _lookup(mapped, np.sort(daughters))
        mapped[found] = mother_of[np.argsort(daughters)][at[found]]
    good = (mapped[:, 0] != mapped[:, 1]) & (mapped[:, 1] != mapped[:, 2]) & (mapped[:, 0] != mapped[:, 2])
    good &= ~np.isin(ids_n, np.array(sorted(entering), np.int64)).any(axis=1)
    mapped = mapped[good]
    first = _first_of_each(_triple_keys(mapped))  # two triangles that become the same when daughters merge
    mapped = mapped[first]
    xy4 = xy_n[good][first]
    moved = np.isin(mapped, np.array(sorted(mothers), np.int64)).any(axis=1)
    if moved.any():  # a mother at the mean of its daughters; the other triangles as they are in the next frame
        pos4 = frames.positions(t_next, mapped[moved].ravel(), merged).reshape(-1, 3, 2)
        xy4[moved] = _corners(mapped[moved], pos4, box)
    s4 = _State(mapped, xy4, layers.labels(t, mapped, xy4))
    s4 = s4.take(s4.area > 0)
    gone, come = ~_isin_rows(s3.ids, s4.ids), ~_isin_rows(s4.ids, s3.ids)
    removed, added = s3.take(gone), s4.take(come)
    share, comp, matched = _step4_kinds(removed.ids, added.ids, dying, t1.at(t_next), K,
                                        (contacts[0], _merge_daughters(contacts[1], mothers, K)))
    n_removed = len(removed.ids)
    sums = s3.sums(sizes)
    events = []
    for k, term in enumerate(_STEP4):
        w = share[comp, k] if len(comp) else np.zeros(0)
        plus, minus = added.sums(sizes, w[n_removed:]), removed.sums(sizes, w[:n_removed])
        sums = [s + p - m for s, p, m in zip(sums, plus, minus)]
        chain.append((term, sums))
    chain[-1] = (chain[-1][0], s4.sums(sizes))  # the same, without the sums' rounding
    for c, evs in enumerate(matched):
        if not evs:
            continue
        rows_r, rows_a = np.flatnonzero(comp[:n_removed] == c), np.flatnonzero(comp[n_removed:] == c)
        dxx = (added.area[rows_a] * added.qxx[rows_a]).sum() - (removed.area[rows_r] * removed.qxx[rows_r]).sum()
        dxy = (added.area[rows_a] * added.qxy[rows_a]).sum() - (removed.area[rows_r] * removed.qxy[rows_r]).sum()
        events.extend((e, -dxx / len(evs), -dxy / len(evs)) for e in evs)
    # 5. daughters split, then the cells entering the tissue
    keep = ~np.isin(ids_n, np.array(sorted(entering), np.int64)).any(axis=1)
    s5 = _State(ids_n[keep], xy_n[keep], layers.labels(t, ids_n[keep], xy_n[keep]))
    chain.append(("division", s5.sums(sizes)))
    s6 = _State(ids_n, xy_n, layers.labels(t, ids_n, xy_n))
    chain.append(("border", s6.sums(sizes)))
    blocks = [_block(chain, flow, i, n) for i, n in enumerate(sizes)]
    # a region empty at any step has no mean elongation there: it gets no row for this interval
    complete = [np.all([sums[i][0] > 0 for _, sums in chain], axis=0) for i in range(len(sizes))]
    info = {"n_triangles": len(ids0), "n_flipped": int((~usable).sum()), "splits": splits,
            "area": [c[0] for c in end], "complete": complete}
    return blocks, events, info


def _merge_daughters(keys, mothers, K):
    """Contact keys with each daughter's id replaced by its mother's (a contact between sisters dropped)."""
    if not mothers or len(keys) == 0:
        return keys
    daughters = np.array([d for ds in mothers.values() for d in ds], np.int64)
    mother_of = np.array([m for m, ds in mothers.items() for _ in ds], np.int64)
    order = np.argsort(daughters)
    daughters, mother_of = daughters[order], mother_of[order]
    ab = np.stack(np.divmod(keys, np.int64(K)))
    at, found = _lookup(ab, daughters)
    ab = np.where(found, mother_of[at], ab)
    keep = ab[0] != ab[1]
    return _sorted_unique(pair_keys(ab[0][keep], ab[1][keep], K))


#: A triangle whose area falls below this fraction of its start within an interval is retriangulated
#: (``rearrangement``) instead of deformed: near a collapse its velocity gradient diverges, the quadrature
#: cannot follow it (closure 2e-6 of the total on the ITASC movie at 1e-9, 3e-13 from 0.02 on).
COLLAPSE = 0.05


def _stays_positive(xy0, xy1):
    """Triangles whose area stays above :data:`COLLAPSE` of its start on the straight path from ``xy0`` to ``xy1``."""
    R0, R1 = edge_matrices(xy0), edge_matrices(xy1)
    ok = det2(R0) > 0
    M = (R1 - R0) @ inv2(np.where(ok[:, None, None], R0, np.eye(2)))
    # det(I + tau M) = 1 + tau tr M + tau^2 det M on [0, 1]
    tr, dt = M[:, 0, 0] + M[:, 1, 1], det2(M)
    end = 1 + tr + dt
    with np.errstate(invalid="ignore", divide="ignore"):
        vertex = np.where(dt != 0, -tr / (2 * dt), -1.0)
    inner = (vertex > 0) & (vertex < 1)
    low = np.where(inner, 1 + vertex * tr + vertex ** 2 * dt, 1.0)
    # and not flat at the end, relative to its size (an area of rounding errors is no shape)
    flat = det2(R1) <= 1e-12 * np.einsum("nij,nij->n", R1, R1)
    return ok & (end > COLLAPSE) & (low > COLLAPSE) & ~flat


def _block(chain, flow, layer, n):
    """The budget of one layer: an array (len(DEFORMATION_COLUMNS), n) in the order of :func:`_columns`."""
    cols = {}
    first, last = _means(chain[0][1][layer]), _means(chain[-1][1][layer])
    shear = {term: np.zeros((3, n)) for term in _TERMS_OF_STEPS}
    with np.errstate(invalid="ignore"):  # a region empty at a step: no row (see _pair's "complete")
        for (_, before), (term, after) in zip(chain[:-1], chain[1:]):
            if term != "flow":
                shear[term] -= _means(after[layer]) - _means(before[layer])
    f = flow[layer] if flow is not None else np.full((12, n), np.nan)
    cols["total"] = np.array([f[0], f[1], f[2]])
    cols["cell_shape"] = last - first
    cols["corotation"] = np.array([f[3], f[4], np.zeros(n)])
    cols["nonlinear"] = np.array([f[5], f[6], np.zeros(n)])
    cols["growth_correlation"] = np.array([f[7], f[8], np.zeros(n)])
    cols["rotation_correlation"] = np.array([f[9], f[10], np.zeros(n)])
    cols.update(shear)
    parts = sum(v for k, v in cols.items() if k != "total")
    cols["closure"] = cols["total"] - parts
    out = []
    for term in DEFORMATION_TERMS:
        out.extend([cols[term][0], cols[term][1]])
        if term in ISOTROPIC_TERMS:
            out.append(cols[term][2])
    out.append(f[11])
    return np.array(out)


_TERMS_OF_STEPS = ("border", "extrusion", "rearrangement", "resampling", "advection", "t1_cycle",
                   "t1_intercalation", "t1_unresolved", "division")


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
