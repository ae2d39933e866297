"""p-atic shape order of cells: the order stage.

The shape function of a polygon with vertices ``r_v`` (relative to a cell
centre, ``x`` = column, ``y`` = row) is ::

    gamma_p = sum_v |r_v|^p exp(i p phi_v) / sum_v |r_v|^p,

a complex number with ``|gamma_p| <= 1`` (1 for a regular p-gon) whose
argument divided by ``p`` is the cell's p-fold orientation.  The mesh stage
gives geometry only; :func:`shape_order` adds the ``gamma{p}`` columns, and
:func:`coarse_grain` turns them into the field ``Gamma_p`` on a grid.

The package, by concept (each module imports only those listed before it):
:mod:`.shape` (the shape functions of single cells and their columns),
:mod:`.grid` (the grid's geometry: cell radius, nodes, disk coverage) and
:mod:`.coarse` (:func:`coarse_grain`, :func:`order_vs_radius`).
"""
from __future__ import annotations

from . import grid, shape
from .coarse import coarse_grain, order_vs_radius
from .grid import cell_radius
from .shape import cells_from_polygons, shape_function, shape_function_flat, shape_order

__all__ = [
    "shape_function",
    "shape_function_flat",
    "shape_order",
    "cells_from_polygons",
    "cell_radius",
    "coarse_grain",
    "order_vs_radius",
]

# beyond __all__, the names other code and the tests read from the package keep their names here (assigned, not
# imported: the module map above says where each lives)
K, DEGENERATE_AREA, shape_functions_flat = shape.K, shape.DEGENERATE_AREA, shape.shape_functions_flat
gamma_columns, gamma_arrays, polygon_rows = shape.gamma_columns, shape.gamma_arrays, shape.polygon_rows
RADIUS_FACTOR, SPACING_FACTOR, COVER_FACTOR = grid.RADIUS_FACTOR, grid.SPACING_FACTOR, grid.COVER_FACTOR
MAX_NODES, RASTER_PER_RCELL = grid.MAX_NODES, grid.RASTER_PER_RCELL
_neighbours, _half_widths = grid._neighbours, grid._half_widths
