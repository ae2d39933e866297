"""Force inference from the junction network: junction tensions, cell pressures, and the stress they make.

At mechanical equilibrium every vertex of the network is at force balance
(Ishihara & Sugimura, J. Theor. Biol. 313, 201, 2012; Chiou et al., PLoS
Comput. Biol. 8, e1002512, 2012).  With straight junctions, the force on
vertex ``v`` is

    F_v = sum_j T_j u_j + sum_c P_c dA_c/dx_v = 0,

the sum over the junctions ``j`` meeting at ``v`` (``u_j`` the unit vector
from ``v`` along ``j``) and the cells ``c`` around it (``dA_c/dx_v =
(y_next - y_prev, x_prev - x_next) / 2`` for the counter-clockwise polygon).
This is minus the gradient of ``E = sum_j T_j l_j - sum_c P_c A_c``.  The
equations of the vertices that lie wholly inside the tissue (no cell 0
around them) form a sparse linear system ``A x = 0`` in the unknown
tensions and pressures (:func:`force_system`), homogeneous: tensions are
known up to a scale (fixed here by mean tension = 1) and pressures up to a
constant (fixed by mean pressure = 0).  :func:`infer_forces` solves it by
least squares (``method="lsq"``) or as the Bayesian MAP estimate with a
Gaussian prior on the tensions whose weight is chosen by ABIC
(``method="bayes"``), with posterior standard deviations.  Where the
equations leave unknowns free (open images: the vertices on the tissue's edge
give no equation but their junctions and cells are unknowns; four-fold
vertices), those are found and reported, never given a silent number
(:func:`infer_forces`); the free modes are extended, so on an open image
least squares determines nothing and only the Bayesian prior makes an
estimate (docs/mechanics.md).  Curved junctions (Young-Laplace; the
``curvature`` argument, measured by :mod:`hexatissue.mechanics.curvature`):
the vertices are balanced by the tensions along the arcs' end tangents, and
each junction's curvature ties the pressure difference across it to its
tension (:func:`force_system`); the vertices then set the tensions on their
own, and open images are determined.  :func:`frame_forces`, what the stage
runs, chooses between the two from the junctions' own pixels
(:func:`hexatissue.mechanics.curvature.junction_shapes`).
:mod:`hexatissue.mechanics.stress` turns
the forces into the Batchelor stress of each cell, of the tissue and on the
Gamma_p grid.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar
from scipy.sparse import csc_matrix, csr_matrix, diags, identity
from scipy.sparse.csgraph import dijkstra
from scipy.sparse.linalg import splu

from ..errors import InputError, as_generator, is_real
from ..schema import require_columns
from .curvature import junction_curvature, junction_shapes
from .history import t1_tension_histories
from .stress import cell_stress, stress_grid, tissue_stress

__all__ = ["ForceSystem", "Forces", "force_system", "infer_forces", "frame_forces", "JUNCTION_MODELS", "MU_RANGE",
           "cell_stress", "tissue_stress", "stress_grid",
           "junction_curvature", "t1_tension_histories", "METHODS"]

#: Estimators of :func:`infer_forces`.
METHODS = ("lsq", "bayes")
#: Junction models of :func:`frame_forces`.
JUNCTION_MODELS = ("auto", "straight", "curved")
# Relative regularisation of the normal equations: it lifts the null modes (so one factorisation serves the solve
# and the test of which unknowns are determined) and biases the determined ones by ~1e-10 only.
_EPS = 1e-12
# The free unknowns: a random vector multiplied _PROBE_STEPS times by eps M^-1 keeps its null-mode part and loses
# a factor eps / (eps + lambda) of every other mode each time (lambda, an eigenvalue of the pinned, unit-diagonal
# normal equations).  A component above _FREE marks a free unknown: null modes give O(1e-3 - 1), a mode with
# lambda = 3e-12 gives 6e-8 after twelve steps.
_PROBE_STEPS = 12
_FREE = 1e-6
# SuperLU's supernode relaxation and panel width for the pinned factor (its defaults: 10 and 20); see _factor
_RELAX, _PANEL = 1, 12
_SD_BLOCK = 256  # right-hand sides per solve when the posterior variances are computed
# Weight of the Young-Laplace rows against the vertex rows (both in force units).  A junction's curvature is a
# second derivative of its shape, measured less well than the tangents at its ends; a small weight lets the
# vertices set the tensions and the curvatures the pressures (the two-stage estimate is the limit of a vanishing
# weight, reached by 0.1: on the Surface Evolver tissue 0.1 and 0.01 give the same errors to 3 digits, 1 doubles
# the tension error; docs/mechanics.md).  Exact equations are met at any weight.
_LAPLACE_WEIGHT = 0.1
# ABIC's search range, log10 mu.  Exact equations make ABIC fall toward mu = 0 until the residual |A x|^2 reaches
# round-off (near 1e-10 at the 1e-12 regularisation), where it turns up steeply: the lower end lets the estimate
# follow exact data (vertex model, 256 cells, exact vertices, three seeds: largest tension error 1e-5 - 1e-3 at
# mu = 1e-10, 1e-3 - 2e-2 at 1e-8).
_LOG_MU = (-10.0, 3.0)
#: The range of prior weights ABIC searches (:func:`infer_forces`); at its upper end the prior alone sets the
#: tensions (all near 1), and their posterior s.d. is the prior's, not a measurement.
MU_RANGE = (10.0 ** _LOG_MU[0], 10.0 ** _LOG_MU[1])
# frame_forces, junctions="auto": arcs when more than this share of the tested junctions show a curvature.  Measured
# shares: Surface Evolver foam drawn at 4 px per unit 0.78; vertex-model sheets (straight junctions) 0.00-0.01
# clean, 0.13 (20 px per cell) and 0.24 (40 px) with boundary noise of 0.5 px.
_CURVED_SHARE = 0.5
# frame_forces: s.d. of a vertex coordinate found in a label image, px (the mesh's sub-pixel vertices: median distance
# to the truth 0.21-0.33 px on rendered vertex models, 0.25 px on Voronoi labels, i.e. about 0.2 px per axis).  It
# floors the posterior s.d. where the balance is met exactly (infer_forces, vertex_sd); on the benchmark's clean
# sheets (seed 0) the fitted noise is 1.4-2.4 x the floor, and benchmarks/results_forces.md is the same without it.
_VERTEX_SD = 0.2


@dataclass
class ForceSystem:
    """The force-balance equations of one frame (:func:`force_system`).

    Attributes
    ----------
    matrix : scipy.sparse.csr_matrix
        ``(2 n_vertices [+ n_laplace], n_edges + n_cells)``: rows x then y of
        each balanced vertex (then, for curved junctions, one Young-Laplace
        row per junction between two cells); columns the tensions, then the
        pressures.
    edge_rows, cell_rows, vertex_rows : ndarray of int
        Rows of the ``edges``, ``cells`` and ``vertices`` tables of the
        unknown tensions, the unknown pressures and the balanced vertices.
    balanced : ndarray of bool
        Per row of ``vertices``: the vertex's force balance is an equation.
    """

    matrix: csr_matrix
    edge_rows: np.ndarray
    cell_rows: np.ndarray
    vertex_rows: np.ndarray
    balanced: np.ndarray


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


def _frame_of(table, name):
    frames = np.unique(table["frame"].to_numpy()) if "frame" in table.columns else np.zeros(1, int)
    if len(frames) > 1:
        raise InputError(f"{name} must hold one frame; got frames {frames[:5].tolist()}...")
    return int(frames[0]) if len(frames) else 0


def _min_image(d, box):
    return d if box is None else box.min_image(d)


def _cycle_neighbours(cell, rank):
    """For rows of cell_vertices: the rows of the previous and next vertex in the same cell's polygon."""
    order = np.lexsort((rank, cell))
    c = cell[order]
    n = len(c)
    start = np.r_[True, c[1:] != c[:-1]] if n else np.zeros(0, bool)
    first = np.maximum.accumulate(np.where(start, np.arange(n), 0))
    end = np.r_[start[1:], True] if n else np.zeros(0, bool)
    last = np.zeros(n, np.int64)
    last_idx = np.flatnonzero(end)
    last[:] = np.repeat(last_idx, np.diff(np.r_[0, last_idx + 1]))
    nxt_sorted = np.where(end, first, np.arange(n) + 1)
    prv_sorted = np.where(start, last, np.arange(n) - 1)
    prev, nxt = np.empty(n, np.int64), np.empty(n, np.int64)
    prev[order], nxt[order] = order[prv_sorted], order[nxt_sorted]
    return prev, nxt


