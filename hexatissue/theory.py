"""Analytic results of the active hexatic continuum model (defect quadrupole).

Conventions (see ``docs/hydro.md``): ``z = x + i y = r exp(i phi)``; vectors
are complex numbers ``V = v_x + i v_y``; ``D = d_x + i d_y``, ``Dbar = d_x - i
d_y = 2 d_z``.  Positions are relative to the quadrupole centre, in the same
length unit as ``ell`` (for grids: x = column, y = row).

The quadrupole has -1/6 defects at ``(+-ell, 0)`` and +1/6 defects at
``(0, +-ell)``; its exact phase field is ``Psi6 = W / |W|`` with
``W = (z^2 + ell^2) / (z^2 - ell^2)``.  The paper's printed phase expansion has
a factor-2 error (the leading coefficient is ``-ell^2 / 3``), which is why the
expansion here is derived from ``6 theta = Im log W``.
"""
from __future__ import annotations

from math import comb

import numpy as np

from .errors import InputError, check_positive

__all__ = [
    "quadrupole_psi",
    "quadrupole_phase",
    "active_force",
    "quadrupole_flow",
    "ell6",
]


def _positions(x, y):
    try:
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        z = x + 1j * y
    except (TypeError, ValueError) as exc:
        raise InputError(f"x and y must be real arrays of positions with broadcastable shapes; {exc}") from exc
    return z



def quadrupole_phase(x, y, ell, terms=None):
    """Orientation ``theta`` of the quadrupole (``Psi6 = exp(6 i theta)``).

    Parameters
    ----------
    x, y : array_like
        Positions relative to the quadrupole centre (x = column, y = row).
    ell : float
        Half-distance between like defects (same unit as x, y).
    terms : int, optional
        None: exact ``theta = Im log W / 6`` (atan2 branch, in (-pi/6, pi/6]).
        n >= 1: the first n terms of the large-r series
        ``theta = -sum_k ell^(4k+2) sin((4k+2) phi) / (3 (2k+1) r^(4k+2))``.

    Returns
    -------
    ndarray
        theta, radians.
    """
    z = _positions(x, y)
    check_positive(ell, "ell")
    if terms is None:
        return np.angle(quadrupole_psi(x, y, ell)) / 6.0
    if int(terms) != terms or terms < 1:
        raise InputError(f"terms must be None or a positive integer; got {terms!r}")
    r, phi = np.abs(z), np.angle(z)
    theta = np.zeros(z.shape)
    for k in range(int(terms)):
        n = 4 * k + 2
        theta -= (ell / r) ** n * np.sin(n * phi) / (3.0 * (2 * k + 1))
    return theta


def quadrupole_psi(x, y, ell, terms=None):
    """Hexatic order parameter of the defect quadrupole, ``|Psi6| = 1``.

    Parameters
    ----------
    x, y : array_like
        Positions relative to the quadrupole centre (x = column, y = row).
    ell : float
        Half-distance between like defects.
    terms : int, optional
        None: exact ``W / |W|``.  n: ``exp(6 i theta_n)`` with the n-term
        expansion of :func:`quadrupole_phase`.

    Returns
    -------
    complex ndarray
        Psi6 (1 at infinity; undefined, NaN, exactly at the four cores).
    """
    z = _positions(x, y)
    check_positive(ell, "ell")
    if terms is not None:
        return np.exp(6j * quadrupole_phase(x, y, ell, terms))
    with np.errstate(divide="ignore", invalid="ignore"):
        w = (z * z + ell**2) / (z * z - ell**2)
        return w / np.abs(w)


def _bell(derivs):
    """Complete Bell polynomial Y_n(h, h', ..., h^(n-1)) for n = len(derivs).

    If ``g' = h g`` then ``g^(n) = g Y_n`` (recursion
    ``Y_{m+1} = sum_k C(m, k) Y_{m-k} h^(k)``).
    """
    y = [np.ones_like(derivs[0])]
    for m in range(len(derivs)):
        y.append(sum(comb(m, k) * y[m - k] * derivs[k] for k in range(m + 1)))
    return y[-1]


