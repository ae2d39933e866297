"""Tracking's presentation: the tracking quality in the report, the tracks in napari, the track mode in the
napari widget."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..track import DIVISION_REASONS, division_rows, tracking_qc, tracking_warning
from . import LayerMaker, Section, StageView, columns, single, WidgetField
from .layerdata import common, is_movie
from .text import md_table

__all__ = ["VIEW", "track_layer"]

#: Divisions and per-frame rows shown in report.md (all of them are in the CSV files next to it).
QC_ROWS = 40
#: Track lengths are counted in these bins (frames; the last bin is open).
LENGTH_BINS = (1, 2, 3, 5, 10, 20, 50, 100, 200, 500, 1000)


def _tracking_qc(movie, report):
    """Tracking quality: per frame appearances, disappearances and divisions, track lengths, the divisions."""
    lineage, cal = movie.lineage, movie.calibration
    if lineage is None:
        return []
    summary = movie.summary.get("tracking", {}) or {}
    qc = tracking_qc(lineage, columns(movie, "cells", ["frame"]), summary.get("links"))
    divisions = division_rows(lineage)
    report.table(qc, "tracking_qc.csv")
    report.table(divisions, "divisions.csv")
    n_div, n_suspect = len(divisions), int(divisions["suspect"].sum())
    report.numbers["tracking_qc"] = {"appearances": int(qc["appearances"].sum()),
                              "disappearances": int(qc["disappearances"].sum()),
                              "divisions": n_div, "divisions_plausible": n_div - n_suspect,
                              "divisions_suspect": n_suspect,
                              "interior_appearances": int(qc["interior_appearances"].sum()),
                              "extrusions": int(qc["extrusions"].sum()),
                              "extrusions_unconfirmed": (int(lineage["extrusion_unconfirmed"].sum())
                                                         if "extrusion_unconfirmed" in lineage else None),
                              "doubtful_frames": qc.loc[qc["doubtful"], "frame"].astype(int).tolist()}
    lengths = lineage["n_frames"].to_numpy(np.int64)
    edges = [b for b in LENGTH_BINS if b <= len(movie)] + [np.inf]
    bins = pd.cut(lengths, edges, right=False)
    counts = pd.Series(bins).value_counts(sort=False)
    length_rows = pd.DataFrame({"frames present": [f"{int(i.left)}" + ("" if i.right == i.left + 1 else
                                                                       f"-{int(i.right) - 1}" if np.isfinite(i.right)
                                                                       else "+") for i in counts.index],
                                "tracks": counts.to_numpy()})
    track = movie.options.get("track")
    rules = (f"a daughter lasting >= {track.division_min_frames} frames, no division within "
             f"{track.division_min_cycle} frames of the mother's birth, daughters' area = mother's +- "
             f"{track.division_area_tolerance:.0%}" if track is not None and hasattr(track, "division_min_frames")
             else "see hexatissue.track.check_divisions")
    lines = ["## Tracking quality", "",
             f"- tracks: {len(lineage)}; frames present per track: median {np.median(lengths):g}, "
             f"{int((lengths == len(movie)).sum())} present in all {len(movie)} frames, "
             f"{int((lengths == 1).sum())} in a single frame",
             f"- appearances: {report.numbers['tracking_qc']['appearances']}, disappearances: "
             f"{report.numbers['tracking_qc']['disappearances']} (not counting divisions); inside the tissue (not at its "
             f"border): {report.numbers['tracking_qc']['interior_appearances']} appearances, "
             f"{report.numbers['tracking_qc']['extrusions']} extrusions"
             + (f" ({report.numbers['tracking_qc']['extrusions_unconfirmed']} unconfirmed: the cell did not shrink to half "
                f"its median area before it left; `lineage.extrusion_unconfirmed`)"
                if report.numbers["tracking_qc"]["extrusions_unconfirmed"] is not None else ""),
             f"- divisions: {n_div}, of which {n_div - n_suspect} plausible and {n_suspect} suspect ({rules}; "
             f"`lineage.division_suspect`, `division_reason`)", "",
             "Per frame (appearances: tracks starting there, not by division; disappearances: tracks present at "
             "the frame before and not there; interior_appearances, extrusions: those of them inside the tissue; "
             "divisions: mothers whose daughters start there"
             + ("; link_iou: median overlap (IoU) of the links from the frame before after following the tissue's "
                "motion; confident: share of links with IoU >= 0.5; motion: median displacement, cell diameters"
                if "link_iou" in qc else "")
             + "; doubtful: see below):", ""]
    broken = tracking_warning({**summary, "doubtful_frames": report.numbers["tracking_qc"]["doubtful_frames"],
                               "interior_extrusions": report.numbers["tracking_qc"]["extrusions"],
                               "interior_appearances": report.numbers["tracking_qc"]["interior_appearances"]})
    if broken:
        lines[lines.index("## Tracking quality") + 2:lines.index("## Tracking quality") + 2] = [
            f"**Tracking breaks.** {broken[0].upper()}{broken[1:]}.", ""]
    events = qc.drop(columns=["frame", "cells", "link_iou", "confident", "motion"], errors="ignore")
    shown = qc if len(qc) <= QC_ROWS else qc[(events > 0).any(axis=1)].head(QC_ROWS)
    lines += [md_table(shown), ""]
    if len(shown) < len(qc):
        lines += [f"({len(shown)} of {len(qc)} frames shown, those with an event; all in `tracking_qc.csv`.)", ""]
    lines += ["Track lengths:", "", md_table(length_rows), ""]
    if n_div:
        table = divisions.assign(time=[cal.time(f) for f in divisions["frame"]] if cal.has_time else None)
        table = table.drop(columns=[] if cal.has_time else ["time"])
        if cal.has_time:
            table = table.rename(columns={"time": f"time ({cal.time_label})"})
        lines += ["Divisions (frame: the daughters' first frame; area_ratio: daughters' area / mother's, "
                  "dimensionless):", "", md_table(table.head(QC_ROWS)), ""]
        if n_div > QC_ROWS:
            lines += [f"({QC_ROWS} of {n_div} divisions shown; all in `divisions.csv`.)", ""]
        reasons = sorted({r for text in divisions["reason"] for r in str(text).split(";") if r})
        lines += [f"- `{r}`: {DIVISION_REASONS[r]}" for r in reasons] + ([""] if reasons else [])
    return lines


# ---------------------------------------------------------------------------------------------------------
# tracks
# ---------------------------------------------------------------------------------------------------------
def track_layer(movie) -> tuple | None:
    """Tracks layer ``[track, t, y, x]`` of the cell centroids, with the lineage graph ``{daughter: [parent]}``.

    None for a single image.  In a periodic box each track is unwrapped
    (contiguous; see the module docstring).  ``features``: n_sides, area
    and cell id of each point.
    """
    if not is_movie(movie) or not len(movie.cells):
        return None
    cells = movie.cells.sort_values(["track", "frame"], kind="stable").reset_index(drop=True)
    xy = cells[["x", "y"]].to_numpy(float, copy=True)  # unwrapped in place below
    track = cells["track"].to_numpy()
    if movie.box is not None:
        starts = np.flatnonzero(np.r_[True, track[1:] != track[:-1]])
        for s, e in zip(starts, np.r_[starts[1:], len(track)]):
            xy[s:e] = movie.box.unwrap_polygon(xy[s:e])
    data = np.column_stack([track, cells["frame"].to_numpy(), xy[:, 1], xy[:, 0]]).astype(float)
    graph = {}
    if movie.lineage is not None and len(movie.lineage):
        lin = movie.lineage
        present = set(np.unique(track).tolist())
        for child, parent in zip(lin["track"].to_numpy(), lin["parent"].to_numpy()):
            if parent != 0 and child in present and parent in present:
                graph[int(child)] = [int(parent)]
    kwargs = {"name": "tracks", "graph": graph, "tail_length": 5, "visible": False,
              "features": cells[["cell", "n_sides", "area"]], **common(movie, time=True)}
    return data, kwargs, "tracks"


VIEW = StageView(report=(Section(30, _tracking_qc, tracked=True),),
                 layers=(LayerMaker(60, single(track_layer)),),
                 widget=(WidgetField("mode", name="track_mode", label="track mode"),))
