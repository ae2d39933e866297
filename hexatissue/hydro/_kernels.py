"""Pointwise kernels of the hydrodynamics right-hand side (numba, with numpy references).

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

__all__ = ["pointwise", "pointwise_numpy"]


def pointwise_numpy(psi, psi_x, psi_y, lap, vel, omega, domega, L6, A6, B6):
    """Plain-numpy reference of :func:`pointwise`; returns (H, N, F, R)."""
    h = L6 * lap - A6 * psi - 0.5 * B6 * (psi.real**2 + psi.imag**2) * psi
    vx, vy = vel.real, vel.imag
    n = -(vx * psi_x + vy * psi_y) + 3j * omega * psi
    f = -0.5 * ((h * np.conj(psi_x)).real + 1j * (h * np.conj(psi_y)).real)
    r = (psi * np.conj(h)).imag + 1j * (vx * domega.real + vy * domega.imag)
    return h, n, f, r


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
    """Numba version of :func:`pointwise_numpy` (same arguments, same outputs, same dtype).

    Each output element depends only on its own grid node, so the result does
    not depend on the number of threads.
    """
    out = [np.empty_like(psi) for _ in range(4)]
    real = psi.real.dtype.type
    _pointwise(psi, psi_x, psi_y, lap, vel, omega, domega, real(L6), real(A6), real(B6), *out)
    return tuple(out)
