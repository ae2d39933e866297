"""The tissue flow on a height map's surface: every cell's 3-D velocity in its tangent frame, and the surface
velocity gradient on the Gamma_p grid, with the motion of the surface along its normal.

A cell's 3-D position is its centroid lifted onto the surface, ``(x, y, z)``
(``cells.z`` of the surface stage, px); its velocity ``v = (vx, vy, vz)`` the
centred difference of that position along its track, as
:func:`hexatissue.cell_velocities` takes it of ``(x, y)``.  It is split in the
cell's tangent frame (the surface stage's: ``e1`` the image x axis projected on
the tangent plane, ``e2 = n x e1``, ``n`` the cell's normal facing +z): the
tangential components ``surface_vx = v . e1``, ``surface_vy = v . e2`` and the
normal velocity ``vn = v . n``.

On the grid, the cells' velocities, tangential velocities and normals are each
fitted by an affine function of the image position over the node's disk (the
flat fits', :func:`hexatissue.flow_fields`).  A function ``f(x, y)`` on the
surface has the directional derivative ``df/dx e_x + df/dy e_y`` along a
tangent vector ``e``, whatever its z component, since the image position is a
parametrisation of the surface; so the velocity gradient in the node's tangent
frame ``(E1, E2)`` (the surface stage's frame of the node normal, the grid's
``normal_x/_y/_z``) is ``L_ij = E_i . (dv/dx E_jx + dv/dy E_jy)``.  Of the
tangential velocity its trace is the surface divergence ``div_s v_t``; of the
normals, ``div_s n = -2 H`` gives the mean curvature ``H``; of the whole
velocity, its symmetric traceless part is the surface rate of strain and its
antisymmetric part the vorticity, and its trace ``div_s v`` the rate at which
a patch of surface moving with the cells changes its area:
``d log A / dt = div_s v = div_s v_t - 2 H vn``.  The areal rate is taken as
that trace, of the one fit of the velocity: the product of the fits of ``H``
and ``vn`` carries the errors of both (on a growing bump, 8.5 % against 2.9 %:
docs/surface.md); the columns ``surface_divergence``, ``mean_curvature`` and
``vn`` give the two terms apart.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..box import as_box
from ..errors import check_positive
from ..geometry import node_frames
from ..schema import interior_mask, require_columns
from ._grid import check_min_cells, grid_fits
from .statistics import _centred_rows

__all__ = ["surface_velocities", "surface_flow_fields", "area_rates"]

NORMALS = ["normal_x", "normal_y", "normal_z"]


#: A cell normal within this angle (rad) of +z is +z: the lifted polygons of a constant height map tilt by rounding
#: alone (measured: 1.3e-16), and their frames are then exactly x, y, so that the image plane's surface columns are
#: the flat ones bit for bit.
LEVEL = 1e-12


def _cell_normals(cells):
    """The cells' unit normals ``(m, 3)`` (``normal_x/_y/_z``), those within :data:`LEVEL` of +z set to +z."""
    normal = cells[NORMALS].to_numpy(float, copy=True)
    normal[np.hypot(normal[:, 0], normal[:, 1]) <= LEVEL] = (0.0, 0.0, 1.0)
    return normal


