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

from dataclasses import dataclass
from math import comb

import numpy as np

from .errors import InputError, check_positive

__all__ = [
    "derivative_symbols",
    "linear_operator",
    "dispersion",
    "Dispersion",
    "bulk_onset",
    "stability_diagram",
    "regime",
    "quadrupole_psi",
    "quadrupole_phase",
    "active_force",
    "quadrupole_flow",
    "quadrupole_flow_far",
    "quadrupole_flow_stokes",
    "quadrupole_flow_exact",
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


# ---- linear stability of the uniform hexatic ---------------------------------------------------------------------

SCHEMES = ("continuum", "spectral", "fd")
_PARAM_NAMES = ("rho", "eta", "L6", "A6", "B6", "Gamma6", "lambda6", "alpha6", "dx")


def derivative_symbols(k, dx, scheme):
    """Fourier symbols of one grid direction: ``(ks, lap)`` with ``d/dx -> i ks`` and ``d2/dx2 -> -lap``.

    Parameters
    ----------
    k : array_like
        Wavenumbers (1 / length).
    dx : float
        Grid spacing (ignored for "continuum" and "spectral").
    scheme : {"continuum", "spectral", "fd"}
        "fd": centred differences, ``ks = sin(k dx) / dx``, ``lap = (2 - 2 cos(k dx)) / dx^2`` (the
        stencils of :class:`hexatissue.hydro.Solver` with ``scheme="fd"``); otherwise exact, ``ks = k``,
        ``lap = k^2``.

    Returns
    -------
    ks, lap : ndarray
        1 / length and 1 / length^2.
    """
    k = np.asarray(k, dtype=float)
    if scheme == "fd":
        return np.sin(k * dx) / dx, (2 - 2 * np.cos(k * dx)) / dx**2
    if scheme not in SCHEMES:
        raise InputError(f"scheme must be one of {SCHEMES}; got {scheme!r}")
    return k.copy(), k**2


def _check_params(params):
    missing = [name for name in _PARAM_NAMES if not hasattr(params, name)]
    if missing:
        raise InputError(f"params must carry the model's constants {_PARAM_NAMES} (a hydro.HydroParams); "
                         f"missing {missing}")
    if not params.A6 < 0 or not params.B6 > 0:
        raise InputError(f"params must have A6 < 0 and B6 > 0 (ordered hexatic); got A6={params.A6!r}, "
                         f"B6={params.B6!r}")


def _operator(sx, sy, k2, p, alpha):
    """The 3 x 3 linear operator per wavevector from the symbols (broadcast arrays)."""
    psi0 = np.sqrt(-2 * p.A6 / p.B6)
    sx, sy, k2 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (sx, sy, k2)))
    d6 = (1j * (sx + 1j * sy)) ** 6  # symbol of D^6; that of Dbar^6 is conj(D^6)
    db6 = np.conj(d6)
    inv = np.divide(1.0, k2, out=np.zeros_like(k2), where=k2 > 0)
    # molecular field about the uniform state: H = L6 lap(delta) + 2 A6 Re(delta); rows over (p, q, w)
    diag, zero = -p.L6 * k2 + p.A6, np.zeros_like(k2)
    h = np.stack([diag, np.full_like(k2, p.A6), zero], axis=-1).astype(complex)
    hc = np.stack([np.full_like(k2, p.A6), diag, zero], axis=-1).astype(complex)  # of conj(H)
    m = np.zeros(k2.shape + (3, 3), complex)
    m[..., 0, :] = p.Gamma6 * h
    m[..., 1, :] = p.Gamma6 * hc
    m[..., 0, 2] += 3j * psi0 - 0.25j * p.lambda6 * d6 * inv  # co-rotation, flow alignment (lambda6/4) D^5 V
    m[..., 1, 2] += -3j * psi0 + 0.25j * p.lambda6 * db6 * inv
    active = (alpha / 8) * np.stack([db6, -d6, zero], axis=-1)
    reactive = -(p.lambda6 / 8) * (db6[..., None] * h - d6[..., None] * hc)
    antisym = 1.5 * psi0 * k2[..., None] * (h - hc)
    m[..., 2, :] = (active + reactive + antisym) / 2j
    m[..., 2, 2] -= p.eta * k2
    m[..., 2, :] /= p.rho
    return m


