"""``hexatissue report``: figures and a Markdown summary of a ``hexatissue analyze`` folder.

A single frame gets the coarse-grained order fields with their defects; a
movie also gets the T1 events over time, the T1–defect proximity (Fig. 3e),
migration against defect density (Fig. 3f) and the event timing (Fig. 3g).
Everything goes to ``OUT`` (default ``RESULTS_DIR/report``): PNG figures,
the small analysis tables as CSV and ``report.md`` with the key numbers.
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..box import Box
from ..errors import HexatissueWarning, InputError
from ..frame import Frame
from ..io import atomic_path, read_table, write_table
from ..units import Calibration
from .migration import DEFAULT_DL, migration_populations, migration_table
from .proximity import t1_defect_proximity
from .timing import cell_timing, timing_summary, timing_test

__all__ = ["report", "load_results", "box_from_grid", "results_box", "default_window"]

TABLES = ("cells", "vertices", "edges", "cell_vertices", "grid", "defects", "events", "lineage", "cell_events")


def load_results(results_dir):
    """Tables and metadata of a ``hexatissue analyze`` folder.

    Returns
    -------
    tables : dict
        ``{name: DataFrame}`` of every table present (Parquet preferred over CSV).
    metadata : dict
        ``metadata.json`` (empty when absent).
    """
    folder = Path(results_dir)
    if not folder.is_dir():
        raise InputError(f"results_dir {str(folder)!r} is not a folder; expected the output of hexatissue analyze")
    tables = {}
    for name in TABLES:
        for suffix in (".parquet", ".csv"):
            path = folder / f"{name}{suffix}"
            if path.exists():
                tables[name] = read_table(path)
                break
    if "cells" not in tables:
        raise InputError(f"results_dir {str(folder)!r} holds no cells table; expected the output of hexatissue analyze")
    meta_path = folder / "metadata.json"
    metadata = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    return tables, metadata


def box_from_grid(grid):
    """The periodic box a coarse-graining grid tiles: ``nx`` nodes at ``(i + 1/2) Lx / nx`` give ``Lx``."""
    g = grid[grid["frame"] == grid["frame"].min()] if "frame" in grid.columns else grid
    lengths = []
    for axis, index in (("x", "col"), ("y", "row")):
        n = int(g[index].max()) + 1
        pos = np.sort(np.unique(g[axis].to_numpy(float)))
        if n < 2 or len(pos) < 2:
            raise InputError("grid has fewer than 2 nodes along an axis; cannot infer the box")
        lengths.append(n * (pos[1] - pos[0]))
    return Box(float(np.round(lengths[0], 6)), float(np.round(lengths[1], 6)))


def results_box(tables, metadata):
    """The periodic box of an analysis folder (None for open images)."""
    if not metadata.get("periodic", False):
        return None
    if "box" in metadata:  # [Lx, Ly], when the writer records it
        return Box(*map(float, metadata["box"]))
    if "grid" in tables:
        return box_from_grid(tables["grid"])
    raise InputError("the results are periodic but neither metadata.json nor a grid table gives the box")


def _mpf_save_every(metadata):
    """``save_every`` of the MPF run the results came from (None when the input is not a readable run)."""
    source = str(metadata.get("input", ""))
    if not source.endswith(".zarr") or not Path(source).exists():
        return None
    try:
        from ..simulate import read_run

        return int(read_run(source).attrs["save_every"])
    except Exception:  # a moved or foreign store only loses the default window
        return None


def default_window(metadata, n_frames):
    """Migration window in frames: the paper's 25,000 iterations for MPF runs, else a quarter of the movie.

    For results of an MPF run whose store is still at ``metadata["input"]``,
    ``25_000 / save_every`` frames when that fits in the movie; otherwise
    ``max(1, n_frames // 4)``.
    """
    from .migration import PAPER_WINDOW_ITERATIONS

    save_every = _mpf_save_every(metadata)
    if save_every and PAPER_WINDOW_ITERATIONS % save_every == 0:
        dt = PAPER_WINDOW_ITERATIONS // save_every
        if dt < n_frames:
            return dt
    return max(1, n_frames // 4)


def _frame_of(tables, t, box):
    parts = {}
    for name in ("cells", "vertices", "edges", "cell_vertices"):
        table = tables[name]
        parts[name] = table[table["frame"] == t].reset_index(drop=True) if t is not None else table
    return Frame(**parts, frame=t, box=box)


def _at(table, t):
    return table if t is None or "frame" not in table.columns else table[table["frame"] == t]


def _order_figures(tables, box, frames, order_p, out):
    from .. import plot

    written = []
    if "grid" not in tables:
        return written
    for t in frames:
        frame = _frame_of(tables, t, box)
        polygons = frame.polygons()
        tag = "" if t is None else f"_frame{t:04d}"
        for q in order_p:
            if f"Gamma{q}_re" not in tables["grid"].columns:
                continue
            defects = _at(tables.get("defects", pd.DataFrame(columns=["x", "y", "charge", "p"])), t)
            defects = defects[defects["p"] == q] if "p" in defects.columns else defects
            path = out / f"order{q}{tag}.png"
            plot.plot_order_field(_at(tables["grid"], t), defects, p=q, polygons=polygons, box=box, path=path)
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


def _tissue_section(tables, metadata, frames, order_p):
    cells = tables["cells"]
    n_frames = len(frames)
    inner = cells[~cells["is_border"].to_numpy(bool)] if "is_border" in cells.columns else cells
    lines = ["## Tissue", "",
             f"- frames: {n_frames}" + ("" if n_frames > 1 else " (single image)"),
             f"- cells per frame: {len(cells) / n_frames:.1f} ({len(inner) / n_frames:.1f} interior)",
             f"- periodic box: {metadata.get('periodic', False)}"]
    if "n_sides" in inner.columns and len(inner):
        lines.append(f"- mean number of sides (interior cells): {inner['n_sides'].mean():.3f}")
    numbers = {"frames": n_frames, "cells_per_frame": len(cells) / n_frames}
    for q in order_p:
        col = f"gamma{q}_re"
        if col in inner.columns and len(inner):
            mag = np.hypot(inner[col], inner[f"gamma{q}_im"]).mean()
            lines.append(f"- mean |gamma_{q}| per cell: {mag:.3f}")
            numbers[f"mean_abs_gamma{q}"] = float(mag)
        if "grid" in tables and f"Gamma{q}_re" in tables["grid"].columns:
            g = tables["grid"]
            g = g[g["valid"].to_numpy(bool)] if "valid" in g.columns else g
            mag = float(np.nanmean(np.hypot(g[f"Gamma{q}_re"], g[f"Gamma{q}_im"]))) if len(g) else np.nan
            lines.append(f"- mean |Gamma_{q}| on valid grid nodes: {mag:.3f}")
            numbers[f"mean_abs_Gamma{q}"] = mag
    if "defects" in tables and len(tables["defects"]):
        d = tables["defects"]
        rows = []
        for q, g in d.groupby("p"):
            rows.append({"p": int(q), "+ per frame": (g["charge"] > 0).sum() / n_frames,
                         "- per frame": (g["charge"] < 0).sum() / n_frames,
                         "net charge per frame": g["charge"].sum() / n_frames})
        lines += ["", "Defects (coarse-grained field):", "", _md_table(pd.DataFrame(rows))]
    return lines, numbers


def _figure_line(path, out, caption):
    return [f"![{caption}]({Path(path).relative_to(out).as_posix()})", ""]


def report(results_dir, out=None, *, p=6, order_p=None, dl=DEFAULT_DL, dt=None, n_control=5, seed=0,
           frame_interval=1.0, time_unit="frames", include_border=False, control="cells") -> dict:
    """Render the figures that apply to an analysis folder and a Markdown summary.

    Parameters
    ----------
    results_dir : path
        Output of ``hexatissue analyze`` / :func:`hexatissue.results.analyze_to_folder`.
    out : path, optional
        Report folder (default ``results_dir/report``).
    p : int
        Defect order of the T1–defect and migration analyses.
    order_p : sequence of int, optional
        Orders whose coarse-grained fields are drawn (default: those in metadata, else (6,)).
    dl : float
        Migration subregion side, px.
    dt : int, optional
        Migration window, frames.  Default: :func:`default_window` (the
        paper's 25,000 iterations for MPF runs, else a quarter of the movie).
    n_control : int
        Random cells (or vertices) per T1 event in the proximity control.
    seed : int or numpy.random.Generator
        Seeds the control draw and the mixture fit.
    frame_interval : float
        Time per frame for the timing analysis, in ``time_unit``.
    time_unit : str
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
    tables, metadata = load_results(results_dir)
    out = Path(results_dir) / "report" if out is None else Path(out)
    out.mkdir(parents=True, exist_ok=True)
    box = results_box(tables, metadata)
    order_p = tuple(order_p if order_p is not None else metadata.get("order_p", (6,)))
    cells = tables["cells"]
    frames = np.unique(cells["frame"].to_numpy(np.int64)) if "frame" in cells.columns else np.array([])
    is_movie = len(frames) > 1
    shown = sorted({int(frames[0]), int(frames[-1])}) if len(frames) else [None]
    written = _order_figures(tables, box, shown, order_p, out)
    lines = [f"# hexatissue report: {Path(results_dir).name}", "",
             f"Input: `{metadata.get('input', results_dir)}`", ""]
    section, numbers = _tissue_section(tables, metadata, frames if len(frames) else [0], order_p)
    lines += section + [""]
    for path in written:
        lines += _figure_line(path, out, path.stem)
    if is_movie:
        lines += _movie_sections(tables, metadata, box, frames, out, written, numbers, p=p, dl=dl, dt=dt,
                                 n_control=n_control, seed=seed, frame_interval=frame_interval, time_unit=time_unit,
                                 include_border=include_border, control=control)
    md = out / "report.md"
    with atomic_path(md) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    written.append(md)
    numbers["written"] = [str(w) for w in written]
    return numbers


def _movie_sections(tables, metadata, box, frames, out, written, numbers, *, p, dl, dt, n_control, seed,
                    frame_interval, time_unit, include_border, control):
    from .plots import plot_event_overview, plot_migration, plot_t1_defect_distances, plot_timing

    calibration = Calibration(frame_interval=frame_interval, time_unit=time_unit)
    cells, events = tables["cells"], tables.get("events")
    defects = tables.get("defects", pd.DataFrame(columns=["frame", "defect", "x", "y", "charge", "p"]))
    lines = []
    if events is None:
        return ["## Events", "", "No events table in the results folder.", ""]
    counts = events["kind"].astype(str).value_counts().to_dict()
    cycles = events.loc[events["kind"] == "cycle", "duration"].to_numpy(float)
    numbers["events"] = {k: int(v) for k, v in counts.items()}
    path = out / "events.png"
    plot_event_overview(events, n_frames=int(frames.max()) + 1, path=path, calibration=calibration)
    written.append(path)
    lines += ["## T1 events", "",
              "- " + (", ".join(f"{k}: {v}" for k, v in sorted(counts.items())) or "none detected"),
              f"- mean T1-cycle duration: {np.mean(cycles):.3g} frames" if len(cycles) else "- no T1 cycles", ""]
    lines += _figure_line(path, out, "T1 events")

    # Fig. 3e
    prox = t1_defect_proximity(events, cells, defects, p=p, box=box, n_control=n_control, seed=seed,
                               include_border=include_border, control=control, vertices=tables.get("vertices"))
    s = prox.summary()
    numbers["proximity"] = s
    path = out / "t1_defects.png"
    plot_t1_defect_distances(prox, path=path)
    written += [path, write_table(prox.events, out / "t1_defect_distances.csv"),
                write_table(prox.control, out / "control_distances.csv")]
    lines += [f"## T1 events and ±1/{p} defects (Fig. 3e)", "",
              f"- events with a defect in their frame: {s['n_events']}; random {control}: {s['n_control']} "
              f"({n_control} per event, seed {seed})",
              f"- median distance to the nearest defect: T1s {s['median_dr_events']:.3g} px, "
              f"random {control} {s['median_dr_control']:.3g} px",
              f"- KS statistic {s['ks_statistic']:.3g}, p = {s['ks_pvalue']:.3g} (two-sided), "
              f"p = {s['ks_pvalue_closer']:.3g} (one-sided: T1s closer)", ""]
    lines += _figure_line(path, out, "T1-defect distances")

    # Fig. 3f
    if dt is None:
        dt = default_window(metadata, len(frames))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        table = migration_table(cells, defects, dl=dl, dt=dt, box=box, p=p, events=events,
                                include_border=include_border)
    pops = migration_populations(table, seed=seed)
    numbers["migration"] = {"dl": dl, "dt": dt, "n_subregion_windows": len(table), "threshold": pops.threshold,
                            "delta_bic": pops.delta_bic, "spearman_rho": pops.spearman_rho,
                            "spearman_pvalue": pops.spearman_pvalue}
    path = out / "migration.png"
    plot_migration(pops, path=path)
    written += [path, write_table(pops.table, out / "migration.csv")]
    lines += ["## Migration and defect density (Fig. 3f)", "",
              f"- subregions of {dl:g} px, windows of {dt} frames: {len(table)} subregion-windows",
              f"- Spearman rank correlation of displacement and defect density: rho = {pops.spearman_rho:.3g} "
              f"(p = {pops.spearman_pvalue:.3g})",
              f"- two-component mixture in log10(displacement): split at {pops.threshold:.3g}, "
              f"delta BIC (1 vs 2 components) = {pops.delta_bic:.3g} ({pops.verdict}; "
              f"> 10 is strong evidence for two populations)", "",
              _md_table(pops.summary), ""]
    lines += _figure_line(path, out, "migration")

    # Fig. 3g
    timing = cell_timing(events, cells, frame_interval=frame_interval)
    summ, test = timing_summary(timing), timing_test(timing)
    numbers["timing"] = {"summary": summ.to_dict("records"), **test}
    path = out / "timing.png"
    plot_timing(cell_timing(events, cells), path=path, calibration=calibration)  # in frames, converted on the figure
    written += [path, write_table(timing, out / "cell_timing.csv")]
    lines += ["## Event timing (Fig. 3g)", "", f"Per-cell means, in {time_unit}:", "", _md_table(summ), "",
              f"- Welch two-sided t-test: t = {test['t_statistic']:.3g}, p = {test['pvalue']:.3g}", ""]
    lines += _figure_line(path, out, "timing")
    return lines
