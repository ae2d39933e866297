"""The paper's two experiments: +-1/6 pair annihilation and quadrupole unbinding.

Positions are x = column * dx, y = row * dx (origin at node [0, 0]).
"""
from __future__ import annotations

import numpy as np

from ..box import Box
from ..defects import track_defects
from ..errors import InputError, check_positive, is_real
from .initial import dipole_initial, quadrupole_initial
from .params import HydroParams
from .run import integrate
from .solver import Solver
from .stability import check_run

__all__ = ["run_dipole", "run_quadrupole", "default_params", "departure_angle"]


def default_params(alpha, dt=None, **overrides):
    """The paper's parameters with ``alpha6 = alpha`` and the production scheme.

    Production scheme: pseudo-spectral, 2/3 dealiasing, semi-implicit BDF2,
    dt = 0.05 (see docs/hydro.md for the measured comparison with the paper's
    finite differences).
    """
    kw = {"alpha6": float(alpha), "scheme": "spectral", "integrator": "sbdf2", "dt": 0.05}
    if dt is not None:
        kw["dt"] = float(dt)
    kw.update(overrides)
    return HydroParams(**kw)


def _track(result, box, max_distance):
    d = result.defects
    if len(d):
        d = track_defects(d, max_distance, box=box, time_column="frame",
                          frames=result.diagnostics["frame"].to_numpy())
        d = d.drop(columns="defect").rename(columns={"track": "defect"})
        d = d[["frame", "time", "defect", "x", "y", "charge", "p"]]
    result.defects = d.reset_index(drop=True)
    return result


def _run(kind, psi_fn, alpha, n, steps, dt, seed, out, params, max_time, save_every, field_every,
         resume, progress, stop, meta, spacing):
    if max_time is not None and not (is_real(max_time) and max_time > 0):
        raise InputError(f"max_time must be a positive simulated time (or None: the default); got {max_time!r}")
    params = params if params is not None else default_params(alpha, dt)
    if params.alpha6 != alpha:
        raise InputError(f"params.alpha6 ({params.alpha6}) differs from alpha ({alpha})")
    solver = Solver(n, params)
    # before any work: refuse an unstable dt, warn (and record) outside the stable, active regime
    meta = dict(meta, stability=check_run(params, n, spacing))
    from pathlib import Path

    if resume and out is not None and (Path(out) / "checkpoint.npz").exists():
        state = None
        meta = dict(meta)
    else:
        psi, info = psi_fn(params)
        meta = dict(meta, **{k: v for k, v in info.items()})
        state = solver.state_from_fields(psi)
    if save_every is None:
        save_every = max(1, int(round(1.0 / params.dt)))
    result = integrate(solver, state, steps=steps, max_time=max_time if steps is None else None,
                       save_every=save_every, field_every=field_every, out=out, resume=resume,
                       stop=stop if steps is None else None, meta=dict(meta, kind=kind), progress=progress)
    box = Box(n * params.dx, n * params.dx)
    return _track(result, box, max_distance=5.0 * params.dx)


