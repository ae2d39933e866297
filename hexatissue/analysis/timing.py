"""Event timing per cell: intercalation intervals vs T1-cycle periods (the paper's Fig. 3g).

Per cell, the mean time between consecutive intercalations it takes part in
and the mean period (duration) of its T1 cycles, both from
:func:`hexatissue.events.cell_event_stats`.  Times are in frames; multiply by
the frame interval (e.g. the MPF ``save_every`` in iterations) for physical
units.  The two per-cell populations are compared with a two-sided Welch
t-test (:func:`scipy.stats.ttest_ind` with ``equal_var=False``: the two
populations need not share a variance), and runs of a parameter sweep are
summarised by the mean and quartiles of each population.
"""
from __future__ import annotations

import warnings

from collections.abc import Mapping

import numpy as np
import pandas as pd

from ..errors import InputError
from ..events import cell_event_stats
from ..errors import check_positive
from ..schema import require_columns

__all__ = ["cell_timing", "in_time_units", "timing_test", "timing_summary", "timing_across_runs", "TIMING_QUANTITIES"]

#: The two per-cell quantities compared: column of cell_event_stats -> short name.
TIMING_QUANTITIES = {"mean_intercalation_interval": "intercalation_interval", "mean_cycle_period": "cycle_period"}


def cell_timing(events, cells=None, frame_interval=1.0):
    """Per-cell intercalation interval and T1-cycle period.

    Parameters
    ----------
    events : pandas.DataFrame
        Quartet events (:func:`~hexatissue.detect_t1`) or the paper's per-cell
        events (:func:`~hexatissue.events.neighbour_events`).
    cells : pandas.DataFrame, optional
        Cells table (every cell gets a row; see :func:`~hexatissue.events.cell_event_stats`).
    frame_interval : float
        Time per frame; the two time columns are multiplied by it.

    Returns
    -------
    pandas.DataFrame
        :func:`~hexatissue.events.cell_event_stats` columns (``track``,
        ``n_frames``, ``n_cycles``, ``n_intercalations``, ``n_unresolved``,
        ``mean_cycle_period``, ``n_intervals``,
        ``mean_intercalation_interval``), the two means in units of
        ``frame_interval`` (frames by default).
    """
    per_cell = "track" in events.columns and "cell_a" not in events.columns  # neighbour_events
    cells_of = ("track",) if per_cell else ("cell_a", "cell_b", "cell_c", "cell_d")
    require_columns(events, ("kind", "frame_start", "duration") + cells_of, "events")
    return in_time_units(cell_event_stats(events, cells), frame_interval)


def in_time_units(stats_table, frame_interval):
    """A copy of a per-cell table in frames with its two time columns multiplied by ``frame_interval``.

    The figures take tables in frames and convert them themselves; the CSV
    tables are in the user's time unit. Both come from one
    :func:`cell_timing` call this way.
    """
    require_columns(stats_table, tuple(TIMING_QUANTITIES), "stats_table")
    frame_interval = check_positive(frame_interval, "frame_interval")
    out = stats_table.copy()
    for col in TIMING_QUANTITIES:
        out[col] = out[col] * frame_interval
    return out


def _values(stats_table, column):
    v = stats_table[column].to_numpy(float)
    return v[np.isfinite(v)]


def timing_summary(stats_table):
    """Mean, median and quartiles of both per-cell quantities.

    Returns
    -------
    pandas.DataFrame
        One row per quantity (``intercalation_interval``, ``cycle_period``):
        ``quantity``, ``n_cells``, ``mean``, ``q25``, ``median``, ``q75``
        (time units of the input; NaN when no cell has a value).
    """
    require_columns(stats_table, tuple(TIMING_QUANTITIES), "stats_table")
    rows = []
    for col, name in TIMING_QUANTITIES.items():
        v = _values(stats_table, col)
        q = np.quantile(v, [0.25, 0.5, 0.75]) if len(v) else np.full(3, np.nan)
        rows.append({"quantity": name, "n_cells": len(v), "mean": float(v.mean()) if len(v) else np.nan,
                     "q25": float(q[0]), "median": float(q[1]), "q75": float(q[2])})
    return pd.DataFrame(rows)


def timing_test(stats_table):
    """Two-sided Welch t-test between the cells' intercalation intervals and cycle periods.

    Returns
    -------
    dict
        ``t_statistic``, ``pvalue`` (NaN unless both populations have at
        least two cells), ``n_intercalation_cells``, ``n_cycle_cells``.
    """
    require_columns(stats_table, tuple(TIMING_QUANTITIES), "stats_table")
    a, b = _values(stats_table, "mean_intercalation_interval"), _values(stats_table, "mean_cycle_period")
    if len(a) >= 2 and len(b) >= 2:
        with warnings.catch_warnings():
            # identical values in a population (e.g. every cycle lasting one frame): scipy warns of precision
            # loss in the variance; the statistic it returns (inf or NaN) says the same, and is reported
            warnings.filterwarnings("ignore", message="Precision loss occurred", category=RuntimeWarning)
            from scipy import stats  # here, not at the top: ~18 MB and 0.3 s that every CLI call paid
            res = stats.ttest_ind(a, b, equal_var=False)
        t, pval = float(res.statistic), float(res.pvalue)
    else:
        t = pval = float("nan")
    return {"t_statistic": t, "pvalue": pval, "n_intercalation_cells": len(a), "n_cycle_cells": len(b)}


def timing_across_runs(runs, param="D_r"):
    """Mean and quartiles of both quantities for every run of a sweep.

    Parameters
    ----------
    runs : mapping
        ``{parameter value: per-cell table}`` (:func:`cell_timing` output).
    param : str
        Name of the parameter column.

    Returns
    -------
    pandas.DataFrame
        ``param``, then the :func:`timing_summary` columns, and ``t_pvalue``
        (the run's :func:`timing_test` p-value), sorted by the parameter.
    """
    if not isinstance(runs, Mapping) or not runs:
        raise InputError("runs must be a non-empty mapping {parameter value: per-cell timing table}")
    parts = []
    for value, table in runs.items():
        s = timing_summary(table)
        s.insert(0, param, float(value))
        s["t_pvalue"] = timing_test(table)["pvalue"]
        parts.append(s)
    return pd.concat(parts, ignore_index=True).sort_values([param, "quantity"], ignore_index=True)
