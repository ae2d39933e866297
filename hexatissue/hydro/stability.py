"""Linear stability of the discrete time step about the uniform hexatic, and the checks a run makes before it starts.

The continuum linear operator per wavevector is :func:`hexatissue.theory.linear_operator`; here it is
evaluated with the solver's own symbols on the run's grid and combined with the integrator: RK4 amplifies
a mode by ``R(dt M)``, ``R`` the degree-4 Taylor polynomial; SBDF2 with the implicit block ``L``
(:meth:`Solver.linear`) and explicit rest ``E = M - L`` is the two-step recurrence
``(3/2 - dt L) x' = 2 x - x_prev / 2 + dt (2 E x - E x_prev)``.  A time step is stable when no mode is
amplified per step by more than its exact flow allows, ``exp(max(Re lambda, 0) dt)``, to 1e-9; a mode
that grows in the continuum (alpha6 outside the bulk window) may grow up to 1.5 times faster than its exact rate
(the limit is about the integrator, not the physics).
"""
from __future__ import annotations

import warnings

import numpy as np

from .. import theory
from ..errors import HexatissueWarning, InputError, user_stacklevel
from .params import HydroParams
from .solver import Operators

__all__ = ["grid_operator", "amplification", "dt_limit", "check_run"]


def grid_operator(params: HydroParams, n):
    """Linear operator ``M`` and implicit block ``L`` on the resolved wavevectors of an ``n x n`` grid.

    Returns
    -------
    m, lin : complex ndarray ``(modes, 3, 3)``
        In the variables ``(Psi_hat(k), conj Psi_hat(-k), omega_hat(k))`` (1 / time); ``lin`` is the block
        the SBDF2 integrator treats implicitly (:meth:`Solver.linear`).
    """
    ops = Operators(n, params)
    k1 = 2 * np.pi * np.fft.fftfreq(n, d=params.dx)
    kx, ky = np.meshgrid(k1, k1)
    # one of each pair (k, -k): their rates are complex conjugates
    keep = ops.mask & ((ky > 0) | ((ky == 0) & (kx > 0)))
    m = theory.linear_operator(kx[keep], ky[keep], params, params.scheme)
    u, a, visc, c1 = ops.u[keep], ops.a[keep], ops.visc[keep], ops.c1[keep]
    c2 = (ops.c2 + ops.c2_active)[keep]
    lin = np.zeros_like(m)
    lin[:, 0, 0] = lin[:, 1, 1] = -a
    lin[:, 0, 2] = -0.5j * c1 * u
    lin[:, 1, 2] = 0.5j * c1 * np.conj(u)
    lin[:, 2, 0] = -1j * c2 * np.conj(u)
    lin[:, 2, 1] = 1j * c2 * u
    lin[:, 2, 2] = -visc
    return m, lin


def amplification(params: HydroParams, n, dt=None, operators=None):
    """Per-step growth factor of every resolved mode, and what the exact linear flow allows.

    Returns
    -------
    numeric, exact : ndarray ``(modes,)``
        Spectral radius of the integrator's one-step map at ``dt`` (default ``params.dt``), and
        ``exp(max(Re lambda, 0) dt)`` of the exact flow (both dimensionless).
    """
    dt = params.dt if dt is None else float(dt)
    m, lin = grid_operator(params, n) if operators is None else operators
    rate = np.linalg.eigvals(m).real.max(axis=-1)
    eye = np.eye(3)
    if params.integrator == "rk4":
        z = dt * m
        z2 = z @ z
        step = eye + z + z2 / 2 + z2 @ z / 6 + z2 @ z2 / 24
    else:
        e = m - lin
        inv = np.linalg.inv(1.5 * eye - dt * lin)
        step = np.zeros((len(m), 6, 6), complex)
        step[:, :3, :3] = inv @ (2 * eye + 2 * dt * e)
        step[:, :3, 3:] = inv @ (-0.5 * eye - dt * e)
        step[:, 3:, :3] = eye
    numeric = np.abs(np.linalg.eigvals(step)).max(axis=-1)
    return numeric, np.exp(np.maximum(rate, 0) * dt)


