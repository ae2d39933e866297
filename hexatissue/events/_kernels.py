"""Numba kernels of the events stage (:mod:`hexatissue.events`).

The T1 step between two frames (:func:`_t1_kernel`), the pairing of T1s with their inverses
(:func:`_undo_pairs`), a frame's neighbour lists (:func:`_lists_kernel`) and the changes of those
lists (:func:`_close_kernel`, :func:`_change_kernel`, :func:`_excursion_starts`).  Their
plain-numpy or plain-Python references are in :mod:`hexatissue.events._reference`; the tests
compare the two.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .._hashing import mix64_word


@njit(cache=True)
def _t1_kernel(p_keys, p_u, p_v, p_present, keys, u, v, present, K):
    """:func:`_t1_step` on the two frames' sorted keys, directed contacts and cells."""
    new, gone = keys[_missing(keys, p_keys)], p_keys[_missing(p_keys, keys)]
    loss_ab, loss_cd = _quartet_kernel(gone[_both_in(gone, present, K)], p_keys, p_u, p_v, K)
    gain_cd, gain_ab = _quartet_kernel(new[_both_in(new, p_present, K)], keys, u, v, K)
    return new, gone, loss_ab, loss_cd, gain_ab, gain_cd


@njit(cache=True)
def _both_in(keys, present, K):
    """Which contacts ``a * K + b`` have both cells in the sorted ``present``."""
    out = np.empty(len(keys), np.bool_)
    for i in range(len(keys)):
        out[i] = _contains(present, keys[i] // K) and _contains(present, keys[i] % K)
    return out


@njit(cache=True)
def _missing(a, b):
    """Which of the sorted unique ``a`` are not in the sorted unique ``b`` (a merge)."""
    out = np.ones(len(a), np.bool_)
    j = 0
    for i in range(len(a)):
        while j < len(b) and b[j] < a[i]:
            j += 1
        out[i] = j == len(b) or b[j] != a[i]
    return out


@njit(cache=True)
def _quartet_kernel(pairs, keys, u, v, K):
    """:meth:`_FrameGraph.quartets` of a frame's keys and directed contacts: arrays (pair, c * K + d)."""
    lo, hi = _first_not_below(u, pairs // K, 0), _first_not_below(u, pairs // K, 1)  # neighbours of a (ids: integers)
    common = np.empty((hi - lo).sum(), np.int64)
    found = np.empty(len(pairs) + 1, np.int64)  # first common neighbour of each pair, and the end
    found[0] = 0
    for p in range(len(pairs)):  # the common neighbours of each pair, in order
        b, n = pairs[p] % K, found[p]
        for r in range(lo[p], hi[p]):
            if v[r] != b and _contains(keys, min(b, v[r]) * K + max(b, v[r])):
                common[n] = v[r]
                n += 1
        found[p + 1] = n
    size = 0
    for p in range(len(pairs)):
        n = found[p + 1] - found[p]
        size += n * (n - 1) // 2
    ab, cd = np.empty(size, np.int64), np.empty(size, np.int64)
    q = 0
    for p in range(len(pairs)):  # every pair c < d of them
        for x in range(found[p], found[p + 1]):
            for y in range(x + 1, found[p + 1]):
                ab[q], cd[q] = pairs[p], common[x] * K + common[y]
                q += 1
    return ab, cd


@njit(cache=True)
def _undo_pairs(undone):
    """Scan of T1s sorted by quartet and frame: ``(first, cycle)``, each event's first T1 and whether it is a cycle.

    ``undone[k]``: T1 ``k + 1`` undoes T1 ``k``.  A T1 and the one undoing
    it make one cycle; the next T1 starts a new event (a quartet may go
    round several times).
    """
    first = np.empty(len(undone), np.int64)
    cycle = np.empty(len(undone), np.bool_)
    n = k = 0
    while k < len(undone):
        first[n], cycle[n] = k, undone[k]
        k += 2 if undone[k] else 1
        n += 1
    return first[:n], cycle[:n]


@njit(cache=True)
def _lists_kernel(tracks, a, b, golden):
    """``u, v, row, h, full`` of :class:`_ListsReference` from the contacts ``a - b`` (any order).

    Each contact goes to the lists of its cells present in ``tracks``
    (a counting sort by cell); each list, a few neighbours long, is then
    sorted in place, and its hashes (:func:`hexatissue._hashing.mix64_word`
    of ``v + golden``) summed.
    """
    n = len(tracks)
    ra, rb = _first_not_below(tracks, a, 0), _first_not_below(tracks, b, 0)
    start = np.zeros(n + 1, np.int64)
    for k in range(len(a)):
        if ra[k] < n and tracks[ra[k]] == a[k]:
            start[ra[k] + 1] += 1
        if rb[k] < n and tracks[rb[k]] == b[k]:
            start[rb[k] + 1] += 1
    for r in range(n):
        start[r + 1] += start[r]
    fill = start[:n].copy()
    v = np.empty(start[n], np.int64)
    for k in range(len(a)):  # in the order of _directed: each contact a -> b, then each b -> a
        if ra[k] < n and tracks[ra[k]] == a[k]:
            v[fill[ra[k]]] = b[k]
            fill[ra[k]] += 1
    for k in range(len(a)):
        if rb[k] < n and tracks[rb[k]] == b[k]:
            v[fill[rb[k]]] = a[k]
            fill[rb[k]] += 1
    row = np.empty(start[n], np.int64)
    h = np.empty(start[n], np.uint64)
    full = np.zeros(n, np.uint64)
    for r in range(n):
        for q in range(start[r] + 1, start[r + 1]):  # insertion sort of the list
            x, p = v[q], q
            while p > start[r] and v[p - 1] > x:
                v[p] = v[p - 1]
                p -= 1
            v[p] = x
        for q in range(start[r], start[r + 1]):
            row[q], h[q] = r, mix64_word(np.uint64(v[q]) + golden)
            full[r] += h[q]
    return tracks[row], v, row, h, full


@njit(cache=True)
def _excursion_starts(order, track, start, back):
    """The changes, in ``order``, that start an excursion: a cycle's (``back >= 0``) covers the later changes of
    its cell up to the frame its list is back."""
    first = np.empty(len(order), np.int64)
    n = k = 0
    while k < len(order):
        i = order[k]
        first[n] = i
        n += 1
        k += 1
        if back[i] >= 0:
            while k < len(order) and track[order[k]] == track[i] and start[order[k]] <= back[i]:
                k += 1
    return first[:n]


@njit(cache=True)
def _search(values, x):
    """``np.searchsorted(values, x)`` of one value (binary search).

    numba's ``np.searchsorted`` brings its generic comparisons (complex and
    NaN-aware ones among them) into every kernel that calls it, and
    compiling them was seconds of a first run.
    """
    lo, hi = 0, len(values)
    while lo < hi:
        mid = (lo + hi) // 2
        if values[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def _first_not_below(values, xs, shift):
    """``np.searchsorted(values, xs + shift)`` of integers ``xs``: shift 0 is side "left", shift 1 side "right"."""
    out = np.empty(len(xs), np.int64)
    for k in range(len(xs)):
        out[k] = _search(values, xs[k] + shift)
    return out


@njit(cache=True)
def _contains(values, x):
    """Whether ``x`` is in the sorted array ``values``."""
    i = _search(values, x)
    return i < len(values) and values[i] == x


@njit(cache=True)
def _absent(cell, frame, tracks, keys):
    """Whether ``cell`` is absent from the frame of ``tracks`` or from ``frame`` (``keys``: every row key)."""
    return not (_contains(tracks, cell) and _contains(keys, frame * (1 << 40) + cell))


@njit(cache=True)
def _starts(row, n):
    """First directed contact of each of ``n`` cells (``row``: the cell of each, sorted), and the end."""
    out = np.zeros(n + 1, np.int64)
    for r in range(len(row)):
        out[row[r] + 1] += 1
    for i in range(n):
        out[i + 1] += out[i]
    return out


@njit(cache=True)
def _hash_on(v, h, lo, hi, present):
    """Hash of the list ``v[lo:hi]`` restricted to the sorted ids ``present``."""
    out = np.uint64(0)
    for r in range(lo, hi):
        if _contains(present, v[r]):
            out += h[r]
    return out


@njit(cache=True)
def _close_kernel(tracks, u, v, h, full, open_, ref, m, rare, rare_h, k, common, keys, rare_ids, slot):
    """:meth:`_ChangesReference._close` in place on the buffers: (indices of the changes closed, new m, new k).

    ``slot``: a table over the track ids (-1 everywhere) to find the rows of the open changes' cells, or
    empty (a binary search).  Every open change is compared at every frame (one lookup and one comparison
    each); the buffers are rewritten only from the first change closed on.
    """
    # element by element: numba's fancy-index assignment of an array compiles a shape-mismatch message (str and
    # repr of shapes), seconds of a first run
    if len(slot):
        for r in range(len(tracks)):
            slot[tracks[r]] = r
    back = np.zeros(m, np.bool_)
    first, first_rare, o = m, k, 0  # the first change closed, its first rare neighbour; next rare neighbour
    for c in range(m):
        cell, before, lo = open_[1, c], open_[2, c], o
        while o < k and rare[0, o] == c:
            o += 1
        if len(slot):
            row = slot[cell]
        else:
            row = _search(tracks, cell)
            row = row if row < len(tracks) and tracks[row] == cell else -1
        if row < 0:
            continue
        now, was = full[row], ref[c]
        if rare_ids:  # less the neighbours absent from either frame
            r = _search(u, cell)
            while r < len(u) and u[r] == cell:
                if not _contains(common, v[r]) and _absent(v[r], before, tracks, keys):
                    now -= h[r]
                r += 1
            for q in range(lo, o):
                if _absent(rare[1, q], before, tracks, keys):
                    was -= rare_h[q]
        if now == was:
            back[c] = True
            if first == m:
                first, first_rare = c, lo
    if len(slot):
        for r in range(len(tracks)):
            slot[tracks[r]] = -1
    done = open_[0, first:m][back[first:m]].copy()
    w, wk, o = first, first_rare, first_rare  # open changes and rare neighbours kept; next rare neighbour
    for c in range(first, m):
        lo = o
        while o < k and rare[0, o] == c:
            o += 1
        if back[c]:
            continue
        for q in range(lo, o):
            rare[0, wk], rare[1, wk], rare_h[wk] = w, rare[1, q], rare_h[q]
            wk += 1
        open_[0, w], open_[1, w], open_[2, w], ref[w] = open_[0, c], open_[1, c], open_[2, c], ref[c]
        w += 1
    return done, w, wk


@njit(cache=True)
def _change_kernel(prev_frame, p_tracks, p_v, p_h, p_full, p_row, tracks, v, h, full, row, open_, ref, m, n, rare,
                   rare_h, k, common, rare_ids):
    """The changes of :meth:`_ChangesReference.add` appended in place: (cell, n_lost, n_gained) of each, new m, k.

    The buffers have room for one change per cell and one rare neighbour per directed contact of the
    frame before.
    """
    same = len(p_tracks) == len(tracks) and np.all(p_tracks == tracks)  # then every list is compared whole
    p_start, start = _starts(p_row, len(p_tracks)), _starts(row, len(tracks))
    cells, n_lost, n_gained = np.empty(len(tracks), np.int64), np.empty(len(tracks), np.int64), np.empty(
        len(tracks), np.int64)
    new = j = 0
    for i in range(len(tracks)):
        cell = tracks[i]
        while j < len(p_tracks) and p_tracks[j] < cell:
            j += 1
        if j == len(p_tracks) or p_tracks[j] != cell:
            continue
        lo, hi, p_lo, p_hi = start[i], start[i + 1], p_start[j], p_start[j + 1]
        if same:
            was, now = p_full[j], full[i]
        else:  # on the cells present in both frames
            was, now = _hash_on(p_v, p_h, p_lo, p_hi, tracks), _hash_on(v, h, lo, hi, p_tracks)
        if was == now:
            continue
        lost = gained = 0
        for r in range(p_lo, p_hi):  # lost: neighbours before that are not now but are present now
            x = p_v[r]
            if not _contains(v[lo:hi], x) and _contains(tracks, x):
                lost += 1
            if rare_ids and not _contains(common, x):
                rare[0, k], rare[1, k], rare_h[k] = m, x, p_h[r]
                k += 1
        for r in range(lo, hi):  # gained: the other way round
            x = v[r]
            if not _contains(p_v[p_lo:p_hi], x) and _contains(p_tracks, x):
                gained += 1
        open_[0, m], open_[1, m], open_[2, m], ref[m] = n + new, cell, prev_frame, p_full[j]
        cells[new], n_lost[new], n_gained[new] = cell, lost, gained
        new += 1
        m += 1
    # copies: views would keep the frame-sized arrays of every frame with changes alive
    return cells[:new].copy(), n_lost[:new].copy(), n_gained[:new].copy(), m, k
