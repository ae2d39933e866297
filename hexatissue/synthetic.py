"""Exact synthetic tissues for tests and benchmarks.

Label images are indexed ``[row, col]``; seeds and vertices are ``(x, y)``
with x = column and y = row, origin at the centre of pixel (0, 0).  Label
``k`` (1-based) is the Voronoi cell of ``seeds[k - 1]``.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import Voronoi, cKDTree

from .box import Box
from .errors import InputError

__all__ = [
    "jittered_seeds",
    "voronoi_labels",
    "voronoi_truth",
    "hexagonal_seeds",
    "square_labels",
    "draw_membranes",
]


def _rng(seed):
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def jittered_seeds(shape, spacing, jitter=0.35, seed=0):
    """Seeds on a square lattice of pitch ``spacing`` px, each moved by up to ``jitter * spacing``.

    Returns an ``(n, 2)`` array of (x, y) inside an image of ``shape = (rows, cols)``.
    Jittered lattices avoid the tiny cells of Poisson seeds.
    """
    rng = _rng(seed)
    ny, nx = int(shape[0] // spacing), int(shape[1] // spacing)
    if nx < 1 or ny < 1:
        raise InputError(f"spacing {spacing} is larger than the image shape {shape}")
    gx, gy = np.meshgrid((np.arange(nx) + 0.5) * shape[1] / nx, (np.arange(ny) + 0.5) * shape[0] / ny)
    xy = np.c_[gx.ravel(), gy.ravel()]
    xy += rng.uniform(-jitter, jitter, size=xy.shape) * spacing
    return xy


def hexagonal_seeds(nx, ny, spacing=15.0, row_spacing=13.0, offset=(0.25, 0.25)):
    """Seeds of a hexagonal tiling that is periodic in a box of ``(nx * spacing, ny * row_spacing)``.

    ``ny`` must be even.  ``row_spacing = 13`` with ``spacing = 15`` is within
    0.1 % of a regular hexagonal lattice.  Returns ``(seeds, box)``.
    """
    if ny % 2:
        raise InputError(f"ny must be even for a periodic hexagonal lattice; got {ny}")
    j, i = np.meshgrid(np.arange(nx), np.arange(ny))
    x = (j + 0.5 * (i % 2)) * spacing + offset[0]
    y = i * row_spacing + offset[1]
    return np.c_[x.ravel(), y.ravel()], Box(nx * spacing, ny * row_spacing)


def voronoi_labels(seeds, shape, periodic=False, membrane=0.0):
    """Rasterised Voronoi tessellation: each pixel gets the label of its nearest seed.

    Parameters
    ----------
    seeds : (n, 2) array
        Seed positions (x, y), px.
    shape : (rows, cols)
        Image shape.
    periodic : bool
        Nearest seed by minimum-image distance in the box ``(cols, rows)``.
    membrane : float
        When > 0, pixels whose centre lies within ``membrane / 2`` px of a
        Voronoi ridge are set to 0: junction lines of that width centred on
        the exact ridges (``membrane=1`` gives 1-px lines that still separate
        the cells in 4-connectivity).

    Returns
    -------
    (rows, cols) int32 array with labels 1..n (and 0 on membranes).
    """
    seeds = np.asarray(seeds, dtype=float)
    rows, cols = int(shape[0]), int(shape[1])
    if periodic:
        box = Box(cols, rows)
        tree = cKDTree(box.wrap(seeds), boxsize=[cols, rows])
    else:
        tree = cKDTree(seeds)
    out = np.empty((rows, cols), dtype=np.int32)
    x = np.arange(cols, dtype=float)
    chunk = max(1, 2**20 // max(cols, 1))
    for r0 in range(0, rows, chunk):
        r = np.arange(r0, min(rows, r0 + chunk), dtype=float)
        gx, gy = np.meshgrid(x, r)
        pix = np.c_[gx.ravel(), gy.ravel()]
        if membrane > 0:
            dist, idx = tree.query(pix, k=2, workers=-1)
            lab = idx[:, 0] + 1
            # distance to the bisector of the two nearest seeds (the images the tree used)
            u1, u2 = seeds[idx[:, 0]] - pix, seeds[idx[:, 1]] - pix
            if periodic:
                u1, u2 = box.min_image(u1), box.min_image(u2)
            gap = (dist[:, 1] ** 2 - dist[:, 0] ** 2) / (2 * np.hypot(*(u1 - u2).T))
            lab[gap < membrane / 2] = 0
        else:
            lab = tree.query(pix, workers=-1)[1] + 1
        out[r0 : r0 + len(r)] = lab.reshape(len(r), cols)
    return out


def voronoi_truth(seeds, shape, periodic=False):
    """Exact Voronoi neighbour pairs and vertices for :func:`voronoi_labels`.

    Returns
    -------
    pairs : dict
        ``{(a, b): ridge_length}`` with labels ``a < b`` (1-based), px.  For an
        open image, ridges are clipped to the image rectangle.
    vertices : (m, 2) array
        Voronoi vertices (x, y) inside the image (wrapped into the box when periodic).
    """
    seeds = np.asarray(seeds, dtype=float)
    rows, cols = int(shape[0]), int(shape[1])
    n = len(seeds)
    if periodic:
        box = Box(cols, rows)
        base = box.wrap(seeds)
        shifts = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]) * [cols, rows]
        pts = np.concatenate([base + s for s in shifts])
        owner = np.tile(np.arange(n), len(shifts))
    else:
        span = 4.0 * max(rows, cols)
        far = np.array([[-span, -span], [-span, span], [span, -span], [span, span]]) + [cols / 2, rows / 2]
        pts = np.concatenate([seeds, far])
        owner = np.r_[np.arange(n), -np.ones(4, int)]
    vor = Voronoi(pts)
    lo = np.array([-0.5, -0.5])
    hi = np.array([cols - 0.5, rows - 0.5])
    pairs = {}
    for (p, q), ridge in zip(vor.ridge_points, vor.ridge_vertices):
        a, b = owner[p], owner[q]
        if a < 0 or b < 0 or a == b or -1 in ridge:
            continue
        v0, v1 = vor.vertices[ridge[0]], vor.vertices[ridge[1]]
        if periodic:
            # keep each ridge once: the copy whose midpoint lies in the box
            mid = 0.5 * (v0 + v1)
            if not (np.all(mid >= lo) and np.all(mid < hi)):
                continue
            length = np.hypot(*(v1 - v0))
        else:
            length = _clipped_length(v0, v1, lo, hi)
            if length <= 0:
                continue
        key = (int(min(a, b)) + 1, int(max(a, b)) + 1)
        pairs[key] = pairs.get(key, 0.0) + length
    verts = vor.vertices
    if periodic:
        inside = np.all((verts >= 0) & (verts < [cols, rows]), axis=1)
    else:
        inside = np.all((verts >= lo) & (verts <= hi), axis=1)
    return pairs, verts[inside]


def _clipped_length(v0, v1, lo, hi):
    """Length of the segment v0-v1 inside the rectangle [lo, hi] (Liang-Barsky)."""
    d = v1 - v0
    t0, t1 = 0.0, 1.0
    for k in range(2):
        if d[k] == 0:
            if not lo[k] <= v0[k] <= hi[k]:
                return 0.0
            continue
        ta, tb = (lo[k] - v0[k]) / d[k], (hi[k] - v0[k]) / d[k]
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return max(0.0, t1 - t0) * float(np.hypot(*d))


def square_labels(nx, ny, side):
    """A square tiling: ``ny x nx`` squares of ``side`` px, labels 1..nx*ny row by row."""
    i, j = np.divmod(np.arange(ny * side * nx * side), nx * side)
    return ((i // side) * nx + (j // side) + 1).reshape(ny * side, nx * side).astype(np.int32)


def draw_membranes(labels, width=1, periodic=False):
    """Set junction pixels to 0, as in Tissue Analyzer / EpySeg images.

    ``width=1`` zeroes every pixel whose right or lower neighbour has another
    label (1-px lines that still separate the cells in 4-connectivity);
    ``width=2`` zeroes both sides of every junction.
    """
    if width not in (1, 2):
        raise InputError(f"width must be 1 or 2 px; got {width!r}")
    lab = np.asarray(labels)
    if periodic:
        right, down = np.roll(lab, -1, axis=1), np.roll(lab, -1, axis=0)
        left, up = np.roll(lab, 1, axis=1), np.roll(lab, 1, axis=0)
    else:
        right = np.c_[lab[:, 1:], lab[:, -1:]]
        down = np.r_[lab[1:], lab[-1:]]
        left = np.c_[lab[:, :1], lab[:, :-1]]
        up = np.r_[lab[:1], lab[:-1]]
    mask = (right != lab) | (down != lab)
    if width == 2:
        mask |= (left != lab) | (up != lab)
    out = lab.copy()
    out[mask] = 0
    return out
