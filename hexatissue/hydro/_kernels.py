"""Pointwise kernels of the hydrodynamics right-hand side (numba; numpy references in :mod:`._reference`).

Given Psi, its gradient, its Laplacian, the velocity ``V = v_x + i v_y``, the
vorticity and ``D omega = d_x omega + i d_y omega`` on the grid, compute

- ``H``: molecular field ``L6 lap Psi - A6 Psi - (B6/2)|Psi|^2 Psi``;
- ``N``: ``-(v . grad) Psi + 3 i omega Psi`` (advection and co-rotation);
- ``F``: elastic force ``-(1/2) Re(H grad conj(Psi))`` as ``f_x + i f_y``;
- ``R``: ``Im(Psi conj(H)) + i (v . grad) omega`` (two real fields packed in one
  complex array to save an FFT).
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["pointwise"]


@numba.njit(cache=True)
def _pointwise(psi, psi_x, psi_y, lap, vel, omega, domega, L6, A6, B6, h, n, f, r):
    ny, nx = psi.shape
    for i in range(ny):
        for j in range(nx):
            p = psi[i, j]
            px = psi_x[i, j]
            py = psi_y[i, j]
            hh = L6 * lap[i, j] - A6 * p - 0.5 * B6 * (p.real * p.real + p.imag * p.imag) * p
            vx = vel[i, j].real
            vy = vel[i, j].imag
            h[i, j] = hh
            n[i, j] = -(vx * px + vy * py) + 3j * omega[i, j] * p
            fx = -0.5 * (hh.real * px.real + hh.imag * px.imag)
            fy = -0.5 * (hh.real * py.real + hh.imag * py.imag)
            f[i, j] = fx + 1j * fy
            im = p.imag * hh.real - p.real * hh.imag
            adv = vx * domega[i, j].real + vy * domega[i, j].imag
            r[i, j] = im + 1j * adv


def pointwise(psi, psi_x, psi_y, lap, vel, omega, domega, L6, A6, B6):
    """Numba version of :func:`~hexatissue.hydro._reference.pointwise_numpy` (same arguments, same outputs, same dtype).

    Each output element depends only on its own grid node, so the result does
    not depend on the number of threads.
    """
    out = [np.empty_like(psi) for _ in range(4)]
    real = psi.real.dtype.type
    _pointwise(psi, psi_x, psi_y, lap, vel, omega, domega, real(L6), real(A6), real(B6), *out)
    return tuple(out)


@numba.njit(cache=True)
def _implicit_solve(r_psi, r_om, u, a, visc, c1, c2, tau, out_psi, out_om):
    ny, nx = r_psi.shape
    for i in range(ny):
        ii = (ny - i) % ny
        for j in range(nx):
            jj = (nx - j) % nx
            p = r_psi[i, j]
            q = np.conj(r_psi[ii, jj])
            uu = u[i, j]
            ub = np.conj(uu)
            a11 = 1 + tau * a[i, j]
            a22 = 1 + tau * visc[i, j]
            s = (ub * p + uu * q) / a11
            re = ub * p - uu * q
            det = a11 * a22 + tau * tau * c1[i, j] * c2[i, j]
            e = (a22 * re - 1j * tau * c1[i, j] * r_om[i, j]) / det
            out_om[i, j] = (a11 * r_om[i, j] - 1j * tau * c2[i, j] * re) / det
            out_psi[i, j] = uu * (s + e) / 2


def implicit_solve(r_psi, r_om, u, a, visc, c1, c2, tau):
    """Solve the per-wavevector 3 x 3 implicit block (numba; same as
    :func:`~hexatissue.hydro._reference.implicit_solve_numpy`)."""
    out_psi = np.empty_like(r_psi)
    out_om = np.empty_like(r_om)
    _implicit_solve(r_psi, r_om, u, a, visc, c1, c2, r_psi.real.dtype.type(tau), out_psi, out_om)
    return out_psi, out_om
