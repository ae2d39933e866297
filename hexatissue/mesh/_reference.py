"""Plain-Python references of the numba kernels in :mod:`hexatissue.mesh._kernels`.

The tests compare the kernels against them, and a first run of a small input
on an empty numba cache runs them instead of compiling the kernels
(:mod:`hexatissue._dispatch`).

Each function here has the name, signature and outputs (values, dtypes and,
where the kernel's order is a defined rule, order) of the kernel it checks.
They are written from what the algorithm has to do, not from the kernels'
code, so that a slip in one is unlikely to be repeated in the other:

- the pixels beside a crack come from its geometry (crack midpoint plus or
  minus half the left-hand normal), not from a table of cases;
- a crack is named by the corner it leaves in +x or +y, found by stepping
  along it, and the crack graph is walked by pairing the arms of each
  pass-through corner;
- a junction is kept when it is met from the first of its two ends
  (vertex id, arm direction), with no "visited" flags; loops are closed
  when the walk comes back to its first crack;
- line fits use the covariance matrix's eigenvectors; chains of half-edges
  are found by linear search.

Everything but :func:`corner_types` and :func:`fill_gaps` (whole-array
numpy) is a Python loop over corners or half-edges: slow, and meant for
small images (the bundled sample's 11 frames of 160 x 257 px: about 3 s).  Conventions
(corner lattice, directions, corner types) are those of ``_kernels``.
"""
import numpy as np

from ._kernels import UNWRAP_TIE  # a convention shared with the kernels, not code

# direction d -> unit step (x, y) = (column, row) on the corner lattice: +x, +y, -x, -y
UNIT = ((1, 0), (0, 1), (-1, 0), (0, -1))
# at a corner where two boundaries touch diagonally (types 5 and 6), the arms that form one boundary
DIAGONAL_PAIRS = {5: ((3, 0), (1, 2)), 6: ((3, 2), (0, 1))}


