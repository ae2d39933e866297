"""The paper's Fig. 3e–g from the analysis folders of a parameter sweep.

:func:`figure3` reads every run's ``hexatissue analyze`` folder, runs the
three analyses (T1–defect proximity, migration vs defect density, event
timing), pools them across runs where the paper does, and writes the tables,
figures and a ``summary.json`` with the numbers that decide the paper's
trends.
"""
from __future__ import annotations

import json
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from ..analysis.migration import DEFAULT_DL, cell_displacements, migration_populations, migration_table
from ..analysis.plots import plot_migration, plot_t1_defect_distances, plot_timing, plot_timing_vs_parameter
from ..analysis.proximity import compare_distances, t1_defect_proximity
from ..analysis.timing import cell_timing, in_time_units, timing_across_runs
from ..events import detect_t1, neighbour_events
from ..errors import HexatissueWarning, InputError
from ..results import read_results
from ..io import atomic_path, write_table

__all__ = ["figure3", "loglog_slope", "DEFINITIONS", "events_at_spacing", "timing_vs_frame_spacing"]


def loglog_slope(x, y):
    """Least-squares slope of ``log y`` against ``log x`` over the finite, positive pairs (NaN if < 2)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if ok.sum() < 2 or np.ptp(x[ok]) == 0:
        return float("nan")
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def _runs(runs):
    """``{value: results folder}`` from a mapping or a :func:`~hexatissue.workflows.sweep` table."""
    if isinstance(runs, pd.DataFrame):
        if not {"value", "results"} <= set(runs.columns):
            raise InputError("runs table needs columns 'value' and 'results' (the output of hexatissue.workflows.sweep)")
        runs = dict(zip(runs["value"], runs["results"]))
    if not isinstance(runs, Mapping) or not runs:
        raise InputError("runs must be a non-empty mapping {parameter value: analysis folder} or a sweep table")
    return {float(v): Path(p) for v, p in sorted(runs.items())}


#: Event definitions of Fig. 3e/3g: name -> the Movie table holding them (see docs/t1.md).
DEFINITIONS = {"quartet": "events", "cell_neighbours": "neighbour_events"}
DEFINITION_TITLES = {"quartet": "quartet T1s (hexatissue.detect_t1)",
                     "cell_neighbours": "per-cell neighbour-list changes (the paper's definition)"}


def _controls(control):
    """``control`` as a tuple of distinct control kinds, the first being the main Fig. 3e panel."""
    controls = (control,) if isinstance(control, str) else tuple(control)
    if not controls or len(set(controls)) != len(controls) or not set(controls) <= {"cells", "vertices"}:
        raise InputError(f"control must be 'cells', 'vertices' or a sequence of both without repeats; got {control!r}")
    return controls


def _panels(controls):
    """The Fig. 3e panels: ``(file suffix, definition, control)``.

    Quartet T1s sit at the centre of four cells, so they are compared with each
    requested control (random cells are the paper's; random vertices compare
    junction-level points with junction-level points).  The per-cell events sit
    at a cell's centroid: their like-with-like control is random cells.
    """
    first = [("", "quartet", controls[0])]
    return first + [(f"_{c}", "quartet", c) for c in controls[1:]] + [("_cell_neighbours", "cell_neighbours", "cells")]


def _fig3e(parts, panels, out):
    """Pool each panel's distances over runs, write its tables and figure; returns ``{suffix: summary}``."""
    written, summaries = [], {}
    for suffix, definition, control in panels:
        events_all = pd.concat([e for e, _, _ in parts[suffix]], ignore_index=True)
        control_all = pd.concat([c for _, c, _ in parts[suffix]], ignore_index=True)
        ks_rows = [row for _, _, row in parts[suffix]]
        pooled = compare_distances(events_all, control_all, control)
        tables = {"_distances": events_all, "_control": control_all, "_ks": pd.DataFrame(ks_rows)}
        written += [write_table(t, out / f"fig3e{suffix}{name}.csv") for name, t in tables.items()]
        plot_t1_defect_distances(pooled, path=out / f"fig3e{suffix}.png",
                                 title=f"{DEFINITION_TITLES[definition]} vs random {control}")
        written.append(out / f"fig3e{suffix}.png")
        summaries[suffix] = {"definition": definition, "control": control, "pooled": pooled.summary(),
                             "per_run": ks_rows}
    return written, summaries


