"""``hexatissue report``: figures and a Markdown summary of a ``hexatissue analyze`` folder.

A single frame gets the coarse-grained order fields with their defects; a
movie also gets the T1 events over time, the T1–defect proximity (Fig. 3e),
migration against defect density (Fig. 3f) and the event timing (Fig. 3g).
Everything goes to ``OUT`` (default ``RESULTS_DIR/report``): PNG figures,
the small analysis tables as CSV and ``report.md`` with the key numbers.

Every stage's section comes from its views module (:mod:`hexatissue.views`,
named by its entry in :data:`hexatissue.stages.STAGES`), in the order of
their ranks; this module adds the paper's analyses of the T1 events and the
defects (Figs. 3e-g) between the T1 events (rank 40) and the per-cell
definition (45).
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..analysis.migration import DEFAULT_DL, PAPER_WINDOW_ITERATIONS, migration_populations, migration_table
from ..analysis.plots import plot_migration, plot_t1_defect_distances, plot_timing
from ..analysis.proximity import t1_defect_proximity
from ..analysis.timing import cell_timing, in_time_units, timing_summary, timing_test
from ..errors import HexatissueWarning, InputError, check_p, check_positive
from ..io import atomic_path, check_output_folder
from ..results import Movie, read_results
from ..schema import empty_table
from ..views import Report, Section, columns, report_sections
from ..views.events import TRACK_KEYS, events_note
from ..views.text import length, md_table, speed

__all__ = ["report", "default_window"]


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


def report(results, out=None, *, p=6, order_p=None, dl=DEFAULT_DL, dt=None, n_control=5, seed=0,
           include_border=False, control="cells") -> dict:
    """Render the figures that apply to an analysis and a Markdown summary.

    Parameters
    ----------
    results : path or Movie
        A results folder (``hexatissue analyze``, :meth:`Movie.write`), read
        with :func:`hexatissue.read_results` (``lazy=True``: the tables a
        streamed analysis wrote in parts stay on disk, and each section
        reads only the columns it needs, :func:`hexatissue.views.columns`),
        or a Movie.  Lengths and times are shown in its calibration's units
        when it has them.
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
        movie = read_results(results, lazy=True)  # each section reads the columns it needs
    folder = None if isinstance(results, Movie) else results
    name = Path(str(movie.source.get("path") or folder or "movie")).name  # the input's name, else the folder's
    out = check_output_folder(Path(results) / "report" if out is None else out, "out")
    if folder is not None and out.resolve() == Path(folder).resolve():
        raise InputError(f"out {str(out)!r} is the results folder itself; the report goes into a folder of its own "
                         f"(default: RESULTS_DIR/report)")
    out.mkdir(parents=True, exist_ok=True)
    order = movie.options.get("order")
    order_p = tuple(order_p if order_p is not None else (order.p if order is not None else (6,)))
    context = Report(out=out, p=p, order_p=order_p, dl=dl, dt=dt, n_control=n_control, seed=seed,
                     include_border=include_border, control=control)
    source = movie.source.get("path") or movie.source.get("kind", "")
    lines = [f"# hexatissue report: {name}", "", f"Input: `{source}`", ""]
    tracked, said = len(movie) > 1 and not _independent(movie), False
    for section in report_sections(PAPER_SECTIONS):
        if section.tracked and not tracked:
            if len(movie) > 1 and not said:  # once, where the first section of a tracked movie would be
                lines += ["The frames are independent images (not a movie; nothing was tracked): no T1, migration "
                          "or timing sections.", ""]
                said = True
            continue
        lines += section.run(movie, context)
    md = out / "report.md"
    with atomic_path(md) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    context.written.append(md)
    context.numbers["written"] = [str(w) for w in context.written]
    return context.numbers


def _independent(movie) -> bool:
    """The frames are unrelated images (tracking resolved to ``"off"``, e.g. a folder of polygon files)."""
    return (movie.summary.get("tracking") or {}).get("resolved") == "off"


#: The columns of ``cells`` that the T1-defect proximity's control and the migration read: each cell-frame's
#: frame, track (else its label), centroid and whether it is on the border.
POSITIONS = ("frame", *TRACK_KEYS, "x", "y", "is_border")


def _defects(movie):
    """The columns of the defects table that the proximity and the migration read (an empty table when the
    analysis has none): each defect-frame's frame, id, order, charge and position."""
    if movie.defects is None:
        return empty_table("defects")
    return columns(movie, "defects", ["frame", "defect", "p", "charge", "x", "y"])


