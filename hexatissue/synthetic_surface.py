"""Exact curved tissues for the surface stage: Voronoi tissues on analytic surfaces, projected to labels + heights.

Each tissue is what a surface projection (LocalZProjector, SurfCut, ...)
gives of an epithelium lying on the surface: the projected label image
(``labels[row, col]``: the cell seen at pixel (x = col, y = row)) and the
height map (``height[row, col]``: z of the surface there, px), with the
cells' exact areas and perimeters on the surface.

- :func:`tilted_plane_tissue`: a flat Voronoi tissue on a plane tilted by an
  angle about the x axis; its truth is the flat tissue's own polygons (area,
  perimeter, gamma_p), and ``flat_labels`` the same tissue imaged flat.
- :func:`junction_stack`: the z-stack a microscope would record of such a
  tissue with its junctions stained (the input of
  :func:`hexatissue.surface.height_map`).
- :func:`gaussian_bump_tissue`: a Voronoi tessellation of the (x, y)
  parameter plane lifted onto ``z = h exp(-r^2 / 2 s^2)``; areas are the
  integrals of ``sqrt(1 + |grad z|^2)`` over each cell (7-point degree-5
  rule on a fine subdivision of the cell's triangles), perimeters the
  lifted ridges' lengths (Gauss-Legendre on sub-segments).
- :func:`tilted_plane_movie`, :func:`bump_movie` (a :class:`SurfaceMovie`
  each): a tissue translating uniformly on a tilted plane (its 3-D
  velocity known), and a tissue on a bump that grows in time (its cells'
  areas known in every frame), for the flow on the surface.

Junction networks at force balance (force inference on a height map; a
:class:`SurfaceNetwork` each):

- :func:`tilted_network`: a flat vertex model at force balance
  (:func:`hexatissue.synthetic.vertex_model_tissue`) cut open and laid
  rigidly on a tilted plane, projected: labels, the plane's height map, the
  exact normals, and the flat tensions and pressures, which a rigid motion
  keeps balanced.
- :func:`bump_vertex_model_tissue`: a periodic vertex model relaxed with its
  vertices on a bump (3-D lengths and lifted polygon areas): exactly
  balanced in the surface's tangent planes.

Triangle meshes with cell labels (the surface-mesh measures,
:func:`hexatissue.surface.mesh_tissue`; a :class:`MeshTissue` each):

- :func:`sphere_tissue`: a spherical Voronoi tissue (seeds on a jittered
  Fibonacci lattice) on a sphere; either rendered on an icosphere whose faces
  take the label of the seed nearest their centroid (jagged cell boundaries
  along mesh edges, as a segmented mesh has), or with ``exact=True`` as the
  exact cells, each fanned from its seed and subdivided on the sphere (cell
  boundaries on the great circles).  Truth from
  :class:`scipy.spatial.SphericalVoronoi`: exact areas and arc perimeters.
- :func:`sphere_movie`: frames of :func:`sphere_tissue` with the seeds
  random-walking.
- :func:`torus_tissue`: a Voronoi-like tissue on a torus (Euler
  characteristic 0), faces labelled by the nearest seed.
- :func:`polygon_mesh`: any polygons (a flat tissue) as a mesh, each fanned
  from its vertex mean.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.ndimage import gaussian_filter
from scipy.spatial import cKDTree

from .errors import InputError, check_orders, check_positive
from .geometry import pack_polygons, polygon_area_centroid, polygon_perimeter
from .order.shape import shape_functions_flat
from .synthetic import jittered_seeds, voronoi_labels, voronoi_polygons

__all__ = ["SurfaceTissue", "tilted_plane_tissue", "gaussian_bump_tissue", "junction_stack", "SurfaceMovie",
           "tilted_plane_movie", "bump_movie", "MeshTissue", "icosphere",
           "subdivide_mesh", "sphere_seeds", "sphere_tissue", "sphere_movie", "torus_tissue", "polygon_mesh",
           "SurfaceNetwork", "tilted_network", "bump_vertex_model_tissue"]

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
    seeds = jittered_seeds((rows, cols), spacing, jitter, seed)
    labels, height, truth = _bump(seeds, (rows, cols), h, s, n_sub)
    return SurfaceTissue(labels=labels, height=height, seeds=seeds, truth=truth)


@dataclass
class SurfaceMovie:
    """A tissue moving on an analytic surface, as a surface projection gives it frame by frame.

    Attributes
    ----------
    labels : (frames, rows, cols) int32 array
        The projected tissue of every frame: cell ``k`` is the Voronoi cell of
        seed ``k - 1`` in every frame (the ids are the tracks).
    height : (frames, rows, cols) or (rows, cols) float array
        z of the surface at every pixel centre, px: one map per frame, or one
        for all frames.
    truth : pandas.DataFrame
        The exact cells: ``frame``, ``cell``, ``area`` (px^2), ``perimeter``
        (px) on the surface, for the cells wholly inside the image.
    velocity : (3,) float array or None
        The 3-D velocity of every cell (x, y, z; px/frame) when the tissue
        moves as a whole.
    """

    labels: np.ndarray
    height: np.ndarray
    truth: pd.DataFrame
    velocity: np.ndarray | None = None


def tilted_plane_movie(tilt=50.0, n_frames=5, velocity=(0.0, 1.0), shape=(240, 320), spacing=24.0, jitter=0.35,
                       seed=0) -> SurfaceMovie:
    """A flat Voronoi tissue translating uniformly in a plane tilted by ``tilt`` degrees about the image x axis.

    As :func:`tilted_plane_tissue`: the plane's point (u, v) sits at
    ``(x, y, z) = (u, v cos(tilt), v sin(tilt))``; the seeds move by
    ``velocity = (du, dv)`` px/frame in the plane's own coordinates, so every
    cell moves at ``|velocity|`` on the surface and the 3-D velocity is
    ``(du, dv cos(tilt), dv sin(tilt))``, of which the image sees
    ``(du, dv cos(tilt))``.  Seeds fill the plane beyond the image, so cells
    enter and leave across its edges.

    Parameters
    ----------
    tilt : float
        Tilt angle, degrees, in [0, 80).
    n_frames : int
        Frames.
    velocity : (float, float)
        ``(du, dv)``, px/frame in the plane.
    shape, spacing, jitter, seed
        As :func:`tilted_plane_tissue` (``shape`` of the flat tissue).

    Returns
    -------
    SurfaceMovie
        ``labels`` per frame, one ``height`` (``z = y tan(tilt)``) for all
        frames, ``truth`` the flat cells' areas and perimeters (the cells
        wholly inside the image, in every frame) and ``velocity``.
    """
    tilt = float(tilt)
    if not 0.0 <= tilt < 80.0:
        raise InputError(f"tilt must be an angle in degrees in [0, 80); got {tilt!r}")
    rows, cols = (check_positive(n, "shape", integer=True) for n in shape)
    n_frames = check_positive(n_frames, "n_frames", integer=True)
    step = np.asarray(velocity, dtype=float)
    if step.shape != (2,) or not np.isfinite(step).all():
        raise InputError(f"velocity must be two finite numbers (du, dv), px/frame; got {velocity!r}")
    cos, sin = np.cos(np.radians(tilt)), np.sin(np.radians(tilt))
    margin = float(spacing) + n_frames * float(np.abs(step).max())
    seeds = jittered_seeds((rows + 2 * margin, cols + 2 * margin), spacing, jitter, seed) - margin
    image_rows = max(1, int(round(rows * cos)))
    gy, gx = np.mgrid[0:image_rows, 0:cols].astype(float)
    points = np.column_stack([gx.ravel(), gy.ravel() / cos])
    labels, truth = [], []
    for t in range(n_frames):
        moved = seeds + t * step
        labels.append(_nearest(moved, points).reshape(image_rows, cols))
        polygons = voronoi_polygons(moved, (rows, cols))
        cells = [k for k, xy in polygons.items() if np.all(xy[:, 1] * cos <= image_rows - 0.5)]
        xy, starts = pack_polygons([polygons[k] for k in cells])
        truth.append(pd.DataFrame({"frame": t, "cell": np.array(cells, np.int64),
                                   "area": np.array([_shoelace(polygons[k]) for k in cells]),
                                   "perimeter": polygon_perimeter(xy, starts)}))
    return SurfaceMovie(labels=np.stack(labels), height=gy * np.tan(np.radians(tilt)),
                        truth=pd.concat(truth, ignore_index=True),
                        velocity=np.array([step[0], step[1] * cos, step[1] * sin]))


def bump_movie(n_frames=5, amplitude=60.0, growth=0.05, width=45.0, drift=(0.0, 0.0), shape=(192, 192), spacing=16.0,
               jitter=0.35, seed=0, subdivisions=4) -> SurfaceMovie:
    """A Voronoi tissue on a Gaussian bump that grows in time, its seeds drifting in (x, y).

    Frame ``t`` is :func:`gaussian_bump_tissue`'s tissue with the height
    ``h_t = amplitude (1 + growth t)`` and the seeds moved by ``t drift``: with
    no drift every cell stays at the same (x, y), so its surface point moves
    straight up at ``dz/dt = amplitude growth exp(-r^2 / 2 s^2)`` and its area
    grows at the rate of the area element ``sqrt(1 + |grad z|^2)``:
    ``d log sqrt(1 + |grad z|^2) / dt = h_t amplitude growth |grad g|^2 / (1 + h_t^2 |grad g|^2)``
    with ``z = h_t g``, ``g = exp(-r^2 / 2 s^2)``.

    Parameters
    ----------
    n_frames : int
        Frames.
    amplitude, width : float
        The bump's height at frame 0 and its width ``s``, px.
    growth : float
        Relative growth of the height per frame (negative: the bump sinks;
        ``1 + growth t`` must stay positive).
    drift : (float, float)
        Velocity of the seeds in (x, y), px/frame.
    shape, spacing, jitter, seed
        As :func:`gaussian_bump_tissue`.
    subdivisions : int
        Of the truth's quadratures (:func:`gaussian_bump_tissue`; against 8
        on cells 12 px apart on a bump h = 60, s = 45 px: 3e-8 relative at
        1, 4e-10 at 2, 5e-12 at 4).

    Returns
    -------
    SurfaceMovie
        ``labels`` and ``height`` per frame, ``truth`` per frame and cell.
    """
    rows, cols = (check_positive(n, "shape", integer=True) for n in shape)
    n_frames = check_positive(n_frames, "n_frames", integer=True)
    s, n_sub = check_positive(width, "width"), check_positive(subdivisions, "subdivisions", integer=True)
    if not 1.0 + float(growth) * (n_frames - 1) > 0.0:
        raise InputError(f"growth {growth!r} flattens the bump within {n_frames} frames (1 + growth t must stay "
                         f"positive)")
    step = np.asarray(drift, dtype=float)
    if step.shape != (2,) or not np.isfinite(step).all():
        raise InputError(f"drift must be two finite numbers (dx, dy), px/frame; got {drift!r}")
    seeds = jittered_seeds((rows, cols), spacing, jitter, seed)
    labels, heights, truth = [], [], []
    for t in range(n_frames):
        frame_labels, height, cells = _bump(seeds + t * step, (rows, cols), float(amplitude) * (1 + growth * t), s,
                                            n_sub)
        labels.append(frame_labels)
        heights.append(height)
        truth.append(cells.assign(frame=t)[["frame", "cell", "area", "perimeter"]])
    return SurfaceMovie(labels=np.stack(labels), height=np.stack(heights), truth=pd.concat(truth, ignore_index=True))


def _bump(seeds, shape, h, s, n_sub):
    """Labels, height map and truth (cells wholly inside the image: ``cell``, ``area``, ``perimeter``) of the Voronoi
    tissue of ``seeds`` in (x, y) on the Gaussian bump of height ``h`` and width ``s`` centred on the image."""
    rows, cols = shape
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])

    def z(x, y):
        return h * np.exp(-((x - centre[0]) ** 2 + (y - centre[1]) ** 2) / (2 * s * s))

    def gradient(x, y):
        g = -z(x, y) / (s * s)
        return g * (x - centre[0]), g * (y - centre[1])

    def metric(x, y):  # sqrt(1 + |grad z|^2)
        gx, gy = gradient(x, y)
        return np.sqrt(1 + gx ** 2 + gy ** 2)

    gy, gx = np.mgrid[0:rows, 0:cols].astype(float)
    polygons = voronoi_polygons(seeds, (rows, cols))
    cells = sorted(polygons)
    areas, perimeters = [], []
    for k in cells:
        areas.append(_surface_area(polygons[k], metric, n_sub))
        perimeters.append(_lifted_length(polygons[k], gradient, n_sub))
    truth = pd.DataFrame({"cell": np.array(cells, np.int64), "area": np.array(areas), "perimeter": np.array(perimeters)})
    return voronoi_labels(seeds, (rows, cols)), z(gx, gy), truth


def junction_stack(tissue, z_step=4.0, n_planes=None, psf_xy=1.0, psf_z=6.0, background=0.1, noise=0.05,
                   seed=0) -> np.ndarray:
    """The z-stack of a :class:`SurfaceTissue` with its junctions stained, plane 0 at height 0.

    Every junction pixel (a pixel whose 4-neighbour is another cell) shines
    with intensity 1 at its surface height; the signal is blurred by a
    Gaussian point spread function (``psf_xy`` laterally, ``psf_z`` along z,
    px) and sampled every ``z_step`` px; a uniform ``background`` and
    Gaussian ``noise`` (standard deviation, in units of the junctions'
    intensity) are added.

    Parameters
    ----------
    tissue : SurfaceTissue
        Labels and height map (px).
    z_step : float
        Plane spacing, px: the true height in planes is ``height / z_step``.
    n_planes : int, optional
        Default: enough to hold the surface with ``2 psf_z`` to spare on either
        side (plane 0 at height 0).
    psf_xy, psf_z, background, noise, seed
        Imaging: lateral and axial blur (px), background, noise.

    Returns
    -------
    (planes, rows, cols) float32 array
    """
    labels, height = np.asarray(tissue.labels), np.asarray(tissue.height, float)
    z_step = check_positive(z_step, "z_step", unit="px")
    if n_planes is None:
        n_planes = int(np.ceil((height.max() + 2 * psf_z) / z_step)) + 1
    junction = np.zeros(labels.shape, bool)
    junction[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    junction[:, :-1] |= labels[:, 1:] != labels[:, :-1]
    junction[1:] |= labels[1:] != labels[:-1]
    junction[:-1] |= labels[1:] != labels[:-1]
    z = np.arange(n_planes)[:, None, None] * z_step
    profile = np.exp(-0.5 * ((z - height[None]) / psf_z) ** 2)
    stack = gaussian_filter(junction[None] * profile, (0.0, psf_xy, psf_xy)) if psf_xy > 0 else junction * profile
    rng = np.random.default_rng(seed)
    return (stack + background + noise * rng.standard_normal(stack.shape)).astype(np.float32)


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


# ------------------------------------------------------------------------------------------- triangle meshes


@dataclass
class MeshTissue:
    """A tissue as a triangle mesh with one cell label per face, and its exact cells where known.

    Attributes
    ----------
    vertices : (n, 3) float array
        px.
    faces : (m, 3) int64 array
        Triangles, counter-clockwise seen from outside (outward normals).
    labels : (m,) int64 array
        Cell of every face (``k``: the cell of ``seeds[k - 1]``).
    seeds : (N, 3) float array
        The cells' seeds on the surface, px.
    truth : pandas.DataFrame or None
        Per cell: ``cell``, ``area`` (px^2), ``perimeter`` (px),
        ``n_sides`` of the exact cell (spheres); None where not known (torus).
    euler : int
        The surface's Euler characteristic (2 sphere, 0 torus).
    """

    vertices: np.ndarray
    faces: np.ndarray
    labels: np.ndarray
    seeds: np.ndarray
    truth: pd.DataFrame | None
    euler: int


def subdivide_mesh(vertices, faces, labels=None, times=1, project=None):
    """Each triangle cut into 4 (edge midpoints) ``times`` times; ``project`` maps new points (e.g. onto a sphere).

    Shared edges get one midpoint, so a closed mesh stays closed; the
    orientation and each face's label (repeated 4 times) are kept.
    Returns ``(vertices, faces, labels)``.
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    lab = None if labels is None else np.asarray(labels, dtype=np.int64)
    for _ in range(int(times)):
        edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        key = np.sort(edges, axis=1)
        unique, inverse = np.unique(key, axis=0, return_inverse=True)
        mid = 0.5 * (v[unique[:, 0]] + v[unique[:, 1]])
        if project is not None:
            mid = project(mid)
        m = len(f)
        ab, bc, ca = (len(v) + inverse.reshape(3, m)).astype(np.int64)
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        f = np.concatenate([np.c_[a, ab, ca], np.c_[ab, b, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]])
        v = np.concatenate([v, mid])
        if lab is not None:
            lab = np.tile(lab, 4)
    return v, f, lab