def _pixels_beside(ci, cj, d):
    """Padded (row, col) of the pixels on the left and on the right of the crack from corner (ci, cj) along d.

    Left and right in x-y axes: the left normal of the unit step (ex, ey) is
    (-ey, ex).  Corner (ci, cj) is at x = cj - 0.5, y = ci - 0.5, the crack
    midpoint half a step further, and each pixel centre half a normal to its
    side; pixel (x, y) is ``pad[y + 1, x + 1]``.  Doubled coordinates keep it integer.
    """
    ex, ey = UNIT[d]
    mid2x, mid2y = 2 * cj - 1 + ex, 2 * ci - 1 + ey
    (lx, ly), (rx, ry) = ((mid2x - ey) // 2, (mid2y + ex) // 2), ((mid2x + ey) // 2, (mid2y - ex) // 2)
    return (ly + 1, lx + 1), (ry + 1, rx + 1)


def _labels_beside(pad, ci, cj, d):
    left, right = _pixels_beside(ci, cj, d)
    return pad[left], pad[right]


def _neighbour(ci, cj, d, nci, ncj):
    """The corner one crack away from (ci, cj) along d; the lattice is a torus (open images never leave it)."""
    ex, ey = UNIT[d]
    return (ci + ey) % nci, (cj + ex) % ncj


def _crack_key(ci, cj, d, nci, ncj):
    """(0 horizontal / 1 vertical, row, col): the crack named by the corner from which it runs along +x or +y."""
    if d < 2:
        return d, ci, cj
    ei, ej = _neighbour(ci, cj, d, nci, ncj)
    return d - 2, ei, ej


_ARM_SETS = tuple(tuple(d for d in range(4) if (mask >> d) & 1) for mask in range(16))


def _arm_set(mask):
    """The directions of the arms of a corner, from its arm bits."""
    return _ARM_SETS[mask]


def _partner(corner_kind, mask, arm):
    """The arm continuing the boundary that reaches a pass-through corner (type 2, 5 or 6) by ``arm``."""
    if corner_kind == 2:
        first, second = _arm_set(mask)
        return second if arm == first else first
    for a, b in DIAGONAL_PAIRS[corner_kind]:
        if arm in (a, b):
            return b if arm == a else a
    raise ValueError(f"arm {arm} is not an arm of a corner of type {corner_kind}")


def _walk(arms, kind, ci, cj, d):
    """The cracks (corner row, corner col, direction) of the boundary leaving corner (ci, cj) along d, in order.

    Endless: the caller stops before the walk would have to pass a vertex.
    """
    nci, ncj = arms.shape
    while True:
        yield ci, cj, d
        ci, cj = _neighbour(ci, cj, d, nci, ncj)
        d = _partner(kind[ci, cj], arms[ci, cj], (d + 2) % 4)


def _corner_kind(tl, tr, bl, br, n_arms):
    if n_arms < 4:
        return n_arms  # 0 (inside a cell), 2 (a boundary passes) or 3 (three-fold vertex)
    if len({tl, tr, bl, br}) == 4:
        return 4
    main, anti = tl == br, tr == bl  # which diagonal pair of pixels shares a label
    if main and anti:  # a two-label checkerboard: the smaller label is the connected one
        return 5 if tl < tr else 6
    return 5 if main else 6


def _padded(labels, periodic):
    """The labels padded by one pixel (wrapping on a torus, 0 around an open image) and the lattice shape."""
    pad = np.pad(labels, 1, mode="wrap" if periodic else "constant")
    h, w = labels.shape
    return pad, ((h, w) if periodic else (h + 1, w + 1))


def corner_types(labels, periodic):
    """Reference of :func:`._kernels.corner_types`, on whole arrays (it runs on small first-run inputs too).

    Corner (ci, cj) has TL = ``pad[ci, cj]``, TR = ``pad[ci, cj + 1]``,
    BL = ``pad[ci + 1, cj]``, BR = ``pad[ci + 1, cj + 1]``; arm d runs
    between the two pixels beside its crack (:func:`_pixels_beside`): +x
    between TR and BR, +y between BL and BR, -x between TL and BL, -y
    between TL and TR.
    """
    pad, (nci, ncj) = _padded(labels, periodic)
    tl, tr = pad[:nci, :ncj], pad[:nci, 1:ncj + 1]
    bl, br = pad[1:nci + 1, :ncj], pad[1:nci + 1, 1:ncj + 1]
    present = np.stack([tr != br, bl != br, tl != bl, tl != tr])  # direction d = 0..3
    arms = (present * (1 << np.arange(4))[:, None, None]).sum(axis=0).astype(np.uint8)
    n_arms = present.sum(axis=0)
    distinct = (tl != tr) & (tl != bl) & (tl != br) & (tr != bl) & (tr != br) & (bl != br)
    main, anti = tl == br, tr == bl  # which diagonal pair of pixels shares a label
    # a two-label checkerboard (both pairs equal): the smaller label is the connected one
    five = np.where(main & anti, tl < tr, main)
    kind = np.where(n_arms < 4, n_arms, np.where(distinct, 4, np.where(five, 5, 6))).astype(np.uint8)
    is_vertex = (kind == 3) | (kind == 4)
    if not periodic:  # the image corners of an open image, where a boundary turns
        corner = np.zeros((nci, ncj), bool)
        corner[[0, 0, -1, -1], [0, -1, 0, -1]] = True
        is_vertex |= corner & (n_arms > 0)
    vi, vj = np.nonzero(is_vertex)  # raster order
    # each crack once, named by the corner it leaves along +x or +y (_crack_key)
    d, ci, cj = np.nonzero(present)
    back = d >= 2
    ci[back] = (ci[back] + np.where(d[back] == 3, -1, 0)) % nci
    cj[back] = (cj[back] + np.where(d[back] == 2, -1, 0)) % ncj
    n_cracks = len(np.unique((d % 2) * (nci * ncj) + ci * ncj + cj))
    return arms | (kind << 4), vi.astype(np.int64), vj.astype(np.int64), n_cracks


def _split(corners):
    """The arm bit masks and the types of corner codes (``arms | kind << 4``)."""
    return corners & 15, corners >> 4


def _vertex_map(shape, vi, vj):
    """Vertex id of every corner of the lattice (-1 where none): the vertices numbered in their order."""
    vid = np.full(shape, -1, np.int64)
    vid[vi, vj] = np.arange(len(vi))
    return vid


def _junction_cracks(arms, kind, vid, ci, cj, d):
    """The cracks from vertex corner (ci, cj) along arm d to the next vertex, and that vertex's corner."""
    nci, ncj = arms.shape
    cracks = []
    for crack in _walk(arms, kind, ci, cj, d):
        cracks.append(crack)
        end = _neighbour(*crack, nci, ncj)
        if vid[end] >= 0:
            return cracks, end


def _displacement(cracks):
    return sum(UNIT[d][0] for _, _, d in cracks), sum(UNIT[d][1] for _, _, d in cracks)


def trace_junctions(labels, periodic, corners, vi, vj, n_max, membrane, max_reach):
    """Reference of :func:`._kernels.trace_junctions`.

    A junction is listed once, traced from the first of its two ends in
    (vertex id, arm direction) order; junctions come in the order of those ends.
    Its two arms are then fitted by :func:`arm_lines` over half the junction
    (1 to ``max_reach`` cracks), walking again from each end.  A
    ``membrane`` of size 0 means no membrane pixel.
    """
    arms, kind = _split(corners)
    pad, _ = _padded(labels, periodic)
    if membrane.size == 0:
        membrane = np.zeros(pad.shape, bool)
    vid = _vertex_map(arms.shape, vi, vj)
    rows = []
    walks = {}  # (vertex, arm) -> its cracks, walked once for the junctions and the arm fits
    for v in range(len(vi)):
        for d in _arm_set(arms[vi[v], vj[v]]):
            cracks, end_corner = _junction_cracks(arms, kind, vid, vi[v], vj[v], d)
            walks[v, d] = cracks
            end, end_arm = int(vid[end_corner]), (cracks[-1][2] + 2) % 4
            if (end, end_arm) < (v, d):
                continue  # listed from its other end
            left, right = _labels_beside(pad, vi[v], vj[v], d)
            rows.append((v, end, d, end_arm, left, right, *_displacement(cracks), len(cracks)))
    if len(rows) > n_max:
        raise ValueError(f"{len(rows)} junctions do not fit in n_max = {n_max}")
    columns = list(zip(*rows)) if rows else [()] * 9
    dtypes = [np.int64] * 4 + [pad.dtype] * 2 + [np.int64] * 3
    junctions = tuple(np.array(c, t) for c, t in zip(columns, dtypes))
    start, end, start_arm, end_arm, *_, ncrack = junctions
    reach = np.zeros((len(vi), 4), np.int64)
    half = np.clip((ncrack + 1) // 2, 1, max_reach)
    reach[start, start_arm] = half
    reach[end, end_arm] = half
    return junctions + _arm_lines(arms, kind, vid, vi, vj, reach, membrane, walks)


def mark_junctions(periodic, corners, vi, vj, start, start_arm):
    """Reference of :func:`._kernels.mark_junctions`."""
    arms, kind = _split(corners)
    vid = _vertex_map(arms.shape, vi, vj)
    nci, ncj = arms.shape
    visited = np.zeros((2, nci, ncj), np.bool_)
    for v, d in zip(start, start_arm):
        for crack in _junction_cracks(arms, kind, vid, vi[v], vj[v], d)[0]:
            visited[_crack_key(*crack, nci, ncj)] = True
    return visited


def trace_loops(labels, periodic, corners, visited):
    """Reference of :func:`._kernels.trace_loops` (``visited`` is read, not changed).

    Each loop starts at its first crack in (corner row, corner col,
    direction) order, run along +x or +y, and ends when the walk is back on
    that crack.
    """
    arms, kind = _split(corners)
    pad, _ = _padded(labels, periodic)
    nci, ncj = arms.shape
    left_over = [(ci, cj, d) for ci in range(nci) for cj in range(ncj) for d in _arm_set(arms[ci, cj])
                 if d < 2 and not visited[d, ci, cj]]
    done = set()
    rows = []
    for first in left_over:
        if first in done:
            continue
        cracks = []
        for crack in _walk(arms, kind, *first):
            if cracks and crack == first:
                break
            if len(cracks) > len(left_over):
                raise RuntimeError(f"the boundary from crack {first} does not close")
            cracks.append(crack)
        done.update((ci, cj, d) for d, ci, cj in (_crack_key(*c, nci, ncj) for c in cracks))
        rows.append((first[0], first[1], *_labels_beside(pad, *first), *_displacement(cracks), len(cracks)))
    columns = list(zip(*rows)) if rows else [()] * 7
    return tuple(np.array(c, np.int64) for c in columns)


def _crack_point(membrane, ci, cj, d):
    """Fit point of a crack, relative to its corner: the centre of its membrane pixels, else its midpoint.

    The pixel centres are the midpoint plus and minus half the left normal,
    so one membrane pixel moves the point half a pixel to its side and two
    (or none) leave it at the midpoint.
    """
    (ex, ey), left, right = UNIT[d], *_pixels_beside(ci, cj, d)
    side = int(bool(membrane[left])) - int(bool(membrane[right]))
    return np.array([0.5 * ex - 0.5 * ey * side, 0.5 * ey + 0.5 * ex * side])


def _arm_lines(arms, kind, vid, vi, vj, reach, membrane, walks):
    """The arm line fits of :func:`trace_junctions` over the first ``reach[v, d]`` cracks along arm d of vertex v.

    ``walks[v, d]``: the cracks of that arm's junction, as :func:`_junction_cracks` walked them.

    ``direction`` is a line's axis, whose sign has no meaning; here it has
    x >= 0 (y > 0 when x == 0).  Compare up to sign: the kernel's sign for
    near-vertical lines follows rounding.  Points with an isotropic spread
    (e.g. all four cracks around one pixel, when ``reach`` lets the walk go
    round it) have no axis; there the kernel's choice, (1, 0) from
    ``arctan2(0, 0) = 0``, is returned.
    """
    nv = len(vi)
    count = np.zeros((nv, 4), np.int64)
    mean = np.zeros((nv, 4, 2), np.float64)
    direction = np.zeros((nv, 4, 2), np.float64)
    for v in range(nv):
        for d in _arm_set(arms[vi[v], vj[v]]):
            if reach[v, d] == 0:
                continue
            cracks = walks[v, d][: reach[v, d]]
            # each point relative to the vertex corner: the corner it leaves, unwrapped, plus its point there
            corner = np.cumsum([(0, 0)] + [UNIT[c[2]] for c in cracks[:-1]], axis=0)
            points = corner + np.array([_crack_point(membrane, *c) for c in cracks])
            count[v, d] = len(points)
            mean[v, d] = points.mean(axis=0)
            cov = np.cov(points.T, bias=True) if len(points) > 1 else np.zeros((2, 2))
            if np.trace(cov) < 1e-12:
                direction[v, d] = UNIT[d]
                continue
            values, vectors = np.linalg.eigh(cov)
            if values[1] - values[0] < 1e-12:
                direction[v, d] = (1.0, 0.0)
                continue
            axis = vectors[:, -1]  # largest variance
            direction[v, d] = -axis if axis[0] < 0 or (axis[0] == 0 and axis[1] < 0) else axis
    return count, mean, direction


def _circular_mean(v, period):
    """Circular mean of the coordinates ``v`` (raster order) on a circle of ``period``; ``v[0]`` for a full band."""
    angle = 2.0 * np.pi * v / period
    c, s = np.cumsum(np.cos(angle))[-1], np.cumsum(np.sin(angle))[-1]  # sequential sums, as the kernel
    if not np.hypot(c, s) > 1e-6 * len(v):
        return v[0]
    return (np.arctan2(s, c) % (2.0 * np.pi)) * period / (2.0 * np.pi)


def cell_moments(labels, n_labels, periodic):
    """Reference of :func:`._kernels.cell_moments`."""
    h, w = labels.shape
    count = np.zeros(n_labels, np.float64)
    sx = np.zeros(n_labels, np.float64)
    sy = np.zeros(n_labels, np.float64)
    for lab in range(n_labels):
        y, x = np.nonzero(labels == lab)  # raster order: the first pixel is the label's reference
        if len(x) == 0:
            continue
        x, y = x.astype(float), y.astype(float)
        if periodic:  # the image of each pixel within half a box of the circular mean (ties not moved)
            rx, ry = _circular_mean(x, w), _circular_mean(y, h)
            hw, hh = (0.5 + UNWRAP_TIE) * w, (0.5 + UNWRAP_TIE) * h
            x -= w * np.where(x - rx > hw, 1, np.where(x - rx < -hw, -1, 0))
            y -= h * np.where(y - ry > hh, 1, np.where(y - ry < -hh, -1, 0))
        count[lab], sx[lab], sy[lab] = len(x), x.sum(), y.sum()
    return count, sx, sy


def label_summary(labels):
    """Reference of :func:`._kernels.label_summary`."""
    return (labels.min(), labels.max(), bool(labels.any()), int((labels[:, 1:] == labels[:, :-1]).sum()),
            int((labels[1:] == labels[:-1]).sum()))


def arm_intersections(cluster, off, v, arm, count, mean, direction, n_clusters, max_shift):
    """Reference of :func:`._kernels.arm_intersections` (weighted bincounts of the normal equations)."""
    w = count[v, arm].astype(float)
    t = direction[v, arm]
    point = off[v] + mean[v, arm]  # on the line, relative to the cluster centre
    c = cluster[v]
    pxx, pxy, pyy = 1 - t[:, 0] ** 2, -t[:, 0] * t[:, 1], 1 - t[:, 1] ** 2
    mxx, mxy, myy = (np.bincount(c, w * q, n_clusters) for q in (pxx, pxy, pyy))
    rx = np.bincount(c, w * (pxx * point[:, 0] + pxy * point[:, 1]), n_clusters)
    ry = np.bincount(c, w * (pxy * point[:, 0] + pyy * point[:, 1]), n_clusters)
    det = mxx * myy - mxy**2
    trace = mxx + myy
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = np.c_[(myy * rx - mxy * ry) / det, (mxx * ry - mxy * rx) / det]
        good = (det > 0.1 * trace**2 / 4) & (np.hypot(*shift.T) <= max_shift)
    shift[~good] = 0.0
    return shift


def present_ids(labels, top):
    """Reference of :func:`._kernels.present_ids`."""
    return np.bincount(np.ravel(labels), minlength=top + 1) > 0


def components(n, a, b):
    """Reference of :func:`._kernels.components` (breadth-first search from each vertex in turn)."""
    adjacent = [[] for _ in range(n)]
    for u, v in zip(a, b):
        adjacent[u].append(v)
        adjacent[v].append(u)
    label = np.full(n, -1, np.int64)
    first = []
    for v in range(n):
        if label[v] >= 0:
            continue
        label[v] = len(first)
        queue = [v]
        while queue:
            u = queue.pop()
            for w in adjacent[u]:
                if label[w] < 0:
                    label[w] = len(first)
                    queue.append(w)
        first.append(v)
    return label, np.array(first, np.int64)


def chain_cycles(cell, frm, to):
    """Reference of :func:`._kernels.chain_cycles`.

    A cycle starts at the lowest-index unused half-edge of a cell (cells in
    the order they appear) and goes on along the lowest-index unused
    half-edge of the same cell leaving the vertex reached, until there is none.
    """
    nh = len(cell)
    cycle = np.full(nh, -1, np.int64)
    order = []
    starts = [0]
    for c in dict.fromkeys(np.asarray(cell).tolist()):
        mine = [h for h in range(nh) if cell[h] == c]
        while True:
            free = [h for h in mine if cycle[h] < 0]
            if not free:
                break
            h = free[0]
            while h is not None:
                cycle[h] = len(starts) - 1
                order.append(h)
                h = next((k for k in mine if cycle[k] < 0 and frm[k] == to[h]), None)
            starts.append(len(order))
    return cycle, np.array(order, np.int64), np.array(starts, np.int64)


def half_edge_order(cell, frm, n_cells):
    """Reference of :func:`._kernels.half_edge_order`."""
    return np.lexsort((frm, cell))


def chain_offsets(nv, start, end, vec, short, first):
    """Reference of :func:`._kernels.chain_offsets` (lists of neighbours, a deque)."""
    from collections import deque

    neighbours = [[] for _ in range(nv)]
    for k in np.flatnonzero(short):
        neighbours[start[k]].append((end[k], vec[k]))
        neighbours[end[k]].append((start[k], -vec[k]))
    off = np.zeros((nv, 2))
    seen = np.zeros(nv, bool)
    for r in first:
        seen[r] = True
        queue = deque([r])
        while queue:
            u = queue.popleft()
            for w, d in neighbours[u]:
                if not seen[w]:
                    seen[w] = True
                    off[w] = off[u] + d
                    queue.append(w)
    return off


def unwrap_short(n, start, end, vec, short, lengths):
    """Reference of :func:`._kernels.unwrap_short`: each cluster a dict of its vertices' displacements from its
    first one, clusters joined by relabelling (no union-find)."""
    half = 0.5 * min(lengths)
    if half <= 0:
        return
    cluster = {v: {v: np.zeros(2)} for v in range(n)}  # root -> {member: displacement from the root}
    root = list(range(n))
    for k in np.flatnonzero(short):
        rs, re = root[start[k]], root[end[k]]
        d = cluster[rs][start[k]] + vec[k] - cluster[re][end[k]]
        if rs == re:
            if np.hypot(*d) > half:
                short[k] = False
            continue
        for v, off in cluster.pop(re).items():
            cluster[rs][v] = off + d
            root[v] = rs


def merge_clusters(pos, start, end, start_arm, end_arm, vec, count, mean, direction, lengths, merge_distance,
                   max_rounds, max_shift):
    """Reference of :func:`._kernels.merge_clusters` (whole-array rounds, weighted bincounts)."""
    def positions(short):
        cluster, first = components(len(pos), start[short], end[short])
        off_first = chain_offsets(len(pos), start, end, vec, short, first)
        counts = np.bincount(cluster)
        mean_off = np.column_stack([np.bincount(cluster, off_first[:, a]) for a in range(2)]) / counts[:, None]
        off = off_first - mean_off[cluster]
        use_start = ~short & (start_arm >= 0)
        use_end = ~short & (end_arm >= 0)
        v = np.concatenate((start[use_start], end[use_end]))
        arm = np.concatenate((start_arm[use_start], end_arm[use_end]))
        shift = arm_intersections(cluster, off, v, arm, count, mean, direction, len(first), max_shift)
        return cluster, pos[first] + mean_off + shift, off - shift[cluster]

    short = (start != end) & (np.hypot(*vec.T) < merge_distance)
    unwrap_short(len(pos), start, end, vec, short, lengths)
    for _ in range(max_rounds):
        cluster, centre, off = positions(short)
        keep = ~short
        kvec = vec[keep] + off[start[keep]] - off[end[keep]]
        a, b = cluster[start[keep]], cluster[end[keep]]
        again = (a != b) & (np.hypot(*kvec.T) < merge_distance)
        if not again.any():
            break
        short[np.flatnonzero(keep)[again]] = True
        unwrap_short(len(pos), start, end, vec, short, lengths)
    return centre, keep, a, b, kvec


def segment_total(a, s, n):
    """Reference of :func:`._kernels.segment_total`."""
    return np.add.reduceat(a[s:s + n], [0])[0]


def polygons(centre, a, b, left, right, vec, n_labels):
    """Reference of :func:`._kernels.polygons` (whole-array numpy: cumulative sums, shoelace by reduceat)."""
    from ..geometry import polygon_area_centroid, polygon_perimeter

    cell = np.concatenate((left, right))
    frm = np.concatenate((a, b))
    to = np.concatenate((b, a))
    hvec = np.concatenate((vec, -vec))
    inside = cell != 0
    cell, frm, to, hvec = cell[inside], frm[inside], to[inside], hvec[inside]
    order = half_edge_order(cell, frm, n_labels)
    cell, frm, to, hvec = cell[order], frm[order], to[order], hvec[order]
    _, seq, cstart = chain_cycles(cell, frm, to)
    clen = np.diff(cstart)
    cstart = cstart[:-1]
    step = hvec[seq].reshape(-1, 2)
    cum = np.cumsum(step, axis=0) - step
    first = np.repeat(cstart, clen)
    xy = centre[frm[seq[first]]] + cum - cum[first] if len(seq) else np.zeros((0, 2))
    area = polygon_area_centroid(xy, cstart)[0]
    ccell = cell[seq[cstart]]
    poly_start = np.full(n_labels, -1, np.int64)
    poly_len = np.zeros(n_labels, np.int64)
    poly_area = np.full(n_labels, np.nan)
    perimeter = polygon_perimeter(xy, cstart)
    poly_perimeter = np.full(n_labels, np.nan)
    for c in np.unique(ccell):
        mine = np.flatnonzero(ccell == c)
        best = mine[np.argmax(area[mine])]
        if area[best] > 0:
            poly_start[c], poly_len[c], poly_area[c] = cstart[best], clen[best], area[best]
            poly_perimeter[c] = perimeter[best]
    return (poly_start, poly_len, poly_area, poly_perimeter, frm[seq], xy,
            np.bincount(ccell, minlength=n_labels))


def cell_vertex_rows(rows, poly_start, poly_len, verts, xy, centre, lengths):
    """Reference of :func:`._kernels.cell_vertex_rows` (repeats and gathers)."""
    starts, sizes = poly_start[rows], poly_len[rows]
    has = starts >= 0
    starts, sizes = starts[has], sizes[has]
    first = np.cumsum(sizes) - sizes
    take = np.repeat(starts - first, sizes) + np.arange(sizes.sum())
    vertex = verts[take].astype(np.int64)
    image = np.zeros((len(take), 2), np.int64)
    polygon_xy = centre[vertex]
    if lengths[0] > 0 and len(take):
        image = np.rint((xy[take] - polygon_xy) / lengths).astype(np.int64)
        polygon_xy = polygon_xy + image * lengths
    row = np.repeat(np.flatnonzero(has), sizes)
    return row, np.arange(len(take)) - np.repeat(first, sizes), vertex, image, polygon_xy, first


def at_most_two_values(labels):
    """Reference of :func:`._kernels.at_most_two_values` (two comparisons, not a sort)."""
    others = labels[labels != labels.flat[0]]
    return others.size == 0 or not (others != others[0]).any()


def fill_gaps(labels, passes, periodic):
    """Reference of :func:`._kernels.fill_gaps`, on whole arrays (it runs on small first-run inputs too).

    Each pass gives every 0-pixel the most frequent nonzero label among its
    4 neighbours, read in the order up, left, down, right rotated by
    ``(row + col) % 4``; of equally frequent labels the first read wins.
    """
    cur = labels.copy()
    h, w = labels.shape
    rows, cols = np.indices((h, w))
    start = (rows + cols) % 4
    for _ in range(passes):
        zero = cur == 0
        if not zero.any():
            break
        pad = np.pad(cur, 1, mode="wrap" if periodic else "constant")
        # neighbour k: up, left, down, right (the kernel's k = 0..3)
        around = np.stack([pad[:-2, 1:-1], pad[1:-1, :-2], pad[2:, 1:-1], pad[1:-1, 2:]])
        cand = np.stack([np.take_along_axis(around, ((start + s) % 4)[None], axis=0)[0] for s in range(4)])
        votes = np.where(cand != 0, (cand[:, None] == cand[None]).sum(axis=1), -1)
        best = np.take_along_axis(cand, votes.argmax(axis=0)[None], axis=0)[0]  # argmax: the first of ties
        filled = zero & (best != 0)
        if not filled.any():
            break
        cur = np.where(filled, best, cur)
    return cur