def force_system(cells, vertices, edges, cell_vertices, box=None, curvature=None, arcs=None,
                 directions=None) -> ForceSystem:
    """The force balance of every vertex inside the tissue, as a sparse matrix in the tensions and pressures.

    Straight junctions (``curvature`` None): the equations of the module
    docstring.  Curved junctions (``curvature`` given): each junction is the
    circular arc of signed curvature ``kappa`` through its end vertices
    (:mod:`hexatissue.mechanics.curvature`), of half-angle ``psi = asin(kappa
    c / 2)`` (``c`` its chord).  A vertex is then balanced by the tensions
    alone, each along the arc's tangent at the vertex (the chord turned by
    ``-psi`` at ``vertex_a``, by ``+psi`` at ``vertex_b``): ``sum_j T_j t_j =
    0``; and every junction between two cells with a balanced end adds the
    Young-Laplace equation in force units, ``(P_left - P_right) c / 2 - T
    sin psi = 0`` (``left`` of the direction a -> b), weighted 0.1 against
    the vertex rows, which is what places the pressures.  Both forms are exact for their model: straight junctions with
    the pressure pushing on the chords (a vertex model), or free arcs.

    A vertex is balanced (gives two equations) when it touches no outside
    (``is_border`` False), joins two or more junctions of non-zero length,
    and has as many cells with a polygon around it (``cell_vertices``) as
    junctions.  The unknowns are the tensions of the junctions with a
    balanced end and the pressures of the cells with a balanced vertex.

    Parameters
    ----------
    cells, vertices, edges, cell_vertices : pandas.DataFrame
        One frame's tables (:mod:`hexatissue.schema`; positions in px,
        polygons counter-clockwise in x, y as the mesh makes them).
    box : Box, optional
        Periodic box (displacements by minimum image); None for an open image.
    curvature : ndarray, optional
        Per row of ``edges``: the junction's signed curvature, 1/px
        (:func:`hexatissue.mechanics.curvature.junction_curvature`); None
        for straight junctions with the pressure terms at the vertices.
    arcs : ndarray of bool, optional
        With ``curvature``: per row of ``edges``, the junction is an arc
        (True) or straight (False: its tension along its direction, the
        pressures pushing on it at its ends, no Young-Laplace row).  The two
        forms put the same force on a vertex (an arc's tension along its
        tangent is its tension ``cos psi`` along the chord plus the pressure
        difference's push), so a network may mix them.  None: every junction
        an arc.
    directions : ndarray (n_edges, 2), optional
        Per row of ``edges``: the direction (x, y) of a straight junction
        from ``vertex_a`` to ``vertex_b``, e.g. of the line fitted to its
        pixels (:func:`hexatissue.mechanics.curvature.junction_shapes`);
        NaN rows and None: the chord between the end vertices.

    Returns
    -------
    ForceSystem
    """
    require_columns(cells, ("cell", "n_sides"), "cells")
    require_columns(vertices, ("vertex", "x", "y"), "vertices")
    require_columns(edges, ("edge", "vertex_a", "vertex_b", "cell_a", "cell_b"), "edges")
    require_columns(cell_vertices, ("cell", "rank", "vertex"), "cell_vertices")
    vid = vertices["vertex"].to_numpy(np.int64)
    vpos = pd.Index(vid)
    xy = vertices[["x", "y"]].to_numpy(float)
    nv = len(vid)
    va = vpos.get_indexer(edges["vertex_a"].to_numpy(np.int64))
    vb = vpos.get_indexer(edges["vertex_b"].to_numpy(np.int64))
    if (va < 0).any() or (vb < 0).any():
        raise InputError("edges names vertices that are not in vertices")
    d = _min_image(xy[vb] - xy[va], box)
    length = np.hypot(d[:, 0], d[:, 1])
    cid = cells["cell"].to_numpy(np.int64)
    has_polygon = cells["n_sides"].to_numpy(np.int64) >= 3
    if "polygon_area" in cells.columns:
        has_polygon &= np.isfinite(cells["polygon_area"].to_numpy(float))
    cv_cell = cell_vertices["cell"].to_numpy(np.int64)
    cv_row = pd.Index(cid).get_indexer(cv_cell)
    cv_v = vpos.get_indexer(cell_vertices["vertex"].to_numpy(np.int64))
    if (cv_v < 0).any() or (cv_row < 0).any():
        raise InputError("cell_vertices names cells or vertices that are not in cells and vertices")

    junctions = np.bincount(np.r_[va, vb], minlength=nv)
    short = np.bincount(np.r_[va, vb], weights=np.r_[length, length] <= 0, minlength=nv) > 0
    around = np.bincount(cv_v, weights=has_polygon[cv_row], minlength=nv)
    balanced = (junctions >= 2) & ~short & (around == junctions)
    if "is_border" in vertices.columns:
        balanced &= ~vertices["is_border"].to_numpy(bool)
    # the outside (cell 0) has no pressure: a vertex on it is not balanced even when is_border is absent
    outside = ((edges["cell_a"].to_numpy() == 0) | (edges["cell_b"].to_numpy() == 0)).astype(float)
    balanced &= np.bincount(np.r_[va, vb], weights=np.r_[outside, outside], minlength=nv) == 0
    vrow = np.full(nv, -1, np.int64)
    vertex_rows = np.flatnonzero(balanced)
    vrow[vertex_rows] = np.arange(len(vertex_rows))

    t_edge = np.flatnonzero(balanced[va] | balanced[vb])
    u = d[t_edge] / length[t_edge, None]
    if directions is not None:
        dirs = np.asarray(directions, float)
        if dirs.shape != (len(edges), 2):
            raise InputError(f"directions must hold one (x, y) unit vector per row of edges ({len(edges)}); got "
                             f"shape {dirs.shape}")
        given = np.isfinite(dirs[t_edge]).all(axis=1)
        norm = np.hypot(dirs[t_edge, 0], dirs[t_edge, 1])
        u = np.where(given[:, None], dirs[t_edge] / np.where(given & (norm > 0), norm, 1.0)[:, None], u)
    arc = np.zeros(len(t_edge), bool)
    if curvature is not None:
        kappa = np.asarray(curvature, float)
        if kappa.shape != (len(edges),) or not np.isfinite(kappa[t_edge]).all():
            raise InputError(f"curvature must hold one finite value per row of edges ({len(edges)}); got shape "
                             f"{kappa.shape}" + ("" if kappa.shape != (len(edges),) else " with non-finite values"))
        if arcs is None:
            arc[:] = True
        else:
            arcs = np.asarray(arcs, bool)
            if arcs.shape != (len(edges),):
                raise InputError(f"arcs must hold one bool per row of edges ({len(edges)}); got shape {arcs.shape}")
            arc = arcs[t_edge].copy()
        sin_psi = np.where(arc, np.clip(kappa[t_edge] * length[t_edge] / 2, -1.0, 1.0), 0.0)
        cos_psi = np.sqrt(1.0 - sin_psi ** 2)
    rows, cols, vals = [], [], []
    for end, sign in ((va[t_edge], 1.0), (vb[t_edge], -1.0)):
        keep = balanced[end]
        col = np.flatnonzero(keep)
        r = vrow[end[keep]]
        ux, uy = sign * u[keep, 0], sign * u[keep, 1]
        if arc.any():  # the tangent of an arc: the chord turned by -psi at vertex_a, +psi at vertex_b
            chord = sign * d[t_edge][keep] / length[t_edge][keep, None]
            sn, cs = -sign * sin_psi[keep], cos_psi[keep]
            on_arc = arc[keep]
            ux = np.where(on_arc, cs * chord[:, 0] - sn * chord[:, 1], ux)
            uy = np.where(on_arc, sn * chord[:, 0] + cs * chord[:, 1], uy)
        rows += [2 * r, 2 * r + 1]
        cols += [col, col]
        vals += [ux, uy]

    prev, nxt = _cycle_neighbours(cv_cell, cell_vertices["rank"].to_numpy(np.int64))
    n_rows = 2 * len(vertex_rows)
    pcol = np.full(len(cid), -1, np.int64)
    p_cell = np.zeros(0, np.int64)
    if not arc.all():
        # straight junctions: the pressures push on the vertices through the polygons' sides (dA_c / dx_v)
        at = balanced[cv_v]
        p_cell = np.unique(cv_row[at])
    if arc.any():
        # the cell on the left of a -> b: the one whose counter-clockwise polygon goes from vertex_a to vertex_b
        step = pd.DataFrame({"v": cv_v, "w": cv_v[nxt], "cell": cv_row})
        step = step[has_polygon[cv_row]].drop_duplicates(["v", "w"])
        ends = pd.DataFrame({"v": va[t_edge], "w": vb[t_edge]})
        left = ends.merge(step, on=["v", "w"], how="left")["cell"].to_numpy(float)
        right = ends.rename(columns={"v": "w", "w": "v"}).merge(step, on=["v", "w"], how="left")["cell"].to_numpy(
            float)
        inner = np.isfinite(left) & np.isfinite(right) & arc
        ca, cb = edges["cell_a"].to_numpy()[t_edge], edges["cell_b"].to_numpy()[t_edge]
        inner &= (ca != 0) & (cb != 0)
        j = np.flatnonzero(inner)
        lc, rc = left[j].astype(np.int64), right[j].astype(np.int64)
        p_cell = np.unique(np.r_[p_cell, lc, rc])
    pcol[p_cell] = len(t_edge) + np.arange(len(p_cell))
    if not arc.all():
        k = np.flatnonzero(balanced[cv_v])
        here = xy[cv_v[k]]
        chord = _min_image(xy[cv_v[nxt[k]]] - here, box) - _min_image(xy[cv_v[prev[k]]] - here, box)
        r = vrow[cv_v[k]]
        rows += [2 * r, 2 * r + 1]
        cols += [pcol[cv_row[k]], pcol[cv_row[k]]]
        vals += [0.5 * chord[:, 1], -0.5 * chord[:, 0]]
        if arc.any():
            # an arc carries the pressure difference across it itself (Young-Laplace): its share of the polygons'
            # push, 0.5 (P_left - P_right) (d_y, -d_x) at each end, is taken back out
            dj = d[t_edge[j]]
            for end in (va[t_edge[j]], vb[t_edge[j]]):
                keep = balanced[end]
                r = vrow[end[keep]]
                for cell, sign in ((lc[keep], -1.0), (rc[keep], 1.0)):
                    rows += [2 * r, 2 * r + 1]
                    cols += [pcol[cell], pcol[cell]]
                    vals += [sign * 0.5 * dj[keep, 1], -sign * 0.5 * dj[keep, 0]]
    if arc.any():
        r = n_rows + np.arange(len(j))
        half = 0.5 * length[t_edge[j]]
        rows += [r, r, r]
        cols += [j, pcol[lc], pcol[rc]]
        vals += [_LAPLACE_WEIGHT * -sin_psi[j], _LAPLACE_WEIGHT * half, -_LAPLACE_WEIGHT * half]
        n_rows += len(j)
    matrix = csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                        shape=(n_rows, len(t_edge) + len(p_cell)))
    return ForceSystem(matrix, t_edge, p_cell, vertex_rows, balanced)


