"""Exact curved tissues for the surface stage: Voronoi tissues on analytic surfaces, projected to labels + heights.

Each tissue is what a surface projection (LocalZProjector, SurfCut, ...)
gives of an epithelium lying on the surface: the projected label image
(``labels[row, col]``: the cell seen at pixel (x = col, y = row)) and the
height map (``height[row, col]``: z of the surface there, px), with the
cells' exact areas and perimeters on the surface.

- :func:`tilted_plane_tissue`: a flat Voronoi tissue on a plane tilted by an
  angle about the x axis; its truth is the flat tissue's own polygons (area,
  perimeter, gamma_p), and ``flat_labels`` the same tissue imaged flat.
- :func:`gaussian_bump_tissue`: a Voronoi tessellation of the (x, y)
  parameter plane lifted onto ``z = h exp(-r^2 / 2 s^2)``; areas are the
  integrals of ``sqrt(1 + |grad z|^2)`` over each cell (7-point degree-5
  rule on a fine subdivision of the cell's triangles), perimeters the
  lifted ridges' lengths (Gauss-Legendre on sub-segments).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.spatial import cKDTree

from .errors import InputError, check_orders, check_positive
from .geometry import pack_polygons, polygon_perimeter
from .order.shape import shape_functions_flat
from .synthetic import jittered_seeds, voronoi_labels, voronoi_polygons

__all__ = ["SurfaceTissue", "tilted_plane_tissue", "gaussian_bump_tissue"]

#: The 7-point degree-5 rule on a triangle (Radon): barycentric points and weights (summing to 1).
_A1, _B1, _A2, _B2 = 0.059715871789770, 0.470142064105115, 0.797426985353087, 0.101286507323456
_TRIANGLE_POINTS = np.array([[1 / 3, 1 / 3, 1 / 3],
                             [_A1, _B1, _B1], [_B1, _A1, _B1], [_B1, _B1, _A1],
                             [_A2, _B2, _B2], [_B2, _A2, _B2], [_B2, _B2, _A2]])
_TRIANGLE_WEIGHTS = np.array([0.225] + [0.132394152788506] * 3 + [0.125939180544827] * 3)


@dataclass
class SurfaceTissue:
    """A tissue on an analytic surface, as a surface projection gives it, with its exact cells.

    Attributes
    ----------
    labels : (rows, cols) int32 array
        The projected tissue: cell ``k`` is the Voronoi cell of ``seeds[k - 1]``.
    height : (rows, cols) float array
        z of the surface at every pixel centre, px.
    seeds : (n, 2) array
        The cells' seeds in the surface's own parameter plane (the tissue's
        plane for a tilted plane; x, y for a bump), px.
    truth : pandas.DataFrame
        One row per cell wholly inside the image: ``cell``, ``area`` (px^2),
        ``perimeter`` (px) on the surface; for a plane also ``gamma{p}_re``,
        ``gamma{p}_im`` of the cell in its own plane (first axis the image x
        axis, which lies in the plane).
    flat_labels : (rows, cols) int32 array or None
        The same tissue imaged flat (a plane's own frame); None for a bump.
    """

    labels: np.ndarray
    height: np.ndarray
    seeds: np.ndarray
    truth: pd.DataFrame
    flat_labels: np.ndarray | None = None


def tilted_plane_tissue(tilt=50.0, shape=(240, 320), spacing=24.0, jitter=0.35, p=(6, 2), seed=0) -> SurfaceTissue:
    """A flat Voronoi tissue on a plane tilted by ``tilt`` degrees about the image x axis.

    The tissue's plane has coordinates (u, v), px; its point (u, v) sits at
    ``(x, y, z) = (u, v cos(tilt), v sin(tilt))``, so the projected image is
    the flat tissue squeezed by ``cos(tilt)`` along y and the height map is
    ``z = y tan(tilt)``.

    Parameters
    ----------
    tilt : float
        Tilt angle, degrees, in [0, 80).
    shape : (int, int)
        ``(rows, cols)`` of the flat tissue; the projected image has
        ``round(rows cos(tilt))`` rows.
    spacing, jitter, seed
        The seeds (:func:`hexatissue.synthetic.jittered_seeds`): cells about
        ``spacing`` px across in the tissue's plane.
    p : tuple of int
        Orders of the shape functions in ``truth``.

    Returns
    -------
    SurfaceTissue
        ``truth`` holds the flat cells (in the tissue's plane) that lie wholly
        inside both the flat and the projected image.
    """
    tilt = float(tilt)
    if not 0.0 <= tilt < 80.0:
        raise InputError(f"tilt must be an angle in degrees in [0, 80); got {tilt!r}")
    orders = check_orders(p)
    rows, cols = (check_positive(n, "shape", integer=True) for n in shape)
    cos = np.cos(np.radians(tilt))
    seeds = jittered_seeds((rows, cols), spacing, jitter, seed)
    image_rows = max(1, int(round(rows * cos)))
    gy, gx = np.mgrid[0:image_rows, 0:cols].astype(float)
    labels = _nearest(seeds, np.column_stack([gx.ravel(), gy.ravel() / cos])).reshape(image_rows, cols)
    height = gy * np.tan(np.radians(tilt))
    polygons = voronoi_polygons(seeds, (rows, cols))
    lo, hi = -0.5, np.array([cols - 0.5, image_rows - 0.5])
    cells = [k for k, xy in polygons.items() if np.all((xy[:, 1] * cos >= lo) & (xy[:, 1] * cos <= hi[1]))]
    xy, starts = pack_polygons([polygons[k] for k in cells])
    area = np.array([_shoelace(polygons[k]) for k in cells])
    truth = {"cell": np.array(cells, np.int64), "area": area, "perimeter": polygon_perimeter(xy, starts)}
    for q, gamma in zip(orders, shape_functions_flat(xy, starts, orders) if cells else [np.zeros(0)] * len(orders)):
        truth[f"gamma{q}_re"], truth[f"gamma{q}_im"] = gamma.real, gamma.imag
    return SurfaceTissue(labels=labels, height=height, seeds=seeds, truth=pd.DataFrame(truth),
                         flat_labels=voronoi_labels(seeds, (rows, cols)))


def gaussian_bump_tissue(shape=(256, 256), amplitude=80.0, width=60.0, spacing=20.0, jitter=0.35, seed=0,
                         subdivisions=8) -> SurfaceTissue:
    """A Voronoi tissue of the (x, y) plane lifted onto the Gaussian bump ``z = h exp(-r^2 / 2 s^2)``.

    Parameters
    ----------
    shape : (int, int)
        ``(rows, cols)`` of the image; the bump is centred on it.
    amplitude, width : float
        ``h`` and ``s``, px (the steepest slope is ``h / s * exp(-1/2)``, at
        ``r = s``; the curvature radius at the top is ``s^2 / h``).
    spacing, jitter, seed
        The seeds (:func:`hexatissue.synthetic.jittered_seeds`), in (x, y).
    subdivisions : int
        Each cell triangle (centroid to side) is cut into ``subdivisions^2``
        triangles for the area integral, each side into ``subdivisions``
        segments for the perimeter (8: converged to 1e-9 relative).

    Returns
    -------
    SurfaceTissue
        ``truth`` with ``cell``, ``area``, ``perimeter`` on the bump, for the
        cells wholly inside the image.
    """
    rows, cols = (check_positive(n, "shape", integer=True) for n in shape)
    h, s = float(amplitude), check_positive(width, "width")
    n_sub = check_positive(subdivisions, "subdivisions", integer=True)
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])

    def z(x, y):
        return h * np.exp(-((x - centre[0]) ** 2 + (y - centre[1]) ** 2) / (2 * s * s))

    def gradient(x, y):
        g = -z(x, y) / (s * s)
        return g * (x - centre[0]), g * (y - centre[1])

    def metric(x, y):  # sqrt(1 + |grad z|^2)
        gx, gy = gradient(x, y)
        return np.sqrt(1 + gx ** 2 + gy ** 2)

    seeds = jittered_seeds((rows, cols), spacing, jitter, seed)
    gy, gx = np.mgrid[0:rows, 0:cols].astype(float)
    polygons = voronoi_polygons(seeds, (rows, cols))
    cells = sorted(polygons)
    areas, perimeters = [], []
    for k in cells:
        areas.append(_surface_area(polygons[k], metric, n_sub))
        perimeters.append(_lifted_length(polygons[k], gradient, n_sub))
    truth = pd.DataFrame({"cell": np.array(cells, np.int64), "area": np.array(areas), "perimeter": np.array(perimeters)})
    return SurfaceTissue(labels=voronoi_labels(seeds, (rows, cols)), height=z(gx, gy), seeds=seeds, truth=truth)


def _nearest(seeds, points):
    """Label (1-based) of the nearest seed of every point."""
    return (cKDTree(seeds).query(points, workers=-1)[1] + 1).astype(np.int32)


def _shoelace(xy):
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)))


def _surface_area(xy, metric, n_sub):
    """Integral of ``metric`` over a convex polygon: its fan from the vertex mean, each triangle cut ``n_sub^2`` ways."""
    i, j = np.meshgrid(np.arange(n_sub), np.arange(n_sub), indexing="ij")
    keep = i + j < n_sub
    up = np.stack([i[keep], j[keep]], axis=1)  # sub-triangles (i, j), (i+1, j), (i, j+1)
    keep = i + j < n_sub - 1
    down = np.stack([i[keep], j[keep]], axis=1)  # sub-triangles (i+1, j), (i, j+1), (i+1, j+1)
    corners = np.concatenate([np.stack([up, up + [1, 0], up + [0, 1]], axis=1),
                              np.stack([down + [1, 0], down + [0, 1], down + [1, 1]], axis=1)]) / n_sub
    # quadrature points in the unit triangle's (a, b) coordinates: the point is c + a (p0 - c) + b (p1 - c)
    ab = np.einsum("qk,tkd->tqd", _TRIANGLE_POINTS, corners).reshape(-1, 2)
    weights = np.tile(_TRIANGLE_WEIGHTS, len(corners)) / len(corners)  # each sub-triangle: 1 / n_sub^2 of the area
    centre = xy.mean(axis=0)
    total = 0.0
    for p0, p1 in zip(xy, np.roll(xy, -1, axis=0)):
        d0, d1 = p0 - centre, p1 - centre
        area = 0.5 * abs(d0[0] * d1[1] - d0[1] * d1[0])
        pts = centre + ab[:, :1] * d0 + ab[:, 1:] * d1
        total += area * float(np.dot(weights, metric(pts[:, 0], pts[:, 1])))
    return total


def _lifted_length(xy, gradient, n_sub):
    """Length of the polygon's sides lifted onto the surface of ``gradient``: 5-point Gauss-Legendre on ``n_sub``
    pieces of each side."""
    nodes, weights = np.polynomial.legendre.leggauss(5)
    t = ((np.arange(n_sub)[:, None] + (nodes[None, :] + 1) / 2) / n_sub).ravel()
    w = np.tile(weights / 2, n_sub) / n_sub
    total = 0.0
    for p0, p1 in zip(xy, np.roll(xy, -1, axis=0)):
        d = p1 - p0
        gx, gy = gradient(*(p0 + t[:, None] * d).T)
        total += float(np.dot(w, np.sqrt(d @ d + (gx * d[0] + gy * d[1]) ** 2)))
    return total
