"""The lineage table and the plausibility checks of its divisions and extrusions."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError, is_real
from ..geometry import row_keys
from ..schema import validate


def lineage_table(tracks: pd.DataFrame, parents=None, is_border=None) -> pd.DataFrame:
    """One row per track: its frame span and how it begins and ends.

    Parameters
    ----------
    tracks : pandas.DataFrame
        Columns ``frame``, ``track`` (plus anything else).
    parents : dict, optional
        ``{daughter track: mother track}``.
    is_border : array of bool, optional
        Aligned with ``tracks``: the cell touches the image edge or the
        background.  Tracks starting (ending) on a border cell begin (end) as
        ``border``; otherwise ``appearance`` (``extrusion``).

    Returns
    -------
    pandas.DataFrame
        Columns described in ``hexatissue.schema.TABLES["lineage"]``: ``track``,
        ``frame_start``, ``frame_end`` (frames), ``n_frames``, ``parent``
        (0 = none), ``begin``, ``end``.
    """
    frame, track = tracks["frame"].to_numpy(np.int64), tracks["track"].to_numpy(np.int64)
    border = np.zeros(len(track), bool) if is_border is None else np.asarray(is_border, bool)
    span = (int(frame.min()), int(frame.max())) if len(frame) else (0, 0)
    return lineage_from_spans(track_spans(frame, track, border), parents, span)


def track_spans(frame, track, border) -> pd.DataFrame:
    """Each track's span over these rows of a movie: ``track``, ``frame_start``, ``frame_end``, ``n_frames``
    (rows), ``border_start``, ``border_end`` (the ``border`` flag of its first and last row), sorted by track.

    A track's first (last) row is the first (last) of its rows of its first
    (last) frame, in row order.  The spans of consecutive chunks of a movie
    join with :func:`join_spans`.
    """
    # rows in (track, frame) order, ties in row order: one index sort instead of a sorted copy and a groupby
    order = np.lexsort((frame, track))
    by_track = track[order]
    change = np.ones(len(order), bool)
    change[1:] = by_track[1:] != by_track[:-1]
    bounds = np.append(np.flatnonzero(change), len(order))
    first, last = order[bounds[:-1]], order[bounds[1:] - 1]  # each track's first and last row
    return pd.DataFrame({"track": by_track[bounds[:-1]], "frame_start": frame[first], "frame_end": frame[last],
                         "n_frames": np.diff(bounds), "border_start": border[first], "border_end": border[last]})


def join_spans(chunks) -> pd.DataFrame:
    """The :func:`track_spans` of a movie from those of its consecutive chunks of frames (in frame order)."""
    spans = pd.concat(list(chunks), ignore_index=True)
    order = np.lexsort((spans["frame_start"].to_numpy(), spans["track"].to_numpy()))  # a chunk's frames: its own
    spans = spans.iloc[order]
    track = spans["track"].to_numpy()
    start = np.r_[True, track[1:] != track[:-1]] if len(track) else np.zeros(0, bool)
    bounds = np.append(np.flatnonzero(start), len(track))
    first, last = bounds[:-1], bounds[1:] - 1
    return pd.DataFrame({"track": track[first], "frame_start": spans["frame_start"].to_numpy()[first],
                         "frame_end": spans["frame_end"].to_numpy()[last],
                         "n_frames": np.add.reduceat(spans["n_frames"].to_numpy(), first) if len(first)
                         else np.zeros(0, np.int64),
                         "border_start": spans["border_start"].to_numpy(bool)[first],
                         "border_end": spans["border_end"].to_numpy(bool)[last]})


def lineage_from_spans(spans, parents=None, frames=(0, 0)) -> pd.DataFrame:
    """:func:`lineage_table` from the tracks' :func:`track_spans` (the whole movie's), ``parents`` and the movie's
    first and last frame with a cell (``frames``)."""
    parents = parents or {}
    out = pd.DataFrame({"track": spans["track"].to_numpy(np.int64),
                        "frame_start": spans["frame_start"].to_numpy(np.int64),
                        "frame_end": spans["frame_end"].to_numpy(np.int64),
                        "n_frames": spans["n_frames"].to_numpy(np.int64)})
    out["parent"] = out["track"].map(parents).fillna(0).astype(np.int64)
    t0, t1 = frames
    mothers = set(parents.values())
    begin = np.where(spans["border_start"].to_numpy(bool), "border", "appearance").astype(object)
    begin[out["parent"].to_numpy() > 0] = "division"
    begin[out["frame_start"].to_numpy() == t0] = "movie_start"
    end = np.where(spans["border_end"].to_numpy(bool), "border", "extrusion").astype(object)
    end[out["track"].isin(mothers).to_numpy()] = "division"
    end[out["frame_end"].to_numpy() == t1] = "movie_end"
    out["begin"] = pd.array(begin, dtype="string")
    out["end"] = pd.array(end, dtype="string")
    return validate(out.reset_index(drop=True), "lineage")


def checked_tracks(lineage) -> np.ndarray:
    """The tracks whose areas :func:`check_divisions` and :func:`check_extrusions` look at (sorted): daughters,
    their mothers, and tracks that end by extrusion; the cells of the others can be left out of their ``cells``."""
    parent = lineage["parent"].to_numpy(np.int64)
    track = lineage["track"].to_numpy(np.int64)
    extruded = (lineage["end"].astype(str) == "extrusion").to_numpy()
    return np.unique(np.r_[track[parent > 0], parent[parent > 0], track[extruded]])


#: Why a division is suspect (``lineage.division_reason``, several joined by ``;``), in the order they are checked.
DIVISION_REASONS = {
    "mother_continues": "the mother's track goes on after its daughters start",
    "not_two_daughters": "the mother has one daughter or more than two",
    "late_daughter": "a daughter starts more than max_delay frames after the mother's last frame",
    "area_mismatch": "the daughters' areas at their first frame do not sum to the mother's at its last, within "
                     "area_tolerance",
    "short_daughter": "a daughter ends (border, extrusion or division) before min_frames frames",
    "unconfirmed": "a daughter reaches the movie's end before min_frames frames: its persistence cannot be checked",
    "redivision": "the mother was born by a division fewer than min_cycle frames before, or a daughter divides "
                  "again within min_cycle frames",
}


def check_divisions(lineage: pd.DataFrame, cells: pd.DataFrame, min_frames: int = 3, min_cycle: int = 5,
                    area_tolerance: float = 0.4, max_delay: int = 1) -> pd.DataFrame:
    """The lineage with every division checked against what a division must look like.

    A division is kept as found; its two daughter rows are marked suspect
    when the mother does not end before them, it does not have two
    daughters, a daughter starts more than ``max_delay`` frames after the
    mother's last frame, the daughters' first-frame areas do not sum to the
    mother's last-frame area within ``area_tolerance`` (as a fraction of it),
    a daughter lasts fewer than ``min_frames`` frames (or reaches the end of
    the movie before: unconfirmed), or the mother was itself born by a
    division fewer than ``min_cycle`` frames before or a daughter divides
    again within ``min_cycle`` frames (:data:`DIVISION_REASONS`).  An
    over-segmented cell split for a frame or two, or two cells merged then
    split by the overlap tracker, fails these; a real division passes them.

    Parameters
    ----------
    lineage : pandas.DataFrame
        :func:`lineage_table` (``track``, ``frame_start``, ``frame_end``,
        ``n_frames``, ``parent``, ``end``).
    cells : pandas.DataFrame
        ``frame``, ``track``, ``area`` (px).
    min_frames : int
        Frames a daughter must be present.
    min_cycle : int
        Shortest cell cycle, frames: from a cell's first frame (it was born
        by a division) to the first frame of its own daughters.
    area_tolerance : float
        Largest ``|daughters' area / mother's area - 1|``.
    max_delay : int
        Largest ``daughter frame_start - mother frame_end`` (1: the next frame).

    Returns
    -------
    pandas.DataFrame
        ``lineage`` with ``division_area_ratio`` (the daughters' summed area at
        their first frame over the mother's at its last frame, on daughter rows;
        NaN elsewhere, dimensionless), ``division_suspect`` (bool, daughter rows)
        and ``division_reason`` (the :data:`DIVISION_REASONS` keys that apply,
        joined by ``;``; empty when plausible or not a daughter).
    """
    for name, value in (("min_frames", min_frames), ("min_cycle", min_cycle), ("max_delay", max_delay)):
        if isinstance(value, bool) or int(value) != value or value < 0:
            raise InputError(f"{name} must be a non-negative integer number of frames; got {value!r}")
    if not is_real(area_tolerance) or area_tolerance < 0:
        raise InputError(f"area_tolerance must be a finite fraction >= 0; got {area_tolerance!r}")
    out = lineage.copy()
    n = len(out)
    ratio, reasons = np.full(n, np.nan), [[] for _ in range(n)]
    track = out["track"].to_numpy(np.int64)
    parent = out["parent"].to_numpy(np.int64)
    start, end = out["frame_start"].to_numpy(np.int64), out["frame_end"].to_numpy(np.int64)
    ending = out["end"].astype(str).to_numpy()
    row_of = dict(zip(track.tolist(), range(n)))
    area = _areas_at(cells, track, start, end)
    daughters = np.flatnonzero(parent > 0)
    for mother, rows in pd.Series(daughters).groupby(parent[daughters]):
        rows = rows.to_numpy()
        m = row_of.get(int(mother))
        why = []
        if m is None or end[m] >= start[rows].min():
            why.append("mother_continues")
        if len(rows) != 2:
            why.append("not_two_daughters")
        if m is not None and (start[rows] - end[m] > max_delay).any():
            why.append("late_daughter")
        if m is not None:
            ratio[rows] = area[1][rows].sum() / area[0][m]
            if not abs(ratio[rows[0]] - 1) <= area_tolerance:
                why.append("area_mismatch")
        young = (end - start + 1)[rows] < min_frames
        if (young & (ending[rows] != "movie_end")).any():
            why.append("short_daughter")
        if (young & (ending[rows] == "movie_end")).any():
            why.append("unconfirmed")
        again = (ending[rows] == "division") & (end[rows] + 1 - start[rows] < min_cycle)
        if (m is not None and parent[m] > 0 and end[m] + 1 - start[m] < min_cycle) or again.any():
            why.append("redivision")
        for r in rows.tolist():
            reasons[r] = why
    out["division_area_ratio"] = ratio
    out["division_suspect"] = np.array([bool(r) for r in reasons])
    out["division_reason"] = pd.array([";".join(r) for r in reasons], dtype="string")
    return validate(out, "lineage")


#: An extrusion is confirmed when the cell's area at its last frame is at most this fraction of its median area
#: over its track: an extruding cell constricts apically before it leaves the surface.
EXTRUSION_SHRINK = 0.5


def check_extrusions(lineage: pd.DataFrame, cells: pd.DataFrame, shrink: float = EXTRUSION_SHRINK) -> pd.DataFrame:
    """The lineage with every interior extrusion checked: did the cell shrink before it left?

    A cell that ends inside the tissue (``end == "extrusion"``) with its
    last-frame area at most ``shrink`` times its median area over its track
    is a confirmed extrusion; one that vanishes at its usual size (or is seen
    in a single frame) is unconfirmed: as likely a cell the tracking lost, or
    a segmentation error, as a cell that left the tissue.

    Parameters
    ----------
    lineage : pandas.DataFrame
        :func:`lineage_table` (``track``, ``frame_start``, ``frame_end``, ``end``).
    cells : pandas.DataFrame
        ``frame``, ``track``, ``area`` (px).
    shrink : float
        Largest last-frame area of a confirmed extrusion, as a fraction of the track's median area.

    Returns
    -------
    pandas.DataFrame
        ``lineage`` with ``extrusion_area_ratio`` (last-frame area over the
        median area of the track, on extrusion rows; NaN elsewhere,
        dimensionless) and ``extrusion_unconfirmed`` (bool: an extrusion whose
        ratio is above ``shrink``, or NaN: a single frame).
    """
    if not is_real(shrink) or not 0 < shrink < 1:
        raise InputError(f"shrink must be a fraction in (0, 1); got {shrink!r}")
    out = lineage.copy()
    track = out["track"].to_numpy(np.int64)
    ext = (out["end"].astype(str) == "extrusion").to_numpy()
    median = cells.groupby("track")["area"].median()
    last = _areas_at(cells, track, out["frame_start"].to_numpy(np.int64), out["frame_end"].to_numpy(np.int64))[0]
    ratio = np.full(len(out), np.nan)
    one = out["n_frames"].to_numpy(np.int64) == 1
    keep = ext & ~one
    ratio[keep] = last[keep] / median.reindex(track[keep]).to_numpy(float)
    out["extrusion_area_ratio"] = ratio
    out["extrusion_unconfirmed"] = ext & ~(ratio <= shrink)
    return validate(out, "lineage")


def _areas_at(cells, track, start, end):
    """Each track's area (px) at its first frame and at its last, from ``cells`` (``frame``, ``track``, ``area``)."""
    keys = row_keys(cells["frame"].to_numpy(np.int64), cells["track"].to_numpy(np.int64))
    area = cells["area"].to_numpy(float)
    order = np.argsort(keys, kind="stable")
    keys, area = keys[order], area[order]

    def at(frame):
        wanted = row_keys(frame, track)
        pos = np.minimum(np.searchsorted(keys, wanted), max(len(keys) - 1, 0))
        found = (keys[pos] == wanted) if len(keys) else np.zeros(len(wanted), bool)
        return np.where(found, area[pos] if len(keys) else np.nan, np.nan)

    return at(end), at(start)