def _unit(x):
    return x / np.linalg.norm(x, axis=1)[:, None]


def icosphere(subdivisions=4, radius=1.0):
    """A geodesic sphere: the icosahedron cut ``subdivisions`` times (20 * 4^s faces), vertices on the sphere.

    Faces are counter-clockwise seen from outside.  Returns ``(vertices, faces)``.
    """
    t = (1 + 5 ** 0.5) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    v, f, _ = subdivide_mesh(_unit(v), f, None, check_positive(subdivisions + 1, "subdivisions", integer=True) - 1,
                             _unit)
    return radius * _unit(v), f


def sphere_seeds(n_cells, jitter=0.3, seed=0):
    """``n_cells`` unit vectors: a Fibonacci lattice, each moved by up to ``jitter`` times the lattice spacing."""
    n = check_positive(n_cells, "n_cells", integer=True)
    rng = np.random.default_rng(seed)
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5 ** 0.5) * k
    r = np.sqrt(1 - z * z)
    u = np.c_[r * np.cos(phi), r * np.sin(phi), z]
    spacing = np.sqrt(4 * np.pi / n)
    step = rng.normal(size=(n, 3))
    step -= (step * u).sum(axis=1)[:, None] * u
    step = _unit(step) * (jitter * spacing * np.sqrt(rng.uniform(size=n)))[:, None]
    return _unit(u + step)


