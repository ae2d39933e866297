"""p-atic shape order of cells: the order stage.

The shape function of a polygon with vertices ``r_v`` (relative to a cell
centre, ``x`` = column, ``y`` = row) is

    gamma_p = sum_v |r_v|^p exp(i p phi_v) / sum_v |r_v|^p,

a complex number with ``|gamma_p| <= 1`` (1 for a regular p-gon) whose
argument divided by ``p`` is the cell's p-fold orientation.  The mesh stage
gives geometry only; :func:`shape_order` adds the ``gamma{p}`` columns, and
:func:`coarse_grain` turns them into the field ``Gamma_p`` on a grid.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial import cKDTree

from .box import as_box
from .errors import InputError, check_orders, check_p, is_real
from .geometry import (lookup, pack_polygons, polygon_area_centroid, polygon_perimeter, row_keys, segment_sum,
                       table_polygons)
from .schema import interior_mask, validate

__all__ = [
    "shape_function",
    "shape_function_flat",
    "shape_order",
    "cells_from_polygons",
    "cell_radius",
    "coarse_grain",
    "order_vs_radius",
]

CENTERS = ("vertex_mean", "area_centroid")
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
    xy = np.asarray(xy, dtype=float)
    starts = np.asarray(starts, dtype=np.int64)
    n = len(starts)
    lengths = np.diff(np.r_[starts, len(xy)])
    if isinstance(center, str):
        if center == "vertex_mean":
            with np.errstate(invalid="ignore", divide="ignore"):
                c = segment_sum(xy, starts, n) / lengths[:, None]
        elif center == "area_centroid":
            c = polygon_area_centroid(xy, starts)[1]
        else:
            raise InputError(f"center must be one of {CENTERS} or an (n_cells, 2) array; got {center!r}")
    else:
        c = np.asarray(center, dtype=float)
        if c.shape != (n, 2):
            raise InputError(f"center array must have shape ({n}, 2), one (x, y) per polygon; got {c.shape}")
    owner = np.repeat(np.arange(n), lengths)
    r = xy - c[owner]
    z = r[:, 0] + 1j * r[:, 1]
    weight = np.abs(z) ** p
    phase = np.exp(1j * p * np.angle(z))
    num = segment_sum(weight * phase, starts, n)
    den = segment_sum(weight, starts, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        gamma = num / den
    # degenerate polygons (collinear or collapsed vertices, area ~ 0) have no shape
    area = np.abs(polygon_area_centroid(xy, starts)[0]) if n else np.zeros(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        size2 = segment_sum(np.abs(z) ** 2, starts, n) / lengths
    gamma[(lengths < 3) | ~(den > 0) | ~(area > DEGENERATE_AREA * size2)] = np.nan
    return gamma


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


def gamma_columns(cells, vertices, cell_vertices, box=None, p=(6, 2), center="vertex_mean"):
    """``cells`` (a copy) with ``gamma{p}_re`` / ``gamma{p}_im`` computed from the polygons of the tables.

    The tables are those of :func:`hexatissue.mesh_from_labels` (one frame
    or many, each with a ``frame`` column); cells without a polygon get NaN.
    """
    orders = check_orders(p)
    keys, xy, starts = table_polygons(vertices, cell_vertices, box)
    out = cells.drop(columns=[c for c in cells.columns if c.startswith("gamma")])
    take = lookup(row_keys(keys["frame"], keys["cell"]), None,
                  row_keys(out["frame"].to_numpy(np.int64), out["cell"].to_numpy(np.int64)))
    has = take >= 0
    for q in orders:
        g = shape_function_flat(xy, starts, p=q, center=center)
        value = np.full(len(out), np.nan + 0j)
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
    cells = gamma_columns(network.cells, network.vertices, network.cell_vertices, network.box, p, center)
    return network.replace(cells=validate(cells, "cells"))


def cells_from_polygons(polygons, p=(2, 6), centers=None, is_border=None, center="vertex_mean"):
    """Cells table from cell polygons (e.g. published polygon data, or another segmentation tool).

    Parameters
    ----------
    polygons : dict or sequence
        ``{cell: (n, 2) array of (x, y)}`` or a sequence (cells numbered from
        1); x = column, y = row, origin at the centre of pixel (0, 0).  A
        repeated closing vertex is dropped.
    p : int or sequence of int
        Symmetry orders of the shape functions to compute.
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
    area, centroid = polygon_area_centroid(xy, starts)
    pos = centroid if centers is None else np.asarray(centers, float)
    if pos.shape != (len(starts), 2):
        raise InputError(f"centers must have shape ({len(starts)}, 2); got {pos.shape}")
    border = np.zeros(len(starts), bool) if is_border is None else np.asarray(is_border, bool)
    if border.shape != (len(starts),):
        raise InputError(f"is_border must have shape ({len(starts)},); got {border.shape}")
    table = {"frame": np.zeros(len(starts), np.int64), "cell": np.asarray(ids, np.int64), "x": pos[:, 0],
             "y": pos[:, 1], "area": np.abs(area), "polygon_area": np.abs(area),
             "perimeter": polygon_perimeter(xy, starts), "n_sides": lengths.astype(np.int64),
             "n_boundaries": np.ones(len(starts), np.int64), "is_border": border}
    for order in check_orders(p):
        gamma = shape_function_flat(xy, starts, p=order, center=center)
        table[f"gamma{order}_re"], table[f"gamma{order}_im"] = gamma.real, gamma.imag
    return validate(pd.DataFrame(table), "cells")


