"""Numba kernels of the tracking stage (:mod:`hexatissue.track`): label compaction, overlap counts, divisions.

Their plain-numpy references are in :mod:`hexatissue.track._reference` (and
:func:`hexatissue.track._compact_reference`, which the tracker also uses for
sparse ids); the tests compare the two.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _id_table(flat, top):
    """Compact id of each value 0..top of ``flat`` (-1 for 0 and for values absent) and the ids present (sorted)."""
    new = np.zeros(top + 1, np.int32)
    for v in flat:
        new[v] = 1
    n = 0
    for v in range(1, top + 1):
        if new[v]:
            new[v] = n
            n += 1
        else:
            new[v] = -1
    new[0] = -1
    ids = np.empty(n, np.int64)
    for v in range(1, top + 1):
        if new[v] >= 0:
            ids[new[v]] = v
    return new, ids


@njit(cache=True)
def _compact_index(flat, top):
    """Compact index of each pixel of ``flat`` (ids 0..top; -1 for 0), the ids present (sorted) and their areas.

    Two passes over the pixels and one over the ids, with no temporary image
    (the reference builds the compact image, shifts and casts it, then counts it).
    """
    new, ids = _id_table(flat, top)
    index = np.empty(flat.size, np.int32)
    area = np.zeros(len(ids), np.int64)
    for k in range(flat.size):
        c = new[flat[k]]
        index[k] = c
        if c >= 0:
            area[c] += 1
    return index, ids, area


@njit(cache=True)
def _compact_overlaps(flat, top, prev, n_prev):
    """:func:`_compact_index` of ``flat`` and its :func:`_dense_overlaps` with ``prev`` (``n_prev`` cells).

    One pass over the pixels for both (the two kernels apart read the new
    index again, and their count table is touched in a second pass).
    """
    new, ids = _id_table(flat, top)
    n = len(ids)
    index = np.empty(flat.size, np.int32)
    area = np.zeros(n, np.int64)
    width = n + 1  # background in the last row and column, as in _dense_overlaps
    counts = np.zeros((n_prev + 1) * width, np.int64)
    met = np.empty(min(flat.size, (n_prev + 1) * width), np.int64)
    m = 0
    for k in range(flat.size):
        c = new[flat[k]]
        index[k] = c
        if c >= 0:
            area[c] += 1
        # the count of _dense_overlaps, written out again: a shared per-pixel helper (even inline="always")
        # measured 8x slower for both kernels (reference counting of the arrays on every call)
        a = prev[k]
        key = (a if a >= 0 else n_prev) * width + (c if c >= 0 else n)
        if counts[key] == 0:
            met[m] = key
            m += 1
        counts[key] += 1
    i, j, count = _cell_pairs(counts, met[:m], width, n_prev, n)
    return index, ids, area, i, j, count


@njit(cache=True)
def _dense_overlaps(ia, ib, na, nb):
    """Overlap counts of the cell pairs (rows of ``ia`` x columns of ``ib``, -1 = background) that overlap.

    Returns ``i, j, n`` in row-major order of ``(i, j)``, as ``np.nonzero`` of the dense count table.
    The pairs met are listed as they first occur and sorted, so the (mostly
    empty) table is not scanned.
    """
    width = nb + 1  # background in the last row and column
    counts = np.zeros((na + 1) * width, np.int64)
    met = np.empty(min(len(ia), (na + 1) * width), np.int64)
    m = 0
    for k in range(len(ia)):
        a = ia[k]
        b = ib[k]
        key = (a if a >= 0 else na) * width + (b if b >= 0 else nb)
        if counts[key] == 0:
            met[m] = key
            m += 1
        counts[key] += 1
    return _cell_pairs(counts, met[:m], width, na, nb)


@njit(cache=True)
def _cell_pairs(counts, met, width, na, nb):
    """``i, j, n`` of the keys ``met`` of the count table that are pairs of cells (not background), sorted."""
    met = np.sort(met)
    m = len(met)
    cells = 0
    for q in range(m):
        cells += met[q] // width < na and met[q] % width < nb
    i = np.empty(cells, np.int64)
    j = np.empty(cells, np.int64)
    n = np.empty(cells, np.int64)
    cells = 0
    for q in range(m):
        a, b = met[q] // width, met[q] % width
        if a < na and b < nb:
            i[cells], j[cells], n[cells] = a, b, counts[met[q]]
            cells += 1
    return i, j, n


@njit(cache=True)
def _sparse_overlaps(ia, ib, na, nb):
    """:func:`_dense_overlaps` for frames with too many cells for a dense count table.

    The pixels of both frames' cells are bucketed by their cell of ``ia``
    (a counting sort into one int32 array), then each cell's pixels are
    counted in a scratch row of ``nb`` counts, cleared after the cell.  About
    4 bytes per pixel, against ~30 for the key sort of the reference
    (:func:`_sparse_overlaps_reference`).
    """
    start = np.zeros(na + 1, np.int64)
    for k in range(len(ia)):
        if ia[k] >= 0 and ib[k] >= 0:
            start[ia[k] + 1] += 1
    for a in range(na):
        start[a + 1] += start[a]
    fill = start[:na].copy()
    cols = np.empty(start[na], np.int32)  # the ib of each pixel in both, grouped by ia
    for k in range(len(ia)):
        a = ia[k]
        if a >= 0 and ib[k] >= 0:
            cols[fill[a]] = ib[k]
            fill[a] += 1
    counts = np.zeros(nb, np.int64)
    pairs = 0  # first pass: the number of pairs, so the output is allocated once
    for a in range(na):
        for q in range(start[a], start[a + 1]):
            pairs += counts[cols[q]] == 0
            counts[cols[q]] = 1
        for q in range(start[a], start[a + 1]):
            counts[cols[q]] = 0
    i = np.empty(pairs, np.int64)
    j = np.empty(pairs, np.int64)
    n = np.empty(pairs, np.int64)
    m = 0
    for a in range(na):
        first = m
        for q in range(start[a], start[a + 1]):
            b = cols[q]
            if counts[b] == 0:
                j[m] = b
                m += 1
            counts[b] += 1
        j[first:m] = np.sort(j[first:m])
        for r in range(first, m):
            i[r] = a
            n[r] = counts[j[r]]
            counts[j[r]] = 0
    return i, j, n


@njit(cache=True)
def _division_kernel(i, j, n, area_a, area_b, child_fraction, mother_fraction, min_iou):
    """:func:`_divisions` in three passes over the pairs (the reference sorts them twice): mothers and daughters."""
    na, nb = len(area_a), len(area_b)
    best = np.full(na, -1, np.int64)  # pair of the highest IoU of each cell of a (the first of ties)
    best_iou = np.full(na, -1.0)
    for k in range(len(i)):
        iou = n[k] / (area_a[i[k]] + area_b[j[k]] - n[k])
        if iou > best_iou[i[k]]:
            best_iou[i[k]], best[i[k]] = iou, k
    n_best = np.zeros(nb, np.int64)  # cells of a whose best successor (IoU >= min_iou / 2) is this cell of b
    for a in range(na):
        if best[a] >= 0 and best_iou[a] >= min_iou / 2:
            n_best[j[best[a]]] += 1
    top = np.full((na, 2), -1, np.int64)  # the two largest candidate overlaps of each mother (pairs)
    for k in range(len(i)):
        a, b = i[k], j[k]
        own = 1 if best[a] >= 0 and best_iou[a] >= min_iou / 2 and j[best[a]] == b else 0
        if n[k] < child_fraction * area_b[b] or n[k] < mother_fraction * area_a[a] or n_best[b] - own != 0:
            continue
        if top[a, 0] < 0 or n[k] > n[top[a, 0]]:
            top[a, 1], top[a, 0] = top[a, 0], k
        elif top[a, 1] < 0 or n[k] > n[top[a, 1]]:
            top[a, 1] = k
    m = 0
    for a in range(na):
        m += top[a, 1] >= 0
    mothers, first, second = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m, np.int64)
    m = 0
    for a in range(na):
        if top[a, 1] >= 0:
            mothers[m], first[m], second[m] = a, j[top[a, 0]], j[top[a, 1]]
            m += 1
    return mothers, first, second


@njit(cache=True)
def _cell_moments(index, cols, n):
    """Pixel count and summed x (column) and y (row) of each of the ``n`` cells of a compact index (-1 skipped).

    Summed along runs of one cell in a row (a run of length L from column
    c0 adds L, L (2 c0 + L - 1) / 2 and L r): one scattered write per run,
    not per pixel.
    """
    count = np.zeros(n, np.int64)
    sx = np.zeros(n)
    sy = np.zeros(n)
    rows = index.size // cols
    for r in range(rows):
        base = r * cols
        c0 = 0
        while c0 < cols:
            k = index[base + c0]
            c1 = c0 + 1
            while c1 < cols and index[base + c1] == k:
                c1 += 1
            if k >= 0:
                length = c1 - c0
                count[k] += length
                sx[k] += length * (c0 + c1 - 1) / 2.0
                sy[k] += length * r
            c0 = c1
    return count, sx, sy


@njit(cache=True)
def _warp_index(index, rows, cols, x0, y0, step, ux, uy, periodic):
    """``index`` (a frame's compact cells, flat) carried forward by a displacement field on a regular grid.

    Each output pixel ``(r, c)`` takes the cell of the input pixel at
    ``(r - u_y, c - u_x)`` (rounded), the displacement interpolated
    bilinearly from the grid nodes ``(x0 + j * step, y0 + i * step)``
    (clamped at the grid's edge).  Off the image: -1, or wrapped when
    ``periodic``.  The field is interpolated along y once per row, then
    along x per pixel from per-column weights.
    """
    ny, nx = ux.shape
    out = np.empty(rows * cols, np.int32)
    j0 = np.zeros(cols, np.int64)
    wx = np.zeros(cols)
    for c in range(cols):
        fx = min(max((c - x0) / step, 0.0), nx - 1.0)
        if nx > 1:
            j0[c] = min(int(fx), nx - 2)
            wx[c] = fx - j0[c]
    rx = np.empty(nx)
    ry = np.empty(nx)
    for r in range(rows):
        fy = min(max((r - y0) / step, 0.0), ny - 1.0)
        i0 = min(int(fy), ny - 2) if ny > 1 else 0
        wy = fy - i0 if ny > 1 else 0.0
        i1 = i0 + 1 if ny > 1 else 0
        for j in range(nx):
            rx[j] = (1 - wy) * ux[i0, j] + wy * ux[i1, j]
            ry[j] = (1 - wy) * uy[i0, j] + wy * uy[i1, j]
        for c in range(cols):
            a = j0[c]
            b = a + 1 if nx > 1 else a
            w = wx[c]
            sr = int(np.floor(r - ((1 - w) * ry[a] + w * ry[b]) + 0.5))
            sc = int(np.floor(c - ((1 - w) * rx[a] + w * rx[b]) + 0.5))
            if periodic:
                sr %= rows
                sc %= cols
            elif sr < 0 or sr >= rows or sc < 0 or sc >= cols:
                out[r * cols + c] = -1
                continue
            out[r * cols + c] = index[sr * cols + sc]
    return out
