"""The shape functions gamma_p of single cells (:func:`shape_function`, with the one gamma_p kernel
``_kernels.shape_sums``) and their columns in the cells table (:func:`shape_order`, :func:`cells_from_polygons`).
"""
from __future__ import annotations

import numpy as np

from .._dispatch import Kernels
from ..errors import InputError, check_orders, check_p
from ..frame import Frame
from ..geometry import lookup, pack_polygons, polygon_area_centroid, polygon_cells, row_keys, table_polygons
from ..options import CENTERS
from ..schema import validate
from . import _kernels


K = Kernels(_kernels, "hexatissue.order._reference")

#: Polygons with area < DEGENERATE_AREA * (mean squared vertex radius) have no shape function (NaN).
DEGENERATE_AREA = 1e-9


def shape_function_flat(xy, starts, p=6, center="vertex_mean"):
    """:func:`shape_function` for polygons stored back to back in one ``(M, 2)`` array.

    ``starts`` gives each polygon's first row in ``xy``.  Polygons must be
    contiguous (unwrapped in periodic boxes) and not closed.  Polygons with
    fewer than three vertices, and degenerate ones (area below
    ``DEGENERATE_AREA`` times their mean squared vertex distance from the
    centre: collinear or collapsed vertices), give NaN.
    """
    return shape_functions_flat(xy, starts, (p,), center)[0]


def shape_functions_flat(xy, starts, orders, center="vertex_mean"):
    """:func:`shape_function_flat` for each p of ``orders`` (a list of arrays), in one pass over the polygons.

    The numba kernel :func:`hexatissue.order._kernels.shape_sums` computes
    gamma_p without transcendental functions (``sum z^p / sum |z|^p``).
    """
    xy = np.ascontiguousarray(xy, dtype=float)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    n = len(starts)
    own_centre = isinstance(center, str) and center == "vertex_mean"
    if own_centre:
        c = np.zeros((0, 2))
    elif isinstance(center, str):
        if center != "area_centroid":
            raise InputError(f"center must be one of {CENTERS} or an (n_cells, 2) array; got {center!r}")
        c = polygon_area_centroid(xy, starts)[1]
    else:
        c = np.asarray(center, dtype=float)
        if c.shape != (n, 2):
            raise InputError(f"center array must have shape ({n}, 2), one (x, y) per polygon; got {c.shape}")
    gamma = K.shape_sums(xy, starts, np.ascontiguousarray(c), own_centre,
                       np.array(orders, np.int64), DEGENERATE_AREA)
    return list(gamma)


def shape_function(polygons, p=6, center="vertex_mean"):
    """p-fold shape function gamma_p of each polygon.

    Parameters
    ----------
    polygons : sequence of (n_i, 2) arrays
        Vertices (x, y) of each cell, x = column, y = row, in order around the
        cell (either direction; a repeated closing vertex is dropped).
        Polygons in a periodic box must be unwrapped (contiguous).
    p : int
        Symmetry order (2 = nematic, 6 = hexatic).
    center : {"vertex_mean", "area_centroid"} or (N, 2) array
        Cell centre from which vertices are measured.  The default, the mean
        of the vertices, is the convention of the published MDCK data
        (Armengol-Collado et al. 2023); ``"area_centroid"`` uses the centroid
        of the polygon's area.

    Returns
    -------
    numpy.ndarray of complex
        gamma_p per polygon (dimensionless, ``|gamma_p| <= 1``); NaN for
        polygons with fewer than three vertices.
    """
    p = check_p(p)
    xy, starts = pack_polygons(polygons)
    if len(starts) == 0:
        return np.zeros(0, dtype=complex)
    return shape_function_flat(xy, starts, p=p, center=center)


def gamma_columns(cells, vertices, cell_vertices, box=None, p=(6, 2), center="vertex_mean", polygons=None):
    """``cells`` (a copy) with ``gamma{p}_re`` / ``gamma{p}_im`` computed from the polygons of the tables.

    The tables are those of :func:`hexatissue.mesh_from_labels` (one frame
    or many, each with a ``frame`` column); cells without a polygon get NaN.
    ``polygons``, ``(xy, starts)`` of the rows of ``cells`` with
    ``n_sides > 0`` in their order (as :func:`hexatissue.mesh.network.network_columns`
    gives them), saves reading them back from the tables.
    """
    old = [c for c in cells.columns if c.startswith("gamma")]
    out = cells.drop(columns=old) if old else cells.copy(deep=False)  # (pandas copies on write: cells stays)
    if polygons is None:
        keys, xy, starts = table_polygons(vertices, cell_vertices, box)
        take = lookup(row_keys(keys["frame"], keys["cell"]), None,
                      row_keys(out["frame"].to_numpy(np.int64), out["cell"].to_numpy(np.int64)))
    else:
        xy, starts = polygons
        take = polygon_rows(out["n_sides"].to_numpy(np.int64) > 0)
    for name, value in gamma_arrays(xy, starts, take, p, center).items():
        out[name] = value
    return out


