"""Gamma_p coarse-grained on a grid (:func:`coarse_grain`) and its order against the radius
(:func:`order_vs_radius`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .._dispatch import Kernels
from ..box import as_box
from ..errors import InputError, check_orders, check_positive
from ..options import check_pair
from ..schema import interior_mask, validate
from . import _kernels
from .grid import (_area_column, _check_length, _check_radii, _check_validity, _coverage, _frame_geometry,
                   _mean_radius, _neighbours)


K = Kernels(_kernels, "hexatissue.order._reference")


def _grid_columns(orders, size, frame_dtype=np.int64):
    """Empty output columns of a grid table of ``size`` rows, and the Gamma columns as one array.

    The float columns are the rows of one 2-D buffer and the int64 columns of another: numpy backs
    buffers of 4 MiB or more with transparent huge pages, so the columns of a large grid (50 MB on
    the 63 MDCK images with 5 orders and 9 radii) cost tens of page faults instead of thousands of
    fresh 4 KiB pages, each of which costs more than the numbers written into it.  The
    ``Gamma{p}_re``, ``Gamma{p}_im`` columns are consecutive rows (returned as one
    ``(2 n_orders, size)`` array), so the disk kernel writes every order's means in place.
    """
    gamma = [f"Gamma{q}_{part}" for q in orders for part in ("re", "im")]
    float_block = np.empty((len(gamma) + 5, size))
    columns = dict(zip(["x", "y", *gamma, "coverage", "radius", "spacing"], float_block))
    columns.update(zip(["node", "row", "col", "n_cells"], np.empty((4, size), np.int64)))
    columns.update(frame=np.empty(size, frame_dtype), valid=np.empty(size, bool))
    names = ["frame", "node", "row", "col", "x", "y", *gamma, "n_cells", "coverage", "valid", "radius", "spacing"]
    return {name: columns[name] for name in names}, float_block[2:2 + len(gamma)]


def _frame_fill(geometry, xy, gamma, area, orders, box, min_coverage, validity, columns, means, start):
    """Compute one frame's grid (every radius, rows (radius, node)) into ``columns[...][start:]``.

    ``means`` is the array of the Gamma columns (:func:`_grid_columns`).
    """
    finite, use, r_cell, radii = geometry["finite"], geometry["use"], geometry["r_cell"], geometry["radii"]
    gx, gy, spacing = geometry["gx"], geometry["gy"], geometry["spacing"]
    col, row = np.tile(np.arange(len(gx)), len(gy)), np.repeat(np.arange(len(gy)), len(gx))  # row-major nodes
    nodes = np.empty((len(col), 2))
    nodes[:, 0], nodes[:, 1] = gx[col], gy[row]
    # one neighbour structure for every p, every radius and the tissue raster
    neighbours = _neighbours(xy[finite], box)
    ok = use[finite]
    g = gamma[finite]
    values = np.empty((len(g), 2 * len(orders)))
    values[:, 0::2], values[:, 1::2] = g.real, g.imag
    n, k = len(nodes), len(radii)
    rows = slice(start, start + n * k)

    def block(name):
        return columns[name][rows].reshape(k, n)

    xy_nb, (order, starts, cl_origin, size, nbins, period) = neighbours
    K.disk_means(nodes, xy_nb, values, ok, np.asarray(radii, float), order, starts, cl_origin, size, nbins, period,
                 0.0 if validity == "all" else np.nan, means[:, rows].reshape(-1, k, n), block("n_cells"))
    counts = block("n_cells")
    if box is not None:
        coverage = 1.0
    elif validity == "tissue":
        coverage = _coverage(gx, gy, radii, spacing, None if area is None else area[finite], ok, r_cell,
                             neighbours).T
    else:  # not needed by the rule: not measured (validity="tissue", min_coverage=0 measures it)
        coverage = np.nan
    block("coverage")[:] = coverage
    if validity == "all":
        block("valid")[:] = True
    elif validity == "occupied":
        np.greater(counts, 0, out=block("valid"))
    else:
        block("valid")[:] = (counts > 0) & (block("coverage") >= min_coverage)
    block("node")[:] = np.arange(n)
    block("row")[:], block("col")[:] = row, col
    block("x")[:], block("y")[:] = nodes[:, 0], nodes[:, 1]
    block("radius")[:] = np.asarray(radii, float)[:, None]
    block("spacing")[:] = spacing
    return n * k


def _cell_arrays(cells, orders):
    """``xy``, ``gamma`` (one column per order), ``interior`` and ``area`` (or None) of a cells table."""
    xy = cells[["x", "y"]].to_numpy(float)
    gamma = np.empty((len(cells), len(orders)), complex)
    for a, q in enumerate(orders):
        gamma[:, a] = cells[f"gamma{q}_re"].to_numpy(float) + 1j * cells[f"gamma{q}_im"].to_numpy(float)
    return xy, gamma, interior_mask(cells), _area_column(cells)


def _frame_arrays(arrays, rows):
    xy, gamma, interior, area = arrays
    return xy[rows], gamma[rows], interior[rows], None if area is None else area[rows]


def _frames(cells):
    """``(frame, rows)`` of each frame of a cells table, in frame order (one frame 0 without a column)."""
    if "frame" not in cells.columns:
        return [(0, slice(None))], np.int64
    frame = cells["frame"].to_numpy()
    order = np.argsort(frame, kind="stable")
    values, first = np.unique(frame[order], return_index=True)
    bounds = np.r_[first, len(order)]
    return [(values[i], order[bounds[i]:bounds[i + 1]]) for i in range(len(values))], cells["frame"].dtype


def _check_grid_options(cells, orders, spacing, box, min_coverage, r_cell, origin, shape, validity):
    """The checked grid options ``(spacing, box, min_coverage, r_cell, origin, shape, validity)``; checks ``cells``."""
    spacing, r_cell = _check_length(spacing, "spacing"), _check_length(r_cell, "r_cell")
    box = as_box(box)
    validity, min_coverage = _check_validity(validity, min_coverage)
    origin, shape = check_pair(origin, "origin", False), check_pair(shape, "shape", True)
    if box is not None and shape is not None:
        raise InputError(f"shape must be None in a periodic box (the grid tiles the box); got {shape!r}")
    _check_cells(cells, orders)
    return spacing, box, min_coverage, r_cell, origin, shape, validity


def _check_cells(cells, orders):
    if not isinstance(cells, pd.DataFrame):
        raise InputError(f"cells must be a pandas DataFrame; got {type(cells).__name__}")
    needed = ["x", "y"] + [f"gamma{q}_{part}" for q in orders for part in ("re", "im")]
    missing = [c for c in needed if c not in cells.columns]
    if missing:
        raise InputError(f"cells is missing column(s) {missing}; expected {needed} (compute gamma with p={orders})")
    if len(cells) == 0:
        raise InputError("cells is empty; expected at least one interior cell to coarse-grain")


def coarse_grain(cells, p=6, radius=None, spacing=None, box=None, min_coverage=1.0, r_cell=None, origin=None,
                 shape=None, validity="tissue"):
    """Coarse-grained shape parameter Gamma_p on a square grid.

    ``Gamma_p(r)`` is the mean of the cells' ``gamma_p`` over the cells whose
    centroid lies within a disk of radius ``R`` centred at the node ``r``
    (``dx^2 + dy^2 <= R^2``; Armengol-Collado et al. 2023, Methods).
    Border cells (``is_border``) never enter the mean.  Several symmetry
    orders and several radii can be done in one call: they share one
    neighbour search and one tissue raster per frame.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table: ``x``, ``y`` (centroid, px; x = column, y = row, origin
        at the centre of pixel (0, 0)), ``gamma{p}_re``, ``gamma{p}_im``;
        optionally ``is_border`` (default: no border cells), ``area`` or
        ``polygon_area`` (px^2; needed for R_cell unless ``r_cell`` is given)
        and ``frame`` (a movie: each frame is coarse-grained on its own and
        ``frame`` is passed through).  A cell enters the means when its
        ``x``, ``y`` and ``gamma_p`` of every requested ``p`` are finite.
    p : int or sequence of int
        Symmetry order(s) (2 nematic, 6 hexatic); one ``Gamma{p}`` column
        pair each, on the same nodes.
    radius : float or sequence of float, optional
        Disk radius R, px.  Default ``1.5 R_cell``.  With several radii the
        grid holds every node once per radius (rows ordered by frame, radius
        as given, node).
    spacing : float, optional
        Grid spacing, px.  Default ``R_cell``.  In a periodic box the grid
        tiles the box exactly (``round(L / spacing)`` nodes per side, so the
        actual spacing along x and y is ``Lx / nx`` and ``Ly / ny``).
    box : Box, optional
        Periodic box: distances are minimum-image and ``coverage`` is 1.
        ``None`` means an open image.
    min_coverage : float
        ``validity="tissue"`` on open images: a node is valid when at least
        this fraction of its disk lies on interior cells (default 1.0: the
        whole disk, so the tissue edge, border cells and holes do not bias
        Gamma_p).
    r_cell : float, optional
        R_cell, px, of every frame (the published scripts use one value for
        all images).  Default: ``sqrt(mean area / pi)`` of each frame's
        interior cells (:func:`cell_radius`).  It sets the default radius and
        spacing, the pitch of the tissue raster and the cells' reach.
    origin : (float, float), optional
        Position ``(x, y)``, px, of node (row 0, col 0).  Default: open
        image, the grid is centred on the interior cells' extent; periodic
        box, half a grid step from (0, 0).
    shape : (int, int), optional
        Open images: nodes ``(rows, cols)``.  Default: enough nodes to span
        the interior cells' extent from the first node.  With ``origin`` and
        ``shape`` the grid may reach beyond the cells' bounding box (e.g. a
        whole image); those nodes are kept and ``validity`` decides whether
        they count.  A periodic grid always tiles the box (``shape`` must be
        None).
    validity : {"tissue", "occupied", "all"}
        Which nodes are ``valid`` (used for statistics and defects):
        ``"tissue"`` (default): at least one cell in the disk and, on open
        images, ``coverage >= min_coverage``; ``"occupied"``: at least one
        cell in the disk (the published scripts' averages); ``"all"``: every
        node, and an empty disk gives ``Gamma_p = 0`` (the published scripts'
        grids and defects).

    Returns
    -------
    pandas.DataFrame
        Grid table, one row per node (row-major) and radius, per frame:
        ``frame`` (0 for a table without one), ``node`` (id, 0-based per
        frame, the same for every radius), ``row``, ``col`` (node index along
        y and x), ``x``, ``y`` (node position, px), ``Gamma{p}_re``,
        ``Gamma{p}_im`` for every ``p`` (dimensionless; NaN when the disk is
        empty, 0 with ``validity="all"``), ``n_cells`` (cells in the disk),
        ``coverage`` (fraction of the disk on interior cells, measured on the
        tissue raster: raster points within R of the node, a raster point
        being on the tissue when its nearest centroid, border cells included,
        is an interior cell c closer than ``1.5 max(sqrt(area_c / pi),
        R_cell)``; the raster has a pitch of at most ``R_cell / 4`` and holds
        every node; 1 in a periodic box; NaN on open images with
        ``validity="occupied"`` or ``"all"``, which do not use it: take
        ``validity="tissue", min_coverage=0`` for the "occupied" rule with
        coverage measured), ``valid`` (bool), ``radius`` (R, px) and
        ``spacing`` (requested grid spacing, px).
    """
    orders = check_orders(p)
    radii = _check_radii(radius)
    spacing, box, min_coverage, r_cell, origin, shape, validity = _check_grid_options(
        cells, orders, spacing, box, min_coverage, r_cell, origin, shape, validity)
    groups, frame_dtype = _frames(cells)
    arrays = _cell_arrays(cells, orders)
    frames = [_frame_arrays(arrays, rows) for _, rows in groups]
    geometry = [_frame_geometry(*f, radii, spacing, box, r_cell, origin, shape) for f in frames]
    columns, means = _grid_columns(orders, sum(g["size"] for g in geometry), frame_dtype)
    start = 0
    for (frame, _), (xy, gamma, _, area), geo in zip(groups, frames, geometry):
        size = _frame_fill(geo, xy, gamma, area, orders, box, min_coverage, validity, columns, means, start)
        columns["frame"][start:start + size] = frame
        start += size
    return validate(pd.DataFrame(columns, copy=False), "grid")


def order_vs_radius(cells, p=6, factors=(1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0), box=None, min_coverage=1.0,
                    r_cell=None, spacing=None, origin=None, shape=None, validity="tissue"):
    """Mean ``|Gamma_p|`` over the valid grid nodes as a function of the coarse-graining radius.

    For each frame, the grid of :func:`coarse_grain` is built once with every
    radius ``R = factor * R_cell`` (one neighbour search and one tissue raster
    for all radii and orders), and ``|Gamma_p|`` is averaged over the valid
    nodes of each radius.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table as for :func:`coarse_grain` (``area`` needed unless
        ``r_cell`` is given).
    p : int or sequence of int
        Symmetry order(s).
    factors : sequence of float
        Radii in units of R_cell.
    box, min_coverage, r_cell, origin, shape, validity
        As for :func:`coarse_grain`.  ``r_cell`` fixes R_cell for every frame
        (the published scripts use 21.5 px for all MDCK images); by default
        each frame has its own.
    spacing : float, optional
        Grid spacing, px (default R_cell of the frame).

    Returns
    -------
    pandas.DataFrame
        One row per frame, p and factor (in that order): ``frame``, ``p``,
        ``factor`` (R / R_cell), ``radius`` (R, px), ``abs_Gamma`` (mean
        ``|Gamma_p|`` over valid nodes, dimensionless; NaN when none is
        valid), ``n_nodes`` (valid nodes).
    """
    orders = check_orders(p)
    factors = tuple(check_positive(f, "factors") for f in (factors if not np.isscalar(factors) else (factors,)))
    if not factors:
        raise InputError("factors must list at least one radius in units of R_cell")
    spacing, box, min_coverage, r_cell, origin, shape, validity = _check_grid_options(
        cells, orders, spacing, box, min_coverage, r_cell, origin, shape, validity)
    groups, _ = _frames(cells)
    arrays = _cell_arrays(cells, orders)
    rows = []
    for frame, index in groups:
        xy, gamma, interior, area = _frame_arrays(arrays, index)
        rc = _mean_radius(area, interior) if r_cell is None else r_cell
        radii = tuple(f * rc for f in factors)
        geometry = _frame_geometry(xy, gamma, interior, area, radii, rc if spacing is None else spacing, box, rc,
                                   origin, shape)
        grid, means = _grid_columns(orders, geometry["size"])
        _frame_fill(geometry, xy, gamma, area, orders, box, min_coverage, validity, grid, means, 0)
        valid = grid["valid"].reshape(len(factors), -1)
        for q in orders:
            size = np.hypot(grid[f"Gamma{q}_re"], grid[f"Gamma{q}_im"]).reshape(len(factors), -1)
            n_valid = valid.sum(axis=1)
            total = np.where(valid, size, 0.0).sum(axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                mean = np.where(n_valid > 0, total / n_valid, np.nan)
            rows += [(frame, q, f, r, m, int(n)) for f, r, m, n in zip(factors, radii, mean, n_valid)]
    return pd.DataFrame(rows, columns=["frame", "p", "factor", "radius", "abs_Gamma", "n_nodes"])