def _factor(matrix, unrelaxed=False):
    """Sparse LU of a symmetric positive definite matrix: minimum degree on its pattern, pivots on the diagonal.

    Diagonal pivots keep the symmetric ordering (the default partial pivoting
    fills a 2,500-cell system 15 x more and takes 40 x longer).
    ``unrelaxed``: supernodes are not relaxed (``relax=1``, panels of 12
    columns): the zeros a relaxed supernode stores cost more than its denser
    blocks save on these balance equations (the factorisation alone of the
    10,000-cell benchmark tissue, alternated with the defaults: 13-28 % less
    time; the whole estimate: benchmarks/results_mechanics.md).  Only the factor whose
    solves give nothing but the free-unknown test (the Bayesian estimate's
    pinned factor) is made so: the other solves round differently with
    another partition into supernodes, and the estimates on the softest modes
    follow the rounding (least squares moved by 6e-8; near its minimum ABIC is
    flat down to the rounding of the log-determinant, and its mu moved by 2e-4,
    relative, on a 10,000-cell tissue).  Should a diagonal pivot vanish, the
    factorisation is redone with partial pivoting.
    """
    matrix = csc_matrix(matrix)
    tuning = {"relax": _RELAX, "panel_size": _PANEL} if unrelaxed else {}
    try:
        return splu(matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True},
                    **tuning)
    except RuntimeError:
        return splu(matrix, permc_spec="COLAMD")