# ----------------------------------------------------------------------------
# Coarse-grained shape parameter Gamma_p on a grid
# ----------------------------------------------------------------------------

#: Default disk radius and grid spacing in units of R_cell (Armengol-Collado et al. 2023, Methods).
RADIUS_FACTOR = 1.5
SPACING_FACTOR = 1.0
#: On open images a disk sample point counts as tissue when its nearest cell centroid is an
#: interior cell c closer than COVER_FACTOR * max(sqrt(area_c / pi), R_cell) (a regular hexagon's
#: corners are 1.1 sqrt(area / pi) from its centre).
COVER_FACTOR = 1.5
#: Largest coarse-graining grid (nodes per frame); a finer spacing is refused, not computed for minutes.
MAX_NODES = 1_000_000


def _check_length(value, name):
    if value is None:
        return None
    if not is_real(value) or value <= 0:
        raise InputError(f"{name} must be a positive finite length in px (or None for the default); got {value!r}")
    return float(value)


def cell_radius(cells):
    """R_cell = sqrt(mean cell area / pi), px, over the interior (non-border) cells.

    Uses the ``area`` column (``polygon_area`` if ``area`` is absent).
    """
    column = "area" if "area" in cells.columns else "polygon_area" if "polygon_area" in cells.columns else None
    if column is None:
        raise InputError("cells needs an 'area' (or 'polygon_area') column, px^2, to compute R_cell")
    area = cells[column].to_numpy(float)[interior_mask(cells)]
    area = area[np.isfinite(area)]
    if len(area) == 0 or not area.mean() > 0:
        raise InputError("cells has no interior cell with a positive finite area to compute R_cell")
    return float(np.sqrt(area.mean() / np.pi))


def _grid_axes(cells_xy, spacing, box):
    """Node coordinates along x and y: tiling the periodic box, or centred on the cells' extent."""
    if box is not None:
        counts = [max(2, int(round(box.Lx / spacing))), max(2, int(round(box.Ly / spacing)))]
    else:
        lo, hi = cells_xy.min(axis=0), cells_xy.max(axis=0)
        counts = [max(int(np.floor((hi[k] - lo[k]) / spacing)) + 1, 1) for k in range(2)]
    if counts[0] * counts[1] > MAX_NODES:
        raise InputError(f"spacing {spacing:g} px gives a grid of {counts[0]} x {counts[1]} nodes (more than "
                         f"{MAX_NODES:,}); expected a spacing comparable to the cell size (default R_cell)")
    if box is not None:
        nx, ny = counts
        return (np.arange(nx) + 0.5) * box.Lx / nx, (np.arange(ny) + 0.5) * box.Ly / ny
    axes = []
    for k in range(2):
        n = counts[k]
        start = lo[k] + 0.5 * ((hi[k] - lo[k]) - (n - 1) * spacing)
        axes.append(start + spacing * np.arange(n))
    return axes[0], axes[1]


