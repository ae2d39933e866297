"""Initial states of the paper's experiments: a defect quadrupole and a +-1/6 pair.

Inside disks the phase is fixed to the analytic field; outside it starts
random; the whole field is then relaxed (model A dynamics, no flow) with the
disks held fixed until the free energy changes by less than ``tol`` over
``check_time`` (default 0.1 % over 10 time units), as in the paper.
Positions: node ``[i, j]`` is at ``x = j dx``, ``y = i dx`` (x = column,
y = row); defects are placed on plaquette centres so no node is singular.
"""
from __future__ import annotations

import numpy as np

from ..defects import plaquette_charges
from ..errors import InputError, as_generator
from ..theory import quadrupole_psi
from .params import HydroParams
from .solver import Solver, fft2, ifft2

__all__ = ["quadrupole_initial", "dipole_initial", "thermalise", "core_profile"]


def _grid(n, dx):
    x = np.arange(n) * dx
    return np.meshgrid(x, x)


def core_profile(r, params):
    """Amplitude ``psi0 r / sqrt(r^2 + 2 xi^2)`` of a defect core, ``xi = sqrt(L6 / (2 |A6|))``."""
    xi2 = params.L6 / (2 * abs(params.A6))
    return r / np.sqrt(r**2 + 2 * xi2)


def thermalise(psi, fixed, params, dt=0.5, check_time=10.0, tol=1e-3, max_time=10000.0, clean=True):
    """Relax ``d_t Psi = Gamma6 H`` (no flow) holding ``psi[fixed]`` fixed.

    Semi-implicit Euler (diffusion implicit), with the scheme's Laplacian.
    Stops when ``|F(t) - F(t - check_time)| < tol |F(t)|`` and, if ``clean``,
    no defect is left outside the fixed region (the 0.1 % criterion alone
    stops while stray defects from the random start are still coarsening),
    or at ``max_time``.

    Returns
    -------
    psi : complex ndarray
        Relaxed field.
    time : float
        Relaxation time used.
    """
    n = psi.shape[0]
    solver = Solver(n, params)
    ops = solver.ops
    p = params
    pinned = psi[fixed].copy()
    psi = psi.astype(p.complex_dtype)
    denom = 1 + dt * p.Gamma6 * p.L6 * ops.k2
    steps_per_check = max(1, int(round(check_time / dt)))
    energy = None
    t = 0.0
    while t < max_time:
        for _ in range(steps_per_check):
            react = -p.A6 * psi - 0.5 * p.B6 * np.abs(psi) ** 2 * psi
            psi = ifft2((fft2(psi) + dt * p.Gamma6 * fft2(react)) / denom)
            psi[fixed] = pinned
        t += steps_per_check * dt
        new = solver.free_energy(solver.state_from_fields(psi))
        if energy is not None and abs(new - energy) < tol * abs(new) and (not clean or _clean(psi, fixed)):
            break
        energy = new
    return psi, t


def _clean(psi, fixed):
    """No defect on plaquettes that do not touch the fixed region."""
    charges = plaquette_charges(psi, 6, periodic=True)
    near = fixed | np.roll(fixed, -1, 0) | np.roll(fixed, -1, 1) | np.roll(np.roll(fixed, -1, 0), -1, 1)
    return not np.any(charges[~near] != 0)


def _random_outside(psi, fixed, params, seed, noise):
    """Outside ``fixed``: random phases (``noise=None``) or the analytic phase plus uniform noise in (-noise, noise)."""
    rng = as_generator(seed)
    if noise is None:
        outside = params.psi0 * np.exp(1j * rng.uniform(0, 2 * np.pi, psi.shape))
    else:
        outside = params.psi0 * np.exp(1j * (np.angle(psi) + rng.uniform(-noise, noise, psi.shape)))
    return np.where(fixed, psi, outside)


NOISE = np.pi / 3


def _check_orientation(orientation):
    if isinstance(orientation, bool) or not isinstance(orientation, (int, float, np.integer, np.floating)) \
            or not np.isfinite(orientation):
        raise InputError(f"orientation must be a finite angle in radians; got {orientation!r}")
    return np.exp(6j * float(orientation))