def infer_forces(cells, vertices, edges, cell_vertices, box=None, method="bayes", mu=None, sd=True,
                 seed=0, curvature=None, arcs=None, directions=None, vertex_sd=None) -> Forces:
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
        fitted ``s^2`` says nothing about them.

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
    system = force_system(cells, vertices, edges, cell_vertices, box, curvature, arcs, directions)
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


def frame_forces(labels, cells, vertices, edges, cell_vertices, box=None, junctions="auto", method="bayes", mu=None,
                 sd=True):
    """Forces of one frame with the junction model chosen from its pixels: what the mechanics stage runs.

    ``junctions="auto"``: every interior junction with at least 4 pixel
    points is tested on its own pixels
    (:func:`hexatissue.mechanics.curvature.junction_shapes`: a parabola
    against a line, by the drop of the residual over the pixel noise).  When
    more than half of them show a curvature (``_CURVED_SHARE``), the tissue is
    a foam of arcs: every junction is an arc through its end vertices
    (tangent forces and Young-Laplace); else every junction is straight,
    with the pressures pushing on the vertices (the vertex model).  With
    pixels, the posterior s.d. are floored by vertices known to 0.2 px per
    axis (:func:`infer_forces`, ``vertex_sd``).  The
    choice is made per frame, not per junction: a network mixing the two
    forms is exact for exact shapes (:func:`force_system`, ``arcs``) but, with
    the curvatures of a few junctions only, ill-conditioned: measured on the
    Surface Evolver foam with 68 % of the junctions as arcs, tension r = 0.05
    (0.985 with all of them), and on a vertex-model sheet with boundary noise
    0.07 (0.61 straight; benchmarks/results_forces.md).  ``"straight"``,
    ``"curved"``: that model for every junction.  ``labels`` None (polygon
    input): straight.

    Parameters
    ----------
    labels : ndarray (H, W) of int or None
        The frame's touching cell labels (``Frame.labels``).
    cells, vertices, edges, cell_vertices : pandas.DataFrame
    box : Box, optional
    junctions : {"auto", "straight", "curved"}
    method, mu, sd
        As :func:`infer_forces`.

    Returns
    -------
    forces : Forces
    curvature : ndarray
        Per row of ``edges``: the curvature of the arcs, 1/px; 0 for
        straight junctions.
    model : str
        The model used: ``"straight"`` or ``"curved"``.
    curved_share : float
        The share of the tested junctions whose pixels show a curvature (NaN
        when none was tested: ``"straight"``, ``"curved"``, no pixels).
    """
    if junctions not in JUNCTION_MODELS:
        raise InputError(f"junctions must be one of {JUNCTION_MODELS}; got {junctions!r}")
    pixels = labels is not None and isinstance(labels, np.ndarray) and labels.ndim == 2
    model, share = ("straight" if junctions == "auto" or not pixels else junctions), np.nan
    if pixels and junctions == "auto":
        shapes = junction_shapes(labels, vertices, edges, box)
        tested = ((edges["cell_a"].to_numpy() != 0) & (edges["cell_b"].to_numpy() != 0)
                  & (shapes["n_points"].to_numpy() >= 4))
        if tested.any():
            share = float(shapes["curved"].to_numpy(bool)[tested].mean())
            model = "curved" if share > _CURVED_SHARE else "straight"
    curvature = junction_curvature(labels, vertices, edges, box) if model == "curved" else None
    forces = infer_forces(cells, vertices, edges, cell_vertices, box=box, method=method, mu=mu, sd=sd,
                          curvature=curvature, vertex_sd=_VERTEX_SD if pixels else None)
    return forces, (np.zeros(len(edges)) if curvature is None else curvature), model, share


