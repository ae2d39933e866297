"""Pair events of tracked defects (:func:`defect_events`; :class:`PairEvents`, gathered frame by frame): a +/- pair
created or annihilated, a lone defect appearing or disappearing.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..box import as_box
from ..errors import InputError, check_positive
from ..schema import require_columns, rows_by_frame, string_column, validate
from .tracking import _charge_keys, _match, _track_ends


#: the ``kind`` of a defect event, alphabetical (events carry its index until their table is built)
EVENT_KINDS = ("annihilation", "appearance", "creation", "disappearance")
_KIND_CODES = {name: code for code, name in enumerate(EVENT_KINDS)}


def _pair_ends(xy, charge, pair_distance, box):
    """Positions in one frame's ends: positive matched to negative (charges cancelling) within ``pair_distance``."""
    keys = _charge_keys(charge)
    ia, ib = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for key in np.unique(keys[keys > 0]):  # each charge q pairs with -q only: independent matchings
        pos, neg = np.flatnonzero(keys == key), np.flatnonzero(keys == -key)
        i, j = _match(xy[pos], xy[neg], pair_distance, box)
        ia.append(pos[i])
        ib.append(neg[j])
    ia, ib = np.concatenate(ia), np.concatenate(ib)
    order = np.argsort(ia, kind="stable")  # in row order of the positive ends
    return ia[order], ib[order]


def defect_events(tracked, pair_distance, box=None, time_column="frame", include_unpaired=False, frames=None):
    """Creation and annihilation of +- defect pairs from tracked defects.

    A track that starts after the first frame of the movie is a birth and one
    that ends before the last frame is a death.  In each frame, births are
    paired (positive with negative, charges summing to zero, within
    ``pair_distance``) by optimal assignment into *creation* events, and
    deaths likewise into *annihilation* events.  Births and deaths without a
    partner (a defect entering or leaving an open image, or a linking
    failure) are ``appearance`` / ``disappearance`` events, reported only if
    ``include_unpaired``.

    Parameters
    ----------
    tracked : pandas.DataFrame
        Output of :func:`track_defects` (columns ``time_column``, ``x``,
        ``y``, ``charge``, ``track``).
    pair_distance : float
        Largest separation of the two partners, px (typically the
        ``max_distance`` used for tracking, or a few grid spacings).
    box : Box, optional
        Periodic box for minimum-image distances and midpoints.
    time_column : str
        Column giving the time point.
    include_unpaired : bool
        Also report unpaired births and deaths.
    frames : array_like, optional
        Every time point of the movie.  Only its first and last entries
        matter: tracks starting at the first or ending at the last frame are
        not events.  Default: the first and last frames present in
        ``tracked`` (so a pair annihilating just before a final frame without
        any defect would be missed; pass ``frames`` to catch it).

    Returns
    -------
    pandas.DataFrame
        One row per event, sorted by time: ``time_column`` (for a creation:
        the first frame in which the pair exists; for an annihilation: the
        last frame in which it exists), ``kind`` (``"creation"``,
        ``"annihilation"``, and if requested ``"appearance"``,
        ``"disappearance"``), ``x``, ``y`` (px: pair midpoint, minimum image,
        wrapped into a periodic box; the defect itself for unpaired events),
        ``track_plus``, ``track_minus`` (track ids of the positive and
        negative partners; -1 when absent), ``separation`` (px, distance
        between the partners; NaN when unpaired).
    """
    require_columns(tracked, (time_column, "x", "y", "charge", "track"), "tracked")
    events = PairEvents(pair_distance, box, time_column, include_unpaired)
    if len(tracked) == 0:
        return events.table()
    span = tracked[time_column].to_numpy() if frames is None else np.asarray(frames)
    if len(span) == 0:
        raise InputError("frames must list at least one time point")
    t_first, t_last = span.min(), span.max()
    for first in (True, False):
        ends = _track_ends(tracked, time_column, first).reset_index(drop=True)
        ends = ends[ends[time_column] != (t_first if first else t_last)]
        times = ends[time_column].to_numpy()
        xy = ends[["x", "y"]].to_numpy(float)
        charge, track = ends["charge"].to_numpy(float), ends["track"].to_numpy(np.int64)
        for at in rows_by_frame(times).values():  # one frame's births (or deaths) at a time, as arrays
            events.add(times[at[0]], first, xy[at], charge[at], track[at])
    return events.table()