def _fig3g(timing, timing_frames, out, param, calibration):
    """Per-cell timing of both definitions: tables, box plots and trends; returns (written, records, trends)."""
    written, across_all, cells_all, trends = [], [], [], {}
    for definition in DEFINITIONS:
        suffix = "" if definition == "quartet" else f"_{definition}"
        title = DEFINITION_TITLES[definition]
        cells_all += [t.assign(**{param: v, "definition": definition}) for v, t in timing[definition].items()]
        across = timing_across_runs(timing[definition], param=param).assign(definition=definition)
        across_all.append(across)
        plot_timing(timing_frames[definition], path=out / f"fig3g_box{suffix}.png", calibration=calibration,
                    param=param, title=title)
        plot_timing_vs_parameter(timing_across_runs(timing_frames[definition], param=param), param=param,
                                 path=out / f"fig3g_vs_param{suffix}.png", calibration=calibration, title=title)
        written += [out / f"fig3g_box{suffix}.png", out / f"fig3g_vs_param{suffix}.png"]
        ic = across[across["quantity"] == "intercalation_interval"]
        cy = across[across["quantity"] == "cycle_period"]
        trends[definition] = {"intercalation_interval_loglog_slope": loglog_slope(ic[param], ic["mean"]),
                              "cycle_period_loglog_slope": loglog_slope(cy[param], cy["mean"])}
    across_all = pd.concat(across_all, ignore_index=True)
    written += [write_table(pd.concat(cells_all, ignore_index=True), out / "fig3g_cell_timing.csv"),
                write_table(across_all, out / "fig3g_summary.csv")]
    return written, across_all.to_dict("records"), trends


