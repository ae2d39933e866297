"""Plain-numpy reference of the kernel in :mod:`hexatissue.surface._kernels` (same name and signature).

Built from the public numpy functions (:func:`~hexatissue.surface.lift`,
:func:`~hexatissue.surface.tangent_polygons`); the tests compare the kernel
against it.
"""
from __future__ import annotations

import numpy as np

from ..box import Box
from ..geometry import next_vertex, segment_sum
from .tangent import lift, tangent_polygons


def surface_polygons(xy, starts, height, scale, periodic, degenerate_area):
    """Reference of :func:`hexatissue.surface._kernels.surface_polygons`."""
    n, m = len(starts), len(xy)
    box = Box(height.shape[1], height.shape[0]) if periodic else None
    sides = np.empty((2 * m, 2))  # every vertex, then its side's midpoint: lifted, they follow the curved side
    sides[0::2], sides[1::2] = xy, 0.5 * (xy + xy[next_vertex(m, starts)])
    fine, fine_starts = lift(height, sides, scale, box), 2 * starts
    plane = tangent_polygons(fine[0::2], starts, degenerate_area)
    counts = np.maximum(np.diff(np.r_[starts, m]), 1)
    apex = lift(height, segment_sum(xy, starts, n) / counts[:, None], scale, box)
    area = _fan_area(fine, fine_starts, apex, plane["normal"])
    perimeter = segment_sum(np.linalg.norm(fine[next_vertex(2 * m, fine_starts)] - fine, axis=1), fine_starts, n)
    flat = ~np.isfinite(plane["vector_area"])
    area[flat] = perimeter[flat] = np.nan
    return area, perimeter, plane["normal"], plane["uv"]


def _fan_area(xyz, starts, apex, normal):
    """Area of the triangle fan from ``apex`` (one 3-D point per polygon) over each polygon's sides.

    Each triangle counts with the sign of its orientation against the
    polygon's normal, so that a planar polygon gives its exact area from any
    apex in its plane (a non-convex cell's fan folds back on itself).
    """
    n, m = len(starts), len(xyz)
    owner = np.repeat(np.arange(n), np.diff(np.r_[starts, m]))
    a = xyz - apex[owner]
    cross = np.cross(a, a[next_vertex(m, starts)])
    size = np.linalg.norm(cross, axis=1)
    sign = np.where((cross * normal[owner]).sum(axis=1) < 0, -1.0, 1.0)
    return 0.5 * segment_sum(sign * size, starts, n)