def surface_velocities(cells, box=None) -> dict:
    """Every cell's 3-D velocity on the surface, in its tangent frame, px/frame.

    ``v(t) = (r(t + 1) - r(t - 1)) / 2`` of ``r = (x, y, z)``, the centroid
    lifted onto the surface (minimum image of x, y in a periodic box), for a
    cell whose track is in both neighbouring frames (as
    :func:`hexatissue.cell_velocities`: NaN at the ends of tracks); split in
    the cell's tangent frame at ``t`` (:func:`hexatissue.surface.tangent_polygons`:
    ``e1`` the image x axis projected on the tangent plane, ``e2 = n x e1``).
    A normal within :data:`LEVEL` (1e-12 rad) of +z is taken as +z, so that
    on a constant height map the frame is exactly x, y, z and
    ``surface_vx``, ``surface_vy`` are ``vx``, ``vy``.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with the surface stage's columns: ``frame``, ``x``, ``y``,
        ``z`` (px), ``normal_x``, ``normal_y``, ``normal_z`` and ``track`` (or
        ``cell``, whose ids are then the tracks).
    box : Box, optional
        Periodic box; None for an open image.

    Returns
    -------
    dict of numpy.ndarray
        In row order, px/frame: ``vx``, ``vy``, ``vz`` (the 3-D velocity;
        ``vx``, ``vy`` those of :func:`hexatissue.cell_velocities`),
        ``surface_vx`` (``v . e1``), ``surface_vy`` (``v . e2``) and ``vn``
        (``v . n``, positive towards +z); NaN where the velocity is undefined
        and, for the last three, where the cell has no normal (no polygon).
    """
    require_columns(cells, ["frame", "x", "y", "z", *NORMALS], "cells")
    box = as_box(box)
    order, xy, inner = _centred_rows(cells)
    r = np.column_stack([xy, cells["z"].to_numpy(float)[order]])
    v = np.full((len(r), 3), np.nan)
    d = r[inner + 1] - r[inner - 1]
    if box is not None:
        d[:, :2] = box.min_image(d[:, :2])
    v[inner] = 0.5 * d
    out = np.empty_like(v)
    out[order] = v
    normal = _cell_normals(cells)
    e1, e2 = node_frames(normal)
    return {"vx": out[:, 0].copy(), "vy": out[:, 1].copy(), "vz": out[:, 2].copy(),
            "surface_vx": (out * e1).sum(axis=1),
            "surface_vy": (out * e2).sum(axis=1), "vn": (out * normal).sum(axis=1)}


