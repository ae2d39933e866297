"""Figures of the tissue-scale analyses (Fig. 3e–g style), without pyplot.

Every function returns a matplotlib :class:`~matplotlib.figure.Figure` and
writes a PNG atomically when ``path`` is given (same conventions as
:mod:`hexatissue.plot`).  Their input tables are in px and frames, like all
hexatissue tables; a :class:`~hexatissue.units.Calibration` converts
distances to its length unit and times to its time unit on the figure (px
and frames when there is none).
"""
from __future__ import annotations

from textwrap import fill

import numpy as np

from ..errors import as_generator
from ..flow import correlation_length, in_units, msd_exponent, reliable_bins, velocity_unit
from ..plot import MINUS_COLOR, PLUS_COLOR, save_figure
from ..units import as_calibration

__all__ = ["plot_cell_distributions", "plot_t1_defect_distances", "plot_migration", "plot_timing", "plot_timing_vs_parameter",
           "plot_event_overview", "plot_flow_statistics", "plot_event_flow"]

EVENT_COLOR = "#2a7f62"
CONTROL_COLOR = "#7f7f7f"
SLOW_COLOR = "#1f77b4"
FAST_COLOR = "#ff7f0e"


def _figure(ncols, figsize):
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=100, layout="constrained")
    return fig, [fig.add_subplot(1, ncols, k + 1) for k in range(ncols)]


def _finish(fig, path, title=None):
    if title:
        fig.suptitle(title, fontsize=10)
    if path is not None:
        save_figure(fig, path, dpi=110)
    return fig


def _decade(values):
    """Power of ten of the largest finite positive value (0 when there is none)."""
    values = values[np.isfinite(values) & (values > 0)]
    return int(np.floor(np.log10(values.max()))) if len(values) else 0


def _empty(ax, text):
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, color="0.4")