def polygon_rows(has_polygon):
    """For each row, its polygon's index among the rows with a polygon (``has_polygon``), else -1."""
    return np.where(has_polygon, np.cumsum(has_polygon) - 1, -1)


def gamma_arrays(xy, starts, take, p=(6, 2), center="vertex_mean"):
    """``gamma{p}_re`` and ``gamma{p}_im`` columns (dimensionless) of rows whose polygon is ``take`` (-1: NaN).

    ``xy`` and ``starts`` hold the polygons back to back (:func:`shape_function_flat`).
    """
    orders = check_orders(p)
    has = take >= 0
    out = {}
    for q, g in zip(orders, shape_functions_flat(xy, starts, orders, center)):
        value = np.full(len(take), np.nan + 0j)
        value[has] = g[take[has]]
        out[f"gamma{q}_re"], out[f"gamma{q}_im"] = value.real, value.imag
    return out


def shape_order(network, p=(6, 2), center="vertex_mean"):
    """The order stage on a junction network: its cells table gains the shape functions.

    Parameters
    ----------
    network : Frame or Movie
        From :func:`hexatissue.mesh_from_labels` (a Frame) or
        :func:`hexatissue.analyze` (a Movie).
    p : int or sequence of int
        Symmetry orders (2 nematic, 6 hexatic).
    center : {"vertex_mean", "area_centroid"}
        Cell centre of the shape function (see :func:`shape_function`).

    Returns
    -------
    Frame or Movie
        A copy whose ``cells`` has ``gamma{p}_re``, ``gamma{p}_im``
        (dimensionless; NaN for cells without a polygon) for every ``p``.
    """
    if center not in CENTERS:
        raise InputError(f"center must be one of {CENTERS}; got {center!r}")
    # a Frame fresh from the mesh has its polygons in row order: no rebuild from the tables' keys
    polygons = network.mesh_polygons() if isinstance(network, Frame) else None
    cells = gamma_columns(network.cells, network.vertices, network.cell_vertices, network.box, p, center, polygons)
    return network.replace(cells=validate(cells, "cells"))


def cells_from_polygons(polygons, p=(6, 2), centers=None, is_border=None, center="vertex_mean"):
    """Cells table from cell polygons (e.g. published polygon data, or another segmentation tool).

    Parameters
    ----------
    polygons : dict or sequence
        ``{cell: (n, 2) array of (x, y)}`` or a sequence (cells numbered from
        1); x = column, y = row, origin at the centre of pixel (0, 0).  A
        repeated closing vertex is dropped.
    p : int or sequence of int
        Symmetry orders of the shape functions to compute, their columns in
        this order (default ``(6, 2)``, as :func:`shape_order` and
        :attr:`~hexatissue.options.OrderOptions.p`).
    centers : (N, 2) array, optional
        Cell positions ``x``, ``y`` (e.g. the published centres of mass);
        default the polygons' area centroids.
    is_border : (N,) bool array, optional
        Border flags; default all False (interior cells).
    center : str or (N, 2) array
        Centre used by :func:`shape_function`.

    Returns
    -------
    pandas.DataFrame
        Cells table: ``frame`` (0), ``cell``, ``x``, ``y`` (px), ``area`` and
        ``polygon_area`` (both the polygon's area, px^2), ``perimeter`` (px),
        ``n_sides``, ``n_boundaries`` (1: one polygon per cell), ``is_border``,
        ``gamma{p}_re``, ``gamma{p}_im``.
    """
    if isinstance(polygons, dict):
        ids, polys = list(polygons), list(polygons.values())
    else:
        polys = list(polygons)
        ids = list(range(1, len(polys) + 1))
    xy, starts = pack_polygons(polys, "polygons")
    lengths = np.diff(np.r_[starts, len(xy)])
    if (lengths < 3).any():
        k = ids[int(np.flatnonzero(lengths < 3)[0])]
        raise InputError(f"polygon of cell {k} must be an (n >= 3, 2) array of (x, y); it has fewer than 3 vertices")
    table = polygon_cells(ids, xy, starts)
    if centers is not None:
        pos = np.asarray(centers, float)
        if pos.shape != (len(starts), 2):
            raise InputError(f"centers must have shape ({len(starts)}, 2); got {pos.shape}")
        table["x"], table["y"] = pos[:, 0], pos[:, 1]
    border = np.zeros(len(starts), bool) if is_border is None else np.asarray(is_border, bool)
    if border.shape != (len(starts),):
        raise InputError(f"is_border must have shape ({len(starts)},); got {border.shape}")
    table.insert(0, "frame", np.zeros(len(starts), np.int64))
    table["is_border"] = border
    orders = check_orders(p)
    for order, gamma in zip(orders, shape_functions_flat(xy, starts, orders, center)):
        table[f"gamma{order}_re"], table[f"gamma{order}_im"] = gamma.real, gamma.imag
    return validate(table, "cells")
