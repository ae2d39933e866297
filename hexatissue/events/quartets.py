"""Raw T1s: each frame's contact graph (:class:`_FrameGraph`), the quartets of a lost or gained contact, and
the pairing of losses with gains into one T1 each.
"""
from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd

from .._hashing import GOLDEN, mix64
from ..geometry import in_sorted
from ..schema import FrameRows
from ._kernels import _both_in, _lists_kernel, _quartet_kernel, _t1_kernel
from .classify import KERNELS
from .frames import _unique
from .pairing import _pair_losses_and_gains, _runs


def _quartet_keys(ids):
    """An order-free key of each row of four cell ids (``(n, 4)``): the sum of their 64-bit hashes."""
    with np.errstate(over="ignore"):
        return mix64(np.asarray(ids, np.int64).astype(np.uint64) + np.uint64(GOLDEN)).sum(axis=1, dtype=np.uint64)


def _vertex_quartets(held):
    """The :func:`_quartet_keys` of every four cells around one vertex of four or more cells, sorted (``held``: a
    frame's :func:`~hexatissue.events.frames._held_pairs` entry): what :func:`_find_t1` keeps of a frame's held
    vertices once its contacts are searched, to tell a vertex whose sides collapse in turn (8 bytes a four-fold
    vertex, not its pairs)."""
    group, cell = held[2], held[3]
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]]) if len(group) else np.zeros(0, np.int64)
    sizes = np.diff(np.r_[starts, len(group)])
    quartets = [cell[starts[sizes == 4, None] + np.arange(4)]]  # the four-fold vertices at once
    for start, size in zip(starts[sizes > 4].tolist(), sizes[sizes > 4].tolist()):  # the rarer higher ones
        quartets.append(cell[start + np.array(list(combinations(range(size), 4)))])
    return np.sort(_quartet_keys(np.concatenate(quartets)))


def _one_vertex(keys, quartets):
    """Whether each of the ``quartets`` (:func:`_quartet_keys`) is around one vertex of four or more cells, from a
    frame's :func:`_vertex_quartets` ``keys`` (None: the frame has none)."""
    if keys is None or not len(keys):
        return np.zeros(len(quartets), bool)
    return keys[np.minimum(np.searchsorted(keys, quartets), len(keys) - 1)] == quartets


def _expand(lo, hi):
    """Concatenated ranges ``lo[k]..hi[k]-1`` and the query index of each element."""
    count = hi - lo
    owner = np.repeat(np.arange(len(lo)), count)
    start = np.repeat(lo - (np.cumsum(count) - count), count)
    return np.arange(count.sum()) + start, owner


def _directed(a, b):
    """Both directions ``u -> v`` of the contacts ``a - b``, sorted by ``(u, v)``.

    One argsort of the key ``u * top + v`` when the ids are small non-negative
    integers (a third of a two-key lexsort's time); the values are the same
    either way, as each ``(u, v)`` has one value.
    """
    u, v = np.concatenate((a, b)), np.concatenate((b, a))
    if not len(u):
        return u, v
    top = int(max(u.max(), v.max())) + 1
    small = top < 2**31 and min(u.min(), v.min()) >= 0
    order = np.argsort(u * top + v) if small else np.lexsort((v, u))
    return u[order], v[order]


