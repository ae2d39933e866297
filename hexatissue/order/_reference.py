"""Plain-numpy references of the kernels in :mod:`hexatissue.order._kernels` (same names and signatures).

They ignore the cell list and work by brute force (all node-centroid pairs,
a KD-tree for nearest centroids, explicit disk windows), so they are slow but
obviously right; the tests compare the kernels against them.  The shape
kernel ``shape_sums`` has :func:`reference_shape_functions` (the transcendental form).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..geometry import polygon_area_centroid, segment_sum
from .shape import DEGENERATE_AREA


def disk_means(nodes, xy, values, counted, radii, order, starts, origin, size, nbins, period, empty, means, counts):
    """Reference of :func:`hexatissue.order._kernels.disk_means`."""
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
    """Reference of :func:`hexatissue.order._kernels.tissue_mask` (nearest centroid by KD-tree)."""
    px, py = np.meshgrid(rx, ry)
    dist, nearest = cKDTree(xy).query(np.c_[px.ravel(), py.ravel()])
    return (interior[nearest] & (dist <= reach[nearest])).reshape(px.shape)


def disk_coverage(mask, node_i, node_j, half_width):
    """Reference of :func:`hexatissue.order._kernels.disk_coverage` (explicit disk windows)."""
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


def reference_shape_functions(xy, starts, orders, center):
    """Plain-numpy reference of :func:`hexatissue.order._kernels.shape_sums`: the transcendental form
    ``sum |r|^p exp(i p phi) / sum |r|^p`` (the form the kernel's complex powers replace)."""
    n = len(starts)
    lengths = np.diff(np.r_[starts, len(xy)])
    with np.errstate(invalid="ignore", divide="ignore"):
        c = segment_sum(xy, starts, n) / lengths[:, None] if center is None else center
        owner = np.repeat(np.arange(n), lengths)
        z = (xy[:, 0] - c[owner, 0]) + 1j * (xy[:, 1] - c[owner, 1])
        radius, angle = np.abs(z), np.angle(z)
        area = np.abs(polygon_area_centroid(xy, starts)[0])
        degenerate = (lengths < 3) | ~(area > DEGENERATE_AREA * segment_sum(radius**2, starts, n) / lengths)
        out = []
        for p in orders:
            den = segment_sum(radius**p, starts, n)
            gamma = segment_sum(radius**p * np.exp(1j * p * angle), starts, n) / den
            gamma[degenerate | ~(den > 0)] = np.nan
            out.append(gamma)
    return np.array(out)


def shape_sums(xy, starts, centre, own_centre, orders, degenerate_area):
    """:func:`reference_shape_functions` with the signature of :func:`hexatissue.order._kernels.shape_sums`."""
    if degenerate_area != DEGENERATE_AREA:
        raise ValueError(f"the reference tests degeneracy with DEGENERATE_AREA = {DEGENERATE_AREA}; got {degenerate_area}")
    return reference_shape_functions(xy, starts, orders, None if own_centre else centre)
