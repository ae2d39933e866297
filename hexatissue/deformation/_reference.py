"""Plain-numpy references of :mod:`hexatissue.deformation._kernels` (same names, same signatures)."""
from __future__ import annotations

import numpy as np

from .triangles import edge_matrices, elongation


def _corotation_factor(q2):
    small = q2 < 1e-4
    q = np.sqrt(np.where(small, 1.0, q2))
    exact = (1.0 - 2.0 * q / np.tanh(2.0 * q)) / q ** 2
    series = -4.0 / 3.0 + 16.0 / 45.0 * q2 - 128.0 / 945.0 * q2 ** 2
    return np.where(small, series, exact)


def triangle_shapes(xy, reference_inverse):
    """As :func:`hexatissue.deformation._kernels.triangle_shapes`, with whole-array numpy."""
    area, qxx, qxy, _ = elongation(edge_matrices(xy) @ reference_inverse)
    return area, qxx, qxy


def flow_sums(M, S0, A0, tau, labels, offsets, n_regions):
    """As :func:`hexatissue.deformation._kernels.flow_sums`, with whole-array numpy."""
    t = tau[:, None, None, None]
    F = np.eye(2) + t * M[None]
    det = F[..., 0, 0] * F[..., 1, 1] - F[..., 0, 1] * F[..., 1, 0]
    adj = np.stack([np.stack([F[..., 1, 1], -F[..., 0, 1]], -1), np.stack([-F[..., 1, 0], F[..., 0, 0]], -1)], -2)
    L = (M[None] @ adj) / det[..., None, None]
    area = A0[None] * det
    _, qxx, qxy, _ = elongation(F @ S0[None])
    vxx, vxy = 0.5 * (L[..., 0, 0] - L[..., 1, 1]), 0.5 * (L[..., 0, 1] + L[..., 1, 0])
    iso = L[..., 0, 0] + L[..., 1, 1]
    w = 0.5 * (L[..., 1, 0] - L[..., 0, 1])
    along = (-qxy * vxx + qxx * vxy) * _corotation_factor(qxx ** 2 + qxy ** 2)
    values = (np.ones_like(area), qxx, qxy, vxx, vxy, iso, w, -qxy * along, qxx * along, qxx * iso, qxy * iso,
              w * qxx, w * qxy)
    G = len(tau)
    out = np.zeros((G, n_regions, 13))
    for layer in range(labels.shape[0]):
        ok = labels[layer] >= 0
        index = (offsets[layer] + labels[layer][ok])[None, :] + n_regions * np.arange(G)[:, None]
        for k, v in enumerate(values):
            out[:, :, k] += np.bincount(index.ravel(), (area * v)[:, ok].ravel(),
                                        minlength=G * n_regions).reshape(G, n_regions)
    return out
