"""The whole-movie implementation of the T1 and neighbour-list events (before they streamed frames),
and the plain-numpy references of the kernels in :mod:`hexatissue.events._kernels`.

The whole-movie implementation is kept only as the reference the streaming implementation in
:mod:`hexatissue.events` is compared against (``tests/test_events.py``): it holds every contact of
the movie at once.  The helpers that did not change are imported, not copied.
"""
from __future__ import annotations

import bisect

import numpy as np
import pandas as pd

from ..geometry import in_sorted, lookup, row_keys
from ..graph import contact_table as graph_contacts
from ..schema import interior_mask, track_ids, validate
from .classify import classify_t1, default_censor
from .neighbours import _ChangeLog, _mix
from .neighbours import _Lists as _FrameLists  # (_Lists below is the whole-movie implementation's own)
from .quartets import _directed, _expand


def track_contacts(edges: pd.DataFrame, cells: pd.DataFrame | None = None, min_length: float = 0.0) -> pd.DataFrame:
    """Cell-cell contacts per frame, in track ids. (reference)"""
    pairs = graph_contacts(edges)
    frame = pairs["frame"].to_numpy(np.int64)
    a, b = pairs["cell_a"].to_numpy(np.int64), pairs["cell_b"].to_numpy(np.int64)
    length = pairs["length"].to_numpy(float)
    del pairs
    if min_length > 0:
        keep = length >= min_length
        frame, a, b, length = frame[keep], a[keep], b[keep], length[keep]
    if cells is not None and "track" in cells.columns:  # label ids -> track ids, one sorted key per cell
        keys = row_keys(cells["frame"].to_numpy(np.int64), cells["cell"].to_numpy(np.int64))
        missing = "edges refer to (frame, cell) pairs missing from the cells table"
        track = cells["track"].to_numpy(np.int64)
        a = lookup(keys, track, row_keys(frame, a), missing)
        b = lookup(keys, track, row_keys(frame, b), missing)
        a, b = np.minimum(a, b), np.maximum(a, b)
        order = np.lexsort((b, a, frame))  # track ids need not keep the label order
        frame, a, b, length = frame[order], a[order], b[order], length[order]
    return pd.DataFrame({"frame": frame, "a": a, "b": b, "length": length})


class _Graph:
    """Contacts and presence of every frame as sorted int64 keys (frame positions, compact ids)."""

    def __init__(self, frame, a, b, pres_frame, pres_id, n_ids):
        self.K = np.int64(n_ids + 1)
        self.pair_key = np.sort((frame * self.K + a) * self.K + b)
        # directed adjacency sorted by (frame, u)
        u, v, f = np.r_[a, b], np.r_[b, a], np.r_[frame, frame]
        order = np.lexsort((v, u, f))
        self.adj_key, self.adj_v = (f * self.K + u)[order], v[order]
        self.present = np.sort(pres_frame * self.K + pres_id)

    def has_pair(self, frame, a, b):
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        key = (frame * self.K + lo) * self.K + hi
        pos = np.searchsorted(self.pair_key, key)
        pos = np.minimum(pos, len(self.pair_key) - 1)
        return (self.pair_key[pos] == key) if len(self.pair_key) else np.zeros(len(key), bool)

    def is_present(self, frame, cell):
        key = frame * self.K + cell
        pos = np.minimum(np.searchsorted(self.present, key), max(len(self.present) - 1, 0))
        return (self.present[pos] == key) if len(self.present) else np.zeros(len(key), bool)

    def common_neighbours(self, frame, a, b):
        """Rows ``(query index, v)`` for every common neighbour v of a and b at ``frame``."""
        key = frame * self.K + a
        lo, hi = np.searchsorted(self.adj_key, key, "left"), np.searchsorted(self.adj_key, key, "right")
        idx, owner = _expand(lo, hi)
        v = self.adj_v[idx]
        keep = (v != b[owner]) & self.has_pair(frame[owner], b[owner], v)
        return owner[keep], v[keep]