def division_rows(lineage: pd.DataFrame) -> pd.DataFrame:
    """One row per division of a checked lineage (:func:`check_divisions`).

    Returns
    -------
    pandas.DataFrame
        ``mother`` (track), ``frame`` (first frame of the daughters),
        ``daughter_a``, ``daughter_b`` (tracks; -1 when there is no second
        one), ``area_ratio`` (daughters' area over the mother's,
        dimensionless), ``suspect`` (bool), ``reason``.
    """
    d = lineage[lineage["parent"] > 0].sort_values(["parent", "track"])
    cols = {"mother": [], "frame": [], "daughter_a": [], "daughter_b": [], "area_ratio": [], "suspect": [],
            "reason": []}
    for mother, rows in d.groupby("parent", sort=True):
        ids = rows["track"].tolist()
        cols["mother"].append(int(mother))
        cols["frame"].append(int(rows["frame_start"].min()))
        cols["daughter_a"].append(ids[0])
        cols["daughter_b"].append(ids[1] if len(ids) > 1 else -1)
        first = rows.iloc[0]
        cols["area_ratio"].append(float(first.get("division_area_ratio", np.nan)))
        cols["suspect"].append(bool(first.get("division_suspect", False)))
        cols["reason"].append(str(first.get("division_reason", "")))
    out = pd.DataFrame(cols).astype({"mother": np.int64, "frame": np.int64, "daughter_a": np.int64,
                                     "daughter_b": np.int64, "area_ratio": float, "suspect": bool})
    return out.sort_values(["frame", "mother"], ignore_index=True)


def lineage_roots(parents: dict, ids) -> dict:
    """``{id: its first ancestor}`` following ``parents`` (``{child: parent}``) up from each of ``ids``.

    An id without a parent is its own root; a cycle (bad input) stops where it closes.
    """
    out = {}
    for i in ids:
        root, seen = int(i), set()
        while root in parents and root not in seen:
            seen.add(root)
            root = int(parents[root])
        out[int(i)] = root
    return out
