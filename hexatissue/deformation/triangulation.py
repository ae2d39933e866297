"""Each frame's triangulation: the cell-centre triangles dual to the interior vertices (:func:`frame_triangles`)
and the cell pairs that share a vertex (:func:`frame_contacts`), with their integer keys.
"""
from __future__ import annotations

import numpy as np

from ..geometry import in_sorted
from .triangles import edge_matrices


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
    """Triangles (ids, corners) of rings of four or more cells, all of one size, and the pair keys of every
    diagonal their fans chose among.

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
    diagonals = pair_keys(np.broadcast_to(ids[:, :, None], (n, k, k - 3)).ravel(), ids[:, diag].ravel(), K)

    def votes(keys):
        if keys is None or len(keys) == 0:
            return np.zeros((n, k))
        return in_sorted(diagonals, keys).reshape(n, k, k - 3).sum(axis=2)

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
    return ids[rows, fan].reshape(-1, 3), pos[rows, fan].reshape(-1, 3, 2), diagonals


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
    return _triangulation(track, xy, cell, vertices, cell_vertices, box, previous, interior, K, following)[:2]


def _triangulation(track, xy, cell, vertices, cell_vertices, box=None, previous=None, interior=None, K=None,
                   following=None):
    """:func:`frame_triangles`' triangles (ids, corners), and the sorted pair keys of every diagonal its rings'
    fans chose among: the only keys of ``previous`` and ``following`` it asks about."""
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
    ids_parts, xy_parts, diagonals = [track[rows]], [xy[rows]], [np.zeros(0, np.int64)]
    xy_parts[0][:, 1:] = xy_parts[0][:, :1] + _min_image(xy_parts[0][:, 1:] - xy_parts[0][:, :1], box)
    vxy = vertices[["x", "y"]].to_numpy(float)
    for k in np.unique(counts[counts > 3]):
        at_k = starts[counts == k]
        ring_rows = row[at_k[:, None] + np.arange(k)[None, :]]
        ring_ids, ring_xy = _rings(ring_rows, vxy[vrow[at_k]], track, xy, box)
        fan_ids, fan_xy, fan_diagonals = _fans(ring_ids, ring_xy, previous, K, following)
        ids_parts.append(fan_ids)
        xy_parts.append(fan_xy)
        diagonals.append(fan_diagonals)
    ids, tri_xy = np.concatenate(ids_parts), np.concatenate(xy_parts)
    ids, tri_xy = _orient(ids.astype(np.int64), tri_xy)
    R = edge_matrices(tri_xy)
    flat = R[:, 0, 0] * R[:, 1, 1] - R[:, 0, 1] * R[:, 1, 0] <= 1e-9  # three centres on a line: no shape
    ids, tri_xy = ids[~flat], tri_xy[~flat]
    # two vertices joining the same three cells (cells that share two junctions) give one triangle
    first = _first_of_each(_triple_keys(ids))
    return ids[first], tri_xy[first], _sorted_unique(np.concatenate(diagonals))


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
