"""``hexatissue report``: figures and a Markdown summary of a ``hexatissue analyze`` folder.

A single frame gets the coarse-grained order fields with their defects; a
movie also gets the T1 events over time, the T1–defect proximity (Fig. 3e),
migration against defect density (Fig. 3f) and the event timing (Fig. 3g).
Everything goes to ``OUT`` (default ``RESULTS_DIR/report``): PNG figures,
the small analysis tables as CSV and ``report.md`` with the key numbers.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..analysis.migration import DEFAULT_DL, PAPER_WINDOW_ITERATIONS, migration_populations, migration_table
from ..analysis.proximity import t1_defect_proximity
from ..analysis.timing import cell_timing, in_time_units, timing_summary, timing_test
from ..errors import HexatissueWarning, InputError, check_p, check_positive
from ..io import atomic_path, check_output_folder, write_table
from ..results import Movie, read_results
from ..schema import empty_table
from ..track import DIVISION_REASONS, division_rows, tracking_qc, tracking_warning
from .figures import shown_frames

__all__ = ["report", "default_window"]


#: Epithelial cell apical areas span about 5-500 µm^2 (Drosophila ~10-50, MDCK ~100-400); a mean outside this
#: wider range says the pixel size is wrong more likely than the cells.
CELL_AREA_UM2 = (1.0, 5000.0)


def default_window(movie) -> int:
    """Migration window in frames: the paper's 25,000 iterations for MPF runs, else a quarter of the movie.

    For a movie whose frame interval is in simulation iterations (MPF runs),
    ``25_000 / frame_interval`` frames when that is a whole number shorter
    than the movie; otherwise ``max(1, n_frames // 4)``.
    """
    cal = movie.calibration
    if cal.time_unit == "iteration":
        frames = PAPER_WINDOW_ITERATIONS / cal.frame_interval
        if frames == int(frames) and frames < len(movie):
            return int(frames)
    return max(1, len(movie) // 4)


def _length(cal, px):
    """``"12.3 px"``, or ``"12.3 px (2.46 µm)"`` when the movie is calibrated."""
    text = f"{px:.3g} px"
    return text + f" ({cal.length(px):.3g} {cal.length_label})" if cal.has_length else text


def _speed(cal, px_per_frame):
    """``"0.38 px/frame"``, with µm/min (the calibration's units) when the movie is calibrated."""
    text = f"{px_per_frame:.3g} px/frame"
    if cal.has_length or cal.has_time:
        text += f" ({cal.length(px_per_frame) / cal.frame_interval:.3g} {cal.length_label}/{cal.time_unit})"
    return text


def _order_figures(movie, frames, order_p, out):
    from .. import plot

    written = []
    if movie.grid is None:
        return written
    for t in frames:
        polygons = movie.polygons(t)
        tag = "" if len(movie) == 1 else f"_frame{t:04d}"
        grid, defects = movie.table_at("grid", t), movie.table_at("defects", t)
        for q in order_p:
            if f"Gamma{q}_re" not in grid.columns or len(grid) == 0:
                continue
            path = out / f"order{q}{tag}.png"
            plot.plot_order_field(grid, defects[defects["p"] == q], p=q, polygons=polygons, box=movie.box, path=path,
                                  calibration=movie.calibration)
            written.append(path)
    return written


def _md_table(df, floatfmt="{:.4g}"):
    def cell(v):
        if isinstance(v, (float, np.floating)):
            return "" if not np.isfinite(v) else floatfmt.format(v)
        return str(v)

    lines = ["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join(lines)


def _tissue_section(movie, order_p):
    cells, cal = movie.cells, movie.calibration
    n_frames = max(len(movie), 1)
    inner = cells[~cells["is_border"].to_numpy(bool)]
    numbers = {"frames": len(movie), "cells_per_frame": len(cells) / n_frames}
    lines = ["## Tissue", "",
             f"- frames: {len(movie)}" + ("" if len(movie) > 1 else " (single image)"),
             f"- cells per frame: {len(cells) / n_frames:.1f} ({len(inner) / n_frames:.1f} interior)",
             f"- periodic box: {movie.box is not None}",
             f"- pixel size: " + (f"{cal.pixel_size:g} {cal.length_label}" if cal.has_length else "not calibrated (px)"),
             f"- frame interval: " + (f"{cal.frame_interval:g} {cal.time_label}" if cal.has_time
                                     else "not calibrated (frames)"),
             f"- calibration: {cal.origin_text}"]
    if len(inner):
        polygons = inner["n_sides"].to_numpy() >= 3
        left_out = int((~polygons).sum())
        if polygons.any():
            lines.append(f"- mean number of sides (interior cells with a polygon, n_sides >= 3): "
                         f"{inner['n_sides'][polygons].mean():.3f}"
                         + (f"; {left_out} interior fragment(s) with fewer than 3 vertices left out" if left_out
                            else ""))
        numbers["mean_sides"] = float(inner["n_sides"][polygons].mean()) if polygons.any() else float("nan")
        if polygons.any():
            share = {n: float((inner["n_sides"][polygons] == n).mean()) for n in (5, 6, 7)}
            numbers["side_shares"] = share
            lines.append(f"- hexagons {100 * share[6]:.1f} %, pentagons {100 * share[5]:.1f} %, heptagons "
                         f"{100 * share[7]:.1f} % of them")
        numbers["fragments_left_out"] = left_out
        area = inner["area"].mean()
        lines.append(f"- mean cell area (interior): {area:.4g} px^2"
                     + (f" ({cal.area(area):.4g} {cal.length_label}^2)" if cal.has_length else ""))
        if cal.has_length and cal.length_unit == "um" and not CELL_AREA_UM2[0] <= cal.area(area) <= CELL_AREA_UM2[1]:
            lines.append(f"- **check the pixel size**: a mean cell area of {cal.area(area):.4g} µm^2 is outside "
                         f"{CELL_AREA_UM2[0]:g}-{CELL_AREA_UM2[1]:g} µm^2, the range of epithelial cells")
    for q in order_p:
        col = f"gamma{q}_re"
        if col in inner.columns and len(inner):
            mag = np.hypot(inner[col], inner[f"gamma{q}_im"]).mean()
            lines.append(f"- mean |gamma_{q}| per cell: {mag:.3f}")
            numbers[f"mean_abs_gamma{q}"] = float(mag)
        if movie.grid is not None and f"Gamma{q}_re" in movie.grid.columns:
            g = movie.grid[movie.grid["valid"].to_numpy(bool)]
            mag = float(np.nanmean(np.hypot(g[f"Gamma{q}_re"], g[f"Gamma{q}_im"]))) if len(g) else np.nan
            lines.append(f"- mean |Gamma_{q}| on valid grid nodes: {mag:.3f}")
            numbers[f"mean_abs_Gamma{q}"] = mag
    if movie.defects is not None and len(movie.defects):
        rows = []
        for q, g in movie.defects.groupby("p"):
            rows.append({"p": int(q), "+ per frame": (g["charge"] > 0).sum() / n_frames,
                         "- per frame": (g["charge"] < 0).sum() / n_frames,
                         "net charge per frame": g["charge"].sum() / n_frames})
        lines += ["", "Defects (coarse-grained field):", "", _md_table(pd.DataFrame(rows))]
    return lines, numbers


def _figure_line(path, out, caption):
    return [f"![{caption}]({Path(path).relative_to(out).as_posix()})", ""]


def report(results, out=None, *, p=6, order_p=None, dl=DEFAULT_DL, dt=None, n_control=5, seed=0,
           include_border=False, control="cells") -> dict:
    """Render the figures that apply to an analysis and a Markdown summary.

    Parameters
    ----------
    results : path or Movie
        A results folder (``hexatissue analyze``, :meth:`Movie.write`), read
        with :func:`hexatissue.read_results`, or a Movie.  Lengths and times
        are shown in its calibration's units when it has them.
    out : path, optional
        Report folder (default ``results/report``; required for a Movie).
    p : int
        Defect order of the T1–defect and migration analyses.
    order_p : sequence of int, optional
        Orders whose coarse-grained fields are drawn (default: those analysed).
    dl : float
        Migration subregion side, px.
    dt : int, optional
        Migration window, frames.  Default: :func:`default_window` (the
        paper's 25,000 iterations for MPF runs, else a quarter of the movie).
    n_control : int
        Random cells (or vertices) per T1 event in the proximity control.
    seed : int or numpy.random.Generator
        Seeds the control draw and the mixture fit.
    include_border : bool
        Keep border cells and events touching them in the proximity and
        migration analyses (e.g. MPF runs whose unassigned gaps mark cells as border).
    control : {"cells", "vertices"}
        Proximity control: random cells (the paper's) or random vertices
        (junction level; see :func:`~hexatissue.analysis.t1_defect_proximity`).

    Returns
    -------
    dict
        Key numbers (also in ``report.md``) and ``written``: the files written.
    """
    # the numbers are checked before any figure is drawn: a refused report writes nothing
    check_p(p)
    check_positive(dl, "dl")
    check_positive(n_control, "n_control", integer=True)
    if isinstance(results, Movie):
        if out is None:
            raise InputError("out is required when results is a Movie (there is no results folder to write into)")
        movie = results
    else:
        movie = read_results(results)
    folder = None if isinstance(results, Movie) else results
    name = Path(str(movie.source.get("path") or folder or "movie")).name  # the input's name, else the folder's
    out = check_output_folder(Path(results) / "report" if out is None else out, "out")
    if folder is not None and out.resolve() == Path(folder).resolve():
        raise InputError(f"out {str(out)!r} is the results folder itself; the report goes into a folder of its own "
                         f"(default: RESULTS_DIR/report)")
    out.mkdir(parents=True, exist_ok=True)
    order = movie.options.get("order")
    order_p = tuple(order_p if order_p is not None else (order.p if order is not None else (6,)))
    written = _order_figures(movie, shown_frames(movie), order_p, out)
    source = movie.source.get("path") or movie.source.get("kind", "")
    lines = [f"# hexatissue report: {name}", "", f"Input: `{source}`", ""]
    section, numbers = _tissue_section(movie, order_p)
    lines += section + [""]
    if movie.cells is not None and len(movie.cells):
        from ..analysis.plots import plot_cell_distributions

        path = out / "cells.png"
        plot_cell_distributions(movie.cells, path=path, calibration=movie.calibration)
        lines += _figure_line(path, out, "neighbour number and area of the interior cells")
        written.append(path)
    for path in written:
        lines += _figure_line(path, out, path.stem)
    if len(movie) > 1 and _independent(movie):
        lines += ["The frames are independent images (not a movie; nothing was tracked): no T1, migration or "
                  "timing sections.", ""]
    elif len(movie) > 1:
        lines += _tracking_qc_section(movie, out, written, numbers)
        lines += _movie_sections(movie, out, written, numbers, p=p, dl=dl, dt=dt, n_control=n_control, seed=seed,
                                 include_border=include_border, control=control)
        lines += _flow_section(movie, out, written, numbers, p)
    lines += _mechanics_section(movie, out, written, numbers)
    md = out / "report.md"
    with atomic_path(md) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    written.append(md)
    numbers["written"] = [str(w) for w in written]
    return numbers


def _independent(movie) -> bool:
    """The frames are unrelated images (tracking resolved to ``"off"``, e.g. a folder of polygon files)."""
    return (movie.summary.get("tracking") or {}).get("resolved") == "off"


def _censor_of(movie):
    """The censoring window the events were classified with (None when the folder does not say)."""
    events = movie.options.get("events")
    return getattr(events, "censor", None) if events is not None else None


def _events_note(movie, events):
    """Why there is no intercalation to show, or None: no events, or every T1 not undone is unresolved."""
    if len(events) == 0:
        return (f"No T1 event was detected in the {len(movie)} frames: no neighbour exchange between cells "
                f"present on both sides of it.")
    kinds = events["kind"].astype(str)
    n_unresolved = int((kinds == "unresolved").sum())
    if n_unresolved and not (kinds == "intercalation").any():
        censor = _censor_of(movie)
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


#: Divisions and per-frame rows shown in report.md (all of them are in the CSV files next to it).
QC_ROWS = 40
#: Track lengths are counted in these bins (frames; the last bin is open).
LENGTH_BINS = (1, 2, 3, 5, 10, 20, 50, 100, 200, 500, 1000)


def _tracking_qc_section(movie, out, written, numbers):
    """Tracking quality: per frame appearances, disappearances and divisions, track lengths, the divisions."""
    lineage, cal = movie.lineage, movie.calibration
    if lineage is None:
        return []
    summary = movie.summary.get("tracking", {}) or {}
    qc = tracking_qc(lineage, movie.cells, summary.get("links"))
    divisions = division_rows(lineage)
    written += [write_table(qc, out / "tracking_qc.csv"), write_table(divisions, out / "divisions.csv")]
    n_div, n_suspect = len(divisions), int(divisions["suspect"].sum())
    numbers["tracking_qc"] = {"appearances": int(qc["appearances"].sum()),
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
             f"- appearances: {numbers['tracking_qc']['appearances']}, disappearances: "
             f"{numbers['tracking_qc']['disappearances']} (not counting divisions); inside the tissue (not at its "
             f"border): {numbers['tracking_qc']['interior_appearances']} appearances, "
             f"{numbers['tracking_qc']['extrusions']} extrusions"
             + (f" ({numbers['tracking_qc']['extrusions_unconfirmed']} unconfirmed: the cell did not shrink to half "
                f"its median area before it left; `lineage.extrusion_unconfirmed`)"
                if numbers["tracking_qc"]["extrusions_unconfirmed"] is not None else ""),
             f"- divisions: {n_div}, of which {n_div - n_suspect} plausible and {n_suspect} suspect ({rules}; "
             f"`lineage.division_suspect`, `division_reason`)", "",
             "Per frame (appearances: tracks starting there, not by division; disappearances: tracks present at "
             "the frame before and not there; interior_appearances, extrusions: those of them inside the tissue; "
             "divisions: mothers whose daughters start there"
             + ("; link_iou: median overlap (IoU) of the links from the frame before after following the tissue's "
                "motion; confident: share of links with IoU >= 0.5; motion: median displacement, cell diameters"
                if "link_iou" in qc else "")
             + "; doubtful: see below):", ""]
    broken = tracking_warning({**summary, "doubtful_frames": numbers["tracking_qc"]["doubtful_frames"],
                               "interior_extrusions": numbers["tracking_qc"]["extrusions"],
                               "interior_appearances": numbers["tracking_qc"]["interior_appearances"]})
    if broken:
        lines[lines.index("## Tracking quality") + 2:lines.index("## Tracking quality") + 2] = [
            f"**Tracking breaks.** {broken[0].upper()}{broken[1:]}.", ""]
    events = qc.drop(columns=["frame", "cells", "link_iou", "confident", "motion"], errors="ignore")
    shown = qc if len(qc) <= QC_ROWS else qc[(events > 0).any(axis=1)].head(QC_ROWS)
    lines += [_md_table(shown), ""]
    if len(shown) < len(qc):
        lines += [f"({len(shown)} of {len(qc)} frames shown, those with an event; all in `tracking_qc.csv`.)", ""]
    lines += ["Track lengths:", "", _md_table(length_rows), ""]
    if n_div:
        table = divisions.assign(time=[cal.time(f) for f in divisions["frame"]] if cal.has_time else None)
        table = table.drop(columns=[] if cal.has_time else ["time"])
        if cal.has_time:
            table = table.rename(columns={"time": f"time ({cal.time_label})"})
        lines += ["Divisions (frame: the daughters' first frame; area_ratio: daughters' area / mother's, "
                  "dimensionless):", "", _md_table(table.head(QC_ROWS)), ""]
        if n_div > QC_ROWS:
            lines += [f"({QC_ROWS} of {n_div} divisions shown; all in `divisions.csv`.)", ""]
        reasons = sorted({r for text in divisions["reason"] for r in str(text).split(";") if r})
        lines += [f"- `{r}`: {DIVISION_REASONS[r]}" for r in reasons] + ([""] if reasons else [])
    return lines


def _movie_sections(movie, out, written, numbers, *, p, dl, dt, n_control, seed, include_border, control):
    from ..analysis.plots import plot_event_overview, plot_migration, plot_t1_defect_distances, plot_timing

    cells, events, box, cal = movie.cells, movie.events, movie.box, movie.calibration
    defects = movie.defects if movie.defects is not None else empty_table("defects")
    frame_interval, time_unit = cal.frame_interval, cal.time_label
    lines = []
    if events is None:
        return ["## Events", "", "No events table in the results folder.", ""]
    note = _events_note(movie, events)
    counts = events["kind"].astype(str).value_counts().to_dict()
    cycles = events.loc[events["kind"] == "cycle", "duration"].to_numpy(float)
    numbers["events"] = {k: int(v) for k, v in counts.items()}
    censor = _censor_of(movie)
    lines += ["## T1 events", "", *_tracking_lines(movie), *_held_lines(movie), *_one_frame_lines(movie),
              "- " + (", ".join(f"{k}: {v}" for k, v in sorted(counts.items())) or "none detected")
              + (f" (censor {censor} frames)" if censor is not None else ""),
              (f"- mean T1-cycle duration: {np.mean(cycles):.3g} frames"
               + (f" ({cal.time(np.mean(cycles)):.3g} {time_unit})" if cal.has_time else "")
               if len(cycles) else "- no T1 cycles"), ""]
    lines += [note, ""] if note else []
    if len(events):  # no empty panels
        path = out / "events.png"
        plot_event_overview(events, n_frames=len(movie), path=path, calibration=cal)
        written.append(path)
        lines += _figure_line(path, out, "T1 events")

    # Fig. 3e
    prox = t1_defect_proximity(events, cells, defects, p=p, box=box, n_control=n_control, seed=seed,
                               include_border=include_border, control=control, vertices=movie.vertices)
    s = prox.summary()
    numbers["proximity"] = s
    lines += [f"## T1 events and ±1/{p} defects (Fig. 3e)", ""]
    if s["n_events"]:
        path = out / "t1_defects.png"
        plot_t1_defect_distances(prox, path=path, calibration=cal)
        written += [path, write_table(prox.events, out / "t1_defect_distances.csv"),
                    write_table(prox.control, out / "control_distances.csv")]
        lines += [f"- events with a defect in their frame: {s['n_events']}; random {control}: {s['n_control']} "
                  f"({n_control} per event, seed {seed})",
                  f"- median distance to the nearest defect: T1s {_length(cal, s['median_dr_events'])}, "
                  f"random {control} {_length(cal, s['median_dr_control'])}",
                  f"- KS statistic {s['ks_statistic']:.3g}, p = {s['ks_pvalue']:.3g} (two-sided), "
                  f"p = {s['ks_pvalue_closer']:.3g} (one-sided: T1s closer)", ""]
        lines += _figure_line(path, out, "T1-defect distances")
    else:
        if len(events) == 0:
            why = "there are no T1 events"
        elif not (defects["p"].to_numpy() == p).any():
            why = f"no ±1/{p} defect was found in any frame"
        else:
            why = (f"no T1 event{'' if include_border else ' away from the border'} has a ±1/{p} defect in its "
                   f"frame")
        lines += [f"Nothing to compare: {why}.", ""]

    # Fig. 3f
    if dt is None:
        dt = default_window(movie)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        table = migration_table(cells, defects, dl=dl, dt=dt, box=box, p=p, events=events,
                                include_border=include_border)
    pops = migration_populations(table, seed=seed)
    split = pops.two_populations
    numbers["migration"] = {"dl": dl, "dt": dt, "n_subregion_windows": len(table),
                            "threshold": pops.threshold if split else float("nan"), "verdict": pops.verdict,
                            "delta_bic": pops.delta_bic, "spearman_rho": pops.spearman_rho,
                            "spearman_pvalue": pops.spearman_pvalue}
    written.append(write_table(pops.table, out / "migration.csv"))
    moved = pops.table["displacement"].to_numpy(float) > 0
    lines += ["## Migration and defect density (Fig. 3f)", "",
              f"- subregions of {_length(cal, dl)}, windows of {dt} frames: {len(table)} subregion-windows, "
              f"{int(moved.sum())} of them moved", ""]
    if len(table) == 0:
        why = (f"the movie has {len(movie)} frames, fewer than one window of {dt} frames plus one"
               if len(movie) <= dt else f"no interior cell is present through a whole window of {dt} frames")
        lines += [f"No subregion-window to show: {why} (default window: a quarter of the movie, "
                  f"or 25,000 iterations for MPF runs; set it with --dt).", ""]
    elif not moved.any():
        lines += ["No cell moved in any window: nothing to correlate.", ""]
    else:
        median = float(np.median(pops.table["displacement"].to_numpy(float)[moved]))
        lines[-1:] = [f"- Spearman rank correlation of displacement and defect density: rho = "
                      f"{pops.spearman_rho:.3g} (p = {pops.spearman_pvalue:.3g})",
                      f"- median displacement {median:.3g} (dimensionless: the sum of a cell's squared steps over "
                      f"the window / dl^2, the paper's measure); as the rms frame-to-frame step of that median "
                      f"subregion-window, {_speed(cal, np.sqrt(median * dl**2 / dt))} (the tissue-wide rms step "
                      f"and velocity are under 'Tissue flow')"]
        fit = (f"delta BIC (1 vs 2 components) = {pops.delta_bic:.3g} ({pops.verdict}; "
               f"> 10 is strong evidence for two populations)")
        if split:
            lines += [f"- two-component mixture in log10(displacement): split at {pops.threshold:.3g}, {fit}", "",
                      _md_table(pops.summary), ""]
        else:
            lines += [f"- mixture in log10(displacement): {fit}; no slow/fast split", ""]
        if note:
            lines += [f"Intercalations per cell are all 0 here: {note}", ""]
        path = out / "migration.png"
        plot_migration(pops, path=path, calibration=cal)
        written.append(path)
        lines += _figure_line(path, out, "migration")

    # Fig. 3g
    timing_frames = cell_timing(events, cells)  # the figures convert frames themselves
    timing = in_time_units(timing_frames, frame_interval)
    summ, test = timing_summary(timing), timing_test(timing)
    numbers["timing"] = {"summary": summ.to_dict("records"), **test}
    written.append(write_table(timing, out / "cell_timing.csv"))
    n_cells = test["n_cycle_cells"] + test["n_intercalation_cells"]
    lines += ["## Event timing (Fig. 3g)", ""]
    if n_cells:
        lines += [f"Per-cell means from the T1 events above, in {time_unit}:", "", _md_table(summ), ""]
    if test["n_intercalation_cells"] and test["n_cycle_cells"]:
        lines += [f"- Welch two-sided t-test: t = {test['t_statistic']:.3g}, p = {test['pvalue']:.3g}", ""]
    else:
        n_cyc, n_int = counts.get("cycle", 0), counts.get("intercalation", 0)
        why = note or (f"a cycle period needs a T1 cycle and an intercalation interval two intercalations of the "
                       f"same cell; the movie has {n_cyc} cycle(s) and {n_int} intercalation(s)")
        lines += [f"Too little to compare: {test['n_cycle_cells']} cell(s) with a cycle period, "
                  f"{test['n_intercalation_cells']} with an intercalation interval. {why}", ""]
    if n_cells:
        path = out / "timing.png"
        plot_timing(timing_frames, path=path, calibration=cal)
        written.append(path)
        lines += _figure_line(path, out, "timing")
    if movie.neighbour_events is not None and len(movie.neighbour_events):
        lines += _per_cell_definition(movie, out, written, numbers)
    lines += _deformation_section(movie, out, written, numbers)
    return lines


def _per_cell_definition(movie, out, written, numbers):
    """The paper's second, per-cell definition of the events, labelled as such, its one-frame flickers apart."""
    cal = movie.calibration
    events = movie.neighbour_events
    kinds = events["kind"].astype(str).to_numpy()
    flicker = (kinds == "cycle") & (events["duration"].to_numpy(float) <= 1)
    counts = pd.Series(kinds).value_counts().to_dict()
    lines = [f"Second definition, the paper's per-cell one (changes of each cell's own neighbour list; it also "
             f"counts contacts lost or gained outside a T1 quartet): {len(events)} events ("
             + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())) + ")"
             + (f"; {int(flicker.sum())} of the cycles last one frame (flickers: a contact lost and regained at "
                f"once, often segmentation noise) and are left out below" if flicker.any() else "") + ".", ""]
    per_cell = cell_timing(events[~flicker], movie.cells, frame_interval=cal.frame_interval)
    test = timing_test(per_cell)
    numbers["timing_per_cell_definition"] = {"summary": timing_summary(per_cell).to_dict("records"),
                                             "n_flickers": int(flicker.sum()), **test}
    written.append(write_table(per_cell, out / "cell_timing_neighbour_lists.csv"))
    if test["n_cycle_cells"] + test["n_intercalation_cells"]:
        lines += [f"Per-cell means by this definition, in {cal.time_label}:", "", _md_table(timing_summary(per_cell)),
                  ""]
    if test["n_cycle_cells"] and test["n_intercalation_cells"]:
        lines += [f"- Welch two-sided t-test: t = {test['t_statistic']:.3g}, p = {test['pvalue']:.3g}", ""]
    return lines


def _deformation_section(movie, out, written, numbers):
    """The deformation budget: cumulative contributions over the movie, the curves and the map."""
    from ..plot import BUDGET_GROUPS, plot_deformation_budget, plot_deformation_map

    budget = movie.deformation
    if budget is None or len(budget) == 0:
        return []
    cal = movie.calibration
    everything = budget[budget["region"] == "tissue"]
    # the headline leaves out the intervals whose events rest on doubtful tracking (their totals stay in the CSV)
    doubtful = (everything["tracking_doubtful"].to_numpy(bool) if "tracking_doubtful" in everything
                else np.zeros(len(everything), bool))
    every_one = bool(len(everything)) and doubtful.all()  # nothing to leave them out for: shown, and said so
    tissue = everything if every_one else everything[~doubtful]

    def cumulative(part):
        rows = []
        for label, terms, _ in (("total", ("total",), None),) + BUDGET_GROUPS:
            rows.append({"contribution": label, **{f"cumulative {c}": sum(part[f"{t}_{c}"].sum() for t in terms
                                                                          if f"{t}_{c}" in part)
                                                   for c in ("xx", "xy", "iso")}})
        return pd.DataFrame(rows)

    table = cumulative(tissue)
    closure = float(everything[["closure_xx", "closure_xy", "closure_iso"]].abs().to_numpy().max(initial=0.0))
    numbers["deformation"] = {"cumulative": table.to_dict("records"), "max_closure": closure,
                              "n_pairs": int(len(tissue)), "n_pairs_doubtful": int(doubtful.sum())}
    if doubtful.any() and not every_one:
        numbers["deformation"]["cumulative_all"] = cumulative(everything).to_dict("records")
    written.append(write_table(budget, out / "deformation.csv"))
    path = out / "deformation.png"
    plot_deformation_budget(budget, calibration=cal, path=path)
    written.append(path)
    duration = cal.time(float(len(tissue)))
    span = (f"{len(tissue)} frame intervals, **every one of them with doubtful tracking** (see Tracking quality: "
            f"the events' terms are likely tracking errors)" if every_one else
            f"the {len(tissue)} frame intervals of {len(everything)} whose tracking is not doubtful" if doubtful.any()
            else f"{len(tissue)} frame intervals")
    lines = ["## Deformation budget", "",
             f"The tissue's shear and growth over {span} ({duration:.3g} {cal.time_label}), "
             f"split into the contributions of cell shape change and of each kind of cellular event (the triangle "
             f"method; cumulative, dimensionless; 'cell shape change' includes its corotational terms):", "",
             _md_table(table), ""]
    if doubtful.any() and not every_one:
        left = everything.loc[doubtful, "frame"].astype(int).tolist()
        shown = ", ".join(f"{t}-{t + 1}" for t in left[:10]) + (", ..." if len(left) > 10 else "")
        total = cumulative(everything).iloc[0]
        lines += [f"- left out of the table: {len(left)} interval(s) ({shown}) whose tracking is doubtful (interior "
                  f"extrusions above 1 % of the cells, frames far apart, a suspect division or an unconfirmed "
                  f"extrusion: see Tracking "
                  f"quality; `deformation.tracking_doubtful`); with them the cumulative total would be "
                  f"xx {total['cumulative xx']:.3g}, xy {total['cumulative xy']:.3g}, iso "
                  f"{total['cumulative iso']:.3g}", ""]
    lines += [f"- closure (total minus the sum of the parts): at most {closure:.2g} per interval",
              f"- triangles that would flip over within an interval (retriangulated instead): "
              f"{int(tissue['n_flipped'].sum())}", ""]
    lines += _figure_line(path, out, "deformation budget")
    if (budget["region"] == "grid").any() and movie.grid is not None:
        path = out / "deformation_map.png"
        plot_deformation_map(budget, movie.grid, calibration=cal, path=path, box=movie.box)
        written.append(path)
        lines += _figure_line(path, out, "deformation map")
    return lines


def _rate(cal, value, length_power=1):
    """A velocity (``length_power`` 1, px/frame) or a rate (0, 1/frame) as text, also in the calibration's units."""
    from ..flow import in_units, velocity_unit

    text = f"{value:.3g} {'px/frame' if length_power else '1/frame'}"
    if not (cal.has_time or (length_power and cal.has_length)):  # nothing to convert
        return text
    unit = velocity_unit(cal) if length_power else f"1/{cal.time_unit if cal.has_time else 'frame'}"
    return text + f" ({float(in_units(value, cal, length_power, -1)):.3g} {unit})"


def _flow_section(movie, out, written, numbers, p):
    """The tissue flow: velocity statistics, the flow field of a middle frame, C(r) and the MSD."""
    from .. import plot
    from ..analysis.plots import plot_flow_statistics
    from ..flow import flow_summary, mean_squared_displacement, velocity_correlation, velocity_statistics
    from ..flow.piv import piv_agreement

    cells, cal, box = movie.cells, movie.calibration, movie.box
    if "vx" not in cells.columns:
        return ["## Tissue flow", "", "No cell velocities in the results folder (analysed with `--no-flow`).", ""]
    per_frame = velocity_statistics(cells)
    correlation = velocity_correlation(cells, box)
    msd = mean_squared_displacement(cells, box)
    summary = flow_summary(cells, box, correlation, msd)
    numbers["flow"] = summary
    lines = ["## Tissue flow", "",
             f"- cell velocities: {summary['n_velocities']} cell-frames (centred differences along the tracks; none "
             f"on the first and last frame of a track, at divisions or beside gaps; border cells left out)"]
    if summary["n_velocities"] == 0:
        return lines + ["", "No interior cell has a velocity (every track is shorter than three frames).", ""]
    if summary["mean_speed"] == 0:
        return lines + ["", "No cell moved: every velocity is 0 (no polar order, correlation or MSD to measure).", ""]
    xi = summary["correlation_length"]
    lines += [f"- mean speed {_rate(cal, summary['mean_speed'])}; rms velocity {_rate(cal, summary['rms_velocity'])} "
              f"(centred differences over two frames); rms frame-to-frame step {_rate(cal, summary['rms_step'])} "
              f"(larger by the motion that reverses within a frame: centroid jitter of the segmentation and "
              f"fluctuations, which the two-frame difference averages out)",
              f"- polar order of the velocities (mean over frames): {summary['polar_order']:.3g}",
              "- velocity correlation length (a fit of A exp(-r/xi) + B to C(r) of the velocity fluctuations up to its "
              "first zero; bins with under 10 pairs or 1 % of the fullest bin's left out): "
              + (f"{_length(cal, xi)} ± {_length(cal, summary['correlation_length_sd'])} over "
                 f"{summary['correlation_bins']} bins, A = {summary['correlation_amplitude']:.2f} (the share of the "
                 f"velocity fluctuations that correlates between cells)" if np.isfinite(xi)
                 else f"not measured: {summary['correlation_reason']}"),
              f"- MSD exponent (MSD ~ lag^alpha, lags {int(msd['lag'].min())}-{int(msd['lag'].max())} frames): "
              f"{summary['msd_exponent']:.3g}"]
    flow = movie.tables.get("flow")
    shown = None
    if flow is not None and flow["valid"].any():
        valid = flow[flow["valid"]]
        numbers["flow"]["valid_nodes"] = float(flow["valid"].mean())
        lines += [f"- flow fields on the Gamma_p grid: {100 * flow['valid'].mean():.1f} % of the nodes have a fit "
                  f"(disks of {_length(cal, float(valid['radius'].median()))}); mean |vorticity| "
                  f"{_rate(cal, float(valid['vorticity'].abs().mean()), 0)}, mean |divergence| "
                  f"{_rate(cal, float(valid['divergence'].abs().mean()), 0)}"]
        frames = np.unique(valid["frame"].to_numpy())
        shown = int(frames[len(frames) // 2])
        if "piv_vx" in flow.columns:
            agree = piv_agreement(flow)
            numbers["flow"]["piv"] = agree
            lines.append(f"- PIV of the raw channel on the same nodes ({agree['nodes']} node-frames with both fields): "
                         + (f"rms velocity {_rate(cal, agree['rms_piv'])} (tracks: {_rate(cal, agree['rms_tracks'])}), "
                            f"rms difference {_rate(cal, agree['rms_difference'])} "
                            f"({agree['relative_difference']:.2f} of the tracks' rms); correlation of the components "
                            f"r_x = {agree['r_vx']:.2f}, r_y = {agree['r_vy']:.2f}" if agree["nodes"] else
                            "none to compare"))
    lines.append("")
    path = out / "flow_statistics.png"
    plot_flow_statistics(per_frame, correlation, msd, path=path, calibration=cal,
                         spacing=summary["cell_spacing"])
    written += [path, write_table(per_frame, out / "flow_per_frame.csv"),
                write_table(correlation, out / "velocity_correlation.csv"), write_table(msd, out / "msd.csv")]
    lines += _figure_line(path, out, "flow statistics")
    if shown is not None:
        path = out / f"flow_frame{shown:04d}.png"
        plot.plot_flow(movie.table_at("flow", shown), polygons=movie.polygons(shown), box=box, calibration=cal,
                       path=path)
        written.append(path)
        lines += _figure_line(path, out, f"flow, frame {shown}")
    if movie.events is not None and len(movie.events):
        lines += _t1_flow_lines(movie, out, written, numbers)
    if movie.grid is not None and movie.defects is not None and f"Gamma{p}_re" in movie.grid.columns:
        lines += _defect_flow_lines(movie, out, written, numbers, p)
    return lines


def _harmonics_table(harmonics, cal):
    """Markdown rows of the radial harmonics n = 2, 4, 6 of each kind, and the numbers by kind."""
    lines, numbers = ["| kind | n = 2 | n = 4 | n = 6 | share of n = 6 |", "|---|---|---|---|---|"], {}
    for kind, group in harmonics.groupby("kind"):
        amp = group.set_index("n")["radial_amplitude"]
        share = _n6_share(group)
        numbers[str(kind)] = {"radial_n2": float(amp[2]), "radial_n4": float(amp[4]), "radial_n6": float(amp[6]),
                              "n6_share": share}
        lines.append(f"| {kind} | {_rate(cal, amp[2])} | {_rate(cal, amp[4])} | {_rate(cal, amp[6])} | {share:.2f} |")
    return lines, numbers


def _defect_flow_lines(movie, out, written, numbers, p):
    """The flow averaged around the ±1/p defects in their own axes, and its harmonics."""
    from ..analysis.plots import plot_event_flow
    from ..flow import angular_harmonics, defect_flow

    cal = movie.calibration
    average, samples = defect_flow(movie.cells, movie.defects, movie.grid, p=p, box=movie.box)
    if not len(samples):
        return [f"### Flow around ±1/{p} defects", "", f"No ±1/{p} defect has cells with velocities around it.", ""]
    r_cell = float(np.sqrt(np.nanmean(movie.cells["area"].to_numpy(float)) / np.pi))
    harmonics = angular_harmonics(samples, r_min=r_cell)
    path = out / "defect_flow.png"
    plot_event_flow(average, path=path, calibration=cal, title=f"mean flow around ±1/{p} defects (defect axes)",
                    x_label="x along the defect's axis")
    written += [path, write_table(average, out / "defect_flow.csv"),
                write_table(harmonics, out / "defect_flow_harmonics.csv")]
    table, numbers["defect_flow"] = _harmonics_table(harmonics, cal)
    return [f"### Flow around ±1/{p} defects", "",
            f"Cells within {_length(cal, 4 * r_cell)} of each ±1/{p} defect, their velocity minus their mean, in "
            f"axes turned by the defect's orientation from the Gamma_{p} phase. Radial harmonics (samples beyond "
            f"{_length(cal, r_cell)}):", "", *table, "", *_figure_line(path, out, f"flow around ±1/{p} defects")]


#: Offsets (frames from the T1's frame_start) of the report's T1-centred flow.
T1_OFFSETS = (-4, 0, 4)


def _quadrupole_harmonics():
    """Radial harmonics of the quadrupole's Stokes flow (:func:`hexatissue.theory.quadrupole_flow_exact`), 2-4 ell."""
    from ..flow import angular_harmonics
    from ..theory import quadrupole_flow_exact

    r, phi = np.meshgrid(np.linspace(2.0, 4.0, 9), np.linspace(-np.pi, np.pi, 97)[:-1])
    x, y = (r * np.cos(phi)).ravel(), (r * np.sin(phi)).ravel()
    vx, vy = quadrupole_flow_exact(x, y, 1.0, 1.0)
    samples = pd.DataFrame({"kind": "theory", "offset": 0, "x": x, "y": y, "vx": vx, "vy": vy})
    return angular_harmonics(samples)


def _n6_share(harmonics):
    """Share of n = 6 in the radial harmonics 1 .. max of one group (by amplitude)."""
    h = harmonics[harmonics["n"] > 0]
    total = h["radial_amplitude"].sum()
    return float(h.loc[h["n"] == 6, "radial_amplitude"].sum() / total) if total > 0 else float("nan")


def _t1_flow_lines(movie, out, written, numbers):
    """The flow averaged around the T1s (cycles and intercalations apart), its harmonics, and the theory's."""
    from ..analysis.plots import plot_event_flow
    from ..flow import angular_harmonics, t1_flow

    cal = movie.calibration
    average, samples = t1_flow(movie.cells, movie.events, movie.box, offsets=T1_OFFSETS)
    if not len(samples):
        return ["### Flow around T1 events", "", "No T1 event has its four cells with velocities at the offsets "
                f"{list(T1_OFFSETS)} frames.", ""]
    r_cell = float(np.sqrt(np.nanmean(movie.cells["area"].to_numpy(float)) / np.pi))
    harmonics = angular_harmonics(samples, r_min=r_cell)
    theory = _n6_share(_quadrupole_harmonics())
    path = out / "t1_flow.png"
    plot_event_flow(average, path=path, calibration=cal, title="mean flow around T1s (quartet frame)")
    written += [path, write_table(average, out / "t1_flow.csv"), write_table(harmonics, out / "t1_flow_harmonics.csv")]
    at0 = harmonics[harmonics["offset"] == 0]
    numbers["t1_flow"] = {"n6_share_quadrupole_theory": theory}
    lines = ["### Flow around T1 events", "",
             f"Cells within {_length(cal, 4 * r_cell)} of each T1's quartet centre, their velocity minus the "
             f"quartet's mean, in axes with the vanishing junction (c -> d) along x, averaged over the events "
             f"of each kind at {', '.join(f'{o:+d}' for o in T1_OFFSETS)} frames from the T1. Radial harmonics "
             f"of the relative velocity (least squares over the samples beyond {_length(cal, r_cell)}, offset 0):",
             ""]
    table, by_kind = _harmonics_table(at0, cal)
    numbers["t1_flow"].update(by_kind)
    lines += table
    lines += ["", f"The unbinding quadrupole's Stokes flow (`hexatissue.theory.quadrupole_flow_exact`, 2-4 ell) puts "
              f"{theory:.2f} of its radial harmonics 1-8 in n = 6.", ""]
    return lines + _figure_line(path, out, "flow around T1s")
def _mechanics_section(movie, out, written, numbers):
    """Force inference: tensions and pressures of the first frame, the tissue stress per frame."""
    from ..mechanics import MU_RANGE, tissue_stress
    from ..plot import plot_stress, plot_tension_histogram, plot_tensions

    edges = movie.tables.get("edges")
    if edges is None or "tension" not in edges.columns:
        return []
    cells, cal = movie.cells, movie.calibration
    per_frame = []
    for t, rows in cells.groupby("frame", sort=True):
        s = tissue_stress(rows, rows)
        frame_edges = edges[edges["frame"] == t]
        tension = frame_edges["tension"].to_numpy(float)
        sd = (frame_edges["tension_sd"].to_numpy(float) if "tension_sd" in frame_edges.columns
              else np.full(len(tension), np.nan))
        curved = (frame_edges["curvature"].to_numpy(float) != 0) if "curvature" in frame_edges.columns else None
        per_frame.append({"frame": int(t), "junction_model": "arcs" if curved is not None and curved.any()
                          else "straight", "tensions": int(np.isfinite(tension).sum()),
                          "junctions": int(len(frame_edges)),
                          "negative": int((tension < 0).sum()),
                          # negative beyond its 90 % posterior interval (NaN s.d.: least squares, no interval)
                          "negative_90": int((tension + 1.6448536 * sd < 0).sum()),
                          "median_tension_sd": float(np.nanmedian(sd)) if np.isfinite(sd).any() else np.nan,
                          "pressures": int(np.isfinite(rows["pressure"]).sum()), "cells": int(len(rows)),
                          "stress_xx": s[0, 0], "stress_xy": s[0, 1], "stress_yy": s[1, 1]})
    table = pd.DataFrame(per_frame)
    fit = movie.tables.get("force_fit")
    if fit is not None and len(fit):
        # the model and the prior weight each frame's estimate actually used
        fit = fit.set_index("frame")
        table["junction_model"] = np.where(fit["arcs"].reindex(table["frame"]).fillna(False).to_numpy(bool),
                                           "arcs", "straight")
        for column in ("mu", "n_free"):
            table.insert(2, column, fit[column].reindex(table["frame"]).to_numpy())
    options = movie.options.get("mechanics")
    method = {"bayes": "Bayesian, prior weight by ABIC" if getattr(options, "mu", None) is None else
              f"Bayesian, prior weight {options.mu:g}", "lsq": "least squares"}.get(getattr(options, "method", ""),
                                                                                  "?")
    junctions = getattr(options, "junctions", "?")
    numbers["mechanics"] = {"method": method, "junctions": junctions, "frames": table.to_dict("records")}
    written.append(write_table(table, out / "mechanics.csv"))
    first = int(table["frame"].iloc[0])
    lines = ["## Force inference", "",
             f"Junction tensions and cell pressures from the force balance of the vertices inside the tissue "
             f"(estimator: {method}; junction model `{junctions}`, the one used per frame in `junction_model`: "
             f"arcs balanced by their tangents and Young-Laplace, or straight junctions with the pressures at the "
             f"vertices; tensions relative, mean interior tension 1 per frame; pressures relative to the frame's mean, in "
             f"tension/px; docs/mechanics.md). Per frame: the prior weight `mu` the estimate used (at "
             f"{MU_RANGE[0]:g}, the lower end, the balance is met almost exactly and the estimate is least squares' "
             f"wherever the balance determines it; at {MU_RANGE[1]:g}, the upper end, the prior alone sets the "
             f"tensions), `n_free` the junctions and cells the balance leaves free (their values are the prior's), "
             f"the junctions and cells with an estimate, the negative "
             f"tensions (`negative_90`: below 0 by more than their 90 % posterior interval), the median posterior "
             f"s.d. of the tensions, and the tissue's Batchelor stress (area-weighted mean of the cells with a "
             f"stress, tension/px):", "", _md_table(table.head(20)), ""]
    if len(table) > 20:
        lines += [f"(first 20 of {len(table)} frames; all in mechanics.csv)", ""]
    if not np.isfinite(edges["tension"]).any():
        lines += ["No junction has a tension: the force balance leaves every unknown free (least squares on an "
                  "open image or a network with four-fold vertices; use the Bayesian estimator).", ""]
        return lines
    path = out / "tensions.png"
    plot_tensions(edges[edges["frame"] == first], movie.vertices[movie.vertices["frame"] == first],
                  calibration=cal, box=movie.box, path=path)
    written.append(path)
    lines += _figure_line(path, out, f"tensions, frame {first}")
    path = out / "tension_histogram.png"
    plot_tension_histogram(edges[edges["frame"] == first], path=path)
    written.append(path)
    lines += _figure_line(path, out, f"tension histogram, frame {first}")
    path = out / "pressure.png"
    plot_stress(cells[cells["frame"] == first], "pressure", movie.polygons(first), box=movie.box, calibration=cal,
                title=f"inferred pressure relative to the mean (tension/px), frame {first}", path=path)
    written.append(path)
    lines += _figure_line(path, out, f"pressure, frame {first}")
    lines += _t1_tension_lines(movie, edges, out, written, numbers)
    return lines


def _t1_tension_lines(movie, edges, out, written, numbers, before=10):
    """The tension of each T1's lost junction over the frames before it, by kind (when there are T1s)."""
    from ..mechanics import t1_tension_histories
    from ..plot import plot_t1_tensions

    events = movie.tables.get("events")
    if events is None or not len(events):
        return []
    histories = t1_tension_histories(events, edges, movie.cells, before=before)
    written.append(write_table(histories, out / "t1_tensions.csv"))
    last = histories[histories["lag"] == -1].groupby("kind")["tension"].median()
    numbers["mechanics"]["t1_tension_at_lag_minus_1"] = {str(k): float(v) for k, v in last.items()}
    path = out / "t1_tensions.png"
    plot_t1_tensions(histories, path=path)
    written.append(path)
    return [f"Tension of the junction each T1 removes, over the {before} frames before it, by kind "
            f"(`t1_tensions.csv`; median at the last frame before the T1: "
            + ", ".join(f"{k} {v:.2f}" for k, v in last.items()) + "):", ""] + _figure_line(
                path, out, "tension before T1s")
