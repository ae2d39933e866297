"""The T1 events table of a movie (:func:`detect_t1`), and that table with the per-cell one from one pass
over the contacts (:func:`t1_tables`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .._system import release_freed_memory
from ..box import Box
from ..schema import validate
from .classify import _check_censor, classify_t1, default_censor
from .frames import _check_cells, _held_frames, _ids, _movie_frames, cell_frames
from .neighbours import _changes, _lists, _neighbour_table
from .quartets import _find_t1


def _centre(xy, box):
    """Mean of each row's points ``xy`` (rows x points x 2, NaN = missing), minimum-image in a periodic ``box``."""
    if box is not None:
        xy = xy[:, :1] + box.min_image(xy - xy[:, :1])
        return box.wrap(np.nanmean(xy, axis=1))
    return np.nanmean(xy, axis=1)


def _positions(events, cells, box):
    """Quartet centre (x, y) and border flag at frame_start, from the cells (a
    :class:`~hexatissue.events.frames.CellFrames`)."""
    if events.empty:
        return np.empty(0), np.empty(0), np.empty(0, bool)
    quartet = ("cell_a", "cell_b", "cell_c", "cell_d")
    frame = np.tile(events["frame_start"].to_numpy(np.int64), 4)
    found, at = cells.values_at(frame, np.concatenate([events[c].to_numpy(np.int64) for c in quartet]),
                                ("x", "y", "is_border"))
    xy = np.stack([at["x"], at["y"]], axis=-1).reshape(4, -1, 2).transpose(1, 0, 2)  # event, cell, (x, y)
    flag = (found & at["is_border"]).reshape(4, -1).T.any(axis=1)
    centre = _centre(xy, box)
    return centre[:, 0], centre[:, 1], flag


def _events_table(raw, cells, box, censor):
    """The ``events`` table of the raw T1s of :func:`find_t1`: classified, placed, numbered."""
    events = classify_t1(raw, cells.last_frame(), censor)
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
    cells = cell_frames(cells)
    frames = _movie_frames(edges, cells, min_length)
    raw = _find_t1(frames, _ids(edges, cells), _held_frames(edges, cells))
    return _events_table(raw, cells, box, default_censor(cells.last_frame() + 1) if censor is None else censor)


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
    cells = cell_frames(cells)
    changes = _changes(cells)

    def contacts():  # each frame's contacts, to the per-cell lists as they go to the quartet search
        for f, tracks, a, b, length in _movie_frames(edges, cells, min_length):
            changes.add(_lists(f, tracks, a, b))
            yield f, tracks, a, b, length

    raw = _find_t1(contacts(), _ids(edges, cells), _held_frames(edges, cells))
    release_freed_memory()  # the contacts' freed working set would stay resident under the two tables' own
    return _events_table(raw, cells, box, censor), _neighbour_table(changes, cells, censor)
