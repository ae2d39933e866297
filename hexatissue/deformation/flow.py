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

from ._kernels import flow_sums
from .triangles import REFERENCE_INVERSE, det2, inv2

__all__ = ["FLOW_TERMS", "integrate_flow"]

#: What :func:`integrate_flow` returns per region, in this order (each an (xx, xy) pair but ``iso`` and ``rotation``).
FLOW_TERMS = ("total_xx", "total_xy", "total_iso", "corotation_xx", "corotation_xy", "nonlinear_xx", "nonlinear_xy",
              "growth_correlation_xx", "growth_correlation_xy", "rotation_correlation_xx",
              "rotation_correlation_xy", "rotation")

_GAUSS = np.polynomial.legendre.leggauss(8)
_MAX_SPLITS = 1024
#: The smallest rate (1/interval) the closure is measured against (see integrate_flow).
SCALE_FLOOR = 1e-3


def _integrate(M, S0, A0, layers, splits):
    """Every term of :data:`FLOW_TERMS` per layer, integrated over ``splits`` equal sub-intervals."""
    x, w = _GAUSS
    tau = ((np.arange(splits)[:, None] + 0.5 * (x[None] + 1.0)) / splits).ravel()
    weight = np.tile(w, splits) / (2.0 * splits)
    sizes = [n for _, n in layers]
    offsets = np.cumsum([0] + sizes[:-1]).astype(np.int64)
    labels = np.stack([np.asarray(lab, np.int64) for lab, _ in layers])
    sums = flow_sums(M, S0, A0, tau, labels, offsets, int(sum(sizes)))
    with np.errstate(invalid="ignore", divide="ignore"):
        means = sums[..., 1:] / sums[..., :1]  # (G, regions, 12) area-weighted means
    out = []
    for offset, n in zip(offsets, sizes):
        Qxx, Qxy, Vxx, Vxy, Iso, W, Jxx, Jxy, QxxI, QxyI, WQxx, WQxy = np.moveaxis(means[:, offset:offset + n], 2, 0)
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
        the end states; the quadrature is refined until this identity, and
        the growth's (the integral of <tr L> is the log of the area ratio),
        close
        to ``tolerance`` x the size of its terms (at most 1024 sub-intervals; only the regions still open
        are integrated again).

    Returns
    -------
    list of (len(FLOW_TERMS), n_regions) arrays
        Per layer, the integrals of :data:`FLOW_TERMS` (shear and isotropic
        rates in 1/interval, ``rotation`` in rad/interval).
    int
        The most sub-intervals a region needed.
    """
    R0 = np.stack([xy0[:, 1] - xy0[:, 0], xy0[:, 2] - xy0[:, 0]], axis=-1)
    R1 = np.stack([xy1[:, 1] - xy1[:, 0], xy1[:, 2] - xy1[:, 0]], axis=-1)
    M = (R1 - R0) @ inv2(R0)
    S0 = R0 @ REFERENCE_INVERSE
    A0 = det2(S0)
    # each region's log area ratio, from the triangles' own changes (A1 - A0 = A0 (tr M + det M)): the
    # difference of the two sums would leave 1e-15 of rounding on a tissue that hardly grows
    grown = A0 * (M[:, 0, 0] + M[:, 1, 1] + det2(M))
    growth = []
    for labels, n in layers:
        ok = labels >= 0
        with np.errstate(invalid="ignore", divide="ignore"):
            growth.append(np.log1p(np.bincount(labels[ok], grown[ok], n) / np.bincount(labels[ok], A0[ok], n)))
    out = [np.full((len(FLOW_TERMS), n), np.nan) for _, n in layers]
    pending = [np.ones(n, bool) for _, n in layers]
    splits = 1
    # each region is refined until it closes: a region's sums depend on its own triangles only, so a
    # finer pass takes just the triangles of the regions still open (in any layer)
    while True:
        take = np.zeros(len(M), bool)
        compact = []  # each layer's open regions numbered 0.. (closed ones -1)
        for (labels, _), open_ in zip(layers, pending):
            number = np.where(open_, np.cumsum(open_) - 1, -1)
            compact.append(np.where(labels >= 0, number[np.maximum(labels, 0)], -1))
            take |= compact[-1] >= 0
        part = [(c[take], int(open_.sum())) for c, open_ in zip(compact, pending)]
        terms = _integrate(M[take], S0[take], A0[take], part, splits)
        for i, (new, change) in enumerate(zip(terms, elongation_change)):
            out[i][:, pending[i]] = new
            t = out[i]
            parts = change + t[3:11].reshape(4, 2, -1).sum(axis=0)
            size = np.abs(t[:2]) + np.abs(change) + np.abs(t[3:11]).reshape(4, 2, -1).sum(axis=0)
            # relative to the terms' size, but not below 1e-3 per interval (where rounding is all there is)
            gap = (np.abs(t[:2] - parts) / np.maximum(size, SCALE_FLOOR)).max(axis=0)
            # the growth: the integral of <tr L> is the log of the area ratio
            gap = np.maximum(gap, np.abs(t[2] - growth[i]) / np.maximum(np.abs(t[2]) + size.max(axis=0), SCALE_FLOOR))
            pending[i] &= gap > tolerance  # NaN (an empty region) is closed
        if splits >= _MAX_SPLITS or not any(p.any() for p in pending):
            return out, splits
        splits *= 2