def figure3(runs, out, *, param="D_r", p=6, dl=DEFAULT_DL, dt=25, n_control=5, seed=0, include_border=False,
            control="cells") -> dict:
    """Fig. 3e (T1–defect distances), 3f (migration vs defect density) and 3g (event timing) of a sweep.

    Fig. 3e and 3g are made for both event definitions (see
    :data:`DEFINITIONS` and docs/t1.md): the quartet T1s of
    :func:`~hexatissue.detect_t1` (``events`` table) and the paper's per-cell
    changes of neighbour lists (``neighbour_events`` table).  Fig. 3f counts
    the quartet T1s of each subregion's cells.

    Parameters
    ----------
    runs : mapping or pandas.DataFrame
        ``{parameter value: analysis folder}``, or the table returned by
        :func:`~hexatissue.workflows.sweep` (columns ``value``, ``results``).
    out : path
        Folder for the figures, tables (CSV) and ``summary.json`` (see Returns).
    param : str
        Name of the swept parameter (axis labels, table columns).
    p : int
        Defect order.
    dl, dt : float, int
        Migration subregion side (px) and window (frames; 25,000 iterations
        are ``25_000 / save_every`` frames).
    n_control : int
        Random cells (or vertices) per event in the proximity control.
    seed : int
        Seeds the control draws (``seed + run index``) and the mixture fit.
    include_border : bool
        Keep border cells and events touching them (see :func:`~hexatissue.workflows.report`).
    control : {"cells", "vertices"} or sequence of them
        Fig. 3e control(s) for the quartet T1s: random cells (the paper's) or
        random vertices (needs the ``vertices`` tables; see
        :func:`~hexatissue.analysis.t1_defect_proximity`).  The first is the
        main panel (``fig3e.png``); each further one ``c`` writes
        ``fig3e_c.png`` and its tables.  The per-cell events are always
        compared with random cells (``fig3e_cell_neighbours.png``).

    Returns
    -------
    dict
        The contents of ``summary.json``: ``fig3e`` (main panel) and
        ``fig3e_<suffix>`` (the others), each with ``definition``, ``control``,
        the pooled KS tests (``pooled``, distances in px) and ``per_run``;
        ``fig3f``, the migration populations pooled over runs, and
        ``net_displacement``: per run, ``n_cell_windows``, ``mean_px`` and
        ``median_px`` of the cells' net displacement over one window (px);
        ``fig3g``, one
        record per run, quantity and ``definition`` (the
        :func:`~hexatissue.analysis.timing_across_runs` columns, times in the
        runs' calibrated unit: iterations for MPF runs, the same for every
        run); ``trends``, per definition, the log-log slopes of the mean
        intercalation interval and of the mean T1-cycle period against the
        parameter.  Files: ``fig3e{,_vertices,_cell_neighbours}.png`` with
        ``fig3e*_distances.csv``, ``fig3e*_control.csv``, ``fig3e*_ks.csv``;
        ``fig3f.png``, ``fig3f_migration.csv``, ``fig3f_populations.csv``;
        ``fig3g_box{,_cell_neighbours}.png``,
        ``fig3g_vs_param{,_cell_neighbours}.png``, ``fig3g_cell_timing.csv``
        and ``fig3g_summary.csv`` (with a ``definition`` column).
    """
    runs = _runs(runs)
    panels = _panels(_controls(control))
    calibration = None
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    parts = {suffix: [] for suffix, _, _ in panels}
    mig_parts, travel = [], []
    timing = {d: {} for d in DEFINITIONS}
    timing_frames = {d: {} for d in DEFINITIONS}
    for k, (value, folder) in enumerate(runs.items()):
        movie = read_results(folder, lazy=False)
        box, cells, defects = movie.box, movie.cells, movie.defects
        if calibration is not None and movie.calibration != calibration:
            raise InputError(f"{folder}: its calibration {movie.calibration} differs from the other runs' "
                             f"{calibration}; Fig. 3g compares times across runs in one unit")
        calibration = movie.calibration
        tables = {d: getattr(movie, name) for d, name in DEFINITIONS.items()}
        missing = [name for d, name in DEFINITIONS.items() if tables[d] is None] + ([] if defects is not None
                                                                                    else ["defects"])
        if missing:
            raise InputError(f"{folder}: needs the {', '.join(missing)} table(s); analyse the run again with "
                             f"hexatissue analyze (p including {p})")
        for suffix, definition, kind in panels:
            prox = t1_defect_proximity(tables[definition], cells, defects, p=p, box=box, n_control=n_control,
                                       seed=seed + k, control=kind, vertices=movie.vertices,
                                       include_border=include_border)
            parts[suffix].append((prox.events.assign(**{param: value}), prox.control.assign(**{param: value}),
                                  {param: value, **prox.summary()}))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HexatissueWarning)
            mig = migration_table(cells, defects, dl=dl, dt=dt, box=box, p=p, events=tables["quartet"],
                                  include_border=include_border)
            # how far cells get in one window (caged or flowing): the net displacement |r(t0 + dt) - r(t0)|
            net = np.sqrt(cell_displacements(cells, dl=dl, dt=dt, box=box, include_border=include_border)["msd"])
        mig_parts.append(mig.assign(**{param: value}))
        travel.append({param: value, "n_cell_windows": len(net), "mean_px": float(net.mean()) if len(net) else np.nan,
                       "median_px": float(net.median()) if len(net) else np.nan})
        for d in DEFINITIONS:
            timing_frames[d][value] = cell_timing(tables[d], cells)  # the figures convert frames themselves
            timing[d][value] = in_time_units(timing_frames[d][value], calibration.frame_interval)
    written, fig3e = _fig3e(parts, panels, out)

    pops = migration_populations(pd.concat(mig_parts, ignore_index=True), seed=seed)
    written += [write_table(pops.table, out / "fig3f_migration.csv"),
                write_table(pops.summary, out / "fig3f_populations.csv")]
    plot_migration(pops, path=out / "fig3f.png")
    written.append(out / "fig3f.png")

    g_written, g_records, trends = _fig3g(timing, timing_frames, out, param, calibration)
    written += g_written
    summary = {
        "param": param, "values": list(runs), "p": p, "dl": dl, "dt": dt, "frame_interval": calibration.frame_interval,
        "time_unit": calibration.time_unit, "include_border": include_border, "control": panels[0][2],
        **{f"fig3e{suffix}": fig3e[suffix] for suffix, _, _ in panels},
        "fig3f": {"n_subregion_windows": len(pops.table), "threshold": pops.threshold, "delta_bic": pops.delta_bic,
                  "verdict": pops.verdict, "spearman_rho": pops.spearman_rho, "spearman_pvalue": pops.spearman_pvalue,
                  "populations": pops.summary.to_dict("records"), "net_displacement": travel},
        "fig3g": g_records,
        "trends": trends,
    }
    path = out / "summary.json"
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(summary, indent=2, default=float))
    summary["written"] = [str(w) for w in written + [path]]
    return summary


