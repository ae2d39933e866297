"""Plain-numpy references of the kernels in :mod:`hexatissue.hydro._kernels` (same arguments, same outputs).

See :mod:`hexatissue.hydro._kernels` for the fields ``H``, ``N``, ``F``, ``R``; the tests compare the two.
"""
from __future__ import annotations

import numpy as np

__all__ = ["pointwise_numpy", "implicit_solve_numpy"]


def pointwise_numpy(psi, psi_x, psi_y, lap, vel, omega, domega, L6, A6, B6):
    """Plain-numpy reference of :func:`hexatissue.hydro._kernels.pointwise`; returns (H, N, F, R)."""
    h = L6 * lap - A6 * psi - 0.5 * B6 * (psi.real**2 + psi.imag**2) * psi
    vx, vy = vel.real, vel.imag
    n = -(vx * psi_x + vy * psi_y) + 3j * omega * psi
    f = -0.5 * ((h * np.conj(psi_x)).real + 1j * (h * np.conj(psi_y)).real)
    r = (psi * np.conj(h)).imag + 1j * (vx * domega.real + vy * domega.imag)
    return h, n, f, r


def implicit_solve_numpy(r_psi, r_om, u, a, visc, c1, c2, tau):
    """Plain-numpy reference of :func:`hexatissue.hydro._kernels.implicit_solve` (``Solver.solve_implicit`` documents
    the block)."""
    ny, nx = r_psi.shape
    q = np.conj(r_psi[(-np.arange(ny)) % ny][:, (-np.arange(nx)) % nx])
    ub = np.conj(u)
    s = (ub * r_psi + u * q) / (1 + tau * a)
    re = ub * r_psi - u * q
    a11 = 1 + tau * a
    a22 = 1 + tau * visc
    det = a11 * a22 + tau**2 * c1 * c2
    e = (a22 * re - 1j * tau * c1 * r_om) / det
    w = (a11 * r_om - 1j * tau * c2 * re) / det
    return u * (s + e) / 2, w
