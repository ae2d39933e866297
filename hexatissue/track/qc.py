"""How well the tracking went: per-frame checks, the warning they raise and the run's summary."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

from .tracker import CONFIDENT_SHARE

#: A frame's tracking is doubtful when more than this share of its cells end inside the tissue (extrusions) ...
EXTRUSION_SHARE = 0.01
#: ... (and at least this many: one extrusion in a small field of view is biology, not a tracking failure) ...
MIN_EXTRUSIONS = 2
#: ... or when fewer than this share of its links to the frame before overlap with IoU >= CONFIDENT_IOU after
#: warping: the frames look far apart in time (or are different fields of view).
FAR_APART = 0.5


class CellCounts(NamedTuple):
    """What the tracking summary counts of a movie's tracked cells, gathered a chunk of frames at a time
    (:meth:`of` a chunk's ``frame``, ``cell``, ``track``; :meth:`join` of consecutive chunks)."""

    frames: np.ndarray  # the frames with cells, sorted
    per_frame: np.ndarray  # the cells of each
    ids: np.ndarray  # the distinct label ids, sorted
    tracks: np.ndarray  # the distinct tracks, sorted
    rows_track_not_cell: int  # rows whose track is not their label id

    @classmethod
    def of(cls, cells) -> "CellCounts":
        frames, per_frame = np.unique(cells["frame"].to_numpy(np.int64), return_counts=True)
        ids, tracks = cells["cell"].to_numpy(np.int64), cells["track"].to_numpy(np.int64)
        return cls(frames, per_frame.astype(np.int64), np.unique(ids), np.unique(tracks), int((tracks != ids).sum()))

    @classmethod
    def join(cls, chunks) -> "CellCounts":
        chunks = list(chunks)

        def union(arrays):  # one unique of them all, not a union per chunk (quadratic in the chunks)
            return np.unique(np.concatenate(arrays)) if arrays else np.zeros(0, np.int64)

        return cls(np.concatenate([c.frames for c in chunks]), np.concatenate([c.per_frame for c in chunks]),
                   union([c.ids for c in chunks]), union([c.tracks for c in chunks]),
                   sum(c.rows_track_not_cell for c in chunks))


def tracking_qc(lineage: pd.DataFrame, cells, links: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per frame: cells, tracks that appear and disappear, divisions plausible and suspect, and whether the
    tracking there is doubtful.

    Parameters
    ----------
    lineage : pandas.DataFrame
        :func:`lineage_table`, checked by :func:`check_divisions` (without
        ``division_suspect`` every division counts as plausible).
    cells : pandas.DataFrame or CellCounts
        ``frame`` (one row per cell), or the counts of a movie's cells.
    links : pandas.DataFrame, optional
        :meth:`Tracker.link_qc` (``frame``, ``link_iou``, ``confident``,
        ``motion``), e.g. from ``summary["tracking"]["links"]`` of an analysis.

    Returns
    -------
    pandas.DataFrame
        ``frame``, ``cells`` (count), ``appearances`` (tracks starting at
        the frame inside the tissue or at its border, not by division),
        ``disappearances`` (tracks present at the frame before and not
        after it, ended by extrusion or at the border, not by division),
        ``interior_appearances`` and ``extrusions`` (of those, the ones
        inside the tissue), ``divisions`` (mothers whose daughters start at
        the frame), ``divisions_suspect`` (of those, the suspect ones);
        counts per frame.  With ``links``: ``link_iou`` (median IoU of the
        links from the frame before, after warping), ``confident`` (share of
        them with IoU >= :data:`CONFIDENT_IOU`), ``motion`` (median
        displacement from the frame before, cell diameters); NaN at the first
        frame.  ``doubtful`` (bool): more than :data:`EXTRUSION_SHARE` of the
        frame's cells (and at least :data:`MIN_EXTRUSIONS`) ended inside the
        tissue there, or ``confident`` < :data:`FAR_APART`.
    """
    if isinstance(cells, CellCounts):
        frames, per_frame = cells.frames, cells.per_frame
    else:
        frames, per_frame = np.unique(cells["frame"].to_numpy(np.int64), return_counts=True)
    out = pd.DataFrame({"frame": frames, "cells": per_frame.astype(np.int64)})
    begin, end = lineage["begin"].astype(str), lineage["end"].astype(str)
    # the frame after a track's last one, in the movie's own frame numbers
    after = np.searchsorted(frames, lineage["frame_end"].to_numpy(np.int64), "right")
    gone_at = np.where(after < len(frames), frames[np.minimum(after, len(frames) - 1)], -1)

    def per_frame(values):
        return pd.Series(values).value_counts().reindex(frames, fill_value=0).to_numpy(np.int64)

    out["appearances"] = per_frame(lineage.loc[begin.isin(["appearance", "border"]).to_numpy(), "frame_start"])
    out["disappearances"] = per_frame(gone_at[end.isin(["extrusion", "border"]).to_numpy()])
    out["interior_appearances"] = per_frame(lineage.loc[(begin == "appearance").to_numpy(), "frame_start"])
    out["extrusions"] = per_frame(gone_at[(end == "extrusion").to_numpy()])
    daughters = lineage[lineage["parent"] > 0]
    first = daughters.groupby("parent")["frame_start"].min()
    suspect = (daughters.groupby("parent")["division_suspect"].any() if "division_suspect" in daughters.columns
               else pd.Series(False, index=first.index))
    out["divisions"] = per_frame(first.to_numpy())
    out["divisions_suspect"] = per_frame(first[suspect.reindex(first.index).to_numpy(bool)].to_numpy())
    doubtful = (out["extrusions"] > EXTRUSION_SHARE * out["cells"]) & (out["extrusions"] >= MIN_EXTRUSIONS)
    if links is not None:
        links = pd.DataFrame(links)
        for name in ("link_iou", "confident", "motion"):
            values = links.set_index("frame")[name] if len(links) else pd.Series(dtype=float)
            out[name] = values.reindex(frames).to_numpy(float)
        doubtful |= out["confident"] < FAR_APART
    out["doubtful"] = doubtful.to_numpy(bool)
    return out


def tracking_warning(summary: dict) -> str | None:
    """What to tell the user when the tracking of some frames is doubtful (None when none is), from
    :func:`tracking_summary`."""
    frames = summary.get("doubtful_frames") or []
    if not frames:
        return None
    links = summary.get("links") or {}
    confident = dict(zip(links.get("frame", []), links.get("confident", [])))
    far = [t for t in frames if confident.get(t, 1.0) < FAR_APART]
    # frames whose existing links overlap well: the cells that end have no partner in the next frame's labels
    linked = [t for t in frames if t not in far and confident.get(t, np.nan) >= CONFIDENT_SHARE]
    other = [t for t in frames if t not in far and t not in linked]

    def listed(values):
        return ", ".join(str(t) for t in values[:10]) + (", ..." if len(values) > 10 else "")

    parts = []
    if other:
        parts.append(f"at frame(s) {listed(other)} more than {EXTRUSION_SHARE:.0%} of the cells end inside the tissue "
                     f"and fewer links overlap well: extrusions, appearances and divisions there are likely tracking "
                     f"errors")
    if linked:
        parts.append(f"at frame(s) {listed(linked)} more than {EXTRUSION_SHARE:.0%} of the cells end inside the "
                     f"tissue although at least {CONFIDENT_SHARE:.0%} of the links overlap well: the cells that end have "
                     f"no partner in the next frame's labels (cells missing or merged in the segmentation there, or "
                     f"real extrusions); check those frames' labels")
    if far:
        parts.append(f"at frame(s) {listed(far)} fewer than {FAR_APART:.0%} of the links overlap well after following "
                     f"the motion: the frames look far apart in time or are different fields of view; if the ids are "
                     f"the same cell across frames, use --track never; if the frames are unrelated images, --track off")
    return (f"tracking is doubtful at {len(frames)} frame(s) ({listed(frames)}) of a movie with "
            f"{summary.get('interior_extrusions', 0)} interior extrusions and "
            f"{summary.get('interior_appearances', 0)} interior appearances: " + "; ".join(parts)
            + " (those intervals are marked `tracking_doubtful` in the deformation budget and left out of the "
              "report's cumulative budget)")


def tracking_summary(tracker, cells, parents, lineage=None):
    """The tracker's decision and what it changed: rows whose track differs from the id, tracks, divisions
    (plausible and suspect ones when ``lineage`` was checked by :func:`check_divisions`).

    ``cells``: the tracked cells (``frame``, ``cell``, ``track``), or their :class:`CellCounts`.
    """
    out = tracker.summary()
    counts = cells if isinstance(cells, CellCounts) else CellCounts.of(cells)
    out.update(rows_track_not_cell=counts.rows_track_not_cell, n_ids=len(counts.ids), n_tracks=len(counts.tracks),
               n_divisions=len(set(parents.values())))
    if lineage is not None and "division_suspect" in lineage.columns:
        daughters = lineage[lineage["parent"] > 0]
        suspect = daughters.groupby("parent")["division_suspect"].any()
        out.update(n_divisions_plausible=int((~suspect).sum()), n_divisions_suspect=int(suspect.sum()))
    links = tracker.link_qc() if hasattr(tracker, "link_qc") else None
    if links is not None and len(links):  # per frame pair, as JSON lists (metadata.json)
        out["links"] = {name: [v.item() if hasattr(v, "item") else v for v in links[name].tolist()]
                        for name in ("frame", "link_iou", "confident", "motion", "measured", "rescued")}
    if lineage is not None and "extrusion_unconfirmed" in lineage.columns:
        out["n_extrusions_unconfirmed"] = int(lineage["extrusion_unconfirmed"].sum())
    if lineage is not None and out.get("resolved") != "off":  # untracked frames: every cell ends, nothing to doubt
        qc = tracking_qc(lineage, counts, out.get("links"))
        out["doubtful_frames"] = qc.loc[qc["doubtful"], "frame"].astype(int).tolist()
        out["interior_extrusions"] = int(qc["extrusions"].sum())
        out["interior_appearances"] = int(qc["interior_appearances"].sum())
    return out