def events_at_spacing(edges, cells, stride, min_length=0.0, censor=10, box=None):
    """Both definitions' events of a movie seen only on every ``stride``-th frame.

    Each frame's network does not depend on the other frames (and MPF ids are
    consistent), so keeping the ``edges`` and ``cells`` rows of frames
    ``0, stride, 2 stride, ...`` (renumbered ``frame // stride``) is what an
    analysis of the coarser movie would see.  ``censor`` is in frames of the
    full movie and is divided by ``stride`` (at least 1), so the censoring
    window keeps its length in time.

    Returns
    -------
    cells : pandas.DataFrame
        The kept rows of ``cells``, frames renumbered.
    events : dict
        ``{"quartet": detect_t1 table, "cell_neighbours": neighbour_events
        table}``, frames (and durations) in units of the coarse spacing.
    """
    stride = int(stride)
    if stride < 1:
        raise InputError(f"stride must be a positive integer; got {stride!r}")

    def keep(table):
        rows = table[table["frame"].to_numpy(np.int64) % stride == 0]
        return rows.assign(frame=rows["frame"].to_numpy(np.int64) // stride)

    cells, edges = keep(cells), keep(edges)
    c = max(1, int(round(censor / stride)))
    return cells, {"quartet": detect_t1(edges, cells, min_length=min_length, censor=c, box=box),
                   "cell_neighbours": neighbour_events(edges, cells, min_length=min_length, censor=c)}


def timing_vs_frame_spacing(runs, strides=(1, 2, 4), param="D_r") -> pd.DataFrame:
    """Fig. 3g's per-cell means of both definitions when only every ``stride``-th frame is analysed.

    The paper does not state how often it sampled its runs; both definitions
    see only changes between analysed frames, so the timing can depend on it.
    Events are re-detected (:func:`events_at_spacing`) with each run's own
    ``min_length`` and censoring window (``metadata.json``).

    Parameters
    ----------
    runs : mapping or pandas.DataFrame
        As for :func:`figure3`.
    strides : sequence of int
        Keep every k-th frame.
    param : str
        Name of the swept parameter.

    Returns
    -------
    pandas.DataFrame
        One row per run, stride, definition and quantity: ``param``,
        ``stride``, ``frame_interval`` (time between analysed frames, the
        runs' time unit), ``definition``, ``quantity``, ``n_cells``, ``mean``,
        ``q25``, ``median``, ``q75`` (time unit of the runs), ``t_pvalue``
        (Welch, intercalation interval vs cycle period), ``n_cycles``,
        ``n_intercalations`` (events of that definition).
    """
    rows = []
    for value, folder in _runs(runs).items():
        movie = read_results(folder, lazy=False)
        options = movie.options["events"]  # censor as resolved by hexatissue.analyze
        for stride in strides:
            cells, tables = events_at_spacing(movie.edges, movie.cells, stride, options.min_length, options.censor,
                                              movie.box)
            interval = stride * movie.calibration.frame_interval
            for definition, events in tables.items():
                counts = events["kind"].value_counts()
                timing = timing_across_runs({value: cell_timing(events, cells, frame_interval=interval)}, param=param)
                rows.append(timing.assign(stride=int(stride), frame_interval=interval, definition=definition,
                                          n_cycles=int(counts.get("cycle", 0)),
                                          n_intercalations=int(counts.get("intercalation", 0))))
    cols = [param, "stride", "frame_interval", "definition", "quantity", "n_cells", "mean", "q25", "median", "q75",
            "t_pvalue", "n_cycles", "n_intercalations"]
    return pd.concat(rows, ignore_index=True)[cols]
