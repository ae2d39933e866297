"""The linear algebra of the inference: the regularised factorisation of the normal equations, the free
unknowns it leaves, the posterior variances, and why each unknown without an estimate has none.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.sparse import csc_matrix
from scipy.sparse.linalg import splu


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
