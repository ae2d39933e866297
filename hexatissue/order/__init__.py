"""p-atic shape order of cells: the order stage.

The shape function of a polygon with vertices ``r_v`` (relative to a cell
centre, ``x`` = column, ``y`` = row) is ::

    gamma_p = sum_v |r_v|^p exp(i p phi_v) / sum_v |r_v|^p,

a complex number with ``|gamma_p| <= 1`` (1 for a regular p-gon) whose
argument divided by ``p`` is the cell's p-fold orientation.  The mesh stage
gives geometry only; :func:`shape_order` adds the ``gamma{p}`` columns, and
:func:`coarse_grain` turns them into the field ``Gamma_p`` on a grid.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from . import _kernels
from .._dispatch import Kernels
from ..box import as_box
from ..errors import InputError, check_orders, check_p, check_positive
from ..frame import Frame
from ..options import CENTERS, VALIDITY, check_pair
from ..geometry import (lookup, pack_polygons, polygon_area_centroid, polygon_cells, row_keys, table_polygons)
from ..schema import interior_mask, validate

K = Kernels(_kernels, "hexatissue.order._reference")

__all__ = [
    "shape_function",
    "shape_function_flat",
    "shape_order",
    "cells_from_polygons",
    "cell_radius",
    "coarse_grain",
    "order_vs_radius",
]

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


# ----------------------------------------------------------------------------
# Coarse-grained shape parameter Gamma_p on a grid
# ----------------------------------------------------------------------------

#: Default disk radius and grid spacing in units of R_cell (Armengol-Collado et al. 2023, Methods).
RADIUS_FACTOR = 1.5
SPACING_FACTOR = 1.0
#: On open images a raster point counts as tissue when its nearest cell centroid is an
#: interior cell c closer than COVER_FACTOR * max(sqrt(area_c / pi), R_cell) (a regular hexagon's
#: corners are 1.1 sqrt(area / pi) from its centre).
COVER_FACTOR = 1.5
#: Largest coarse-graining grid (nodes per frame); a finer spacing is refused, not computed for minutes.
MAX_NODES = 1_000_000
#: The tissue raster of an open image has a pitch of at most R_cell / RASTER_PER_RCELL.
RASTER_PER_RCELL = 4


def _check_length(value, name):
    if value is None:
        return None
    return check_positive(value, name, unit="px (or None for the default)")


def _check_radii(value):
    """``radius`` as a tuple of positive lengths (one or more), or None."""
    if value is None:
        return None
    values = (value,) if np.isscalar(value) else tuple(value)
    if not values:
        raise InputError(f"radius must be a positive length in px or a non-empty sequence of them; got {value!r}")
    return tuple(check_positive(v, "radius", unit="px") for v in values)




def _check_validity(validity, min_coverage):
    if validity not in VALIDITY:
        raise InputError(f"validity must be one of {VALIDITY}; got {validity!r}")
    if isinstance(min_coverage, bool) or not np.isscalar(min_coverage) or not 0.0 <= min_coverage <= 1.0:
        raise InputError(f"min_coverage must be a fraction in [0, 1]; got {min_coverage!r}")
    if validity != "tissue" and min_coverage != 1.0:
        raise InputError(f"min_coverage applies to validity='tissue' only; got min_coverage={min_coverage!r} "
                         f"with validity={validity!r}")
    return validity, float(min_coverage)


def _area_column(cells):
    """Cell areas, px^2, from ``area`` (``polygon_area`` if ``area`` is absent); None when neither is there."""
    column = "area" if "area" in cells.columns else "polygon_area" if "polygon_area" in cells.columns else None
    return None if column is None else cells[column].to_numpy(float)


def _mean_radius(area, interior):
    """sqrt(mean area / pi) over the interior cells with a finite area (the concept behind :func:`cell_radius`)."""
    if area is None:
        raise InputError("cells needs an 'area' (or 'polygon_area') column, px^2, to compute R_cell "
                         "(or pass r_cell)")
    area = area[interior]
    area = area[np.isfinite(area)]
    if len(area) == 0 or not area.mean() > 0:
        raise InputError("cells has no interior cell with a positive finite area to compute R_cell")
    return float(np.sqrt(area.mean() / np.pi))


def cell_radius(cells):
    """R_cell = sqrt(mean cell area / pi), px, over the interior (non-border) cells.

    Uses the ``area`` column (``polygon_area`` if ``area`` is absent).
    """
    return _mean_radius(_area_column(cells), interior_mask(cells))


def _grid_axes(cells_xy, spacing, box, origin, shape):
    """Node coordinates along x and y.

    Periodic box: ``round(L / spacing)`` nodes tile each side, from ``origin`` (default half a step).
    Open image: ``shape`` nodes (default: enough to span the cells' extent) starting at ``origin``
    (default: centred on the cells' extent).
    """
    if box is not None:
        axes = []
        for k, length in enumerate(box.lengths):
            n = max(2, int(round(length / spacing)))
            step = length / n
            start = 0.5 * step if origin is None else origin[k]
            axes.append(start + step * np.arange(n))
        return _bounded(axes, spacing)
    lo, hi = cells_xy.min(axis=0), cells_xy.max(axis=0)
    axes = []
    for k in range(2):
        if shape is not None:
            n = shape[1 - k]  # shape is (rows, cols): cols count x nodes
        elif origin is not None:
            n = max(int(np.floor((hi[k] - origin[k]) / spacing)) + 1, 1)
        else:
            n = max(int(np.floor((hi[k] - lo[k]) / spacing)) + 1, 1)
        start = lo[k] + 0.5 * ((hi[k] - lo[k]) - (n - 1) * spacing) if origin is None else origin[k]
        axes.append(start + spacing * np.arange(n))
    return _bounded(axes, spacing)


def _bounded(axes, spacing):
    """``(x nodes, y nodes)``, refused when the grid would exceed :data:`MAX_NODES` nodes."""
    if len(axes[0]) * len(axes[1]) > MAX_NODES:
        raise InputError(f"spacing {spacing:g} px gives a grid of {len(axes[0])} x {len(axes[1])} nodes (more than "
                         f"{MAX_NODES:,}); expected a spacing comparable to the cell size (default R_cell)")
    return axes[0], axes[1]


def _reach(area, r_cell):
    """Largest distance from each centroid still counted as inside the cell, px.

    ``COVER_FACTOR * max(sqrt(area / pi), R_cell)``: large cells reach further, and
    small cells next to large ones do not punch holes into the coverage.  ``area`` may be None.
    """
    if area is None:
        return np.full(1, COVER_FACTOR * r_cell)
    return COVER_FACTOR * np.fmax(r_cell, np.sqrt(np.abs(area) / np.pi))  # fmax ignores NaN areas


def _neighbours(xy, box):
    """Cell list of the centroids ``xy`` (``_kernels`` conventions), about 2 centroids per bin."""
    if box is not None:
        lengths = box.lengths
        xy = box.wrap(xy)
        size = np.sqrt(2.0 * lengths.prod() / max(len(xy), 1))
        nbins = np.maximum(1, np.floor(lengths / size)).astype(np.int64)
        origin, size, period = np.zeros(2), lengths / nbins, lengths
    else:
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        extent = np.maximum(hi - lo, 1e-9)
        size = max(np.sqrt(2.0 * extent.prod() / max(len(xy), 1)), 1e-3 * extent.max())
        nbins = (np.floor(extent / size) + 1).astype(np.int64)
        origin, size, period = lo, np.full(2, size), np.zeros(2)
    order, starts = K.cell_list(xy, origin, size, nbins)
    return xy, (order, starts, origin, size, nbins, period)


def _half_widths(radii, step, pad):
    """Raster disks of ``radii``: half width (in raster columns) of every row offset -pad..pad, -1 if empty.

    A raster offset (a, b) steps lies in the disk of radius R when (a step)^2 + (b step)^2 <= R^2.
    """
    off = np.arange(-pad, pad + 1) * step
    inside = (off[None, None, :] ** 2 + off[None, :, None] ** 2) <= np.asarray(radii)[:, None, None] ** 2
    return (inside.sum(axis=2) - 1) // 2, inside.sum(axis=(1, 2))


def _coverage(gx, gy, radii, spacing, area, interior, r_cell, neighbours):
    """(n_nodes, n_radii) fraction of each node's disks on the tissue of an open image.

    The tissue is a raster of pitch ``spacing / k <= R_cell / 4`` aligned with the grid (every
    node is a raster point); a raster point is on the tissue when its nearest centroid (border
    cells included) is an interior cell within that cell's reach (:func:`_reach`).  The raster is
    made once per frame for every radius; each disk count is a sum of row runs of the raster.
    """
    k = max(1, int(np.ceil(RASTER_PER_RCELL * spacing / r_cell)))
    step = spacing / k
    pad = int(np.ceil(max(radii) / step))
    rx = gx[0] + step * np.arange(-pad, (len(gx) - 1) * k + pad + 1)
    ry = gy[0] + step * np.arange(-pad, (len(gy) - 1) * k + pad + 1)
    xy, (order, starts, origin, size, nbins, _) = neighbours
    reach = np.broadcast_to(_reach(area, r_cell), len(xy))
    mask = K.tissue_mask(rx, ry, xy, interior, np.ascontiguousarray(reach), float(reach.max()), order, starts,
                         origin, size, nbins)
    half, n_disk = _half_widths(radii, step, pad)
    col, row = np.meshgrid(np.arange(len(gx)), np.arange(len(gy)))
    inside = K.disk_coverage(mask, pad + k * row.ravel(), pad + k * col.ravel(), half)
    return inside / n_disk[None, :]


def _frame_geometry(xy, gamma, interior, area, radii, spacing, box, r_cell, origin, shape):
    """The grid of one frame: a dict with the cells used, R_cell, radii, spacing and node axes ``gx``, ``gy``.

    ``xy`` (m, 2), ``gamma`` (m, n_orders) complex, ``interior`` (m,) and ``area`` (m,) or None
    are the frame's cells.
    """
    finite = np.isfinite(xy).all(axis=1)
    use = interior & np.isfinite(gamma).all(axis=1) & finite
    if not use.any():
        raise InputError("cells has no interior cell with finite x, y and gamma to coarse-grain")
    if r_cell is None and (radii is None or spacing is None or box is None):
        r_cell = _mean_radius(area, interior)
    radii = (RADIUS_FACTOR * r_cell,) if radii is None else radii
    spacing = SPACING_FACTOR * r_cell if spacing is None else spacing
    gx, gy = _grid_axes(xy[use], spacing, box, origin, shape)
    return {"finite": finite, "use": use, "r_cell": r_cell, "radii": radii, "spacing": spacing, "gx": gx, "gy": gy,
            "size": len(gx) * len(gy) * len(radii)}


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