def linear_operator(kx, ky, params, scheme="continuum", alpha=None):
    """Linear operator of the model about the uniform hexatic ``Psi6 = psi0`` (real: a bond along x), per wavevector.

    For a perturbation ``Psi6 = psi0 + delta`` and vorticity ``omega``, the Fourier amplitudes at
    wavevector k, ``p = delta_hat(k)``, ``q = conj(delta_hat(-k))`` and ``w = omega_hat(k)``, obey
    ``d/dt (p, q, w) = M (p, q, w)`` (the equations of :class:`hexatissue.hydro.Solver`, linearised; advection
    and the Ericksen stress are of second order)::

        dp/dt = Gamma6 h + 3 i psi0 w - (i lambda6 / 4) D6 w / k2
        dq/dt = Gamma6 h' - 3 i psi0 w + (i lambda6 / 4) conj(D6) w / k2
        rho dw/dt = -eta k2 w + [alpha6/8 (conj(D6) p - D6 q) - lambda6/8 (conj(D6) h - D6 h')] / 2i
                    + (3/2) psi0 k2 (h - h') / 2i

    with ``h = -L6 k2 p + A6 (p + q)``, ``h' = -L6 k2 q + A6 (p + q)`` (the molecular field and its
    conjugate), ``D6 = (i (ks_x + i ks_y))^6`` and ``k2`` minus the Laplacian's symbol (the scheme's).

    Parameters
    ----------
    kx, ky : array_like
        Wavevector components (1 / length), broadcast together.
    params : hydro.HydroParams
        Model constants (``rho, eta, L6, A6, B6, Gamma6, lambda6, alpha6, dx``).
    scheme : {"continuum", "spectral", "fd"}
        Symbols of the derivatives (:func:`derivative_symbols`); "spectral" and "continuum" are the same
        symbols (the spectral grid only cuts the wavevectors off).
    alpha : float, optional
        Activity; default ``params.alpha6``.

    Returns
    -------
    complex ndarray, shape ``broadcast(kx, ky).shape + (3, 3)``
        ``M`` acting on ``(p, q, w)`` (1 / time).
    """
    _check_params(params)
    sx, lx = derivative_symbols(kx, params.dx, scheme)
    sy, ly = derivative_symbols(ky, params.dx, scheme)
    return _operator(sx, sy, lx + ly, params, params.alpha6 if alpha is None else float(alpha))


@dataclass
class Dispersion:
    """Growth rates and modes of the uniform hexatic (:func:`dispersion`).

    Attributes
    ----------
    rates : complex ndarray ``(..., 3)``
        Eigenvalues of the linear operator (1 / time), sorted by decreasing real part; the real part is the
        growth rate, the imaginary part the angular frequency.
    modes : complex ndarray ``(..., 3, 3)``
        ``modes[..., :, j]`` is the eigenvector of ``rates[..., j]`` in physical components: relative amplitude
        ``delta|Psi6| / psi0`` (dimensionless), orientation ``theta`` (radians, ``Psi6 = psi0 exp(6 i theta)``)
        and stream function (length^2 / time), normalised to unit norm.
    matrix : complex ndarray ``(..., 3, 3)``
        The operator in the solver's variables ``(p, q, w)`` (:func:`linear_operator`).
    """

    rates: np.ndarray
    modes: np.ndarray
    matrix: np.ndarray


