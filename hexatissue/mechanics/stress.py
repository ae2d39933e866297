"""The Batchelor stress of the cells, of the tissue and on the Gamma_p grid, from tensions and pressures.

A cell's stress is its pressure plus the tension of its junctions, each
shared by its two cells (Batchelor 1970; Ishihara & Sugimura 2012):

    sigma_c = -P_c I + 1 / (2 A_c) sum_j T_j l_j (x) l_j / |l_j|,

positive = tensile.  The stress of a region is the area-weighted mean of its
cells' stresses.  Its traceless (nematic, p = 2) part is the second angular
moment of the tension-weighted junctions, ``(sigma_xx - sigma_yy) / 2 + i
sigma_xy = 1 / (2 A) sum_j T_j |l_j| exp(2 i theta_j)``; the same moment with
``p = 6`` is its hexatic projection.

On a surface (``surface=True``, after the surface stage: vertices with
heights, cells with their normals and surface areas) a cell's stress is taken
in its tangent frame (``e1`` the image x axis projected on the cell's plane,
``e2 = n x e1``, the frame of its ``surface_gamma{p}``): each 3-D junction
vector ``l`` enters as ``T (P l) (x) (P l) / |l|`` with ``P l`` its
projection on the plane (the 3-D tensor ``T l (x) l / |l|`` projected), over
twice the cell's surface area.  On the grid, each cell's stress is carried
into the node's tangent frame before the mean (isotropic part unchanged,
nematic part turned as an order-2 quantity, the ``p`` moments as order ``p``:
:func:`hexatissue.surface.transport_to_nodes`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial import cKDTree

from ..errors import InputError
from ..schema import require_columns
from ..surface.field import NORMAL_COLUMNS, node_frames, transport_to_nodes

__all__ = ["cell_stress", "tissue_stress", "stress_grid"]


def cell_stress(cells, vertices, edges, tension, pressure, box=None, p=(6,), surface=False):
    """Batchelor stress of every cell whose junctions all have a tension and which has a pressure.

    Parameters
    ----------
    cells, vertices, edges : pandas.DataFrame
        One frame's tables (``cells``: ``cell``, ``polygon_area``;
        ``edges``: ``vertex_a``, ``vertex_b``, ``cell_a``, ``cell_b``).
    tension : array_like
        Per row of ``edges`` (NaN: unknown).
    pressure : array_like
        Per row of ``cells`` (NaN: unknown).
    box : Box, optional
        Periodic box; None for an open image.
    p : sequence of int
        Orders of the extra angular moments returned (6: hexatic).
    surface : bool
        The stress in each cell's tangent frame (module docstring): needs
        ``vertices["z"]`` (px) and the cells' ``normal_x/_y/_z`` and
        ``surface_area`` (the surface stage's columns).  False: in the image
        plane, with ``polygon_area``.

    Returns
    -------
    pandas.DataFrame
        Per row of ``cells``: ``cell``, ``stress_xx``, ``stress_xy``,
        ``stress_yy`` (tension/px; with ``surface``, along the cell's tangent
        axes ``e1``, ``e2`` instead of x, y) and ``stress{p}_re``,
        ``stress{p}_im`` (tension/px; angles from x, or from ``e1``) for each
        ``p``; NaN for a cell with a junction without tension (e.g. with the
        outside), no pressure or no polygon (or, with ``surface``, no normal).
    """
    if surface:
        return _surface_cell_stress(cells, vertices, edges, tension, pressure, box, p)
    require_columns(cells, ("cell", "polygon_area"), "cells")
    require_columns(edges, ("vertex_a", "vertex_b", "cell_a", "cell_b"), "edges")
    tension, pressure = _checked_forces(cells, edges, tension, pressure)
    vpos = pd.Index(vertices["vertex"].to_numpy(np.int64))
    xy = vertices[["x", "y"]].to_numpy(float)
    d = xy[vpos.get_indexer(edges["vertex_b"].to_numpy(np.int64))] - xy[vpos.get_indexer(edges["vertex_a"].to_numpy(np.int64))]
    d = d if box is None else box.min_image(d)
    length = np.hypot(d[:, 0], d[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        w = tension / length  # T l (x) l / |l|
    theta = np.arctan2(d[:, 1], d[:, 0])
    parts = {"xx": w * d[:, 0] ** 2, "xy": w * d[:, 0] * d[:, 1], "yy": w * d[:, 1] ** 2}
    for q in p:
        parts[f"{q}_re"] = tension * length * np.cos(q * theta)
        parts[f"{q}_im"] = tension * length * np.sin(q * theta)
    cpos = pd.Index(cells["cell"].to_numpy(np.int64))
    rows = np.r_[cpos.get_indexer(edges["cell_a"].to_numpy(np.int64)),
                 cpos.get_indexer(edges["cell_b"].to_numpy(np.int64))]
    on = rows >= 0  # cell 0 (the outside) is not a row
    area = cells["polygon_area"].to_numpy(float)
    out = {"cell": cells["cell"].to_numpy(np.int64)}
    for name, value in parts.items():
        # NaN tensions propagate: a cell with one unknown junction has no stress
        total = np.bincount(rows[on], weights=np.r_[value, value][on], minlength=len(cells))
        out[name] = total / (2.0 * area)
    out["xx"] -= pressure
    out["yy"] -= pressure
    return pd.DataFrame({("cell" if k == "cell" else f"stress_{k}" if k in ("xx", "xy", "yy") else f"stress{k}"): v
                         for k, v in out.items()})


def _checked_forces(cells, edges, tension, pressure):
    tension = np.asarray(tension, float)
    pressure = np.asarray(pressure, float)
    if tension.shape != (len(edges),):
        raise InputError(f"tension must have one value per row of edges ({len(edges)}); got shape {tension.shape}")
    if pressure.shape != (len(cells),):
        raise InputError(f"pressure must have one value per row of cells ({len(cells)}); got shape {pressure.shape}")
    return tension, pressure


def _surface_cell_stress(cells, vertices, edges, tension, pressure, box, p):
    """:func:`cell_stress` in each cell's tangent frame (``surface=True``)."""
    require_columns(cells, ("cell", "surface_area") + NORMAL_COLUMNS, "cells (with the surface stage's columns)")
    require_columns(vertices, ("vertex", "x", "y", "z"), "vertices (with the surface stage's z)")
    require_columns(edges, ("vertex_a", "vertex_b", "cell_a", "cell_b"), "edges")
    tension, pressure = _checked_forces(cells, edges, tension, pressure)
    vpos = pd.Index(vertices["vertex"].to_numpy(np.int64))
    va = vpos.get_indexer(edges["vertex_a"].to_numpy(np.int64))
    vb = vpos.get_indexer(edges["vertex_b"].to_numpy(np.int64))
    xy = vertices[["x", "y"]].to_numpy(float)
    z = vertices["z"].to_numpy(float)
    d = xy[vb] - xy[va]
    d = d if box is None else box.min_image(d)
    d3 = np.column_stack([d, z[vb] - z[va]])  # a periodic height map is periodic: its differences are read as is
    length3 = np.linalg.norm(d3, axis=1)
    cpos = pd.Index(cells["cell"].to_numpy(np.int64))
    rows = np.r_[cpos.get_indexer(edges["cell_a"].to_numpy(np.int64)),
                 cpos.get_indexer(edges["cell_b"].to_numpy(np.int64))]
    on = np.flatnonzero(rows >= 0)  # cell 0 (the outside) is not a row
    cell = rows[on]
    edge = on % len(edges) if len(edges) else on
    e1, e2 = node_frames(cells[list(NORMAL_COLUMNS)].to_numpy(float))
    a = np.sum(d3[edge] * e1[cell], axis=1)  # the junction in the cell's tangent frame
    b = np.sum(d3[edge] * e2[cell], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = tension[edge] / length3[edge]  # T (P l) (x) (P l) / |l|
    theta = np.arctan2(b, a)
    parts = {"xx": w * a * a, "xy": w * a * b, "yy": w * b * b}
    for q in p:
        parts[f"{q}_re"] = w * (a * a + b * b) * np.cos(q * theta)
        parts[f"{q}_im"] = w * (a * a + b * b) * np.sin(q * theta)
    area = cells["surface_area"].to_numpy(float)
    out = {"cell": cells["cell"].to_numpy(np.int64)}
    for name, value in parts.items():
        out[name] = np.bincount(cell, weights=value, minlength=len(cells)) / (2.0 * area)
    out["xx"] -= pressure
    out["yy"] -= pressure
    return pd.DataFrame({("cell" if k == "cell" else f"stress_{k}" if k in ("xx", "xy", "yy") else f"stress{k}"): v
                         for k, v in out.items()})


def tissue_stress(cells, stress) -> np.ndarray:
    """The tissue's stress: the area-weighted mean of the cells' stresses (cells with a stress), a 2 x 2 array.

    ``cells`` has ``polygon_area``; ``stress`` is :func:`cell_stress`'s table
    (same rows).  Tension/px; NaN when no cell has a stress.
    """
    area = cells["polygon_area"].to_numpy(float)
    s = stress[["stress_xx", "stress_xy", "stress_yy"]].to_numpy(float)
    ok = np.isfinite(s).all(axis=1) & np.isfinite(area)
    if not ok.any():
        return np.full((2, 2), np.nan)
    xx, xy, yy = (area[ok, None] * s[ok]).sum(axis=0) / area[ok].sum()
    return np.array([[xx, xy], [xy, yy]])


def stress_grid(cells, stress, grid, box=None, p=(6,), surface=False) -> pd.DataFrame:
    """The stress coarse-grained on the nodes of the Gamma_p grid.

    At each node, the area-weighted mean stress of the cells with a stress
    whose centroid lies within the node's disk (``grid.radius``, the disk of
    Gamma_p; :func:`hexatissue.coarse_grain`).

    Parameters
    ----------
    cells : pandas.DataFrame
        ``x``, ``y`` (centroid, px), ``polygon_area``; one frame.
    stress : pandas.DataFrame
        :func:`cell_stress` of ``cells`` (same rows, same ``p``).
    grid : pandas.DataFrame
        The frame's ``grid`` table (``frame``, ``node``, ``x``, ``y``, ``radius``).
    box : Box, optional
        Periodic box (distances by minimum image).
    p : sequence of int
        Orders of the angular moments (as given to :func:`cell_stress`).
    surface : bool
        ``stress`` is :func:`cell_stress` with ``surface=True`` and ``grid``
        the order fields' grid on the surface (with ``normal_x/_y/_z``):
        each cell's stress is carried into the node's tangent frame and the
        mean is weighted by the cells' ``surface_area`` (module docstring).

    Returns
    -------
    pandas.DataFrame
        The ``stress`` table: ``frame``, ``node``, ``x``, ``y`` (px),
        ``stress_xx``, ``stress_xy``, ``stress_yy`` (tension/px; with
        ``surface``, along the node's tangent axes ``e1``, ``e2``),
        ``stress_iso`` (the isotropic part, ``(xx + yy) / 2``), ``stress2_re``,
        ``stress2_im`` (the nematic part: ``(xx - yy) / 2``, ``xy``),
        ``stress{p}_re``, ``stress{p}_im`` (tension/px), ``n_cells``; NaN
        where the disk holds no cell with a stress.
    """
    require_columns(grid, ("node", "x", "y", "radius"), "grid")
    require_columns(cells, ("x", "y", "polygon_area"), "cells")
    names = ["stress_xx", "stress_xy", "stress_yy"] + [f"stress{q}_{c}" for q in p for c in ("re", "im")]
    require_columns(stress, names, "stress")
    value = stress[names].to_numpy(float)
    if surface:
        require_columns(cells, ("surface_area",) + NORMAL_COLUMNS, "cells (with the surface stage's columns)")
        require_columns(grid, NORMAL_COLUMNS, "grid (the order fields' grid on the surface)")
        area = cells["surface_area"].to_numpy(float)
        cell_normals = cells[list(NORMAL_COLUMNS)].to_numpy(float)
    else:
        area = cells["polygon_area"].to_numpy(float)
    ok = np.isfinite(value).all(axis=1) & np.isfinite(area)
    cxy = cells[["x", "y"]].to_numpy(float)[ok]
    value, area = value[ok], area[ok]
    if surface:
        cell_normals = cell_normals[ok]
        # the tensor as its isotropic part and its order-2 (nematic) part, which turn differently between frames
        value = np.column_stack([0.5 * (value[:, 0] + value[:, 2]), 0.5 * (value[:, 0] - value[:, 2]),
                                 value[:, 1], value[:, 3:]])
        orders = (2,) + tuple(p)
    nodes = grid[["x", "y"]].to_numpy(float)
    radius = grid["radius"].to_numpy(float)
    sums = np.zeros((len(grid), len(names)))
    weight = np.zeros(len(grid))
    count = np.zeros(len(grid), np.int64)
    if len(cxy) and len(grid):
        if box is None:
            tree = cKDTree(cxy)
            query = nodes
        else:
            tree = cKDTree(box.wrap(cxy), boxsize=box.lengths)
            query = box.wrap(nodes)
        for r in np.unique(radius):
            at = np.flatnonzero(radius == r)
            hits = tree.query_ball_point(query[at], r)
            node = np.repeat(at, [len(h) for h in hits])
            cell = np.concatenate([np.asarray(h, np.int64) for h in hits]) if len(hits) else np.zeros(0, np.int64)
            pair = value[cell]
            if surface:
                # each cell's stress in the node's tangent frame: the order-q parts turned by the transport
                to = grid[list(NORMAL_COLUMNS)].to_numpy(float)[node]
                pair = pair.copy()
                for k, q in enumerate(orders):
                    turned = transport_to_nodes(pair[:, 1 + 2 * k] + 1j * pair[:, 2 + 2 * k], cell_normals[cell], to,
                                                q)
                    pair[:, 1 + 2 * k], pair[:, 2 + 2 * k] = turned.real, turned.imag
            np.add.at(sums, node, area[cell, None] * pair)
            np.add.at(weight, node, area[cell])
            np.add.at(count, node, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / weight[:, None]
    out = pd.DataFrame({"frame": grid["frame"].to_numpy(np.int64) if "frame" in grid.columns else 0,
                        "node": grid["node"].to_numpy(np.int64), "x": nodes[:, 0], "y": nodes[:, 1]})
    if surface:  # back from the isotropic and nematic parts
        iso, nem_re, nem_im = mean[:, 0].copy(), mean[:, 1].copy(), mean[:, 2].copy()
        mean[:, 0], mean[:, 1], mean[:, 2] = iso + nem_re, nem_im, iso - nem_re
    for k, name in enumerate(names[:3]):
        out[name] = mean[:, k]
    out["stress_iso"] = 0.5 * (mean[:, 0] + mean[:, 2])
    out["stress2_re"] = 0.5 * (mean[:, 0] - mean[:, 2])
    out["stress2_im"] = mean[:, 1]
    for k, name in enumerate(names[3:]):
        out[name] = mean[:, 3 + k]
    out["n_cells"] = count
    return out