def plot_cell_distributions(cells, path=None, calibration=None, figsize=(10, 3.6)):
    """Distributions of the interior cells' number of sides and area, over every frame of ``cells``.

    Parameters
    ----------
    cells : pandas.DataFrame
        A ``cells`` table (``n_sides``, ``area`` in px^2, ``is_border``); border cells are left out (cut by the
        image edge), and so are cells without a polygon (``n_sides`` < 3) from the sides panel.
    path : path-like, optional
        PNG written atomically.
    calibration : Calibration, optional
        Areas in its length unit squared (px^2 when None).

    Returns
    -------
    matplotlib.figure.Figure
        Left: fraction of cells per number of sides, with the percentages; right: histogram of the areas with
        the mean marked.
    """
    cal = as_calibration(calibration)
    inner = cells[~cells["is_border"].to_numpy(bool)]
    fig, (left, right) = _figure(2, figsize)
    sides = inner["n_sides"].to_numpy(int)
    sides = sides[sides >= 3]
    if len(sides):
        values, counts = np.unique(sides, return_counts=True)
        share = counts / counts.sum()
        left.bar(values, share, color=EVENT_COLOR, width=0.8)
        for v, f in zip(values, share):
            left.text(v, f, f"{100 * f:.1f}%", ha="center", va="bottom", fontsize=8)
        left.set_xticks(values)
        left.set_ylim(0, min(1.0, share.max() * 1.18))
    else:
        _empty(left, "no interior cell with a polygon")
    left.set_xlabel("number of sides (neighbours)")
    left.set_ylabel("fraction of interior cells")
    left.set_title(f"{len(sides)} interior cell-frames", fontsize=10)
    area = cal.area(inner["area"].to_numpy(float))
    unit = f"{cal.length_label}$^2$" if cal.has_length else "px$^2$"
    if len(area):
        right.hist(area, bins=min(40, max(5, len(area) // 10)), color=CONTROL_COLOR)
        right.axvline(area.mean(), color="k", linewidth=1)
        right.text(area.mean(), right.get_ylim()[1] * 0.95, f" mean {area.mean():.3g} {unit}", fontsize=8,
                   va="top")
    else:
        _empty(right, "no interior cell")
    right.set_xlabel(f"cell area ({unit})")
    right.set_ylabel("cells")
    return _finish(fig, path, "interior cells: neighbour number and area")


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
    fig, (ax, ax2) = _figure(2, figsize)
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
        _empty(ax, "no T1 event with a defect in its frame")
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
        _empty(ax2, "no events")
    ax2.set_aspect("equal")
    ax2.set_xlabel(f"dx = x_defect - x_T1 ({unit})")
    ax2.set_ylabel(f"dy ({unit})")
    return _finish(fig, path, title)


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
    fig, (ax, ax2) = _figure(2, figsize)
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
        _empty(ax, "no complete window")
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
        _empty(ax2, "no data")
    ax2.set_xlabel(r"$\log_{10}$ normalised displacement")
    ax2.set_ylabel("probability density")
    return _finish(fig, path)


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
    fig, (ax,) = _figure(1, figsize or (max(4.5, 1.6 * len(runs) + 2), 4))
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
        _empty(ax, "no intercalation interval or cycle period")
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
    return _finish(fig, path, title)


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
    fig, (ax,) = _figure(1, figsize)
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
    return _finish(fig, path, title)


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
    fig, (ax, ax2) = _figure(2, figsize)
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
        _empty(ax, "no T1 events")
    ax.set_xlabel(f"time ({cal.time_label})")
    ax.set_ylabel("T1 events starting per frame")
    d = events.loc[events["kind"] == "cycle", "duration"].to_numpy(float) if len(events) else np.zeros(0)
    d = d[np.isfinite(d)]
    if len(d):
        bins = _duration_bins(d)
        ax2.hist(cal.time(d), bins=cal.time(bins), color=FAST_COLOR)
    else:
        _empty(ax2, "no T1 cycles")
    ax2.set_xlabel(f"T1-cycle duration ({cal.time_label})")
    ax2.set_ylabel("cycles")
    return _finish(fig, path)


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


def plot_flow_statistics(per_frame, correlation, msd, path=None, calibration=None, spacing=None, figsize=(12, 3.8)):
    """Mean speed and polar order over time, the velocity correlation C(r), and the MSD.

    Parameters
    ----------
    per_frame, correlation, msd : pandas.DataFrame
        :func:`hexatissue.flow.velocity_statistics`,
        :func:`hexatissue.flow.velocity_correlation` and
        :func:`hexatissue.flow.mean_squared_displacement` (px and frames).
    calibration : Calibration, optional
        Units of the axes (px and frames when None).
    spacing : float, optional
        The cell spacing, px (:func:`hexatissue.flow.cell_spacing`): a
        correlation length below it is refused.

    Returns
    -------
    matplotlib.figure.Figure
        Three panels; C(r) shows its :func:`hexatissue.flow.reliable_bins`
        with their standard errors, the fitted ``A exp(-r / xi) + B`` and its
        length xi (:func:`hexatissue.flow.correlation_length`, or why it is
        refused); the MSD exponent is marked.
    """
    cal = as_calibration(calibration)
    fig, (a, b, c) = _figure(3, figsize)
    time = cal.time(per_frame["frame"].to_numpy(float))
    a.plot(time, in_units(per_frame["mean_speed"].to_numpy(float), cal), color="k", lw=1)
    a.set_xlabel(f"time ({cal.time_label})")
    a.set_ylabel(f"mean speed ({velocity_unit(cal)})")
    twin = a.twinx()
    twin.plot(time, per_frame["polar_order"].to_numpy(float), color=FAST_COLOR, lw=1)
    twin.set_ylabel("polar order", color=FAST_COLOR)
    twin.set_ylim(0, 1)
    shown = reliable_bins(correlation)  # bins of a few pairs (tiny cells) are noise
    r_px = correlation["r"].to_numpy(float)[shown]
    value = correlation["correlation"].to_numpy(float)[shown]
    sd = (correlation["correlation_sd"].to_numpy(float)[shown] if "correlation_sd" in correlation.columns
          else np.full(len(value), np.nan))
    b.errorbar(cal.length(r_px), value, yerr=np.where(np.isfinite(sd), sd, 0.0), fmt="o", ms=3, color=SLOW_COLOR,
               lw=0.8, capsize=0)
    b.plot([0.0], [1.0], "o", ms=3, mfc="none", color=SLOW_COLOR)  # C(0) = 1: a cell with itself
    b.axhline(0.0, color="0.7", lw=0.6)
    fit = correlation_length(correlation, spacing)
    if np.isfinite(fit.length):
        x = np.linspace(0.0, fit.r_fit, 100)
        b.plot(cal.length(x), fit.amplitude * np.exp(-x / fit.length) + fit.offset, color="0.3", lw=0.9)
        b.axvline(cal.length(fit.length), color="0.3", lw=0.8, ls=":")
        b.set_title(f"correlation length {cal.length(fit.length):.3g} ± {cal.length(fit.sd):.2g} "
                    f"{cal.length_label} (A = {fit.amplitude:.2f})", fontsize=9)
    else:
        b.set_title("no correlation length", fontsize=9)
        b.text(0.98, 0.95, fill(fit.reason, 40), transform=b.transAxes, ha="right", va="top", fontsize=7)
    b.set_xlabel(f"r ({cal.length_label})")
    b.set_ylabel("velocity correlation C(r)")
    ok = np.isfinite(msd["msd"].to_numpy(float)) & (msd["msd"].to_numpy(float) > 0)
    if ok.any():
        c.loglog(cal.time(msd["lag"].to_numpy(float)[ok]), in_units(msd["msd"].to_numpy(float)[ok], cal, 2, 0),
                 "o-", ms=3, color="k")
        c.set_title(f"MSD exponent {msd_exponent(msd):.2f}", fontsize=9)
        from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

        # lags of one or two decades: plain numbers at 1, 2, 5 x 10^k (log minor labels overlap)
        c.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        c.xaxis.set_major_formatter(ScalarFormatter())
        c.xaxis.set_minor_formatter(NullFormatter())
    else:
        _empty(c, "no displacement pairs")
    c.set_xlabel(f"lag ({cal.time_label})")
    c.set_ylabel(f"MSD ({cal.length_label}$^2$)")
    return _finish(fig, path)


def plot_event_flow(average, path=None, calibration=None, title=None, x_label="x along the junction"):
    """Event-centred mean flow: one panel per kind (rows) and time offset (columns).

    Arrows are the mean relative velocity of each bin, over the radial
    velocity ``v_r`` in colour (red: outward), in the event's axes (a T1's
    vanishing junction along x, :func:`hexatissue.flow.t1_flow`; a defect's
    orientation, :func:`hexatissue.flow.defect_flow`).

    Parameters
    ----------
    average : pandas.DataFrame
        The ``average`` table of :func:`hexatissue.flow.t1_flow` or
        :func:`hexatissue.flow.defect_flow` (px, px/frame).
    calibration : Calibration, optional
        Units of the axes and the colour bar (px and frames when None).
    x_label : str
        What the x axis of the event's axes is.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    cal = as_calibration(calibration)
    kinds = list(dict.fromkeys(average["kind"].astype(str)))
    offsets = sorted(set(average["offset"].tolist()))
    fig = Figure(figsize=(3.2 * max(len(offsets), 1) + 1.0, 3.0 * max(len(kinds), 1)), dpi=100, layout="constrained")
    axes = fig.subplots(max(len(kinds), 1), max(len(offsets), 1), squeeze=False)
    if not len(average):
        _empty(axes[0, 0], "no event with velocities")
        return _finish(fig, path, title)
    x, y = average["x"].to_numpy(float), average["y"].to_numpy(float)
    u, v = average["vx"].to_numpy(float), average["vy"].to_numpy(float)
    r = np.hypot(x, y)
    with np.errstate(invalid="ignore", divide="ignore"):
        radial = np.where(r > 0, (x * u + y * v) / r, 0.0)
    top = float(np.nanpercentile(np.abs(in_units(radial, cal)), 98)) or 1.0
    speed = float(np.percentile(np.hypot(u, v), 95)) or 1.0
    gx, gy = np.unique(x), np.unique(y)  # the bins' lattice, shared by the panels
    step = float(np.min(np.diff(gx))) if len(gx) > 1 else 1.0
    mesh = None
    for i, kind in enumerate(kinds):
        for j, offset in enumerate(offsets):
            ax = axes[i, j]
            sel = (average["kind"].astype(str).to_numpy() == kind) & (average["offset"].to_numpy() == offset)
            if not sel.any():
                _empty(ax, "no event")
                continue
            image = np.full((len(gy), len(gx)), np.nan)
            image[np.searchsorted(gy, y[sel]), np.searchsorted(gx, x[sel])] = in_units(radial[sel], cal)
            mesh = ax.pcolormesh(cal.length(gx), cal.length(gy), np.ma.masked_invalid(image), cmap="RdBu_r",
                                 vmin=-top, vmax=top, shading="nearest")
            ax.quiver(cal.length(x[sel]), cal.length(y[sel]), u[sel], v[sel], angles="xy", scale_units="xy",
                      scale=speed / (0.9 * cal.length(step)), width=0.006)
            ax.plot([0], [0], "k+", ms=8)
            ax.set_aspect("equal")
            ax.invert_yaxis()  # image orientation, as the tissue figures
            n_events = int(average.loc[sel, "n_events"].iloc[0])
            ax.set_title(f"{kind}, offset {offset:+d} frames ({n_events} events)", fontsize=8)
            ax.set_xlabel(f"{x_label} ({cal.length_label})", fontsize=8)
            ax.set_ylabel(f"y ({cal.length_label})", fontsize=8)
    if mesh is not None:
        fig.colorbar(mesh, ax=axes, shrink=0.6, label=f"radial velocity ({velocity_unit(cal)})")
    return _finish(fig, path, title)