def dispersion(k, params, scheme="continuum"):
    """Growth rates of the uniform hexatic per wavevector (linear stability; docs/hydro.md).

    Parameters
    ----------
    k : array_like, shape ``(..., 2)``
        Wavevectors ``(k_x, k_y)`` (1 / length); the uniform state has a bond direction along x.
    params : hydro.HydroParams
        Model constants, with the activity ``alpha6``.
    scheme : {"continuum", "spectral", "fd"}
        Derivative symbols (:func:`derivative_symbols`).

    Returns
    -------
    Dispersion
        ``rates`` (1 / time), ``modes`` (amplitude, phase, stream function), ``matrix``.
    """
    k = np.asarray(k, dtype=float)
    if k.ndim < 1 or k.shape[-1] != 2:
        raise InputError(f"k must be an array of wavevectors with last axis (k_x, k_y); got shape {k.shape}")
    m = linear_operator(k[..., 0], k[..., 1], params, scheme)
    rates, vec = np.linalg.eig(m)
    order = np.argsort(-rates.real, axis=-1, kind="stable")
    rates = np.take_along_axis(rates, order, axis=-1)
    vec = np.take_along_axis(vec, order[..., None, :], axis=-1)
    psi0 = np.sqrt(-2 * params.A6 / params.B6)
    sx, lx = derivative_symbols(k[..., 0], params.dx, scheme)
    sy, ly = derivative_symbols(k[..., 1], params.dx, scheme)
    k2 = lx + ly
    inv = np.divide(1.0, k2, out=np.zeros_like(k2), where=k2 > 0)
    p, q, w = vec[..., 0, :], vec[..., 1, :], vec[..., 2, :]
    modes = np.stack([(p + q) / (2 * psi0), (p - q) / (12j * psi0), w * inv[..., None]], axis=-2)
    norm = np.linalg.norm(modes, axis=-2, keepdims=True)
    modes = modes / np.where(norm > 0, norm, 1)
    return Dispersion(rates, modes, m)


def _wavevectors(params, scheme, n):
    """Candidate wavevectors of a scheme: the grid's (n given) or a coarse scan of its resolved range."""
    dx = params.dx
    if n is not None:
        k1 = 2 * np.pi * np.fft.fftfreq(int(n), d=dx)
        kx, ky = np.meshgrid(k1, k1)
        keep = (ky > 0) | ((ky == 0) & (kx > 0))  # one of each pair (k, -k): their rates are complex conjugates
        if scheme == "spectral":
            kc = (2.0 / 3.0) * np.abs(k1).max()  # the solver's 2/3 dealiasing mask
            keep &= (np.abs(kx) < kc) & (np.abs(ky) < kc)
        return kx[keep], ky[keep]
    if scheme == "continuum":
        # rates depend on the direction only through exp(6 i phi): one 60 degree sector suffices
        xi = np.sqrt(params.L6 / (2 * -params.A6))
        kk, phi = np.meshgrid(np.geomspace(1e-2, 1e2, 400) / xi, np.linspace(0, np.pi / 3, 13))
        return (kk * np.cos(phi)).ravel(), (kk * np.sin(phi)).ravel()
    kc = np.pi / dx if scheme == "fd" else (2.0 / 3.0) * np.pi / dx
    kx, ky = np.meshgrid(np.linspace(-kc, kc, 81), np.linspace(-kc, kc, 81))
    keep = (kx != 0) | (ky != 0)
    return kx[keep], ky[keep]


def _max_growth(params, scheme, kx, ky, alpha):
    """(largest growth rate, index of its wavevector) among the wavevectors ``kx, ky``."""
    sx, lx = derivative_symbols(kx, params.dx, scheme)
    sy, ly = derivative_symbols(ky, params.dx, scheme)
    g = np.linalg.eigvals(_operator(sx, sy, lx + ly, params, alpha)).real.max(axis=-1)
    i = int(np.argmax(g))
    return float(g[i]), i


