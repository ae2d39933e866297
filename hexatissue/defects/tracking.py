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
    pair creation and annihilation show up (see :func:`defect_events`).  A
    movie too long to hold its defects at once is linked a chunk of frames at
    a time by a :class:`DefectLinker`, with the same tracks.

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
    linker = DefectLinker(max_distance, box)
    track = linker.link(defects[time_column].to_numpy(), defects[["x", "y"]].to_numpy(float),
                        defects["charge"].to_numpy(float), frames)
    return defects.assign(track=track)  # a new table sharing the given columns until either is modified


class DefectLinker:
    """Defects linked into tracks frame after frame, a chunk of frames at a time (what :func:`track_defects` runs).

    Between calls of :meth:`link` it keeps what linking the next frames
    needs: the last frame linked, its defects (positions, charges, tracks)
    and the number of tracks so far.  Linking a movie's frames chunk by chunk,
    in order, therefore gives exactly the tracks of :func:`track_defects` on
    the whole movie, while only a chunk's defects are in memory.

    Parameters
    ----------
    max_distance : float
        Largest displacement of a defect between consecutive frames, px.
    box : Box, optional
        Periodic box for minimum-image distances; None for an open image.

    Attributes
    ----------
    n_tracks : int
        Tracks started so far (the next track's id).
    last_frame : int or None
        The last frame linked (None before the first).

    Examples
    --------
    >>> linker = DefectLinker(max_distance=3.0)
    >>> linker.link([0, 0], [[1.0, 1.0], [9.0, 9.0]], [0.5, -0.5]).tolist()
    [0, 1]
    >>> linker.link([1, 2], [[2.0, 1.0], [3.0, 1.0]], [0.5, 0.5], frames=[1, 2]).tolist()
    [0, 0]
    """

    def __init__(self, max_distance, box=None):
        self.box = as_box(box)
        check_positive(max_distance, "max_distance", unit="px")
        self.max_distance = max_distance
        self.n_tracks = 0
        self.last_frame = None
        self._forget()

    def _forget(self):
        """No defects in the last frame: the next frame's start new tracks."""
        self._xy, self._keys, self._track = np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64)

    def restart(self):
        """Link the next frame to nothing (an unrelated image): its defects start new tracks; ids go on."""
        self._forget()
        self.last_frame = None

    def link(self, times, xy, charge, frames=None):
        """Track ids of the next frames' defects.

        Parameters
        ----------
        times : array_like of int
            Each defect's frame; every frame after :attr:`last_frame`.
        xy : array_like, shape (n, 2)
            Positions (x, y), px.
        charge : array_like of float
            Topological charges; only equal charges are linked.
        frames : array_like, optional
            The frames of this chunk, including those without defects
            (consecutive entries are linked, the first to :attr:`last_frame`);
            default: the distinct ``times``.

        Returns
        -------
        numpy.ndarray
            Each defect's track id (int64), in the order given.
        """
        times = np.asarray(times).reshape(-1)
        xy = np.asarray(xy, float).reshape(-1, 2)
        keys = _charge_keys(charge)
        if not len(times) == len(xy) == len(keys):
            raise InputError(f"times, xy and charge must have one entry per defect; got {len(times)}, {len(xy)} "
                             f"and {len(keys)}")
        sequence = _frame_sequence(times, frames)
        if self.last_frame is not None and len(sequence) and sequence[0] <= self.last_frame:
            raise InputError(f"frames must follow the last frame linked ({self.last_frame}); got {sequence[0]}")
        track = np.full(len(times), -1, np.int64)
        rows_of = rows_by_frame(times)
        empty = np.zeros(0, np.int64)
        for t in sequence:
            current = rows_of.get(t, empty)
            for key in np.unique(keys[current]):
                cur = current[keys[current] == key]
                before = self._keys == key
                ia, ib = _match(self._xy[before], xy[cur], self.max_distance, self.box)
                track[cur[ib]] = self._track[before][ia]
            new = current[track[current] < 0]
            track[new] = np.arange(self.n_tracks, self.n_tracks + len(new))
            self.n_tracks += len(new)
            self._xy, self._keys, self._track = xy[current], keys[current], track[current]
        if len(sequence):
            self.last_frame = sequence[-1]
        return track


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
