"""The T1 events' presentation: the events by kind and over time, and the paper's per-cell definition, in the
report; the events in napari."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..analysis.timing import cell_timing, timing_summary, timing_test
from ..plot import FAST_COLOR, SLOW_COLOR, empty_panel, finish_panels, panels
from ..units import as_calibration
from . import LayerMaker, Section, StageView, columns, single
from .layerdata import common, coords, is_movie, rgba, spacing
from .text import md_table

__all__ = ["VIEW", "plot_event_overview", "event_layer", "EVENT_COLORS", "events_note", "censor_of", "TRACK_KEYS"]

#: The columns of ``cells`` that give each row its track (``track``, else the label ``cell``): all that the
#: per-cell event timing reads of it (its rows per track).
TRACK_KEYS = ("track", "cell")


def censor_of(movie):
    """The censoring window the events were classified with (None when the folder does not say)."""
    events = movie.options.get("events")
    return getattr(events, "censor", None) if events is not None else None


def events_note(movie, events):
    """Why there is no intercalation to show, or None: no events, or every T1 not undone is unresolved."""
    if len(events) == 0:
        return (f"No T1 event was detected in the {len(movie)} frames: no neighbour exchange between cells "
                f"present on both sides of it.")
    kinds = events["kind"].astype(str)
    n_unresolved = int((kinds == "unresolved").sum())
    if n_unresolved and not (kinds == "intercalation").any():
        censor = censor_of(movie)
        window = f"censor = {censor} frames" if censor is not None else "the censoring window"
        return (f"All {n_unresolved} T1 events that are not undone are unresolved: each starts within {window} of "
                f"the last frame, so the movie cannot tell intercalations from cycles still to close. Re-run "
                f"`hexatissue analyze` with a smaller `--censor` to classify them (unfinished cycles may then count "
                f"as intercalations).")
    return None


def _tracking_lines(movie):
    """How the cells were tracked (from ``movie.summary``), as report lines."""
    t = movie.summary.get("tracking")
    if not t:
        return []
    how = ("label ids kept as tracks" if t["resolved"] == "never" else
           "cells re-tracked by overlap after following the tissue's motion" if t.get("follow") == "flow" else
           "cells re-tracked by overlap")
    split = (f" ({t['n_divisions_plausible']} plausible, {t['n_divisions_suspect']} suspect)"
             if "n_divisions_suspect" in t else "")
    return [f"- tracking: {how} (track={t['mode']!r}): {t['reason']}",
            f"- tracks: {t['n_tracks']} for {t['n_ids']} label ids; {t['rows_track_not_cell']} rows with track != "
            f"cell; {t['n_divisions']} division(s){split}"]


def _held_lines(movie):
    """How many contacts the network held as four-fold vertices (junctions shorter than merge_distance)."""
    e, mesh = movie.summary.get("events") or {}, movie.options.get("mesh")
    if e.get("n_held_contacts") is None:
        return []
    merge = f" = {mesh.merge_distance:g} px" if mesh is not None else ""
    return [f"- short junctions held as four-fold vertices (shorter than merge_distance{merge}): "
            f"{e['n_held_contacts']} contact-frames at {e['n_held_vertices']} vertex-frames; a T1 whose new "
            f"junction never grows past merge_distance is one of these, not an event (`vertices.n_merged`; "
            f"`--merge-distance` sets it)"]


def _one_frame_lines(movie):
    """How many T1s are cycles of one frame, the doubtful ones on segmented microscopy."""
    e = movie.summary.get("events") or {}
    if not e.get("n_one_frame_cycles"):
        return []
    return [f"- cycles of one frame (a-b lost and c-d gained in one frame, undone in the next): "
            f"{e['n_one_frame_cycles']} of {e['n_events']} T1s; on segmented microscopy these are mostly four-fold "
            f"vertex flicker or segmentation errors (docs/t1.md, *T1 counts on real data*); leave them out with "
            f"`duration == 1` when the movie is not exactly resolved"]


def plot_event_overview(events, n_frames=None, path=None, calibration=None, figsize=(10, 3.8)):
    """T1 events per frame by kind (left) and the distribution of T1-cycle durations (right).

    Parameters
    ----------
    events : pandas.DataFrame
        Events table (``kind``, ``frame_start``, ``duration`` in frames).
    n_frames : int, optional
        Number of frames of the movie (the last event's start frame when None).
    path : str or Path, optional
        Where to write the PNG.
    calibration : Calibration, optional
        Times and durations are shown in its time unit (frames when None);
        the counts stay per frame.
    figsize : tuple of float
        Width and height in inches (event counts and cycle durations).

    Returns
    -------
    matplotlib.figure.Figure
    """
    cal = as_calibration(calibration)
    fig, (ax, ax2) = panels(2, figsize)
    kinds = (("cycle", FAST_COLOR), ("intercalation", SLOW_COLOR), ("unresolved", "0.6"))
    if len(events):
        last = int(events["frame_start"].max()) if n_frames is None else n_frames - 1
        frames = np.arange(last + 1)
        for kind, color in kinds:
            f = events.loc[events["kind"] == kind, "frame_start"].to_numpy(np.int64)
            ax.plot(cal.time(frames), np.bincount(f, minlength=last + 1)[:last + 1], color=color,
                    label=f"{kind} ({len(f)})")
        ax.legend(frameon=False, fontsize=8)
    else:
        empty_panel(ax, "no T1 events")
    ax.set_xlabel(f"time ({cal.time_label})")
    ax.set_ylabel("T1 events starting per frame")
    d = events.loc[events["kind"] == "cycle", "duration"].to_numpy(float) if len(events) else np.zeros(0)
    d = d[np.isfinite(d)]
    if len(d):
        bins = _duration_bins(d)
        ax2.hist(cal.time(d), bins=cal.time(bins), color=FAST_COLOR)
    else:
        empty_panel(ax2, "no T1 cycles")
    ax2.set_xlabel(f"T1-cycle duration ({cal.time_label})")
    ax2.set_ylabel("cycles")
    return finish_panels(fig, path)


def _duration_bins(durations, max_bins=30):
    """Bin edges for durations in whole frames: centred on whole frames, ``step`` frames wide, covering all.

    ``step`` is the smallest whole number giving at most ``max_bins`` bins;
    the last edge is at or above ``max + 0.5``, so the longest durations are
    counted.
    """
    d = np.asarray(durations, float)
    d = d[np.isfinite(d)]
    lo = min(0.5, float(np.floor(d.min())) - 0.5) if len(d) else 0.5
    hi = float(d.max()) if len(d) else 1.0
    step = max(1, int(np.ceil((hi - lo) / max_bins)))
    n = max(1, int(np.ceil((hi + 0.5 - lo) / step)))
    return lo + step * np.arange(n + 1)


def _t1_events(movie, report):
    """The T1 events: how the cells were tracked, the events by kind, their overview over time."""
    events, cal = movie.events, movie.calibration
    time_unit = cal.time_label
    lines = []
    if events is None:
        return ["## Events", "", "No events table in the results folder.", ""]
    note = events_note(movie, events)
    counts = events["kind"].astype(str).value_counts().to_dict()
    cycles = events.loc[events["kind"] == "cycle", "duration"].to_numpy(float)
    report.numbers["events"] = {k: int(v) for k, v in counts.items()}
    censor = censor_of(movie)
    lines += ["## T1 events", "", *_tracking_lines(movie), *_held_lines(movie), *_one_frame_lines(movie),
              "- " + (", ".join(f"{k}: {v}" for k, v in sorted(counts.items())) or "none detected")
              + (f" (censor {censor} frames)" if censor is not None else ""),
              (f"- mean T1-cycle duration: {np.mean(cycles):.3g} frames"
               + (f" ({cal.time(np.mean(cycles)):.3g} {time_unit})" if cal.has_time else "")
               if len(cycles) else "- no T1 cycles"), ""]
    lines += [note, ""] if note else []
    if len(events):  # no empty panels
        path = report.out / "events.png"
        plot_event_overview(events, n_frames=len(movie), path=path, calibration=cal)
        lines += report.figure(path, "T1 events")
    return lines


def _per_cell_definition(movie, report):
    """The paper's second, per-cell definition of the events, labelled as such, its one-frame flickers apart."""
    cal = movie.calibration
    events = movie.neighbour_events
    if events is None or not len(events):
        return []
    kinds = events["kind"].astype(str).to_numpy()
    flicker = (kinds == "cycle") & (events["duration"].to_numpy(float) <= 1)
    counts = pd.Series(kinds).value_counts().to_dict()
    lines = [f"Second definition, the paper's per-cell one (changes of each cell's own neighbour list; it also "
             f"counts contacts lost or gained outside a T1 quartet): {len(events)} events ("
             + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())) + ")"
             + (f"; {int(flicker.sum())} of the cycles last one frame (flickers: a contact lost and regained at "
                f"once, often segmentation noise) and are left out below" if flicker.any() else "") + ".", ""]
    per_cell = cell_timing(events[~flicker], columns(movie, "cells", TRACK_KEYS), frame_interval=cal.frame_interval)
    test = timing_test(per_cell)
    report.numbers["timing_per_cell_definition"] = {"summary": timing_summary(per_cell).to_dict("records"),
                                             "n_flickers": int(flicker.sum()), **test}
    report.table(per_cell, "cell_timing_neighbour_lists.csv")
    if test["n_cycle_cells"] + test["n_intercalation_cells"]:
        lines += [f"Per-cell means by this definition, in {cal.time_label}:", "", md_table(timing_summary(per_cell)),
                  ""]
    if test["n_cycle_cells"] and test["n_intercalation_cells"]:
        lines += [f"- Welch two-sided t-test: t = {test['t_statistic']:.3g}, p = {test['pvalue']:.3g}", ""]
    return lines