def held_rings(edges: pd.DataFrame, cells: pd.DataFrame) -> dict:
    """Per frame, the cell sets (track ids) of the vertices of four or more cells, from the edges' ends. (reference)"""
    if not {"vertex_a", "vertex_b"} <= set(edges.columns):
        return {}
    translate = "track" in cells.columns
    track = dict(zip(zip(cells["frame"].tolist(), cells["cell"].tolist()), cells["track"].tolist())) if translate else {}
    around = {}
    for f, va, vb, a, b in zip(*(edges[c].tolist() for c in ("frame", "vertex_a", "vertex_b", "cell_a", "cell_b"))):
        for v in (va, vb):
            around.setdefault((f, v), set()).update(c for c in (a, b) if c > 0)
    out = {}
    for (f, _), cs in around.items():
        if len(cs) >= 4:
            out.setdefault(f, []).append(frozenset(track[(f, c)] if translate else c for c in cs))
    return out


def find_t1(contacts: pd.DataFrame, presence: pd.DataFrame, held: dict | None = None) -> pd.DataFrame:
    """Raw T1s (one per neighbour exchange) from contacts and cell presence. (reference)

    ``held`` (:func:`held_rings`): the cells around each vertex of four or
    more cells, per frame; their pairs are neighbours in the quartet search,
    and a T1 whose four cells are around one such vertex before its loss and
    after its gain is a four-fold vertex's sides collapsing in turn, not a T1.
    """
    frames = np.unique(presence["frame"].to_numpy(np.int64))
    ids, inv = np.unique(np.r_[presence["track"].to_numpy(np.int64), contacts["a"].to_numpy(np.int64),
                               contacts["b"].to_numpy(np.int64)], return_inverse=True)
    n_p, n_c = len(presence), len(contacts)
    p_id, a, b = inv[:n_p], inv[n_p:n_p + n_c], inv[n_p + n_c:]
    p_fr = np.searchsorted(frames, presence["frame"].to_numpy(np.int64))
    c_fr = np.searchsorted(frames, contacts["frame"].to_numpy(np.int64))
    empty = pd.DataFrame({c: np.empty(0, np.int64) for c in
                          ("frame_lost", "frame_gain", "cell_a", "cell_b", "cell_c", "cell_d")})
    if n_c == 0 or len(frames) < 2:
        return empty
    g = _Graph(c_fr, a, b, p_fr, p_id, len(ids))
    flanks = g
    held = {} if held is None else held
    if held:  # the contacts and the pairs around every vertex of four or more cells
        fa, fb, ff = [a], [b], [c_fr]
        for f, rings in held.items():
            if f not in set(frames.tolist()):
                continue
            for ring in rings:
                r = sorted(np.searchsorted(ids, sorted(ring)).tolist())
                pairs = [(x, y) for i, x in enumerate(r) for y in r[i + 1:]]
                fa.append(np.array([x for x, _ in pairs], np.int64))
                fb.append(np.array([y for _, y in pairs], np.int64))
                ff.append(np.full(len(pairs), np.searchsorted(frames, f), np.int64))
        fa, fb, ff = np.concatenate(fa), np.concatenate(fb), np.concatenate(ff)
        key = np.unique((ff * g.K + fa) * g.K + fb)
        ff, rest = np.divmod(key, g.K * g.K)
        fa, fb = np.divmod(rest, g.K)
        flanks = _Graph(ff, fa, fb, p_fr, p_id, len(ids))
    # Runs of consecutive frames of each contact: interval starts are gains, ends are losses.
    pair = a * g.K + b
    order = np.lexsort((c_fr, pair))
    pair, fr = pair[order], c_fr[order]
    brk = np.r_[True, (pair[1:] != pair[:-1]) | (fr[1:] != fr[:-1] + 1)]
    starts = np.flatnonzero(brk)
    ends = np.r_[starts[1:], len(pair)] - 1
    i_pair, i_start, i_stop = pair[starts], fr[starts], fr[ends] + 1
    same_next = np.r_[i_pair[1:] == i_pair[:-1], False]
    i_next = np.where(same_next, np.r_[i_start[1:], 0], np.iinfo(np.int64).max)
    same_prev = np.r_[False, i_pair[1:] == i_pair[:-1]]
    i_prev = np.where(same_prev, np.r_[0, i_stop[:-1]], -1)  # end of the contact's previous run
    ia, ib = np.divmod(i_pair, g.K)
    T = len(frames)
    # losses: a-b present at stop-1, absent at stop, both cells present at stop
    lost = (i_stop < T)
    lost &= g.is_present(np.minimum(i_stop, T - 1), ia) & g.is_present(np.minimum(i_stop, T - 1), ib)
    L = np.flatnonzero(lost)
    # gains: c-d present at start, absent at start-1, both cells present at start-1
    gain = i_start > 0
    gain &= g.is_present(np.maximum(i_start - 1, 0), ia) & g.is_present(np.maximum(i_start - 1, 0), ib)
    G = np.flatnonzero(gain)
    # Quartet of a loss: common neighbours of a, b just before; of a gain: of c, d just after.
    q, v = flanks.common_neighbours(i_stop[L] - 1, ia[L], ib[L])
    lq, lc, ld = _quartets(q, v)
    q, v = flanks.common_neighbours(i_start[G], ia[G], ib[G])
    gq, ga, gb = _quartets(q, v)
    # a loss of a-b (run k) and a gain of c-d (run g) are one T1 when the quartet is seen before the loss
    # (c, d common neighbours of a, b) or after the gain (a, b common neighbours of c, d), the gain is the
    # first of c-d since the loss and a-b has not come back by then: plain loops over the runs
    before = {}  # loss run -> the c-d keys around it
    for k, c, d in zip(L[lq].tolist(), lc.tolist(), ld.tolist()):
        before.setdefault(k, set()).add(c * g.K + d)
    after = {}  # gain run -> the a-b keys around it
    for k, a_, b_ in zip(G[gq].tolist(), ga.tolist(), gb.tolist()):
        after.setdefault(k, set()).add(a_ * g.K + b_)
    runs_of = {}
    for k, p in enumerate(i_pair.tolist()):
        runs_of.setdefault(p, []).append(k)
    # every loss may take part, also one with fewer than two common neighbours just before (the gain sees
    # its quartet); a gain only with a quartet after it
    loss_runs = set(L.tolist())
    sides = {}  # (loss run, gain run) -> on how many sides the quartet is seen (1 or 2)
    for k_loss, cds in before.items():
        for k_gain in (k for cd in cds for k in runs_of.get(cd, []) if k in after):
            sides[(k_loss, k_gain)] = sides.get((k_loss, k_gain), 0) + 1
    for k_gain, abs_ in after.items():
        for k_loss in (k for ab in abs_ for k in runs_of.get(ab, []) if k in loss_runs):
            sides[(k_loss, k_gain)] = sides.get((k_loss, k_gain), 0) + 1
    candidates = []
    for (k_loss, k_gain), n_sides in sides.items():
        t_lost, t_gain = int(i_stop[k_loss]), int(i_start[k_gain])
        if t_lost <= t_gain < i_next[k_loss] and i_prev[k_gain] <= t_lost:
            ab, cd = int(i_pair[k_loss]), int(i_pair[k_gain])
            candidates.append((n_sides == 1, t_gain - t_lost, t_gain, ab, cd, t_lost))
    # each loss and each gain is one T1 at most: both-sided quartets first, then the shortest wait
    chosen, used = [], set()
    for _, _, t_gain, ab, cd, t_lost in sorted(candidates):
        if ("loss", ab, t_lost) not in used and ("gain", cd, t_gain) not in used:
            used |= {("loss", ab, t_lost), ("gain", cd, t_gain)}
            quartet = {int(ids[ab // g.K]), int(ids[ab % g.K]), int(ids[cd // g.K]), int(ids[cd % g.K])}
            if not all(any(quartet <= ring for ring in held.get(int(frames[t]), ())) for t in (t_lost - 1, t_gain)):
                chosen.append((ab, cd, t_lost, t_gain))
    if not chosen:
        return empty
    ab, cd, lost_at, gain_at = map(np.array, zip(*chosen))
    out = pd.DataFrame({
        "frame_lost": frames[lost_at], "frame_gain": frames[gain_at],
        "cell_a": ids[ab // g.K], "cell_b": ids[ab % g.K], "cell_c": ids[cd // g.K], "cell_d": ids[cd % g.K],
    })
    return out.sort_values(["frame_lost", "cell_a", "cell_b", "cell_c", "cell_d"], ignore_index=True)


def _positions(events, cells, box):
    """Quartet centre (x, y) and border flag at frame_start, from the cells table."""
    if events.empty:
        return np.empty(0), np.empty(0), np.empty(0, bool)
    border = ~interior_mask(cells)
    keys = row_keys(cells["frame"].to_numpy(np.int64), track_ids(cells))
    pos = np.c_[cells["x"].to_numpy(float), cells["y"].to_numpy(float)]
    frame = events["frame_start"].to_numpy(np.int64)
    xy, flag = [], np.zeros(len(events), bool)
    for col in ("cell_a", "cell_b", "cell_c", "cell_d"):
        row = lookup(keys, None, row_keys(frame, events[col].to_numpy(np.int64)))
        xy.append(np.where(row[:, None] >= 0, pos[np.maximum(row, 0)], np.nan))
        flag |= (row >= 0) & border[np.maximum(row, 0)]
    xy = np.stack(xy, axis=1)
    if box is not None:
        xy = xy[:, :1] + box.min_image(xy - xy[:, :1])
        centre = box.wrap(np.nanmean(xy, axis=1))
    else:
        centre = np.nanmean(xy, axis=1)
    return centre[:, 0], centre[:, 1], flag


def detect_t1(edges: pd.DataFrame, cells: pd.DataFrame, min_length: float = 0.0, censor: int | None = None,
              box=None) -> pd.DataFrame:
    """T1 events of a movie, classified as ``cycle``, ``intercalation`` or ``unresolved``. (reference)"""
    presence = pd.DataFrame({"frame": cells["frame"].to_numpy(np.int64), "track": track_ids(cells)})
    contacts = track_contacts(edges, cells, min_length)
    raw = find_t1(contacts, presence, held_rings(edges, cells))
    last = int(presence["frame"].max()) if len(presence) else 0
    events = classify_t1(raw, last, default_censor(last + 1) if censor is None else censor)
    x, y, border = _positions(events, cells, box)  # the reference's own placement, not the package's
    events.insert(8, "x", x)
    events.insert(9, "y", y)
    events["is_border"] = border
    events.insert(0, "event", np.arange(len(events), dtype=np.int64))
    return validate(events, "events")


class _Lists:
    """Every cell's neighbour list in every frame, as hashes (vectorised) and, on demand, as sets. (reference)"""

    def __init__(self, contacts, frames, tracks):
        key = row_keys(frames, tracks)
        _, first = np.unique(key, return_index=True)
        order = first[np.lexsort((frames[first], tracks[first]))]
        self.frame, self.track = frames[order], tracks[order]
        self.keys = row_keys(self.frame, self.track)
        u = np.r_[contacts["a"].to_numpy(np.int64), contacts["b"].to_numpy(np.int64)]
        v = np.r_[contacts["b"].to_numpy(np.int64), contacts["a"].to_numpy(np.int64)]
        f = np.r_[contacts["frame"].to_numpy(np.int64), contacts["frame"].to_numpy(np.int64)]
        srt = np.lexsort((v, u, f))  # by (frame, cell): the order of their row keys
        self.u, self.v, self.f = u[srt], v[srt], f[srt]
        row = lookup(self.keys, None, row_keys(self.f, self.u))
        ok = row >= 0
        self.u, self.v, self.f, row = self.u[ok], self.v[ok], self.f[ok], row[ok]
        n = len(self.keys)
        h = _mix(self.v)
        self.full = np.zeros(n, np.uint64)
        np.add.at(self.full, row, h)
        # the list at f restricted to cells present at f + 1, and to cells present at f - 1
        fwd, bwd = np.zeros(n, np.uint64), np.zeros(n, np.uint64)
        np.add.at(fwd, row, np.where(self.present(self.f + 1, self.v), h, np.uint64(0)))
        np.add.at(bwd, row, np.where(self.present(self.f - 1, self.v), h, np.uint64(0)))
        consecutive = np.r_[False, (self.track[1:] == self.track[:-1]) & (self.frame[1:] == self.frame[:-1] + 1)]
        self.changed = consecutive & (np.r_[np.uint64(0), fwd[:-1]] != bwd)
        self.contact_key = row_keys(self.f, self.u)  # sorted: slices of one row's neighbours
        frame_ids, counts = np.unique(self.frame, return_counts=True)
        self.constant = len(set(counts.tolist())) <= 1 and all(
            np.array_equal(self.track[self.frame == frame_ids[0]], self.track[self.frame == g]) for g in frame_ids[1:])

    def present(self, frames, tracks):
        return lookup(self.keys, None, row_keys(frames, tracks)) >= 0

    def members(self, frame, track):
        """The neighbour set of ``track`` at ``frame``."""
        k = row_keys(np.int64(frame), np.int64(track))
        lo, hi = np.searchsorted(self.contact_key, [k, k + 1])
        return frozenset(self.v[lo:hi].tolist())


def _same_list(a, b, present_a, present_b):
    """Neighbour lists ``a`` (at one frame) and ``b`` (at another) agree on the cells present in both frames."""
    return a == b or all(c not in present_a or c not in present_b for c in a ^ b)


def _quartets(owner, v):
    """Every pair (c < d) of common neighbours per query: arrays (query, c, d)."""
    df = pd.DataFrame({"q": owner, "v": v})
    pairs = df.merge(df, on="q")
    pairs = pairs[pairs["v_x"] < pairs["v_y"]]
    return pairs["q"].to_numpy(np.int64), pairs["v_x"].to_numpy(np.int64), pairs["v_y"].to_numpy(np.int64)


def _cell_events(lists, lo, hi, population, last, censor):
    """Events of the cell of rows ``lo:hi``: (frame_start, frame_end or None, kind, n_lost, n_gained)."""
    frames_of = lists.frame[lo:hi].tolist()
    track = int(lists.track[lo])
    changes = np.flatnonzero(lists.changed[lo:hi]).tolist()
    if not changes:
        return []
    full = lists.full[lo:hi]
    out = []
    c = 0
    while c < len(changes):
        k = changes[c]
        prev, f = frames_of[k - 1], frames_of[k]
        before, after = lists.members(prev, track), lists.members(f, track)
        n_lost = sum(x in population(f) for x in before - after)
        n_gained = sum(x in population(prev) for x in after - before)
        back = None  # first later row whose list is the one left at `prev`, on the cells present at both
        if lists.constant:  # the same cells in every frame: the lists must be equal, and so their hashes
            same = np.flatnonzero(full[k + 1:] == full[k - 1])
            back = int(same[0]) + k + 1 if len(same) else None
        else:
            for j in range(k + 1, len(frames_of)):
                g = frames_of[j]
                if _same_list(lists.members(g, track), before, population(g), population(prev)):
                    back = j
                    break
        if back is not None:
            out.append((f, frames_of[back], "cycle", n_lost, n_gained))
            c = bisect.bisect_right(changes, back)
        else:
            out.append((f, None, "unresolved" if last - f < censor else "intercalation", n_lost, n_gained))
            c += 1
    return out


def neighbour_events(edges: pd.DataFrame, cells: pd.DataFrame, min_length: float = 0.0, censor: int = 10
                     ) -> pd.DataFrame:
    """Neighbour exchanges by the paper's per-cell definition: changes of each cell's list of neighbours. (reference)"""
    frames = cells["frame"].to_numpy(np.int64)
    tracks = track_ids(cells)
    lists = _Lists(track_contacts(edges, cells, min_length), frames, tracks)
    last = int(frames.max()) if len(frames) else 0
    by_frame = {}

    def population(frame):  # the cells present at a frame, as a set (built when first needed)
        if frame not in by_frame:
            by_frame[frame] = set(lists.track[lists.frame == frame].tolist())
        return by_frame[frame]

    rows = []
    bounds = np.flatnonzero(np.r_[True, lists.track[1:] != lists.track[:-1], True])
    with_changes = np.add.reduceat(lists.changed, bounds[:-1]) > 0 if len(lists.track) else np.zeros(0, bool)
    for lo, hi in zip(bounds[:-1][with_changes], bounds[1:][with_changes]):
        track = int(lists.track[lo])
        for start, end, kind, n_lost, n_gained in _cell_events(lists, lo, hi, population, last, censor):
            rows.append((track, kind, start, np.nan if end is None else float(end), n_lost, n_gained))
    out = pd.DataFrame(rows, columns=["track", "kind", "frame_start", "frame_end", "n_lost", "n_gained"])
    out = out.astype({"track": np.int64, "frame_start": np.int64, "frame_end": float, "n_lost": np.int64,
                      "n_gained": np.int64})
    out.insert(4, "duration", out["frame_end"] - out["frame_start"])
    out["kind"] = out["kind"].astype("string")
    at = pd.DataFrame({"frame": frames, "track": tracks, "x": cells["x"].to_numpy(float),
                       "y": cells["y"].to_numpy(float), "is_border": ~interior_mask(cells)})
    at = at.drop_duplicates(["frame", "track"])
    out = out.merge(at, left_on=["frame_start", "track"], right_on=["frame", "track"], how="left").drop(columns="frame")
    out = out.sort_values(["frame_start", "track"], ignore_index=True)
    out.insert(0, "event", np.arange(len(out), dtype=np.int64))
    return validate(out, "neighbour_events")


# ----------------------------------------------------------------------------
# References of the kernels in hexatissue.events._kernels (compared in tests/test_events.py)
# ----------------------------------------------------------------------------

def _t1_step_reference(prev, cur):
    """:func:`hexatissue.events._t1_step` in numpy (about 40 calls on a few hundred values); the quartets
    of each frame's ``flanks`` (its contacts, and the pairs held at four-fold vertices)."""
    new, gone = cur.keys[~in_sorted(cur.keys, prev.keys)], prev.keys[~in_sorted(prev.keys, cur.keys)]
    la, lb = np.divmod(gone, cur.K)  # losses: both cells still present; quartets of the frame before
    loss_ab, loss_cd = prev.flanks.quartets(gone[cur.is_present(la) & cur.is_present(lb)])
    ga, gb = np.divmod(new, cur.K)  # gains: both cells present before; quartets of this frame
    gain_cd, gain_ab = cur.flanks.quartets(new[prev.is_present(ga) & prev.is_present(gb)])
    return new, gone, loss_ab, loss_cd, gain_ab, gain_cd


def _undo_pairs_reference(undone):
    """:func:`hexatissue.events._kernels._undo_pairs` as a plain-Python fold (the test's reference)."""
    events, partner = [], False
    for k, undoes_next in enumerate(undone.tolist()):
        if partner:  # the inverse of the T1 before it: part of that cycle
            partner = False
            continue
        events.append((k, undoes_next))
        partner = undoes_next
    first, cycle = zip(*events) if events else ((), ())
    return np.array(first, np.int64), np.array(cycle, bool)


class _ListsReference(_FrameLists):
    """The plain-numpy reference of :class:`hexatissue.events._Lists`: the same lists, sorted and hashed in numpy."""

    def __init__(self, frame, tracks, a, b):
        self.frame, self.tracks = frame, tracks
        u, v = _directed(a, b)
        ok = in_sorted(u, tracks)  # a list belongs to a cell present in the frame
        self.u, self.v = u[ok], v[ok]
        self.row = np.searchsorted(tracks, self.u)
        self.h = _mix(self.v)
        self.full = self.restricted(None)


def _excursion_starts_reference(order, track, start, back):
    """:func:`hexatissue.events._kernels._excursion_starts` as a plain-Python fold (the test's reference)."""
    first, open_track, open_until = [], None, -1
    for i in order.tolist():
        if track[i] == open_track and start[i] <= open_until:
            continue  # inside the excursion of the cycle before it
        first.append(i)
        open_track, open_until = track[i], back[i]  # back -1 (not a cycle) covers nothing: frames are >= 0
    return np.array(first, np.int64)


class _ChangesReference(_ChangeLog):
    """The plain-numpy reference of :class:`hexatissue.events._Changes`: the open changes in arrays, about 60 numpy
    calls a frame."""

    def __init__(self, present_keys, top=None):
        super().__init__(present_keys)
        # row of each track id in the current frame (-1: absent), when the ids are few enough for a table:
        # the open changes (every intercalation stays open) are looked up at every frame
        self.slot = None if top is None else np.full(int(top) + 1, -1, np.int64)
        empty = np.zeros(0, np.int64)
        # open changes: index, cell, frame before the change, hash of the list left there
        self.index, self.track, self.prev_frame, self.ref = empty, empty, empty, np.zeros(0, np.uint64)
        self.owner, self.before = empty, empty  # the neighbours of that list not present in every frame

    def _rare(self, cells):
        """Which ``cells`` are not present in every frame."""
        return np.zeros(len(cells), bool) if self.always is None else ~in_sorted(cells, self.always)

    def _absent(self, frame, cells, lists):
        """Which ``cells`` (not present in every frame) are absent from ``lists``' frame or from ``frame``."""
        return ~(in_sorted(cells, lists.tracks) & in_sorted(row_keys(frame, cells), self.present_keys))

    def add(self, lists):
        self._close(lists)
        prev = self.prev
        self.prev = lists
        if prev is None or prev.frame != lists.frame - 1 or not len(prev.tracks):
            return
        at_prev = np.minimum(np.searchsorted(prev.tracks, lists.tracks), len(prev.tracks) - 1)
        both = prev.tracks[at_prev] == lists.tracks
        changed = both & (prev.restricted(lists.tracks)[at_prev] != lists.restricted(prev.tracks))
        track = lists.tracks[changed]
        if not len(track):
            return
        b_owner, rows = prev.neighbours(track)
        before = prev.v[rows]
        a_owner, rows = lists.neighbours(track)
        after = lists.v[rows]
        # lost: neighbours at f - 1 that are not at f but present at f; gained: the other way round
        lost = ~in_sorted(row_keys(b_owner, before), row_keys(a_owner, after)) & in_sorted(before, lists.tracks)
        gained = ~in_sorted(row_keys(a_owner, after), row_keys(b_owner, before)) & in_sorted(after, prev.tracks)
        m = len(track)
        self.found.append((track, np.full(m, lists.frame), np.bincount(b_owner[lost], minlength=m),
                           np.bincount(a_owner[gained], minlength=m)))
        rare = self._rare(before)
        self.owner = np.concatenate((self.owner, b_owner[rare] + len(self.track)))
        self.before = np.concatenate((self.before, before[rare]))
        self.index = np.concatenate((self.index, self.n + np.arange(m)))
        self.track = np.concatenate((self.track, track))
        self.prev_frame = np.concatenate((self.prev_frame, np.full(m, prev.frame)))
        self.ref = np.concatenate((self.ref, prev.full[at_prev[changed]]))
        self.n += m

    def _close(self, lists):
        """Close the open changes whose list is back at this frame."""
        m = len(self.track)
        if not m or not len(lists.tracks):
            return
        k, here = self._rows(lists)
        now, ref = lists.full[k], self.ref.copy()
        if self.always is not None:  # less the neighbours absent from either frame
            rare = np.flatnonzero(self._rare(lists.v))
            if len(rare):
                rare_u = lists.u[rare]
                rows, owner = _expand(np.searchsorted(rare_u, self.track, "left"),
                                      np.searchsorted(rare_u, self.track, "right"))
                rows = rare[rows]
                gone = self._absent(self.prev_frame[owner], lists.v[rows], lists)
                np.subtract.at(now, owner[gone], lists.h[rows[gone]])
            gone = self._absent(self.prev_frame[self.owner], self.before, lists)
            np.subtract.at(ref, self.owner[gone], _mix(self.before[gone]))
        done = here & (now == ref)
        if not done.any():
            return
        self.back.append((self.index[done], np.full(int(done.sum()), lists.frame)))
        kept = ~done
        new_pos = np.cumsum(kept) - 1
        rows = kept[self.owner]
        self.owner, self.before = new_pos[self.owner[rows]], self.before[rows]
        self.index, self.track = self.index[kept], self.track[kept]
        self.prev_frame, self.ref = self.prev_frame[kept], self.ref[kept]

    def _rows(self, lists):
        """Row in ``lists`` of each open change's cell (any row if absent) and whether it is there."""
        if self.slot is None:  # a binary search of every open change
            k = np.minimum(np.searchsorted(lists.tracks, self.track), len(lists.tracks) - 1)
            return k, lists.tracks[k] == self.track
        self.slot[lists.tracks] = np.arange(len(lists.tracks))
        k = self.slot[self.track]
        self.slot[lists.tracks] = -1
        return np.maximum(k, 0), k >= 0
