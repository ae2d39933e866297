"""Defects linked across frames into trajectories (:func:`track_defects`)."""
from __future__ import annotations

import numpy as np

from ..box import as_box
from ..errors import InputError, check_positive
from ..geometry import match_points
from ..schema import require_columns, rows_by_frame


def _match(a, b, max_distance, box):
    """Optimal one-to-one matching of points ``a`` to ``b`` within ``max_distance``; ``(ia, ib)``."""
    pairs = match_points(a, b, max_distance, box)
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]  # in the order of a
    return pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64)


def _charge_keys(charge):
    """Integer keys identifying equal charges (robust to float round-off)."""
    return np.round(np.asarray(charge, float) * 7_207_200).astype(np.int64)  # lcm(1..16) * 10


def _frame_sequence(times, frames):
    """Sorted frames to link consecutively; defects in frames not listed are an error."""
    present = np.unique(times)
    if frames is None:
        return present
    frames = np.unique(np.asarray(frames))
    if not np.isin(present, frames).all():
        raise InputError("frames must list every frame present in the defects table")
    return frames


def track_defects(defects, max_distance, box=None, time_column="frame", frames=None):
    """Link defects across consecutive frames into tracks.

    Between each pair of consecutive frames, defects of the same charge are
    matched one to one by optimal assignment
    (:func:`scipy.optimize.linear_sum_assignment`): among the matchings that
    link the most defects with every link shorter than ``max_distance``, the
    one of least total distance.  Distances are minimum-image in a periodic
    ``box``.  Defects left unmatched start (or end) a track, which is how
    pair creation and annihilation show up (see :func:`defect_events`).

    Parameters
    ----------
    defects : pandas.DataFrame
        Defects table with columns ``time_column``, ``x``, ``y`` (px; x =
        column, y = row, origin at the centre of pixel (0, 0)) and ``charge``.
    max_distance : float
        Largest displacement of a defect between consecutive frames, px.
    box : Box, optional
        Periodic box for minimum-image distances; None (or a non-periodic
        box) for an open image.
    time_column : str
        Column giving the time point (default ``"frame"``).
    frames : array_like, optional
        Every time point of the movie, including those without defects.
        Consecutive entries are linked; by default the sorted distinct values
        of ``time_column`` are (so a frame without any defect would be
        skipped over; pass ``frames`` to break tracks there).

    Returns
    -------
    pandas.DataFrame
        A copy of ``defects`` (same rows, same order) with an added ``track``
        column (int64): tracks are numbered from 0 in order of their first
        frame, then of row order.
    """
    require_columns(defects, (time_column, "x", "y", "charge"), "defects")
    box = as_box(box)
    check_positive(max_distance, "max_distance", unit="px")
    times = defects[time_column].to_numpy()
    xy = defects[["x", "y"]].to_numpy(float)
    keys = _charge_keys(defects["charge"].to_numpy(float))
    sequence = _frame_sequence(times, frames)
    track = np.full(len(defects), -1, np.int64)
    rows_of = rows_by_frame(times)
    empty = np.zeros(0, np.int64)
    previous = empty
    next_id = 0
    for t in sequence:
        current = rows_of.get(t, empty)
        for key in np.unique(keys[current]):
            cur = current[keys[current] == key]
            prev = previous[keys[previous] == key]
            ia, ib = _match(xy[prev], xy[cur], max_distance, box)
            track[cur[ib]] = track[prev[ia]]
        new = current[track[current] < 0]
        track[new] = np.arange(next_id, next_id + len(new))
        next_id += len(new)
        previous = current
    return defects.assign(track=track)  # a new table sharing the given columns until either is modified


def _track_ends(tracked, time_column, first):
    """One row per track: its first (``first=True``) or last frame, position and charge.

    The rows of ``tracked`` (index kept) in the order of a stable sort by
    time.  Found from one argsort of the time column, not a sorted copy of
    the table and a groupby (several copies of its columns on a movie's
    defects).
    """
    order = np.argsort(tracked[time_column].to_numpy(), kind="stable")
    track = tracked["track"].to_numpy()[order]
    if first:
        at = np.unique(track, return_index=True)[1]
    else:
        at = len(track) - 1 - np.unique(track[::-1], return_index=True)[1]
    return tracked.iloc[order[np.sort(at)]]