def _posterior_variance(factor, scale, n_t, n_p):
    """Diagonal of the posterior covariance (up to ``s^2``), pressures taken relative to their mean.

    The factor pins one pressure (the gauge of the solve); the variance of
    ``P_c - mean(P)`` does not depend on that choice: ``C_cc - 2 (C 1)_c / n
    + 1'C1 / n^2`` on the pressure block.
    """
    n = n_t + n_p
    var = np.empty(n)
    for start in range(0, n, _SD_BLOCK):
        stop = min(start + _SD_BLOCK, n)
        rhs = np.zeros((n, stop - start))
        rhs[np.arange(start, stop), np.arange(stop - start)] = 1.0
        var[start:stop] = factor.solve(rhs)[np.arange(start, stop), np.arange(stop - start)]
    var *= scale ** 2
    ones = np.r_[np.zeros(n_t), scale[n_t:]]
    row = scale[n_t:] * factor.solve(ones)[n_t:]  # (C 1)_c over the pressures
    var[n_t:] += -2.0 * row / n_p + row.sum() / n_p ** 2
    return np.maximum(var, 0.0)


def _reasons(cells, edges, system, free, n_t):
    """The interior junctions and cells without an estimate from the force balance, and why."""
    kinds, ids, reasons = [], [], []
    cid = cells["cell"].to_numpy(np.int64)
    has_polygon = cells["n_sides"].to_numpy(np.int64) >= 3
    if "polygon_area" in cells.columns:
        has_polygon &= np.isfinite(cells["polygon_area"].to_numpy(float))
    unknown_cell = np.zeros(len(cid), bool)
    unknown_cell[system.cell_rows] = True
    free_cell = np.zeros(len(cid), bool)
    free_cell[system.cell_rows] = free[n_t:]
    for mask, why in ((~has_polygon, "no polygon"), (has_polygon & ~unknown_cell, "no balanced vertex"),
                      (free_cell, "free")):
        ids.append(cid[mask])
        kinds += ["cell"] * int(mask.sum())
        reasons += [why] * int(mask.sum())
    interior = (edges["cell_a"].to_numpy() != 0) & (edges["cell_b"].to_numpy() != 0)
    unknown_edge = np.zeros(len(edges), bool)
    unknown_edge[system.edge_rows] = True
    free_edge = np.zeros(len(edges), bool)
    free_edge[system.edge_rows] = free[:n_t]
    eid = edges["edge"].to_numpy(np.int64)
    for mask, why in ((interior & ~unknown_edge, "no balanced vertex"), (free_edge, "free")):
        ids.append(eid[mask])
        kinds += ["edge"] * int(mask.sum())
        reasons += [why] * int(mask.sum())
    return pd.DataFrame({"kind": pd.array(kinds, dtype="string"), "id": np.concatenate(ids).astype(np.int64),
                         "reason": pd.array(reasons, dtype="string")})
