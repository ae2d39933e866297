"""Tensions and pressures from the force balance (:func:`infer_forces`): least squares, or the Bayesian MAP
estimate with its prior weight chosen by ABIC and posterior standard deviations.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar
from scipy.sparse import csr_matrix, diags, identity
from scipy.sparse.csgraph import dijkstra

from ..errors import InputError, as_generator, is_real
from .solve import _EPS, _FREE, _PROBE_STEPS, _factor, _posterior_variance, _reasons
from .system import _frame_of, _min_image, force_system


#: Estimators of :func:`infer_forces`.
METHODS = ("lsq", "bayes")


# ABIC's search range, log10 mu.  Exact equations make ABIC fall toward mu = 0 until the residual |A x|^2 reaches
# round-off (near 1e-10 at the 1e-12 regularisation), where it turns up steeply: the lower end lets the estimate
# follow exact data (vertex model, 256 cells, exact vertices, three seeds: largest tension error 1e-5 - 1e-3 at
# mu = 1e-10, 1e-3 - 2e-2 at 1e-8).
_LOG_MU = (-10.0, 3.0)
#: The range of prior weights ABIC searches (:func:`infer_forces`); at its upper end the prior alone sets the
#: tensions (all near 1), and their posterior s.d. is the prior's, not a measurement.
MU_RANGE = (10.0 ** _LOG_MU[0], 10.0 ** _LOG_MU[1])


@dataclass
class Forces:
    """What :func:`infer_forces` found.

    Attributes
    ----------
    edges : pandas.DataFrame
        One row per junction of the ``edges`` table: ``frame``, ``edge``,
        ``tension`` (relative: the mean inferred interior tension is 1),
        ``tension_sd`` (posterior s.d., same unit; NaN for ``lsq``).
    cells : pandas.DataFrame
        One row per cell: ``frame``, ``cell``, ``pressure`` (tension/px;
        relative to the mean inferred pressure, which is 0), ``pressure_sd``
        (posterior s.d. of the pressure minus the mean pressure; NaN for
        ``lsq``).
    undetermined : pandas.DataFrame
        ``kind`` (``"edge"`` or ``"cell"``), ``id`` (edge or cell id) and
        ``reason`` of every interior junction and cell without an estimate
        from the force balance: ``"no polygon"``, ``"no balanced vertex"``
        (each of its vertices touches the outside, or a junction of zero
        length, or a cell without a polygon), ``"free"`` (the force balance leaves it free: more
        unknowns than independent equations, as on any open image or with
        four-fold vertices).  ``lsq``
        gives these NaN; ``bayes`` gives a ``free`` unknown its prior-dominated
        estimate and s.d.
    method : str
    mu : float
        The prior's weight (``bayes``; NaN for ``lsq``).
    abic : float
        ABIC at ``mu`` (``bayes``), up to a constant.
    residual : float
        RMS force imbalance at the balanced vertices, in units of the mean tension.
    n_equations, n_unknowns : int
    """

    edges: pd.DataFrame
    cells: pd.DataFrame
    undetermined: pd.DataFrame
    method: str
    mu: float
    abic: float
    residual: float
    n_equations: int
    n_unknowns: int


def infer_forces(cells, vertices, edges, cell_vertices, box=None, method="bayes", mu=None, sd=True,
                 seed=0, curvature=None, arcs=None, directions=None, vertex_sd=None, normals=None) -> Forces:
    """Tensions of the interior junctions and pressures of the interior cells of one frame, from force balance.

    The equations are those of :func:`force_system` (straight junctions).
    ``method="lsq"``: least squares ``min |A x|^2`` with the tension scale
    fixed, then normalised to mean tension 1.  ``method="bayes"``
    (Ishihara & Sugimura 2012): the MAP estimate with Gaussian force errors
    of variance ``s^2`` and a Gaussian prior ``T_j ~ N(1, s^2 / mu)`` on every
    tension (none on pressures), i.e. ``min |A x|^2 + mu |T - 1|^2``, with
    ``mu`` minimising ABIC (``s^2`` at its maximum-likelihood value); the
    tensions are then scaled to mean 1.  Pressures are shifted to mean 0 in
    both.  Exact equilibrium vertices give the exact forces with ``lsq``
    wherever they are determined (periodic tissues: everywhere).

    Parameters
    ----------
    cells, vertices, edges, cell_vertices : pandas.DataFrame
        One frame's tables (:mod:`hexatissue.schema`).
    box : Box, optional
        Periodic box; None for an open image.
    method : {"bayes", "lsq"}
    mu : float, optional
        The prior's weight (``bayes``) in the units of ``|A x|^2`` (a
        tension's coefficients are unit vectors); default: chosen by ABIC.
    sd : bool
        Compute the posterior standard deviations (``bayes``; one solve per
        unknown, the slow part on large frames).
    seed : int or numpy.random.Generator
        Seed of the random probes that find the free unknowns.
    curvature : ndarray, optional
        Per row of ``edges``: signed junction curvature, 1/px
        (:func:`hexatissue.mechanics.curvature.junction_curvature`): the
        junctions are then circular arcs, balanced by their tangents at the
        vertices and by Young-Laplace across them (:func:`force_system`).
        None: straight junctions.
    arcs, directions : ndarray, optional
        Which junctions are arcs (with ``curvature``; None: all) and the
        directions of the straight ones (None: their chords); see
        :func:`force_system`.
    vertex_sd : float, optional
        S.d. of each vertex coordinate, px (e.g. from rounding to pixels).
        It bounds the force error below: a junction of length ``l`` whose
        ends move by it turns by ``sqrt(2) vertex_sd / l``, so each balance
        equation has an error variance of at least ``vertex_sd^2 sum_j 1 /
        l_j^2`` (junctions at the vertex, tensions near 1), averaged over the
        balanced vertices; the posterior s.d. use the larger of that and the
        fitted ``s^2``.  None: the fitted ``s^2`` alone.  A square periodic
        network meets its equations whatever its vertices' errors, so its
        fitted ``s^2`` says nothing about them.  ``l_j`` is the junction's
        length in the image (the vertices are found there), also on a surface.
    normals : ndarray (n_vertices, 3), optional
        The surface's unit normal at every vertex, with ``vertices["z"]``:
        each vertex balanced in its tangent plane (:func:`force_system`);
        not with ``curvature``.  None: the image plane.

    Returns
    -------
    Forces
        ``edges``: ``frame``, ``edge``, ``tension`` (relative, mean interior
        tension = 1), ``tension_sd`` (same unit); ``cells``: ``frame``,
        ``cell``, ``pressure`` (tension/px, mean 0), ``pressure_sd``
        (tension/px); NaN where there is no estimate, with the reason in
        ``undetermined`` (see :class:`Forces`).
    """
    if method not in METHODS:
        raise InputError(f"method must be one of {METHODS}; got {method!r}")
    if mu is not None and not (is_real(mu) and mu > 0):
        raise InputError(f"mu must be a positive finite number or None; got {mu!r}")
    if vertex_sd is not None and not (is_real(vertex_sd) and vertex_sd >= 0):
        raise InputError(f"vertex_sd must be a non-negative finite number or None; got {vertex_sd!r}")
    frame = _frame_of(cells, "cells")
    system = force_system(cells, vertices, edges, cell_vertices, box, curvature, arcs, directions, normals)
    A = system.matrix
    n_t, n_p = len(system.edge_rows), len(system.cell_rows)
    n = n_t + n_p
    tension = np.full(len(edges), np.nan)
    tension_sd = np.full(len(edges), np.nan)
    pressure = np.full(len(cells), np.nan)
    pressure_sd = np.full(len(cells), np.nan)
    free = np.zeros(n, bool)
    mu_used = abic = residual = np.nan
    if len(system.vertex_rows) and n_p:
        vpos = pd.Index(vertices["vertex"].to_numpy(np.int64))
        va = vpos.get_indexer(edges["vertex_a"].to_numpy(np.int64))
        vb = vpos.get_indexer(edges["vertex_b"].to_numpy(np.int64))
        pcol = np.full(len(cells), -1, np.int64)
        pcol[system.cell_rows] = np.arange(n_p)
        cv_row = pcol[pd.Index(cells["cell"].to_numpy(np.int64)).get_indexer(cell_vertices["cell"].to_numpy(np.int64))]
        cv_v = vpos.get_indexer(cell_vertices["vertex"].to_numpy(np.int64))
        keep = cv_row >= 0
        nv = len(vpos)
        graph = csr_matrix((np.ones(len(va)), (va, vb)), shape=(nv, nv))
        sources = np.flatnonzero(~system.balanced)
        depth = (dijkstra(graph, directed=False, indices=sources, min_only=True, unweighted=True) if len(sources)
                 else np.zeros(nv))
        depth = np.where(np.isfinite(depth), depth, 0.0)
        t_ref = int(np.argmax(np.minimum(depth[va[system.edge_rows]], depth[vb[system.edge_rows]])))
        p_depth = np.full(n_p, np.inf)
        np.minimum.at(p_depth, cv_row[keep], depth[cv_v[keep]])
        p_ref = n_t + int(np.argmax(p_depth))

        # unit diagonal: the equations weigh tensions and pressures (px-sized coefficients) alike
        G = (A.T @ A).tocsr()
        scale = 1.0 / np.sqrt(np.maximum(G.diagonal(), 1e-300))
        S = diags(scale)
        Gs = (S @ G @ S).tocsr()
        pin_p = np.zeros(n)
        pin_p[p_ref] = 1.0  # fixes the pressure constant
        base = Gs + diags(pin_p)
        pinned = pin_p.copy()
        pinned[t_ref] = 1.0  # and the tension scale
        lu = _factor(base + diags(pinned - pin_p) + _EPS * identity(n), unrelaxed=method == "bayes")

        # least squares with the mean tension fixed, min |A x|^2 at c.x = 1, is proportional to G+^-1 c for G+ =
        # G with the pressure pinned; with the tension pinned too (M = G+ + e e'), Sherman-Morrison gives
        # G+^-1 c ~ (1 - e'M^-1 e) M^-1 c + (e'M^-1 c) M^-1 e, bounded even where G+ is singular (exact forces).
        # The Bayesian estimate uses the pinned factor for the probes below only.
        if method == "lsq":
            As = A @ S

            def solve(rhs):
                """M^-1 rhs (columns), refined with the residual of A itself: the long-wavelength stress modes make
                A ill-conditioned, and its normal equations square that."""
                y = lu.solve(rhs)
                for _ in range(2):
                    y = y + lu.solve(rhs - As.T @ (As @ y) - pinned[:, None] * y)
                return y

            c = np.r_[scale[:n_t], np.zeros(n_p)]
            e = np.zeros(n)
            e[t_ref] = 1.0
            m_e, m_c = solve(np.stack([e, c], axis=1)).T
            x_lsq = (1.0 - m_e[t_ref]) * m_c + m_c[t_ref] * m_e
        # the null modes of the pinned equations (beyond scale and pressure constant), probed at random: the
        # regularisation keeps them at O(1), every determined unknown at O(eps / eigenvalue)
        # Every network is probed, also one whose count of equations leaves no free mode: a regular lattice has
        # exact null modes beyond the count (the periodic hexagonal lattice: least squares gave tensions of -9 to
        # +38 with zero residual).  Twelve steps shrink the softest determined modes of a 10,000-cell tissue
        # (eigenvalues ~3e-12) below 1e-7 while null modes keep O(1).
        probe = as_generator(seed).standard_normal((n, 2))
        for _ in range(_PROBE_STEPS):
            probe = _EPS * lu.solve(probe)
        free = np.abs(probe).max(axis=1) > _FREE
        # the anchors pass the test by construction: alone, they are no estimate (a ratio of a value to itself)
        for block in (slice(0, n_t), slice(n_t, n)):
            if np.count_nonzero(~free[block]) <= 1:
                free[block] = True
        if method == "lsq":
            x = scale * x_lsq
        else:
            prior = diags(np.r_[scale[:n_t] ** 2, np.zeros(n_p)])
            rhs = np.r_[scale[:n_t], np.zeros(n_p)]
            n_dof = A.shape[0] + n_t - (n - 1)

            lowest = {}  # the search's best solve, returned again for the chosen mu instead of factorised anew

            def solve(m):
                if lowest.get("mu") == m:
                    return lowest["out"]
                f = _factor(base + m * prior + _EPS * identity(n))
                xs = f.solve(m * rhs)
                xx = scale * xs
                s2 = float(np.sum((A @ xx) ** 2) + m * np.sum((xx[:n_t] - 1.0) ** 2))
                logdet = float(np.sum(np.log(np.abs(f.U.diagonal()))))
                out = f, xx, s2, n_dof * np.log(max(s2, 1e-300)) - n_t * np.log(m) + logdet
                if mu is None and out[3] < lowest.get("out", (None,) * 3 + (np.inf,))[3]:
                    lowest.update(mu=m, out=out)
                return out

            if mu is None:
                grid = np.arange(_LOG_MU[0], _LOG_MU[1] + 0.01, 1.0)
                values = [solve(10.0 ** g)[3] for g in grid]
                k = int(np.argmin(values))
                lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
                best = minimize_scalar(lambda g: solve(10.0 ** g)[3], bounds=(lo, hi), method="bounded",
                                       options={"xatol": 0.02})
                mu = 10.0 ** float(best.x if best.fun < values[k] else grid[k])
            f, x, s2, abic = solve(mu)
            mu_used = float(mu)
            if sd:
                noise = s2 / max(n_dof, 1)
                if vertex_sd is not None:
                    ends = (system.balanced[va[system.edge_rows]].astype(float)
                                            + system.balanced[vb[system.edge_rows]])
                    lengths = np.hypot(*(_min_image(vertices[["x", "y"]].to_numpy(float)[vb[system.edge_rows]]
                                                    - vertices[["x", "y"]].to_numpy(float)[va[system.edge_rows]],
                                                    box)).T)
                    floor = vertex_sd ** 2 * np.sum(ends / np.maximum(lengths, 1e-12) ** 2) / len(system.vertex_rows)
                    noise = max(noise, floor)
                var = _posterior_variance(f, scale, n_t, n_p) * noise
        t = x[:n_t]
        determined_t = ~free[:n_t] if method == "lsq" else np.ones(n_t, bool)
        unit = float(np.mean(t[determined_t])) if determined_t.any() else np.nan
        x = x / unit
        p = x[n_t:]
        determined_p = ~free[n_t:] if method == "lsq" else np.ones(n_p, bool)
        p = p - (np.mean(p[determined_p]) if determined_p.any() else np.nan)
        residual = float(np.sqrt(np.mean((A @ np.r_[x[:n_t], p]) ** 2)))
        tension[system.edge_rows] = np.where(determined_t, x[:n_t], np.nan)
        pressure[system.cell_rows] = np.where(determined_p, p, np.nan)
        if method == "bayes" and sd:
            tension_sd[system.edge_rows] = np.sqrt(var[:n_t]) / abs(unit)
            pressure_sd[system.cell_rows] = np.sqrt(var[n_t:]) / abs(unit)
    undetermined = _reasons(cells, edges, system, free, n_t)
    return Forces(
        edges=pd.DataFrame({"frame": frame, "edge": edges["edge"].to_numpy(np.int64), "tension": tension,
                            "tension_sd": tension_sd}),
        cells=pd.DataFrame({"frame": frame, "cell": cells["cell"].to_numpy(np.int64), "pressure": pressure,
                            "pressure_sd": pressure_sd}),
        undetermined=undetermined, method=method, mu=mu_used, abic=float(abic), residual=residual,
        n_equations=int(A.shape[0]), n_unknowns=int(n))
