"""Gamma_p and its defects on the surface a height map describes (the order fields stage after the surface stage).

Every grid node has the height map's tangent plane: its unit normal from the
height map's gradient (central differences, bilinear at the node) and its
tangent frame, ``e1`` = the image x axis projected on the plane, ``e2 = n x
e1``, as every cell's (:mod:`hexatissue.surface.tangent`).  Each cell's
surface gamma_p is parallel-transported from its tangent frame into the
node's before it is averaged (:func:`surface_coarse_grain`), and the
plaquette charges of the grid take in the transport between neighbouring
nodes and the curvature each plaquette encloses (:func:`surface_defects`),
with the connection and the solid angles of :mod:`hexatissue.surface.mesh`.
Formulas: docs/surface.md ("Gamma_p and its defects on a height map").
"""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from ..errors import HexatissueWarning, check_orders
from ..geometry import bilinear, node_frames
from ..order import coarse_grain
from ..order.coarse import _frames
from ..schema import interior_mask, require_columns
from ..defects.grid import _stack, grid_defects
from .transport import solid_angles, transport_angles
from .tangent import check_height

__all__ = ["node_normals", "node_frames", "transport_to_nodes", "surface_coarse_grain", "surface_plaquette_charges",
           "surface_defects", "NORMAL_COLUMNS"]

#: The grid columns of the node normals: a grid that has them holds the field on the surface.
NORMAL_COLUMNS = ("normal_x", "normal_y", "normal_z")
#: A plaquette's charge times p further than this from an integer is reported (only round-off can do it).
_CHARGE_TOLERANCE = 1e-6


def node_normals(height, x, y, scale=1.0, box=None) -> np.ndarray:
    """Unit normals ``(N, 3)`` of the height map at the points ``x``, ``y`` (px), facing +z.

    ``n = (-dz/dx, -dz/dy, 1) / |.|`` with ``z = scale * height`` and its
    gradient by central differences at the pixels (one-sided at the edge of
    an open image, wrapped on a periodic ``box``), bilinearly interpolated
    at the points (clamped at the edge, wrapped in a box).  Exact for a plane;
    ``(0, 0, 1)`` exactly for a constant height map.
    """
    h = check_height(height) * float(scale)
    if box is not None:
        gx = 0.5 * (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1))
        gy = 0.5 * (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0))
    else:
        gy, gx = (np.gradient(h, axis=a) if h.shape[a] > 1 else np.zeros_like(h) for a in (0, 1))
    x, y = np.asarray(x, float).ravel(), np.asarray(y, float).ravel()
    periodic = box is not None
    n = np.column_stack([-bilinear(gx, x, y, periodic), -bilinear(gy, x, y, periodic), np.ones(len(x))])
    return n / np.linalg.norm(n, axis=1)[:, None]


def transport_to_nodes(gamma, cell_normals, node_normals, p):
    """``gamma`` (per pair, of order ``p``) carried from the cells' tangent frames into the nodes':
    ``gamma exp(i p phi)``, ``phi`` the transport angle (:func:`hexatissue.surface.transport.transport_angles`)."""
    e1_cell, _ = node_frames(cell_normals)
    e1_node, e2_node = node_frames(node_normals)
    phi = transport_angles(cell_normals, e1_cell, node_normals, e1_node, e2_node)
    return gamma * np.exp(1j * p * phi)


def _disk_pairs(cell_xy, nodes, radius, box):
    """``(node, cell)`` index pairs with ``dx^2 + dy^2 <= radius^2`` (minimum image in a box): the disks of
    :func:`hexatissue.coarse_grain`, with its kernel's arithmetic (cells folded into the box, nodes folded by
    ``floor``, the offset's minimum image by ``rint``)."""
    from scipy.spatial import cKDTree

    if len(cell_xy) == 0 or len(nodes) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    if box is not None:
        lengths = np.asarray(box.lengths, float)
        cell_xy = box.wrap(cell_xy)
        nodes = nodes - lengths * np.floor(nodes / lengths)
        tree = cKDTree(cell_xy, boxsize=lengths)
        lists = tree.query_ball_point(box.wrap(nodes), radius * (1 + 1e-9) + 1e-9)
    else:
        lists = cKDTree(cell_xy).query_ball_point(nodes, radius * (1 + 1e-9) + 1e-9)
    counts = np.fromiter((len(a) for a in lists), np.int64, len(lists))
    node = np.repeat(np.arange(len(nodes)), counts)
    cell = np.fromiter((c for a in lists for c in a), np.int64, int(counts.sum()))
    d = cell_xy[cell] - nodes[node]
    if box is not None:
        d -= lengths * np.rint(d / lengths)
    inside = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] <= radius * radius
    return node[inside], cell[inside]


