"""The Gamma_p grid's geometry: the cell radius, the lattice of nodes, each node's disks and how much of
them the tissue covers.
"""
from __future__ import annotations

import numpy as np

from .._dispatch import Kernels
from ..errors import InputError, check_positive
from ..options import VALIDITY
from ..schema import interior_mask
from . import _kernels


K = Kernels(_kernels, "hexatissue.order._reference")

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
