"""numba kernels of the junction-network extraction.

The boundaries between labels run along pixel edges ("cracks").  They form a
graph on the lattice of pixel corners: corner ``(ci, cj)`` lies at
``x = cj - 0.5``, ``y = ci - 0.5`` and is surrounded, in the label array
padded by one pixel ``pad`` (wrapping on a torus, 0 around an open image),
by TL = ``pad[ci, cj]``, TR = ``pad[ci, cj + 1]``, BL = ``pad[ci + 1, cj]``
and BR = ``pad[ci + 1, cj + 1]``.  On a torus the lattice has one corner
per pixel, on an open image one more each way.  The kernels take the
labels unpadded and read the padding through :func:`_pad_at` and
:func:`_row_or_zeros` (no padded copy of the image).  From a corner a
crack "arm" leaves in direction 0 (+x), 1 (+y), 2 (-x) or 3 (-y) when the two
pixels it separates differ.

Corner types: 0 no arm; 2 a boundary passes; 3 three-fold vertex; 4 four-fold
vertex (four distinct labels); 5 and 6 two boundaries touching diagonally
(pairs of arms {3, 0}, {1, 2} for type 5, where TL == BR is the connected
label; {3, 2}, {0, 1} for type 6, where TR == BL is connected).  A corner is one byte, its
"code": arm bits | type << 4 (:func:`corner_types`), so that a walk reads one byte per step.

Each kernel has an independently written plain-Python reference of the same
name and outputs in :mod:`._reference` (tests only; ``tests/test_mesh_kernels.py``
compares them).  ``py_func`` runs the same code uncompiled and is no such check.
"""
import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

# direction -> (d row, d col) on the corner lattice
DI = np.array([0, 1, 0, -1], dtype=np.int64)
DJ = np.array([1, 0, -1, 0], dtype=np.int64)


@njit(cache=True)
def _pad_at(labels, periodic, i, j):
    """``pad[i, j]``: the label of pixel (i - 1, j - 1), wrapped on a torus, 0 outside an open image.

    ``i`` and ``j`` lie within the padded image (0..h + 1, 0..w + 1), so
    wrapping is one add or subtract, not a division.
    """
    h, w = labels.shape
    i -= 1
    j -= 1
    if periodic:
        return labels[_wrap(i, h), _wrap(j, w)]
    if i < 0 or i >= h or j < 0 or j >= w:
        return labels[0, 0] - labels[0, 0]  # 0 of the labels' dtype (a literal 0 would be int64)
    return labels[i, j]


@njit(cache=True)
def _wrap(i, n):
    """``i % n`` for ``-n <= i < 2 n`` (an index at most one period outside ``0..n-1``)."""
    if i < 0:
        return i + n
    if i >= n:
        return i - n
    return i


@njit(cache=True)
def _lattice_shape(labels, periodic):
    """(nci, ncj): one corner per pixel on a torus, one more each way on an open image."""
    h, w = labels.shape
    return (h, w) if periodic else (h + 1, w + 1)


@njit(cache=True)
def _row_or_zeros(labels, periodic, r, zeros):
    """Row r of the labels, wrapped on a torus; ``zeros`` (a row of 0) outside an open image."""
    h = labels.shape[0]
    if periodic:
        return labels[r % h]
    if r < 0 or r >= h:
        return zeros
    return labels[r]


@njit(cache=True)
def _corner_code(tl, tr, bl, br):
    """Code (arm bits | type << 4) of the corner between pixels TL, TR, BL, BR (selects only, no branch)."""
    a0 = np.uint8(tr != br)
    a1 = np.uint8(bl != br)
    a2 = np.uint8(tl != bl)
    a3 = np.uint8(tl != tr)
    n = a0 + a1 + a2 + a3
    # four arms: 5 when TL == BR connect, 6 when TR == BL do, the smaller id when both; else 4
    d5 = np.uint8(tl == br)
    d6 = np.uint8(tr == bl)
    four = 4 + d5 + 2 * d6 - d5 * d6 * (2 - np.uint8(tl >= tr))
    k = four if n == 4 or n == 1 else n  # (one arm cannot occur: around a corner arms pair up)
    return (a0 | (a1 << 1) | (a2 << 2) | (a3 << 3)) | (np.uint8(k) << 4)


