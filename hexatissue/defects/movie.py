"""A movie's defects tracked per p, with their pair events: :class:`MovieDefects` (a chunk of frames at a time, what
the defect tracks stage runs) and :func:`link_movie_defects` (tables in memory).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .._system import release_freed_memory
from ..errors import InputError
from ..schema import rows_by_frame, string_column, validate
from .pairs import EVENT_KINDS, PairEvents
from .tracking import DefectLinker


#: Default largest defect displacement between frames, in grid spacings (:func:`link_movie_defects`).
DEFECT_SPACINGS = 1.5


def default_max_distance(values, counts) -> float:
    """The default largest displacement of a defect between frames, px: :data:`DEFECT_SPACINGS` times the median
    of the grid's ``spacing`` column over the movie (1 px without any grid node).

    The column is given as ``values`` (px) and how many rows hold each
    (``counts``; a value may come several times, e.g. once from each chunk
    of frames: ``numpy.unique(spacing, return_counts=True)`` of each chunk,
    concatenated), so that a long movie's column is never read whole; the
    median is that of the whole column (:func:`median_of_counts`).
    """
    values, inverse = np.unique(np.asarray(values, float).reshape(-1), return_inverse=True)
    merged = np.zeros(len(values), np.int64)
    np.add.at(merged, inverse.reshape(-1), np.asarray(counts, np.int64).reshape(-1))
    if not merged.sum():
        return 1.0
    return DEFECT_SPACINGS * float(median_of_counts(values, merged))


def median_of_counts(values, counts) -> float:
    """``numpy.median`` of ``values`` each repeated ``counts`` times, without the repeated array.

    ``values`` distinct and sorted (NaN last, as :func:`numpy.unique` gives
    them), ``counts`` positive integers, at least one.  Equal to
    ``np.median(np.repeat(values, counts))``, bit for bit: the middle value,
    or the mean of the two middle values as numpy takes it; NaN when any
    value is NaN.
    """
    values, counts = np.asarray(values, float), np.asarray(counts, np.int64)
    n = int(counts.sum())
    if n == 0:
        raise InputError("counts must count at least one value")
    if np.isnan(values[counts > 0]).any():
        return np.nan
    ends = np.cumsum(counts)  # sorted position of each value's last copy, plus one
    lower, upper = values[np.searchsorted(ends, [(n - 1) // 2, n // 2], side="right")]
    return lower if n % 2 else np.mean(np.array([lower, upper]))


class MovieDefects:
    """A movie's defects linked over frames per p, and their pair events, a chunk of frames at a time.

    Each p has its own :class:`~hexatissue.defects.DefectLinker` (tracks
    numbered from 0 per p) and its own pair events
    (:class:`~hexatissue.defects.pairs.PairEvents`, built from each frame's
    births and deaths as the frames are linked: a track is born in a frame
    where its id was not in the frame before and dies in a frame whose
    successor lacks it; births in the movie's first frame and deaths in its
    last are not events).  Between chunks only the last frame's defects of
    each p are kept, so that linking a movie chunk by chunk, in frame order
    from frame 0, gives exactly the tables of linking it whole, with a
    chunk's defects in memory.

    Parameters
    ----------
    orders : sequence of int
        The p to keep (``OrderOptions.p``); defects of other p are dropped.
    max_distance : float
        Largest displacement of a defect between frames, px; also the largest
        separation of a created or annihilated pair.
    box : Box, optional
        Periodic box; None for an open image.
    linked : bool
        False when the frames are unrelated images: every frame is tracked
        alone (each defect is its own track) and there are no pair events.
    """

    def __init__(self, orders, max_distance, box=None, linked=True):
        self.orders, self.linked = tuple(orders), linked
        self._linkers = {q: DefectLinker(max_distance, box) for q in self.orders}
        self._events = {q: PairEvents(max_distance, box) for q in self.orders}
        self._last = dict.fromkeys(self.orders)  # the last frame linked of each p: (frame, xy, charge, track)
        self._next = 0  # the first frame of the next chunk

    def link(self, defects, first, last) -> pd.DataFrame:
        """The defects of frames ``first`` to ``last`` with their ``track``.

        ``defects`` is the defects table's rows of these frames (every p, in
        the table's order; a ``track`` column is replaced).  Its columns are
        taken one at a time as the tracked table is built (``defects`` is
        left empty), so that at most one column more than the chunk is in
        memory.  The chunks come in frame order: the first at frame 0,
        each next one at the frame after the last of the one before.

        Returns
        -------
        pandas.DataFrame
            The rows of the p in ``orders``, sorted by ``frame``, ``p`` and
            ``defect`` (a stable sort): the columns of ``defects`` and
            ``track`` (int64; per p, numbered from 0 over the movie in order
            of the track's first frame, then of row order).
        """
        if first != self._next:
            raise InputError(f"defects: the chunk of frames {first}-{last} must start at frame {self._next} (the "
                             f"chunks follow each other from frame 0)")
        frame, p = defects["frame"].to_numpy(), defects["p"].to_numpy()
        if len(frame) and (frame.min() < first or frame.max() > last):
            raise InputError(f"defects: the chunk of frames {first}-{last} holds defects of frames {frame.min()} to "
                             f"{frame.max()}")
        frames = np.arange(first, last + 1)
        track = np.zeros(len(frame), np.int64)
        for q in self.orders:
            rows = np.flatnonzero(p == q)
            xy = np.column_stack([defects["x"].to_numpy(float)[rows], defects["y"].to_numpy(float)[rows]])
            track[rows] = self._link(q, frame[rows], xy, defects["charge"].to_numpy(float)[rows], frames)
        self._next = last + 1
        # by frame, p and defect (a stable sort), one column at a time from the table given away
        rows = np.lexsort((defects["defect"].to_numpy(), p, frame))
        rows = rows[np.isin(p[rows], self.orders)]
        del frame, p
        columns = {c: defects.pop(c).to_numpy()[rows] for c in list(defects.columns) if c != "track"}
        columns["track"] = track[rows]
        return validate(pd.DataFrame(columns, copy=False), "defects")

    def _link(self, q, times, xy, charge, frames):
        """Track ids of the defects of p = ``q`` in ``frames``; their births and deaths added to the events."""
        linker = self._linkers[q]
        by_frame = rows_by_frame(times)
        if not self.linked:  # every frame alone: each defect starts a track, no frame has a predecessor
            track = np.zeros(len(times), np.int64)
            for t in frames:
                if t in by_frame:
                    linker.restart()
                    track[by_frame[t]] = linker.link(times[by_frame[t]], xy[by_frame[t]], charge[by_frame[t]])
            return track
        track = linker.link(times, xy, charge, frames)
        events, last, empty = self._events[q], self._last[q], np.zeros(0, np.int64)
        for t in frames:
            at = by_frame.get(t, empty)
            ids = track[at]
            if last is not None:  # births after the movie's first frame, deaths before its last
                t_before, xy_before, charge_before, ids_before = last
                ended = ~np.isin(ids_before, ids)
                events.add(t_before, False, xy_before[ended], charge_before[ended], ids_before[ended])
                born = ~np.isin(ids, ids_before)
                events.add(t, True, xy[at][born], charge[at][born], ids[born])
            last = (t, xy[at], charge[at], ids)
        self._last[q] = last
        return track

    def events(self) -> pd.DataFrame:
        """The pair events of the frames linked: the ``defect_events`` table (of every p, in the order of
        ``orders``, each sorted as :func:`~hexatissue.defects.defect_events` sorts)."""
        taken = [(q, self._events[q].take_columns()) for q in self.orders]
        taken = [(q, columns) for q, columns in taken if columns is not None]
        if not taken:  # the empty table of defect_events, with a p column
            tables = [self._events[q].table().assign(p=np.int64(q)) for q in self.orders]
            return validate(pd.concat(tables, ignore_index=True).astype({"frame": np.int64}), "defect_events")
        # each column of every p at once, each p's let go as it is copied: not a table per p, then their
        # concatenation, which copies every column at each step
        lengths = [len(columns["frame"]) for _, columns in taken]
        cols = {}
        for name in list(taken[0][1]):
            cols[name] = np.concatenate([columns.pop(name) for _, columns in taken])
        cols["frame"] = cols["frame"].astype(np.int64, copy=False)
        cols["kind"] = string_column(cols["kind"], EVENT_KINDS)
        cols["p"] = np.repeat(np.array([q for q, _ in taken], np.int64), lengths)
        return validate(pd.DataFrame(cols, copy=False), "defect_events")


def link_movie_defects(tables, orders, max_distance=None, box=None, n_frames=0, linked=True):
    """Link ``tables["defects"]`` over frames per p (``track``); add their pair events as ``tables["defect_events"]``.

    ``tables`` holds a movie's ``grid`` and ``defects`` (every frame, every
    p); ``orders`` the p to keep; ``max_distance`` the largest displacement
    of a defect between frames, px (None: :data:`DEFECT_SPACINGS` grid
    spacings, :func:`default_max_distance`); ``n_frames`` the movie's frames.
    With ``linked`` False (frames that are unrelated images) every frame is
    tracked alone: each defect is its own track and there are no pair
    events.  The whole movie as one chunk of :class:`MovieDefects`.  The
    tables come in a dict so that the untracked defects are freed column by
    column as the tracked table is built (an argument would stay referenced
    by the caller for the whole call).
    """
    defects = tables.pop("defects")
    if max_distance is None:
        max_distance = default_max_distance(*np.unique(tables["grid"]["spacing"].to_numpy(float), return_counts=True))
        release_freed_memory()  # the sorted copy of the grid column would stay resident under the tracking
    linker = MovieDefects(orders, max_distance, box, linked)
    tables["defects"] = linker.link(defects, 0, n_frames - 1)
    del defects
    tables["defect_events"] = linker.events()
