"""The shape order's presentation: gamma_p and Gamma_p in the report with the field's figures, the stars and the
Gamma_p field with its defects in ``analyze --figures`` (:func:`save_analysis_figures`), the stars and the
defects in napari."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..defects import find_defects
from ..errors import InputError
from ..order import coarse_grain
from ..plot import MINUS_COLOR, PLUS_COLOR, plot_labels, plot_order_field, plot_stars, star_segments
from ..units import as_calibration
from . import LayerMaker, Section, StageView, WidgetField, columns, has_column, shown_frames
from .layerdata import common, coords, rgba, spacing
from .text import md_table

__all__ = ["VIEW", "save_analysis_figures", "star_layer", "defect_layers", "STAR_COLOR", "STAR_SCALE"]


def _order_numbers(movie, report):
    """gamma_p per cell, Gamma_p on the grid and the defects per frame, for every order shown."""
    numbers = report.numbers
    n_frames = max(len(movie), 1)
    orders = [(f"gamma{q}_re", f"gamma{q}_im") for q in report.order_p]
    cells = columns(movie, "cells", ["is_border", *(c for pair in orders for c in pair)])
    inner = cells[~cells["is_border"].to_numpy(bool)]
    grid = columns(movie, "grid", ["valid", *(f"Gamma{q}_{part}" for q in report.order_p for part in ("re", "im"))])
    lines = []
    for q in report.order_p:
        col = f"gamma{q}_re"
        if col in inner.columns and len(inner):
            mag = np.hypot(inner[col], inner[f"gamma{q}_im"]).mean()
            lines.append(f"- mean |gamma_{q}| per cell: {mag:.3f}")
            numbers[f"mean_abs_gamma{q}"] = float(mag)
        if has_column(movie, "grid", f"Gamma{q}_re"):
            g = grid[grid["valid"].to_numpy(bool)]
            mag = float(np.nanmean(np.hypot(g[f"Gamma{q}_re"], g[f"Gamma{q}_im"]))) if len(g) else np.nan
            lines.append(f"- mean |Gamma_{q}| on valid grid nodes: {mag:.3f}")
            numbers[f"mean_abs_Gamma{q}"] = mag
    if movie.defects is not None and len(movie.defects):
        rows = []
        for q, g in columns(movie, "defects", ["p", "charge"]).groupby("p"):
            rows.append({"p": int(q), "+ per frame": (g["charge"] > 0).sum() / n_frames,
                         "- per frame": (g["charge"] < 0).sum() / n_frames,
                         "net charge per frame": g["charge"].sum() / n_frames})
        lines += ["", "Defects (coarse-grained field):", "", md_table(pd.DataFrame(rows))]
    return lines + [""]


def _order_figures(movie, report):
    """The Gamma_p field with its defects of the first and last frame, for every order shown."""
    lines = []
    if movie.grid is None:
        return lines
    for t in shown_frames(movie):
        polygons = movie.polygons(t)
        tag = "" if len(movie) == 1 else f"_frame{t:04d}"
        grid, defects = movie.table_at("grid", t), movie.table_at("defects", t)
        for q in report.order_p:
            if f"Gamma{q}_re" not in grid.columns or len(grid) == 0:
                continue
            path = report.out / f"order{q}{tag}.png"
            plot_order_field(grid, defects[defects["p"] == q], p=q, polygons=polygons, box=movie.box, path=path,
                                  calibration=movie.calibration)
            lines += report.figure(path, path.stem)
    return lines


def save_analysis_figures(frame, directory, labels=None, grid=None, defects=None, p=6, prefix="",
                          calibration=None):
    """Write the standard figures of one frame: polygons, p-legged stars, Gamma_p field with defects.

    Parameters
    ----------
    frame : hexatissue.Frame
        One time point (``frame.cells`` with ``gamma{p}``, ``frame.box``, polygons).
    directory : str or Path
        Output folder (created if needed).
    labels : (rows, cols) int array, optional
        The label image, drawn underneath.
    grid, defects : pandas.DataFrame, optional
        This frame's grid and defects tables; computed with the defaults of
        :func:`hexatissue.coarse_grain` and :func:`hexatissue.find_defects`
        when not given.
    p : int
        Symmetry order of the stars and the field.
    prefix : str
        Prepended to the file names (e.g. ``"frame0003_"``).
    calibration : Calibration, optional
        Pixel size and length unit of the scale bars; when None, the
        frame's ``calibration`` attribute if it has one, else px.

    Returns
    -------
    list of pathlib.Path
        ``{prefix}polygons.png``, ``{prefix}stars{p}.png``, ``{prefix}gamma{p}_defects.png``.
    """
    if calibration is None:
        calibration = getattr(frame, "calibration", None)
    calibration = as_calibration(calibration)
    directory = Path(directory)
    box = frame.box
    if grid is None:
        grid = coarse_grain(frame.cells, p=p, box=box)
    if defects is None:
        defects = find_defects(grid, p=p, box=box)
    polygons = frame.polygons()
    paths = [directory / f"{prefix}polygons.png", directory / f"{prefix}stars{p}.png",
             directory / f"{prefix}gamma{p}_defects.png"]
    plot_labels(labels, polygons, frame.cells, path=paths[0], box=box, calibration=calibration)
    plot_stars(frame.cells, p=p, polygons=polygons, labels=labels, path=paths[1], box=box, calibration=calibration)
    plot_order_field(grid, defects, p=p, polygons=polygons, labels=labels, box=box, path=paths[2],
                     calibration=calibration)
    return paths


def _figures(movie, folder, source=None):
    """The p-legged stars and the Gamma_p field with its defects of the first and last frame, for every p analysed
    (the field computed with the defaults when the analysis had none)."""
    order = movie.options.get("order")
    single = len(movie) == 1
    written = []
    for t in shown_frames(movie):
        frame = movie.frame(t)
        labels = source.frame(t) if source is not None and source.kind == "labels" else None  # polygons: no image
        prefix = "" if single else f"frame{t:04d}_"
        calibration = as_calibration(getattr(frame, "calibration", None))
        polygons = frame.polygons()
        for q in order.p if order is not None else (6,):
            if movie.grid is not None and f"Gamma{q}_re" in movie.grid.columns:
                grid = movie.table_at("grid", t)
                defects = movie.table_at("defects", t)
                defects = defects[defects["p"] == q]
                if len(grid) == 0:
                    continue
            else:
                grid = coarse_grain(frame.cells, p=q, box=frame.box)
                defects = find_defects(grid, p=q, box=frame.box)
            paths = [Path(folder) / f"{prefix}stars{q}.png", Path(folder) / f"{prefix}gamma{q}_defects.png"]
            plot_stars(frame.cells, p=q, polygons=polygons, labels=labels, path=paths[0], box=frame.box,
                       calibration=calibration)
            plot_order_field(grid, defects, p=q, polygons=polygons, labels=labels, box=frame.box, path=paths[1],
                             calibration=calibration)
            written += paths
    return written


DEFECT_SIZE = 0.8  # defect marker diameter, in typical cell spacings


STAR_COLOR = "#ff3cd2"  # bright magenta: visible on every polygon colour and on black


STAR_SCALE = 0.45  # star leg for |gamma_p| = 1, in typical cell spacings (as hexatissue.plot.plot_stars)


def star_layer(movie, p=6, scale=STAR_SCALE) -> tuple:
    """Vectors layer of p-legged stars at the cell centroids: orientation ``Arg(gamma_p) / p``, legs ~ ``|gamma_p|``.

    Each leg is one vector from the centroid; its length is ``scale`` x the
    typical cell spacing x ``|gamma_p|`` (as :func:`hexatissue.plot.plot_stars`).
    Cells whose ``gamma{p}`` is NaN get no star.  ``features``: frame, cell,
    track and ``abs_gamma{p}`` of each leg's cell.
    """
    cells = movie.cells
    re, im = f"gamma{p}_re", f"gamma{p}_im"
    if re not in cells.columns:
        raise InputError(f"p={p!r}: the cells table has no {re!r} column; the results have "
                         f"{sorted(c[5:-3] for c in cells.columns if c.startswith('gamma') and c.endswith('_re'))}")
    gamma = cells[re].to_numpy(float) + 1j * cells[im].to_numpy(float)
    xy = cells[["x", "y"]].to_numpy(float)
    ok = np.isfinite(gamma) & np.isfinite(xy).all(axis=1)
    segments = star_segments(xy[ok], np.angle(gamma[ok]) / p, np.abs(gamma[ok]) * scale * spacing(movie), p)
    frame = np.repeat(cells["frame"].to_numpy()[ok], p)
    start = coords(movie, frame, segments[:, 0, 0], segments[:, 0, 1])
    step = coords(movie, np.zeros(len(frame)), *(segments[:, 1] - segments[:, 0]).T)
    leg = cells.loc[ok, ["frame", "cell", "track"]].reset_index(drop=True)
    features = leg.loc[np.repeat(np.arange(len(leg)), p)].reset_index(drop=True).assign(
        **{f"abs_gamma{p}": np.repeat(np.abs(gamma[ok]), p)})
    kwargs = {"name": f"gamma{p} stars", "edge_width": 0.7, "edge_color": STAR_COLOR,
              "vector_style": "line", "length": 1.0, "features": features,
              **common(movie, p=int(p), leg_per_unit_gamma_px=scale * spacing(movie))}
    return np.stack([start, step], axis=1), kwargs, "vectors"


def defect_layers(movie, shown=6) -> list:
    """One Points layer per order p of the Gamma_p defects: +1/p (and other positive charges) as red discs,
    negative ones as blue triangles; ``features`` = the defects rows.  Only the layer of p = ``shown``
    starts visible (the colours are the same for every p)."""
    d = movie.defects
    if d is None:
        return []
    size = DEFECT_SIZE * spacing(movie)
    out = []
    for p in sorted(int(v) for v in d["p"].unique()):
        rows = d[d["p"].to_numpy() == p].reset_index(drop=True)
        plus = rows["charge"].to_numpy(float) > 0
        kwargs = {"name": f"Gamma{p} defects", "size": size,
                  "face_color": rgba(np.where(plus, PLUS_COLOR, MINUS_COLOR)), "border_color": "black",
                  "border_width": 0.1, "symbol": np.where(plus, "disc", "triangle_up"), "features": rows,
                  "visible": p == shown,
                  **common(movie, p=p, colors={"+": PLUS_COLOR, "-": MINUS_COLOR})}
        out.append((coords(movie, rows["frame"], rows["x"], rows["y"]), kwargs, "points"))
    return out


def _layers(movie, p):
    return ([star_layer(movie, p)] if f"gamma{p}_re" in movie.cells.columns else []) + defect_layers(movie, shown=p)


def _legend(movie, p):
    return [(f"Γ{p} defect, charge > 0", "disc", PLUS_COLOR), (f"Γ{p} defect, charge < 0", "triangle_up", MINUS_COLOR),
            (f"γ{p} star", "cross", STAR_COLOR)]


VIEW = StageView(figures=_figures, report=(Section(11, _order_numbers), Section(13, _order_figures)),
                 layers=(LayerMaker(30, _layers),), legend=_legend,
                 widget=(WidgetField("radius", name="radius", label="radius (px, 0 = auto)",
                                     limits={"min": 0.0, "max": 1e4, "step": 1.0}),))