@njit(cache=True)
def corner_types(labels, periodic):
    """The code of every corner: its arm bits (bit d = arm in direction d) | its type << 4 (uint8).

    Also returns the vertices (corners of type 3 and 4, and on an open
    image the four corners of the image where a boundary turns) as row and
    column arrays in raster order (vertex ids are their ranks: see
    :func:`_vertex_id`) and the total number of cracks.

    The first pass has no branch (selects only) and no running count in
    its inner loop over the corners between two rows of labels, so it runs
    on whole vectors of corners; the first and last corner of a row (where
    the padding is) are done apart.  The arms and forks are counted from
    the codes read 8 at a time (:func:`_arm_count`, :func:`_fork_bytes`).
    Vertices are few and are numbered in a last pass, which looks closer
    only at the words with a fork (or an image corner).
    """
    h, w = labels.shape
    nci, ncj = _lattice_shape(labels, periodic)
    zeros = np.zeros(w, labels.dtype)
    n_corners = nci * ncj
    words = np.empty((n_corners + 7) // 8, np.uint64)  # the codes, also as 8-byte words for the vertex scan
    words[-1] = 0
    corners = words.view(np.uint8)[:n_corners].reshape((nci, ncj))
    for ci in range(nci):
        top = _row_or_zeros(labels, periodic, ci - 1, zeros)
        bottom = _row_or_zeros(labels, periodic, ci, zeros)
        for cj in range(1, w):  # corner cj lies between columns cj - 1 and cj
            corners[ci, cj] = _corner_code(top[cj - 1], top[cj], bottom[cj - 1], bottom[cj])
        # corner 0 (left of column 0) and, on an open image, corner w (right of column w - 1)
        for cj in range(0, ncj, w):  # 0, and w when the lattice has it
            left = _pad_at(labels, periodic, ci, cj)
            right = _pad_at(labels, periodic, ci, cj + 1)
            below_left = _pad_at(labels, periodic, ci + 1, cj)
            below_right = _pad_at(labels, periodic, ci + 1, cj + 1)
            corners[ci, cj] = _corner_code(left, right, below_left, below_right)
    n_arms = np.uint64(0)
    n_forks = np.uint64(0)
    for wi in range(len(words)):  # the bytes past the last corner are 0: no arm, no fork
        n_arms += _arm_count(words[wi])
        n_forks += _byte_sum(_fork_bytes(words[wi]))
    image_corners = not periodic
    vi = np.empty(n_forks + 4, np.int64)  # + the corners of an open image
    vj = np.empty(n_forks + 4, np.int64)
    # the image corners of an open image (flat indices, ascending) are looked at whatever their type
    extra = np.array([0, ncj - 1, n_corners - ncj, n_corners - 1]) if image_corners else np.zeros(0, np.int64)
    x = 0
    n_vertices = 0
    for wi in range(len(words)):
        hit = _fork_bytes(words[wi])
        while x < len(extra) and extra[x] // 8 == wi:
            hit |= np.uint64(1) << np.uint64(8 * (extra[x] - 8 * wi))
            x += 1
        if hit == 0:  # most words: no vertex among their 8 corners
            continue
        for b in range(8):
            if (hit >> np.uint64(8 * b)) & np.uint64(1):
                ci, cj = divmod(8 * wi + b, ncj)
                if _is_vertex(corners, ci, cj, nci, ncj, image_corners):  # the walks' own rule of where they end
                    vi[n_vertices] = ci
                    vj[n_vertices] = cj
                    n_vertices += 1
    return corners, vi[:n_vertices].copy(), vj[:n_vertices].copy(), np.int64(n_arms) // 2


@njit(cache=True)
def _byte_sum(word):
    """Sum of the 8 bytes of a word (each byte at most 31, so that the sum fits in one byte)."""
    return (word * np.uint64(0x0101010101010101)) >> np.uint64(56)


@njit(cache=True)
def _arm_count(word):
    """Number of arm bits (the low 4 bits of each byte) in a word of 8 corner codes (a bit count per byte)."""
    x = word & np.uint64(0x0F0F0F0F0F0F0F0F)
    x = x - ((x >> np.uint64(1)) & np.uint64(0x0505050505050505))
    x = (x & np.uint64(0x0303030303030303)) + ((x >> np.uint64(2)) & np.uint64(0x0303030303030303))
    return _byte_sum(x)


@njit(cache=True)
def _fork_bytes(word):
    """Bit 0 of each byte of a word of 8 corner codes set where the corner's type is 3 or 4 (a fork).

    Per byte, type + 5 is 5..11 (no carry into the next byte) and has bit 3
    set and bit 1 clear exactly for types 3 and 4 (8 = 0b1000, 9 = 0b1001).
    """
    y = ((word >> np.uint64(4)) & np.uint64(0x0F0F0F0F0F0F0F0F)) + np.uint64(0x0505050505050505)
    return (y >> np.uint64(3)) & ~(y >> np.uint64(1)) & np.uint64(0x0101010101010101)


def _next_dir_table():
    """NEXT[code, d_in]: the direction leaving a pass-through corner of code ``arms | kind << 4`` entered
    moving in direction d_in.

    Kind 2 leaves by its other arm; kinds 5 and 6 by the arm paired with
    the one entered ({3, 0} and {1, 2} for 5, {3, 2} and {0, 1} for 6).
    -1 where no walk arrives.  A table, not branches: the walks are
    dominated by mispredicted branches on the direction otherwise.
    """
    table = np.full((256, 4), -1, np.int8)
    partner = {5: {3: 0, 0: 3, 1: 2, 2: 1}, 6: {3: 2, 2: 3, 0: 1, 1: 0}}
    for arms in range(16):
        for d_in in range(4):
            back = (d_in + 2) % 4
            if not (arms >> back) & 1:
                continue
            others = [d for d in range(4) if d != back and (arms >> d) & 1]
            if len(others) == 1:
                table[arms | 2 << 4, d_in] = others[0]
            if arms == 15:
                for kind in (5, 6):
                    table[arms | kind << 4, d_in] = partner[kind][back]
    return table


NEXT = _next_dir_table()


@njit(cache=True)
def _next_dir(code, d_in):
    """Direction leaving a pass-through corner of ``code`` entered moving in direction ``d_in`` (see :func:`_next_dir_table`)."""
    return np.int64(NEXT[code, d_in])


@njit(cache=True)
def _sides(labels, periodic, ci, cj, d):
    """Labels on the left and right of the crack leaving corner (ci, cj) in direction d (left in x-y axes)."""
    if d == 0:
        return _pad_at(labels, periodic, ci + 1, cj + 1), _pad_at(labels, periodic, ci, cj + 1)
    if d == 1:
        return _pad_at(labels, periodic, ci + 1, cj), _pad_at(labels, periodic, ci + 1, cj + 1)
    if d == 2:
        return _pad_at(labels, periodic, ci, cj), _pad_at(labels, periodic, ci + 1, cj)
    return _pad_at(labels, periodic, ci, cj + 1), _pad_at(labels, periodic, ci, cj)


@njit(cache=True)
def _step(ci, cj, d, nci, ncj):
    """The corner next to (ci, cj) in direction d, wrapping around the lattice."""
    ci += DI[d]
    cj += DJ[d]
    if ci < 0:
        ci += nci
    elif ci >= nci:
        ci -= nci
    if cj < 0:
        cj += ncj
    elif cj >= ncj:
        cj -= ncj
    return ci, cj


@njit(cache=True)
def _crack_index(ci, cj, d, nci, ncj):
    """(array 0 = horizontal / 1 = vertical, row, col) of the crack leaving (ci, cj) in direction d.

    Without a branch on d (selects only): it changes at every turn of a boundary.
    """
    r = ci - (d == 3)
    c = cj - (d == 2)
    if r < 0:
        r += nci
    if c < 0:
        c += ncj
    return d & 1, r, c


@njit(cache=True)
def _is_vertex(corners, ci, cj, nci, ncj, image_corners):
    """Whether corner (ci, cj) is a vertex: a fork (types 3, 4), or with ``image_corners`` a corner of the image
    where a boundary turns.

    The walks read 1 byte a corner to know where they end (a 4-byte map of
    vertex ids would be touched at every step and is not kept at all).
    """
    k = corners[ci, cj] >> 4
    if k == 3 or k == 4:
        return True
    return image_corners and (ci == 0 or ci == nci - 1) and (cj == 0 or cj == ncj - 1) and k != 0


@njit(cache=True)
def _lower_bound(values, lo, hi, key):
    """First index in ``lo..hi`` of the sorted ``values[lo:hi]`` whose value is not below ``key`` (binary search)."""
    while lo < hi:
        mid = (lo + hi) // 2
        if values[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def _row_starts(vi, nci):
    """Index of the first vertex of every corner row 0..nci (vertices in raster order; ``nci`` = their number)."""
    first = np.zeros(nci + 1, np.int64)
    for ci in vi:
        first[ci + 1] += 1
    for ci in range(nci):
        first[ci + 1] += first[ci]
    return first


@njit(cache=True)
def _vertex_id(row_first, vj, ci, cj):
    """Id of the vertex at corner (ci, cj): its rank in raster order, searched among the vertices of row ``ci``."""
    return _lower_bound(vj, row_first[ci], row_first[ci + 1], cj)


@njit(cache=True)
def _walk(corners, image_corners, ci, cj, d, nci, ncj):
    """Follow a boundary from corner (ci, cj) in direction d until it reaches a vertex.

    Returns (end corner row, end corner col, dx, dy, number of cracks, last
    direction, head, tail): ``head`` holds the directions of the first
    ``FIT_MAX_CRACKS`` cracks, ``tail`` those of the last 32, 2 bits each
    (the first, and the last, lowest), the keys of the arm fits at both ends
    (:func:`_arm_fit`).
    """
    dx = 0
    dy = 0
    n = 0
    head = np.uint64(0)
    tail = np.uint64(0)
    while True:
        if n < FIT_MAX_CRACKS:
            head |= np.uint64(d) << np.uint64(2 * n)
        tail = (tail << np.uint64(2)) | np.uint64(d)
        dx += DJ[d]
        dy += DI[d]
        n += 1
        ci, cj = _step(ci, cj, d, nci, ncj)
        if _is_vertex(corners, ci, cj, nci, ncj, image_corners):
            return ci, cj, dx, dy, n, d, head, tail
        d = _next_dir(corners[ci, cj], d)


@njit(cache=True)
def _arm_sums(corners, membrane, ci, cj, d, n, nci, ncj):
    """Sums x, y, xx, xy, yy of the fit points of the first n cracks of the boundary leaving corner (ci, cj) in
    direction d, relative to the corner.

    A crack's fit point is :func:`_crack_point` (``membrane`` of size 0: no
    membrane pixels, its midpoint).  The n cracks lie on one junction (n is
    at most its length), so the walk turns at pass-through corners only.
    The points are multiples of 0.25 px near the vertex, so their sums are
    exact in any order, and the same from either end of a crack.
    """
    sx = 0.0
    sy = 0.0
    sxx = 0.0
    sxy = 0.0
    syy = 0.0
    dx = 0
    dy = 0
    for i in range(n):
        if membrane.size:
            mx, my = _crack_point(membrane, ci, cj, d)
        else:
            mx, my = 0.5 * DJ[d], 0.5 * DI[d]
        mx += dx
        my += dy
        sx += mx
        sy += my
        sxx += mx * mx
        sxy += mx * my
        syy += my * my
        dx += DJ[d]
        dy += DI[d]
        ci, cj = _step(ci, cj, d, nci, ncj)
        if i + 1 < n:
            d = _next_dir(corners[ci, cj], d)
    return sx, sy, sxx, sxy, syy


@njit(cache=True)
def _line_fit(n, d0, sx, sy, sxx, sxy, syy):
    """Mean (x, y) of n points from their sums, and the unit principal axis of their covariance.

    The axis is arm direction ``d0`` when fewer than 2 points or no spread.
    """
    mx = sx / n
    my = sy / n
    cxx = sxx / n - mx * mx
    cxy = sxy / n - mx * my
    cyy = syy / n - my * my
    if n < 2 or cxx + cyy < 1e-12:
        return mx, my, float(DJ[d0]), float(DI[d0])
    theta = 0.5 * np.arctan2(2.0 * cxy, cxx - cyy)  # principal axis of the 2x2 covariance
    return mx, my, np.cos(theta), np.sin(theta)


#: Slots of the table of :func:`_arm_fit` (2 ** FIT_SLOT_BITS), and how many of them it fills at most.
FIT_SLOT_BITS = 12
FIT_SLOTS = 1 << FIT_SLOT_BITS
FIT_FILL = FIT_SLOTS // 2
#: The longest arm :func:`_arm_fit` keys by its path (2 bits a crack, and the length above them, in 64 bits).
FIT_MAX_CRACKS = 28
#: Every direction of a path turned round (d ^ 2): the path walked the other way.
TURN_ROUND = np.uint64(0xAAAAAAAAAAAAAAAA)


@njit(cache=True)
def _arm_fit(corners, membrane, ci, cj, d, n, nci, ncj, path, keys, fits):
    """:func:`_line_fit` of :func:`_arm_sums`, looked up by the arm's path when there are no membrane pixels.

    Without membrane pixels the fit points are the cracks' midpoints: the
    fit depends on the directions of the n cracks only (``path``, 2 bits
    each, the first lowest; for n up to ``FIT_MAX_CRACKS``), and a digital
    line's first cracks take few shapes (~800 among the 58,000 arms of a
    2048^2 Voronoi image).  So each is fitted once and then read back: the
    same numbers, without the libm calls.  ``keys`` (-1 = empty;
    ``FIT_SLOTS`` of them, then the number of paths stored) and ``fits``
    (``FIT_SLOTS`` x 4) are the table, open addressing on a multiplicative
    hash; once ``FIT_FILL`` are stored, new paths are fitted, not stored.
    """
    keyed = membrane.size == 0 and n <= FIT_MAX_CRACKS
    slot = 0
    key = -1
    if keyed:
        key = np.int64((path & ((np.uint64(1) << np.uint64(2 * n)) - np.uint64(1)))
                       | (np.uint64(n) << np.uint64(2 * FIT_MAX_CRACKS)))
        slot = np.int64((np.uint64(key) * np.uint64(0x9E3779B97F4A7C15)) >> np.uint64(64 - FIT_SLOT_BITS))
        while keys[slot] != -1:
            if keys[slot] == key:
                return fits[slot, 0], fits[slot, 1], fits[slot, 2], fits[slot, 3]
            slot = (slot + 1) & (FIT_SLOTS - 1)
    fit = _line_fit(n, d, *_arm_sums(corners, membrane, ci, cj, d, n, nci, ncj))
    if keyed and keys[FIT_SLOTS] < FIT_FILL:
        keys[FIT_SLOTS] += 1
        keys[slot] = key
        for a in range(4):
            fits[slot, a] = fit[a]
    return fit


@njit(cache=True)
def _store_fit(fit, n, d0, v, count, mean, direction):
    """Store a :func:`_line_fit` of n points as arm d0 of vertex v."""
    count[v, d0] = n
    mean[v, d0, 0] = fit[0]
    mean[v, d0, 1] = fit[1]
    direction[v, d0, 0] = fit[2]
    direction[v, d0, 1] = fit[3]


@njit(cache=True)
def trace_junctions(labels, periodic, corners, vi, vj, n_max, membrane, max_reach):
    """Trace every boundary between the vertices ``(vi, vj)`` of :func:`corner_types`, and fit its arms.

    Returns arrays over junctions: start vertex, end vertex, the arm
    directions by which the junction leaves its start and enters its end
    vertex, left label, right label, dx, dy (exact displacement start -> end,
    px), number of cracks; then the arm line fits of every (vertex, arm
    direction), for sub-pixel vertex positions: the number of cracks fitted
    (half the junction, 1 to ``max_reach``, so the far end does not bend
    the fit; 0 = no arm), the mean (dx, dy) of their points relative to the
    vertex corner and the unit direction of their principal axis.

    A junction is traced from its first end in (vertex, arm) order: the
    ends reached are marked per vertex, not crack by crack (see
    :func:`mark_junctions` for the cracks, when loops are to be found).

    A crack's point is the mean centre of the pixels beside it that were
    membrane (``membrane``, padded by one pixel on each side, True where the input had
    a 0-valued junction pixel), else the crack midpoint: the fit follows the
    membrane centreline where the image has membranes.  An arm's points are
    read walking its cracks again from its vertex; without membrane pixels
    the fit of an arm whose path was fitted before is read back
    (:func:`_arm_fit`).
    """
    nci, ncj = corners.shape
    nv = len(vi)
    done = np.zeros(nv, np.uint8)  # bit d: the junction on arm d has been traced (from its other end)
    row_first = _row_starts(vi, nci)
    start = np.empty(n_max, np.int64)
    end = np.empty(n_max, np.int64)
    left = np.empty(n_max, labels.dtype)
    right = np.empty(n_max, labels.dtype)
    ddx = np.empty(n_max, np.int64)
    ddy = np.empty(n_max, np.int64)
    start_arm = np.empty(n_max, np.int64)
    end_arm = np.empty(n_max, np.int64)
    ncrack = np.empty(n_max, np.int64)
    count = np.zeros((nv, 4), np.int64)
    mean = np.zeros((nv, 4, 2), np.float64)
    direction = np.zeros((nv, 4, 2), np.float64)
    fit_keys = np.full(FIT_SLOTS + 1, -1, np.int64)  # the table of _arm_fit
    fit_keys[FIT_SLOTS] = 0
    fits = np.empty((FIT_SLOTS, 4), np.float64)
    k = 0
    for v in range(nv):
        ci = vi[v]
        cj = vj[v]
        for d in range(4):
            if not (corners[ci, cj] >> d) & 1 or (done[v] >> d) & 1:
                continue
            lab_l, lab_r = _sides(labels, periodic, ci, cj, d)
            ei, ej, dx, dy, n, d_last, head, tail = _walk(corners, not periodic, ci, cj, d, nci, ncj)
            start[k] = v
            end[k] = _vertex_id(row_first, vj, ei, ej)
            start_arm[k] = d
            end_arm[k] = (d_last + 2) % 4
            done[end[k]] |= np.uint8(1 << end_arm[k])
            left[k] = lab_l
            right[k] = lab_r
            ddx[k] = dx
            ddy[k] = dy
            ncrack[k] = n
            half = min(max(1, (n + 1) // 2), max_reach)
            fit = _arm_fit(corners, membrane, ci, cj, d, half, nci, ncj, head, fit_keys, fits)
            _store_fit(fit, half, d, v, count, mean, direction)
            # the end's arm: the last `half` cracks walked back from the end, relative to the end corner
            fit = _arm_fit(corners, membrane, ei, ej, end_arm[k], half, nci, ncj, tail ^ TURN_ROUND, fit_keys, fits)
            _store_fit(fit, half, end_arm[k], end[k], count, mean, direction)
            k += 1
    return (start[:k], end[:k], start_arm[:k], end_arm[:k], left[:k], right[:k], ddx[:k], ddy[:k], ncrack[:k],
            count, mean, direction)


@njit(cache=True)
def mark_junctions(periodic, corners, vi, vj, start, start_arm):
    """Flags (2, nci, ncj) of the cracks on the junctions of :func:`trace_junctions` (its start, start_arm).

    Only needed to find the loops with no vertex (:func:`trace_loops`), so
    only run when the junctions leave cracks over.
    """
    nci, ncj = corners.shape
    visited = np.zeros((2, nci, ncj), dtype=np.bool_)
    for k in range(len(start)):
        ci = vi[start[k]]
        cj = vj[start[k]]
        d = start_arm[k]
        while True:
            a, r, c = _crack_index(ci, cj, d, nci, ncj)
            visited[a, r, c] = True
            ci, cj = _step(ci, cj, d, nci, ncj)
            if _is_vertex(corners, ci, cj, nci, ncj, not periodic):
                break
            d = _next_dir(corners[ci, cj], d)
    return visited


@njit(cache=True)
def trace_loops(labels, periodic, corners, visited):
    """Boundaries left unvisited by the junctions (``visited`` of :func:`mark_junctions`): closed loops with no vertex.

    Returns, per loop, the start corner (row, col), left and right labels,
    dx, dy (the loop's net displacement: nonzero only for loops winding
    around a torus) and crack count.
    """
    nci, ncj = corners.shape
    rows = []
    cols = []
    lefts = []
    rights = []
    dxs = []
    dys = []
    ns = []
    for ci in range(nci):
        for cj in range(ncj):
            for d in range(2):
                if not (corners[ci, cj] >> d) & 1 or visited[d, ci, cj]:
                    continue
                lab_l, lab_r = _sides(labels, periodic, ci, cj, d)
                dx = 0
                dy = 0
                n = 0
                i, j, dd = ci, cj, d
                while True:
                    a, r, c = _crack_index(i, j, dd, nci, ncj)
                    if visited[a, r, c]:
                        break
                    visited[a, r, c] = True
                    dx += DJ[dd]
                    dy += DI[dd]
                    n += 1
                    i, j = _step(i, j, dd, nci, ncj)
                    dd = _next_dir(corners[i, j], dd)
                rows.append(ci)
                cols.append(cj)
                lefts.append(lab_l)
                rights.append(lab_r)
                dxs.append(dx)
                dys.append(dy)
                ns.append(n)
    return (np.array(rows, np.int64), np.array(cols, np.int64), np.array(lefts, np.int64),
            np.array(rights, np.int64), np.array(dxs, np.int64), np.array(dys, np.int64), np.array(ns, np.int64))


#: Relative tolerance of a tie at half a period in the torus unwrap of :func:`cell_moments`.
UNWRAP_TIE = 1e-9


@njit(cache=True)
def _angle_table(n):
    """cos and sin of ``2 pi k / n`` for k = 0..n-1 (the circular-mean terms of one coordinate)."""
    c = np.empty(n, np.float64)
    s = np.empty(n, np.float64)
    for k in range(n):
        a = 2.0 * np.pi * k / n
        c[k] = np.cos(a)
        s[k] = np.sin(a)
    return c, s


@njit(cache=True)
def _circular_refs(cx, snx, seen, ref, period):
    """Circular mean of each label's coordinate (kept at the first pixel's for a band around the torus)."""
    for k in range(len(ref)):
        if np.hypot(cx[k], snx[k]) > 1e-6 * seen[k]:
            ref[k] = (np.arctan2(snx[k], cx[k]) % (2.0 * np.pi)) * period / (2.0 * np.pi)


@njit(cache=True)
def _unwrapped(v, ref, period):
    """The image of coordinate ``v`` within half a period of ``ref`` (ties not moved).

    A tie is a distance within ``UNWRAP_TIE * period`` of half a period: the
    circular mean ``ref`` carries the last-bit differences of the libm's
    cos/sin (numba's and numpy's differ), which must not decide which image
    of a pixel exactly half a box away is taken.
    """
    half = (0.5 + UNWRAP_TIE) * period
    if v - ref > half:
        return v - period
    if v - ref < -half:
        return v + period
    return v


#: Initial room of :func:`cell_moments` for runs: one per this many pixels (~17 in a 2048^2 image of 9,801 cells).
RUN_PIXELS = 8


@njit(cache=True)
def _grown(values, n):
    """``values`` in an array twice as long, its first ``n`` entries kept."""
    out = np.empty(2 * len(values), values.dtype)
    out[:n] = values[:n]
    return out


@njit(cache=True)
def _run_starts(row, is_start, run_start, n):
    """Store the start column of every run of equal values of ``row`` at ``run_start[n:]``; returns the new end.

    ``is_start``: ``ceil(len(row) / 8)`` words, zero past ``len(row)`` bytes, to hold a byte per pixel
    (1 where a run starts), written without a branch and read a word at a time.
    """
    flags = is_start.view(np.uint8)
    flags[0] = 1
    for j in range(1, len(row)):
        flags[j] = row[j] != row[j - 1]
    for k in range(len(is_start)):
        word = is_start[k]
        while word:  # one bit per start, bit 0 of its byte
            run_start[n] = 8 * k + (trailing_zeros(word) >> 3)
            n += 1
            word &= word - np.uint64(1)
    return n


@njit(cache=True)
def cell_moments(labels, n_labels, periodic):
    """Pixel count and centroid of every label 0..n_labels-1 (unwrapped on a torus).

    Returns count (n,), sum_x (n,), sum_y (n,) as float64 with centroids
    ``sum / count`` in pixel coordinates (x = column, y = row).  On a torus
    the sums are of positions unwrapped around the label's circular mean
    (a second pass), so cells wider than half the box get the right
    centroid; along an axis a label wraps around completely (a band) its
    first pixel is the reference.

    The image is read along runs of equal labels in a row.  The sums are of
    whole numbers, exact in any order.  A label spanning less than half the
    box less a pixel along an axis is never moved along it (its circular
    mean lies within its span), so circular means are taken only of the
    wider ones (those touching the box edge, or large): their cos/sin terms
    come from per-column and per-row tables and are added pixel by pixel in
    raster order, as a pixel-by-pixel sum does.  The first pass finds the
    runs of a row from a byte per pixel, 1 where a run starts, written
    without a branch (whole vectors of pixels) and read 8 bytes at a time
    (:func:`_run_starts`), and keeps the start column and label of every
    run; on a torus one pass over those picks out the runs of the wide
    labels, and the two later passes visit only them, not every run again.
    """
    h, w = labels.shape
    count = np.zeros(n_labels, np.float64)
    sx = np.zeros(n_labels, np.float64)
    sy = np.zeros(n_labels, np.float64)
    lo_x = np.full(n_labels, w, np.int64)
    hi_x = np.full(n_labels, -1, np.int64)
    lo_y = np.full(n_labels, h, np.int64)
    hi_y = np.full(n_labels, -1, np.int64)
    ref_x = np.zeros(n_labels, np.float64)
    ref_y = np.zeros(n_labels, np.float64)
    # run starts row after row; row i's runs are run_start[row_first[i]:row_first[i + 1]], each ending where
    # the next starts (or at w).  Sized for runs of RUN_PIXELS px on average, grown if a row might not fit:
    # not one entry per pixel, whose allocation (mapped afresh at every call) costs page faults
    run_start = np.empty(h * w // RUN_PIXELS + w, np.int64)
    run_label = np.empty(len(run_start), labels.dtype)  # the label of every run (read again by the torus passes)
    row_first = np.zeros(h + 1, np.int64)
    is_start = np.zeros((w + 7) // 8, np.uint64)  # of the row being read, 8 pixels a word (bytes past w stay 0)
    n_runs = 0
    for i in range(h):
        row = labels[i]
        if n_runs + w > len(run_start):
            run_start = _grown(run_start, n_runs)
            run_label = _grown(run_label, n_runs)
        m = _run_starts(row, is_start, run_start, n_runs)
        row_first[i + 1] = m
        for r in range(n_runs, m):
            j0 = run_start[r]
            j = run_start[r + 1] if r + 1 < m else w
            lab = row[j0]
            run_label[r] = lab
            n = j - j0
            if count[lab] == 0:  # first pixel: the reference of a band around the whole torus
                ref_x[lab] = j0
                ref_y[lab] = i
                lo_y[lab] = i
            count[lab] += n
            sx[lab] += 0.5 * (j0 + j - 1) * n  # the columns j0..j-1 (a whole number)
            sy[lab] += n * float(i)
            lo_x[lab] = min(lo_x[lab], j0)
            hi_x[lab] = max(hi_x[lab], j - 1)
            hi_y[lab] = i
        n_runs = m
    if not periodic:
        return count, sx, sy
    wide_x = hi_x - lo_x >= 0.5 * w - 1
    wide_y = hi_y - lo_y >= 0.5 * h - 1
    wide = wide_x | wide_y
    if not wide.any():
        return count, sx, sy
    cos_x, sin_x = _angle_table(w)
    cos_y, sin_y = _angle_table(h)
    cx = np.zeros(n_labels, np.float64)
    snx = np.zeros(n_labels, np.float64)
    cy = np.zeros(n_labels, np.float64)
    sny = np.zeros(n_labels, np.float64)
    # the runs of the wide labels (few), in raster order: the two passes below visit only them
    wide_row = np.empty(n_runs, np.int64)
    wide_label = np.empty(n_runs, labels.dtype)
    wide_start = np.empty(n_runs, np.int64)  # columns wide_start .. wide_end - 1
    wide_end = np.empty(n_runs, np.int64)
    n_wide = 0
    for i in range(h):
        for r in range(row_first[i], row_first[i + 1]):
            if wide[run_label[r]]:
                wide_row[n_wide] = i
                wide_label[n_wide] = run_label[r]
                wide_start[n_wide] = run_start[r]
                wide_end[n_wide] = run_start[r + 1] if r + 1 < row_first[i + 1] else w
                n_wide += 1
    for q in range(n_wide):
        i = wide_row[q]
        lab = wide_label[q]
        j0 = wide_start[q]
        j1 = wide_end[q]
        a = cx[lab]
        b = snx[lab]
        c = cy[lab]
        d = sny[lab]
        for j in range(j0, j1):
            a += cos_x[j]
            b += sin_x[j]
            c += cos_y[i]
            d += sin_y[i]
        cx[lab] = a
        snx[lab] = b
        cy[lab] = c
        sny[lab] = d
    _circular_refs(cx, snx, count, ref_x, w)
    _circular_refs(cy, sny, count, ref_y, h)
    for k in range(n_labels):  # summed again below, unwrapped
        if wide_x[k]:
            sx[k] = 0.0
        if wide_y[k]:
            sy[k] = 0.0
    for q in range(n_wide):
        i = wide_row[q]
        lab = wide_label[q]
        j0 = wide_start[q]
        j = wide_end[q]
        n = j - j0
        if wide_y[lab]:
            sy[lab] += n * _unwrapped(float(i), ref_y[lab], h)
        if wide_x[lab]:
            if _unwrapped(float(j0), ref_x[lab], w) != j0 or _unwrapped(float(j - 1), ref_x[lab], w) != j - 1:
                for k in range(j0, j):  # the move is monotone in x: only runs whose ends move are split
                    sx[lab] += _unwrapped(float(k), ref_x[lab], w)
            else:
                sx[lab] += 0.5 * (j0 + j - 1) * n
    return count, sx, sy


@njit(cache=True)
def label_summary(labels):
    """One pass over a 2-D integer image: min, max, whether any pixel is nonzero, and the numbers of
    horizontally and vertically neighbouring pixel pairs that share their value."""
    h, w = labels.shape
    lo = labels[0, 0]
    hi = labels[0, 0]
    nonzero = False
    same_h = 0
    same_v = 0
    for i in range(h):
        for j in range(w):
            v = labels[i, j]
            lo = min(lo, v)
            hi = max(hi, v)
            nonzero |= v != 0
            if j > 0:
                same_h += v == labels[i, j - 1]
            if i > 0:
                same_v += v == labels[i - 1, j]
    return lo, hi, nonzero, same_h, same_v


@njit(cache=True)
def at_most_two_values(labels):
    """Whether a 2-D image holds at most two distinct values; stops at the third (at once in a label image)."""
    h, w = labels.shape
    first = labels[0, 0]
    second = first
    for i in range(h):
        for j in range(w):
            v = labels[i, j]
            if v != first and v != second:
                if second != first:
                    return False
                second = v
    return True


@njit(cache=True)
def present_ids(labels, top):
    """Which ids 0..top occur in ``labels`` (any integer image with values in that range)."""
    present = np.zeros(top + 1, np.bool_)
    for v in labels.ravel():
        present[v] = True
    return present


@njit(cache=True)
def fill_gaps(labels, passes, periodic):
    """Give 0-valued pixels the majority label of their 4 neighbours, ``passes`` times.

    Only pixels within ``passes`` steps of a cell are filled (membranes and
    skeleton lines); larger background stays 0.  Ties are broken by a
    neighbour order that rotates with the pixel's position, so boundaries are
    not biased towards larger or smaller ids.
    """
    h, w = labels.shape
    cur = labels.copy()
    di = np.array([-1, 0, 1, 0])
    dj = np.array([0, -1, 0, 1])
    cand = np.zeros(4, labels.dtype)
    for _ in range(passes):
        prev = cur.copy()
        changed = False
        for i in range(h):
            for j in range(w):
                if prev[i, j] != 0:
                    continue
                start = (i + j) % 4
                nc = 0
                for s in range(4):
                    k = (start + s) % 4
                    ii = i + di[k]
                    jj = j + dj[k]
                    if periodic:
                        ii %= h
                        jj %= w
                    elif ii < 0 or ii >= h or jj < 0 or jj >= w:
                        continue
                    lab = prev[ii, jj]
                    if lab != 0:
                        cand[nc] = lab
                        nc += 1
                if nc == 0:
                    continue
                best = cand[0]
                best_n = 0
                for a in range(nc):
                    m = 0
                    for b in range(nc):
                        if cand[b] == cand[a]:
                            m += 1
                    if m > best_n:
                        best_n = m
                        best = cand[a]
                cur[i, j] = best
                changed = True
        if not changed:
            break
    return cur


@njit(cache=True, error_model="numpy")  # numpy's division: 0 / 0 is NaN, as the checks below expect
def arm_intersections(cluster, off, v, arm, count, mean, direction, n_clusters, max_shift):
    """Least-squares intersection of the fitted arm lines of each cluster of vertices, relative to its centre.

    Arm ``arm[k]`` of vertex ``v[k]`` is the line through ``off[v] +
    mean[v, arm]`` along ``direction[v, arm]``, weighted by its crack
    ``count``; ``cluster`` maps vertices to clusters.  Minimises
    sum_k w_k |(I - t t^T)(x - point_k)|^2 per cluster (its normal equations
    are summed in the order of ``v``).  Clusters whose lines are nearly
    parallel, or whose intersection is farther than ``max_shift`` px, get 0.
    """
    mxx = np.zeros(n_clusters)
    mxy = np.zeros(n_clusters)
    myy = np.zeros(n_clusters)
    rx = np.zeros(n_clusters)
    ry = np.zeros(n_clusters)
    for k in range(len(v)):
        vk = v[k]
        ak = arm[k]
        w = float(count[vk, ak])
        t0 = direction[vk, ak, 0]
        t1 = direction[vk, ak, 1]
        p0 = off[vk, 0] + mean[vk, ak, 0]
        p1 = off[vk, 1] + mean[vk, ak, 1]
        pxx = 1 - t0 * t0
        pxy = -t0 * t1
        pyy = 1 - t1 * t1
        c = cluster[vk]
        mxx[c] += w * pxx
        mxy[c] += w * pxy
        myy[c] += w * pyy
        rx[c] += w * (pxx * p0 + pxy * p1)
        ry[c] += w * (pxy * p0 + pyy * p1)
    shift = np.zeros((n_clusters, 2))
    for c in range(n_clusters):
        det = mxx[c] * myy[c] - mxy[c] * mxy[c]
        trace = mxx[c] + myy[c]
        sx = (myy[c] * rx[c] - mxy[c] * ry[c]) / det
        sy = (mxx[c] * ry[c] - mxy[c] * rx[c]) / det
        if det > 0.1 * (trace * trace) / 4 and _length_below(sx, sy, max_shift, True):
            shift[c, 0] = sx
            shift[c, 1] = sy
    return shift


@njit(cache=True)
def _length_below(x, y, limit, or_equal):
    """``np.hypot(x, y) < limit`` (``<=`` with ``or_equal``), decided from ``x * x + y * y`` unless it is a near tie.

    The libm's hypot costs ~20 ns; the sum of squares is within a few
    ulps of the true square length and hypot within one ulp of the true
    length, so outside a relative band of 1e-9 the two agree; inside it
    (and for inf or NaN) hypot decides.
    """
    q = x * x + y * y
    l2 = limit * limit
    if q < l2 * (1.0 - 1e-9):
        return True
    if q > l2 * (1.0 + 1e-9):
        return False
    h = np.hypot(x, y)
    return h <= limit if or_equal else h < limit


@njit(cache=True)
def chain_offsets(nv, start, end, vec, short, first):
    """Each vertex's displacement from its cluster's first vertex, summed along the ``short`` junctions.

    Breadth-first from each ``first`` vertex, neighbours in junction order.
    Along the junctions, not by minimum image: a cluster may be wider than
    half a periodic box (no cycle of short junctions goes around it:
    :func:`unwrap_short`), and the junctions' own vectors place it right.
    """
    ptr = np.zeros(nv + 1, np.int64)
    for k in range(len(start)):
        if short[k]:
            ptr[start[k] + 1] += 1
            ptr[end[k] + 1] += 1
    for v in range(nv):
        ptr[v + 1] += ptr[v]
    fill = ptr[:-1].copy()
    other = np.empty(ptr[nv], np.int64)
    step = np.empty((ptr[nv], 2))
    for k in range(len(start)):
        if short[k]:
            for u, w, sign in ((start[k], end[k], 1.0), (end[k], start[k], -1.0)):
                other[fill[u]] = w
                step[fill[u], 0] = sign * vec[k, 0]
                step[fill[u], 1] = sign * vec[k, 1]
                fill[u] += 1
    off = np.zeros((nv, 2))
    seen = np.zeros(nv, np.bool_)
    queue = np.empty(nv, np.int64)
    for r in first:
        seen[r] = True
        queue[0] = r
        head, tail = 0, 1
        while head < tail:
            u = queue[head]
            head += 1
            for i in range(ptr[u], ptr[u + 1]):
                w = other[i]
                if not seen[w]:
                    seen[w] = True
                    off[w, 0] = off[u, 0] + step[i, 0]
                    off[w, 1] = off[u, 1] + step[i, 1]
                    queue[tail] = w
                    tail += 1
    return off


@njit(cache=True, error_model="numpy")
def _cluster_positions(pos, start, end, start_arm, end_arm, vec, short, count, mean, direction, max_shift):
    """Vertices joined by ``short`` junctions: cluster of each vertex, cluster positions, vertex offsets.

    A vertex's position is its cluster's position plus its offset (from the
    cluster's first vertex along the junctions, :func:`chain_offsets`, then
    centred on the mean); the
    cluster positions are moved to the intersection of the arm lines of the
    junctions that stay (:func:`arm_intersections`, start ends then end
    ends, in junction order).  Sums run in vertex order, as ``np.bincount``.
    """
    nv = len(pos)
    cluster, first = components(nv, start[short], end[short])
    nc = len(first)
    off = chain_offsets(nv, start, end, vec, short, first)
    counts = np.zeros(nc, np.int64)
    sums = np.zeros((nc, 2))
    for v in range(nv):
        c = cluster[v]
        for a in range(2):
            sums[c, a] += off[v, a]
        counts[c] += 1
    centre = np.empty((nc, 2))
    for c in range(nc):
        for a in range(2):
            sums[c, a] = sums[c, a] / counts[c]  # the mean offset from the first vertex
            centre[c, a] = pos[first[c], a] + sums[c, a]
    for v in range(nv):
        for a in range(2):
            off[v, a] -= sums[cluster[v], a]
    n_ends = 0
    for k in range(len(start)):
        n_ends += (not short[k]) * ((start_arm[k] >= 0) + (end_arm[k] >= 0))
    vs = np.empty(n_ends, np.int64)
    arms = np.empty(n_ends, np.int64)
    e = 0
    for ends, ends_arm in ((start, start_arm), (end, end_arm)):
        for k in range(len(start)):
            if not short[k] and ends_arm[k] >= 0:
                vs[e] = ends[k]
                arms[e] = ends_arm[k]
                e += 1
    shift = arm_intersections(cluster, off, vs, arms, count, mean, direction, nc, max_shift)
    for c in range(nc):
        for a in range(2):
            centre[c, a] += shift[c, a]
    for v in range(nv):
        for a in range(2):
            off[v, a] -= shift[cluster[v], a]
    return cluster, centre, off


@njit(cache=True)
def _root_offset(parent, ox, oy, v):
    """Root of ``v`` in the offset union-find, and the displacement from the root to ``v``; compresses the path.

    ``ox[u], oy[u]``: the displacement from ``parent[u]`` to ``u``.
    """
    r = v
    sx = 0.0
    sy = 0.0
    while parent[r] != r:
        sx += ox[r]
        sy += oy[r]
        r = parent[r]
    u, cx, cy = v, sx, sy
    while parent[u] != u:
        nxt, nx, ny = parent[u], cx - ox[u], cy - oy[u]
        parent[u], ox[u], oy[u] = r, cx, cy
        u, cx, cy = nxt, nx, ny
    return r, sx, sy


@njit(cache=True)
def unwrap_short(n, start, end, vec, short, lengths):
    """Keep (clear ``short`` for) each junction that would close a cycle of short junctions around a periodic box.

    Contracting such a cycle would fold a loop around the torus into a point
    and change the network's topology (V - E + F no longer 0).  Junctions
    are taken in order; one whose ends are already joined by short junctions
    along a path whose displacement, with its own, sums to a box vector (not
    to 0) stays a junction.  Nothing to do for an open image (``lengths`` 0).
    """
    half = 0.5 * min(lengths[0], lengths[1])
    if half <= 0:
        return
    parent = np.arange(n)
    ox = np.zeros(n)
    oy = np.zeros(n)
    for k in range(len(start)):
        if not short[k]:
            continue
        rs, sx, sy = _root_offset(parent, ox, oy, start[k])
        re, ex, ey = _root_offset(parent, ox, oy, end[k])
        dx, dy = sx + vec[k, 0] - ex, sy + vec[k, 1] - ey  # end[k]'s root as seen from rs through k
        if rs == re:
            if dx * dx + dy * dy > half * half:
                short[k] = False
        else:
            parent[re], ox[re], oy[re] = rs, dx, dy


@njit(cache=True, error_model="numpy")
def merge_clusters(pos, start, end, start_arm, end_arm, vec, count, mean, direction, lengths, merge_distance,
                   max_rounds, max_shift):
    """Contract the junctions shorter than ``merge_distance``, in rounds, until no other is (loops never are).

    Junction lengths are measured between the sub-pixel positions of the
    merged vertices (:func:`_cluster_positions`), which depend on what was
    merged: a junction that becomes shorter than ``merge_distance`` is
    contracted in the next round, up to ``max_rounds`` rounds.  ``lengths``:
    the periodic box's (Lx, Ly), zeros for an open image.

    Returns the cluster positions, which junctions are kept (not
    contracted), and for the kept ones their end clusters and their vectors
    between the merged positions (in junction order).
    """
    nj = len(start)
    short = np.empty(nj, np.bool_)
    for k in range(nj):
        short[k] = start[k] != end[k] and _length_below(vec[k, 0], vec[k, 1], merge_distance, False)
    unwrap_short(len(pos), start, end, vec, short, lengths)
    again = np.zeros(nj, np.bool_)
    keep = ~short
    for _ in range(max_rounds):
        cluster, centre, off = _cluster_positions(pos, start, end, start_arm, end_arm, vec, short, count, mean,
                                                  direction, max_shift)
        keep = ~short
        n_keep = 0
        any_again = False
        for k in range(nj):
            if keep[k]:
                n_keep += 1
                vx = vec[k, 0] + off[start[k], 0] - off[end[k], 0]
                vy = vec[k, 1] + off[start[k], 1] - off[end[k], 1]
                again[k] = cluster[start[k]] != cluster[end[k]] and _length_below(vx, vy, merge_distance, False)
                any_again |= again[k]
        if not any_again:
            break
        for k in range(nj):
            short[k] |= again[k]
        unwrap_short(len(pos), start, end, vec, short, lengths)
    a = np.empty(n_keep, np.int64)
    b = np.empty(n_keep, np.int64)
    kvec = np.empty((n_keep, 2))
    i = 0
    for k in range(nj):
        if keep[k]:
            a[i] = cluster[start[k]]
            b[i] = cluster[end[k]]
            for x in range(2):
                kvec[i, x] = vec[k, x] + off[start[k], x] - off[end[k], x]
            i += 1
    return centre, keep, a, b, kvec


@njit(cache=True)
def components(n, a, b):
    """Connected components of the graph on vertices 0..n-1 with edges ``(a[k], b[k])``.

    Returns the component id of every vertex, components numbered in the
    order of their smallest vertex (as scipy's ``connected_components``),
    and that smallest vertex of each component.
    """
    parent = np.arange(n)
    for k in range(len(a)):
        ra = a[k]
        while parent[ra] != ra:
            parent[ra] = parent[parent[ra]]
            ra = parent[ra]
        rb = b[k]
        while parent[rb] != rb:
            parent[rb] = parent[parent[rb]]
            rb = parent[rb]
        if ra < rb:  # the root is the smallest vertex of its component
            parent[rb] = ra
        elif rb < ra:
            parent[ra] = rb
    label = np.empty(n, np.int64)
    first = np.empty(n, np.int64)
    n_components = 0
    for v in range(n):  # a root precedes every vertex of its component, so its label is known first
        r = v
        while parent[r] != r:
            r = parent[r]
        if r == v:
            label[v] = n_components
            first[n_components] = v
            n_components += 1
        else:
            label[v] = label[r]
    return label, first[:n_components].copy()


@njit(cache=True)
def half_edge_order(cell, frm, n_cells):
    """The order that sorts half-edges by (cell, frm), ties kept in input order (``np.lexsort((frm, cell))``).

    A counting sort by cell (ids 0..n_cells-1), then an insertion sort of
    each cell's few half-edges by ``frm``: linear, where a general sort of
    the keys is not.
    """
    first = np.zeros(n_cells + 1, np.int64)
    for c in cell:
        first[c + 1] += 1
    for c in range(n_cells):
        first[c + 1] += first[c]
    fill = first[:-1].copy()
    order = np.empty(len(cell), np.int64)
    for h in range(len(cell)):
        order[fill[cell[h]]] = h
        fill[cell[h]] += 1
    for c in range(n_cells):
        for i in range(first[c] + 1, first[c + 1]):
            h = order[i]
            j = i - 1
            while j >= first[c] and frm[order[j]] > frm[h]:  # strict: equal keys keep their order
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = h
    return order


@njit(cache=True)
def chain_cycles(cell, frm, to):
    """Boundary cycles of every cell from its half-edges.

    Half-edges must be sorted by (cell, frm).  Returns ``cycle`` (cycle id of
    each half-edge) and ``order`` (the half-edge indices cycle after cycle,
    each cycle in traversal order), and the cycle start offsets in ``order``.
    A vertex visited twice by one cell (a pinched cell) is resolved by taking
    the first unused half-edge.
    """
    nh = len(cell)
    used = np.zeros(nh, np.bool_)
    cycle = -np.ones(nh, np.int64)
    order = np.empty(nh, np.int64)
    starts = np.empty(nh + 1, np.int64)
    n_cycles = 0
    pos = 0
    s = 0
    while s < nh:
        e = s
        while e < nh and cell[e] == cell[s]:
            e += 1
        for h in range(s, e):
            if used[h]:
                continue
            starts[n_cycles] = pos
            cur = h
            while True:
                used[cur] = True
                cycle[cur] = n_cycles
                order[pos] = cur
                pos += 1
                target = to[cur]
                lo = _lower_bound(frm, s, e, target)  # the first half-edge of this cell leaving `target`
                nxt = -1
                while lo < e and frm[lo] == target:
                    if not used[lo]:
                        nxt = lo
                        break
                    lo += 1
                if nxt < 0:
                    break
                cur = nxt
            n_cycles += 1
        s = e
    starts[n_cycles] = pos
    return cycle, order, starts[: n_cycles + 1]


@njit(cache=True)
def _pairwise_sum(a, s, n):
    """Sum of ``a[s:s + n]`` in numpy's pairwise order (``pairwise_sum`` of numpy's ``loops_utils.h.src``).

    So that a sum over a polygon equals numpy's to the last bit
    (``tests/test_mesh_kernels.py`` checks it against ``np.add.reduceat``).
    """
    if n < 8:
        r = -0.0
        for i in range(n):
            r += a[s + i]
        return r
    if n <= 128:
        r = np.empty(8)
        for u in range(8):
            r[u] = a[s + u]
        i = 8
        while i < n - n % 8:
            for u in range(8):
                r[u] += a[s + i + u]
            i += 8
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
        while i < n:
            res += a[s + i]
            i += 1
        return res
    half = n // 2
    half -= half % 8
    return _pairwise_sum(a, s, half) + _pairwise_sum(a, s + half, n - half)


@njit(cache=True)
def segment_total(a, s, n):
    """``np.add.reduceat`` over the segment ``a[s:s + n]`` (n >= 1): its first value plus the pairwise sum of the rest."""
    return a[s] + _pairwise_sum(a, s + 1, n - 1)


@njit(cache=True)
def polygons(centre, a, b, left, right, vec, n_labels):
    """Counter-clockwise boundary cycles of every cell from the kept junctions; the largest per cell.

    Half-edges are the junctions seen from their left cell (a -> b) then
    from their right cell (b -> a, reversed vector), cell 0 left out, sorted
    by (cell, start vertex) (:func:`half_edge_order`) and chained
    (:func:`chain_cycles`).  Each cycle is unwrapped from its first vertex's
    position by the exact junction vectors: a running sum over all cycles,
    as ``np.cumsum`` computes it, less its value at the cycle's start.
    Signed shoelace areas are summed as ``np.add.reduceat`` does.

    Returns per cell (compact id) the start offset, length, signed area and
    perimeter (NaN without a polygon; summed as ``np.add.reduceat`` does) of
    its polygon (the largest cycle, the first of equal ones, if its area is
    positive) in ``verts``/``xy`` (vertex ids and unwrapped (x, y) of every
    cycle back to back), and its number of cycles.
    """
    nk = len(a)
    nh = 0
    for k in range(nk):
        nh += (left[k] != 0) + (right[k] != 0)
    cell = np.empty(nh, np.int64)
    frm = np.empty(nh, np.int64)
    to = np.empty(nh, np.int64)
    hvec = np.empty((nh, 2))
    h = 0
    for side in range(2):
        for k in range(nk):
            c = left[k] if side == 0 else right[k]
            if c == 0:
                continue
            cell[h] = c
            frm[h] = a[k] if side == 0 else b[k]
            to[h] = b[k] if side == 0 else a[k]
            sign = 1.0 if side == 0 else -1.0
            hvec[h, 0] = sign * vec[k, 0]
            hvec[h, 1] = sign * vec[k, 1]
            h += 1
    order = half_edge_order(cell, frm, n_labels)
    cell = cell[order]
    frm = frm[order]
    to = to[order]
    hvec = hvec[order]
    _, seq, cstart = chain_cycles(cell, frm, to)
    n_cyc = len(cstart) - 1
    xy = np.empty((nh, 2))
    verts = np.empty(nh, np.int64)
    cross = np.empty(nh)
    area = np.empty(n_cyc)
    run_x = 0.0
    run_y = 0.0
    for q in range(n_cyc):
        s, e = cstart[q], cstart[q + 1]
        v0 = frm[seq[s]]
        for i in range(s, e):
            hx, hy = hvec[seq[i], 0], hvec[seq[i], 1]
            run_x += hx
            run_y += hy
            xy[i, 0] = run_x - hx  # the running sum before this step, as np.cumsum(step) - step gives it
            xy[i, 1] = run_y - hy
            verts[i] = frm[seq[i]]
        bx, by = xy[s, 0], xy[s, 1]
        for i in range(s, e):
            xy[i, 0] = centre[v0, 0] + xy[i, 0] - bx
            xy[i, 1] = centre[v0, 1] + xy[i, 1] - by
        for i in range(s, e):
            j = i + 1 if i + 1 < e else s
            cross[i] = xy[i, 0] * xy[j, 1] - xy[j, 0] * xy[i, 1]
        area[q] = 0.5 * segment_total(cross, s, e - s)
    poly_start = np.full(n_labels, -1, np.int64)
    poly_len = np.zeros(n_labels, np.int64)
    poly_area = np.full(n_labels, np.nan)
    poly_perimeter = np.full(n_labels, np.nan)
    n_cycles = np.zeros(n_labels, np.int64)
    q = 0
    while q < n_cyc:  # the cycles of a cell are consecutive
        c = cell[seq[cstart[q]]]
        best = q
        r = q
        while r < n_cyc and cell[seq[cstart[r]]] == c:
            if area[r] > area[best]:
                best = r
            r += 1
        n_cycles[c] = r - q
        if area[best] > 0:
            s, e = cstart[best], cstart[best + 1]
            poly_start[c] = s
            poly_len[c] = e - s
            poly_area[c] = area[best]
            for i in range(s, e):  # side lengths (the cross products are not needed any more)
                j = i + 1 if i + 1 < e else s
                cross[i] = np.hypot(xy[j, 0] - xy[i, 0], xy[j, 1] - xy[i, 1])
            poly_perimeter[c] = segment_total(cross, s, e - s)
        q = r
    return poly_start, poly_len, poly_area, poly_perimeter, verts, xy, n_cycles


@njit(cache=True)
def cell_vertex_rows(rows, poly_start, poly_len, verts, xy, centre, lengths):
    """The ``cell_vertices`` rows of the cells ``rows`` (compact ids, in table order), and their polygons.

    Returns, over the polygon vertices of the rows with a polygon, back to
    back: the row's index in ``rows``, the rank, the vertex id, and the
    periodic image (x, y) of the vertex that makes the polygon contiguous
    (``rint((xy - centre[vertex]) / lengths)``; 0 on an open image, where
    ``lengths`` is 0); the polygons' vertex positions (the vertex's
    position plus its image, as the tables give it back) and the first row of each polygon.
    """
    n = 0
    n_poly = 0
    for r in range(len(rows)):
        if poly_start[rows[r]] >= 0:
            n += poly_len[rows[r]]
            n_poly += 1
    row = np.empty(n, np.int64)
    rank = np.empty(n, np.int64)
    vertex = np.empty(n, np.int64)
    image = np.zeros((n, 2), np.int64)
    polygon_xy = np.empty((n, 2))
    first = np.empty(n_poly, np.int64)
    periodic = lengths[0] > 0
    i = 0
    q = 0
    for r in range(len(rows)):
        s = poly_start[rows[r]]
        if s < 0:
            continue
        first[q] = i
        q += 1
        for k in range(poly_len[rows[r]]):
            v = verts[s + k]
            row[i] = r
            rank[i] = k
            vertex[i] = v
            for a in range(2):
                polygon_xy[i, a] = centre[v, a]
                if periodic:
                    image[i, a] = np.int64(np.rint((xy[s + k, a] - centre[v, a]) / lengths[a]))
                    polygon_xy[i, a] = centre[v, a] + image[i, a] * lengths[a]
            i += 1
    return row, rank, vertex, image, polygon_xy, first


@njit(cache=True)
def _crack_point(membrane, ci, cj, d):
    """Point representing the crack leaving corner (ci, cj) in direction d, relative to the corner.

    The mean centre of the membrane pixels on either side of the crack, or
    the crack midpoint when neither side was membrane.
    """
    # padded indices of the two pixels beside the crack
    if d == 0:
        r1, c1, r2, c2 = ci, cj + 1, ci + 1, cj + 1
    elif d == 1:
        r1, c1, r2, c2 = ci + 1, cj, ci + 1, cj + 1
    elif d == 2:
        r1, c1, r2, c2 = ci, cj, ci + 1, cj
    else:
        r1, c1, r2, c2 = ci, cj, ci, cj + 1
    sx = 0.0
    sy = 0.0
    n = 0
    if membrane[r1, c1]:
        sx += c1 - cj - 0.5
        sy += r1 - ci - 0.5
        n += 1
    if membrane[r2, c2]:
        sx += c2 - cj - 0.5
        sy += r2 - ci - 0.5
        n += 1
    if n == 0:
        return 0.5 * DJ[d], 0.5 * DI[d]
    return sx / n, sy / n
