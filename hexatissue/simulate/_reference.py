"""Plain-numpy full-lattice reference of the MPF model (slow; for tests and small systems).

Each cell's field lives on the whole periodic lattice, ``fields[c, row, col]``.
The patch representation of ``_kernels.py`` is the special case where
``fields[c]`` is constrained to 0 outside its patch interior (``masks[c]``);
with those masks one :func:`heun_step` here equals one step of the numba
kernels up to rounding.

Discretisation (lattice spacing 1): 5-point Laplacian, advection
``v . grad phi`` with the third-order upwind stencil or central differences
(``Params.advection``; :func:`advection`), and the free energy with forward differences, whose
exact variational derivative is the 5-point Laplacian, so :func:`free_energy`
is the Lyapunov function of the passive dynamics.
"""
from __future__ import annotations

import numpy as np

from .params import Params

__all__ = ["patches_to_full", "patch_masks", "advection", "rhs", "heun_step", "euler_step", "free_energy"]


def _index(o, L, P):
    return (np.asarray(o)[:, None] + np.arange(P)[None, :]) % L


def patches_to_full(phi, ox, oy, shape) -> np.ndarray:
    """Embed patches ``(N, P, P)`` with origins ``ox, oy`` in the lattice: ``(N, Ly, Lx)`` float64."""
    N, P = phi.shape[0], phi.shape[1]
    gx, gy = _index(ox, shape[1], P), _index(oy, shape[0], P)
    out = np.zeros((N,) + tuple(shape))
    for c in range(N):
        out[c][np.ix_(gy[c], gx[c])] = phi[c]
    return out


def full_to_patches(fields, ox, oy, P) -> np.ndarray:
    """Inverse of :func:`patches_to_full` (values outside the patches are dropped)."""
    N, Ly, Lx = fields.shape
    gx, gy = _index(ox, Lx, P), _index(oy, Ly, P)
    return np.stack([fields[c][np.ix_(gy[c], gx[c])] for c in range(N)])


def patch_masks(ox, oy, P, shape) -> np.ndarray:
    """``(N, Ly, Lx)`` bool: True on each patch's interior (the nodes that evolve)."""
    inner = np.zeros((len(ox), P, P))
    inner[:, 1:-1, 1:-1] = 1
    return patches_to_full(inner, ox, oy, shape) > 0


def _lap(f):
    return np.roll(f, 1, -1) + np.roll(f, -1, -1) + np.roll(f, 1, -2) + np.roll(f, -1, -2) - 4 * f


def _shift(f, k, axis):
    """``f[..., n + k, ...]`` along ``axis`` (periodic)."""
    return np.roll(f, -k, axis)


def advection(f, vx, vy, scheme="upwind3") -> np.ndarray:
    """``vx d_x f + vy d_y f`` on periodic lattices (x = last axis, y = the one before; spacing 1).

    ``scheme="central"``: ``(f[+1] - f[-1]) / 2``.  ``scheme="upwind3"``: the third-order upwind
    stencil, biased against the velocity component: ``(2 f[+1] + 3 f[0] - 6 f[-1] + f[-2]) / 6``
    where it is > 0, ``(-f[+2] + 6 f[+1] - 3 f[0] - 2 f[-1]) / 6`` where it is <= 0.  ``vx, vy``
    broadcast against ``f``.
    """
    f = np.asarray(f, dtype=float)
    out = 0.0
    for v, axis in ((vx, -1), (vy, -2)):
        v = np.asarray(v, dtype=float)
        if scheme == "central":
            d = 0.5 * (_shift(f, 1, axis) - _shift(f, -1, axis))
        elif scheme == "upwind3":
            plus = (2 * _shift(f, 1, axis) + 3 * f - 6 * _shift(f, -1, axis) + _shift(f, -2, axis)) / 6
            minus = (-_shift(f, 2, axis) + 6 * _shift(f, 1, axis) - 3 * f - 2 * _shift(f, -1, axis)) / 6
            d = np.where(v > 0, plus, minus)
        else:
            raise ValueError(f"unknown advection scheme {scheme!r}")
        out = out + v * d
    return out


def rhs(fields, params: Params, theta, v0, masks=None) -> np.ndarray:
    """``d fields / dt = -M dF/dphi - v . grad phi`` on the full lattice (zero outside ``masks``)."""
    p = params
    f = np.asarray(fields, dtype=float)
    S1 = f.sum(0)
    S2 = (f**2).sum(0)
    a0 = p.target_area
    area = (f**2).sum((1, 2))[:, None, None]
    lap = _lap(f)
    mu = (
        0.5 * p.alpha * f * (f - p.phi0) * (2 * f - p.phi0)
        - p.k_phi * lap
        + 2 * p.eps * f * (S2 - f**2)
        - p.k_ad * (_lap(S1)[None] - lap)
        - 4 * p.lam / a0 * (1 - area / a0) * f
    )
    vx = (v0 * np.cos(theta))[:, None, None]
    vy = (v0 * np.sin(theta))[:, None, None]
    out = -p.M * mu - advection(f, vx, vy, p.advection)
    return out if masks is None else out * masks


def heun_step(fields, params: Params, theta, v0, masks=None) -> np.ndarray:
    """One Heun (predictor-corrector) step of the full-lattice model."""
    k1 = rhs(fields, params, theta, v0, masks)
    pred = fields + params.dt * k1
    k2 = rhs(pred, params, theta, v0, masks)
    return fields + 0.5 * params.dt * (k1 + k2)


def euler_step(fields, params: Params, theta, v0, masks=None) -> np.ndarray:
    """One explicit Euler step of the full-lattice model."""
    return fields + params.dt * rhs(fields, params, theta, v0, masks)


def free_energy(fields, params: Params, masks=None) -> float:
    """Discrete free energy F (forward differences; float64).

    ``masks`` is accepted for symmetry with :func:`rhs` and ignored: fields
    are already 0 outside their patches.
    """
    p = params
    f = np.asarray(fields, dtype=float)
    S1 = f.sum(0)
    S2 = (f**2).sum(0)
    gx = np.roll(f, -1, -1) - f
    gy = np.roll(f, -1, -2) - f
    grad2 = (gx**2 + gy**2).sum(0)
    gS1x = np.roll(S1, -1, -1) - S1
    gS1y = np.roll(S1, -1, -2) - S1
    bulk = 0.25 * p.alpha * (f**2 * (f - p.phi0) ** 2).sum()
    stiff = 0.5 * p.k_phi * grad2.sum()
    # sum_{c<c'} phi_c^2 phi_c'^2 = (S2^2 - sum_c phi_c^4) / 2; same identity for the gradients
    repel = 0.5 * p.eps * (S2**2 - (f**4).sum(0)).sum()
    adhes = 0.5 * p.k_ad * ((gS1x**2 + gS1y**2) - grad2).sum()
    area = (f**2).sum((1, 2))
    volume = p.lam * ((1 - area / p.target_area) ** 2).sum()
    return float(bulk + stiff + repel + adhes + volume)