def _spherical_truth(units, radius):
    from scipy.spatial import SphericalVoronoi

    sv = SphericalVoronoi(units, radius=1.0)
    sv.sort_vertices_of_regions()
    areas = sv.calculate_areas() * radius ** 2
    regions, perimeters = [], []
    for k, region in enumerate(sv.regions):
        region = list(region)
        w = sv.vertices[region]
        if np.dot(units[k], np.cross(w[1] - w[0], w[2] - w[0])) < 0:  # counter-clockwise seen from outside
            region = region[::-1]
            w = w[::-1]
        regions.append(region)
        dots = np.clip((w * np.roll(w, -1, axis=0)).sum(axis=1), -1, 1)
        perimeters.append(radius * np.arccos(dots).sum())
    truth = pd.DataFrame({"cell": np.arange(1, len(units) + 1, dtype=np.int64), "area": areas,
                          "perimeter": np.array(perimeters), "n_sides": np.array([len(r) for r in regions], np.int64)})
    return sv.vertices, regions, truth


def _face_graph(faces):
    """Pairs of faces sharing an edge."""
    m = len(faces)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    owner = np.tile(np.arange(m), 3)
    order = np.lexsort((key[:, 1], key[:, 0]))
    k, o = key[order], owner[order]
    same = (k[1:] == k[:-1]).all(axis=1)
    return o[:-1][same], o[1:][same]


