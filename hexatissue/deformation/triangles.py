"""Triangles of cell centres and their shape: the geometry of the triangle method.

A triangle of cell centres ``r0, r1, r2`` (counter-clockwise in x, y) is
mapped from an equilateral reference triangle of unit area by its state
tensor ``S = R C^-1`` (``R`` holds the edge vectors ``r1 - r0`` and
``r2 - r0`` as columns, ``C`` those of the reference).  ``S`` factors
uniquely as ``S = sqrt(A) exp(Q) Rot(theta)`` (Merkel et al., Phys. Rev. E 95,
032401, 2017): ``A`` the area, ``Q`` the symmetric traceless elongation
tensor (``Q_xx = |Q| cos 2phi``, ``Q_xy = |Q| sin 2phi``), ``theta`` a
rotation.  With ``S = [[a, b], [c, d]]``, ``P = ((a - d) / 2, (b + c) / 2)``,
``T = (a + d) / 2`` and ``W = (c - b) / 2``: ``theta = atan2(W, T)``,
``|Q| = asinh(|P| / sqrt(det S))`` and ``2 phi = arg P + theta``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["REFERENCE_INVERSE", "state_tensors", "elongation", "edge_matrices"]

# The reference: an equilateral triangle of unit area, one edge along x.
_SIDE = np.sqrt(4.0 / np.sqrt(3.0))
_REFERENCE = _SIDE * np.array([[1.0, 0.5], [0.0, np.sqrt(3.0) / 2.0]])
#: ``C^-1``: the state tensor is ``S = R @ REFERENCE_INVERSE``.
REFERENCE_INVERSE = np.linalg.inv(_REFERENCE)


def edge_matrices(xy):
    """Edge matrices ``R`` (``(..., 2, 2)``, columns ``r1 - r0`` and ``r2 - r0``) of triangles ``xy`` (``(..., 3, 2)``)."""
    return np.stack([xy[..., 1, :] - xy[..., 0, :], xy[..., 2, :] - xy[..., 0, :]], axis=-1)


def state_tensors(R):
    """State tensors ``S = R C^-1`` of edge matrices ``R`` (``(..., 2, 2)``)."""
    return R @ REFERENCE_INVERSE


def elongation(S):
    """Area, elongation and rotation of state tensors ``S`` (``(..., 2, 2)``).

    Returns
    -------
    area : ndarray
        ``det S``: the area in the unit of the positions squared (negative for
        a clockwise triangle).
    qxx, qxy : ndarray
        The elongation tensor's components (dimensionless; 0 for an
        equilateral triangle).
    theta : ndarray
        The rotation angle from the reference, rad.
    """
    a, b, c, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 0], S[..., 1, 1]
    area = a * d - b * c
    px, py = 0.5 * (a - d), 0.5 * (b + c)
    theta = np.arctan2(0.5 * (c - b), 0.5 * (a + d))
    norm = np.hypot(px, py)
    ratio = norm / np.sqrt(np.abs(area))
    # |Q| / |P| = asinh(x) / x / sqrt(det S), smooth at x = 0 (an equilateral triangle)
    small = ratio < 1e-4
    safe = np.where(small, 1.0, ratio)
    scale = np.where(small, 1.0 - ratio ** 2 / 6.0, np.arcsinh(safe) / safe) / np.sqrt(np.abs(area))
    cos, sin = np.cos(theta), np.sin(theta)
    # Q is P rotated by theta (in the 2-vector of its components)
    qxx = scale * (cos * px - sin * py)
    qxy = scale * (sin * px + cos * py)
    return area, qxx, qxy, theta
