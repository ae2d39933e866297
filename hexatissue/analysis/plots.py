"""Figures of the paper's tissue-scale analyses (Fig. 3e–g style), without pyplot.

Every function returns a matplotlib :class:`~matplotlib.figure.Figure` and
writes a PNG atomically when ``path`` is given (same conventions as
:mod:`hexatissue.plot`).  Their input tables are in px and frames, like all
hexatissue tables; a :class:`~hexatissue.units.Calibration` converts
distances to its length unit and times to its time unit on the figure (px
and frames when there is none).  The stages' own report figures are in their
views modules (:mod:`hexatissue.views`).
"""
from __future__ import annotations

import numpy as np

from ..errors import as_generator
from ..plot import (CONTROL_COLOR, EVENT_COLOR, FAST_COLOR, MINUS_COLOR, PLUS_COLOR, SLOW_COLOR, empty_panel,
                    finish_panels, panels)
from ..units import as_calibration

__all__ = ["plot_t1_defect_distances", "plot_migration", "plot_timing", "plot_timing_vs_parameter"]


def _decade(values):
    """Power of ten of the largest finite positive value (0 when there is none)."""
    values = values[np.isfinite(values) & (values > 0)]
    return int(np.floor(np.log10(values.max()))) if len(values) else 0


def plot_t1_defect_distances(result, path=None, calibration=None, figsize=(10, 4), title=None):
    """Distance from T1s and from random cells to the nearest defect (Fig. 3e).

    Left: histograms (probability density) of ``|dr|`` for T1 events and the
    random-cell control, with the KS p-value.  Right: the displacement
    ``(dx, dy)`` from each event to its nearest defect, coloured by that
    defect's charge (red +, blue -).

    Parameters
    ----------
    result : ProximityResult
        Distances in px.
    path : str or Path, optional
        Where to write the PNG.
    calibration : Calibration, optional
        Distances are shown in its length unit (px when None).
    figsize : tuple of float
        Width and height in inches (histogram and displacement panels).
    title : str, optional
        Heading above both panels (e.g. the event definition and the control).

    Returns
    -------
    matplotlib.figure.Figure
    """
    cal = as_calibration(calibration)
    unit = cal.length_label
    fig, (ax, ax2) = panels(2, figsize)
    e, c = cal.length(result.events["dr"].to_numpy(float)), cal.length(result.control["dr"].to_numpy(float))
    if len(e) or len(c):
        top = np.nanmax(np.r_[e, c]) if len(np.r_[e, c]) else 1.0
        bins = np.linspace(0, top * 1.0001 + 1e-12, 21)
        if len(c):
            ax.hist(c, bins=bins, density=True, histtype="stepfilled", color=CONTROL_COLOR, alpha=0.45,
                    label=f"random {result.control_kind} (n={len(c)})")
        if len(e):
            ax.hist(e, bins=bins, density=True, histtype="step", color=EVENT_COLOR, linewidth=2,
                    label=f"T1 events (n={len(e)})")
        ax.legend(frameon=False)
        ax.set_title(f"KS p = {result.ks_pvalue:.2g} (two-sided), {result.ks_pvalue_closer:.2g} (T1s closer)",
                     fontsize=9)
    else:
        empty_panel(ax, "no T1 event with a defect in its frame")
    ax.set_xlabel(f"distance to nearest defect ({unit})")
    ax.set_ylabel("probability density")
    if len(e):
        plus = result.events["charge"].to_numpy(float) > 0
        dx, dy = cal.length(result.events["dx"].to_numpy(float)), cal.length(result.events["dy"].to_numpy(float))
        # thousands of events: small translucent points, drawn in a shuffled order so neither charge hides the other
        n = len(dx)
        order = as_generator(0).permutation(n)
        colors = np.where(plus, PLUS_COLOR, MINUS_COLOR)[order]
        ax2.scatter(dx[order], dy[order], s=12 if n < 500 else 3, c=colors, alpha=min(1.0, max(0.1, 300 / n)),
                    linewidths=0)
        for color, label in ((PLUS_COLOR, "+1/6"), (MINUS_COLOR, "-1/6")):
            ax2.scatter([], [], s=12, color=color, label=label)
        lim = 1.05 * max(np.nanmax(np.abs(np.r_[dx, dy])), 1e-9)
        ax2.set_xlim(-lim, lim)
        ax2.set_ylim(lim, -lim)  # image orientation: y grows downwards
        ax2.axhline(0, color="0.8", lw=0.8)
        ax2.axvline(0, color="0.8", lw=0.8)
        ax2.legend(frameon=False, title="nearest defect", fontsize=8)
    else:
        empty_panel(ax2, "no events")
    ax2.set_aspect("equal")
    ax2.set_xlabel(f"dx = x_defect - x_T1 ({unit})")
    ax2.set_ylabel(f"dy ({unit})")
    return finish_panels(fig, path, title)


