"""Cells measured on the surface a height map gives: vertices lifted to 3-D, each cell in its tangent plane.

Coordinates are ``(x, y, z)`` in px: x = column, y = row (origin at the
centre of pixel (0, 0)) and z the height map's value converted to px, a
right-handed frame.  The functions work on polygons stored back to back
(:mod:`hexatissue.geometry`): ``xy`` of shape ``(M, 2)`` and ``starts``,
the first row of each polygon.
"""
from __future__ import annotations

import numpy as np

from .._dispatch import Kernels
from ..errors import InputError
from ..geometry import bilinear, lookup, next_vertex, row_keys, segment_sum, table_polygons
from ..options import CENTERS
from ..order.shape import shape_functions_flat
from . import _kernels

__all__ = ["check_height", "lift", "cell_heights", "tangent_polygons", "surface_arrays", "surface_cells"]

K = Kernels(_kernels, "hexatissue.surface._reference")

#: A cell whose vector area is below this fraction of its mean squared vertex distance from its centre has no
#: tangent plane (collapsed or collinear vertices): its surface columns are NaN.
DEGENERATE_AREA = 1e-9


def check_height(height, name="height", shape=None) -> np.ndarray:
    """``height`` as a float64 2-D array of finite values (of ``shape`` when given); else :class:`InputError`."""
    try:
        h = np.asarray(height, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a 2-D array of heights; got {type(height).__name__}") from None
    if h.ndim != 2:
        raise InputError(f"{name} must be a 2-D array of heights (rows, cols); got shape {h.shape}")
    if shape is not None and h.shape != tuple(shape):
        raise InputError(f"{name} has shape {h.shape}; expected the labels' shape {tuple(shape)}")
    bad = ~np.isfinite(h)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise InputError(f"{name} holds {int(bad.sum())} NaN or infinite height(s) (first at row {r}, col {c}); "
                         f"fill the pixels with no surface before measuring on it")
    return h


def lift(height, xy, scale=1.0, box=None) -> np.ndarray:
    """The points ``xy`` (x = column, y = row, px) lifted onto the height map: ``(M, 3)`` of x, y, z in px.

    ``z`` is ``scale`` times the height map bilinearly interpolated at the
    point (wrapped on a periodic ``box``, clamped at the edge of an open
    image); ``scale`` converts the height map's unit to px.
    """
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    z = scale * bilinear(height, xy[:, 0], xy[:, 1], box is not None)
    return np.column_stack([xy, z])


def cell_heights(height, x, y, scale=1.0, box=None) -> np.ndarray:
    """The height of the surface above the cells' centres ``(x, y)`` (px): their 3-D positions' z, px.

    ``scale`` times the height map at the points, as :func:`lift` lifts them;
    on a constant height map exactly its value (the bilinear weights would
    change its last bits), so that the cells of an image plane lie at one
    height.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if height.size and float(np.ptp(height)) == 0.0:
        return np.full(len(x), scale * float(height.flat[0]))
    return lift(height, np.column_stack([x, y]), scale, box)[:, 2]


def tangent_polygons(xyz, starts, degenerate_area=DEGENERATE_AREA):
    """Each polygon of 3-D vertices in its own tangent plane.

    Parameters
    ----------
    xyz : (M, 3) float array
        Lifted vertices, polygon after polygon (:func:`lift`), px.
    starts : (N,) int array
        First row of each polygon in ``xyz``.

    Returns
    -------
    dict
        ``normal`` ``(N, 3)``: the unit vector area ``sum_i v_i x v_(i+1) / 2``,
        turned towards +z; ``e1`` ``(N, 3)``: the image x axis projected on
        the tangent plane and normalised; ``e2 = normal x e1``; ``uv``
        ``(M, 2)``: every vertex in that frame, relative to the polygon's
        vertex mean (px); ``vector_area`` ``(N,)``: the length of the vector
        area (px^2).  Rows of polygons with fewer than three vertices, or
        whose vector area is not above ``degenerate_area`` times their
        vertices' mean squared distance from their mean, are NaN.
    """
    xyz = np.asarray(xyz, dtype=float)
    starts = np.asarray(starts, dtype=np.int64)
    n, m = len(starts), len(xyz)
    counts = np.diff(np.r_[starts, m])
    owner = np.repeat(np.arange(n), counts)
    mean = segment_sum(xyz, starts, n) / np.maximum(counts, 1)[:, None]
    local = xyz - mean[owner]  # about the vertex mean: no cancellation of large coordinates
    cross = np.cross(local, local[next_vertex(m, starts)])
    vector = 0.5 * segment_sum(cross, starts, n)
    size = np.linalg.norm(vector, axis=1)
    spread = segment_sum((local ** 2).sum(axis=1), starts, n) / np.maximum(counts, 1)
    bad = (counts < 3) | ~(size > degenerate_area * spread)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = vector / size[:, None]
    normal[normal[:, 2] < 0] *= -1  # a height map's surface faces +z
    # e1: the image x axis in the tangent plane (a height map's plane is never vertical: n_z > 0)
    e1 = np.column_stack([1.0 - normal[:, 0] ** 2, -normal[:, 0] * normal[:, 1], -normal[:, 0] * normal[:, 2]])
    with np.errstate(invalid="ignore", divide="ignore"):
        e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(normal, e1)
    normal[bad] = e1[bad] = e2[bad] = np.nan
    uv = np.column_stack([(local * e1[owner]).sum(axis=1), (local * e2[owner]).sum(axis=1)])
    size[bad] = np.nan
    return {"normal": normal, "e1": e1, "e2": e2, "uv": uv, "vector_area": size}


def surface_arrays(xy, starts, take, height, scale=1.0, box=None, p=(6, 2), center="vertex_mean") -> dict:
    """The surface columns of the rows whose polygon is ``take`` (-1: no polygon, NaN).

    Parameters
    ----------
    xy, starts : arrays
        Cell polygons (x = column, y = row, px) back to back, contiguous
        (unwrapped on a periodic box).
    take : (R,) int array
        Each row's polygon (:func:`hexatissue.order.polygon_rows`), -1 for none.
    height : (rows, cols) array
        The height map, finite (:func:`check_height`).
    scale : float
        px per unit of the height map.
    box : Box, optional
        Periodic box (heights read wrapped); None: open image.
    p : tuple of int
        Orders of the surface shape functions.
    center : {"vertex_mean", "area_centroid"}
        Cell centre of the shape functions, taken in the tangent plane.

    Returns
    -------
    dict
        ``surface_area`` (px^2), ``surface_perimeter`` (px), ``normal_x``,
        ``normal_y``, ``normal_z``, ``surface_gamma{p}_re`` /
        ``surface_gamma{p}_im`` for every p: arrays of length R.
    """
    if isinstance(center, str) and center not in CENTERS:
        raise InputError(f"center must be one of {CENTERS}; got {center!r}")
    xy = np.ascontiguousarray(xy, dtype=float).reshape(-1, 2)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    take = np.asarray(take, dtype=np.int64)
    n = len(starts)
    area, perimeter, normal, uv = K.surface_polygons(xy, starts, np.ascontiguousarray(height, dtype=float),
                                                     float(scale), box is not None, DEGENERATE_AREA)
    flat = ~np.isfinite(area)
    per_polygon = {"surface_area": area, "surface_perimeter": perimeter, "normal_x": normal[:, 0],
                   "normal_y": normal[:, 1], "normal_z": normal[:, 2]}
    uv = np.nan_to_num(uv)  # a degenerate cell's NaN frame: its gamma is NaN from the kernel's own test
    orders = tuple(p)
    for q, gamma in zip(orders, shape_functions_flat(uv, starts, orders, center) if n else [np.zeros(0)] * len(orders)):
        gamma = np.where(flat, np.nan + 0j, gamma)
        per_polygon[f"surface_gamma{q}_re"], per_polygon[f"surface_gamma{q}_im"] = gamma.real, gamma.imag
    has = take >= 0
    out = {}
    for name, values in per_polygon.items():
        column = np.full(len(take), np.nan)
        column[has] = values[take[has]]
        out[name] = column
    return out


def surface_cells(cells, vertices, cell_vertices, height, scale=1.0, box=None, p=(6, 2), center="vertex_mean"):
    """``cells`` (a copy) with the surface columns of :func:`surface_arrays`, its polygons read from the tables.

    Parameters
    ----------
    cells, vertices, cell_vertices : pandas.DataFrame
        One frame's tables of :func:`hexatissue.mesh_from_labels` (or of
        :func:`hexatissue.analyze`, for one frame).
    height : (rows, cols) array
        The frame's height map (checked: 2-D and finite).
    scale, box, p, center
        As in :func:`surface_arrays`.

    Returns
    -------
    pandas.DataFrame
        ``cells`` with ``z`` (the height above the centroid, px,
        :func:`cell_heights`), ``surface_area``, ``surface_perimeter``,
        ``normal_x/_y/_z`` and ``surface_gamma{p}_re/_im``; NaN for cells
        without a polygon (but ``z``).
    """
    height = check_height(height)
    keys, xy, starts = table_polygons(vertices, cell_vertices, box)
    take = lookup(row_keys(keys["frame"].to_numpy(np.int64), keys["cell"].to_numpy(np.int64)), None,
                  row_keys(cells["frame"].to_numpy(np.int64), cells["cell"].to_numpy(np.int64)))
    out = cells.copy(deep=False)
    out["z"] = cell_heights(height, cells["x"], cells["y"], scale, box)
    for name, values in surface_arrays(xy, starts, take, height, scale, box, p, center).items():
        out[name] = values
    return out
