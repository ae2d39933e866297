"""Plain-numpy references of the kernels in :mod:`hexatissue.track._kernels`; the tests compare the two.

(:func:`hexatissue.track._compact_reference`, the reference of the compaction
kernels, stays in :mod:`hexatissue.track`: the tracker uses it for sparse ids.)
"""
from __future__ import annotations

import numpy as np


def _dense_overlaps_reference(ia, ib, na, nb):
    """Reference of :func:`_dense_overlaps` (one bincount of the pair index)."""
    ia = np.where(ia < 0, na, ia).astype(np.int64)
    counts = np.bincount(ia * (nb + 1) + np.where(ib < 0, nb, ib), minlength=(na + 1) * (nb + 1))
    counts = counts.reshape(na + 1, nb + 1)[:na, :nb]
    i, j = np.nonzero(counts)
    return i.astype(np.int64), j.astype(np.int64), counts[i, j].astype(np.int64)


def _sparse_overlaps_reference(ia, ib, na, nb):
    """Reference of :func:`_sparse_overlaps`: one sorted int64 key per pixel in both frames' cells."""
    both = (ia >= 0) & (ib >= 0)
    key, n = np.unique(ia[both].astype(np.int64) * nb + ib[both], return_counts=True)
    i, j = np.divmod(key, nb)
    return i, j, n.astype(np.int64)


def _divisions_reference(i, j, n, area_a, area_b, child_fraction, mother_fraction, min_iou):
    """Reference of :func:`_divisions` (sorts and bincounts): mother index -> two daughter indices, from overlaps.

    A daughter candidate of mother ``i`` is a cell ``j`` lying mostly inside
    ``i`` (``n_ij >= child_fraction * area_j``) and holding a sizeable part of
    it (``n_ij >= mother_fraction * area_i``), and that is not the best
    successor (highest IoU, at least ``min_iou / 2``) of another cell: a
    neighbour that took over part of ``i`` is not its daughter.  A mother with
    two or more candidates divided; its two largest overlaps are the daughters.
    """
    iou = n / (area_a[i] + area_b[j] - n)
    order = np.lexsort((-iou, i))
    first = order[np.r_[True, i[order][1:] != i[order][:-1]]] if len(i) else order
    best_j = np.full(len(area_a), -1)
    strong = iou[first] >= min_iou / 2
    best_j[i[first][strong]] = j[first][strong]
    n_best = np.bincount(best_j[best_j >= 0], minlength=len(area_b))
    others = n_best[j] - (best_j[i] == j)
    cand = (n >= child_fraction * area_b[j]) & (n >= mother_fraction * area_a[i]) & (others == 0)
    ci, cj, cn = i[cand], j[cand], n[cand]
    if len(ci) < 2:
        return np.empty(0, np.int64), np.empty((0, 2), np.int64)
    order = np.lexsort((-cn, ci))
    ci, cj = ci[order], cj[order]
    first = np.r_[True, ci[1:] != ci[:-1]]
    starts = np.flatnonzero(first)
    counts = np.diff(np.r_[starts, len(ci)])
    mothers = starts[counts >= 2]
    return ci[mothers], np.c_[cj[mothers], cj[mothers + 1]]


def _cell_moments_reference(index, cols, n):
    """Reference of :func:`_cell_moments` (bincounts)."""
    k = np.flatnonzero(index >= 0)
    c = index[k]
    return (np.bincount(c, minlength=n).astype(np.int64), np.bincount(c, k % cols, minlength=n).astype(float),
            np.bincount(c, k // cols, minlength=n).astype(float))


def _warp_index_reference(index, rows, cols, x0, y0, step, ux, uy, periodic):
    """Reference of :func:`_warp_index` (scipy's bilinear map_coordinates on the clamped grid)."""
    from scipy.ndimage import map_coordinates

    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    fy = np.clip((r - y0) / step, 0, ux.shape[0] - 1)
    fx = np.clip((c - x0) / step, 0, ux.shape[1] - 1)
    dx = map_coordinates(ux, [fy, fx], order=1, mode="nearest")
    dy = map_coordinates(uy, [fy, fx], order=1, mode="nearest")
    sr, sc = np.floor(r - dy + 0.5).astype(np.int64), np.floor(c - dx + 0.5).astype(np.int64)
    if periodic:
        sr, sc = sr % rows, sc % cols
        return index[(sr * cols + sc).ravel()].astype(np.int32)
    inside = (sr >= 0) & (sr < rows) & (sc >= 0) & (sc < cols)
    out = np.full(rows * cols, -1, np.int32)
    out[inside.ravel()] = index[(sr * cols + sc)[inside]]
    return out


def _compact_index(flat, top):
    """Reference of :func:`_compact_index` (``np.unique``): compact index per pixel (-1 for 0), ids, areas."""
    ids, inverse, area = np.unique(flat, return_inverse=True, return_counts=True)
    background = len(ids) > 0 and ids[0] == 0
    index = (inverse.ravel() - int(background)).astype(np.int32)
    if background:
        ids, area = ids[1:], area[1:]
    return index, ids.astype(np.int64), area.astype(np.int64)


def _compact_overlaps(flat, top, prev, n_prev):
    """Reference of :func:`_compact_overlaps`: :func:`_compact_index`, then the overlaps with ``prev``."""
    index, ids, area = _compact_index(flat, top)
    return (index, ids, area, *_dense_overlaps_reference(prev, index, n_prev, len(ids)))


def _division_reference(i, j, n, area_a, area_b, child_fraction, mother_fraction, min_iou):
    """:func:`_divisions_reference` with the outputs of :func:`_division_kernel`: mothers, first and second daughters."""
    mothers, daughters = _divisions_reference(i, j, n, area_a, area_b, child_fraction, mother_fraction, min_iou)
    return mothers.astype(np.int64), daughters[:, 0].astype(np.int64), daughters[:, 1].astype(np.int64)
