"""Numba kernels of the coarse-graining stage (:func:`hexatissue.coarse_grain`).

Each kernel has a plain-numpy twin of the same name and signature in
:mod:`hexatissue._coarse_reference`; the tests compare the two.  Positions
are (x, y) = (column, row) in px.

The neighbour structure is a *cell list*: the centroids sorted by the bin of
a regular lattice of bins (:func:`cell_list`), so that every query scans only the
bins its search disk overlaps.  One cell list per frame serves every disk
radius, every symmetry order and the tissue raster.

Cell list arguments, shared by the kernels:

``order``
    (m,) int64: centroid indices sorted by bin.
``starts``
    (nbx * nby + 1,) int64: the centroids of bin ``b = by * nbx + bx`` are
    ``order[starts[b]:starts[b + 1]]``.
``origin``, ``size``
    (2,) float: lower corner and side lengths (x, y) of bin (0, 0), px.
``nbins``
    (2,) int64: bins along x and y.
``period``
    (2,) float: box lengths (Lx, Ly) of a periodic box (distances are then
    minimum-image and bins wrap around), or (0, 0) for an open image.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


def cell_list(xy, origin, size, nbins):
    """Sort points into bins: ``(order, starts)`` (see the module docstring); plain numpy, shared."""
    nbx, nby = int(nbins[0]), int(nbins[1])
    bx = np.clip(np.floor((xy[:, 0] - origin[0]) / size[0]), 0, nbx - 1).astype(np.int64)
    by = np.clip(np.floor((xy[:, 1] - origin[1]) / size[1]), 0, nby - 1).astype(np.int64)
    key = by * nbx + bx
    order = np.argsort(key, kind="stable").astype(np.int64)
    starts = np.searchsorted(key[order], np.arange(nbx * nby + 1)).astype(np.int64)
    return order, starts


@njit(cache=True)
def _bin_range(q, r, origin, size, nb, period):
    """First and last bin (inclusive, unwrapped) along one axis overlapping [q - r, q + r]; whole axis if it wraps."""
    lo = int(math.floor((q - r - origin) / size))
    hi = int(math.floor((q + r - origin) / size))
    if period > 0.0:
        if hi - lo + 1 >= nb:
            return 0, nb - 1
        return lo, hi
    return max(lo, 0), min(hi, nb - 1)


@njit(cache=True)
def _offset(d, period):
    """Minimum-image displacement along one axis (``d`` itself on an open image)."""
    if period > 0.0:
        return d - period * np.rint(d / period)
    return d


@njit(cache=True)
def _row_runs(x0, x1, nb):
    """The bins ``x0 .. x1`` (unwrapped) of one row as at most two runs of bin columns, in scan order.

    Returns ``(a0, a1, b0, b1)``: bins ``a0 .. a1`` then ``b0 .. b1`` (an empty run has its last bin
    before its first); the bins of one row are contiguous in the cell list, so each run is one
    slice of it.  ``x0 .. x1`` is empty (``x1 < x0``), or one run inside ``0 .. nb - 1`` on an open
    image, or wraps around a periodic axis (``_bin_range``).
    """
    if x1 < x0:
        return 0, -1, 0, -1
    a0, a1 = x0 % nb, x1 % nb
    if a0 + (x1 - x0) < nb:  # one run: no wrap, or the whole axis (which _bin_range gives as 0 .. nb - 1)
        return a0, a0 + (x1 - x0), 0, -1
    return a0, nb - 1, 0, a1


@njit(cache=True)
def _counted_runs(xy, values, counted, order, starts):
    """The counted centroids and their values in cell-list order, and the bin starts among them.

    Each bin is then a contiguous run of the returned ``xs``, ``ys``, ``vs`` (in the order of
    ``order``), so scanning a bin reads consecutive memory and skips nothing.
    """
    n_bins = starts.shape[0] - 1
    kept = np.zeros(n_bins + 1, np.int64)
    xs, ys = np.empty(order.shape[0]), np.empty(order.shape[0])
    vs = np.empty((order.shape[0], values.shape[1]))
    m = 0
    for b in range(n_bins):
        kept[b] = m
        for s in range(starts[b], starts[b + 1]):
            c = order[s]
            if counted[c]:
                xs[m], ys[m] = xy[c, 0], xy[c, 1]
                vs[m] = values[c]
                m += 1
    kept[n_bins] = m
    return xs, ys, vs, kept


@njit(cache=True)
def disk_means(nodes, xy, values, counted, radii, order, starts, origin, size, nbins, period, empty, means, counts):
    """Means of ``values`` and counts of the counted centroids within each radius of each node, written out.

    Parameters
    ----------
    nodes : (n, 2) float
        Node positions (x, y), px.
    xy : (m, 2) float
        Centroids (x, y), px (inside the box when periodic).
    values : (m, q) float
        Quantities to average (e.g. Re and Im of gamma_p for several p).
    counted : (m,) bool
        Centroids that enter the means (the others, e.g. border cells, only share the cell list).
    radii : (k,) float
        Disk radii, px, in any order.
    order, starts, origin, size, nbins, period
        Cell list of ``xy`` (module docstring).
    empty : float
        Mean written for a disk without centroids.
    means : (q, k, n) float, written
        ``means[t, j, i]`` = mean of ``values[:, t]`` over the counted centroids with
        ``dx^2 + dy^2 <= radii[j]^2`` from node ``i`` (minimum image when periodic).
    counts : (k, n) int64, written
        Number of those centroids.

    Notes
    -----
    Each node's centroids are binned into the bands between consecutive radii (ascending), and
    the disks' sums are cumulative sums over the bands; the means are those sums over the counts.
    The centroids are visited bin row by bin row, each row's bins as one contiguous run of the
    cell list (``_row_runs``), so no per-bin bookkeeping is needed.
    """
    n, k, q = nodes.shape[0], radii.shape[0], values.shape[1]
    if k == 0:
        return
    rank = np.argsort(radii, kind="mergesort")  # band j is radius rank[j] (ascending; ties stable)
    r2 = np.empty(k)
    for j in range(k):
        r2[j] = radii[rank[j]] * radii[rank[j]]
    rmax = radii[rank[k - 1]]
    nbx, nby = nbins[0], nbins[1]
    xs, ys, vs, starts = _counted_runs(xy, values, counted, order, starts)
    band = np.zeros((k, q))
    in_band = np.zeros(k, np.int64)
    total = np.zeros(q)
    for i in range(n):
        qx, qy = nodes[i, 0], nodes[i, 1]
        if period[0] > 0.0:
            qx -= period[0] * math.floor(qx / period[0])
            qy -= period[1] * math.floor(qy / period[1])
        x0, x1 = _bin_range(qx, rmax, origin[0], size[0], nbx, period[0])
        y0, y1 = _bin_range(qy, rmax, origin[1], size[1], nby, period[1])
        band[:] = 0.0
        in_band[:] = 0
        a0, a1, b0, b1 = _row_runs(x0, x1, nbx)
        for byu in range(y0, y1 + 1):
            row = (byu % nby) * nbx
            for run in range(2):
                lo, hi = (a0, a1) if run == 0 else (b0, b1)
                if hi < lo:
                    continue
                for s in range(starts[row + lo], starts[row + hi + 1]):
                    dx = _offset(xs[s] - qx, period[0])
                    dy = _offset(ys[s] - qy, period[1])
                    d2 = dx * dx + dy * dy
                    if d2 > r2[k - 1]:
                        continue
                    j = 0  # first disk holding the centroid (branch-free: the radii compare unpredictably)
                    for t in range(k - 1):
                        if d2 > r2[t]:
                            j += 1
                    in_band[j] += 1
                    for t in range(q):
                        band[j, t] += vs[s, t]
        count = 0
        for j in range(k):  # bands -> disks
            count += in_band[j]
            counts[rank[j], i] = count
            for t in range(q):
                total[t] = band[j, t] if j == 0 else total[t] + band[j, t]
                means[t, rank[j], i] = total[t] / count if count > 0 else empty


#: Side of the raster tiles of :func:`tissue_mask`, in raster points.
TILE = 4


@njit(cache=True)
def tissue_mask(rx, ry, xy, interior, reach, max_reach, order, starts, origin, size, nbins):
    """Raster of the tissue of an open image: point on an interior cell within that cell's reach.

    Parameters
    ----------
    rx, ry : (nx,), (ny,) float
        Raster coordinates along x and y, px, ascending.
    xy : (m, 2) float
        Every centroid (border cells included), px.
    interior : (m,) bool
        Interior (non-border) cells.
    reach : (m,) float
        Largest distance from each centroid still counted as inside the cell, px.
    max_reach : float
        ``reach.max()``: no nearest centroid beyond it can count.
    order, starts, origin, size, nbins
        Cell list of ``xy`` (open image).

    Returns
    -------
    (ny, nx) bool
        ``mask[i, j]``: the centroid nearest to ``(rx[j], ry[i])`` is an
        interior cell ``c`` at distance ``<= reach[c]`` (of equidistant
        nearest centroids, the one of smallest index).

    Notes
    -----
    The raster is cut into tiles of ``TILE x TILE`` points, and the centroids
    within ``max_reach`` of a tile are its candidates; ``D`` is a candidate's
    distance to the tile centre and ``h`` the largest distance of a tile
    point from the centre.  When every candidate is interior and reaches
    further than ``min(D) + h``, the whole tile is tissue (each point's
    nearest centroid is no farther than that).  Otherwise the candidates are
    sorted by ``D``; a point cannot be closer than ``D - h`` to a candidate,
    so its search stops once that bound exceeds the best distance found.
    """
    nx, ny = rx.shape[0], ry.shape[0]
    mask = np.zeros((ny, nx), np.bool_)
    nbx, nby = nbins[0], nbins[1]
    mr2 = max_reach * max_reach
    cand = np.empty(xy.shape[0], np.int64)
    cdist = np.empty(xy.shape[0])
    for ti in range(0, ny, TILE):
        i1 = min(ti + TILE, ny)
        ylo, yhi = ry[ti], ry[i1 - 1]
        by0, by1 = _bin_range(0.5 * (ylo + yhi), 0.5 * (yhi - ylo) + max_reach, origin[1], size[1], nby, 0.0)
        for tj in range(0, nx, TILE):
            j1 = min(tj + TILE, nx)
            xlo, xhi = rx[tj], rx[j1 - 1]
            cx, cy = 0.5 * (xlo + xhi), 0.5 * (ylo + yhi)
            h = math.sqrt((0.5 * (xhi - xlo)) ** 2 + (0.5 * (yhi - ylo)) ** 2)
            h = h * (1.0 + 1e-9) + 1e-9  # round-off margin: h bounds |point - centre| for sure
            bx0, bx1 = _bin_range(cx, 0.5 * (xhi - xlo) + max_reach, origin[0], size[0], nbx, 0.0)
            nc = 0
            dmin, rmin, all_interior = np.inf, np.inf, True
            for by in range(by0, by1 + 1):
                for bx in range(bx0, bx1 + 1):
                    b = by * nbx + bx
                    for s in range(starts[b], starts[b + 1]):
                        c = order[s]
                        ex = max(xlo - xy[c, 0], 0.0, xy[c, 0] - xhi)
                        ey = max(ylo - xy[c, 1], 0.0, xy[c, 1] - yhi)
                        if ex * ex + ey * ey <= mr2:  # within max_reach of the tile
                            cand[nc] = c
                            cdist[nc] = math.sqrt((xy[c, 0] - cx) ** 2 + (xy[c, 1] - cy) ** 2)
                            dmin = min(dmin, cdist[nc])
                            rmin = min(rmin, reach[c])
                            all_interior = all_interior and interior[c]
                            nc += 1
            if nc == 0:
                continue
            # Whole tile on the tissue when every candidate is interior and reaches further than
            # dmin + h: each point's nearest centroid is then a candidate no farther than that.
            if all_interior and rmin >= dmin + h:
                for i in range(ti, i1):
                    for j in range(tj, j1):
                        mask[i, j] = True
                continue
            for a in range(1, nc):  # insertion sort by distance to the tile centre
                c, d = cand[a], cdist[a]
                e = a
                while e > 0 and cdist[e - 1] > d:
                    cand[e], cdist[e] = cand[e - 1], cdist[e - 1]
                    e -= 1
                cand[e], cdist[e] = c, d
            for i in range(ti, i1):
                py = ry[i]
                for j in range(tj, j1):
                    px = rx[j]
                    best, best2 = -1, mr2
                    for a in range(nc):
                        bound = cdist[a] - h
                        if bound > 0.0 and bound * bound > best2:
                            break
                        c = cand[a]
                        dx = xy[c, 0] - px
                        dy = xy[c, 1] - py
                        d2 = dx * dx + dy * dy
                        if d2 < best2 or (d2 == best2 and (best < 0 or c < best)):
                            best, best2 = c, d2
                    if best >= 0 and interior[best] and math.sqrt(best2) <= reach[best]:
                        mask[i, j] = True
    return mask


@njit(cache=True)
def disk_coverage(mask, node_i, node_j, half_width):
    """Number of tissue raster points in the disk of every node, for several disks.

    Parameters
    ----------
    mask : (ny, nx) bool
        Tissue raster.
    node_i, node_j : (n,) int64
        Raster row and column of each node; the disks must lie inside the raster.
    half_width : (k, 2 * pad + 1) int64
        Disk ``j`` holds, in raster row ``node_i + dy - pad``, the columns
        ``node_j - w .. node_j + w`` with ``w = half_width[j, dy]`` (no column
        when ``w < 0``).

    Returns
    -------
    (n, k) int64
        Tissue raster points in each node's disks.
    """
    ny, nx = mask.shape
    prefix = np.zeros((ny, nx + 1), np.int32)  # prefix[i, j] = tissue points in row i before column j
    for i in range(ny):
        for j in range(nx):
            prefix[i, j + 1] = prefix[i, j] + (1 if mask[i, j] else 0)
    n, k = node_i.shape[0], half_width.shape[0]
    pad = (half_width.shape[1] - 1) // 2
    first = np.zeros(k, np.int64)  # the rows of disk j are first[j] .. 2 pad - first[j] (a disk is convex)
    for j in range(k):
        while first[j] < pad and half_width[j, first[j]] < 0:
            first[j] += 1
    out = np.zeros((n, k), np.int64)
    for a in range(n):
        ci, cj = node_i[a], node_j[a]
        for j in range(k):
            total = 0
            for dy in range(first[j], 2 * pad + 1 - first[j]):
                w = half_width[j, dy]
                if w >= 0:
                    row = ci + dy - pad
                    total += prefix[row, cj + w + 1] - prefix[row, cj - w]
            out[a, j] = total
    return out


@njit(cache=True)
def field_layouts(row, col, rows, cuts):
    """Shape of every field of a grid table, whether it holds each of its nodes once, and whether in place.

    Parameters
    ----------
    row, col : (N,) int64
        Node index along y and x of every row of the grid table.
    rows : (M,) int64
        The table rows of every field, field after field.
    cuts : (G + 1,) int64
        Field ``g`` is ``rows[cuts[g]:cuts[g + 1]]`` (never empty).

    Returns
    -------
    shapes : (G, 2) int64
        ``(ny, nx)`` of each field: its largest ``row`` and ``col`` plus one.
    once : (G,) bool
        The field holds every node of its ``ny x nx`` grid exactly once.
    block : (G,) bool
        Moreover its rows are consecutive table rows in row-major node order (so the field is a
        ``(ny, nx)`` reshape of a slice of the columns).
    """
    g_count = cuts.shape[0] - 1
    shapes = np.zeros((g_count, 2), np.int64)
    once, block = np.zeros(g_count, np.bool_), np.zeros(g_count, np.bool_)
    seen = np.zeros(0, np.bool_)
    for g in range(g_count):
        a, b = cuts[g], cuts[g + 1]
        low, ny, nx = 0, row[rows[a]] + 1, col[rows[a]] + 1
        for e in range(a, b):
            low = min(low, row[rows[e]], col[rows[e]])
            ny, nx = max(ny, row[rows[e]] + 1), max(nx, col[rows[e]] + 1)
        shapes[g, 0], shapes[g, 1] = ny, nx
        if low < 0 or b - a != ny * nx:
            continue
        if seen.shape[0] < b - a:
            seen = np.zeros(b - a, np.bool_)
        seen[:b - a] = False
        once[g], block[g] = True, True
        for e in range(a, b):
            node = row[rows[e]] * nx + col[rows[e]]
            if seen[node]:
                once[g], block[g] = False, False
                break
            seen[node] = True
            block[g] = block[g] and node == e - a and rows[e] == rows[a] + (e - a)
    return shapes, once, block


@njit(cache=True)
def _wrapped(d, period):
    """``d`` wrapped into (-period/2, period/2] (as ``hexatissue.defects._wrap_angle``)."""
    return d - period * np.ceil(d / period - 0.5)


@njit(cache=True)
def _plaquette_charge(here, right, down, diag, p, period):
    """Charge of a plaquette from its corners' orientations: the four steps counter-clockwise, each wrapped."""
    total = (_wrapped(right - here, period) + _wrapped(diag - right, period)
             + _wrapped(down - diag, period) + _wrapped(here - down, period))
    return np.round(total * p / (2.0 * np.pi)) / p


