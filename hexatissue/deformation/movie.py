"""What the budget reads of the movie: the cells' positions per frame by track, their lineage, and the T1s
whose triangulation may change into each frame.
"""
from __future__ import annotations

import numpy as np

from .triangulation import _min_image


# the budget term of each kind of T1 of the events tables
_T1_KINDS = {"cycle": "t1_cycle", "intercalation": "t1_intercalation", "unresolved": "t1_unresolved"}


class _Frames:
    """The cells' positions per frame, by track (a mother at the mean of its daughters on request)."""

    def __init__(self, cells, box):
        frame = cells["frame"].to_numpy(np.int64)
        order = np.lexsort((cells["track"].to_numpy(np.int64), frame))
        self.frame = frame[order]
        self.track = cells["track"].to_numpy(np.int64)[order]
        self.xy = cells[["x", "y"]].to_numpy(float)[order]
        self.cell = cells["cell"].to_numpy(np.int64)[order]
        border = cells["is_border"].to_numpy(bool) if "is_border" in cells else np.zeros(len(cells), bool)
        self.interior = ~border[order]
        self.bounds = {int(f): (int(a), int(b)) for f, a, b in _runs(self.frame)}
        self.box = box

    def rows(self, t):
        a, b = self.bounds[t]
        return slice(a, b)

    def positions(self, t, ids, merged=None):
        """Positions (k, 2) of tracks ``ids`` at frame ``t``; ``merged`` maps a mother to its daughters' rows."""
        sl = self.rows(t)
        tracks = self.track[sl]
        at = np.searchsorted(tracks, ids)
        at = np.minimum(at, len(tracks) - 1)
        found = tracks[at] == ids
        out = np.full((len(ids), 2), np.nan)
        out[found] = self.xy[sl][at[found]]
        if merged:
            for i in np.flatnonzero(~found):
                rows = merged.get(int(ids[i]))
                if rows is not None:
                    out[i] = _mean_position(self.xy[sl][rows], self.box)
        return out


def _runs(values):
    starts = np.flatnonzero(np.r_[True, values[1:] != values[:-1]])
    ends = np.r_[starts[1:], len(values)]
    return zip(values[starts], starts, ends)


def _mean_position(xy, box):
    return xy[0] + _min_image(xy - xy[0], box).mean(axis=0)


def _corners(ids, pos, box):
    """Contiguous corners (m, 3, 2) of triangles ``ids`` from positions ``pos`` (m, 3, 2)."""
    xy = pos.copy()
    xy[:, 1:] = xy[:, :1] + _min_image(xy[:, 1:] - xy[:, :1], box)
    return xy


def _lookup(ids, keys):
    """Positions of ``ids`` in the sorted ``keys``, and whether each was found there."""
    at = np.minimum(np.searchsorted(keys, ids), len(keys) - 1)
    return at, keys[at] == ids


class _Lineage:
    """What becomes of each track: its end, its mother, its daughters."""

    def __init__(self, lineage):
        self.end = dict(zip(lineage["track"].to_numpy(np.int64).tolist(), lineage["end"].astype(str).tolist()))
        self.parent = dict(zip(lineage["track"].to_numpy(np.int64).tolist(),
                               lineage["parent"].to_numpy(np.int64).tolist()))


class _Candidates:
    """The T1s whose triangulation may change into a frame: (event id, term, set of tracks), by frame."""

    def __init__(self, t1, source):
        self.by_frame = {}
        if t1 is None or len(t1) == 0:
            return
        if source == "quartets":
            frames = [c for c in ("frame_start", "frame_gain", "frame_undo", "frame_end") if c in t1]
            cells = t1[["cell_a", "cell_b", "cell_c", "cell_d"]].to_numpy(np.int64)
        else:
            frames = ["frame_start", "frame_end"]
            cells = t1[["track"]].to_numpy(np.int64)
        events, kinds = t1["event"].to_numpy(np.int64), t1["kind"].astype(str).to_numpy()
        when = t1[frames].to_numpy(float)
        for e, k, c, f in zip(events.tolist(), kinds, cells.tolist(), when.tolist()):
            entry = (e, _T1_KINDS.get(k, "t1_unresolved"), set(c))
            for frame in {v for v in f if v == v}:  # its distinct frames, NaN left out
                self.by_frame.setdefault(int(frame), []).append(entry)

    def at(self, frame):
        return self.by_frame.get(frame, [])