def _disk_means(nodes, xy, gamma, radius, box):
    """Mean of ``gamma`` over the points of ``xy`` within ``radius`` of each node, and their count."""
    if box is not None:
        tree = cKDTree(box.wrap(xy), boxsize=box.lengths)
    else:
        tree = cKDTree(xy)
    members = tree.query_ball_point(nodes, r=radius)
    counts = np.fromiter((len(m) for m in members), np.int64, len(members))
    index = np.concatenate([np.asarray(m, np.int64) for m in members]) if counts.sum() else np.zeros(0, np.int64)
    owner = np.repeat(np.arange(len(nodes)), counts)
    total = np.bincount(owner, gamma.real[index], len(nodes)) + 1j * np.bincount(owner, gamma.imag[index], len(nodes))
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / counts, counts


def _reach(cells, r_cell):
    """Largest distance from each centroid still counted as inside the cell, px.

    ``COVER_FACTOR * max(sqrt(area / pi), R_cell)``: large cells reach further, and
    small cells next to large ones do not punch holes into the coverage.
    """
    column = "area" if "area" in cells.columns else "polygon_area" if "polygon_area" in cells.columns else None
    r = np.full(len(cells), r_cell)
    if column is not None:
        own = np.sqrt(np.abs(cells[column].to_numpy(float)) / np.pi)
        r = np.fmax(r, own)  # fmax ignores NaN areas
    return COVER_FACTOR * r


def _coverage(gx, gy, radius, spacing, all_xy, interior, reach, r_cell):
    """Fraction of each node's disk lying on interior cells (open images, see :func:`coarse_grain`).

    The tissue mask is sampled on a raster of pitch ``spacing / k <= R_cell / 4`` aligned with
    the grid (every node is a raster point); a raster point is on the tissue when its nearest
    centroid is an interior cell within that cell's ``reach``.  The disk sums are one FFT
    correlation of the mask with the disk, read off at the nodes.
    """
    k = max(1, int(np.ceil(4.0 * spacing / r_cell)))
    step = spacing / k
    pad = int(np.ceil(radius / step))
    rx = gx[0] + step * np.arange(-pad, (len(gx) - 1) * k + pad + 1)
    ry = gy[0] + step * np.arange(-pad, (len(gy) - 1) * k + pad + 1)
    px, py = np.meshgrid(rx, ry)
    dist, nearest = cKDTree(all_xy).query(np.c_[px.ravel(), py.ravel()])
    mask = (interior[nearest] & (dist <= reach[nearest])).reshape(px.shape)
    off = np.arange(-pad, pad + 1) * step
    disk = (off[None, :] ** 2 + off[:, None] ** 2) <= radius**2
    inside = _valid_correlation(mask.astype(float), disk.astype(float))
    return (np.rint(inside[::k, ::k]) / disk.sum()).ravel()


def _valid_correlation(image, kernel):
    """``scipy.signal.correlate(image, kernel, "valid")`` by FFT (kernel point-symmetric, so = convolution).

    Uses scipy.fft directly: importing scipy.signal costs seconds.
    """
    from scipy import fft

    shape = [fft.next_fast_len(m + q - 1, real=True) for m, q in zip(image.shape, kernel.shape)]
    full = fft.irfft2(fft.rfft2(image, shape) * fft.rfft2(kernel, shape), shape)
    return full[kernel.shape[0] - 1: image.shape[0], kernel.shape[1] - 1: image.shape[1]]