def dt_limit(params: HydroParams, n, rtol=1e-3):
    """Largest stable time step of the run's scheme and integrator about the uniform state, at its alpha6.

    Bisection on ``dt`` up to the explicit bulk term's bound ``1 / (Gamma6 |A6|)`` (:class:`HydroParams`);
    the criterion is in the module's docstring.

    Returns
    -------
    float
        Time units (relative accuracy ``rtol``).
    """
    top = 1.0 / (params.Gamma6 * -params.A6)

    def stable(dt, ops):
        numeric, exact = amplification(params, n, dt, ops)
        return bool(np.all(numeric <= exact**1.5 * (1 + 1e-9)))

    def bisect(lo, hi, ops):
        while hi - lo > rtol * hi:
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if stable(mid, ops) else (lo, mid)
        return lo, hi

    full = grid_operator(params, n)
    if stable(top, full):
        return top
    lo, hi = 0.0, top
    if n > 32:  # bracket on a coarse grid first (its limit is within a few % of the fine grid's), then refine
        guess = bisect(0.0, top, grid_operator(params, 32))[0]
        lo, hi = 0.8 * guess, min(1.25 * guess, top)
        while lo > 1e-6 and not stable(lo, full):
            lo, hi = lo / 2, lo
        while hi < top and stable(hi, full):
            lo, hi = hi, min(2 * hi, top)
    return bisect(lo, hi, full)[0]


def check_run(params: HydroParams, n, ell):
    """Check a run before it starts: refuse a ``dt`` beyond the scheme's limit, warn outside the stable regime.

    Raises :class:`InputError` naming the limit when ``params.dt`` exceeds :func:`dt_limit`; warns
    (:class:`HexatissueWarning`) when ``alpha6`` is outside the bulk stability window of the scheme on this grid
    (:func:`hexatissue.theory.bulk_onset`) or when the active length ``ell6 = sqrt(|alpha6| / L6)`` is shorter than
    the defect spacing ``ell`` (activity does not beat elasticity at the defects' scale).

    Returns
    -------
    dict
        :func:`hexatissue.theory.regime` on this grid plus ``dt_limit`` (time units) and ``warnings`` (list of
        str): recorded in the run's metadata.
    """
    limit = dt_limit(params, n)
    if params.dt > limit:
        raise InputError(f"HydroParams.dt = {params.dt:g} is beyond the stability limit {limit:.3g} of scheme "
                         f"{params.scheme!r} with {params.integrator!r} at alpha6 = {params.alpha6:g} on a {n}^2 "
                         f"grid; use dt <= {limit:.3g}")
    info = theory.regime(params, ell, params.scheme, n)
    info["window"] = [float(a) if np.isfinite(a) else None for a in info["window"]]  # JSON for the run's attrs
    info["dt_limit"] = limit
    notes = []
    lo, hi = (float("nan") if a is None else a for a in info["window"])
    if not info["bulk_stable"]:
        notes.append(f"alpha6 = {params.alpha6:g} is outside the bulk stability window ({lo:.4g}, {hi:.4g}) of scheme "
                     f"{params.scheme!r} on this grid: the uniform hexatic itself is unstable (docs/hydro.md)")
    if params.alpha6 != 0 and not info["active"]:
        notes.append(f"ell6 = sqrt(|alpha6| / L6) = {info['ell6']:.3g} is shorter than the defect spacing "
                     f"{ell:g}: elasticity dominates activity at the defects' scale (|alpha6| >= L6 ell^2 = "
                     f"{info['alpha_at_ell']:.3g} needed; docs/hydro.md)")
    for note in notes:
        warnings.warn(note, HexatissueWarning, stacklevel=user_stacklevel())
    info["warnings"] = notes
    return info
