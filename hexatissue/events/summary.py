"""Per-cell statistics of the events, intervals between a cell's intercalations, and the events stage's
summary.
"""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from ..errors import HexatissueWarning, InputError, user_stacklevel
from ..geometry import in_sorted
from ..schema import track_ids, validate
from .classify import CYCLE, INTERCALATION, T1_KINDS, UNRESOLVED


def _participants(events: pd.DataFrame) -> dict:
    """One entry per (event, cell taking part), as arrays: ``track``, ``kind``, ``duration``, ``frame``.

    Quartet events (:func:`detect_t1`) have four cells, ``cell_a``..``cell_d``;
    per-cell events (:func:`neighbour_events`) have one, ``track``.  ``kind``
    is the code of :data:`T1_KINDS` (-1 for any other value); ``frame`` is
    the event's ``frame_start``.  Codes, not strings: each string operation
    on tens of thousands of rows goes through Arrow, whose allocator keeps
    several MB of it resident.
    """
    columns = ("cell_a", "cell_b", "cell_c", "cell_d") if "cell_a" in events.columns else ("track",)
    for col in columns + ("kind", "frame_start", "duration"):
        if col not in events.columns:
            raise InputError(f"events table is missing column {col!r}; expected the output of detect_t1 or "
                             f"neighbour_events")
    names = events["kind"].to_numpy(object, na_value="")
    kind = np.full(len(names), -1, np.int8)
    for code, name in enumerate(T1_KINDS):
        kind[names == name] = code
    return {"track": np.concatenate([events[c].to_numpy(np.int64) for c in columns]),
            "kind": np.tile(kind, len(columns)), "duration": np.tile(events["duration"].to_numpy(float), len(columns)),
            "frame": np.tile(events["frame_start"].to_numpy(np.int64), len(columns))}


def intercalation_intervals(events: pd.DataFrame) -> pd.DataFrame:
    """Frames between consecutive intercalations of each cell.

    Only ``intercalation`` events count (cycles are undone; unresolved ones
    are censored).  The time of an intercalation is its ``frame_start``.
    ``events`` may be quartet events (:func:`detect_t1`: all four cells take
    part) or per-cell events (:func:`neighbour_events`).

    Returns
    -------
    pandas.DataFrame
        ``track``, ``frame_prev``, ``frame_next`` (frames), ``interval`` (frames).
    """
    long = _participants(events)
    chosen = long["kind"] == INTERCALATION
    track, frame = long["track"][chosen], long["frame"][chosen]
    order = np.lexsort((frame, track))  # by track, then frame, stable
    track, frame = track[order], frame[order]
    same = track[1:] == track[:-1]
    return pd.DataFrame({"track": track[:-1][same], "frame_prev": frame[:-1][same], "frame_next": frame[1:][same],
                         "interval": frame[1:][same] - frame[:-1][same]})


def _per_track(tracks, track, chosen, values=None):
    """Count (``values`` None) or mean of ``values`` over the ``chosen`` entries of each of the sorted ``tracks``.

    Entries whose ``track`` is not in ``tracks`` are left out; a mean over
    no entry (or only NaN values) is NaN.
    """
    at = np.searchsorted(tracks, track)
    chosen = chosen & in_sorted(track, tracks)
    if values is None:
        return np.bincount(at[chosen], minlength=len(tracks)).astype(np.int64)
    chosen &= ~np.isnan(values)
    count = np.bincount(at[chosen], minlength=len(tracks))
    total = np.bincount(at[chosen], weights=values[chosen], minlength=len(tracks))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def cell_event_stats(events: pd.DataFrame, cells: pd.DataFrame | None = None, lineage: pd.DataFrame | None = None
                     ) -> pd.DataFrame:
    """Per-cell T1 statistics (columns: ``hexatissue.schema.TABLES["cell_events"]``).

    Parameters
    ----------
    events : pandas.DataFrame
        Quartet events (:func:`detect_t1`) or per-cell events (:func:`neighbour_events`).
    cells : pandas.DataFrame, optional
        With ``frame`` and ``track`` (or ``cell``): every cell gets a row,
        also those without events, and ``n_frames`` is filled.
    lineage : pandas.DataFrame, optional
        The movie's lineage (:func:`hexatissue.track.lineage_table`), in place
        of ``cells``: its ``track`` and ``n_frames`` (rows per track) are the same.

    Returns
    -------
    pandas.DataFrame
        ``track``, ``n_frames``, ``n_cycles``, ``n_intercalations``,
        ``n_unresolved``, ``mean_cycle_period`` (frames), ``n_intervals``,
        ``mean_intercalation_interval`` (frames).
    """
    long = _participants(events)
    if lineage is not None:
        order = np.argsort(lineage["track"].to_numpy(np.int64), kind="stable")
        tracks, n_frames = lineage["track"].to_numpy(np.int64)[order], lineage["n_frames"].to_numpy(np.int64)[order]
    elif cells is not None:  # rows per track: a sort of one column (a hash table of it costs far more)
        tracks, n_frames = np.unique(track_ids(cells), return_counts=True)
    else:
        tracks = np.unique(long["track"])
        n_frames = np.zeros(len(tracks))
    out = pd.DataFrame({"track": tracks, "n_frames": n_frames.astype(np.int64)})
    track, kind = long["track"], long["kind"]
    for code, col in ((CYCLE, "n_cycles"), (INTERCALATION, "n_intercalations"), (UNRESOLVED, "n_unresolved")):
        out[col] = _per_track(tracks, track, kind == code)
    out["mean_cycle_period"] = _per_track(tracks, track, kind == CYCLE, long["duration"])
    iv = intercalation_intervals(events)
    every = np.ones(len(iv), bool)
    out["n_intervals"] = _per_track(tracks, iv["track"].to_numpy(), every)
    out["mean_intercalation_interval"] = _per_track(tracks, iv["track"].to_numpy(), every,
                                                    iv["interval"].to_numpy(float))
    return validate(out, "cell_events")


