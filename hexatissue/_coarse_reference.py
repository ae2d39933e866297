"""Plain-numpy references of the kernels in :mod:`hexatissue._coarse_kernels` (same names and signatures).

They ignore the cell list and work by brute force (all node-centroid pairs,
a KD-tree for nearest centroids, explicit disk windows), so they are slow but
obviously right; the tests compare the kernels against them.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .defects import winding  # noqa: F401  (the reference of _coarse_kernels.winding lives beside plaquette_charges)


def disk_sums(nodes, xy, values, radii, order, starts, origin, size, nbins, period):
    """Reference of :func:`hexatissue._coarse_kernels.disk_sums`."""
    n, k, q = len(nodes), len(radii), values.shape[1]
    sums = np.zeros((n, k, q))
    counts = np.zeros((n, k), np.int64)
    for i in range(n):
        d = xy - nodes[i]
        if period[0] > 0:
            d = d - period * np.rint(d / period)
        d2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
        for j in range(k):
            inside = d2 <= radii[j] * radii[j]
            counts[i, j] = inside.sum()
            sums[i, j] = values[inside].sum(axis=0)
    return sums, counts


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