class _FrameGraph:
    """One frame's contacts and cells in compact ids: sorted pair keys ``a * K + b`` and adjacency.

    ``flanks``: the graph the quartet search looks at (:func:`_t1_step`), the
    contacts and the pairs held at four-fold vertices; the frame itself
    when none is held.
    """

    def __init__(self, present, a, b, K):
        self.present, self.K, self.flanks = present, K, self
        keys = np.minimum(a, b) * K + np.maximum(a, b)
        self.keys = _unique(keys)  # the contacts of _movie_frames come sorted and unique already
        lo, hi = np.divmod(self.keys, K)
        # both directions sorted by (u, v): the neighbour lists of the present cells (a kernel, no sort;
        # their hashes are not used) when they hold every contact, else a sort of them all
        if KERNELS.replaced("_lists_kernel"):  # the sort of them all, in numpy
            self.u, self.v = _directed(lo, hi)
            return
        self.u, self.v = _lists_kernel(present, lo, hi, np.uint64(GOLDEN))[:2]
        if len(self.v) != 2 * len(self.keys):
            self.u, self.v = _directed(lo, hi)

    def has_pair(self, a, b):
        return in_sorted(np.minimum(a, b) * self.K + np.maximum(a, b), self.keys)

    def is_present(self, cell):
        return in_sorted(cell, self.present)

    def quartets(self, pairs):
        """Each contact a-b of ``pairs`` with each pair c < d of common neighbours: arrays (pair, c * K + d)."""
        a, b = np.divmod(pairs, self.K)
        lo, hi = np.searchsorted(self.u, a, "left"), np.searchsorted(self.u, a, "right")
        idx, owner = _expand(lo, hi)
        v = self.v[idx]
        keep = (v != b[owner]) & self.has_pair(b[owner], v)
        q, c, d = _quartets(owner[keep], v[keep])
        return pairs[q], c * self.K + d


def _quartets(owner, v):
    """Every pair (c < d) of common neighbours per query (``owner`` sorted): arrays (query, c, d)."""
    starts = np.searchsorted(owner, owner, "left")
    idx, first = _expand(starts, np.searchsorted(owner, owner, "right"))  # each element with its group
    keep = v[first] < v[idx]
    return owner[first[keep]], v[first[keep]], v[idx[keep]]


def find_t1(contacts: pd.DataFrame, presence: pd.DataFrame) -> pd.DataFrame:
    """Raw T1s (one per neighbour exchange) from contacts and cell presence.

    Parameters
    ----------
    contacts : pandas.DataFrame
        ``frame``, ``a`` < ``b`` (track ids), e.g. from :func:`track_contacts`.
    presence : pandas.DataFrame
        ``frame``, ``track``: which cells exist in which frame.

    Returns
    -------
    pandas.DataFrame
        ``frame_lost`` (first frame without a-b), ``frame_gain`` (first frame
        with c-d), ``cell_a`` < ``cell_b`` (lose contact), ``cell_c`` <
        ``cell_d`` (gain contact), sorted by ``frame_lost``.  Frames are those
        of the input; consecutive means consecutive in the sorted list of
        frames present in ``presence``; contacts of other frames are ignored.
    """
    track = presence["track"].to_numpy(np.int64)
    a, b = contacts["a"].to_numpy(np.int64), contacts["b"].to_numpy(np.int64)
    contact_rows = FrameRows(contacts["frame"].to_numpy(np.int64))
    frames = ((frame, np.unique(track[rows]), a[contact_rows.rows(frame)], b[contact_rows.rows(frame)], None)
              for frame, rows in FrameRows(presence["frame"].to_numpy(np.int64)))
    return _find_t1(frames, np.unique(np.r_[track, a, b]))