def _coarse_grain_frame(cells, p, radius, spacing, box, min_coverage):
    """Grid table (without ``frame``) of one frame's cells."""
    xy_all = cells[["x", "y"]].to_numpy(float)
    gamma = cells[f"gamma{p}_re"].to_numpy(float) + 1j * cells[f"gamma{p}_im"].to_numpy(float)
    use = interior_mask(cells) & np.isfinite(gamma) & np.isfinite(xy_all).all(axis=1)
    if not use.any():
        raise InputError("cells has no interior cell with finite x, y and gamma to coarse-grain")
    need_rcell = radius is None or spacing is None or box is None
    r_cell = cell_radius(cells) if need_rcell else np.nan
    radius = RADIUS_FACTOR * r_cell if radius is None else radius
    spacing = SPACING_FACTOR * r_cell if spacing is None else spacing
    gx, gy = _grid_axes(xy_all[use], spacing, box)
    col, row = np.meshgrid(np.arange(len(gx)), np.arange(len(gy)))
    nodes = np.c_[gx[col.ravel()], gy[row.ravel()]]
    mean, counts = _disk_means(nodes, xy_all[use], gamma[use], radius, box)
    if box is None:
        finite = np.isfinite(xy_all).all(axis=1)
        reach = _reach(cells, r_cell)
        coverage = _coverage(gx, gy, radius, spacing, xy_all[finite], use[finite], reach[finite], r_cell)
    else:
        coverage = np.ones(len(nodes))
    return pd.DataFrame(
        {
            "node": np.arange(len(nodes), dtype=np.int64),
            "row": row.ravel().astype(np.int64),
            "col": col.ravel().astype(np.int64),
            "x": nodes[:, 0],
            "y": nodes[:, 1],
            f"Gamma{p}_re": mean.real,
            f"Gamma{p}_im": mean.imag,
            "n_cells": counts,
            "coverage": coverage,
            "valid": (counts > 0) & (coverage >= min_coverage),
            "radius": np.full(len(nodes), radius),
            "spacing": np.full(len(nodes), spacing),
        }
    )


