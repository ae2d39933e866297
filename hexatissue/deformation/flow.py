"""The continuous part of the budget: a fixed triangulation deformed from one frame to the next.

Between the two frames every cell centre moves on a straight line, so each
triangle's edge matrix is ``R(tau) = F(tau) R0`` with ``F(tau) = I + tau M``
and ``M = (R1 - R0) R0^-1`` (``tau`` from 0 to 1 over the frame interval).
Its velocity gradient is ``L = M F^-1``; along the path the exact identity
(Merkel et al. 2017, rederived for this parametrisation; docs/deformation.md)

    <v~> = dQ/dtau - 2 w Q_perp + <J> - <(Q_n - Q)(tr L_n)> - 2 <(w_n - w)(Q_perp,n - Q_perp)>

holds at every ``tau`` for the area-weighted means ``<.>`` over a region's
triangles (``Q`` and ``w`` the mean elongation and vorticity, ``Q_perp =
(-Q_xy, Q_xx)`` the elongation turned by 45 degrees, ``J_n`` the triangle's
nonlinear corotational term).  Each term is integrated over ``tau`` by
Gauss-Legendre quadrature; the change of ``Q`` is taken exactly from the two
end states, so what the quadrature misses shows in the budget's closure
(the number of sub-intervals doubles until it is below ``tolerance``).
"""
from __future__ import annotations

import numpy as np

from .triangles import REFERENCE_INVERSE, elongation

__all__ = ["FLOW_TERMS", "integrate_flow"]

#: What :func:`integrate_flow` returns per region, in this order (each an (xx, xy) pair but ``iso`` and ``rotation``).
FLOW_TERMS = ("total_xx", "total_xy", "total_iso", "corotation_xx", "corotation_xy", "nonlinear_xx", "nonlinear_xy",
              "growth_correlation_xx", "growth_correlation_xy", "rotation_correlation_xx",
              "rotation_correlation_xy", "rotation")

_GAUSS = np.polynomial.legendre.leggauss(8)
_MAX_SPLITS = 64


def _corotation_factor(q2):
    """``(1 - 2q coth 2q) / q^2`` of ``q2 = |Q|^2``, with its series below |Q| = 1e-2 (-4/3 at 0)."""
    small = q2 < 1e-4
    q = np.sqrt(np.where(small, 1.0, q2))
    exact = (1.0 - 2.0 * q / np.tanh(2.0 * q)) / q ** 2
    series = -4.0 / 3.0 + 16.0 / 45.0 * q2 - 128.0 / 945.0 * q2 ** 2
    return np.where(small, series, exact)


def _rates(M, S0, A0, tau):
    """Per-triangle area and rates at the path points ``tau`` (``(G,)``): arrays of shape ``(G, m)``."""
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
    # J_n = (v~ . Q_perp) f(|Q|) Q_perp: the shear the triangle takes without its elongation changing the same
    along = (-qxy * vxx + qxx * vxy) * _corotation_factor(qxx ** 2 + qxy ** 2)
    return area, qxx, qxy, vxx, vxy, iso, w, -qxy * along, qxx * along


def _means(labels, n_regions, area, values):
    """Area-weighted means per region and path point: ``(len(values), G, n_regions)``, and the areas."""
    G = area.shape[0]
    index = (labels[None, :] + n_regions * np.arange(G)[:, None]).ravel()
    keep = np.repeat(labels[None, :] >= 0, G, axis=0).ravel()
    index, weight = index[keep], area.ravel()[keep]
    total = np.bincount(index, weight, minlength=G * n_regions).reshape(G, n_regions)
    out = [np.bincount(index, weight * v.ravel()[keep], minlength=G * n_regions).reshape(G, n_regions) for v in values]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.array(out) / total, total


def _integrate(M, S0, A0, layers, splits):
    """Every term of :data:`FLOW_TERMS` per layer, integrated over ``splits`` equal sub-intervals."""
    x, w = _GAUSS
    tau = ((np.arange(splits)[:, None] + 0.5 * (x[None] + 1.0)) / splits).ravel()
    weight = np.tile(w, splits) / (2.0 * splits)
    area, qxx, qxy, vxx, vxy, iso, vort, jxx, jxy = _rates(M, S0, A0, tau)
    out = []
    for labels, n_regions in layers:
        m, _ = _means(labels, n_regions, area, (qxx, qxy, vxx, vxy, iso, vort, jxx, jxy, qxx * iso, qxy * iso,
                                                vort * qxx, vort * qxy))
        Qxx, Qxy, Vxx, Vxy, Iso, W, Jxx, Jxy, QxxI, QxyI, WQxx, WQxy = m
        terms = (Vxx, Vxy, Iso, 2 * W * Qxy, -2 * W * Qxx, Jxx, Jxy, -(QxxI - Qxx * Iso), -(QxyI - Qxy * Iso),
                 2 * (WQxy - W * Qxy), -2 * (WQxx - W * Qxx), W)
        out.append(np.einsum("g,kgr->kr", weight, np.array(terms)))
    return out


def integrate_flow(xy0, xy1, layers, elongation_change, tolerance=1e-12):
    """The continuous part of the budget, per region, for triangles moving from ``xy0`` to ``xy1``.

    Parameters
    ----------
    xy0, xy1 : (m, 3, 2) float arrays
        Each triangle's corners (x, y) at the start and the end of the
        interval, px, contiguous (periodic images already resolved), with a
        positive area all along the path.
    layers : list of (labels, n_regions)
        Region labels (``(m,)`` ints, -1 for none) of each layer of regions.
    elongation_change : list of (2, n_regions) arrays
        Per layer, the exact change of the mean elongation (xx, xy) between
        the end states; the quadrature is refined until the identity closes
        to ``tolerance`` x the size of its terms (at most 64 sub-intervals).

    Returns
    -------
    list of (len(FLOW_TERMS), n_regions) arrays
        Per layer, the integrals of :data:`FLOW_TERMS` (shear and isotropic
        rates in 1/interval, ``rotation`` in rad/interval).
    int
        The number of sub-intervals used.
    """
    R0 = np.stack([xy0[:, 1] - xy0[:, 0], xy0[:, 2] - xy0[:, 0]], axis=-1)
    R1 = np.stack([xy1[:, 1] - xy1[:, 0], xy1[:, 2] - xy1[:, 0]], axis=-1)
    M = (R1 - R0) @ np.linalg.inv(R0)
    S0 = R0 @ REFERENCE_INVERSE
    A0 = np.linalg.det(S0)
    splits = 1
    while True:
        out = _integrate(M, S0, A0, layers, splits)
        worst = 0.0
        for terms, change in zip(out, elongation_change):
            parts = change + terms[3:11].reshape(4, 2, -1).sum(axis=0)
            size = np.abs(terms[:2]) + np.abs(change) + np.abs(terms[3:11]).reshape(4, 2, -1).sum(axis=0)
            gap = np.abs(terms[:2] - parts) / np.maximum(size, 1e-14)
            worst = max(worst, float(np.nanmax(gap, initial=0.0)))
        if worst <= tolerance or splits >= _MAX_SPLITS:
            return out, splits
        splits *= 2
