"""Triangulations with their shapes and region labels (:class:`_State`), their sums per region, and the
connected groups of triangles a retriangulation changes.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ._kernels import triangle_shapes
from .triangles import REFERENCE_INVERSE
from .triangulation import _triple_keys, pair_keys


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