def coarse_grain(cells, p=6, radius=None, spacing=None, box=None, min_coverage=1.0):
    """Coarse-grained shape parameter Gamma_p on a square grid.

    ``Gamma_p(r)`` is the mean of the cells' ``gamma_p`` over the cells whose
    centroid lies within a disk of radius ``R`` centred at the node ``r``
    (Armengol-Collado et al. 2023, Methods).  Border cells (``is_border``)
    never enter the mean.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table: ``x``, ``y`` (centroid, px; x = column, y = row, origin
        at the centre of pixel (0, 0)), ``gamma{p}_re``, ``gamma{p}_im``;
        optionally ``is_border`` (default: no border cells), ``area`` or
        ``polygon_area`` (px^2; needed for the defaults and on open images)
        and ``frame`` (a movie: each frame is coarse-grained on its own and
        ``frame`` is passed through).
    p : int
        Symmetry order (2 nematic, 6 hexatic).
    radius : float, optional
        Disk radius R, px.  Default ``1.5 R_cell`` with
        ``R_cell = sqrt(mean area / pi)`` of the frame's interior cells
        (:func:`cell_radius`).
    spacing : float, optional
        Grid spacing, px.  Default ``R_cell``.  In a periodic box the grid
        tiles the box exactly (``round(L / spacing)`` nodes per side, so the
        actual spacing along x and y is ``Lx / nx`` and ``Ly / ny``).
    box : Box, optional
        Periodic box: distances are minimum-image and every node with at
        least one cell in its disk is valid.  ``None`` (or a non-periodic box)
        means an open image.
    min_coverage : float
        Open images only: a node is ``valid`` when at least this fraction of
        its disk lies on interior cells.  The fraction is measured on a raster
        of pitch at most ``R_cell / 4`` aligned with the grid (the disk's
        raster points); a point lies on an interior cell when its nearest
        cell centroid (border cells included) belongs to an interior cell c and
        is closer than ``1.5 max(sqrt(area_c / pi), R_cell)`` (a regular
        hexagon's corners are ``1.1 sqrt(area / pi)`` from its centre).  The default 1.0 keeps only disks that
        lie wholly inside the tissue, so the tissue edge, the border cells and
        holes do not bias Gamma_p.

    Returns
    -------
    pandas.DataFrame
        Grid table, one row per node (row-major), per frame:
        ``frame`` (0 for a table without one), ``node`` (id, 0-based per frame), ``row``,
        ``col`` (node index along y and x), ``x``, ``y`` (node position, px),
        ``Gamma{p}_re``, ``Gamma{p}_im`` (dimensionless; NaN when the disk is
        empty), ``n_cells`` (cells in the disk), ``coverage`` (fraction of the
        disk on interior cells; 1 in a periodic box), ``valid`` (bool: used
        for statistics and defects), ``radius`` (R, px) and ``spacing``
        (requested grid spacing, px).
    """
    p = check_p(p)
    radius, spacing = _check_length(radius, "radius"), _check_length(spacing, "spacing")
    box = as_box(box)
    if not 0.0 <= min_coverage <= 1.0:
        raise InputError(f"min_coverage must be a fraction in [0, 1]; got {min_coverage!r}")
    if not isinstance(cells, pd.DataFrame):
        raise InputError(f"cells must be a pandas DataFrame; got {type(cells).__name__}")
    needed = ["x", "y", f"gamma{p}_re", f"gamma{p}_im"]
    missing = [c for c in needed if c not in cells.columns]
    if missing:
        raise InputError(f"cells is missing column(s) {missing}; expected {needed} (compute gamma with p={p})")
    if len(cells) == 0:
        raise InputError("cells is empty; expected at least one interior cell to coarse-grain")
    if "frame" not in cells.columns:  # a table built by hand: one image, frame 0
        cells = cells.assign(frame=np.int64(0))
    parts = []
    for frame, group in cells.groupby("frame", sort=True):
        grid = _coarse_grain_frame(group, p, radius, spacing, box, min_coverage)
        grid.insert(0, "frame", np.full(len(grid), frame, dtype=cells["frame"].dtype))
        parts.append(grid)
    return validate(pd.concat(parts, ignore_index=True), "grid")


def order_vs_radius(cells, p=6, factors=(1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0), box=None, min_coverage=1.0):
    """Mean ``|Gamma_p|`` over the valid grid nodes as a function of the coarse-graining radius.

    For each factor, every frame is coarse-grained (:func:`coarse_grain`)
    with ``R = factor * R_cell`` (R_cell of that frame, grid spacing R_cell)
    and ``|Gamma_p|`` is averaged over its valid nodes.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table as for :func:`coarse_grain` (``area`` needed).
    p : int
        Symmetry order.
    factors : sequence of float
        Radii in units of R_cell.
    box, min_coverage
        As for :func:`coarse_grain`.

    Returns
    -------
    pandas.DataFrame
        One row per frame and factor: ``frame``, ``p``,
        ``factor`` (R / R_cell), ``radius`` (R, px), ``abs_Gamma`` (mean
        ``|Gamma_p|`` over valid nodes, dimensionless; NaN when none is
        valid), ``n_nodes`` (valid nodes).
    """
    p = check_p(p)
    groups = cells.groupby("frame", sort=True) if "frame" in cells.columns else [(0, cells)]
    rows = []
    for frame, group in groups:
        r_cell = cell_radius(group)
        for factor in factors:
            grid = coarse_grain(group, p=p, radius=float(factor) * r_cell, spacing=r_cell, box=box,
                                min_coverage=min_coverage)
            valid = grid[grid["valid"]]
            size = np.hypot(valid[f"Gamma{p}_re"], valid[f"Gamma{p}_im"]).to_numpy()
            rows.append((frame, p, float(factor), float(factor) * r_cell,
                         size.mean() if len(size) else np.nan, len(size)))
    out = pd.DataFrame(rows, columns=["frame", "p", "factor", "radius", "abs_Gamma", "n_nodes"])
    return out