def _connected_labels(faces, labels):
    """Labels with every cell in one edge-connected piece: faces off a cell's largest piece take their neighbours'
    most common label (repeated until none is left)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    a, b = _face_graph(faces)
    lab = labels.copy()
    m = len(faces)
    for _ in range(20):
        same = lab[a] == lab[b]
        graph = coo_matrix((np.ones(int(same.sum())), (a[same], b[same])), shape=(m, m))
        _, comp = connected_components(graph, directed=False)
        size = np.bincount(comp)
        best = np.zeros(lab.max() + 1, np.int64)
        np.maximum.at(best, lab, size[comp])
        stray = size[comp] < best[lab]
        if not stray.any():
            return lab
        for f in np.flatnonzero(stray):
            around = np.r_[lab[b[a == f]], lab[a[b == f]]]
            around = around[around != lab[f]]
            if len(around):
                values, counts = np.unique(around, return_counts=True)
                lab[f] = values[np.argmax(counts)]
    return lab


def sphere_tissue(n_cells=100, radius=100.0, seed=0, subdivisions=5, jitter=0.3, exact=False,
                  seeds=None) -> MeshTissue:
    """A spherical Voronoi tissue as a labelled triangle mesh, with its exact cells.

    Parameters
    ----------
    n_cells : int
        Cells (seeds on a jittered Fibonacci lattice, :func:`sphere_seeds`).
    radius : float
        Sphere radius, px.
    seed : int
        Random seed of the jitter.
    subdivisions : int
        Mesh resolution.  Labelled (default): an icosphere cut
        ``subdivisions`` times (20 * 4^s faces, edges about
        ``1.1 radius / 2^s`` long), each face the cell of the seed nearest its
        centroid (a face off its cell's main piece joins its neighbours).
        Exact: each cell's fan from its seed cut ``subdivisions`` times.
    jitter : float
        Seed displacement, times the lattice spacing.
    exact : bool
        Render the exact cells (boundaries on the great circles) instead of
        labelling an icosphere.
    seeds : (n, 3) array, optional
        Seed directions instead of the lattice (normalised).

    Returns
    -------
    MeshTissue
        ``truth``: the exact spherical Voronoi cells' ``area``, ``perimeter``
        (great-circle arcs) and ``n_sides``.
    """
    radius = check_positive(radius, "radius")
    units = sphere_seeds(n_cells, jitter, seed) if seeds is None else _unit(np.asarray(seeds, dtype=float))
    corners, regions, truth = _spherical_truth(units, radius)
    project = _unit
    if exact:
        n_v = len(corners)
        tris, labs = [], []
        for k, region in enumerate(regions):
            r = np.asarray(region)
            tris.append(np.c_[np.full(len(r), n_v + k), r, np.roll(r, -1)])
            labs.append(np.full(len(r), k + 1))
        v, f, lab = subdivide_mesh(np.concatenate([corners, units]), np.concatenate(tris), np.concatenate(labs),
                                   subdivisions, project)
        v = radius * v
    else:
        v, f = icosphere(subdivisions, 1.0)
        centroid = v[f].mean(axis=1)
        lab = cKDTree(units).query(centroid, workers=-1)[1].astype(np.int64) + 1
        lab = _connected_labels(f, lab)
        v = radius * v
    return MeshTissue(vertices=v, faces=f, labels=lab, seeds=radius * units, truth=truth, euler=2)


def sphere_movie(n_cells=100, n_frames=5, radius=100.0, seed=0, subdivisions=5, step=0.1, exact=False):
    """Frames of :func:`sphere_tissue` whose seeds random-walk by ``step`` lattice spacings per frame."""
    n_frames = check_positive(n_frames, "n_frames", integer=True)
    rng = np.random.default_rng(seed)
    units = sphere_seeds(n_cells, 0.3, seed)
    spacing = np.sqrt(4 * np.pi / len(units))
    frames = []
    for _ in range(n_frames):
        frames.append(sphere_tissue(n_cells, radius, seed, subdivisions, exact=exact, seeds=units))
        move = rng.normal(size=units.shape) * step * spacing / np.sqrt(2)
        move -= (move * units).sum(axis=1)[:, None] * units
        units = _unit(units + move)
    return frames


def torus_tissue(n_cells=200, major=100.0, minor=40.0, seed=0, resolution=160, jitter=0.3) -> MeshTissue:
    """A tissue on a torus (Euler characteristic 0): faces labelled by the nearest seed (3-D distance).

    The torus ``((R + r cos v) cos u, (R + r cos v) sin u, r sin v)`` is a
    ``resolution x (resolution r / R)`` grid of (u, v) cut into triangles,
    counter-clockwise seen from outside; the seeds are a jittered (u, v)
    lattice of about ``n_cells`` points, spaced for equal lengths along u
    (at the tube's centre line) and v.  No truth (``truth`` None).
    """
    R, r = check_positive(major, "major"), check_positive(minor, "minor")
    if r >= R:
        raise InputError(f"minor radius must be below the major radius; got {r} >= {R}")
    nu = check_positive(resolution, "resolution", integer=True)
    nv = max(8, int(round(nu * r / R)))
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv

    def point(uu, vv):
        rho = R + r * np.cos(vv)
        return np.stack([rho * np.cos(uu), rho * np.sin(uu), r * np.sin(vv)], axis=-1)

    uu, vv = np.meshgrid(u, v, indexing="ij")
    verts = point(uu.ravel(), vv.ravel())
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = (i * nv + j).ravel()
    b = (((i + 1) % nu) * nv + j).ravel()
    c = (((i + 1) % nu) * nv + (j + 1) % nv).ravel()
    d = (i * nv + (j + 1) % nv).ravel()
    faces = np.concatenate([np.c_[a, b, c], np.c_[a, c, d]]).astype(np.int64)
    rng = np.random.default_rng(seed)
    ratio = R / r
    n_v_seeds = max(3, int(round(np.sqrt(n_cells / ratio))))
    n_u_seeds = max(3, int(round(n_cells / n_v_seeds)))
    su, sv = np.meshgrid((np.arange(n_u_seeds) + 0.5) / n_u_seeds, (np.arange(n_v_seeds) + 0.5) / n_v_seeds,
                         indexing="ij")
    su = su.ravel() + rng.uniform(-jitter, jitter, su.size) / n_u_seeds
    sv = sv.ravel() + rng.uniform(-jitter, jitter, sv.size) / n_v_seeds
    seeds = point(2 * np.pi * su, 2 * np.pi * sv)
    centroid = verts[faces].mean(axis=1)
    lab = cKDTree(seeds).query(centroid, workers=-1)[1].astype(np.int64) + 1
    lab = _connected_labels(faces, lab)
    return MeshTissue(vertices=verts, faces=faces, labels=lab, seeds=seeds, truth=None, euler=0)


def polygon_mesh(polygons):
    """Polygons (a tissue) as a triangle mesh: each polygon fanned from its vertex mean.

    Parameters
    ----------
    polygons : sequence of (k, 2) or (k, 3) arrays
        Each cell's vertices in order (2-D ones are put at z = 0 and turned
        counter-clockwise); vertices with equal coordinates are merged, so
        neighbouring cells must share their vertices exactly.

    Returns
    -------
    (vertices, faces, labels)
        Cell ``k`` (1-based) is ``polygons[k - 1]``.
    """
    rings = []
    for xy in polygons:
        xy = np.asarray(xy, dtype=float)
        if xy.shape[1] == 2:
            x, y = xy[:, 0], xy[:, 1]
            if np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) < 0:
                xy = xy[::-1]
            xy = np.c_[xy, np.zeros(len(xy))]
        rings.append(xy)
    points = np.concatenate(rings)
    unique, inverse = np.unique(points, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    centres = np.array([ring.mean(axis=0) for ring in rings])
    faces, labels, at = [], [], 0
    for k, ring in enumerate(rings):
        ids = inverse[at:at + len(ring)]
        at += len(ring)
        faces.append(np.c_[np.full(len(ids), len(unique) + k), ids, np.roll(ids, -1)])
        labels.append(np.full(len(ids), k + 1))
    return np.concatenate([unique, centres]), np.concatenate(faces).astype(np.int64), np.concatenate(labels)


@dataclass
class SurfaceNetwork:
    """A junction network at force balance on a surface, as a height map's analysis sees it, with its exact forces.

    Attributes
    ----------
    tables : dict of pandas.DataFrame
        ``cells``, ``vertices``, ``edges``, ``cell_vertices`` of the
        projected network (x = column, y = row, px; polygons counter-clockwise
        in x, y); ``vertices`` has ``z`` (px), the surface's height there.
    tension : ndarray
        Per row of ``edges``: the junction's tension (tension units).
    pressure : ndarray
        Per row of ``cells``: the cell's pressure (tension/px, on the surface).
    normals : (n_vertices, 3) ndarray
        Per row of ``vertices``: the surface's exact unit normal (facing +z).
    box : Box or None
        The periodic box (of the network and of the image); None for an
        open image.
    labels : (rows, cols) int32 ndarray
        The projected network drawn at 1 px per px (pixel centres inside each
        projected polygon; 0 outside the tissue).
    height : (rows, cols) ndarray
        z of the surface at every pixel centre, px.
    """

    tables: dict
    tension: np.ndarray
    pressure: np.ndarray
    normals: np.ndarray
    box: object
    labels: np.ndarray
    height: np.ndarray


def _draw_polygons(tables, shape):
    """Label image of ``shape`` (an open image): each pixel centre inside a cell's polygon gets the cell's id."""
    from skimage.draw import polygon as draw_polygon

    xy = tables["vertices"][["x", "y"]].to_numpy(float)
    vpos = pd.Index(tables["vertices"]["vertex"].to_numpy()).get_indexer
    labels = np.zeros(shape, np.int32)
    for cell, group in tables["cell_vertices"].sort_values(["cell", "rank"]).groupby("cell", sort=True):
        poly = xy[vpos(group["vertex"].to_numpy())]
        rr, cc = draw_polygon(poly[:, 1], poly[:, 0], shape)
        labels[rr, cc] = cell
    return labels


def tilted_network(tables, tension, pressure, box, tilt, azimuth=0.0, margin=3.0) -> SurfaceNetwork:
    """A flat periodic network at force balance, cut open and laid on a plane tilted by ``tilt`` degrees, projected.

    The cells whose polygon does not cross the box's edge are kept (the
    others become the outside, cell 0); their point ``(u, v)`` goes to ``R
    (u, v, 0)``, ``R`` the rotation by ``tilt`` about the axis at ``azimuth``
    degrees from x in the image plane, and is seen at ``(x, y)`` with height
    ``z``, shifted to ``margin`` px from the image's top-left corner.  The
    height map is the plane ``z = a x + b y + c`` at every pixel centre.
    Tensions and pressures are the flat network's: a rigid motion keeps the
    force balance on the plane.

    Parameters
    ----------
    tables, tension, pressure, box
        A periodic network at force balance and its forces
        (:func:`hexatissue.synthetic.vertex_model_tissue`).
    tilt : float
        Degrees, in [0, 80).
    azimuth : float
        Direction of the tilt axis, degrees from the image x axis.
    margin : float
        Px between the tissue's extent and the image's top and left edges (and
        at least its bottom and right edges).

    Returns
    -------
    SurfaceNetwork
        An open image; ``tension`` and ``pressure`` per row of the kept
        edges and cells; edges with one kept cell border the outside.
    """
    tilt = float(tilt)
    if not 0.0 <= tilt < 80.0:
        raise InputError(f"tilt must be an angle in degrees in [0, 80); got {tilt!r}")
    vertices, edges, cv = tables["vertices"], tables["edges"], tables["cell_vertices"]
    xy = vertices[["x", "y"]].to_numpy(float)
    vpos = pd.Index(vertices["vertex"].to_numpy())
    # a cell is kept when its polygon, as stored, needs no unwrapping
    order = cv.sort_values(["cell", "rank"])
    poly_v = vpos.get_indexer(order["vertex"].to_numpy())
    nxt = order.groupby("cell")["vertex"].transform(lambda v: np.roll(v.to_numpy(), -1)).to_numpy()
    step = xy[vpos.get_indexer(nxt)] - xy[poly_v]
    whole = np.all(np.isclose(step, box.min_image(step), rtol=0.0, atol=1e-9), axis=1)
    cut = set(order["cell"].to_numpy()[~whole])
    cells = tables["cells"]
    keep_cell = ~cells["cell"].isin(cut).to_numpy()
    kept = set(cells["cell"].to_numpy()[keep_cell])
    ca = edges["cell_a"].where(edges["cell_a"].isin(kept), 0).to_numpy()
    cb = edges["cell_b"].where(edges["cell_b"].isin(kept), 0).to_numpy()
    keep_edge = (ca != 0) | (cb != 0)
    out_edges = edges[keep_edge].assign(cell_a=ca[keep_edge], cell_b=cb[keep_edge]).reset_index(drop=True)
    used = np.unique(np.r_[out_edges["vertex_a"].to_numpy(), out_edges["vertex_b"].to_numpy()])
    on_outside = np.unique(out_edges.loc[(out_edges["cell_a"] == 0) | (out_edges["cell_b"] == 0),
                                         ["vertex_a", "vertex_b"]].to_numpy())
    t, a = np.radians(tilt), np.radians(float(azimuth))
    axis = np.array([np.cos(a), np.sin(a), 0.0])
    skew = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(t) * skew + (1 - np.cos(t)) * skew @ skew  # Rodrigues
    vrows = vpos.get_indexer(used)
    lifted = np.column_stack([xy[vrows], np.zeros(len(vrows))]) @ rotation.T
    shift = margin - lifted[:, :2].min(axis=0)
    lifted[:, :2] += shift
    normal = rotation[:, 2]
    out_vertices = vertices.iloc[vrows].reset_index(drop=True).assign(
        x=lifted[:, 0], y=lifted[:, 1], z=lifted[:, 2], is_border=np.isin(used, on_outside))
    out_cv = cv[cv["cell"].isin(kept)].reset_index(drop=True)
    out_cells = cells[keep_cell].reset_index(drop=True).copy()
    open_tables = {"cells": out_cells, "vertices": out_vertices, "edges": out_edges, "cell_vertices": out_cv}
    _projected_geometry(open_tables)
    out_cells["is_border"] = out_cells["cell"].isin(np.r_[out_edges.loc[out_edges["cell_b"] == 0, "cell_a"],
                                                          out_edges.loc[out_edges["cell_a"] == 0, "cell_b"]])
    shape = tuple(int(np.ceil(v + margin)) + 1 for v in lifted[:, 1::-1].max(axis=0))
    gy, gx = np.mgrid[0:shape[0], 0:shape[1]].astype(float)
    # the plane through the lifted points: n . (X - X_0) = 0
    height = lifted[0, 2] - (normal[0] * (gx - lifted[0, 0]) + normal[1] * (gy - lifted[0, 1])) / normal[2]
    return SurfaceNetwork(tables=open_tables, tension=np.asarray(tension, float)[keep_edge],
                          pressure=np.asarray(pressure, float)[keep_cell], normals=np.tile(normal, (len(used), 1)),
                          box=None, labels=_draw_polygons(open_tables, shape), height=height)


def _projected_geometry(tables):
    """The open tables' 2-D geometry columns recomputed from the vertices (edges' length; cells' x, y, areas,
    perimeter)."""
    xy = tables["vertices"][["x", "y"]].to_numpy(float)
    vpos = pd.Index(tables["vertices"]["vertex"].to_numpy()).get_indexer
    edges, cells = tables["edges"], tables["cells"]
    d = xy[vpos(edges["vertex_b"].to_numpy())] - xy[vpos(edges["vertex_a"].to_numpy())]
    edges["length"] = np.hypot(d[:, 0], d[:, 1])
    polygons = {cell: xy[vpos(group["vertex"].to_numpy())]
                for cell, group in tables["cell_vertices"].sort_values(["cell", "rank"]).groupby("cell", sort=True)}
    packed, starts = pack_polygons([polygons[c] for c in cells["cell"].to_numpy()])
    area, centroid = polygon_area_centroid(packed, starts)
    cells["x"], cells["y"] = centroid.T
    cells["area"] = cells["polygon_area"] = area
    cells["perimeter"] = polygon_perimeter(packed, starts)


#: bump_vertex_model_tissue: the bump is raised in this many equal steps, each relaxed by Newton steps (4 diverged
#: at h = 20 px, s = 35 px on 6 x 6 cells).
_BUMP_STEPS = 8


class _SurfaceVertexModel:
    """``E = sum_j Lambda_j l_j + sum_c K / 2 (A_c - A0_c)^2`` of a periodic network whose vertices ``(x, y)`` lie on
    ``z = height(x, y)``, lengths and areas in 3-D, and its gradient in ``(x, y)``."""

    def __init__(self, tables, box, line_tension, K, A0, height, gradient):
        from .synthetic import _polygon_rows

        self.box, self.lam, self.K, self.A0, self.height, self.gradient = box, line_tension, K, A0, height, gradient
        vpos = pd.Index(tables["vertices"]["vertex"].to_numpy()).get_indexer
        edges, cv = tables["edges"], tables["cell_vertices"]
        self.va, self.vb = vpos(edges["vertex_a"].to_numpy()), vpos(edges["vertex_b"].to_numpy())
        order, self.nxt, self.first = _polygon_rows(cv)
        self.v = vpos(cv["vertex"].to_numpy()[order])
        self.prev = np.empty_like(self.nxt)
        self.prev[self.nxt] = np.arange(len(self.nxt))
        self.cell = pd.Index(tables["cells"]["cell"].to_numpy()).get_indexer(cv["cell"].to_numpy()[order])
        self.n_cells = len(tables["cells"])

    def lift(self, xy):
        return np.column_stack([xy, self.height(xy[:, 0], xy[:, 1])])

    def vector_areas(self, xyz):
        """Each cell's vector area ``sum_i r_i x r_(i+1) / 2`` (``r`` about its first vertex; z read as is: the height
        is periodic)."""
        r = xyz[self.v] - xyz[self.v[self.first]]
        r[:, :2] = self.box.min_image(r[:, :2])
        cross = np.cross(r, r[self.nxt])
        return 0.5 * np.column_stack([np.bincount(self.cell, weights=cross[:, a], minlength=self.n_cells)
                                      for a in range(3)])

    def energy(self, flat):
        xy = flat.reshape(-1, 2)
        xyz = self.lift(xy)
        d = xyz[self.vb] - xyz[self.va]
        d[:, :2] = self.box.min_image(d[:, :2])
        length = np.linalg.norm(d, axis=1)
        vector = self.vector_areas(xyz)
        area = np.linalg.norm(vector, axis=1)
        energy = np.sum(self.lam * length) + 0.5 * self.K * np.sum((area - self.A0) ** 2)
        grad = np.zeros_like(xyz)
        f = self.lam[:, None] * d / length[:, None]
        np.add.at(grad, self.vb, f)
        np.add.at(grad, self.va, -f)
        chord = xyz[self.v[self.nxt]] - xyz[self.v[self.prev]]
        chord[:, :2] = self.box.min_image(chord[:, :2])
        normal = (vector / area[:, None])[self.cell]
        np.add.at(grad, self.v, (self.K * (area - self.A0))[self.cell, None] * 0.5 * np.cross(chord, normal))
        gx, gy = self.gradient(xy[:, 0], xy[:, 1])
        return energy, np.column_stack([grad[:, 0] + grad[:, 2] * gx, grad[:, 1] + grad[:, 2] * gy]).ravel()


def bump_vertex_model_tissue(nx=6, ny=6, spacing=24.0, amplitude=20.0, width=35.0, tension_spread=0.15,
                             area_spread=0.1, K=0.01, seed=0) -> SurfaceNetwork:
    """A periodic vertex-model tissue at force balance on a bump, with its exact tensions and pressures.

    The flat vertex model (:func:`hexatissue.synthetic.vertex_model_tissue`,
    its tensions ``Lambda_j`` and target areas) relaxed with its vertices on
    the periodic bump ``z = h exp(k (cos(2 pi x' / L_x) + cos(2 pi y' /
    L_y) - 2))``, ``x', y'`` from the box's centre and ``k = (L / 2 pi s)^2``
    for ``L`` the mean box side (near the top, the Gaussian of height ``h``
    and width ``s``; periodic, so every vertex is inside the tissue): the
    minimum of ``E = sum_j Lambda_j l_j + sum_c K / 2 (A_c - A0_c)^2`` with
    3-D junction lengths (straight, vertex to vertex) and the areas of the
    lifted polygons (``|sum_i X_i x X_(i+1)| / 2``), taken over the vertices'
    ``(x, y)``: the bump raised in 8 steps from the flat minimum, each
    relaxed by Newton steps on the dense finite-difference Hessian with a
    backtracking line search (L-BFGS needs thousands of iterations on the
    soft long-wavelength modes; the dense Hessian keeps this to small
    tissues: 6 x 6 cells in about 10 s).  At the minimum the force on each vertex has no component in
    the surface's tangent plane: tension ``Lambda_j``, pressure ``-K (A_c -
    A0_c)``.

    Parameters
    ----------
    nx, ny, spacing
        The flat lattice (``ny`` even), px.
    amplitude, width : float
        ``h`` and ``s``, px.
    tension_spread, area_spread, K, seed
        As :func:`hexatissue.synthetic.vertex_model_tissue`.

    Returns
    -------
    SurfaceNetwork
        Periodic (``box``, whole pixels: the rows are ``spacing sqrt(3) /
        2`` rounded down to half pixels, ``ny`` even); ``labels`` the
        projected network drawn by
        :func:`hexatissue.synthetic.network_labels`, ``height`` the bump.
    """
    from .synthetic import _with_positions, network_labels, vertex_model_tissue

    h, s = float(amplitude), check_positive(width, "width")
    row = np.floor(2 * spacing * np.sqrt(3) / 2) / 2  # whole pixels for ny even
    tables, lam, pressure, box = vertex_model_tissue(nx, ny, spacing, tension_spread=tension_spread,
                                                     area_spread=area_spread, K=K, seed=seed, row_spacing=row)
    A0 = tables["cells"]["polygon_area"].to_numpy(float) + pressure / K
    lengths = np.array([box.Lx, box.Ly])
    centre = lengths / 2
    k = (lengths.mean() / (2 * np.pi * s)) ** 2
    w = 2 * np.pi / lengths

    def height(x, y):
        return h * np.exp(k * (np.cos(w[0] * (x - centre[0])) + np.cos(w[1] * (y - centre[1])) - 2))

    def gradient(x, y):
        z = height(x, y)
        return -z * k * w[0] * np.sin(w[0] * (x - centre[0])), -z * k * w[1] * np.sin(w[1] * (y - centre[1]))

    x = tables["vertices"][["x", "y"]].to_numpy(float).ravel()
    for fraction in np.linspace(0.0, 1.0, _BUMP_STEPS + 1)[1:]:
        model = _SurfaceVertexModel(tables, box, lam, K, A0, lambda x_, y_, f=fraction: f * height(x_, y_),
                                    lambda x_, y_, f=fraction: tuple(f * g for g in gradient(x_, y_)))
        for _ in range(12):
            grad = model.energy(x)[1]
            if np.abs(grad).max() < 1e-11:
                break
            step = 1e-5
            hess = np.column_stack([(model.energy(x + step * e)[1] - model.energy(x - step * e)[1]) / (2 * step)
                                    for e in np.eye(len(x))])
            hess = 0.5 * (hess + hess.T)
            dx = -np.linalg.lstsq(hess, grad, rcond=1e-12)[0]
            # a full step can overshoot while the bump rises: halved until the energy or the largest force drops
            e0 = model.energy(x)[0]
            t = 1.0
            while t > 1e-4:
                e1, g1 = model.energy(x + t * dx)
                if e1 <= e0 + 1e-12 * abs(e0) or np.abs(g1).max() < np.abs(grad).max():
                    break
                t *= 0.5
            x = x + t * dx
    xy = box.wrap(x.reshape(-1, 2))
    force = np.abs(model.energy(xy.ravel())[1]).max()
    if force > 1e-9:
        raise InputError(f"the vertex model on the bump did not reach a force balance (largest force {force:.1e}): "
                         f"lower amplitude or tension_spread")
    tables = _with_positions(tables, xy, box)
    xyz = model.lift(xy)
    tables["vertices"]["z"] = xyz[:, 2]
    area = np.linalg.norm(model.vector_areas(xyz), axis=1)
    gx, gy = gradient(xy[:, 0], xy[:, 1])
    normals = np.column_stack([-gx, -gy, np.ones(len(xy))])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    labels, image_box = network_labels(tables, box, 1.0)
    rows, cols = np.mgrid[0:labels.shape[0], 0:labels.shape[1]].astype(float)
    return SurfaceNetwork(tables=tables, tension=lam, pressure=-K * (area - A0), normals=normals, box=image_box,
                          labels=labels, height=height(cols, rows))