#: Warning when the censoring window leaves no T1 to count as an intercalation.
NO_INTERCALATION = ("no T1 event is classified as an intercalation: every T1 that is not undone starts within the "
                    "censoring window of the movie's end and is unresolved (see EventOptions.censor and "
                    "movie.summary['events'])")


def events_summary(events, censor, given, n_frames, vertices=None):
    """Censoring window used (``given`` by the user, or the default rule), the number of events of each kind,
    and what the network could not resolve: the contacts held as four-fold vertices.

    ``vertices``: the movie's vertices table, or an iterable of its chunks
    (each a table of the same columns); with its ``n_merged`` column
    (label input), ``n_held_contacts`` counts the contact-frames of junctions
    shorter than ``merge_distance`` held as four-fold (or higher) vertices,
    summed over frames, and ``n_held_vertices`` the vertex-frames holding
    them (a T1 whose new junction never grows past ``merge_distance`` is one
    of these, not an event); both None without that column.
    ``n_one_frame_cycles``: cycles of one frame (``duration`` 1: a-b lost and
    c-d gained in one frame, undone in the next), the doubtful T1s of a
    segmented movie (docs/t1.md, *T1 counts on real data*).  Warns
    (:class:`HexatissueWarning`) when no T1 is an intercalation because every
    one that is not undone is unresolved.
    """
    counts = events["kind"].astype(str).value_counts()
    n = {kind: int(counts.get(kind, 0)) for kind in ("cycle", "intercalation", "unresolved")}
    if n["unresolved"] and not n["intercalation"]:
        warnings.warn(NO_INTERCALATION, HexatissueWarning, stacklevel=user_stacklevel())
    rule = "given" if given else "min(10, max(1, n_frames // 5))"
    held = None if vertices is None else _held_counts([vertices] if isinstance(vertices, pd.DataFrame) else vertices)
    return {"censor": int(censor), "censor_rule": rule, "n_frames": int(n_frames), "n_events": int(len(events)),
            "n_cycles": n["cycle"], "n_intercalations": n["intercalation"], "n_unresolved": n["unresolved"],
            "n_classified": n["cycle"] + n["intercalation"],
            "n_one_frame_cycles": int(((events["kind"].astype(str) == "cycle")
                                       & (events["duration"].to_numpy(float) == 1)).sum()),
            "n_held_contacts": None if held is None else held[0],
            "n_held_vertices": None if held is None else held[1]}


def _held_counts(chunks):
    """``(contacts, vertices)`` held as four-fold vertices, summed over the vertices tables ``chunks``; None
    when they have no ``n_merged`` column."""
    contacts = vertices = 0
    for table in chunks:
        if "n_merged" not in table.columns:
            return None
        merged = table["n_merged"].to_numpy(np.int64)
        contacts, vertices = contacts + int(merged.sum()), vertices + int((merged > 0).sum())
    return contacts, vertices