#: T1 event colour by kind.
EVENT_COLORS = {"cycle": "#ffffff", "intercalation": "#ffd700", "unresolved": "#888888"}


def event_layer(movie) -> tuple | None:
    """Points layer of the T1 events at their quartet centre in the first frame after the contact is lost
    (``frame_start``), coloured by kind; ``features`` = the events rows (kind, duration, cells, ...)."""
    e = movie.events
    if e is None:
        return None
    e = e.reset_index(drop=True)
    colors = [EVENT_COLORS.get(str(k), "#888888") for k in e["kind"]]
    kwargs = {"name": "T1 events", "size": 0.5 * spacing(movie), "symbol": "star",
              "face_color": rgba(colors), "border_color": "black", "border_width": 0.1, "features": e,
              "ndim": 3 if is_movie(movie) else 2, **common(movie, colors=EVENT_COLORS)}
    return coords(movie, e["frame_start"], e["x"], e["y"]), kwargs, "points"


def _legend(movie, p):
    return [(f"T1 {kind}", "star", c) for kind, c in EVENT_COLORS.items()] if movie.events is not None else []


VIEW = StageView(report=(Section(40, _t1_events, tracked=True), Section(45, _per_cell_definition, tracked=True)),
                 layers=(LayerMaker(50, single(event_layer)),), legend=_legend)