@njit(cache=True)
def plaquette_defects(theta, p, periodic):
    """The charged plaquettes of a stack of orientation grids (the kernel of :func:`hexatissue.defects.find_defects`).

    Parameters
    ----------
    theta : (g, ny, nx) float
        Orientations ``Arg(field) / p``, radians, indexed ``[grid, row, col]``; NaN nodes make
        the plaquettes around them NaN (never charged).
    p : int
        Symmetry order.
    periodic : bool
        The grids wrap around: ``ny x nx`` plaquettes, else ``(ny - 1) x (nx - 1)``.

    Returns
    -------
    flat : (d,) int64
        Flat index in the ``(g, ny', nx')`` array of plaquettes of every plaquette of nonzero
        charge, ascending (as ``np.flatnonzero`` of the charges).  Plaquette ``[i, j]`` has the
        corners ``[i, j]`` to ``[i+1, j+1]``.
    charge : (d,) float
        Their charges: the sum of the four steps counter-clockwise in x, y, each wrapped into
        ``(-pi/p, pi/p]``, over ``2 pi`` (a nonzero multiple of ``1/p``).

    The charges of every plaquette are :func:`hexatissue.defects.winding` (the plain-numpy path);
    this kernel keeps only the charged ones, without the array of every charge.
    """
    g, ny, nx = theta.shape
    my, mx = (ny, nx) if periodic else (ny - 1, nx - 1)
    period = 2.0 * np.pi / p
    # room for every plaquette: only the pages of the defects found are ever touched
    flat, charge = np.empty(g * my * mx, np.int64), np.empty(g * my * mx)
    row_charges = np.empty(mx)
    d = 0
    for a in range(g):
        for i in range(my):
            top, bottom = theta[a, i], theta[a, i + 1 if i + 1 < ny else 0]
            # a row's charges first, in a loop without branches (the compiler vectorises it), then the charged ones
            for j in range(nx - 1):
                row_charges[j] = _plaquette_charge(top[j], top[j + 1], bottom[j], bottom[j + 1], p, period)
            if periodic:
                row_charges[nx - 1] = _plaquette_charge(top[nx - 1], top[0], bottom[nx - 1], bottom[0], p, period)
            for j in range(mx):
                if row_charges[j] > 0.0 or row_charges[j] < 0.0:  # NaN compares False
                    flat[d], charge[d] = (a * my + i) * mx + j, row_charges[j]
                    d += 1
    return flat[:d].copy(), charge[:d].copy()