def surface_coarse_grain(cells, height, scale=1.0, p=6, radius=None, spacing=None, box=None, min_coverage=1.0,
                         r_cell=None, origin=None, shape=None, validity="tissue"):
    """Gamma_p on the surface: the cells' surface gamma_p transported into each node's tangent frame, averaged.

    The grid, the disks and everything but the Gamma columns are those of
    :func:`hexatissue.coarse_grain` on the cells' surface gamma_p (the same
    nodes in the image plane, the same cells in each disk, counted equally:
    disks of radius R in the image plane, the projection of a surface patch
    slightly larger than R where the surface tilts).  Each cell's
    ``surface_gamma{p}`` is multiplied by ``exp(i p phi)``, ``phi`` the angle
    of the minimal rotation taking the cell's normal to the node's
    (:func:`transport_to_nodes`), then averaged.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with the surface stage's columns: ``x``, ``y``,
        ``normal_x/_y/_z``, ``surface_gamma{p}_re/_im`` (and optionally
        ``is_border``, ``area``, ``frame``).  A cell enters the means when its
        ``x``, ``y``, normal and surface gamma_p of every ``p`` are finite.
    height : (rows, cols) array
        The height map the cells were measured on (every frame of ``cells``).
    scale : float
        px per unit of the height map (:attr:`hexatissue.SurfaceOptions.scale`).
    p, radius, spacing, box, min_coverage, r_cell, origin, shape, validity
        As for :func:`hexatissue.coarse_grain`.

    Returns
    -------
    pandas.DataFrame
        The grid table of :func:`hexatissue.coarse_grain` with the
        transported means in ``Gamma{p}_re/_im`` (in each node's tangent frame)
        and ``normal_x``, ``normal_y``, ``normal_z``: the node's unit normal
        (:func:`node_normals`).
    """
    orders = check_orders(p)
    surface = [f"surface_gamma{q}_{part}" for q in orders for part in ("re", "im")]
    require_columns(cells, ("x", "y", *NORMAL_COLUMNS, *surface), "cells")
    height = check_height(height)
    flat = pd.DataFrame({c: cells[c] for c in cells.columns if not c.startswith("gamma")}, copy=False)
    for q in orders:
        for part in ("re", "im"):
            flat[f"gamma{q}_{part}"] = cells[f"surface_gamma{q}_{part}"].to_numpy(float)
    grid = coarse_grain(flat, p=orders, radius=radius, spacing=spacing, box=box, min_coverage=min_coverage,
                        r_cell=r_cell, origin=origin, shape=shape, validity=validity)
    gx, gy = grid["x"].to_numpy(float), grid["y"].to_numpy(float)
    normals = node_normals(height, gx, gy, scale, box)
    xy = cells[["x", "y"]].to_numpy(float)
    cell_n = cells[list(NORMAL_COLUMNS)].to_numpy(float)
    gamma = np.column_stack([cells[f"surface_gamma{q}_re"].to_numpy(float)
                             + 1j * cells[f"surface_gamma{q}_im"].to_numpy(float) for q in orders])
    use = (interior_mask(cells) & np.isfinite(xy).all(axis=1) & np.isfinite(cell_n).all(axis=1)
           & np.isfinite(gamma).all(axis=1))
    means = np.full((len(grid), len(orders)), np.nan + 0j)
    counts = np.zeros(len(grid), np.int64)
    grid_frame = grid["frame"].to_numpy()
    grid_radius = grid["radius"].to_numpy(float)
    for frame, rows in _frames(cells)[0]:
        idx = np.arange(len(cells))[rows]
        idx = idx[use[idx]]
        in_frame = np.flatnonzero(grid_frame == frame) if "frame" in cells.columns else np.arange(len(grid))
        for r in np.unique(grid_radius[in_frame]):
            at = in_frame[grid_radius[in_frame] == r]
            node, cell = _disk_pairs(xy[idx], np.column_stack([gx[at], gy[at]]), r, box)
            cell = idx[cell]
            counts[at] = np.bincount(node, minlength=len(at))
            for a, q in enumerate(orders):
                carried = transport_to_nodes(gamma[cell, a], cell_n[cell], normals[at[node]], q)
                total = (np.bincount(node, carried.real, len(at)) + 1j * np.bincount(node, carried.imag, len(at)))
                with np.errstate(invalid="ignore", divide="ignore"):
                    means[at, a] = np.where(counts[at] > 0, total / np.maximum(counts[at], 1),
                                            0.0 if validity == "all" else np.nan)
    differ = counts != grid["n_cells"].to_numpy()
    if differ.any():  # the same disks as coarse_grain's kernel but for a centroid at R to round-off
        warnings.warn(f"surface_coarse_grain: {int(differ.sum())} node(s) count a cell at the disk's edge that "
                      f"coarse_grain does not (round-off); n_cells there counts the cells averaged",
                      HexatissueWarning, stacklevel=2)
        grid["n_cells"] = counts
    for a, q in enumerate(orders):
        grid[f"Gamma{q}_re"], grid[f"Gamma{q}_im"] = means[:, a].real, means[:, a].imag
    for k, name in enumerate(NORMAL_COLUMNS):
        grid[name] = normals[:, k]
    return grid