def active_force(x, y, ell, alpha, exact=True):
    """Active force of the quadrupole, ``f = (alpha6 / 8) Dbar^5 Psi6 = 4 alpha6 d_z^5 Psi6``.

    Exact (``|Psi6| = 1``, ``Psi6 = W / |W|``):
    ``f_x + i f_y = 4 alpha6 Wbar^(-1/2) d_z^5 W^(1/2) = 4 alpha6 Psi6 Y_5``
    where ``h = d_z log W^(1/2)`` has simple poles at the four cores and
    ``Y_5`` is its complete Bell polynomial (no branch cuts involved).
    Expanded (the paper's form, two orders in ell/r):
    ``960 alpha6 ell^2 r^-7 [-3 e^{-7i phi} + (ell/r)^2 (3 e^{-5i phi} - 14 e^{-9i phi})]``,
    whose relative error is ~(ell/r)^4 (35 % at r = 3 ell, 4 % at 5 ell).

    Parameters
    ----------
    x, y : array_like
        Positions relative to the quadrupole centre (x = column, y = row).
    ell : float
        Half-distance between like defects.
    alpha : float
        Activity alpha6.
    exact : bool
        Exact closed form, or the two-term expansion.

    Returns
    -------
    f_x, f_y : ndarray
        Force density components (units of alpha6 / length^5).
    """
    z = _positions(x, y)
    check_positive(ell, "ell")
    if exact:
        poles = np.array([1j * ell, -1j * ell, ell, -ell])
        signs = np.array([1.0, 1.0, -1.0, -1.0])
        with np.errstate(divide="ignore", invalid="ignore"):
            derivs = []
            for m in range(5):
                # d^m/dz^m of (1/2) sum_j s_j / (z - z_j)
                fact = (-1) ** m * float(np.prod(np.arange(1, m + 1)))
                derivs.append(0.5 * fact * sum(s / (z - p) ** (m + 1) for s, p in zip(signs, poles)))
            force = 4.0 * alpha * quadrupole_psi(x, y, ell) * _bell(derivs)
    else:
        r, e = np.abs(z), np.exp(-1j * np.angle(z))
        with np.errstate(divide="ignore", invalid="ignore"):
            force = 960.0 * alpha * ell**2 / r**7 * (-3 * e**7 + (ell / r) ** 2 * (3 * e**5 - 14 * e**9))
    return force.real, force.imag


def quadrupole_flow(x, y, ell, alpha, eta=1.0):
    """Exact incompressible Stokes flow driven by the two-term active force outside ``r = ell``.

    Solves ``eta lap v - grad P + f Theta(r - ell) = 0`` in the plane, with
    ``f`` the expanded force of :func:`active_force` (the problem posed in the
    paper; its printed solution is not divergence-free, see docs/hydro.md).
    Stream function modes sin 6phi, sin 8phi, sin 10phi; ``V = -i D psi``.

    Parameters
    ----------
    x, y : array_like
        Positions relative to the quadrupole centre (x = column, y = row).
    ell : float
        Half-distance between like defects.
    alpha : float
        Activity alpha6.
    eta : float
        Shear viscosity.

    Returns
    -------
    v_x, v_y : ndarray
        Velocity components (units of alpha6 / (eta length^3)).
    """
    z = _positions(x, y)
    check_positive(ell, "ell")
    check_positive(eta, "eta")
    r = np.abs(z)
    ei = np.exp(1j * np.angle(z))
    l2 = ell**2
    with np.errstate(divide="ignore", invalid="ignore"):
        log = np.log(r / ell)
        outer = l2 * (
            -360 / r**7 * (l2 - r**2 + 2 * l2 * log) * ei**7
            - 180 * (r**2 - l2) ** 2 / r**9 * ei**9
            - 840 * l2 * (r**2 - l2) ** 2 / r**11 * ei**11
            + 12 * (6 * r**2 - 5 * l2) / r**7 * ei**-5
            - 60 * (7 * r**2 - 6 * l2) / (7 * r**7) * ei**-7
            - 70 * l2 * (9 * r**2 - 8 * l2) / (3 * r**9) * ei**-9
        )
    zb = np.conj(z)
    # inside: psi = Im(sum c_n z^n) with real c_n, so V = -i D psi = sum n c_n zbar^(n-1)
    inner = 12 * zb**5 / ell**8 - 8 * 15 / 14 * zb**7 / ell**10 - 10 * 7 / 3 * zb**9 / ell**12
    v = alpha / eta * np.where(r > ell, outer, inner)
    return v.real, v.imag


def ell6(alpha, L6):
    """Active length ``ell6 = sqrt(|alpha6| / L6)`` (same length unit as the model's grid).

    Parameters
    ----------
    alpha : float
        Activity alpha6.
    L6 : float
        Elastic constant (> 0).

    Returns
    -------
    float
    """
    check_positive(L6, "L6")
    return float(np.sqrt(np.abs(alpha) / L6))