def _onset(params, scheme, kx, ky, sign, lo, hi, threshold, rtol=1e-7):
    """Bisection for the onset |alpha| in [lo, hi] (stable at lo, unstable at hi) on the wavevectors kx, ky."""
    while hi - lo > rtol * hi:
        mid = (lo + hi) / 2
        if _max_growth(params, scheme, kx, ky, sign * mid)[0] > threshold:
            hi = mid
        else:
            lo = mid
    return hi, _max_growth(params, scheme, kx, ky, sign * hi)[1]


def bulk_onset(params, scheme="continuum", n=None, alpha_max=1e4, tol=1e-6):
    """Activities at which the uniform hexatic becomes linearly unstable, on both sides of zero.

    The uniform state is stable at ``alpha6 = 0`` (all rates <= 0; the phase mode is the Goldstone mode,
    rate -> 0 as k -> 0).  For each sign of ``alpha6`` the onset is the smallest ``|alpha6|`` at which some
    wavevector grows (rate > ``tol`` ``Gamma6 |A6|``), found by bisection on the largest growth rate of
    :func:`linear_operator` over the scheme's wavevectors: those of an ``n x n`` grid, or (``n=None``) a scan
    of the scheme's whole range refined twice around the first growing wavevector.

    Parameters
    ----------
    params : hydro.HydroParams
        Model constants (``params.alpha6`` is not used).
    scheme : {"continuum", "spectral", "fd"}
        "continuum": all wavevectors (exact symbols); "spectral": exact symbols on the solver's dealiased
        range ``|k_x|, |k_y| < 2 pi / (3 dx)``; "fd": the centred-difference symbols on the Brillouin zone.
    n : int, optional
        Only the wavevectors of an ``n x n`` periodic grid (the first growing mode of a run on that grid).
    alpha_max : float
        Largest ``|alpha6|`` searched.
    tol : float
        Growth rate counted as unstable, in units of ``Gamma6 |A6|``.

    Returns
    -------
    DataFrame
        One row per sign: ``side`` ("extensile" for alpha6 < 0, "contractile" for alpha6 > 0), ``alpha``
        (the onset alpha6; NaN if stable up to ``alpha_max``; 0 if unstable at any activity), ``k``
        (``|k|`` of the first growing wavevector, 1 / length), ``wavelength`` (2 pi / k, length), ``angle_deg``
        (angle of that wavevector from the bond direction, degrees, folded into [0, 30]), ``kx``, ``ky`` (that
        wavevector, 1 / length).
    """
    import pandas as pd

    _check_params(params)
    if scheme not in SCHEMES:
        raise InputError(f"scheme must be one of {SCHEMES}; got {scheme!r}")
    if n is not None:
        check_positive(n, "n", integer=True)
    threshold = tol * params.Gamma6 * -params.A6
    kx, ky = _wavevectors(params, scheme, n)
    rows = []
    for sign, side in ((-1, "extensile"), (1, "contractile")):
        row = {"side": side, "alpha": np.nan, "k": np.nan, "wavelength": np.nan, "angle_deg": np.nan,
               "kx": np.nan, "ky": np.nan}
        lo, hi = 0.0, 1e-3
        while hi <= alpha_max and _max_growth(params, scheme, kx, ky, sign * hi)[0] <= threshold:
            lo, hi = hi, hi * 2
        if lo == 0.0 and hi <= alpha_max:
            row["alpha"] = 0.0
        if lo == 0.0 or hi > alpha_max:
            rows.append(row)
            continue
        a, i = _onset(params, scheme, kx, ky, sign, lo, hi, threshold, 1e-6 if n is not None else 1e-3)
        bx, by = kx[i], ky[i]
        if n is None:
            # refine around the first growing wavevector: the true onset is at most the coarse one
            span = 2 * max(np.abs(np.diff(np.unique(kx))).max(), np.abs(np.diff(np.unique(ky))).max())
            span = min(span, 0.5 * np.hypot(bx, by))
            for rtol in (1e-5, 1e-7):
                fx, fy = np.meshgrid(np.linspace(bx - span, bx + span, 41), np.linspace(by - span, by + span, 41))
                fx, fy = fx.ravel(), fy.ravel()
                lo = 0.98 * a
                while lo > 1e-9 and _max_growth(params, scheme, fx, fy, sign * lo)[0] > threshold:
                    lo /= 2
                a, i = _onset(params, scheme, fx, fy, sign, lo, a, threshold, rtol)
                bx, by, span = fx[i], fy[i], span / 10
        kk = float(np.hypot(bx, by))
        angle = np.degrees(np.arctan2(by, bx)) % 60.0
        row.update(alpha=sign * a, k=kk, wavelength=2 * np.pi / kk, angle_deg=float(min(angle, 60.0 - angle)),
                   kx=float(bx), ky=float(by))
        rows.append(row)
    return pd.DataFrame(rows)


