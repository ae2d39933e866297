"""Tension histories of the junctions that shrink into T1 events, by the events' kind."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ..schema import require_columns

__all__ = ["t1_tension_histories"]


def t1_tension_histories(events, edges, cells=None, before=10):
    """The tension of each T1's lost junction (cells a-b) in the frames before it is lost.

    Parameters
    ----------
    events : pandas.DataFrame
        The ``events`` table (:mod:`hexatissue.schema`): ``event``, ``kind``,
        ``frame_start``, ``cell_a``, ``cell_b`` (track ids).
    edges : pandas.DataFrame
        The movie's ``edges`` with ``frame``, ``cell_a``, ``cell_b``,
        ``length`` and ``tension`` (the mechanics stage).
    cells : pandas.DataFrame, optional
        The movie's ``cells`` with ``frame``, ``cell`` and ``track``: label ids
        of ``edges`` are translated to track ids.  Without it (or without
        ``track``) label ids are track ids.
    before : int
        Frames before ``frame_start`` to report (``frame_start - before`` to
        ``frame_start - 1``).

    Returns
    -------
    pandas.DataFrame
        One row per event and frame where cells a and b share a junction:
        ``event``, ``kind`` (cycle, intercalation, unresolved), ``frame``,
        ``lag`` (frames: ``frame - frame_start``, negative), ``length`` (px,
        summed over the a-b junctions of the frame), ``tension`` (relative,
        the frame's mean interior tension being 1: the length-weighted mean
        over those junctions; NaN if none has a tension).  Sorted by event and
        frame.
    """
    require_columns(events, ("event", "kind", "frame_start", "cell_a", "cell_b"), "events")
    require_columns(edges, ("frame", "cell_a", "cell_b", "length", "tension"), "edges")
    if isinstance(before, bool) or not isinstance(before, (int, np.integer)) or before < 1:
        raise InputError(f"before must be a positive integer (frames); got {before!r}")
    e = edges[["frame", "cell_a", "cell_b", "length", "tension"]].copy()
    if cells is not None and "track" in cells.columns:
        track = cells.set_index(["frame", "cell"])["track"]
        for side in ("cell_a", "cell_b"):
            e[side] = track.reindex(pd.MultiIndex.from_arrays([e["frame"], e[side]])).to_numpy()
        e = e.dropna(subset=["cell_a", "cell_b"])
    a, b = e["cell_a"].to_numpy(np.int64), e["cell_b"].to_numpy(np.int64)
    e["a"], e["b"] = np.minimum(a, b), np.maximum(a, b)
    t = e["tension"].to_numpy(float)
    has = np.isfinite(t)
    e["weighted"] = np.where(has, t * e["length"], 0.0)
    e["weight"] = np.where(has, e["length"], 0.0)
    pair = e.groupby(["frame", "a", "b"], as_index=False)[["length", "weighted", "weight"]].sum()
    ev = events[["event", "kind", "frame_start", "cell_a", "cell_b"]]
    ea, eb = ev["cell_a"].to_numpy(np.int64), ev["cell_b"].to_numpy(np.int64)
    lags = np.arange(-before, 0)
    want = pd.DataFrame({
        "event": np.repeat(ev["event"].to_numpy(np.int64), before),
        "kind": np.repeat(ev["kind"].astype(str).to_numpy(), before),
        "frame": np.repeat(ev["frame_start"].to_numpy(np.int64), before) + np.tile(lags, len(ev)),
        "lag": np.tile(lags, len(ev)),
        "a": np.repeat(np.minimum(ea, eb), before),
        "b": np.repeat(np.maximum(ea, eb), before),
    })
    out = want.merge(pair, on=["frame", "a", "b"], how="inner")
    out["tension"] = np.where(out["weight"] > 0, out["weighted"] / out["weight"].where(out["weight"] > 0, 1.0),
                              np.nan)
    out = out.sort_values(["event", "frame"]).reset_index(drop=True)
    out["kind"] = out["kind"].astype("string")
    return out[["event", "kind", "frame", "lag", "length", "tension"]]
