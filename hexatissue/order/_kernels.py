"""Numba kernels of the order stage: coarse-graining (:func:`hexatissue.coarse_grain`) and shape functions.

Each coarse-graining kernel has a plain-numpy twin of the same name and
signature in :mod:`hexatissue.order._reference`; the tests compare the two.
Positions are (x, y) = (column, row) in px.  The kernels of the defects
found on the coarse-grained field are in :mod:`hexatissue.defects._kernels`.

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

The shape functions gamma_p (:func:`shape_sums`, for
:func:`hexatissue.order.shape_functions_flat`) are
gamma_p = sum_v z_v^p / sum_v |z_v|^p with ``z_v = x_v + i y_v`` the vertex
relative to the cell centre: the same number as the textbook form
``sum |r|^p exp(i p phi) / sum |r|^p``, computed without transcendental
functions (complex powers by repeated squaring, ``|z|^p = (x^2 + y^2)^(p/2)``,
a square root only for odd p).  It agrees with the transcendental form to
~1e-15; its plain-numpy reference (the transcendental form) is
:func:`hexatissue.order._reference.reference_shape_functions`.
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


# ---------------------------------------------------------------------------- shape functions gamma_p


@njit(cache=True)
def _power(base, p):
    """``base ** p`` for an integer p >= 0 by repeated squaring (real or complex ``base``)."""
    result = base * 0 + 1
    while p:
        if p & 1:
            result *= base
        base *= base
        p >>= 1
    return result


@njit(cache=True)
def shape_sums(xy, starts, centre, own_centre, orders, degenerate_area):
    """gamma_p of polygons stored back to back, for each p of ``orders``.

    Parameters
    ----------
    xy : (M, 2) float array
        Vertices (x, y), polygon after polygon; polygon k starts at row ``starts[k]``.
    starts : (N,) int64 array
    centre : (N, 2) float array
        Cell centres; ignored with ``own_centre``, which uses the mean of each polygon's vertices.
    own_centre : bool
    orders : (P,) int64 array
        Symmetry orders (>= 1).
    degenerate_area : float
        A polygon whose area is not above ``degenerate_area`` times its mean
        squared vertex radius (collinear or collapsed vertices), or with fewer
        than 3 vertices, gets NaN; so does one whose denominator is not positive.

    Returns
    -------
    (P, N) complex array
    """
    n = len(starts)
    out = np.full((len(orders), n), np.nan + 0j)
    for k in range(n):
        s = starts[k]
        e = starts[k + 1] if k + 1 < n else len(xy)
        nv = e - s
        if nv < 3:
            continue
        if own_centre:
            cx = 0.0
            cy = 0.0
            for v in range(s, e):
                cx += xy[v, 0]
                cy += xy[v, 1]
            cx /= nv
            cy /= nv
        else:
            cx = centre[k, 0]
            cy = centre[k, 1]
        cross = 0.0  # twice the signed area, of the centred polygon
        size2 = 0.0
        for v in range(s, e):
            w = v + 1 if v + 1 < e else s
            x0 = xy[v, 0] - cx
            y0 = xy[v, 1] - cy
            cross += x0 * (xy[w, 1] - cy) - (xy[w, 0] - cx) * y0
            size2 += x0 * x0 + y0 * y0
        if not (0.5 * abs(cross) > degenerate_area * size2 / nv):
            continue
        for q in range(len(orders)):
            p = orders[q]
            num = 0j
            den = 0.0
            for v in range(s, e):
                x = xy[v, 0] - cx
                y = xy[v, 1] - cy
                r2 = x * x + y * y
                weight = _power(r2, p // 2)
                if p & 1:
                    weight *= np.sqrt(r2)
                num += _power(complex(x, y), p)
                den += weight
            if den > 0:
                out[q, k] = num / den
    return out
