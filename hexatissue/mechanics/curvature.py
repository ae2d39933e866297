"""Junction curvature: the circular arc through a junction's end vertices that best fits its own pixels.

At force balance a junction of uniform tension ``T`` between cells of
pressures ``P_left``, ``P_right`` is a circular arc of curvature
``kappa = (P_left - P_right) / T`` (Young-Laplace), and the force it pulls
its end vertex with is ``T`` along the arc's tangent there, not along the
chord.  This module measures ``kappa`` per junction of the network, from
the cracks between the junction's two cells in the label image
(:func:`junction_curvature`) or from any points along it (:func:`fit_arcs`).

Sign convention: ``kappa`` is the signed curvature of the junction followed
from ``vertex_a`` to ``vertex_b`` (x = column, y = row): positive when it
turns counter-clockwise in (x, y), i.e. the circle's centre lies to the left
of the direction a -> b and the junction bulges to the right.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ..schema import require_columns

__all__ = ["fit_arcs", "junction_curvature", "junction_shapes"]

# Crack points this close (px) to an end vertex are left out of the fit: the corner there belongs to three cells
# and its pixels follow the lattice, not the junction.
_END_MARGIN = 1.0


def fit_arcs(points, owner, start, end):
    """Signed curvature of the circle through each junction's two ends that best fits its points.

    The circles through ``A`` and ``B`` form the pencil ``lam (s^2 + h^2 -
    c^2 / 4) + h = 0`` in chord coordinates (``s`` along the chord from its
    midpoint, ``h`` to the left, ``c`` the chord length); ``lam = 0`` is the
    chord itself.  ``lam`` is fitted by linear least squares (near the chord
    the residual is the point's distance to the circle), and ``kappa = -2 lam
    / sqrt(1 + lam^2 c^2)`` (smooth through the straight junction).

    Parameters
    ----------
    points : ndarray (n, 2)
        x, y of points along the junctions, px, given relative to the
        junction's start (``start`` is then the origin) or absolute.
    owner : ndarray of int (n,)
        Junction index of each point, in ``0 .. len(start) - 1``.
    start, end : ndarray (m, 2)
        The end vertices of each junction, in the frame of ``points``.

    Returns
    -------
    ndarray (m,)
        ``kappa``, 1/px (sign: module docstring); 0 for a junction with no
        point (drawn straight).
    """
    points = np.asarray(points, float).reshape(-1, 2)
    owner = np.asarray(owner, np.int64)
    start, end = np.asarray(start, float).reshape(-1, 2), np.asarray(end, float).reshape(-1, 2)
    m = len(start)
    chord = end - start
    c = np.hypot(chord[:, 0], chord[:, 1])
    if (c <= 0).any():
        raise InputError("start and end must differ for every junction (a junction of zero length has no arc)")
    u = chord / c[:, None]
    rel = points - (start + end)[owner] / 2
    s = rel[:, 0] * u[owner, 0] + rel[:, 1] * u[owner, 1]
    h = -rel[:, 0] * u[owner, 1] + rel[:, 1] * u[owner, 0]
    g = s ** 2 + h ** 2 - c[owner] ** 2 / 4
    num = np.bincount(owner, weights=h * g, minlength=m)
    den = np.bincount(owner, weights=g * g, minlength=m)
    lam = np.where(den > 0, -num / np.where(den > 0, den, 1.0), 0.0)
    return -2.0 * lam / np.sqrt(1.0 + lam ** 2 * c ** 2)


def junction_curvature(labels, vertices, edges, box=None):
    """Signed curvature of every junction, from the cracks between its two cells in the label image.

    Every pair of 4-adjacent pixels of cells ``cell_a`` and ``cell_b`` gives
    a point at the midpoint of their shared crack (pixel ``(row, col)`` is
    centred on ``x = col``, ``y = row``).  Two cells that share more than one
    junction give each crack to the junction whose chord is nearest.  Cracks
    within 1 px of an end vertex are left out.  Junctions with the outside
    (cell 0) are measured too.

    Parameters
    ----------
    labels : ndarray (H, W) of int
        The frame's cell labels, touching (as the junction network stage
        leaves them: ``Frame.labels``).
    vertices, edges : pandas.DataFrame
        The frame's network tables (:mod:`hexatissue.schema`).
    box : Box, optional
        Periodic box: cracks across the image edge count, and displacements
        are taken by minimum image.

    Returns
    -------
    ndarray
        Per row of ``edges``: ``kappa``, 1/px, signed as in the module
        docstring (positive: the junction turns counter-clockwise from
        ``vertex_a`` to ``vertex_b``); 0 where no crack was found.
    """
    rel, owner, ok, chord = _junction_points(labels, vertices, edges, box)
    kappa = np.zeros(len(edges))
    if len(rel):
        kappa[ok] = fit_arcs(rel, owner, np.zeros((len(ok), 2)), chord)
    return kappa


def junction_shapes(labels, vertices, edges, box=None, threshold=None):
    """Per junction: its arc, the line fitted to its pixels, and whether its pixels show a curvature.

    The points are those of :func:`junction_curvature` (crack midpoints, the
    ones within 1 px of an end left out), in chord coordinates (``s`` along
    the chord from its midpoint, ``h`` to its left).  Two models are fitted
    to them by least squares: the line ``h = a + b s`` and the parabola ``h =
    a + b s + q s^2`` (a circle to second order), neither tied to the end
    vertices, whose errors would otherwise pass for curvature.  With their
    residual sums of squares ``S_line``, ``S_parabola`` and ``s^2 =
    max(S_parabola / (n - 3), 1/12)`` px^2 (at least the variance of pixel
    rounding, uniform over one pixel), the junction is curved when ``F =
    (S_line - S_parabola) / s^2`` exceeds ``threshold`` (``None``: ``max(log
    n, 10.83)``: BIC's penalty, and the 0.1 % tail of chi-square with one
    degree of freedom, because the rounding residuals along a digital line
    are correlated).  Junctions with fewer than 4 points are straight.

    Parameters
    ----------
    labels : ndarray (H, W) of int
        Touching cell labels (``Frame.labels``).
    vertices, edges : pandas.DataFrame
        The frame's network tables.
    box : Box, optional
        Periodic box.
    threshold : float, optional
        Critical value of ``F``.

    Returns
    -------
    pandas.DataFrame
        One row per row of ``edges``: ``kappa`` (1/px: the arc through the
        two end vertices fitted to the points, :func:`fit_arcs`; sign as in the
        module docstring), ``direction_x``, ``direction_y`` (unit vector of
        the fitted line, oriented from ``vertex_a`` to ``vertex_b``; the
        chord's with fewer than 2 points; NaN for a junction of zero length),
        ``n_points``, ``F`` and ``curved`` (bool).
    """
    rel, owner, ok, chord = _junction_points(labels, vertices, edges, box)
    m = len(ok)
    c = np.hypot(chord[:, 0], chord[:, 1])
    u = chord / np.where(c > 0, c, 1.0)[:, None]
    count = np.bincount(owner, minlength=m).astype(float)
    mid = rel - chord[owner] / 2
    s = mid[:, 0] * u[owner, 0] + mid[:, 1] * u[owner, 1]
    h = -mid[:, 0] * u[owner, 1] + mid[:, 1] * u[owner, 0]
    # line h = a + b s against parabola h = a + b s + q s^2, least squares per junction (s scaled by c / 2 so
    # the normal equations are well conditioned)
    z = s / np.maximum(c[owner] / 2, 1e-12)
    basis = np.stack([np.ones_like(z), z, z * z], axis=1)
    gram = np.zeros((m, 3, 3))
    proj = np.zeros((m, 3))
    for i in range(3):
        proj[:, i] = np.bincount(owner, weights=basis[:, i] * h, minlength=m)
        for k in range(3):
            gram[:, i, k] = np.bincount(owner, weights=basis[:, i] * basis[:, k], minlength=m)
    hh = np.bincount(owner, weights=h * h, minlength=m)
    enough = count >= 4
    eye = np.eye(3) * 1e-12
    coef3 = np.linalg.solve(gram + eye, proj[:, :, None])[:, :, 0]
    coef2 = np.linalg.solve(gram[:, :2, :2] + eye[:2, :2], proj[:, :2, None])[:, :, 0]
    s_line = np.maximum(hh - np.sum(coef2 * proj[:, :2], axis=1), 0.0)
    s_quad = np.maximum(hh - np.sum(coef3 * proj, axis=1), 0.0)
    var = np.maximum(s_quad / np.maximum(count - 3, 1), 1.0 / 12.0)
    F = np.where(enough, (s_line - s_quad) / var, 0.0)
    limit = np.maximum(np.log(np.maximum(count, 1)), 10.83) if threshold is None else threshold
    kappa = np.zeros(m)
    if len(rel):
        kappa = fit_arcs(rel, owner, np.zeros((m, 2)), chord)
    # the line's direction: its slope in chord coordinates (h = a + b' s, b' = b / (c / 2))
    angle = np.where(count >= 2, np.arctan(coef2[:, 1] / np.maximum(c / 2, 1e-12)), 0.0)
    direction = np.column_stack([u[:, 0] * np.cos(angle) - u[:, 1] * np.sin(angle),
                                 u[:, 0] * np.sin(angle) + u[:, 1] * np.cos(angle)])
    out = pd.DataFrame({"kappa": 0.0, "direction_x": np.nan, "direction_y": np.nan, "n_points": 0, "F": 0.0,
                        "curved": False}, index=np.arange(len(edges)))
    out.loc[ok, "kappa"] = kappa
    out.loc[ok, "direction_x"], out.loc[ok, "direction_y"] = direction[:, 0], direction[:, 1]
    out.loc[ok, "n_points"] = count.astype(np.int64)
    out.loc[ok, "F"] = F
    out.loc[ok, "curved"] = F > limit
    return out


def _junction_points(labels, vertices, edges, box):
    """Crack midpoints of each junction, relative to its start: ``(rel, owner, ok, chord)``.

    ``ok`` are the rows of ``edges`` with two distinct ends, ``owner`` indexes
    ``ok``, ``chord`` is ``end - start`` per row of ``ok``.
    """
    require_columns(vertices, ("vertex", "x", "y"), "vertices")
    require_columns(edges, ("vertex_a", "vertex_b", "cell_a", "cell_b"), "edges")
    lab = np.asarray(labels)
    if lab.ndim != 2 or not np.issubdtype(lab.dtype, np.integer):
        raise InputError(f"labels must be a 2-D integer label image; got an array of shape {lab.shape}, "
                         f"dtype {lab.dtype}")
    periodic = box is not None
    pts, pa, pb = [], [], []
    for axis in (0, 1):
        other = np.roll(lab, -1, axis=axis) if periodic else (lab[1:] if axis == 0 else lab[:, 1:])
        here = lab if periodic else (lab[:-1] if axis == 0 else lab[:, :-1])
        r, cc = np.nonzero(here != other)
        a, b = here[r, cc], other[r, cc]
        pts.append(np.column_stack((cc + 0.5 * axis, r + 0.5 * (1 - axis))).astype(float))
        pa.append(np.minimum(a, b))
        pb.append(np.maximum(a, b))
    pts, pa, pb = np.concatenate(pts), np.concatenate(pa).astype(np.int64), np.concatenate(pb).astype(np.int64)
    vpos = pd.Index(vertices["vertex"].to_numpy(np.int64))
    xy = vertices[["x", "y"]].to_numpy(float)
    ia = vpos.get_indexer(edges["vertex_a"].to_numpy(np.int64))
    ib = vpos.get_indexer(edges["vertex_b"].to_numpy(np.int64))
    if (ia < 0).any() or (ib < 0).any():
        raise InputError("edges names vertices that are not in vertices")
    start = xy[ia]
    end = start + (box.min_image(xy[ib] - xy[ia]) if periodic else xy[ib] - xy[ia])
    ca, cb = edges["cell_a"].to_numpy(np.int64), edges["cell_b"].to_numpy(np.int64)
    ok = np.flatnonzero((ia != ib) & (np.hypot(*(end - start).T) > 0))
    if not len(ok) or not len(pts):
        return np.zeros((0, 2)), np.zeros(0, np.int64), ok, (end - start)[ok]
    # match cracks to junctions by cell pair; a pair with several junctions: nearest chord
    pair = pd.DataFrame({"a": ca[ok], "b": cb[ok], "j": np.arange(len(ok))})
    crack = pd.DataFrame({"a": pa, "b": pb, "p": np.arange(len(pts))})
    both = crack.merge(pair, on=["a", "b"])
    p, j = both["p"].to_numpy(), both["j"].to_numpy()
    s0, s1 = start[ok][j], end[ok][j]
    rel = pts[p] - s0
    if periodic:
        rel = box.min_image(rel)
    seg = s1 - s0
    t = np.clip(np.sum(rel * seg, axis=1) / np.sum(seg * seg, axis=1), 0.0, 1.0)
    dist = np.hypot(*(rel - t[:, None] * seg).T)
    near_a = np.hypot(*rel.T)
    near_b = np.hypot(*(rel - seg).T)
    order = np.lexsort((dist, p))
    first = np.r_[True, p[order][1:] != p[order][:-1]]
    keep = order[first]
    keep = keep[(near_a[keep] > _END_MARGIN) & (near_b[keep] > _END_MARGIN)]
    return rel[keep], j[keep], ok, (end - start)[ok]