def _proximity(movie, report):
    """Fig. 3e: the distance of each T1 to the nearest ±1/p defect against random cells (or vertices)."""
    events, box, cal = movie.events, movie.box, movie.calibration
    if events is None:
        return []
    defects = _defects(movie)
    p, n_control, seed, include_border, control = (report.p, report.n_control, report.seed, report.include_border,
                                                  report.control)
    # the control draws from one table only: its positions, frames, ids and whether on the border
    cells = columns(movie, "cells", POSITIONS) if control == "cells" else None
    vertices = columns(movie, "vertices", ["frame", "vertex", "x", "y", "degree", "is_border"]) \
        if control == "vertices" else movie.vertices
    lines = []
    prox = t1_defect_proximity(events, cells, defects, p=p, box=box, n_control=n_control, seed=seed,
                               include_border=include_border, control=control, vertices=vertices)
    s = prox.summary()
    report.numbers["proximity"] = s
    lines += [f"## T1 events and ±1/{p} defects (Fig. 3e)", ""]
    if s["n_events"]:
        path = report.out / "t1_defects.png"
        plot_t1_defect_distances(prox, path=path, calibration=cal)
        report.table(prox.events, "t1_defect_distances.csv")
        report.table(prox.control, "control_distances.csv")
        lines += [f"- events with a defect in their frame: {s['n_events']}; random {control}: {s['n_control']} "
                  f"({n_control} per event, seed {seed})",
                  f"- median distance to the nearest defect: T1s {length(cal, s['median_dr_events'])}, "
                  f"random {control} {length(cal, s['median_dr_control'])}",
                  f"- KS statistic {s['ks_statistic']:.3g}, p = {s['ks_pvalue']:.3g} (two-sided), "
                  f"p = {s['ks_pvalue_closer']:.3g} (one-sided: T1s closer)", ""]
        lines += report.figure(path, "T1-defect distances")
    else:
        if len(events) == 0:
            why = "there are no T1 events"
        elif not (defects["p"].to_numpy() == p).any():
            why = f"no ±1/{p} defect was found in any frame"
        else:
            why = (f"no T1 event{'' if include_border else ' away from the border'} has a ±1/{p} defect in its "
                   f"frame")
        lines += [f"Nothing to compare: {why}.", ""]
    return lines


def _migration(movie, report):
    """Fig. 3f: migration against defect density, subregion by subregion."""
    events, box, cal = movie.events, movie.box, movie.calibration
    if events is None:
        return []
    cells, defects = columns(movie, "cells", POSITIONS), _defects(movie)
    p, seed, include_border = report.p, report.seed, report.include_border
    lines = []
    note = events_note(movie, events)
    dt = default_window(movie) if report.dt is None else report.dt
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        table = migration_table(cells, defects, dl=report.dl, dt=dt, box=box, p=p, events=events,
                                include_border=include_border)
    pops = migration_populations(table, seed=seed)
    split = pops.two_populations
    report.numbers["migration"] = {"dl": report.dl, "dt": dt, "n_subregion_windows": len(table),
                            "threshold": pops.threshold if split else float("nan"), "verdict": pops.verdict,
                            "delta_bic": pops.delta_bic, "spearman_rho": pops.spearman_rho,
                            "spearman_pvalue": pops.spearman_pvalue}
    report.table(pops.table, "migration.csv")
    moved = pops.table["displacement"].to_numpy(float) > 0
    lines += ["## Migration and defect density (Fig. 3f)", "",
              f"- subregions of {length(cal, report.dl)}, windows of {dt} frames: {len(table)} subregion-windows, "
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
                      f"subregion-window, {speed(cal, np.sqrt(median * report.dl**2 / dt))} (the tissue-wide rms step "
                      f"and velocity are under 'Tissue flow')"]
        fit = (f"delta BIC (1 vs 2 components) = {pops.delta_bic:.3g} ({pops.verdict}; "
               f"> 10 is strong evidence for two populations)")
        if split:
            lines += [f"- two-component mixture in log10(displacement): split at {pops.threshold:.3g}, {fit}", "",
                      md_table(pops.summary), ""]
        else:
            lines += [f"- mixture in log10(displacement): {fit}; no slow/fast split", ""]
        if note:
            lines += [f"Intercalations per cell are all 0 here: {note}", ""]
        path = report.out / "migration.png"
        plot_migration(pops, path=path, calibration=cal)
        lines += report.figure(path, "migration")
    return lines


def _timing(movie, report):
    """Fig. 3g: the per-cell T1-cycle periods and intercalation intervals, compared."""
    events, cal = movie.events, movie.calibration
    if events is None:
        return []
    cells = columns(movie, "cells", TRACK_KEYS)
    frame_interval, time_unit = cal.frame_interval, cal.time_label
    note = events_note(movie, events)
    counts = events["kind"].astype(str).value_counts().to_dict()
    lines = []
    timing_frames = cell_timing(events, cells)  # the figures convert frames themselves
    timing = in_time_units(timing_frames, frame_interval)
    summ, test = timing_summary(timing), timing_test(timing)
    report.numbers["timing"] = {"summary": summ.to_dict("records"), **test}
    report.table(timing, "cell_timing.csv")
    n_cells = test["n_cycle_cells"] + test["n_intercalation_cells"]
    lines += ["## Event timing (Fig. 3g)", ""]
    if n_cells:
        lines += [f"Per-cell means from the T1 events above, in {time_unit}:", "", md_table(summ), ""]
    if test["n_intercalation_cells"] and test["n_cycle_cells"]:
        lines += [f"- Welch two-sided t-test: t = {test['t_statistic']:.3g}, p = {test['pvalue']:.3g}", ""]
    else:
        n_cyc, n_int = counts.get("cycle", 0), counts.get("intercalation", 0)
        why = note or (f"a cycle period needs a T1 cycle and an intercalation interval two intercalations of the "
                       f"same cell; the movie has {n_cyc} cycle(s) and {n_int} intercalation(s)")
        lines += [f"Too little to compare: {test['n_cycle_cells']} cell(s) with a cycle period, "
                  f"{test['n_intercalation_cells']} with an intercalation interval. {why}", ""]
    if n_cells:
        path = report.out / "timing.png"
        plot_timing(timing_frames, path=path, calibration=cal)
        lines += report.figure(path, "timing")
    return lines


#: The paper's analyses, between the stages' sections (:class:`hexatissue.views.Section`).
PAPER_SECTIONS = (Section(41, _proximity, tracked=True), Section(42, _migration, tracked=True),
                  Section(43, _timing, tracked=True))