def surface_plaquette_charges(theta, normals, p, periodic=False, rounded=True):
    """Charge of every plaquette of orientation grids on a surface: winding, transport and enclosed curvature.

    Parameters
    ----------
    theta : (..., ny, nx) float array
        Orientations ``Arg(Gamma_p) / p`` in each node's tangent frame, rad;
        NaN nodes make the plaquettes around them NaN.
    normals : (..., ny, nx, 3) float array
        The nodes' unit normals (their frames: :func:`node_frames`).
    p : int
        Symmetry order.
    periodic : bool
        The grids wrap around (``ny x nx`` plaquettes, else ``(ny - 1) x (nx - 1)``).
    rounded : bool
        Round to the nearest multiple of ``1/p`` (else the computed value).

    Returns
    -------
    (..., ny', nx') float array
        Plaquette ``[i, j]`` (corners ``[i, j]`` to ``[i+1, j+1]``, counter-
        clockwise in x, y: a -> b -> c -> d = [i, j], [i, j+1], [i+1, j+1],
        [i+1, j]): ``q = (s_ab + s_bc + s_cd + s_da + Omega_abc + Omega_acd) p
        / (2 pi p)``, each step ``s_uv = wrap(theta_v - theta_u - phi_uv)``
        into ``(-pi/p, pi/p]``, ``phi_uv`` the transport angle from u's frame
        to v's, ``Omega`` the signed solid angle of the triangle of normals.
    """
    theta = np.asarray(theta, float)
    n = np.asarray(normals, float)
    e1, e2 = node_frames(n.reshape(-1, 3))
    e1, e2 = e1.reshape(n.shape), e2.reshape(n.shape)
    if periodic:
        def shift(a, di, dj):
            return np.roll(np.roll(a, -di, axis=theta.ndim - 2), -dj, axis=theta.ndim - 1)
    else:
        def shift(a, di, dj):
            ny, nx = theta.shape[-2:]
            return a[..., di:ny - 1 + di, dj:nx - 1 + dj] if a.ndim == theta.ndim else \
                a[..., di:ny - 1 + di, dj:nx - 1 + dj, :]
    period = 2.0 * np.pi / p

    def step(u, v):  # orientation step from corner u to corner v, in v's frame, wrapped
        flat = [shift(a, *u).reshape(-1, 3) for a in (n, e1)] + [shift(a, *v).reshape(-1, 3) for a in (n, e1, e2)]
        phi = transport_angles(*flat).reshape(shift(theta, *u).shape)
        d = shift(theta, *v) - shift(theta, *u) - phi
        return d - period * np.ceil(d / period - 0.5)

    a, b, c, d = (0, 0), (0, 1), (1, 1), (1, 0)
    total = step(a, b) + step(b, c) + step(c, d) + step(d, a)
    na, nb, nc, nd = (shift(n, *k).reshape(-1, 3) for k in (a, b, c, d))
    omega = (solid_angles(na, nb, nc) + solid_angles(na, nc, nd)).reshape(total.shape)
    x = (total + omega) * p / (2.0 * np.pi)
    if not rounded:
        return x / p
    whole = np.round(x)
    ok = np.isfinite(x)
    if ok.any() and np.abs(x[ok] - whole[ok]).max() > _CHARGE_TOLERANCE:
        warnings.warn(f"plaquette charges of p = {p} are up to {np.abs(x[ok] - whole[ok]).max():.2g} / {p} from a "
                      f"multiple of 1/{p} (round-off); rounded", HexatissueWarning, stacklevel=2)
    return whole / p


def surface_defects(grid, p=6, box=None):
    """Defects of a surface grid (:func:`surface_coarse_grain`): :func:`hexatissue.find_defects` with the
    plaquette charges of :func:`surface_plaquette_charges` (the connection between the node frames and the
    curvature each plaquette encloses).  The same table as :func:`hexatissue.find_defects`."""
    require_columns(grid, NORMAL_COLUMNS, "grid")
    normals = grid[list(NORMAL_COLUMNS)].to_numpy(float)

    def plaquettes(theta, q, periodic, stacking, count, shape):
        n = np.stack([_stack(np.ascontiguousarray(normals[:, k]), *stacking, count, shape) for k in range(3)],
                     axis=-1)
        charge = surface_plaquette_charges(theta, n, q, periodic)
        flat = np.flatnonzero(np.nan_to_num(charge) != 0)
        return flat, charge.ravel()[flat]

    return grid_defects(grid, p, box, plaquettes, NORMAL_COLUMNS)