def stability_diagram(params, name, values, scheme="continuum", n=None):
    """Bulk stability window of alpha6 as one model constant varies (the stability diagram).

    Parameters
    ----------
    params : hydro.HydroParams
        The other constants (a frozen dataclass: copies are made with ``dataclasses.replace``).
    name : {"lambda6", "Gamma6", "eta", "L6", "rho"}
        The constant varied.
    values : array_like
        Its values.
    scheme, n
        As :func:`bulk_onset`.

    Returns
    -------
    DataFrame
        ``value`` (of ``name``), ``alpha_extensile``, ``alpha_contractile`` (onsets of alpha6; the uniform
        hexatic is stable strictly between them), ``k_extensile``, ``k_contractile`` (1 / length),
        ``angle_extensile``, ``angle_contractile`` (degrees from the bond direction).
    """
    import dataclasses

    import pandas as pd

    allowed = ("lambda6", "Gamma6", "eta", "L6", "rho")
    if name not in allowed:
        raise InputError(f"name must be one of {allowed}; got {name!r}")
    rows = []
    for v in np.asarray(values, dtype=float).ravel():
        onset = bulk_onset(dataclasses.replace(params, **{name: float(v)}), scheme, n)
        ext, con = onset.iloc[0], onset.iloc[1]
        rows.append({"value": float(v), "alpha_extensile": ext["alpha"], "alpha_contractile": con["alpha"],
                     "k_extensile": ext["k"], "k_contractile": con["k"],
                     "angle_extensile": ext["angle_deg"], "angle_contractile": con["angle_deg"]})
    return pd.DataFrame(rows)


def regime(params, ell, scheme="continuum", n=None):
    """Where a run sits: the bulk stability window and the active length against the defect spacing.

    Parameters
    ----------
    params : hydro.HydroParams
        Model constants with the run's ``alpha6``.
    ell : float
        Defect spacing of the run (quadrupole half-distance, or half the dipole separation), length.
    scheme, n
        As :func:`bulk_onset`.

    Returns
    -------
    dict
        ``alpha`` (the run's alpha6), ``window`` ((extensile onset, contractile onset)), ``bulk_stable``
        (bool: alpha6 strictly inside the window), ``ell6`` (``sqrt(|alpha6| / L6)``, length), ``ell6_over_ell``,
        ``active`` (bool: ``ell6 >= ell``, the activity beats elasticity at the defect spacing),
        ``alpha_at_ell`` (``L6 ell^2``, the ``|alpha6|`` at which ``ell6 = ell``).
    """
    check_positive(ell, "ell")
    onset = bulk_onset(params, scheme, n)
    lo, hi = (float(a) for a in onset["alpha"])
    lo = -np.inf if np.isnan(lo) else lo
    hi = np.inf if np.isnan(hi) else hi
    a = float(params.alpha6)
    length = ell6(a, params.L6)
    return {"alpha": a, "window": (lo, hi), "bulk_stable": bool(lo < a < hi), "ell6": length,
            "ell6_over_ell": length / ell, "active": bool(length >= ell), "alpha_at_ell": params.L6 * ell**2}


