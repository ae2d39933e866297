"""p-atic shape order of cells.

The shape function of a polygon with vertices ``r_v`` (relative to a cell
centre, ``x`` = column, ``y`` = row) is

    gamma_p = sum_v |r_v|^p exp(i p phi_v) / sum_v |r_v|^p,

a complex number with ``|gamma_p| <= 1`` (1 for a regular p-gon) whose
argument divided by ``p`` is the cell's p-fold orientation.
"""
from __future__ import annotations

import numpy as np

from .errors import InputError

__all__ = ["shape_function", "shape_function_flat", "polygon_area_centroid"]

CENTERS = ("vertex_mean", "area_centroid")


def _segment_sum(values, starts, n):
    """Sum of ``values`` over the consecutive segments beginning at ``starts`` (empty segments give 0)."""
    out = np.zeros((n,) + values.shape[1:], dtype=values.dtype)
    if n == 0 or len(values) == 0:
        return out
    nonempty = np.r_[starts[1:], len(values)] > starts
    if nonempty.any():
        out[nonempty] = np.add.reduceat(values, starts[nonempty], axis=0)
    return out


def polygon_area_centroid(xy, starts):
    """Signed shoelace area and area centroid of polygons stored back to back.

    Parameters
    ----------
    xy : (M, 2) float array
        Vertices (x, y) of all polygons, each polygon contiguous (unwrapped), not closed.
    starts : (N,) int array
        Index in ``xy`` of each polygon's first vertex (ascending).

    Returns
    -------
    area : (N,) array
        Signed area, px^2 (positive = counter-clockwise in x, y).
    centroid : (N, 2) array
        Area centroid (x, y) in px; NaN for polygons of zero area.
    """
    n = len(starts)
    lengths = np.diff(np.r_[starts, len(xy)])
    nxt = np.arange(len(xy)) + 1
    ends = starts + lengths
    nxt[ends[lengths > 0] - 1] = starts[lengths > 0]  # close each polygon
    x0, y0 = xy[:, 0], xy[:, 1]
    x1, y1 = xy[nxt, 0], xy[nxt, 1]
    cross = x0 * y1 - x1 * y0
    area = 0.5 * _segment_sum(cross, starts, n)
    cx = _segment_sum((x0 + x1) * cross, starts, n)
    cy = _segment_sum((y0 + y1) * cross, starts, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = np.stack([cx, cy], axis=1) / (6.0 * area[:, None])
    return area, centroid


def shape_function_flat(xy, starts, p=6, center="vertex_mean"):
    """:func:`shape_function` for polygons stored back to back in one ``(M, 2)`` array.

    ``starts`` gives each polygon's first row in ``xy``.  Polygons must be
    contiguous (unwrapped in periodic boxes) and not closed.  Polygons with
    fewer than three vertices give NaN.
    """
    xy = np.asarray(xy, dtype=float)
    starts = np.asarray(starts, dtype=np.int64)
    n = len(starts)
    lengths = np.diff(np.r_[starts, len(xy)])
    if isinstance(center, str):
        if center == "vertex_mean":
            with np.errstate(invalid="ignore", divide="ignore"):
                c = _segment_sum(xy, starts, n) / lengths[:, None]
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
    num = _segment_sum(weight * phase, starts, n)
    den = _segment_sum(weight, starts, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        gamma = num / den
    gamma[(lengths < 3) | ~(den > 0)] = np.nan
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
    if isinstance(p, bool) or not isinstance(p, (int, np.integer)) or p < 1:
        raise InputError(f"p must be a positive integer symmetry order; got {p!r}")
    arrays = []
    for k, poly in enumerate(polygons):
        a = np.asarray(poly, dtype=float)
        if a.ndim != 2 or a.shape[1] != 2:
            raise InputError(f"polygons[{k}] must be an (n, 2) array of (x, y) vertices; got shape {a.shape}")
        if len(a) > 1 and np.array_equal(a[0], a[-1]):
            a = a[:-1]
        arrays.append(a)
    if not arrays:
        return np.zeros(0, dtype=complex)
    starts = np.cumsum([0] + [len(a) for a in arrays[:-1]])
    return shape_function_flat(np.concatenate(arrays), starts, p=p, center=center)