def plot_migration(populations, path=None, calibration=None, figsize=(10, 4)):
    """Normalised displacement against defect density, with the slow and fast populations if there are two (Fig. 3f).

    Left: per subregion and window, displacement (log scale) against the mean
    defect density, coloured by population and with the split when
    :attr:`~hexatissue.analysis.MigrationPopulations.two_populations` (its
    ``verdict`` is ``"two populations"``); otherwise in one colour, with no
    split.  Right: histogram of log10(displacement) with the fitted
    two-component mixture (its components as slow and fast only when they
    are two populations) and the verdict.

    Parameters
    ----------
    populations : MigrationPopulations
        Defect densities in px^-2; the displacement is dimensionless
        (normalised by the subregion size).
    path : str or Path, optional
        Where to write the PNG.
    calibration : Calibration, optional
        Defect densities are shown per square length unit (px^-2 when None),
        scaled by the power of ten of their largest value.
    figsize : tuple of float
        Width and height in inches (scatter and histogram panels).

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = populations.table
    cal = as_calibration(calibration)
    fig, (ax, ax2) = panels(2, figsize)
    moved = t["displacement"].to_numpy(float) > 0
    density = t["defect_density"].to_numpy(float) / cal.area(1.0)
    decade = _decade(density[moved])
    split = populations.two_populations
    if moved.any():
        groups = ((("slow", SLOW_COLOR), ("fast", FAST_COLOR), ("", "0.5")) if split else ((None, "0.35"),))
        population = t["population"].to_numpy(str)
        for name, color in groups:
            part = moved & (population == name) if name is not None else moved
            if part.any():
                label = (name or "unclassified") if name is not None else "subregion-windows"
                ax.scatter(density[part] / 10.0**decade, t["displacement"].to_numpy(float)[part], s=10, color=color,
                           alpha=0.7, label=label)
        ax.set_yscale("log")
        ax.legend(frameon=False)
        title = f"Spearman rho = {populations.spearman_rho:.2f}"
        if split:
            ax.axhline(populations.threshold, color="0.3", ls="--", lw=0.8)
            title += f"; slow/fast split at {populations.threshold:.3g}"
        else:
            title += f"; {populations.verdict}: no split"
        ax.set_title(title, fontsize=9)
    else:
        empty_panel(ax, "no complete window")
    scale = f"$10^{{{decade}}}$ " if decade else ""
    ax.set_xlabel(f"defect density ({scale}{cal.length_label}$^{{-2}}$)")
    ax.set_ylabel(r"$\sum_t |\Delta r|^2 / \Delta\ell^2$")
    logd = t["log_displacement"].to_numpy(float)
    logd = logd[np.isfinite(logd)]
    if len(logd):
        ax2.hist(logd, bins=max(5, min(40, len(logd) // 3)), density=True, color="0.75")
        if populations.mixture is not None:
            x = np.linspace(logd.min() - 0.3, logd.max() + 0.3, 300)
            m = populations.mixture
            comps = np.exp(m.log_densities(x))
            ax2.plot(x, comps.sum(axis=1), color="k", lw=1, ls="--", label="two-component mixture")
            if split:
                ax2.plot(x, comps[:, 0], color=SLOW_COLOR, lw=2, alpha=0.8, label="slow component")
                ax2.plot(x, comps[:, 1], color=FAST_COLOR, lw=2, alpha=0.8, label="fast component")
                ax2.axvline(np.log10(populations.threshold), color="0.3", ls=":", lw=0.8)
            elif populations.single is not None:
                ax2.plot(x, np.exp(populations.single.log_densities(x)).sum(axis=1), color="0.2", lw=2, alpha=0.8,
                         label="one component")
            ax2.set_title(f"delta BIC (1 vs 2 components) = {populations.delta_bic:.1f}: "
                          f"{populations.verdict}", fontsize=9)
            ax2.legend(frameon=False)
    else:
        empty_panel(ax2, "no data")
    ax2.set_xlabel(r"$\log_{10}$ normalised displacement")
    ax2.set_ylabel("probability density")
    return finish_panels(fig, path)


def plot_timing(runs, path=None, calibration=None, param="D_r", figsize=None, title=None):
    """Box plots of the per-cell intercalation interval and T1-cycle period (Fig. 3g).

    Parameters
    ----------
    runs : pandas.DataFrame or mapping
        One per-cell table (:func:`~hexatissue.analysis.cell_timing` with its
        default ``frame_interval=1``, i.e. in frames), or
        ``{parameter value: table}`` for one pair of boxes per run.
    path : str or Path, optional
        Where to write the PNG.
    calibration : Calibration, optional
        Times are shown in its time unit (frames when None).
    param : str
        Name of the parameter the runs differ in (tick labels).
    figsize : tuple of float, optional
        Grows with the number of runs when None.
    title : str, optional
        Heading above the plot (e.g. the event definition).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from .timing import timing_test

    cal = as_calibration(calibration)
    if not isinstance(runs, dict):
        runs = {None: runs}
    fig, (ax,) = panels(1, figsize or (max(4.5, 1.6 * len(runs) + 2), 4))
    data, pos, colors, groups, pvalues = [], [], [], [], []
    for k, (value, table) in enumerate(runs.items()):
        for j, (col, color) in enumerate((("mean_intercalation_interval", SLOW_COLOR),
                                          ("mean_cycle_period", FAST_COLOR))):
            v = cal.time(table[col].to_numpy(float))
            data.append(v[np.isfinite(v)])
            pos.append(3 * k + j)
            colors.append(color)
        p = timing_test(table)["pvalue"]
        text = f"{p:.2g}" if np.isfinite(p) else "n/a"
        groups.append(None if value is None else f"{param}={value:g}")
        pvalues.append(text if value is None else f"{param}={value:g}: {text}")
    nonempty = [i for i, d in enumerate(data) if len(d)]
    if nonempty:
        bp = ax.boxplot([data[i] for i in nonempty], positions=[pos[i] for i in nonempty], widths=0.8,
                        patch_artist=True, showmeans=True)
        for patch, i in zip(bp["boxes"], nonempty):
            patch.set_facecolor(colors[i])
            patch.set_alpha(0.6)
    else:
        empty_panel(ax, "no intercalation interval or cycle period")
    if len(runs) == 1 and groups[0] is None:  # one run: a tick per category
        ax.set_xticks([0, 1], ["between\nintercalations", "T1-cycle\nperiod"])
    else:  # a pair of boxes per run, ticked with its parameter value
        ax.set_xticks([3 * k + 0.5 for k in range(len(runs))], groups)
    ax.set_xlim(-1, 3 * len(runs) - 1)
    ax.set_ylabel(f"time ({cal.time_label})")
    from matplotlib.patches import Patch

    ax.legend(handles=[Patch(color=SLOW_COLOR, alpha=0.6, label="between intercalations"),
                       Patch(color=FAST_COLOR, alpha=0.6, label="T1-cycle period")], frameon=False, fontsize=8)
    ax.set_title("per-cell means; Welch t-test p = " + ", ".join(pvalues), fontsize=9, wrap=True)
    return finish_panels(fig, path, title)