def run_dipole(alpha, n=256, distance=64.0, steps=None, dt=None, seed=0, out=None, params=None, disk=5.0,
               max_time=None, save_every=None, field_every=20, resume=False, progress=True, orientation=0.0):
    """Annihilation of a +1/6 / -1/6 pair (the paper's SI Fig. 2).

    Parameters
    ----------
    alpha : float
        Activity alpha6.
    n : int
        Grid size (dx = 1 by default).
    distance : float
        Initial separation (along x; +1/6 on the left).
    steps : int, optional
        Number of steps; None: run until the pair annihilates, capped at
        ``max_time`` (default ``4 distance^2``, several times the passive
        annihilation time ~ distance^2 / 4).
    dt : float, optional
        Time step (default that of :func:`default_params`).
    seed : int or Generator
        Random phases outside the fixed disks.
    out : path, optional
        zarr store (frame by frame, with checkpoint); ``resume=True`` continues it.
    params : HydroParams, optional
        Overrides the defaults (must have ``alpha6 == alpha``).
    disk : float
        Radius of the disks around the cores held fixed while relaxing.
    save_every : int, optional
        Steps between diagnostics (default: every unit of time).
    field_every : int
        Diagnostics between stored fields.
    orientation : float
        Far-field bond angle theta_inf in radians (Psi6 -> exp(6 i theta_inf)
        at infinity); 0: a bond direction along the pair axis.  The sign of
        the activity effect depends on it (docs/hydro.md).

    Before it starts, the run is checked (:func:`~hexatissue.hydro.stability.check_run`, with the
    half-separation ``distance / 2`` as the defect spacing): a ``dt`` beyond the scheme's stability limit
    at this alpha6 raises :class:`InputError` naming the limit; alpha6 outside the bulk stability window,
    or an active length ``sqrt(|alpha6| / L6)`` shorter than the spacing, warns
    (:class:`HexatissueWarning`).  The check is recorded in ``meta["stability"]``.

    Returns
    -------
    HydroResult
        ``.defects`` has columns frame, time, defect (trajectory id), x, y
        (x = column * dx, y = row * dx), charge, p; ``.annihilation_time``
        is the first diagnostic time with no defect (None if never).
    """
    check_positive(distance, "distance")  # before the stability check, which sees only distance / 2
    if max_time is None:
        max_time = 4.0 * distance**2

    def psi_fn(p):
        return dipole_initial(n, distance, disk, p, seed, orientation=orientation)

    def stop(scal, d):
        return scal["n_defects"] == 0

    return _run("dipole", psi_fn, alpha, n, steps, dt, seed, out, params, max_time, save_every, field_every,
                resume, progress, stop,
                {"distance": distance, "disk": disk, "seed": str(seed), "orientation": float(orientation)},
                distance / 2)


def run_quadrupole(alpha, n=256, ell=7.0, steps=None, dt=None, seed=0, out=None, params=None, disk=28.0,
                   max_time=2000.0, split_distance=None, save_every=None, field_every=20, resume=False,
                   progress=True, orientation=0.0):
    """Fate of a +-1/6 defect quadrupole (the continuum T1): annihilation or unbinding into two dipoles.

    -1/6 defects start at ``(c +- ell, c)``, +1/6 at ``(c, c +- ell)``,
    ``c = (n/2 - 1/2) dx``.  With ``steps=None`` the run stops when no defect
    is left (annihilation), when a defect gets farther than
    ``split_distance`` (default ``6 ell``) from the center (unbinding), or at
    ``max_time``.  Other parameters as in :func:`run_dipole`; the pre-run check uses ``ell`` as the
    defect spacing.

    Returns
    -------
    HydroResult
        As :func:`run_dipole`; ``meta["centre"]`` is the quadrupole center.
        Use :func:`departure_angle` on ``.defects`` for the direction of the
        departing dipoles.
    """
    c = (n / 2 - 0.5) * (params.dx if params is not None else 1.0)
    split = 6.0 * ell if split_distance is None else float(split_distance)

    def psi_fn(p):
        return quadrupole_initial(n, ell, disk, p, seed, orientation=orientation)

    def stop(scal, d):
        if scal["n_defects"] == 0:
            return True
        return bool(len(d)) and float(np.hypot(d["x"] - c, d["y"] - c).max()) > split

    return _run("quadrupole", psi_fn, alpha, n, steps, dt, seed, out, params, max_time, save_every,
                field_every, resume, progress, stop,
                {"ell": ell, "disk": disk, "seed": str(seed), "orientation": float(orientation)}, ell)


def departure_angle(defects, center, min_distance):
    """Direction in which defect pairs leave the center.

    At the last frame, each +1/6 defect is paired with its nearest -1/6 defect;
    the angle of every pair's midpoint seen from ``center`` is returned for the
    pairs farther than ``min_distance``.

    Returns
    -------
    ndarray
        Angles ``atan2(y - cy, x - cx)`` in radians (y = row, so with the image
        shown origin-lower the angle is counter-clockwise from +x).
    """
    last = defects[defects["frame"] == defects["frame"].max()]
    plus = last[last["charge"] > 0][["x", "y"]].to_numpy()
    minus = last[last["charge"] < 0][["x", "y"]].to_numpy()
    if not len(plus) or not len(minus):
        return np.zeros(0)
    d = np.linalg.norm(plus[:, None] - minus[None], axis=2)
    mid = (plus + minus[d.argmin(axis=1)]) / 2 - np.asarray(center)
    keep = np.hypot(mid[:, 0], mid[:, 1]) > min_distance
    return np.arctan2(mid[keep, 1], mid[keep, 0])