# ---- the quadrupole's flow: numerical Stokes reference and the exact far field ---------------------------------

def _quadrupole_monopole():
    """``m = M0 / (2 pi ell^2)``, ``M0 = int (Psi6 - 1 - ell^2 (z^-2 - zbar^-2)) dA`` (principal value).

    Only the angular mean of ``Psi6 - 1`` contributes; with ``F(u) = ((1 + u) / (1 - u))^(1/2) = sum a_m u^m``,
    ``Psi6 = F(ell^2 / z^2) F(-ell^2 / zbar^2)`` outside ``r = ell`` and ``-F(z^2 / ell^2) F(-zbar^2 / ell^2)``
    inside, so the mean is ``+-sum (-1)^m a_m^2 x^(4m)`` and ``m = -1 + sum_{m>=1} (-1)^m a_m^2 / (4 m^2 - 1)``
    (terms ~ m^-3; 20000 of them: error < 1e-9), ``a_2j = a_2j+1 = C(2j, j) / 4^j``.
    """
    terms = 20000
    # F(u) = (1 + u) / sqrt(1 - u^2): a_2j = a_2j+1 = C(2j, j) / 4^j
    j = np.arange(terms // 2)
    c = np.cumprod(np.r_[1.0, (2 * j[1:] - 1) / (2.0 * j[1:])])
    a = np.repeat(c, 2)
    k = np.arange(terms)
    m = k[1:]
    return float(-1 + np.sum((-1.0) ** m * a[1:] ** 2 / (4.0 * m**2 - 1)))


def quadrupole_flow_far(x, y, ell, alpha, eta=1.0):
    """Exact leading far field of the Stokes flow of the quadrupole's active stress (``|Psi6| = 1``), O(r^-5).

    ``V = (alpha6 ell^2 / (eta r^5)) [-60 e^{-7i phi} - 180 e^{9i phi} + c (e^{-5i phi} + 5 e^{7i phi})
    + 12 e^{5i phi}]`` with ``c = -24 m = 31.74`` (:func:`_quadrupole_monopole`).  The ``e^{-7i phi}``,
    ``e^{9i phi}`` terms come from the far field of Psi6 (``6 i theta = ell^2 (z^-2 - zbar^-2)``) and are those of
    :func:`quadrupole_flow`; the ``c`` terms from the monopole of ``Psi6 - 1``, which depends on the whole field
    (the two-term force outside ``r = ell`` gives 72 instead: 2.27 times too large); ``12 e^{5i phi}`` (a harmonic,
    irrotational stream function ``sin 4 phi / r^4``) is missing from :func:`quadrupole_flow`.  Relative error
    against :func:`quadrupole_flow_stokes` (docs/hydro.md): it decays as ``(ell / r)^2`` (with logarithms), and
    is measured there.

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
    c = -24.0 * _quadrupole_monopole()
    r = np.abs(z)
    e = np.exp(1j * np.angle(z))
    with np.errstate(divide="ignore", invalid="ignore"):
        v = alpha * ell**2 / (eta * r**5) * (-60 * e**-7 - 180 * e**9 + c * (e**-5 + 5 * e**7) + 12 * e**5)
    return v.real, v.imag


def quadrupole_flow_stokes(ell, alpha, eta=1.0, n=512, points_per_ell=8, smooth=0.25):
    """Numerical reference: Stokes flow of the exact quadrupole's active stress, FFT on a periodic box.

    ``eta lap^2 psi = (alpha6 / 8) Im(Dbar^6 Psi6)`` with ``Psi6 = W / |W|`` sampled on an ``n x n`` grid of
    spacing ``ell / points_per_ell`` (box ``n / points_per_ell`` ell, centred on the quadrupole, no node on a core),
    solved exactly per Fourier mode: ``psi_hat = -(alpha6 / (16 i eta)) k^2 (e^{-6i phi_k} Psi_hat -
    e^{6i phi_k} conj(Psi)_hat)``, ``V = -i D psi``.  A Gaussian filter of width ``smooth * ell`` removes the
    aliased grid-scale content of the point-like cores; it keeps the monopole of ``Psi6 - 1`` (and so the r^-5
    far field) exactly and changes the flow at distance r by a relative ``~ (smooth ell / r)^2``.

    Returns
    -------
    x : ndarray ``(n,)``
        Node coordinates along each axis relative to the centre (length; same for y).
    v_x, v_y : ndarray ``(n, n)``
        Velocity, indexed ``[y, x]`` (units of alpha6 / (eta length^3)).
    """
    check_positive(ell, "ell")
    check_positive(eta, "eta")
    check_positive(n, "n", integer=True)
    check_positive(points_per_ell, "points_per_ell")
    h = ell / points_per_ell
    x = (np.arange(n) - n / 2 + 0.5) * h
    X, Y = np.meshgrid(x, x)
    chi = quadrupole_psi(X, Y, ell) - 1
    k1 = 2 * np.pi * np.fft.fftfreq(n, d=h)
    KX, KY = np.meshgrid(k1, k1)
    k2 = KX**2 + KY**2
    e6 = ((KX + 1j * KY) / np.sqrt(np.where(k2 > 0, k2, 1))) ** 6
    stream = -(alpha / (16j * eta)) * k2 * (np.conj(e6) * np.fft.fft2(chi) - e6 * np.fft.fft2(np.conj(chi)))
    stream *= np.exp(-k2 * (smooth * ell) ** 2 / 2)
    stream[0, 0] = 0
    v = np.fft.ifft2(-1j * (1j * (KX + 1j * KY)) * stream)
    return x, v.real, v.imag


def quadrupole_flow_exact(x, y, ell, alpha, eta=1.0):
    """The quadrupole's flow at any point: the Stokes reference within 24 ell, its exact far field beyond.

    The flow to compare measurements with; the paper's :func:`quadrupole_flow` solves for a truncated force and
    is off by 64-106 % at 5-20 ell (docs/hydro.md).  Within ``24 ell``: :func:`quadrupole_flow_stokes` on a
    1024^2 grid of spacing ``ell / 8`` (box 128 ell), interpolated by bicubic splines; against a 2048^2 grid
    (box 256 ell) it differs by < 6e-4 of the flow up to 24 ell (< 1e-6 within 8 ell).  Beyond: the closed
    form :func:`quadrupole_flow_far`, within 2.4 % of the reference at 24 ell and falling as ``(ell / r)^2``.

    Parameters
    ----------
    x, y : array_like
        Positions relative to the quadrupole centre (x = column, y = row).
    ell, alpha, eta : float
        As in :func:`quadrupole_flow`.

    Returns
    -------
    v_x, v_y : ndarray
        Velocity components (units of alpha6 / (eta length^3)), the shape of ``x + 1j * y``.
    """
    from scipy.interpolate import RectBivariateSpline

    z = _positions(x, y)
    check_positive(ell, "ell")
    check_positive(eta, "eta")
    vx, vy = (np.array(v, dtype=float) for v in quadrupole_flow_far(z.real, z.imag, ell, alpha, eta))
    near = np.abs(z) <= 24 * ell
    if near.any():
        # the flow of (ell, alpha, eta) at r is alpha / (eta ell^3) times that of (1, 1, 1) at r / ell
        nodes, ux, uy = quadrupole_flow_stokes(1.0, 1.0, n=1024, points_per_ell=8)
        zn, scale = z[near] / ell, alpha / (eta * ell**3)
        vx[near] = scale * RectBivariateSpline(nodes, nodes, ux)(zn.imag, zn.real, grid=False)  # grids are [y, x]
        vy[near] = scale * RectBivariateSpline(nodes, nodes, uy)(zn.imag, zn.real, grid=False)
    return vx, vy