def _find_t1(frames, ids, held=None):
    """:func:`find_t1` of a stream of frames ``(frame, tracks present, a, b, length)`` whose ids are all in ``ids``.

    One pass, two frames at a time: a contact lost between consecutive frames
    (its two cells still present) is a loss, with a quartet for each pair of
    common neighbours before; a contact gained (its cells present before) is
    a gain, with a quartet for each pair of common neighbours after; the runs
    of frames of every contact say which loss and gain were not interrupted.
    ``held`` (:func:`~hexatissue.events.frames._held_frames`, or the dict of
    :func:`~hexatissue.events.frames._held_pairs`): per frame, the pairs
    around four-fold vertices, which count as neighbours in the quartet
    search (not as contacts that are lost or gained); taken frame by frame
    as the frames come.  ``length`` (px, per contact, in the
    order of ``a``, ``b``; or None) breaks ties between candidate pairings
    (:func:`_pair_losses_and_gains`).
    """
    K = np.int64(len(ids) + 1)
    starts, stops, losses, gains, values, every_loss, lengths = [], [], [], [], [], [], []
    prev = None
    index = _index_of(ids)
    held = iter(sorted(held.items()) if isinstance(held, dict) else held or ())
    pending = next(held, None)
    vertex_keys = {}  # per frame with held vertices: its _vertex_quartets
    for i, (frame, tracks, a, b, length) in enumerate(frames):
        cur = _FrameGraph(index(tracks), index(a), index(b), K)
        # the contacts' lengths in the order of cur.keys (the contacts come sorted and unique, see _frames)
        cur.length = length if length is not None and len(length) == len(cur.keys) else None
        while pending is not None and pending[0] < frame:
            pending = next(held, None)
        if pending is not None and pending[0] == frame:
            ha, hb = pending[1][:2]
            cur.flanks = _FrameGraph(cur.present, index(np.r_[a, ha]), index(np.r_[b, hb]), K)
            vertex_keys[frame] = _vertex_quartets(pending[1])
        values.append(frame)
        if prev is None:
            starts.append((cur.keys, 0))
        else:
            new, gone, loss_ab, loss_cd, gain_ab, gain_cd = _t1_step(prev, cur)
            starts.append((new, i))
            stops.append((gone, i))
            losses.append((loss_ab, loss_cd, np.full(len(loss_ab), i), _flank_held(prev, loss_ab, loss_cd)))
            gains.append((gain_ab, gain_cd, np.full(len(gain_ab), i), _flank_held(cur, gain_ab, gain_cd)))
            # every loss, also one with no pair of common neighbours just before (its flanks changed in the
            # same frame): the quartet may be seen after the gain only
            lost = gone[cur.is_present(gone // K) & cur.is_present(gone % K)]
            every_loss.append((lost, np.full(len(lost), i)))
            if prev.length is not None and cur.length is not None:  # the lost contacts' last and the new ones' first
                lengths.append((np.r_[gone, new], np.full(len(gone) + len(new), i),  # length
                                np.r_[prev.length[np.searchsorted(prev.keys, gone)],
                                      cur.length[np.searchsorted(cur.keys, new)]]))
        prev = cur
    empty = pd.DataFrame({c: np.empty(0, np.int64) for c in
                          ("frame_lost", "frame_gain", "cell_a", "cell_b", "cell_c", "cell_d")})
    if len(values) < 2 or not sum(len(k) for k, _ in starts):
        return empty
    stops.append((prev.keys, len(values)))
    runs = _runs(starts, stops)
    losses = pd.DataFrame(dict(zip(("ab", "cd", "frame_lost", "held"), (np.concatenate(c) for c in zip(*losses)))))
    gains = pd.DataFrame(dict(zip(("ab", "cd", "frame_gain", "held"), (np.concatenate(c) for c in zip(*gains)))))
    losses = losses.merge(runs[["pair", "stop", "next_start"]], left_on=["ab", "frame_lost"],
                          right_on=["pair", "stop"]).drop(columns=["pair", "stop"]).rename(columns={"next_start": "next_ab"})
    gains = gains.merge(runs[["pair", "start", "prev_stop"]], left_on=["cd", "frame_gain"],
                        right_on=["pair", "start"]).drop(columns=["pair", "start"]).rename(columns={"prev_stop": "prev_cd"})
    lost = pd.DataFrame(dict(zip(("ab", "frame_lost"), (np.concatenate(c) for c in zip(*every_loss)))))
    lost = lost.merge(runs[["pair", "stop", "next_start"]], left_on=["ab", "frame_lost"], right_on=["pair", "stop"])
    lost = lost[["ab", "frame_lost", "next_start"]].rename(columns={"next_start": "next_ab"})
    if gains.empty or lost.empty:
        return empty
    if lengths:
        lengths = pd.DataFrame(dict(zip(("pair", "frame", "length"), (np.concatenate(c) for c in zip(*lengths)))))
    m = _pair_losses_and_gains(losses, gains, lost, lengths if len(lengths) else None)
    values = np.asarray(values, np.int64)
    if vertex_keys:  # a four-fold vertex's sides collapsing in turn: its four cells around it before the loss and after
        quartet = _quartet_keys(np.stack([ids[m["ab"] // K], ids[m["ab"] % K], ids[m["cd"] // K], ids[m["cd"] % K]],
                                         axis=1))  # the gain
        before, after = values[m["frame_lost"].to_numpy(np.int64) - 1], values[m["frame_gain"].to_numpy(np.int64)]
        around = np.zeros((2, len(m)), bool)
        for side, frame in enumerate((before, after)):
            for f in np.unique(frame).tolist():
                at = np.flatnonzero(frame == f)
                around[side, at] = _one_vertex(vertex_keys.get(f), quartet[at])
        m = m[~(around[0] & around[1])]
    ab, cd = m["ab"].to_numpy(np.int64), m["cd"].to_numpy(np.int64)
    out = pd.DataFrame({
        "frame_lost": values[m["frame_lost"].to_numpy(np.int64)],
        "frame_gain": values[m["frame_gain"].to_numpy(np.int64)],
        "cell_a": ids[ab // K], "cell_b": ids[ab % K], "cell_c": ids[cd // K], "cell_d": ids[cd % K],
    })
    return out.sort_values(["frame_lost", "cell_a", "cell_b", "cell_c", "cell_d"], ignore_index=True)


def _flank_held(graph, ab, cd):
    """Per quartet (contact keys ``ab``, ``cd``) of a :class:`_FrameGraph`: whether a flank of it is held
    at a four-fold vertex rather than a contact of the frame."""
    K = graph.K
    a, b, c, d = ab // K, ab % K, cd // K, cd % K
    return ~(graph.has_pair(a, c) & graph.has_pair(a, d) & graph.has_pair(b, c) & graph.has_pair(b, d))


def _t1_step(prev, cur):
    """What :func:`_find_t1` takes from two consecutive frames (:class:`_FrameGraph`), in numba kernels.

    Returns ``new``, ``gone`` (contact keys gained and lost), ``loss_ab``, ``loss_cd`` (each contact lost
    whose cells are both still present, with each pair of its common neighbours before) and ``gain_ab``,
    ``gain_cd`` (each pair of common neighbours of each contact gained whose cells were both present
    before, with that contact).  Neighbours are those of each frame's ``flanks`` (held four-fold vertices
    included); the kernel's own quartets are those of the contacts, taken when no pair is held.
    :func:`hexatissue.events._reference._t1_step_reference` is the same in numpy.
    """
    reference = KERNELS.replacement("_t1_kernel", "_t1_step_reference")
    if reference is not None:
        return reference(prev, cur)
    new, gone, loss_ab, loss_cd, gain_ab, gain_cd = _t1_kernel(prev.keys, prev.u, prev.v, prev.present, cur.keys,
                                                               cur.u, cur.v, cur.present, cur.K)
    if prev.flanks is not prev:  # the flanks of the losses, held four-fold vertices included
        loss_ab, loss_cd = _quartet_kernel(gone[_both_in(gone, cur.present, cur.K)], prev.flanks.keys,
                                           prev.flanks.u, prev.flanks.v, cur.K)
    if cur.flanks is not cur:  # and of the gains
        gain_cd, gain_ab = _quartet_kernel(new[_both_in(new, prev.present, cur.K)], cur.flanks.keys,
                                           cur.flanks.u, cur.flanks.v, cur.K)
    return new, gone, loss_ab, loss_cd, gain_ab, gain_cd


def _index_of(ids):
    """The function giving the position in the sorted ``ids`` of values that are among them.

    A table over the ids when it is small enough (:func:`_table_fits`): a
    gather instead of a binary search of every contact at every frame.
    """
    if not len(ids) or ids[0] < 0 or not _table_fits(int(ids[-1]), len(ids)):
        return lambda values: np.searchsorted(ids, values)
    table = np.zeros(int(ids[-1]) + 1, np.int64)
    table[ids] = np.arange(len(ids))
    return table.__getitem__


#: :class:`_Changes` (and its reference) and :func:`_index_of` find cells by a table over the track ids when
#: the largest id is below this many times the ids (plus 65,536): the table is then no larger than a few
#: columns of the cells table (:func:`_table_fits`).
SLOT_TABLE_ROWS = 4


def _table_fits(top, n):
    """Whether a lookup table over ids 0..``top`` is small enough for ``n`` ids (:data:`SLOT_TABLE_ROWS`)."""
    return top < SLOT_TABLE_ROWS * n + 2**16