def quadrupole_initial(n=256, ell=7.0, disk=28.0, params=None, seed=0, noise=NOISE, thermalise_kw=None,
                       orientation=0.0):
    """Quadrupole of +-1/6 defects (``Psi6 = W/|W|``, exact) fixed in a disk, random outside, relaxed.

    -1/6 defects at ``(cx +- ell, cy)``, +1/6 at ``(cx, cy +- ell)``, with
    ``cx = cy = (n/2 - 1/2) dx`` (a plaquette centre).  Outside the disk the
    phase of Psi6 is the analytic one plus uniform noise in ``(-noise,
    noise)``; ``noise=None`` takes fully random phases (the paper's wording),
    which leaves stray defects, some trapped at the edge of the fixed disk.
    ``orientation`` is the far-field bond angle theta_inf (radians, from +x):
    the field is multiplied by ``exp(6 i theta_inf)``, which keeps the defects
    where they are but turns the hexatic relative to their axes (the active
    force is linear in Psi6, so theta_inf = pi/6 reverses it).

    Returns
    -------
    psi : (n, n) complex ndarray
    info : dict
        ``centre`` (x, y), ``thermalise_time``.
    """
    params = params or HydroParams()
    _check(n, ell, disk, params)
    X, Y = _grid(n, params.dx)
    c = (n / 2 - 0.5) * params.dx
    psi = quadrupole_psi(X - c, Y - c, ell) * params.psi0 * _check_orientation(orientation)
    for zc in (c + ell + 1j * c, c - ell + 1j * c, c + 1j * (c + ell), c + 1j * (c - ell)):
        psi = psi * core_profile(np.abs(X + 1j * Y - zc), params)
    fixed = np.hypot(X - c, Y - c) <= disk
    psi = _random_outside(psi, fixed, params, seed, noise)
    psi, t = thermalise(psi, fixed, params, **(thermalise_kw or {}))
    return psi, {"centre": (c, c), "thermalise_time": t}


def dipole_initial(n=256, distance=64.0, disk=5.0, params=None, seed=0, noise=NOISE, thermalise_kw=None,
                   orientation=0.0):
    """+1/6 defect at ``(cx - d/2, cy)`` and -1/6 at ``(cx + d/2, cy)``, phase fixed in disks, relaxed.

    ``orientation``: far-field bond angle theta_inf (radians), as in
    :func:`quadrupole_initial`; 0 puts a bond direction along the pair axis.

    Returns
    -------
    psi : (n, n) complex ndarray
    info : dict
        ``positions`` [(x, y, charge), ...], ``thermalise_time``.
    """
    params = params or HydroParams()
    _check(n, distance / 2, disk, params)
    X, Y = _grid(n, params.dx)
    c = (n / 2 - 0.5) * params.dx
    z = X + 1j * Y
    zp, zm = c - distance / 2 + 1j * c, c + distance / 2 + 1j * c
    psi = params.psi0 * np.exp(1j * (np.angle(z - zp) - np.angle(z - zm))) * _check_orientation(orientation)
    psi = psi * core_profile(np.abs(z - zp), params) * core_profile(np.abs(z - zm), params)
    fixed = (np.abs(z - zp) <= disk) | (np.abs(z - zm) <= disk)
    psi = _random_outside(psi, fixed, params, seed, noise)
    psi, t = thermalise(psi, fixed, params, **(thermalise_kw or {}))
    info = {"positions": [(zp.real, zp.imag, 1 / 6), (zm.real, zm.imag, -1 / 6)], "thermalise_time": t}
    return psi, info


def _check(n, half, disk, params):
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 8:
        raise InputError(f"n must be an integer grid size >= 8; got {n!r}")
    if not np.isfinite(half) or half <= 0 or not np.isfinite(disk) or disk <= 0:
        raise InputError(f"defect separation and disk radius must be positive; got {2 * half!r}, {disk!r}")
    if 2 * (half + disk) >= n * params.dx:
        raise InputError(f"defects plus fixed disks (extent {2 * (half + disk)}) do not fit in the box {n * params.dx}")
