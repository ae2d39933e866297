"""Per-cell neighbour events: the neighbour list of each cell per frame (:class:`_Lists`) and its changes
(:class:`_Changes`), classified as T1s are (the per-cell definition, docs/t1.md).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .._hashing import GOLDEN, mix64
from ..geometry import in_sorted, row_keys
from ..schema import FrameRows, string_column, validate
from ._kernels import _change_kernel, _close_kernel, _lists_kernel
from .classify import KERNELS, T1_KINDS, _check_censor, _kind_codes
from .frames import _check_cells, _movie_frames, _unique, block_tracks, cell_frames
from .quartets import _expand, _table_fits


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


def _lists(frame, tracks, a, b):
    """A frame's :class:`_Lists`, or its numpy reference where :mod:`hexatissue._dispatch` replaces the kernel."""
    return (KERNELS.replacement("_lists_kernel", "_ListsReference") or _Lists)(frame, tracks, a, b)


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
    cells = cell_frames(cells)
    changes = _changes(cells)
    for frame, present, a, b, _ in _movie_frames(edges, cells, min_length):
        changes.add(_lists(frame, present, a, b))
    return _neighbour_table(changes, cells, censor)


def _changes(cells):
    """An empty :class:`_Changes` for the cells of a movie (a :class:`~hexatissue.events.frames.CellFrames`).

    Read a block of frames at a time: whether every frame has the same
    cells, then, when not, the (frame, cell) keys of the movie that the
    changes look cells up in (sorted: the blocks come in frame order).
    """
    top = 0

    def frame_tracks():
        nonlocal top
        for _, block in cells.blocks(["frame", "cell", "track"]):
            tracks = block_tracks(block)
            top = max(top, int(tracks.max(initial=0)))
            for _, rows in FrameRows(block["frame"]):
                yield tracks[rows]

    keys = None
    if not _same_cells_every_frame(frame_tracks()):  # it stopped at the first difference: top is not known yet
        keys = []
        for _, block in cells.blocks(["frame", "cell", "track"]):
            tracks = block_tracks(block)
            top = max(top, int(tracks.max(initial=0)))
            keys.append(np.unique(row_keys(block["frame"].astype(np.int64, copy=False), tracks)))
        keys = np.concatenate(keys)
    return (KERNELS.replacement("_close_kernel", "_ChangesReference") or _Changes)(
        keys, top if _table_fits(top, len(cells)) else None)


def _neighbour_table(changes, cells, censor):
    """The ``neighbour_events`` table of the changes of every frame of ``cells`` (a
    :class:`~hexatissue.events.frames.CellFrames`)."""
    track, kind, start, end, n_lost, n_gained = changes.events(cells.last_frame(), censor)
    order = np.lexsort((track, start))  # by frame_start, then track, stable
    track, kind, start, end, n_lost, n_gained = (v[order] for v in (track, kind, start, end, n_lost, n_gained))
    _, at = cells.values_at(start, track, ("x", "y", "is_border"))
    out = pd.DataFrame({"event": np.arange(len(track), dtype=np.int64), "track": track,
                        "kind": string_column(kind, T1_KINDS), "frame_start": start, "frame_end": end,
                        "duration": end - start, "n_lost": n_lost, "n_gained": n_gained,
                        "x": at["x"], "y": at["y"], "is_border": at["is_border"]})
    return validate(out, "neighbour_events")


def _same_cells_every_frame(frame_tracks):
    """Whether every frame has the same set of cells (then neighbour lists compare by hash alone);
    ``frame_tracks``: the track ids of each frame in turn."""
    first = None
    for tracks in frame_tracks:
        here = _unique(tracks)
        if first is None:
            first = here
        elif not np.array_equal(first, here):
            return False
    return True
