"""Tracking scored against exact truth (a :class:`hexatissue.synthetic.FlowingMovie`, or ids known per frame)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ..mesh.labels import touches_outside
from ..track import lineage_table

__all__ = ["score_tracking", "clone_growth"]


def score_tracking(tracks: pd.DataFrame, parents: dict, truth: dict, labels, true_parents=None,
                   true_extruded=None) -> dict:
    """How many of the true frame-to-frame links a tracking kept, and what it reported that did not happen.

    Parameters
    ----------
    tracks : pandas.DataFrame
        ``frame``, ``cell`` (label id), ``track``.
    parents : dict
        ``{daughter track: mother track}`` found.
    truth : dict
        ``{(frame, label id): identity}``: the cell's true identity (a seed, a curated id).
    labels : sequence of (rows, cols) int arrays
        The frames (to tell border cells: touching 0 or the image edge).
    true_parents : dict, optional
        ``{daughter identity: mother identity}``.
    true_extruded : dict, optional
        ``{identity: last frame}`` of the cells that truly leave inside the tissue.

    Returns
    -------
    dict
        ``links`` (true links between consecutive frames), ``kept`` (share of
        them the tracking made), ``false_links`` (links made that are not
        true, count), ``interior_extrusions`` and ``interior_appearances``
        (tracks ending / starting inside the tissue, not by division, less the
        true extrusions; counts), ``divisions`` (true), ``divisions_found``
        (found with the right mother and daughters), ``divisions_false``.
    """
    missing = [k for k in zip(tracks["frame"].tolist(), tracks["cell"].tolist()) if k not in truth]
    if missing:
        raise InputError(f"truth has no identity for {len(missing)} cells, e.g. (frame, cell) {missing[0]}")
    frame = tracks["frame"].to_numpy(np.int64)
    ident = np.array([truth[k] for k in zip(frame.tolist(), tracks["cell"].tolist())], np.int64)
    track = tracks["track"].to_numpy(np.int64)
    true_links, made = set(), set()
    by_frame = {t: (ident[frame == t], track[frame == t]) for t in np.unique(frame).tolist()}
    for t in sorted(by_frame)[1:]:
        if t - 1 not in by_frame:
            continue
        (ia, ta), (ib, tb) = by_frame[t - 1], by_frame[t]
        true_links |= {(t, x) for x in np.intersect1d(ia, ib).tolist()}
        common, pa, pb = np.intersect1d(ta, tb, return_indices=True)
        made |= {(t, int(ia[p]), int(ib[q])) for p, q in zip(pa.tolist(), pb.tolist())}
    right = {(t, x) for t, x, y in made if x == y}
    border = np.concatenate([np.isin(by, touches_outside(np.asarray(labels[t])))
                             for t, by in ((t, tracks.loc[frame == t, "cell"].to_numpy()) for t in sorted(by_frame))])
    order = np.argsort(frame, kind="stable")
    lineage = lineage_table(tracks.iloc[order].reset_index(drop=True), parents, border)
    true_ext = len(true_extruded or {})
    n_ext = int((lineage["end"] == "extrusion").sum())
    n_app = int((lineage["begin"] == "appearance").sum())
    # divisions: a found division is right when its mother's last cell and its daughters' first cells are the
    # true mother and daughters
    first = tracks.assign(ident=ident).sort_values("frame").groupby("track")["ident"]
    first_id, last_id = first.first().to_dict(), first.last().to_dict()
    true_parents = true_parents or {}
    found = {}
    for d, m in parents.items():
        found.setdefault(m, []).append(d)
    good = 0
    for m, ds in found.items():
        want = {first_id.get(d) for d in ds}
        if all(true_parents.get(x) == last_id.get(m) for x in want) and len(want) == 2:
            good += 1
    return {"links": len(true_links), "kept": len(right) / len(true_links) if true_links else float("nan"),
            "false_links": len(made) - len(right), "interior_extrusions": n_ext - true_ext,
            "interior_appearances": n_app, "divisions": len(set(true_parents.values())),
            "divisions_found": good, "divisions_false": len(found) - good}


def clone_growth(cells: pd.DataFrame, lineage: pd.DataFrame, start: int, end: int) -> tuple[float, int]:
    """The growth of the cells of frame ``start`` and their daughters up to frame ``end``: log area ratio.

    Only clones that stay inside the tissue are counted: their first cell is
    not a border cell and none of their cells touches the border or is
    extruded from ``start`` to ``end``.  This is what the deformation
    budget's cumulative ``total_iso`` over the same intervals must equal on a
    uniformly growing tissue.

    Returns
    -------
    growth : float
        ``log(sum of the clones' areas at end / their areas at start)``, dimensionless.
    clones : int
        Clones counted.
    """
    parent = dict(zip(lineage["track"].tolist(), lineage["parent"].tolist()))

    def root(k):
        seen = set()
        while parent.get(k, 0) > 0 and k not in seen:
            seen.add(k)
            k = parent[k]
        return k

    part = cells[(cells["frame"] >= start) & (cells["frame"] <= end)]
    roots = np.array([root(k) for k in part["track"].tolist()])
    first = (part["frame"] == start).to_numpy()
    border = part["is_border"].to_numpy(bool)
    extruded = {root(k) for k in lineage.loc[lineage["end"] == "extrusion", "track"].tolist()}
    keep = np.setdiff1d(roots[first & ~border], np.r_[roots[border], np.fromiter(extruded, np.int64, len(extruded))])
    area = part["area"].to_numpy(float)
    a0 = area[first & np.isin(roots, keep)].sum()
    a1 = area[(part["frame"] == end).to_numpy() & np.isin(roots, keep)].sum()
    return float(np.log(a1 / a0)) if a0 > 0 else float("nan"), int(len(keep))
