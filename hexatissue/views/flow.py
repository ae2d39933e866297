"""The tissue flow's presentation: velocity statistics, the flow field and the flow around T1s and defects in the
report, the flow arrows in napari, its switch in the napari widget."""
from __future__ import annotations

from textwrap import fill

import numpy as np
import pandas as pd

from ..flow import (angular_harmonics, correlation_length, defect_flow, flow_summary, mean_squared_displacement,
                    msd_exponent, reliable_bins, t1_flow, velocity_correlation, velocity_statistics)
from ..flow.piv import piv_agreement
from ..plot import FAST_COLOR, SLOW_COLOR, empty_panel, finish_panels, panels, plot_flow, typical_spacing
from ..theory import quadrupole_flow_exact
from ..units import as_calibration, in_units, velocity_unit
from . import LayerMaker, Section, StageView, columns, has_column, single, WidgetField
from .layerdata import common, coords
from .text import length, rate

__all__ = ["VIEW", "plot_flow_statistics", "plot_event_flow", "flow_layer", "FLOW_ARROW", "FLOW_COLOR", "T1_OFFSETS"]


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
    fig, (a, b, c) = panels(3, figsize)
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
        empty_panel(c, "no displacement pairs")
    c.set_xlabel(f"lag ({cal.time_label})")
    c.set_ylabel(f"MSD ({cal.length_label}$^2$)")
    return finish_panels(fig, path)


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
        empty_panel(axes[0, 0], "no event with velocities")
        return finish_panels(fig, path, title)
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
                empty_panel(ax, "no event")
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
    return finish_panels(fig, path, title)


#: The columns of ``cells`` that the report's flow statistics and the flow around T1s and defects read, over every
#: frame (the velocity statistics, the MSD and the centred flows follow the tracks through the movie).
MOVING_CELLS = ("frame", "track", "cell", "x", "y", "vx", "vy", "area", "is_border")
#: The columns of ``flow`` that the report's numbers read (the PIV ones when the flow has them).
FLOW_NUMBERS = ("frame", "valid", "radius", "vorticity", "divergence", "vx", "vy", "piv_vx", "piv_vy")


