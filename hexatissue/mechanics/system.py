"""The force balance as a sparse linear system (:func:`force_system`): the vertex equations, straight or along
the arcs' end tangents, and the Young-Laplace rows of curved junctions.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.sparse import csr_matrix

from ..errors import InputError
from ..schema import require_columns
from ..surface.field import node_frames


# Weight of the Young-Laplace rows against the vertex rows (both in force units).  A junction's curvature is a
# second derivative of its shape, measured less well than the tangents at its ends; a small weight lets the
# vertices set the tensions and the curvatures the pressures (the two-stage estimate is the limit of a vanishing
# weight, reached by 0.1: on the Surface Evolver tissue 0.1 and 0.01 give the same errors to 3 digits, 1 doubles
# the tension error; docs/mechanics.md).  Exact equations are met at any weight.
_LAPLACE_WEIGHT = 0.1


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


def _frame_of(table, name):
    frames = np.unique(table["frame"].to_numpy()) if "frame" in table.columns else np.zeros(1, int)
    if len(frames) > 1:
        raise InputError(f"{name} must hold one frame; got frames {frames[:5].tolist()}...")
    return int(frames[0]) if len(frames) else 0


def _min_image(d, box):
    return d if box is None else box.min_image(d)


def _tangent_frames(vertices, normals):
    """``z`` (px) and the unit normal, ``e1``, ``e2`` of every vertex's tangent plane, the normals checked.

    ``e1`` is the image x axis projected on the plane and normalised,
    ``e2 = n x e1`` (the frame of :func:`hexatissue.surface.node_frames`);
    normals ``(0, 0, 1)`` give the image axes exactly.
    """
    require_columns(vertices, ("z",), "vertices (the heights of a surface, with normals)")
    n = np.asarray(normals, float)
    if n.shape != (len(vertices), 3):
        raise InputError(f"normals must hold one (x, y, z) unit vector per row of vertices ({len(vertices)}); got "
                         f"shape {n.shape}")
    z = vertices["z"].to_numpy(float)
    if not (np.isfinite(n).all() and np.isfinite(z).all()):
        raise InputError("normals and vertices['z'] must be finite: a vertex off the surface has no tangent plane")
    if np.abs(np.linalg.norm(n, axis=1) - 1.0).max(initial=0.0) > 1e-9 or (n[:, 2] <= 0).any():
        raise InputError("normals must be unit vectors facing +z (normals of a height map)")
    e1, e2 = node_frames(n)
    return z, n, e1, e2


def _polygon_normals(xy, z, cv_v, cv_row, rank, nxt, n_cells, box, vertex_normals):
    """Per row of cell_vertices: the unit vector area of its cell's lifted polygon (facing +z).

    The polygon is taken about its first vertex (by ``rank``), so a constant
    height gives ``(0, 0, 1)`` exactly; where the vector area vanishes, the
    vertex's own normal.
    """
    order = np.lexsort((rank, cv_row))
    c = cv_row[order]
    m = len(c)
    start = np.r_[True, c[1:] != c[:-1]] if m else np.zeros(0, bool)
    first = np.empty(m, np.int64)
    first[order] = order[np.maximum.accumulate(np.where(start, np.arange(m), 0))]
    r = np.column_stack([_min_image(xy[cv_v] - xy[cv_v[first]], box), z[cv_v] - z[cv_v[first]]])
    cross = np.cross(r, r[nxt])
    vector = np.column_stack([np.bincount(cv_row, weights=cross[:, a], minlength=n_cells) for a in range(3)])
    size = np.linalg.norm(vector, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = vector / size[:, None]
    normal[normal[:, 2] < 0] *= -1
    normal = normal[cv_row]
    flat = ~(size[cv_row] > 0)
    normal[flat] = vertex_normals[cv_v[flat]]
    return normal


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
                 directions=None, normals=None) -> ForceSystem:
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
    normals : ndarray (n_vertices, 3), optional
        Per row of ``vertices``: the unit normal of the surface at the vertex
        (e.g. of a height map: :func:`hexatissue.surface.node_normals`), with
        the vertices' heights in ``vertices["z"]`` (px).  Each vertex is then
        balanced in its tangent plane (two rows: the components along ``e1``,
        the image x axis projected on the plane, and ``e2 = n x e1``): the
        junctions' 3-D unit vectors (vertex to vertex; a given direction is
        lifted onto the tangent plane) and the pressure terms ``P_c (c x N_c)
        / 2``, ``c`` the 3-D chord from the polygon's previous vertex to its
        next and ``N_c`` the unit vector area of the cell's lifted polygon
        (``(c x N_c) / 2`` is the gradient of its area), projected on the
        plane (docs/surface.md, "Forces on a height map").  A constant height
        (normals ``(0, 0, 1)``) gives the equations of the image plane, to
        the last bit.  Not with ``curvature``.  None: the image plane.

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
    frames = None
    if normals is not None:
        if curvature is not None:
            raise InputError("curvature cannot be given with normals: junction arcs are modelled in the image "
                             "plane only (docs/surface.md, \"Forces on a height map\")")
        frames = _tangent_frames(vertices, normals)
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
    if frames is not None:
        z, n, e1, e2 = frames
        # the 3-D junction: its height difference is read as is (a periodic height map is periodic)
        dz = z[vb[t_edge]] - z[va[t_edge]]
        length3 = np.hypot(length[t_edge], dz)  # = the 2-D length, bit for bit, where dz = 0
        u3 = np.column_stack([d[t_edge] / length3[:, None], dz / length3])
        given = np.zeros(len(t_edge), bool) if directions is None else given
    rows, cols, vals = [], [], []
    for end, sign in ((va[t_edge], 1.0), (vb[t_edge], -1.0)):
        keep = balanced[end]
        col = np.flatnonzero(keep)
        r = vrow[end[keep]]
        ux, uy = sign * u[keep, 0], sign * u[keep, 1]
        if frames is not None:
            # the tension along the 3-D junction, its component in the vertex's tangent plane
            w = u3[keep]
            if given[keep].any():
                # a direction in the image lifted onto the tangent plane at the vertex: (u, -(n_x u_x + n_y u_y) / n_z)
                nk = n[end[keep]]
                lifted = np.column_stack([u[keep], -(nk[:, 0] * u[keep, 0] + nk[:, 1] * u[keep, 1]) / nk[:, 2]])
                lifted /= np.linalg.norm(lifted, axis=1)[:, None]
                w = np.where(given[keep][:, None], lifted, w)
            ux = sign * np.sum(w * e1[end[keep]], axis=1)
            uy = sign * np.sum(w * e2[end[keep]], axis=1)
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
        if frames is None:
            vals += [0.5 * chord[:, 1], -0.5 * chord[:, 0]]
        else:
            # the gradient of the lifted polygon's area |sum_i X_i x X_(i+1)| / 2: (c x N) / 2, c the 3-D chord
            # prev -> next and N the polygon's unit vector area, its component in the vertex's tangent plane
            here_z = z[cv_v[k]]
            c3 = np.column_stack([chord, (z[cv_v[nxt[k]]] - here_z) - (z[cv_v[prev[k]]] - here_z)])
            push = np.cross(c3, _polygon_normals(xy, z, cv_v, cv_row, cell_vertices["rank"].to_numpy(np.int64), nxt,
                                                 len(cid), box, n)[k])
            vals += [0.5 * np.sum(push * e1[cv_v[k]], axis=1), 0.5 * np.sum(push * e2[cv_v[k]], axis=1)]
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
