"""The losses and gains of contacts paired into T1s: each loss and each gain in one T1 at most, the
intermediate four-fold vertex's runs of frames between them.
"""
from __future__ import annotations

import numpy as np
import pandas as pd


def _pair_losses_and_gains(losses, gains, lost, lengths=None):
    """The T1s of a movie's losses and gains: rows ``ab``, ``cd``, ``frame_lost``, ``frame_gain``.

    ``losses``: each contact a-b lost (``frame_lost``, ``next_ab`` the start
    of its next run) with each pair c-d of common neighbours just before;
    ``gains``: each contact c-d gained (``frame_gain``, ``prev_cd`` the stop
    of its previous run) with each pair a-b of common neighbours just after;
    ``lost``: every loss (``ab``, ``frame_lost``, ``next_ab``), also one with
    fewer than two common neighbours just before (its flanks changed in the
    same frame, a T1 next to a T1), whose quartet only the gain sees.  A gain
    with no quartet after it is never paired: c-d not flanked by a and b is
    not the junction that replaced a-b.
    A loss of a-b and a later (or simultaneous) gain of c-d are one T1 when
    neither contact touched in between (a four-fold vertex at most) and the
    quartet is seen on **either** side: c-d flanked a-b before the loss, or
    a-b flank c-d after the gain.  Requiring both sides loses T1s next to
    T1s: when two junctions that share a vertex swap in the same frame (or
    while the first one's four-fold vertex is held), the first T1's cells
    a, b are no longer both neighbours of c, d after the second, and the
    second's c, d did not both flank its a-b before the first.  Every loss
    and every gain is one T1 at most, matched greedily: quartets seen on both
    sides first, then quartets seen with contacts for flanks (``held``: a
    flank held at a four-fold vertex on every side it is seen from), then
    the shortest wait from loss to gain, then the earliest gain, then the
    shortest junctions (``lengths``: ``pair``, ``frame``, ``length``, the
    lost contact's length before its loss plus the new one's at its gain;
    a T1's junction shrinks to nothing and grows from it), so that two
    losses of one rosette seeing the same gain are told apart by the
    geometry (:func:`_match_once`).  The ids come last: the pairing does not
    depend on how the cells are numbered wherever the geometry decides.
    """
    keys = ["ab", "cd", "frame_lost", "next_ab", "frame_gain", "prev_cd", "held"]
    gained = gains.drop_duplicates(["cd", "frame_gain"])[["cd", "frame_gain", "prev_cd"]]
    # quartets seen before a loss, with every gain of their c-d; quartets seen after a gain, with every loss of a-b
    m = pd.concat([losses.merge(gained, on="cd")[keys], gains.merge(lost, on="ab")[keys]], ignore_index=True)
    m = m[(m["frame_gain"] >= m["frame_lost"]) & (m["next_ab"] > m["frame_gain"]) & (m["prev_cd"] <= m["frame_lost"])]
    m = m.groupby(["ab", "cd", "frame_lost", "frame_gain"], as_index=False, sort=False).agg(
        size=("held", "size"), held=("held", "min"))
    m = m.assign(wait=m["frame_gain"] - m["frame_lost"], one_side=m["size"] == 1, length=np.inf)
    if lengths is not None and len(m):
        at = pd.MultiIndex.from_arrays([lengths["pair"], lengths["frame"]])
        length = pd.Series(lengths["length"].to_numpy(float), index=at)
        before = length.reindex(pd.MultiIndex.from_arrays([m["ab"], m["frame_lost"]])).to_numpy(float)
        after = length.reindex(pd.MultiIndex.from_arrays([m["cd"], m["frame_gain"]])).to_numpy(float)
        m["length"] = np.nan_to_num(before + after, nan=np.inf)
    m = m.sort_values(["one_side", "held", "wait", "frame_gain", "length", "ab", "cd"], kind="stable",
                      ignore_index=True)
    return m[_match_once(m["ab"].to_numpy(np.int64), m["frame_lost"].to_numpy(np.int64),
                         m["cd"].to_numpy(np.int64), m["frame_gain"].to_numpy(np.int64))]


def _match_once(ab, lost, cd, gain):
    """Greedy matching in the given order: row k is kept unless its loss ``(ab, lost)`` or its gain
    ``(cd, gain)`` is in a row kept before it."""
    keep = np.zeros(len(ab), bool)
    used_loss, used_gain = set(), set()
    for k, (loss, won) in enumerate(zip(zip(ab.tolist(), lost.tolist()), zip(cd.tolist(), gain.tolist()))):
        if loss not in used_loss and won not in used_gain:
            keep[k] = True
            used_loss.add(loss)
            used_gain.add(won)
    return keep


def _runs(starts, stops):
    """Runs of consecutive frames of each contact: ``pair``, ``start``, ``stop`` (first frame without it),
    ``next_start`` (of its next run, or a frame past every frame) and ``prev_stop`` (of its previous run, or -1)."""
    def ordered(parts):
        key = np.concatenate([k for k, _ in parts])
        frame = np.concatenate([np.full(len(k), i, np.int64) for k, i in parts])
        order = np.lexsort((frame, key))
        return key[order], frame[order]

    pair, start = ordered(starts)
    _, stop = ordered(stops)  # a contact's runs alternate start, stop: the k-th stop ends the k-th start's run
    same_next = np.r_[pair[1:] == pair[:-1], False]
    same_prev = np.r_[False, pair[1:] == pair[:-1]]
    return pd.DataFrame({"pair": pair, "start": start, "stop": stop,
                         "next_start": np.where(same_next, np.r_[start[1:], 0], np.iinfo(np.int64).max),
                         "prev_stop": np.where(same_prev, np.r_[0, stop[:-1]], -1)})