def _flow(movie, report):
    """The tissue flow: velocity statistics, the flow field of a middle frame, C(r) and the MSD."""
    cal, box = movie.calibration, movie.box
    if not has_column(movie, "cells", "vx"):
        return ["## Tissue flow", "", "No cell velocities in the results folder (analysed with `--no-flow`).", ""]
    cells = columns(movie, "cells", MOVING_CELLS)
    per_frame = velocity_statistics(cells)
    correlation = velocity_correlation(cells, box)
    msd = mean_squared_displacement(cells, box)
    summary = flow_summary(cells, box, correlation, msd)
    report.numbers["flow"] = summary
    lines = ["## Tissue flow", "",
             f"- cell velocities: {summary['n_velocities']} cell-frames (centred differences along the tracks; none "
             f"on the first and last frame of a track, at divisions or beside gaps; border cells left out)"]
    if summary["n_velocities"] == 0:
        return lines + ["", "No interior cell has a velocity (every track is shorter than three frames).", ""]
    if summary["mean_speed"] == 0:
        return lines + ["", "No cell moved: every velocity is 0 (no polar order, correlation or MSD to measure).", ""]
    xi = summary["correlation_length"]
    lines += [f"- mean speed {rate(cal, summary['mean_speed'])}; rms velocity {rate(cal, summary['rms_velocity'])} "
              f"(centred differences over two frames); rms frame-to-frame step {rate(cal, summary['rms_step'])} "
              f"(larger by the motion that reverses within a frame: centroid jitter of the segmentation and "
              f"fluctuations, which the two-frame difference averages out)",
              f"- polar order of the velocities (mean over frames): {summary['polar_order']:.3g}",
              "- velocity correlation length (a fit of A exp(-r/xi) + B to C(r) of the velocity fluctuations up to its "
              "first zero; bins with under 10 pairs or 1 % of the fullest bin's left out): "
              + (f"{length(cal, xi)} ± {length(cal, summary['correlation_length_sd'])} over "
                 f"{summary['correlation_bins']} bins, A = {summary['correlation_amplitude']:.2f} (the share of the "
                 f"velocity fluctuations that correlates between cells)" if np.isfinite(xi)
                 else f"not measured: {summary['correlation_reason']}"),
              f"- MSD exponent (MSD ~ lag^alpha, lags {int(msd['lag'].min())}-{int(msd['lag'].max())} frames): "
              f"{summary['msd_exponent']:.3g}"]
    flow = columns(movie, "flow", FLOW_NUMBERS)
    shown = None
    if flow is not None and flow["valid"].any():
        valid = flow[flow["valid"]]
        report.numbers["flow"]["valid_nodes"] = float(flow["valid"].mean())
        lines += [f"- flow fields on the Gamma_p grid: {100 * flow['valid'].mean():.1f} % of the nodes have a fit "
                  f"(disks of {length(cal, float(valid['radius'].median()))}); mean |vorticity| "
                  f"{rate(cal, float(valid['vorticity'].abs().mean()), 0)}, mean |divergence| "
                  f"{rate(cal, float(valid['divergence'].abs().mean()), 0)}"]
        frames = np.unique(valid["frame"].to_numpy())
        shown = int(frames[len(frames) // 2])
        if "piv_vx" in flow.columns:
            agree = piv_agreement(flow)
            report.numbers["flow"]["piv"] = agree
            lines.append(f"- PIV of the raw channel on the same nodes ({agree['nodes']} node-frames with both fields): "
                         + (f"rms velocity {rate(cal, agree['rms_piv'])} (tracks: {rate(cal, agree['rms_tracks'])}), "
                            f"rms difference {rate(cal, agree['rms_difference'])} "
                            f"({agree['relative_difference']:.2f} of the tracks' rms); correlation of the components "
                            f"r_x = {agree['r_vx']:.2f}, r_y = {agree['r_vy']:.2f}" if agree["nodes"] else
                            "none to compare"))
    lines.append("")
    path = report.out / "flow_statistics.png"
    plot_flow_statistics(per_frame, correlation, msd, path=path, calibration=cal,
                         spacing=summary["cell_spacing"])
    report.table(per_frame, "flow_per_frame.csv")
    report.table(correlation, "velocity_correlation.csv")
    report.table(msd, "msd.csv")
    lines += report.figure(path, "flow statistics")
    if shown is not None:
        path = report.out / f"flow_frame{shown:04d}.png"
        plot_flow(movie.table_at("flow", shown), polygons=movie.polygons(shown), box=box, calibration=cal,
                       path=path)
        lines += report.figure(path, f"flow, frame {shown}")
    if movie.events is not None and len(movie.events):
        lines += _t1_flow_lines(movie, cells, report)
    if movie.defects is not None and has_column(movie, "grid", f"Gamma{report.p}_re"):
        lines += _defect_flow_lines(movie, cells, report)
    return lines


def _harmonics_table(harmonics, cal):
    """Markdown rows of the radial harmonics n = 2, 4, 6 of each kind, and the numbers by kind."""
    lines, numbers = ["| kind | n = 2 | n = 4 | n = 6 | share of n = 6 |", "|---|---|---|---|---|"], {}
    for kind, group in harmonics.groupby("kind"):
        amp = group.set_index("n")["radial_amplitude"]
        share = _n6_share(group)
        numbers[str(kind)] = {"radial_n2": float(amp[2]), "radial_n4": float(amp[4]), "radial_n6": float(amp[6]),
                              "n6_share": share}
        lines.append(f"| {kind} | {rate(cal, amp[2])} | {rate(cal, amp[4])} | {rate(cal, amp[6])} | {share:.2f} |")
    return lines, numbers


def _defect_flow_lines(movie, cells, report):
    """The flow averaged around the ±1/p defects in their own axes, and its harmonics (``cells``: the
    :data:`MOVING_CELLS` columns)."""
    cal, p = movie.calibration, report.p
    defects = columns(movie, "defects", ["frame", "defect", "x", "y", "charge", "p"])
    grid = columns(movie, "grid", ["frame", "x", "y", f"Gamma{p}_re", f"Gamma{p}_im", "valid", "spacing"])
    average, samples = defect_flow(cells, defects, grid, p=p, box=movie.box)
    del defects, grid
    if not len(samples):
        return [f"### Flow around ±1/{p} defects", "", f"No ±1/{p} defect has cells with velocities around it.", ""]
    r_cell = float(np.sqrt(np.nanmean(cells["area"].to_numpy(float)) / np.pi))
    harmonics = angular_harmonics(samples, r_min=r_cell)
    path = report.out / "defect_flow.png"
    plot_event_flow(average, path=path, calibration=cal, title=f"mean flow around ±1/{p} defects (defect axes)",
                    x_label="x along the defect's axis")
    report.table(average, "defect_flow.csv")
    report.table(harmonics, "defect_flow_harmonics.csv")
    table, report.numbers["defect_flow"] = _harmonics_table(harmonics, cal)
    return [f"### Flow around ±1/{p} defects", "",
            f"Cells within {length(cal, 4 * r_cell)} of each ±1/{p} defect, their velocity minus their mean, in "
            f"axes turned by the defect's orientation from the Gamma_{p} phase. Radial harmonics (samples beyond "
            f"{length(cal, r_cell)}):", "", *table, "", *report.figure(path, f"flow around ±1/{p} defects")]


#: Offsets (frames from the T1's frame_start) of the report's T1-centred flow.
T1_OFFSETS = (-4, 0, 4)


def _quadrupole_harmonics():
    """Radial harmonics of the quadrupole's Stokes flow (:func:`hexatissue.theory.quadrupole_flow_exact`), 2-4 ell."""
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


def _t1_flow_lines(movie, cells, report):
    """The flow averaged around the T1s (cycles and intercalations apart), its harmonics, and the theory's
    (``cells``: the :data:`MOVING_CELLS` columns)."""
    cal = movie.calibration
    average, samples = t1_flow(cells, movie.events, movie.box, offsets=T1_OFFSETS)
    if not len(samples):
        return ["### Flow around T1 events", "", "No T1 event has its four cells with velocities at the offsets "
                f"{list(T1_OFFSETS)} frames.", ""]
    r_cell = float(np.sqrt(np.nanmean(cells["area"].to_numpy(float)) / np.pi))
    harmonics = angular_harmonics(samples, r_min=r_cell)
    theory = _n6_share(_quadrupole_harmonics())
    path = report.out / "t1_flow.png"
    plot_event_flow(average, path=path, calibration=cal, title="mean flow around T1s (quartet frame)")
    report.table(average, "t1_flow.csv")
    report.table(harmonics, "t1_flow_harmonics.csv")
    at0 = harmonics[harmonics["offset"] == 0]
    report.numbers["t1_flow"] = {"n6_share_quadrupole_theory": theory}
    lines = ["### Flow around T1 events", "",
             f"Cells within {length(cal, 4 * r_cell)} of each T1's quartet centre, their velocity minus the "
             f"quartet's mean, in axes with the vanishing junction (c -> d) along x, averaged over the events "
             f"of each kind at {', '.join(f'{o:+d}' for o in T1_OFFSETS)} frames from the T1. Radial harmonics "
             f"of the relative velocity (least squares over the samples beyond {length(cal, r_cell)}, offset 0):",
             ""]
    table, by_kind = _harmonics_table(at0, cal)
    report.numbers["t1_flow"].update(by_kind)
    lines += table
    lines += ["", f"The unbinding quadrupole's Stokes flow (`hexatissue.theory.quadrupole_flow_exact`, 2-4 ell) puts "
              f"{theory:.2f} of its radial harmonics 1-8 in n = 6.", ""]
    return lines + report.figure(path, "flow around T1s")


# ---------------------------------------------------------------------------------------------------------
# tissue flow
# ---------------------------------------------------------------------------------------------------------
#: Arrow length of the 95th-percentile node speed of the flow layer, in grid spacings (as hexatissue.plot.plot_flow).
FLOW_ARROW = 0.9
FLOW_COLOR = "#00c8ff"


def flow_layer(movie) -> tuple | None:
    """Vectors layer of the tissue flow: an arrow of the fitted velocity at every valid node of ``flow``.

    None when the results have no ``flow`` table or no valid node.  Arrows
    are drawn to one scale over the movie: the 95th-percentile speed spans
    :data:`FLOW_ARROW` grid spacings (``metadata["px_per_velocity"]``: px of
    arrow per px/frame).  ``features``: frame, node, ``speed`` (px/frame),
    ``vorticity`` and ``divergence`` (1/frame) of each node.
    """
    flow = movie.tables.get("flow")
    if flow is None:
        return None
    rows = flow[flow["valid"].to_numpy(bool)].reset_index(drop=True)
    if not len(rows):
        return None
    u, v = rows["vx"].to_numpy(float), rows["vy"].to_numpy(float)
    speed = np.hypot(u, v)
    typical = float(np.percentile(speed, 95)) or 1.0
    first = rows[rows["frame"] == rows["frame"].iloc[0]]
    per_velocity = FLOW_ARROW * typical_spacing(first[["x", "y"]].to_numpy(float)) / typical
    start = coords(movie, rows["frame"], rows["x"], rows["y"])
    step = coords(movie, np.zeros(len(rows)), u * per_velocity, v * per_velocity)
    features = rows[["frame", "node", "vorticity", "divergence"]].assign(speed=speed)
    kwargs = {"name": "flow", "edge_width": 1.2, "edge_color": FLOW_COLOR, "vector_style": "arrow",
              "length": 1.0, "features": features, **common(movie, px_per_velocity=per_velocity)}
    return np.stack([start, step], axis=1), kwargs, "vectors"


VIEW = StageView(report=(Section(60, _flow, tracked=True),),
                 layers=(LayerMaker(70, single(flow_layer)),),
                 widget=(WidgetField("enabled", name="flow", label="tissue flow"),))