class PairEvents:
    """The events of :func:`defect_events` gathered one frame's births or deaths at a time, then made a table.

    What a movie's defects linked chunk by chunk of frames give: each
    frame's births and deaths are paired as they are found, and only the
    events are kept (the arrays of every :attr:`MERGE_PARTS` frames' births
    or deaths concatenated into one block: a long movie's many thousands of
    small arrays would cost more than their values).

    Parameters
    ----------
    pair_distance : float
        Largest separation of the two partners, px.
    box : Box, optional
        Periodic box for minimum-image distances and midpoints.
    time_column : str
        Name of the time column of the table.
    include_unpaired : bool
        Also keep unpaired births and deaths.
    """

    #: Parts (one frame's events of one kind) gathered before they are concatenated into one block.
    MERGE_PARTS = 256

    def __init__(self, pair_distance, box=None, time_column="frame", include_unpaired=False):
        self.box = as_box(box)
        check_positive(pair_distance, "pair_distance", unit="px")
        self.pair_distance, self.time_column, self.include_unpaired = pair_distance, time_column, include_unpaired
        self._blocks = []  # the columns of many frames' events (lists of arrays, in _event_columns' order)
        self._parts = []  # the columns of each frame's events of each kind since the last block

    def add(self, t, first, xy, charge, track):
        """The births (``first``) or deaths at time ``t`` of the tracks ``track``: their positions ``xy`` (n, 2;
        px) and charges at that time, in row order; all of one time's births (or deaths) in one call, since they
        are paired among themselves."""
        if not len(track):
            return
        kind, lone = ((_KIND_CODES["creation"], _KIND_CODES["appearance"]) if first else
                      (_KIND_CODES["annihilation"], _KIND_CODES["disappearance"]))
        ip, ineg = _pair_ends(xy, charge, self.pair_distance, self.box)
        self._parts.append(_pair_rows(xy, track, ip, ineg, t, kind, self.box))
        if self.include_unpaired:
            alone = np.setdiff1d(np.arange(len(track)), np.r_[ip, ineg])
            self._parts.append(_lone_rows(xy[alone], charge[alone], track[alone], t, lone))
        if len(self._parts) >= self.MERGE_PARTS:
            self._merge()

    def _merge(self):
        if self._parts:
            self._blocks.append([np.concatenate(column) for column in zip(*self._parts)])
            self._parts = []

    def take_columns(self):
        """The events gathered, sorted as the table is, as a dict of numpy columns (``kind``: the index in
        :data:`EVENT_KINDS`), or None without any; the gatherer is left empty, its arrays let go column by column
        as the sorted ones are made.

        Sorted by time, kind (whose codes sort as the names do), x, y (a
        stable sort): the rows of one time and kind come from one frame's
        pairing, so the order in which frames were added is not seen.
        """
        self._merge()
        blocks, self._blocks = self._blocks, []
        if not sum(len(block[0]) for block in blocks):
            return None

        def column(k):
            values = np.concatenate([block[k] for block in blocks])
            for block in blocks:
                block[k] = None
            return values

        names = [self.time_column, "kind", "x", "y", "track_plus", "track_minus", "separation"]
        key = [column(k) for k in range(4)]  # time, kind, x, y
        order = np.lexsort(key[::-1])
        out = {}
        for k, name in enumerate(names):
            out[name] = (key[k] if k < 4 else column(k))[order]
            if k < 4:
                key[k] = None
        return out

    def table(self) -> pd.DataFrame:
        """The events gathered, one row each, as :func:`defect_events` returns them (the gatherer is left
        empty)."""
        cols = self.take_columns()
        if cols is None:
            return _empty_events([self.time_column, "kind", "x", "y", "track_plus", "track_minus", "separation"],
                                 self.time_column)
        cols["kind"] = string_column(cols["kind"], EVENT_KINDS)  # the names made a column once, in order
        out = pd.DataFrame(cols, copy=False)
        return validate(out, "defect_events") if self.time_column == "frame" else out


def _event_columns(t, kind, x, y, track_plus, track_minus, separation):
    """One frame's events of one kind as the columns of :func:`defect_events` (``t`` and the :data:`EVENT_KINDS`
    code ``kind`` repeated)."""
    return (np.full(len(x), t), np.full(len(x), kind, np.int8), x, y, track_plus, track_minus, separation)


def _pair_rows(xy, track, ip, ineg, t, kind, box):
    d = xy[ineg] - xy[ip]
    if box is not None:
        d = box.min_image(d)
    mid = xy[ip] + d / 2
    if box is not None:
        mid = box.wrap(mid)
    return _event_columns(t, kind, mid[:, 0], mid[:, 1], track[ip], track[ineg], np.hypot(d[:, 0], d[:, 1]))


def _lone_rows(xy, charge, track, t, kind):
    plus = charge > 0
    return _event_columns(t, kind, xy[:, 0], xy[:, 1], np.where(plus, track, -1), np.where(plus, -1, track),
                          np.full(len(xy), np.nan))


def _empty_events(columns, time_column):
    out = pd.DataFrame({c: pd.Series(dtype=float) for c in columns})
    out["kind"] = out["kind"].astype("string")
    for c in ("track_plus", "track_minus"):
        out[c] = out[c].astype(np.int64)
    return out
