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

from ..analysis.migration import DEFAULT_DL, migration_populations, migration_table
from ..analysis.plots import plot_migration, plot_t1_defect_distances, plot_timing, plot_timing_vs_parameter
from ..analysis.proximity import compare_distances, t1_defect_proximity
from ..analysis.timing import cell_timing, timing_across_runs
from ..errors import HexatissueWarning, InputError
from ..frame import read_results
from ..io import atomic_path, write_table

__all__ = ["figure3", "loglog_slope"]


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


def figure3(runs, out, *, param="D_r", p=6, dl=DEFAULT_DL, dt=25, n_control=5, seed=0, include_border=False,
            control="cells") -> dict:
    """Fig. 3e (T1–defect distances), 3f (migration vs defect density) and 3g (event timing) of a sweep.

    Parameters
    ----------
    runs : mapping or pandas.DataFrame
        ``{parameter value: analysis folder}``, or the table returned by
        :func:`~hexatissue.workflows.sweep` (columns ``value``, ``results``).
    out : path
        Folder for the figures (``fig3e.png``, ``fig3f.png``,
        ``fig3g_box.png``, ``fig3g_vs_param.png``), tables (CSV) and
        ``summary.json``.
    param : str
        Name of the swept parameter (axis labels, table columns).
    p : int
        Defect order.
    dl, dt : float, int
        Migration subregion side (px) and window (frames; 25,000 iterations
        are ``25_000 / save_every`` frames).
    n_control : int
        Random cells (or vertices) per T1 event in the proximity control.
    seed : int
        Seeds the control draws (``seed + run index``) and the mixture fit.
    include_border : bool
        Keep border cells and events touching them (see :func:`~hexatissue.workflows.report`).
    control : {"cells", "vertices"}
        Fig. 3e control: random cells (the paper's) or random vertices (needs
        the ``vertices`` tables; see :func:`~hexatissue.analysis.t1_defect_proximity`).

    Returns
    -------
    dict
        The contents of ``summary.json``: per-run and pooled KS tests, the
        migration populations (pooled over runs), the timing summary per run,
        and ``trends``: the log-log slopes of the mean intercalation interval
        and of the mean T1-cycle period against the parameter.  Times are in
        the runs' calibrated unit (MPF runs: iterations), which must be the
        same for every run.
    """
    runs = _runs(runs)
    calibration = None
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ev_parts, ctrl_parts, ks_rows, mig_parts, timing, timing_frames = [], [], [], [], {}, {}
    for k, (value, folder) in enumerate(runs.items()):
        movie = read_results(folder)
        box, cells, events, defects = movie.box, movie.cells, movie.events, movie.defects
        if calibration is not None and movie.calibration != calibration:
            raise InputError(f"{folder}: its calibration {movie.calibration} differs from the other runs' "
                             f"{calibration}; Fig. 3g compares times across runs in one unit")
        calibration = movie.calibration
        if events is None or defects is None:
            raise InputError(f"{folder}: needs events and defects tables (a movie analysed with p including {p})")
        prox = t1_defect_proximity(events, cells, defects, p=p, box=box, n_control=n_control, seed=seed + k,
                                   control=control, vertices=movie.vertices, include_border=include_border)
        ev_parts.append(prox.events.assign(**{param: value}))
        ctrl_parts.append(prox.control.assign(**{param: value}))
        ks_rows.append({param: value, **prox.summary()})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HexatissueWarning)
            mig = migration_table(cells, defects, dl=dl, dt=dt, box=box, p=p, events=events,
                                  include_border=include_border)
        mig_parts.append(mig.assign(**{param: value}))
        timing[value] = cell_timing(events, cells, frame_interval=calibration.frame_interval)
        timing_frames[value] = cell_timing(events, cells)  # the figures convert frames with the calibration
    written = []
    events_all, control_all = pd.concat(ev_parts, ignore_index=True), pd.concat(ctrl_parts, ignore_index=True)
    pooled = compare_distances(events_all, control_all, control)
    written += [write_table(events_all, out / "fig3e_distances.csv"),
                write_table(control_all, out / "fig3e_control.csv"),
                write_table(pd.DataFrame(ks_rows), out / "fig3e_ks.csv")]
    plot_t1_defect_distances(pooled, path=out / "fig3e.png")
    written.append(out / "fig3e.png")

    pops = migration_populations(pd.concat(mig_parts, ignore_index=True), seed=seed)
    written += [write_table(pops.table, out / "fig3f_migration.csv"),
                write_table(pops.summary, out / "fig3f_populations.csv")]
    plot_migration(pops, path=out / "fig3f.png")
    written.append(out / "fig3f.png")

    cells_all = pd.concat([t.assign(**{param: v}) for v, t in timing.items()], ignore_index=True)
    across = timing_across_runs(timing, param=param)
    written += [write_table(cells_all, out / "fig3g_cell_timing.csv"), write_table(across, out / "fig3g_summary.csv")]
    plot_timing(timing_frames, path=out / "fig3g_box.png", calibration=calibration, param=param)
    plot_timing_vs_parameter(timing_across_runs(timing_frames, param=param), param=param,
                             path=out / "fig3g_vs_param.png", calibration=calibration)
    written += [out / "fig3g_box.png", out / "fig3g_vs_param.png"]

    ic = across[across["quantity"] == "intercalation_interval"]
    cy = across[across["quantity"] == "cycle_period"]
    summary = {
        "param": param, "values": list(runs), "p": p, "dl": dl, "dt": dt, "frame_interval": calibration.frame_interval,
        "time_unit": calibration.time_unit, "include_border": include_border, "control": control,
        "fig3e": {"pooled": pooled.summary(), "per_run": ks_rows},
        "fig3f": {"n_subregion_windows": len(pops.table), "threshold": pops.threshold, "delta_bic": pops.delta_bic,
                  "verdict": pops.verdict, "spearman_rho": pops.spearman_rho, "spearman_pvalue": pops.spearman_pvalue,
                  "populations": pops.summary.to_dict("records")},
        "fig3g": across.to_dict("records"),
        "trends": {"intercalation_interval_loglog_slope": loglog_slope(ic[param], ic["mean"]),
                   "cycle_period_loglog_slope": loglog_slope(cy[param], cy["mean"])},
    }
    path = out / "summary.json"
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(summary, indent=2, default=float))
    summary["written"] = [str(w) for w in written + [path]]
    return summary