def plot_timing_vs_parameter(summary, param="D_r", path=None, calibration=None, figsize=(5, 4), title=None):
    """Mean (markers) and quartiles (bars) of both per-cell quantities against a sweep parameter.

    Parameters
    ----------
    summary : pandas.DataFrame
        :func:`~hexatissue.analysis.timing_across_runs` output of tables in frames.
    param : str
        The sweep parameter (a column of ``summary``).
    path : str or Path, optional
        Where to write the PNG.
    calibration : Calibration, optional
        Times are shown in its time unit (frames when None).
    figsize : tuple of float
        Width and height in inches.
    title : str, optional
        Heading above the plot (e.g. the event definition).

    Returns
    -------
    matplotlib.figure.Figure
    """
    cal = as_calibration(calibration)
    fig, (ax,) = panels(1, figsize)
    for name, color, label in (("intercalation_interval", SLOW_COLOR, "between intercalations"),
                               ("cycle_period", FAST_COLOR, "T1-cycle period")):
        s = summary[summary["quantity"] == name].sort_values(param)
        s = s[np.isfinite(s["mean"].to_numpy(float))]
        if len(s):
            x = s[param].to_numpy(float)
            mean, q25, q75 = (cal.time(s[c].to_numpy(float)) for c in ("mean", "q25", "q75"))
            # quartile bars drawn from q25 to q75, not as errors about the mean: the mean of skewed per-cell
            # means can lie outside its quartiles (e.g. one short interval among long ones)
            ax.vlines(x, q25, q75, color=color, linewidth=1.5)
            ax.plot(x, mean, color=color, marker="o", label=label)
    values = summary[param].to_numpy(float)
    if len(values) and (values > 0).all() and values.max() / values.min() >= 3:
        ax.set_xscale("log")
        from matplotlib.ticker import NullFormatter

        # label exactly the swept values (the default minor labels of a short log axis overlap)
        ticks = np.unique(values)
        ax.set_xticks(ticks, [f"{v:g}" for v in ticks])
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(param)
    ax.set_ylabel(f"time ({cal.time_label})")
    ax.legend(frameon=False)
    return finish_panels(fig, path, title)
