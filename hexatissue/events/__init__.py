"""T1 events from neighbour-graph changes, classified as cycles, intercalations or unresolved.

A **T1** is a neighbour exchange in a quartet of cells: cells ``a`` and
``b`` lose their shared junction and cells ``c`` and ``d`` gain one, where
``c`` and ``d`` were common neighbours of ``a`` and ``b`` before or ``a``
and ``b`` are common neighbours of ``c`` and ``d`` after (either: two T1s on
junctions that share a vertex, in one frame, each see their quartet on one
side only).  The intermediate four-fold vertex may persist: a-b is lost at
frame ``t1`` and c-d gained at ``t2 >= t1``, with neither contact present in
between.  Every loss and every gain is one T1 at most.

Classification per quartet, in time order:

- ``cycle``: the T1 is later undone by the inverse T1 on the same quartet
  (c-d lost, a-b regained); ``frame_end`` is the first frame a-b touch again
  and ``duration = frame_end - frame_start``.
- ``intercalation``: never undone before the end of the movie.
- ``unresolved``: not undone, but it started fewer than ``censor`` frames
  before the last frame, so the movie is too short to tell (right-censored).
  Leave these out of rate and lifetime statistics.  By default ``censor``
  comes from the movie's length (:func:`default_censor`).

Contacts that appear or disappear because a cell enters, leaves, divides or
dies (a cell absent in one of the two frames) are not T1s; contacts with
cell 0 (outside the tissue) are not cell contacts.  Cell ids are track ids.
Positions follow the package convention: ``x`` = column, ``y`` = row, px,
origin at the centre of pixel (0, 0).
"""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from .._hashing import GOLDEN, mix64
from .._system import release_freed_memory
from ..box import Box
from ..errors import HexatissueWarning, InputError, is_real, user_stacklevel
from ..geometry import in_sorted, lookup, row_keys
from ..graph import pair_groups
from ..schema import FrameRows, deprecated_column_lists, interior_mask, string_column, track_ids, validate
from . import _kernels
from ._kernels import _both_in, _change_kernel, _close_kernel, _lists_kernel, _quartet_kernel, _t1_kernel
from .._dispatch import Kernels

__all__ = ["detect_t1", "neighbour_events", "t1_tables", "default_censor", "CENSOR_MAX", "CENSOR_DIVISOR", "classify_t1",
           "find_t1", "track_contacts", "cell_event_stats", "intercalation_intervals", "events_summary"]

# the kernels, or their references (:mod:`hexatissue._dispatch`); not ``K``, which names the key base here
KERNELS = Kernels(_kernels, "hexatissue.events._reference", names={"_undo_pairs": "_undo_pairs_reference",
                                                                  "_excursion_starts": "_excursion_starts_reference"})

#: The ``kind`` of a T1 (quartet or per-cell event); tables are built from codes, its indices.
T1_KINDS = ("cycle", "intercalation", "unresolved")
CYCLE, INTERCALATION, UNRESOLVED = range(3)

#: Longest default censoring window, frames (enough for most T1 cycles of MPF runs, see docs/t1.md).
CENSOR_MAX = 10
#: The default censoring window is at most a fifth of the movie (``n_frames // CENSOR_DIVISOR``).
CENSOR_DIVISOR = 5


