"""Trackers by id and per frame, the movie tracker that picks one, and tracks from a label stack."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ..geometry import in_sorted, row_keys
from ..mesh.labels import touches_outside, validate_labels
from ..options import TRACK_MODES
from ..progress import progress as progress_bar
from .lineage import lineage_table
from .linking import _check_fractions, _divisions
from .overlap import _Compact, _compact, _contingency, _frame_span, _narrow, _stored_rows
from .tracker import Tracker, _Feed

#: ``mode="auto"`` trusts the ids when at least this fraction of the linked cells keep their id (see :class:`MovieTracker`).
ID_CONSISTENCY = 0.9


class IdTracker(_Feed):
    """Trust the label ids: track id = label id; divisions read from the ids and overlaps.

    For consistently labelled movies (curated tracks, MPF runs).  A cell
    missing for some frames keeps its id, so it stays one track across any
    gap.  A division is a mother id that is absent from the next frame while
    two ids never seen before appear there mostly inside its last mask (the
    overlap rule of :func:`match_frames`, applied to those ids only); a
    mother whose id comes back later was not a mother.  The tracker also
    measures how consistent the ids are (:attr:`consistency`).

    Parameters
    ----------
    min_iou, child_fraction, mother_fraction : float
        See :func:`match_frames`.
    """

    def __init__(self, min_iou=0.2, child_fraction=0.6, mother_fraction=0.2):
        _check_fractions(min_iou, child_fraction, mother_fraction)
        self.min_iou, self.child_fraction, self.mother_fraction = min_iou, child_fraction, mother_fraction
        self._prev: _Compact | None = None
        self._shape = None
        self._seen = np.empty(0, np.int64)  # sorted ids seen so far
        self._divisions: dict[int, tuple[int, int]] = {}  # daughter -> (mother, frame of the daughters)
        self._frames, self._cells = [], []
        self.n_linked = 0  # cells of frame t overlapping a cell of frame t+1 with IoU >= min_iou
        self.n_same = 0  # ... that overlap the cell with their own id with IoU >= min_iou
        self._n = 0

    def add_valid(self, labels, frame=None) -> np.ndarray:
        """:meth:`add` for labels already checked by :func:`~hexatissue.mesh.labels.validate_labels`."""
        frame, cur = self._next_frame(labels, frame)
        if self._prev is not None:
            a = self._prev
            i, j, n = _contingency(a, cur)
            iou = n / (a.area[i] + cur.area[j] - n)
            good = iou >= self.min_iou
            self.n_linked += len(np.unique(i[good]))
            self.n_same += int((good & (a.ids[i] == cur.ids[j])).sum())
            ended = ~in_sorted(a.ids, cur.ids)  # both sorted: binary searches, not isin's sort or table
            new = ~in_sorted(cur.ids, self._seen)
            sel = ended[i] & new[j]
            mothers, daughters = _divisions(i[sel], j[sel], n[sel], a.area, cur.area, self.child_fraction,
                                            self.mother_fraction, self.min_iou)
            for m, pair in zip(a.ids[mothers].tolist(), cur.ids[daughters].tolist()):
                for d in pair:
                    self._divisions[d] = (m, frame)
        if self._prev is None or new.any():  # else every id was seen: no union (a hash unique) to make
            self._seen = np.union1d(self._seen, cur.ids)
        self._frames.append(frame)
        self._cells.append(cur.stored_ids())
        self._prev = cur
        self._n += 1
        return cur.ids.copy()

    def add_ids(self, ids, frame) -> None:
        """Add a frame known only by its cell ids (polygon input): track = id; no overlaps, so no divisions."""
        ids = np.asarray(ids, np.int64)
        self._seen = np.union1d(self._seen, ids)
        self._frames.append(int(frame))
        self._cells.append(_narrow(ids))
        self._n += 1

    @property
    def consistency(self) -> float:
        """Of the cells overlapping a cell of the next frame with IoU >= ``min_iou``, the fraction whose
        own id is such a cell (NaN before two frames with cells)."""
        return self.n_same / self.n_linked if self.n_linked else float("nan")

    def tracks(self, frames=None) -> pd.DataFrame:
        """``frame``, ``cell`` (label id), ``track`` (= ``cell``) of every cell added so far (of frames ``first``
        to ``last`` when ``frames = (first, last)``)."""
        at = _frame_span(self._frames, frames)
        frames, cells = _stored_rows(self._frames[at], self._cells[at])
        return pd.DataFrame({"frame": frames, "cell": cells, "track": cells.copy()}, copy=False)  # new arrays

    @property
    def parents(self) -> dict:
        """``{daughter track: mother track}`` of the divisions found (mothers that never come back)."""
        last = self._last_frames({m for m, _ in self._divisions.values()})
        return {d: m for d, (m, t) in self._divisions.items() if last[m] < t}

    def _last_frames(self, ids) -> dict:
        """``{id: frame}`` of the last frame added that holds each of ``ids`` (asked once, at the end, for
        the mothers only: no per-frame dictionary of every id)."""
        if not ids:
            return {}
        frame, cell = _stored_rows(self._frames, self._cells)
        rows = np.flatnonzero(np.isin(cell, np.fromiter(ids, np.int64)))[::-1]  # the latest rows first
        found, first = np.unique(cell[rows], return_index=True)
        return dict(zip(found.tolist(), frame[rows[first]].tolist()))


class SeparateTracker:
    """No tracking: every cell of every frame is its own track (frames that are unrelated images)."""

    def __init__(self):
        self._frames, self._cells = [], []

    def add_valid(self, labels, frame) -> None:
        """Add a label image (checked by :func:`~hexatissue.mesh.labels.validate_labels`)."""
        self.add_ids(_compact(labels).ids, frame)

    def add_ids(self, ids, frame) -> None:
        """Add a frame by its cell ids."""
        self._frames.append(int(frame))
        self._cells.append(_narrow(np.asarray(ids, np.int64)))

    def tracks(self, frames=None) -> pd.DataFrame:
        """``frame``, ``cell``, ``track`` (1, 2, ... in frame and cell order; of frames ``first`` to ``last``
        when ``frames = (first, last)``)."""
        at = _frame_span(self._frames, frames)
        before = sum(len(c) for c in self._cells[:at.start])  # the tracks of the earlier frames
        frames, cells = _stored_rows(self._frames[at], self._cells[at])
        return pd.DataFrame({"frame": frames, "cell": cells,
                             "track": np.arange(before + 1, before + len(cells) + 1, dtype=np.int64)},
                            copy=False)  # new arrays: no copy

    @property
    def parents(self) -> dict:
        """No divisions: ``{}``."""
        return {}


class MovieTracker:
    """Tracking of a whole movie by mode: keep the ids, link by overlap, or decide from the data.

    Parameters
    ----------
    mode : {"auto", "always", "never", "off"}
        ``"never"``: the ids are the tracks (:class:`IdTracker`: track =
        cell, gap-tolerant, divisions read from the ids and overlaps).
        ``"always"``: link cells by overlap (:class:`Tracker`).  ``"off"``:
        every cell of every frame is its own track (:class:`SeparateTracker`).
        ``"auto"``: ``"off"`` when ``independent``, ``"never"`` when
        ``ids_consistent``; otherwise both run and the ids are kept when
        :attr:`IdTracker.consistency` is at least :data:`ID_CONSISTENCY`
        (or when no two frames could be compared), else the overlap tracks
        are used.
    min_iou, child_fraction, mother_fraction : float
        See :func:`match_frames`.
    max_gap : int
        Gap closing of the overlap tracker (see :class:`Tracker`).
    follow : {"flow", "none"}, periodic : bool
        How the overlap tracker links frames (see :class:`Tracker`).
    ids_consistent : bool
        The source guarantees consistent ids (MPF runs, polygon tables with frames).
    independent : bool
        The frames are unrelated images (a folder of polygon files), not a movie.
    """

    def __init__(self, mode="auto", min_iou=0.2, child_fraction=0.6, mother_fraction=0.2, max_gap=0,
                 ids_consistent=False, independent=False, follow="flow", periodic=False):
        if mode not in TRACK_MODES:
            raise InputError(f"mode must be one of {TRACK_MODES}; got {mode!r}")
        self.mode, self.ids_consistent, self.independent = mode, bool(ids_consistent), bool(independent)
        self.ids = IdTracker(min_iou, child_fraction, mother_fraction)
        self.separate = SeparateTracker() if mode == "off" or (mode == "auto" and self.independent) else None
        overlap = mode == "always" or (mode == "auto" and not self.ids_consistent and not self.independent)
        self.overlap = Tracker(min_iou, child_fraction, mother_fraction, max_gap, follow, periodic) if overlap else None

    def add_valid(self, labels, frame=None, overlaps=None):
        """Add the next frame (labels checked by :func:`~hexatissue.mesh.labels.validate_labels`).

        ``labels`` and ``overlaps`` may come from :func:`compact_frames` (run
        ahead, e.g. in the worker that meshed the frames): ``overlaps`` are then
        the counts with the frame added just before, and ``labels`` may lack
        its pixels unless gap closing needs them (:attr:`needs_pixels`).
        """
        labels = _compact(labels)  # once for both trackers, which share the overlaps too
        if overlaps is not None:
            labels.overlaps = (self.ids._prev, overlaps)
        self.ids.add_valid(labels, frame)
        for feed in (self.overlap, self.separate):
            if feed is not None:
                feed.add_valid(labels, frame)

    @property
    def needs_pixels(self) -> bool:
        """Whether every frame's pixels are needed (gap closing keeps the masks of ended tracks; following the
        flow warps them)."""
        return self.overlap is not None and (self.overlap.max_gap > 0 or self.overlap.follow == "flow")

    def add_ids(self, ids, frame):
        """Add the next frame by its cell ids only (polygon input: nothing to overlap)."""
        if self.overlap is not None:
            raise InputError("add_ids: overlap tracking (mode 'always') needs label images; use add_valid")
        self.ids.add_ids(ids, frame)
        if self.separate is not None:
            self.separate.add_ids(ids, frame)

    def decision(self) -> tuple[str, str]:
        """``(resolved mode, reason)``: ``"never"`` (ids kept) or ``"always"`` (overlap tracks), and why."""
        c = self.ids.consistency
        measured = (f"{c:.1%} of the cells overlapping a cell of the next frame (IoU >= {self.ids.min_iou:g}) "
                    f"overlap their own id" if np.isfinite(c) else "no two frames with overlapping cells")
        if self.mode != "auto":
            return self.mode, f"track={self.mode!r} requested; {measured}"
        if self.independent:
            return "off", "the source's frames are independent images, not a movie: every cell is its own track"
        if self.ids_consistent:
            return "never", ("the source's ids are consistent (MPF run, polygon table or Cell Tracking Challenge "
                             "folder): ids kept")
        if not np.isfinite(c):
            return "never", f"{measured}: ids kept"
        if c >= ID_CONSISTENCY:
            return "never", f"{measured} (>= {ID_CONSISTENCY:.0%}): ids kept"
        return "always", f"{measured} (< {ID_CONSISTENCY:.0%}): cells re-tracked"

    def _chosen(self):
        return {"never": self.ids, "always": self.overlap, "off": self.separate}[self.decision()[0]]

    def tracks(self, frames=None) -> pd.DataFrame:
        """``frame``, ``cell``, ``track`` of the chosen tracking (of frames ``first`` to ``last`` when
        ``frames = (first, last)``)."""
        return self._chosen().tracks(frames)

    @property
    def parents(self) -> dict:
        """``{daughter track: mother track}`` of the chosen tracking."""
        return self._chosen().parents

    def link_qc(self) -> pd.DataFrame:
        """:meth:`Tracker.link_qc` of the overlap tracks when they are the ones chosen (else no rows)."""
        chosen = self._chosen()
        return chosen.link_qc() if isinstance(chosen, Tracker) else Tracker(follow="none").link_qc()

    def summary(self) -> dict:
        """What was decided: ``mode`` requested, ``resolved``, ``reason``, ``id_consistency``, ``threshold``, and
        ``follow`` (how the overlap tracker linked the frames: ``"flow"``, ``"none"``; None without one)."""
        resolved, reason = self.decision()
        c = self.ids.consistency
        return {"mode": self.mode, "resolved": resolved, "reason": reason,
                "id_consistency": float(c) if np.isfinite(c) else None, "threshold": ID_CONSISTENCY,
                "follow": self.overlap.follow if self.overlap is not None else None}


def track_labels(stack, min_iou=0.2, child_fraction=0.6, mother_fraction=0.2, max_gap=0, progress=False):
    """Track the cells of a label movie by overlap.

    Parameters
    ----------
    stack : T x rows x cols array-like or sequence of 2-D label images
        Frames are read one at a time (``stack[t]``), so lazily indexed
        arrays (zarr, dask, memory maps) are never loaded whole.
    min_iou, child_fraction, mother_fraction : float
        See :func:`match_frames`.
    max_gap : int
        Frames a cell may be missing and still continue its track (see :class:`Tracker`).
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    tracks : pandas.DataFrame
        ``frame``, ``cell`` (label id), ``track`` (track id).
    lineage : pandas.DataFrame
        See :func:`lineage_table`; a cell touching background 0 or the image
        edge is a border cell (the mesh's ``is_border`` rule).  Give touching
        labels (membrane images normalised first with
        :func:`hexatissue.mesh.normalize_labels`), else every cell touches 0.
    """

    n = len(stack)
    tracker = Tracker(min_iou, child_fraction, mother_fraction, max_gap)
    border = []
    for t in progress_bar(range(n), enabled=progress, desc="tracking"):
        labels = validate_labels(stack[t], f"stack[{t}]")
        tracker.add(labels, t)
        border.append(np.isin(tracker._cells[-1], touches_outside(labels)))
    tracks = tracker.tracks()
    lineage = lineage_table(tracks, tracker.parents, np.concatenate(border) if border else None)
    return tracks, lineage


def cells_with_tracks(cells, tracker, frames=None):
    """``cells`` with a ``track`` column after ``cell``, from a :class:`MovieTracker`'s ``(frame, cell) -> track``.

    The tracker must have seen exactly the cells of ``cells`` (the mesh's
    own labels, once each); ``frames = (first, last)``: ``cells`` are the
    cells of those frames (a chunk of the movie), None: of every frame.
    """
    ids = tracker.tracks(frames)
    if all(np.array_equal(ids[c].to_numpy(), cells[c].to_numpy()) for c in ("frame", "cell")):
        track = ids["track"].to_numpy(np.int64)  # the mesh's rows in the tracker's order (frame, id): no search
    else:
        track = _tracks_by_key(cells, ids)
    del ids
    cells = cells.drop(columns="track", errors="ignore")
    cells.insert(cells.columns.get_loc("cell") + 1, "track", track)
    return cells


def _tracks_by_key(cells, ids):
    """The ``track`` of each row of ``cells`` from the tracker's ``ids`` table (rows in any order)."""
    # one sorted int64 key per (frame, cell), not a merge (which needs several times the column's memory)
    keys = row_keys(ids["frame"].to_numpy(np.int64), ids["cell"].to_numpy(np.int64))
    order = np.argsort(keys)
    keys = keys[order]
    wanted = row_keys(cells["frame"].to_numpy(np.int64), cells["cell"].to_numpy(np.int64))
    pos = np.minimum(np.searchsorted(keys, wanted), max(len(keys) - 1, 0))
    # the tracker saw the mesh's own labels, once each: anything else is a bug, not bad input
    if len(wanted) and (len(keys) == 0 or (keys[pos] != wanted).any() or (np.diff(keys) == 0).any()):
        raise AssertionError("mesh cells missing from the tracker's labels, or seen twice")
    return ids["track"].to_numpy(np.int64)[order[pos]]
