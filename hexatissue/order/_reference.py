"""Plain-numpy references of the kernels in :mod:`hexatissue._coarse_kernels` (same names and signatures).

They ignore the cell list and work by brute force (all node-centroid pairs,
a KD-tree for nearest centroids, explicit disk windows), so they are slow but
obviously right; the tests compare the kernels against them.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..defects import winding  # noqa: F401  (the reference of _coarse_kernels.plaquette_defects, beside plaquette_charges)


def disk_means(nodes, xy, values, counted, radii, order, starts, origin, size, nbins, period, empty, means, counts):
    """Reference of :func:`hexatissue._coarse_kernels.disk_means`."""
    xy, values = xy[counted], values[counted]
    for i in range(len(nodes)):
        d = xy - nodes[i]
        if period[0] > 0:
            d = d - period * np.rint(d / period)
        d2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
        for j, r in enumerate(radii):
            inside = d2 <= r * r
            counts[j, i] = inside.sum()
            means[:, j, i] = values[inside].mean(axis=0) if counts[j, i] else empty


def tissue_mask(rx, ry, xy, interior, reach, max_reach, order, starts, origin, size, nbins):
    """Reference of :func:`hexatissue._coarse_kernels.tissue_mask` (nearest centroid by KD-tree)."""
    px, py = np.meshgrid(rx, ry)
    dist, nearest = cKDTree(xy).query(np.c_[px.ravel(), py.ravel()])
    return (interior[nearest] & (dist <= reach[nearest])).reshape(px.shape)


def disk_coverage(mask, node_i, node_j, half_width):
    """Reference of :func:`hexatissue._coarse_kernels.disk_coverage` (explicit disk windows)."""
    k, width = half_width.shape
    pad = (width - 1) // 2
    cols = np.arange(-pad, pad + 1)
    out = np.zeros((len(node_i), k), np.int64)
    for j in range(k):
        disk = np.abs(cols)[None, :] <= half_width[j][:, None]
        for a, (ci, cj) in enumerate(zip(node_i, node_j)):
            window = mask[ci - pad: ci + pad + 1, cj - pad: cj + pad + 1]
            out[a, j] = int(window[disk].sum())
    return out


def field_layouts(row, col, rows, cuts):
    """Reference of :func:`hexatissue._coarse_kernels.field_layouts` (one field at a time, numpy)."""
    n_fields = len(cuts) - 1
    shapes, once, block = np.zeros((n_fields, 2), np.int64), np.zeros(n_fields, bool), np.zeros(n_fields, bool)
    for g, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        r, c = row[rows[a:b]], col[rows[a:b]]
        shapes[g] = r.max() + 1, c.max() + 1
        n = shapes[g].prod()
        if len(r) != n or r.min() < 0 or c.min() < 0:
            continue
        node = r * shapes[g, 1] + c
        once[g] = np.bincount(node, minlength=n).max() == 1
        block[g] = once[g] and (node == np.arange(n)).all() and (rows[a:b] == rows[a] + np.arange(n)).all()
    return shapes, once, block