def area_rates(cells, column="surface_area") -> np.ndarray:
    """Each cell's rate of log area along its track, 1/frame: the centred difference
    ``(A(t+1) - A(t-1)) / (2 A(t))`` of ``column`` (NaN at a track's ends and across a gap), in row order.

    What the flow's ``areal_rate`` measures, from the cells' own areas (on a
    height map, ``surface_area``).
    """
    require_columns(cells, ("track", "frame", column), "cells")
    order = np.lexsort((cells["frame"].to_numpy(), cells["track"].to_numpy()))
    area, track, frame = (cells[c].to_numpy()[order] for c in (column, "track", "frame"))
    centred = (track[2:] == track[:-2]) & (frame[2:] == frame[:-2] + 2)
    rate = np.full(len(order), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate[1:-1][centred] = (area[2:] - area[:-2])[centred] / (2 * area[1:-1][centred])
    out = np.empty(len(order))
    out[order] = rate
    return out


def _tangent_gradient(fits, e1, e2):
    """``L_ij = E_i . (dv/dx E_jx + dv/dy E_jy)``, ``(2, 2, n)``, of the fits ``(3, 3, n)`` of a 3-D vector's
    components (value, d/dx, d/dy per node) in the nodes' frames ``E1``, ``E2`` ``(n, 3)``."""
    frame = (e1.T, e2.T)  # (3, n) each
    along = [fits[:, 1] * e[0] + fits[:, 2] * e[1] for e in frame]  # dv/dE_j, (3, n)
    return np.array([[(e * d).sum(axis=0) for d in along] for e in frame])


def surface_flow_fields(cells, grid, box=None, radius_factor=2.0, min_cells=3):
    """The flow on the surface of a height map at the nodes of its grid: the surface columns of the ``flow`` table.

    On the grid of the surface field (its node normals ``normal_x/_y/_z``),
    each node fits the cells' velocities ``v`` over the interior cells of its
    disk that have a 3-D velocity, and their tangential velocities
    ``v_t = v - vn n`` and normals ``n`` over those of them that also have a
    normal, by affine functions of the image position, as
    :func:`hexatissue.flow_fields` fits ``vx``, ``vy`` (the same disks,
    ``min_cells`` and spread), and takes their gradients in the node's
    tangent frame (module docstring).  On a constant height map (node normals
    +z, cell normals +z within :data:`LEVEL`, the cells at one height) the
    frames are exactly x, y, z and every surface column equals its flat
    counterpart.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``frame``, ``x``, ``y``, ``z`` (px), ``vx``, ``vy``,
        ``vz`` (px/frame, :func:`surface_velocities`), ``normal_x``,
        ``normal_y``, ``normal_z`` and optionally ``is_border``.
    grid : pandas.DataFrame
        Grid table of the surface field (``analyze`` with a height map, or
        :func:`hexatissue.surface.surface_coarse_grain`): ``frame``, ``node``,
        ``x``, ``y``, ``radius``, ``valid``, ``normal_x``, ``normal_y``,
        ``normal_z``.
    box : Box, optional
        Periodic box; None for an open image.
    radius_factor, min_cells
        As in :func:`hexatissue.flow_fields`.

    Returns
    -------
    pandas.DataFrame
        One row per row of ``grid``, in its order (the rows of
        :func:`hexatissue.flow_fields`' table, which they join): ``frame``,
        ``node`` and, in each node's tangent frame (``E1`` the image x axis projected on its tangent plane,
        ``E2 = N x E1``): ``surface_vx``, ``surface_vy`` (fitted velocity at
        the node along E1, E2, px/frame), ``vn`` (along the node normal N,
        positive towards +z, px/frame), ``surface_vorticity``
        (``L_21 - L_12``, 1/frame), ``surface_divergence`` (``div_s v_t``,
        of the tangential velocity, 1/frame), ``surface_strain_xx``
        (``(L_11 - L_22) / 2``), ``surface_strain_xy`` (``(L_12 + L_21) / 2``,
        1/frame: the surface rate of strain of the cells' motion, the normal
        motion's included), ``mean_curvature`` (``H = -div_s n / 2``, 1/px:
        negative on a dome, positive in a trough; ``(1/R1 + 1/R2) / 2`` with
        the principal radii signed by this convention) and ``areal_rate``
        (``L_11 + L_22 = div_s v = div_s v_t - 2 H vn``, the rate of change
        of the log of a surface area moving with the cells, 1/frame); NaN
        where there is no fit.
    """
    require_columns(cells, ["frame", "x", "y", "z", "vx", "vy", "vz", *NORMALS], "cells")
    require_columns(grid, ["frame", "node", "x", "y", "radius", "valid", *NORMALS], "grid")
    box = as_box(box)
    radius = grid["radius"].to_numpy(float) * check_positive(radius_factor, "radius_factor")
    xy = cells[["x", "y"]].to_numpy(float)
    v = cells[["vx", "vy", "vz"]].to_numpy(float)
    normal = _cell_normals(cells)
    vn = (v * normal).sum(axis=1)
    frame = cells["frame"].to_numpy(np.int64)
    moving = interior_mask(cells) & np.isfinite(xy).all(axis=1) & np.isfinite(v).all(axis=1)
    with_normal = moving & np.isfinite(normal).all(axis=1)
    nodes = (grid["frame"].to_numpy(np.int64), grid[["x", "y"]].to_numpy(float), radius, box,
             check_min_cells(min_cells))
    velocity, _ = grid_fits(xy[moving], frame[moving], v[moving], *nodes)
    fits, _ = grid_fits(xy[with_normal], frame[with_normal],
                        np.column_stack([v - vn[:, None] * normal, normal])[with_normal], *nodes)
    node_normal = grid[NORMALS].to_numpy(float)
    e1, e2 = node_frames(node_normal)
    tangential, normals = fits[0:3], fits[3:6]
    gradient = _tangent_gradient(velocity, e1, e2)
    divergence = _tangent_gradient(tangential, e1, e2)
    divergence = divergence[0, 0] + divergence[1, 1]
    bend = _tangent_gradient(normals, e1, e2)
    curvature = -0.5 * (bend[0, 0] + bend[1, 1])
    at_node = velocity[:, 0].T  # (n, 3)
    columns = {"surface_vx": (at_node * e1).sum(axis=1), "surface_vy": (at_node * e2).sum(axis=1),
               "vn": (at_node * node_normal).sum(axis=1), "surface_vorticity": gradient[1, 0] - gradient[0, 1],
               "surface_divergence": divergence, "surface_strain_xx": (gradient[0, 0] - gradient[1, 1]) * 0.5,
               "surface_strain_xy": (gradient[0, 1] + gradient[1, 0]) * 0.5, "mean_curvature": curvature,
               "areal_rate": gradient[0, 0] + gradient[1, 1]}
    return pd.DataFrame({"frame": grid["frame"].to_numpy(np.int64), "node": grid["node"].to_numpy(np.int64),
                         **columns}, copy=False)