def default_censor(n_frames) -> int:
    """Censoring window used when none is given: ``min(10, max(1, n_frames // 5))`` frames.

    Long movies get :data:`CENSOR_MAX` (10) frames; a short one keeps four
    fifths of its frames classifiable (11 frames -> 2, 10 -> 2, 301 -> 10),
    and never less than 1: a T1 in the last frame cannot be classified.

    Parameters
    ----------
    n_frames : int
        Frames of the movie.

    Returns
    -------
    int
        Frames.
    """
    if isinstance(n_frames, bool) or int(n_frames) != n_frames or n_frames < 0:
        raise InputError(f"n_frames must be a non-negative integer; got {n_frames!r}")
    return min(CENSOR_MAX, max(1, int(n_frames) // CENSOR_DIVISOR))


def track_contacts(edges: pd.DataFrame, cells: pd.DataFrame | None = None, min_length: float = 0.0) -> pd.DataFrame:
    """Cell-cell contacts per frame, in track ids.

    Parameters
    ----------
    edges : pandas.DataFrame
        ``frame``, ``cell_a``, ``cell_b``, ``length`` (px); several junctions
        between the same two cells are summed.
    cells : pandas.DataFrame, optional
        ``frame``, ``cell`` and ``track``: label ids are translated to track ids.
        Without it (or without ``track``) label ids are track ids.
    min_length : float
        A contact whose total junction length is below ``min_length`` px is
        treated as a four-fold vertex, i.e. not a contact.  0 keeps every junction.

    Returns
    -------
    pandas.DataFrame
        ``frame``, ``a`` < ``b`` (track ids, both > 0), ``length`` (px), sorted.
    """
    if cells is None or "track" not in cells.columns:  # label ids are track ids: every frame of the edges
        frames = edges["frame"].to_numpy(np.int64) if "frame" in edges.columns else np.zeros(0, np.int64)
        cells = pd.DataFrame({"frame": np.unique(frames), "cell": np.int64(0)})
    parts = [(np.full(len(a), frame, np.int64), a, b, length)
             for frame, _, a, b, length in _movie_frames(edges, cells, min_length)]
    frame, a, b, length = (np.concatenate(c) for c in zip(*parts)) if parts else (np.zeros(0, np.int64),) * 4
    return pd.DataFrame({"frame": frame, "a": a, "b": b, "length": length.astype(float)})


#: Cell rows handled at once by the movie-level stages (whole frames): about 0.8 kB of temporaries per row.
BLOCK_ROWS = 1 << 14


def _movie_frames(edges, cells, min_length):
    """Each frame of ``cells`` in turn: ``(frame, tracks, a, b, length)``.

    ``tracks``: the track ids present (sorted, unique); ``a`` < ``b``: its contacts
    in track ids, sorted, with their summed junction ``length`` (px).  The
    contacts exist one block of about ``BLOCK_ROWS`` cell rows at a time: the
    movie-level stages stream the movie instead of holding every contact of
    it (three per cell-frame).
    """
    for col in ("frame", "cell_a", "cell_b", "length"):
        if col not in edges.columns:
            raise InputError(f"edges table is missing column {col!r}; expected frame, cell_a, cell_b, length")
    if not is_real(min_length) or min_length < 0:
        raise InputError(f"min_length must be a finite length >= 0 px; got {min_length!r}")
    cell_rows, edge_rows = FrameRows(cells["frame"].to_numpy(np.int64)), FrameRows(edges["frame"].to_numpy(np.int64))
    translate = "track" in cells.columns
    if translate and len(np.setdiff1d(edge_rows.frames, cell_rows.frames)):
        raise InputError(MISSING_CELLS)
    return _frames(edges, cells, min_length, cell_rows, edge_rows, translate)


#: Edges whose cells the cells table does not have.
MISSING_CELLS = "edges refer to (frame, cell) pairs missing from the cells table"


def _frames(edges, cells, min_length, cell_rows, edge_rows, translate):
    """The generator of :func:`_movie_frames` (its arguments checked): contacts found a block of frames at a time."""
    tracks = track_ids(cells)
    labels = cells["cell"].to_numpy(np.int64) if translate else None
    c_frame = cells["frame"].to_numpy(np.int64)
    e_frame = edges["frame"].to_numpy(np.int64)
    e_a, e_b = edges["cell_a"].to_numpy(np.int64), edges["cell_b"].to_numpy(np.int64)
    e_length = edges["length"].to_numpy(float)
    for frames, rows in cell_rows.blocks(BLOCK_ROWS):
        er = edge_rows.between(frames[0], frames[-1])
        frame, a, b, length = e_frame[er], e_a[er], e_b[er], e_length[er]
        keep = a != 0  # contacts with the outside are not cell contacts
        frame, a, b, length = frame[keep], a[keep], b[keep], length[keep]
        order, starts = pair_groups(frame, a, b)
        first = order[starts]
        frame, a, b = frame[first], a[first], b[first]
        length = np.add.reduceat(length[order], starts) if len(starts) else np.zeros(0)
        if min_length > 0:
            keep = length >= min_length
            frame, a, b, length = frame[keep], a[keep], b[keep], length[keep]
        here = c_frame[rows]
        if labels is not None:  # label ids -> track ids
            keys, track = row_keys(here, labels[rows]), tracks[rows]
            a = lookup(keys, track, row_keys(frame, a), MISSING_CELLS)
            b = lookup(keys, track, row_keys(frame, b), MISSING_CELLS)
            a, b = np.minimum(a, b), np.maximum(a, b)
            if not _increasing(frame, a, b):  # track ids need not keep the label order (they do when ids are kept)
                order = np.lexsort((b, a, frame))
                frame, a, b, length = frame[order], a[order], b[order], length[order]
        present = _unique(row_keys(here, tracks[rows]))
        p_bounds = np.searchsorted(present, row_keys(frames, 0))
        c_bounds = np.searchsorted(frame, frames)
        ids = present - row_keys(np.repeat(frames, np.diff(np.append(p_bounds, len(present)))), 0)
        for k, f in enumerate(frames.tolist()):
            lo, hi = c_bounds[k], c_bounds[k + 1] if k + 1 < len(frames) else len(frame)
            p_hi = p_bounds[k + 1] if k + 1 < len(frames) else len(present)
            yield f, ids[p_bounds[k]:p_hi], a[lo:hi], b[lo:hi], length[lo:hi]


def _held_pairs(edges, cells):
    """Per frame, the pairs of cells around each vertex of four or more cells, and those vertices' cells.

    ``{frame: (a, b, vertex, cell)}``: the pairs ``a`` < ``b`` and, per vertex
    of four or more cells (numbered ``vertex``), its cells (all track ids).

    A four-fold vertex holds a contact (a junction shorter than
    ``merge_distance``, contracted) between one of its two diagonal pairs:
    the contacts table has neither, and a T1 whose flanking contact is held
    so has no quartet of contacts on either side.  These pairs complete the
    flanks the quartet search looks at (:func:`_find_t1`).  Empty when the
    edges have no ``vertex_a``, ``vertex_b``.
    """
    if not {"vertex_a", "vertex_b"} <= set(edges.columns) or len(edges) == 0:
        return {}
    columns = [edges[c].to_numpy(np.int64) for c in ("frame", "vertex_a", "vertex_b", "cell_a", "cell_b")]
    tracks = None
    if "track" in cells.columns:
        tracks = (row_keys(cells["frame"].to_numpy(np.int64), cells["cell"].to_numpy(np.int64)), track_ids(cells))
    out = {}
    for _, rows in FrameRows(columns[0]).blocks(3 * BLOCK_ROWS):  # a block of frames at a time: the movie's
        out.update(_held_block(*(c[rows] for c in columns), tracks))  # edges four times over would not stream
    return out


def _held_block(frame, vertex_a, vertex_b, cell_a, cell_b, tracks):
    """:func:`_held_pairs` of the edges of a few whole frames; ``tracks``: (row keys, track ids) of the cells."""
    frame = np.tile(frame, 4)
    vertex = np.concatenate([vertex_a, vertex_a, vertex_b, vertex_b])  # each end with each side's cell
    cell = np.tile(np.concatenate([cell_a, cell_b]), 2)
    keep = cell > 0
    frame, vertex, cell = frame[keep], vertex[keep], cell[keep]
    order, starts = pair_groups(frame, vertex, cell)
    first = order[starts]  # each (frame, vertex, cell) once, sorted by frame, vertex, cell
    frame, vertex, cell = frame[first], vertex[first], cell[first]
    group = np.r_[True, (frame[1:] != frame[:-1]) | (vertex[1:] != vertex[:-1])].cumsum() - 1
    big = np.bincount(group)[group] >= 4
    frame, group, cell = frame[big], group[big], cell[big]
    if not len(cell):
        return {}
    if tracks is not None:
        cell = lookup(tracks[0], tracks[1], row_keys(frame, cell), MISSING_CELLS)
    later = np.searchsorted(group, group, "right") - np.arange(len(group)) - 1  # each cell with the later ones
    i = np.repeat(np.arange(len(group)), later)
    j = np.arange(later.sum()) - np.repeat(np.cumsum(later) - later, later) + i + 1
    a, b = np.minimum(cell[i], cell[j]), np.maximum(cell[i], cell[j])
    pair_bounds = {int(v): (lo, hi) for v, lo, hi in zip(*_frame_bounds(frame[i]))}
    out = {}
    for value, lo, hi in zip(*_frame_bounds(frame)):
        p0, p1 = pair_bounds[int(value)]
        out[int(value)] = (a[p0:p1], b[p0:p1], group[lo:hi], cell[lo:hi])
    return out


def _one_vertex(held, cells):
    """Whether the ``cells`` are all around one vertex of four or more cells (``held``: a frame's
    :func:`_held_pairs` entry, or None)."""
    if held is None:
        return False
    group, cell = held[2], held[3]
    common = None
    for c in cells:
        around = set(group[cell == c].tolist())
        common = around if common is None else common & around
        if not common:
            return False
    return True


def _frame_bounds(frame):
    """The distinct values of the sorted ``frame`` and where each run starts and ends."""
    starts = np.flatnonzero(np.r_[True, frame[1:] != frame[:-1]])
    return frame[starts], starts, np.r_[starts[1:], len(frame)]


def _unique(values):
    """``np.unique(values)``, without its sort (a hash unique) when ``values`` are strictly increasing already."""
    return values if len(values) < 2 or bool(np.all(values[1:] > values[:-1])) else np.unique(values)


def _increasing(frame, a, b):
    """Whether the rows ``(frame, a, b)`` are in strictly increasing lexicographic order (a lexsort keeps them)."""
    df, da, db = np.diff(frame), np.diff(a), np.diff(b)
    return bool(np.all((df > 0) | ((df == 0) & ((da > 0) | ((da == 0) & (db > 0))))))


def _ids(edges, cells):
    """Every track id a movie's contacts can name, sorted: those of ``cells`` (label ids of the edges too
    when ``cells`` has no ``track``)."""
    tracks = track_ids(cells)
    if "track" in cells.columns:
        return np.unique(tracks)
    return np.unique(np.r_[tracks, edges["cell_a"].to_numpy(np.int64), edges["cell_b"].to_numpy(np.int64)])


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
    ``held`` (:func:`_held_pairs`): per frame, the pairs around four-fold
    vertices, which count as neighbours in the quartet search (not as
    contacts that are lost or gained).  ``length`` (px, per contact, in the
    order of ``a``, ``b``; or None) breaks ties between candidate pairings
    (:func:`_pair_losses_and_gains`).
    """
    K = np.int64(len(ids) + 1)
    starts, stops, losses, gains, values, every_loss, lengths = [], [], [], [], [], [], []
    prev = None
    index = _index_of(ids)
    held = {} if held is None else held
    for i, (frame, tracks, a, b, length) in enumerate(frames):
        cur = _FrameGraph(index(tracks), index(a), index(b), K)
        # the contacts' lengths in the order of cur.keys (the contacts come sorted and unique, see _frames)
        cur.length = length if length is not None and len(length) == len(cur.keys) else None
        if frame in held:
            ha, hb = held[frame][:2]
            cur.flanks = _FrameGraph(cur.present, index(np.r_[a, ha]), index(np.r_[b, hb]), K)
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
    if held:  # a four-fold vertex's sides collapsing in turn: its four cells around it before the loss and after the gain
        quartet = np.stack([ids[m["ab"] // K], ids[m["ab"] % K], ids[m["cd"] // K], ids[m["cd"] % K]], axis=1)
        before, after = values[m["frame_lost"].to_numpy(np.int64) - 1], values[m["frame_gain"].to_numpy(np.int64)]
        m = m[np.array([not (_one_vertex(held.get(int(f0)), q) and _one_vertex(held.get(int(f1)), q))
                        for q, f0, f1 in zip(quartet.tolist(), before.tolist(), after.tolist())], bool)]
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


def _pair_losses_and_gains(losses, gains, lost, lengths=None):
    """The T1s of a movie's losses and gains: rows ``ab``, ``cd``, ``frame_lost``, ``frame_gain``.

    ``losses``: each contact a-b lost (``frame_lost``, ``next_ab`` the start
    of its next run) with each pair c-d of common neighbours just before;
    ``gains``: each contact c-d gained (``frame_gain``, ``prev_cd`` the stop
    of its previous run) with each pair a-b of common neighbours just after;
    ``lost``: every loss (``ab``, ``frame_lost``, ``next_ab``), also one with
    fewer than two common neighbours just before (its flanks changed in the
    same frame, a T1 next to a T1), whose quartet only the gain sees.  A gain
    with no quartet after it is never paired: c-d not flanked by a and b is
    not the junction that replaced a-b.
    A loss of a-b and a later (or simultaneous) gain of c-d are one T1 when
    neither contact touched in between (a four-fold vertex at most) and the
    quartet is seen on **either** side: c-d flanked a-b before the loss, or
    a-b flank c-d after the gain.  Requiring both sides loses T1s next to
    T1s: when two junctions that share a vertex swap in the same frame (or
    while the first one's four-fold vertex is held), the first T1's cells
    a, b are no longer both neighbours of c, d after the second, and the
    second's c, d did not both flank its a-b before the first.  Every loss
    and every gain is one T1 at most, matched greedily: quartets seen on both
    sides first, then quartets seen with contacts for flanks (``held``: a
    flank held at a four-fold vertex on every side it is seen from), then
    the shortest wait from loss to gain, then the earliest gain, then the
    shortest junctions (``lengths``: ``pair``, ``frame``, ``length``, the
    lost contact's length before its loss plus the new one's at its gain;
    a T1's junction shrinks to nothing and grows from it), so that two
    losses of one rosette seeing the same gain are told apart by the
    geometry (:func:`_match_once`).  The ids come last: the pairing does not
    depend on how the cells are numbered wherever the geometry decides.
    """
    keys = ["ab", "cd", "frame_lost", "next_ab", "frame_gain", "prev_cd", "held"]
    gained = gains.drop_duplicates(["cd", "frame_gain"])[["cd", "frame_gain", "prev_cd"]]
    # quartets seen before a loss, with every gain of their c-d; quartets seen after a gain, with every loss of a-b
    m = pd.concat([losses.merge(gained, on="cd")[keys], gains.merge(lost, on="ab")[keys]], ignore_index=True)
    m = m[(m["frame_gain"] >= m["frame_lost"]) & (m["next_ab"] > m["frame_gain"]) & (m["prev_cd"] <= m["frame_lost"])]
    m = m.groupby(["ab", "cd", "frame_lost", "frame_gain"], as_index=False, sort=False).agg(
        size=("held", "size"), held=("held", "min"))
    m = m.assign(wait=m["frame_gain"] - m["frame_lost"], one_side=m["size"] == 1, length=np.inf)
    if lengths is not None and len(m):
        at = pd.MultiIndex.from_arrays([lengths["pair"], lengths["frame"]])
        length = pd.Series(lengths["length"].to_numpy(float), index=at)
        before = length.reindex(pd.MultiIndex.from_arrays([m["ab"], m["frame_lost"]])).to_numpy(float)
        after = length.reindex(pd.MultiIndex.from_arrays([m["cd"], m["frame_gain"]])).to_numpy(float)
        m["length"] = np.nan_to_num(before + after, nan=np.inf)
    m = m.sort_values(["one_side", "held", "wait", "frame_gain", "length", "ab", "cd"], kind="stable",
                      ignore_index=True)
    return m[_match_once(m["ab"].to_numpy(np.int64), m["frame_lost"].to_numpy(np.int64),
                         m["cd"].to_numpy(np.int64), m["frame_gain"].to_numpy(np.int64))]


def _match_once(ab, lost, cd, gain):
    """Greedy matching in the given order: row k is kept unless its loss ``(ab, lost)`` or its gain
    ``(cd, gain)`` is in a row kept before it."""
    keep = np.zeros(len(ab), bool)
    used_loss, used_gain = set(), set()
    for k, (loss, won) in enumerate(zip(zip(ab.tolist(), lost.tolist()), zip(cd.tolist(), gain.tolist()))):
        if loss not in used_loss and won not in used_gain:
            keep[k] = True
            used_loss.add(loss)
            used_gain.add(won)
    return keep


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


def _runs(starts, stops):
    """Runs of consecutive frames of each contact: ``pair``, ``start``, ``stop`` (first frame without it),
    ``next_start`` (of its next run, or a frame past every frame) and ``prev_stop`` (of its previous run, or -1)."""
    def ordered(parts):
        key = np.concatenate([k for k, _ in parts])
        frame = np.concatenate([np.full(len(k), i, np.int64) for k, i in parts])
        order = np.lexsort((frame, key))
        return key[order], frame[order]

    pair, start = ordered(starts)
    _, stop = ordered(stops)  # a contact's runs alternate start, stop: the k-th stop ends the k-th start's run
    same_next = np.r_[pair[1:] == pair[:-1], False]
    same_prev = np.r_[False, pair[1:] == pair[:-1]]
    return pd.DataFrame({"pair": pair, "start": start, "stop": stop,
                         "next_start": np.where(same_next, np.r_[start[1:], 0], np.iinfo(np.int64).max),
                         "prev_stop": np.where(same_prev, np.r_[0, stop[:-1]], -1)})


def classify_t1(t1: pd.DataFrame, last_frame: int, censor: int = 10) -> pd.DataFrame:
    """Pair each T1 with its inverse on the same quartet: cycles, intercalations, unresolved.

    Parameters
    ----------
    t1 : pandas.DataFrame
        Output of :func:`find_t1`.
    last_frame : int
        Last frame of the movie.
    censor : int
        A T1 not undone whose ``frame_start`` is fewer than ``censor`` frames
        before ``last_frame`` is ``unresolved`` instead of ``intercalation``.

    Returns
    -------
    pandas.DataFrame
        ``kind``, ``frame_start``, ``frame_end``, ``duration``, ``cell_a``..``cell_d``,
        ``frame_gain``, ``frame_undo`` (see ``hexatissue.schema.TABLES["events"]``).
    """
    _check_censor(censor)
    df = t1.copy()
    K = np.int64(max([int(df[c].max()) if len(df) else 0 for c in ("cell_a", "cell_b", "cell_c", "cell_d")]) + 1)
    ab = df["cell_a"].to_numpy(np.int64) * K + df["cell_b"].to_numpy(np.int64)
    cd = df["cell_c"].to_numpy(np.int64) * K + df["cell_d"].to_numpy(np.int64)
    # the unordered quartet {a-b, c-d} is the key pairing a T1 with its inverse
    df["q_lo"], df["q_hi"] = np.minimum(ab, cd), np.maximum(ab, cd)
    df = df.sort_values(["q_lo", "q_hi", "frame_lost"], kind="stable").reset_index(drop=True)
    cells = {c: df[c].to_numpy(np.int64) for c in ("cell_a", "cell_b", "cell_c", "cell_d")}
    lost, gain = df["frame_lost"].to_numpy(np.int64), df["frame_gain"].to_numpy(np.int64)
    q_lo, q_hi = df["q_lo"].to_numpy(), df["q_hi"].to_numpy()
    # T1 k is undone by T1 k + 1: the same quartet, the contact lost by k + 1 the one k gained
    undone = np.zeros(len(lost), bool)
    undone[:-1] = (q_lo[1:] == q_lo[:-1]) & (q_hi[1:] == q_hi[:-1]) & (cells["cell_a"][1:] == cells["cell_c"][:-1]) \
        & (cells["cell_b"][1:] == cells["cell_d"][:-1])
    first, cycle = KERNELS._undo_pairs(undone)
    kind = _kind_codes(cycle, lost[first], last_frame, censor)
    undo = np.minimum(first + 1, len(lost) - 1)  # the inverse T1 of a cycle (clipped where there is none)
    end, undo_at = np.where(cycle, gain[undo], np.nan), np.where(cycle, lost[undo], np.nan)
    order = np.lexsort((cells["cell_b"][first], cells["cell_a"][first], lost[first]))  # as sort_values: stable
    first, kind, end, undo_at = first[order], kind[order], end[order], undo_at[order]
    return pd.DataFrame({"kind": string_column(kind, T1_KINDS), "frame_start": lost[first], "frame_end": end,
                         "duration": end - lost[first], **{c: v[first] for c, v in cells.items()},
                         "frame_gain": gain[first], "frame_undo": undo_at})


def _kind_codes(cycle, start, last_frame, censor):
    """:data:`T1_KINDS` codes: a cycle, else unresolved when it started fewer than ``censor`` frames before the end."""
    return np.where(cycle, CYCLE, np.where(last_frame - start < censor, UNRESOLVED, INTERCALATION)).astype(np.int8)


def _rows_at(cells, by_frame, frame, track):
    """Row of ``cells`` of each (``frame``, ``track``), the first if several, -1 if none; a block of frames at a time."""
    out = np.full(len(frame), -1, np.int64)
    order = np.argsort(frame, kind="stable")
    wanted = frame[order]
    c_frame, c_track = cells["frame"].to_numpy(np.int64), track_ids(cells)
    for frames, rows in by_frame.blocks(BLOCK_ROWS):
        lo, hi = np.searchsorted(wanted, [frames[0], frames[-1] + 1])
        if lo == hi:
            continue
        rows = np.arange(rows.start, rows.stop) if isinstance(rows, slice) else rows
        sel = order[lo:hi]
        pos = lookup(row_keys(c_frame[rows], c_track[rows]), None, row_keys(frame[sel], track[sel]))
        out[sel] = np.where(pos >= 0, rows[np.maximum(pos, 0)], -1)
    return out


def _centre(xy, box):
    """Mean of each row's points ``xy`` (rows x points x 2, NaN = missing), minimum-image in a periodic ``box``."""
    if box is not None:
        xy = xy[:, :1] + box.min_image(xy - xy[:, :1])
        return box.wrap(np.nanmean(xy, axis=1))
    return np.nanmean(xy, axis=1)


def _positions(events, cells, box):
    """Quartet centre (x, y) and border flag at frame_start, from the cells table."""
    if events.empty:
        return np.empty(0), np.empty(0), np.empty(0, bool)
    border = ~interior_mask(cells)
    x, y = cells["x"].to_numpy(float), cells["y"].to_numpy(float)
    quartet = ("cell_a", "cell_b", "cell_c", "cell_d")
    frame = np.tile(events["frame_start"].to_numpy(np.int64), 4)
    row = _rows_at(cells, FrameRows(cells["frame"].to_numpy(np.int64)), frame,
                   np.concatenate([events[c].to_numpy(np.int64) for c in quartet])).reshape(4, -1).T
    at = np.maximum(row, 0)
    xy = np.where(row[..., None] >= 0, np.stack([x[at], y[at]], axis=-1), np.nan)  # event, cell, (x, y)
    flag = ((row >= 0) & border[at]).any(axis=1)
    centre = _centre(xy, box)
    return centre[:, 0], centre[:, 1], flag


def _events_table(raw, cells, box, censor):
    """The ``events`` table of the raw T1s of :func:`find_t1`: classified, placed, numbered."""
    events = classify_t1(raw, int(cells["frame"].max()) if len(cells) else 0, censor)
    x, y, border = _positions(events, cells, box)
    events.insert(8, "x", x)
    events.insert(9, "y", y)
    events["is_border"] = border
    events.insert(0, "event", np.arange(len(events), dtype=np.int64))
    return validate(events, "events")


def detect_t1(edges: pd.DataFrame, cells: pd.DataFrame, min_length: float = 0.0, censor: int | None = None,
              box: Box | None = None) -> pd.DataFrame:
    """T1 events of a movie, classified as ``cycle``, ``intercalation`` or ``unresolved``.

    Parameters
    ----------
    edges : pandas.DataFrame
        Junctions of every frame: ``frame``, ``cell_a``, ``cell_b`` (label
        ids, 0 = outside), ``length`` (px).
    cells : pandas.DataFrame
        ``frame``, ``cell``, ``x``, ``y`` (px), optionally ``track`` (label
        ids are translated to track ids) and ``is_border``.  A cell absent
        from a frame is absent from the tissue (entered, left, divided or died).
    min_length : float
        Junctions shorter than ``min_length`` px are treated as four-fold
        vertices (no contact).  Use it to suppress T1s flickering across a
        noisy, nearly four-fold vertex; 0 (default) uses the raw network.
    censor : int, optional
        Right-censoring window, frames (see :func:`classify_t1`); default
        :func:`default_censor` of the movie's frames (last frame + 1).
    box : Box, optional
        Periodic box: quartet centres use minimum-image displacements.

    Returns
    -------
    pandas.DataFrame
        The ``events`` table: ``event`` (id), ``kind``, ``frame_start`` (first
        frame without the a-b contact), ``frame_end`` (first frame a-b touch
        again, cycles only, else NaN), ``duration`` (frames, cycles only),
        ``cell_a``, ``cell_b`` (lose the contact), ``cell_c``, ``cell_d``
        (gain it; all track ids), ``x``, ``y`` (quartet centre at
        ``frame_start``, px; x = column, y = row), ``frame_gain``,
        ``frame_undo``, ``is_border`` (see ``hexatissue.schema.TABLES["events"]``).
    """
    _check_cells(cells)
    frames = _movie_frames(edges, cells, min_length)
    raw = _find_t1(frames, _ids(edges, cells), _held_pairs(edges, cells))
    last = int(cells["frame"].max()) if len(cells) else 0
    return _events_table(raw, cells, box, default_censor(last + 1) if censor is None else censor)


def _check_cells(cells):
    for col in ("frame", "cell", "x", "y"):
        if col not in cells.columns:
            raise InputError(f"cells table is missing column {col!r}; expected frame, cell, x, y")


def t1_tables(edges: pd.DataFrame, cells: pd.DataFrame, min_length: float = 0.0, censor: int = 10,
              box: Box | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """:func:`detect_t1` and :func:`neighbour_events` of one movie, from one pass over its contacts.

    What :func:`hexatissue.analyze` needs: the two tables equal those of the
    two functions called apart, but the contacts of every frame (the larger
    part of either stage's cost) are found once and given to both.

    Parameters
    ----------
    edges, cells, min_length, box
        As for :func:`detect_t1`.
    censor : int
        Right-censoring window of both tables, frames (:func:`classify_t1`).

    Returns
    -------
    events, neighbour_events : pandas.DataFrame
    """
    _check_cells(cells)
    _check_censor(censor)
    changes, by_frame = _changes(cells)

    def contacts():  # each frame's contacts, to the per-cell lists as they go to the quartet search
        for f, tracks, a, b, length in _movie_frames(edges, cells, min_length):
            changes.add(_lists(f, tracks, a, b))
            yield f, tracks, a, b, length

    raw = _find_t1(contacts(), _ids(edges, cells), _held_pairs(edges, cells))
    release_freed_memory()  # the contacts' freed working set would stay resident under the two tables' own
    return _events_table(raw, cells, box, censor), _neighbour_table(changes, cells, by_frame, censor)


def _participants(events: pd.DataFrame) -> dict:
    """One entry per (event, cell taking part), as arrays: ``track``, ``kind``, ``duration``, ``frame``.

    Quartet events (:func:`detect_t1`) have four cells, ``cell_a``..``cell_d``;
    per-cell events (:func:`neighbour_events`) have one, ``track``.  ``kind``
    is the code of :data:`T1_KINDS` (-1 for any other value); ``frame`` is
    the event's ``frame_start``.  Codes, not strings: each string operation
    on tens of thousands of rows goes through Arrow, whose allocator keeps
    several MB of it resident.
    """
    columns = ("cell_a", "cell_b", "cell_c", "cell_d") if "cell_a" in events.columns else ("track",)
    for col in columns + ("kind", "frame_start", "duration"):
        if col not in events.columns:
            raise InputError(f"events table is missing column {col!r}; expected the output of detect_t1 or "
                             f"neighbour_events")
    names = events["kind"].to_numpy(object, na_value="")
    kind = np.full(len(names), -1, np.int8)
    for code, name in enumerate(T1_KINDS):
        kind[names == name] = code
    return {"track": np.concatenate([events[c].to_numpy(np.int64) for c in columns]),
            "kind": np.tile(kind, len(columns)), "duration": np.tile(events["duration"].to_numpy(float), len(columns)),
            "frame": np.tile(events["frame_start"].to_numpy(np.int64), len(columns))}


def intercalation_intervals(events: pd.DataFrame) -> pd.DataFrame:
    """Frames between consecutive intercalations of each cell.

    Only ``intercalation`` events count (cycles are undone; unresolved ones
    are censored).  The time of an intercalation is its ``frame_start``.
    ``events`` may be quartet events (:func:`detect_t1`: all four cells take
    part) or per-cell events (:func:`neighbour_events`).

    Returns
    -------
    pandas.DataFrame
        ``track``, ``frame_prev``, ``frame_next`` (frames), ``interval`` (frames).
    """
    long = _participants(events)
    chosen = long["kind"] == INTERCALATION
    track, frame = long["track"][chosen], long["frame"][chosen]
    order = np.lexsort((frame, track))  # by track, then frame, stable
    track, frame = track[order], frame[order]
    same = track[1:] == track[:-1]
    return pd.DataFrame({"track": track[:-1][same], "frame_prev": frame[:-1][same], "frame_next": frame[1:][same],
                         "interval": frame[1:][same] - frame[:-1][same]})


def _per_track(tracks, track, chosen, values=None):
    """Count (``values`` None) or mean of ``values`` over the ``chosen`` entries of each of the sorted ``tracks``.

    Entries whose ``track`` is not in ``tracks`` are left out; a mean over
    no entry (or only NaN values) is NaN.
    """
    at = np.searchsorted(tracks, track)
    chosen = chosen & in_sorted(track, tracks)
    if values is None:
        return np.bincount(at[chosen], minlength=len(tracks)).astype(np.int64)
    chosen &= ~np.isnan(values)
    count = np.bincount(at[chosen], minlength=len(tracks))
    total = np.bincount(at[chosen], weights=values[chosen], minlength=len(tracks))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def cell_event_stats(events: pd.DataFrame, cells: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per-cell T1 statistics (columns: ``hexatissue.schema.TABLES["cell_events"]``).

    Parameters
    ----------
    events : pandas.DataFrame
        Quartet events (:func:`detect_t1`) or per-cell events (:func:`neighbour_events`).
    cells : pandas.DataFrame, optional
        With ``frame`` and ``track`` (or ``cell``): every cell gets a row,
        also those without events, and ``n_frames`` is filled.

    Returns
    -------
    pandas.DataFrame
        ``track``, ``n_frames``, ``n_cycles``, ``n_intercalations``,
        ``n_unresolved``, ``mean_cycle_period`` (frames), ``n_intervals``,
        ``mean_intercalation_interval`` (frames).
    """
    long = _participants(events)
    if cells is not None:  # rows per track: a sort of one column (a hash table of it costs far more)
        tracks, n_frames = np.unique(track_ids(cells), return_counts=True)
    else:
        tracks = np.unique(long["track"])
        n_frames = np.zeros(len(tracks))
    out = pd.DataFrame({"track": tracks, "n_frames": n_frames.astype(np.int64)})
    track, kind = long["track"], long["kind"]
    for code, col in ((CYCLE, "n_cycles"), (INTERCALATION, "n_intercalations"), (UNRESOLVED, "n_unresolved")):
        out[col] = _per_track(tracks, track, kind == code)
    out["mean_cycle_period"] = _per_track(tracks, track, kind == CYCLE, long["duration"])
    iv = intercalation_intervals(events)
    every = np.ones(len(iv), bool)
    out["n_intervals"] = _per_track(tracks, iv["track"].to_numpy(), every)
    out["mean_intercalation_interval"] = _per_track(tracks, iv["track"].to_numpy(), every,
                                                    iv["interval"].to_numpy(float))
    return validate(out, "cell_events")


# ----------------------------------------------------------------------------
# The paper's per-cell definition: changes of each cell's neighbour list
# ----------------------------------------------------------------------------

def _mix(ids):
    """A 64-bit hash of each id (splitmix64): sums of them identify neighbour sets (order-free)."""
    return mix64(ids.astype(np.uint64) + np.uint64(GOLDEN))


class _Lists:
    """One frame's neighbour lists: directed contacts ``u -> v`` sorted by (u, v), hashed per cell.

    ``full[k]`` hashes the list of ``tracks[k]`` (a sum of :func:`_mix` of its neighbours, so it
    does not depend on their order).  Built by one numba kernel (:func:`~hexatissue.events._kernels._lists_kernel`):
    no sort, no numpy call; its plain-numpy reference is :class:`hexatissue.events._reference._ListsReference`.
    """

    def __init__(self, frame, tracks, a, b):
        self.frame, self.tracks = frame, tracks
        self.u, self.v, self.row, self.h, self.full = _lists_kernel(tracks, a, b, np.uint64(GOLDEN))

    def restricted(self, present):
        """List hashes on the neighbours in the sorted ids ``present`` (all when None), per cell."""
        if present is not None and np.array_equal(present, self.tracks):  # the same cells: every list whole
            return self.full
        out = np.zeros(len(self.tracks), np.uint64)
        h = self.h if present is None else np.where(in_sorted(self.v, present), self.h, np.uint64(0))
        np.add.at(out, self.row, h)
        return out

    def neighbours(self, tracks):
        """Directed contacts of each of ``tracks``: (position in ``tracks``, row of ``u``/``v``/``h``)."""
        rows, owner = _expand(np.searchsorted(self.u, tracks, "left"), np.searchsorted(self.u, tracks, "right"))
        return owner, rows


#: :class:`_Changes` (and its reference) and :func:`_index_of` find cells by a table over the track ids when
#: the largest id is below this many times the ids (plus 65,536): the table is then no larger than a few
#: columns of the cells table (:func:`_table_fits`).
SLOT_TABLE_ROWS = 4


def _lists(frame, tracks, a, b):
    """A frame's :class:`_Lists`, or its numpy reference where :mod:`hexatissue._dispatch` replaces the kernel."""
    return (KERNELS.replacement("_lists_kernel", "_ListsReference") or _Lists)(frame, tracks, a, b)


def _table_fits(top, n):
    """Whether a lookup table over ids 0..``top`` is small enough for ``n`` ids (:data:`SLOT_TABLE_ROWS`)."""
    return top < SLOT_TABLE_ROWS * n + 2**16


class _ChangeLog:
    """Every change of a cell's neighbour list between consecutive frames, and when the list comes back.

    Frames are added in order (``add``); only the previous frame's lists are kept.  A
    change of cell ``t`` at frame ``f`` (its list at ``f`` differs from the
    one at ``f - 1`` on the cells present in both frames) stays open until a
    later frame ``g`` where its list agrees with the one of ``f - 1`` again on
    the cells present at both ``g`` and ``f - 1``.  Lists are compared by
    their hashes on those cells (sums of :func:`_mix`): the whole list's hash
    less the neighbours absent from one of the two frames.  Only neighbours
    that are not present in every frame can be absent, so only those are
    kept and looked up, in ``present_keys`` (sorted
    :func:`~hexatissue.geometry.row_keys` of every (frame, cell) of the
    movie; None when every frame has the same cells).  What the two
    implementations (:class:`_Changes`, :class:`hexatissue.events._reference._ChangesReference`) share:
    the changes found, the returns, and :meth:`events` of them.
    """

    def __init__(self, present_keys):
        self.present_keys = present_keys
        self.always = None  # cells present in every frame (None: all of them)
        if present_keys is not None:
            frames, ids = np.divmod(present_keys, row_keys(1, 0))
            ids, count = np.unique(ids, return_counts=True)
            self.always = ids[count == len(np.unique(frames))]
        self.found = []  # per frame with changes: (track, frame, n_lost, n_gained) arrays
        self.back = []  # per frame with returns: (change index, frame) arrays
        self.n = 0  # changes so far
        self.prev = None

    def events(self, last, censor):
        """Events per cell, by the first change of each excursion, as arrays in (track, frame) order.

        A change whose list comes back is a cycle and the changes up to the
        return belong to it; one that never does is an intercalation
        (``unresolved`` within ``censor`` frames of ``last``).  Returns
        ``track``, ``kind`` (code of :data:`T1_KINDS`), ``start``, ``end``
        (float: the frame the list is back, NaN unless a cycle),
        ``n_lost``, ``n_gained``.
        """
        if not self.found:
            nothing = np.zeros(0, np.int64)
            return nothing, nothing, nothing, np.zeros(0), nothing, nothing
        track, start, n_lost, n_gained = (np.concatenate(c).astype(np.int64) for c in zip(*self.found))
        order = np.lexsort((start, track))  # stable: changes of one cell and frame keep their order
        back = np.full(self.n, -1, np.int64)
        for index, frame in self.back:
            back[index] = frame
        first = KERNELS._excursion_starts(order, track, start, back)
        cycle = back[first] >= 0
        kind = _kind_codes(cycle, start[first], last, censor)
        return (track[first], kind, start[first], np.where(cycle, back[first], np.nan), n_lost[first],
                n_gained[first])


class _Changes(_ChangeLog):
    """:class:`~hexatissue.events._reference._ChangesReference` in two numba kernels a frame
    (:func:`_close_kernel`, :func:`_change_kernel`).

    The reference's ~60 numpy calls a frame (each on a few hundred values) cost more than their work.
    The open changes live in buffers that grow by doubling, filled to ``m`` columns: ``open`` (change
    index, cell, frame before the change) and ``ref`` (hash of the list left there); and, filled to ``k``
    columns, the neighbours of those lists not present in every frame: ``rare`` (column of the change
    in ``open``, id) and ``rare_h`` (their hashes), in the order of their changes.
    """

    def __init__(self, present_keys, top=None):
        super().__init__(present_keys)
        # row of each track id in the current frame (-1: absent), when the ids are few enough for a table
        self.slot = np.zeros(0, np.int64) if top is None else np.full(int(top) + 1, -1, np.int64)
        self.m = self.k = 0
        self.open, self.ref = np.zeros((3, 64), np.int64), np.zeros(64, np.uint64)
        self.rare, self.rare_h = np.zeros((2, 64), np.int64), np.zeros(64, np.uint64)
        self.rare_ids = self.always is not None
        # the kernels take arrays whether or not some cells are missing from some frames
        self.keys = np.zeros(0, np.int64) if present_keys is None else present_keys
        self.common = np.zeros(0, np.int64) if self.always is None else self.always

    def add(self, lists):
        if self.m and len(lists.tracks):  # close the open changes whose list is back at this frame
            done, self.m, self.k = _close_kernel(lists.tracks, lists.u, lists.v, lists.h, lists.full, self.open,
                                                 self.ref, self.m, self.rare, self.rare_h, self.k, self.common,
                                                 self.keys, self.rare_ids, self.slot)
            if len(done):
                self.back.append((done, np.full(len(done), lists.frame)))
        prev = self.prev
        self.prev = lists
        if prev is None or prev.frame != lists.frame - 1 or not len(prev.tracks):
            return
        self._reserve(len(lists.tracks), len(prev.v) if self.rare_ids else 0)
        track, n_lost, n_gained, self.m, self.k = _change_kernel(
            prev.frame, prev.tracks, prev.v, prev.h, prev.full, prev.row, lists.tracks, lists.v, lists.h, lists.full,
            lists.row, self.open, self.ref, self.m, self.n, self.rare, self.rare_h, self.k, self.common, self.rare_ids)
        if len(track):
            self.found.append((track, np.full(len(track), lists.frame), n_lost, n_gained))
            self.n += len(track)

    def _reserve(self, changes, rare):
        """Room for ``changes`` more open changes and ``rare`` more neighbours (buffers doubled when full)."""
        if self.m + changes > self.ref.size:
            size = max(2 * self.ref.size, self.m + changes)
            self.open, self.ref = _grown(self.open, size), _grown(self.ref, size)
        if self.k + rare > self.rare_h.size:
            size = max(2 * self.rare_h.size, self.k + rare)
            self.rare, self.rare_h = _grown(self.rare, size), _grown(self.rare_h, size)


def _grown(buffer, size):
    """``buffer`` (1-D, or 2-D by columns) copied into one of ``size`` columns."""
    out = np.zeros(buffer.shape[:-1] + (size,), buffer.dtype)
    out[..., :buffer.shape[-1]] = buffer
    return out


def neighbour_events(edges: pd.DataFrame, cells: pd.DataFrame, min_length: float = 0.0, censor: int = 10
                     ) -> pd.DataFrame:
    """Neighbour exchanges by the paper's per-cell definition: changes of each cell's list of neighbours.

    Armengol-Collado et al. identify rearrangements "by tracking changes in
    the list of neighbours of each cell".  Here, for every cell and every
    pair of consecutive frames in which it is present, its neighbour list
    (restricted to the cells present in both frames, so cells entering,
    leaving or dividing do not count) either stays or changes.  A change at
    frame ``t`` starts an event; it is a **T1 cycle** of that cell when the
    list returns to the one it had at ``t - 1`` at a later frame ``t + T``
    (``duration = T``; changes in between belong to the same excursion), and
    an **intercalation** when it never does (``unresolved`` when it started
    fewer than ``censor`` frames before the last frame).  Compare
    :func:`detect_t1`, which follows quartets of cells instead: a quartet T1
    gives one event to each of its four cells here, but two quartet T1s that
    share a cell merge into one excursion of that cell.

    Parameters
    ----------
    edges, cells : pandas.DataFrame
        As for :func:`detect_t1` (``cells`` with ``frame``, ``cell``, ``x``,
        ``y``, optionally ``track`` and ``is_border``).
    min_length : float
        Contacts shorter than this (px) are not contacts (hysteresis against
        flickering four-fold vertices), as in :func:`detect_t1`.
    censor : int
        Right-censoring window, frames.

    Returns
    -------
    pandas.DataFrame
        The ``neighbour_events`` table, one row per event of a cell:
        ``event`` (id), ``track``, ``kind`` (cycle, intercalation,
        unresolved), ``frame_start`` (first frame with the changed list),
        ``frame_end`` (first frame the list is back, cycles; else NaN),
        ``duration`` (frames, cycles; else NaN), ``n_lost``, ``n_gained``
        (neighbours lost and gained at ``frame_start``), ``x``, ``y`` (the
        cell's centroid at ``frame_start``, px; x = column, y = row),
        ``is_border`` (a border cell at ``frame_start``).
    """
    _check_cells(cells)
    _check_censor(censor)
    changes, by_frame = _changes(cells)
    for frame, present, a, b, _ in _movie_frames(edges, cells, min_length):
        changes.add(_lists(frame, present, a, b))
    return _neighbour_table(changes, cells, by_frame, censor)


def _check_censor(censor):
    if int(censor) != censor or censor < 0:
        raise InputError(f"censor must be a non-negative integer number of frames; got {censor!r}")


def _changes(cells):
    """An empty :class:`_Changes` for the cells of a movie, and their rows by frame."""
    frames, tracks = cells["frame"].to_numpy(np.int64), track_ids(cells)
    by_frame = FrameRows(frames)
    constant = _same_cells_every_frame(by_frame, tracks)
    top = int(tracks.max()) if len(tracks) else 0
    changes = (KERNELS.replacement("_close_kernel", "_ChangesReference") or _Changes)(
        None if constant else np.unique(row_keys(frames, tracks)), top if _table_fits(top, len(tracks)) else None)
    return changes, by_frame


def _neighbour_table(changes, cells, by_frame, censor):
    """The ``neighbour_events`` table of the changes of every frame of ``cells``."""
    frames = cells["frame"].to_numpy(np.int64)
    track, kind, start, end, n_lost, n_gained = changes.events(int(frames.max()) if len(frames) else 0, censor)
    order = np.lexsort((track, start))  # by frame_start, then track, stable
    track, kind, start, end, n_lost, n_gained = (v[order] for v in (track, kind, start, end, n_lost, n_gained))
    row = _rows_at(cells, by_frame, start, track)
    at = np.maximum(row, 0)
    out = pd.DataFrame({"event": np.arange(len(track), dtype=np.int64), "track": track,
                        "kind": string_column(kind, T1_KINDS), "frame_start": start, "frame_end": end,
                        "duration": end - start, "n_lost": n_lost, "n_gained": n_gained,
                        **{c: np.where(row >= 0, cells[c].to_numpy(float)[at], np.nan) for c in ("x", "y")},
                        "is_border": ~interior_mask(cells)[at]})
    return validate(out, "neighbour_events")


def _same_cells_every_frame(by_frame, tracks):
    """Whether every frame has the same set of cells (then neighbour lists compare by hash alone)."""
    first = None
    for _, rows in by_frame:
        here = _unique(tracks[rows])
        if first is None:
            first = here
        elif not np.array_equal(first, here):
            return False
    return True


#: Warning when the censoring window leaves no T1 to count as an intercalation.
NO_INTERCALATION = ("no T1 event is classified as an intercalation: every T1 that is not undone starts within the "
                    "censoring window of the movie's end and is unresolved (see EventOptions.censor and "
                    "movie.summary['events'])")


def events_summary(events, censor, given, n_frames, vertices=None):
    """Censoring window used (``given`` by the user, or the default rule), the number of events of each kind,
    and what the network could not resolve: the contacts held as four-fold vertices.

    ``vertices``: the movie's vertices table; with its ``n_merged`` column
    (label input), ``n_held_contacts`` counts the contact-frames of junctions
    shorter than ``merge_distance`` held as four-fold (or higher) vertices,
    summed over frames, and ``n_held_vertices`` the vertex-frames holding
    them (a T1 whose new junction never grows past ``merge_distance`` is one
    of these, not an event); both None without that column.
    ``n_one_frame_cycles``: cycles of one frame (``duration`` 1: a-b lost and
    c-d gained in one frame, undone in the next), the doubtful T1s of a
    segmented movie (docs/t1.md, *T1 counts on real data*).  Warns
    (:class:`HexatissueWarning`) when no T1 is an intercalation because every
    one that is not undone is unresolved.
    """
    counts = events["kind"].astype(str).value_counts()
    n = {kind: int(counts.get(kind, 0)) for kind in ("cycle", "intercalation", "unresolved")}
    if n["unresolved"] and not n["intercalation"]:
        warnings.warn(NO_INTERCALATION, HexatissueWarning, stacklevel=user_stacklevel())
    rule = "given" if given else "min(10, max(1, n_frames // 5))"
    held = None if vertices is None or "n_merged" not in vertices.columns else vertices["n_merged"].to_numpy(np.int64)
    return {"censor": int(censor), "censor_rule": rule, "n_frames": int(n_frames), "n_events": int(len(events)),
            "n_cycles": n["cycle"], "n_intercalations": n["intercalation"], "n_unresolved": n["unresolved"],
            "n_classified": n["cycle"] + n["intercalation"],
            "n_one_frame_cycles": int(((events["kind"].astype(str) == "cycle")
                                       & (events["duration"].to_numpy(float) == 1)).sum()),
            "n_held_contacts": None if held is None else int(held.sum()),
            "n_held_vertices": None if held is None else int((held > 0).sum())}


# the column lists of hexatissue 0.1, now read from the one registry
__getattr__ = deprecated_column_lists(__name__, {
    "EVENT_EXTRA_COLUMNS": ("events", ("frame_gain", "frame_undo", "is_border")),
    "CELL_EVENT_COLUMNS": ("cell_events", None)})
