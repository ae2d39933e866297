"""A movie's defects tracked per p, with their pair events (:func:`link_movie_defects`, what the order stage
runs).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .._system import release_freed_memory
from ..schema import rows_by_frame, validate
from .pairs import defect_events
from .tracking import track_defects


#: Default largest defect displacement between frames, in grid spacings (:func:`link_movie_defects`).
DEFECT_SPACINGS = 1.5


def link_movie_defects(tables, orders, max_distance=None, box=None, n_frames=0, linked=True):
    """Link ``tables["defects"]`` over frames per p (``track``); add their pair events as ``tables["defect_events"]``.

    ``tables`` holds a movie's ``grid`` and ``defects`` (every frame, every
    p); ``orders`` the p to keep; ``max_distance`` the largest displacement
    of a defect between frames, px (None: :data:`DEFECT_SPACINGS` grid
    spacings); ``n_frames`` the movie's frames.  With ``linked`` False
    (frames that are unrelated images) every frame is tracked alone: each
    defect is its own track and there are no pair events.  The tables come
    in a dict so that the untracked defects are freed column
    by column as the tracked table is built (an argument would stay
    referenced by the caller for the whole call); tracking reads a copy of
    four columns of each p, not of the whole table.
    """
    defects, grid = tables.pop("defects"), tables["grid"]

    groups = [np.arange(n_frames)] if linked else [np.array([t]) for t in range(n_frames)]
    if max_distance is None:
        spacing = grid["spacing"].to_numpy(float)
        max_distance = DEFECT_SPACINGS * float(np.median(spacing)) if len(spacing) else 1.0
        release_freed_memory()  # np.median's sorted copy of the grid column would stay resident under the tracking
    p = defects["p"].to_numpy()
    track = np.zeros(len(defects), np.int64)
    pair_events = []
    for q in orders:
        rows = np.flatnonzero(p == q)
        # only the columns tracking reads, not a copy of the table per p
        of_p = pd.DataFrame({c: defects[c].to_numpy()[rows] for c in ("frame", "x", "y", "charge")})
        rows_of = None if linked else rows_by_frame(of_p["frame"].to_numpy())  # not one scan per frame
        n_tracks = 0
        for frames in groups:
            at = slice(None) if linked else rows_of.get(int(frames[0]), np.zeros(0, np.int64))
            t = track_defects(of_p if linked else of_p.iloc[at], max_distance, box=box, frames=frames)
            t["track"] += n_tracks
            n_tracks = int(t["track"].max()) + 1 if len(t) else n_tracks
            track[rows[at]] = t["track"].to_numpy()
            pair_events.append(defect_events(t, max_distance, box=box, frames=frames).assign(p=np.int64(q)))
            del t
        del of_p, rows_of
        release_freed_memory()  # tracking and pairing leave freed memory resident under the next p
    # the rows of every p, by frame, p and defect (a stable sort), taken one column at a time from the
    # table given away: at most one column more than the defects table in memory
    rows = np.lexsort((defects["defect"].to_numpy(), p, defects["frame"].to_numpy()))
    rows = rows[np.isin(p[rows], orders)]
    del p
    columns = {c: defects.pop(c).to_numpy()[rows] for c in list(defects.columns) if c != "track"}
    del defects
    columns["track"] = track[rows]
    pair_events = pd.concat(pair_events, ignore_index=True)
    tables["defects"] = validate(pd.DataFrame(columns, copy=False), "defects")
    tables["defect_events"] = validate(pair_events.astype({"frame": np.int64}), "defect_events")
