"""Force inference's presentation: tensions, pressures and the tissue stress in the report, the tensions in napari,
its switch in the napari widget."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..mechanics import MU_RANGE, t1_tension_histories, tissue_stress
from ..plot import plot_stress, plot_t1_tensions, plot_tension_histogram, plot_tensions
from . import LayerMaker, Section, StageView, columns, has_column, single, WidgetField
from .layerdata import common, coords
from .text import md_table

__all__ = ["VIEW", "tension_layer"]



# a run with a height map balances the vertices on the surface (docs/surface.md, Forces on a height map)
_SURFACE_TEXT = ("; on the height map's surface: every vertex balanced in its tangent plane with the junctions' 3-D "
                 "directions, pressures per px^2 of surface, and each cell's stress along its own tangent axes "
                 "(e1 the image x axis projected on its plane), so the tissue's stress adds components of "
                 "different frames where the surface curves")

def _forces(movie, report):
    """Force inference: tensions and pressures of the first frame, the tissue stress per frame."""
    if not has_column(movie, "edges", "tension"):
        return []
    edges = columns(movie, "edges", ["frame", "cell_a", "cell_b", "length", "tension", "tension_sd", "curvature"])
    cells = columns(movie, "cells", ["frame", "polygon_area", "stress_xx", "stress_xy", "stress_yy", "pressure"])
    cal = movie.calibration
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
    fit = columns(movie, "force_fit", ["frame", "arcs", "mu", "n_free"])
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
    report.numbers["mechanics"] = {"method": method, "junctions": junctions, "frames": table.to_dict("records")}
    report.table(table, "mechanics.csv")
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
             f"stress, tension/px){_SURFACE_TEXT if 'z' in movie.vertices.columns else ''}:", "",
             md_table(table.head(20)), ""]
    if len(table) > 20:
        lines += [f"(first 20 of {len(table)} frames; all in mechanics.csv)", ""]
    if not np.isfinite(edges["tension"]).any():
        lines += ["No junction has a tension: the force balance leaves every unknown free (least squares on an "
                  "open image or a network with four-fold vertices; use the Bayesian estimator).", ""]
        return lines
    path = report.out / "tensions.png"
    plot_tensions(movie.table_at("edges", first), movie.table_at("vertices", first), calibration=cal, box=movie.box,
                  path=path)
    lines += report.figure(path, f"tensions, frame {first}")
    path = report.out / "tension_histogram.png"
    plot_tension_histogram(movie.table_at("edges", first), path=path)
    lines += report.figure(path, f"tension histogram, frame {first}")
    path = report.out / "pressure.png"
    plot_stress(movie.table_at("cells", first), "pressure", movie.polygons(first), box=movie.box, calibration=cal,
                title=f"inferred pressure relative to the mean (tension/px), frame {first}", path=path)
    lines += report.figure(path, f"pressure, frame {first}")
    lines += _t1_tension_lines(movie, edges, report)
    return lines


def _t1_tension_lines(movie, edges, report, before=10):
    """The tension of each T1's lost junction over the frames before it, by kind (when there are T1s; ``edges``:
    their ``frame``, ``cell_a``, ``cell_b``, ``length`` and ``tension``)."""
    events = movie.tables.get("events")
    if events is None or not len(events):
        return []
    histories = t1_tension_histories(events, edges, columns(movie, "cells", ["frame", "cell", "track"]),
                                     before=before)
    report.table(histories, "t1_tensions.csv")
    last = histories[histories["lag"] == -1].groupby("kind")["tension"].median()
    report.numbers["mechanics"]["t1_tension_at_lag_minus_1"] = {str(k): float(v) for k, v in last.items()}
    path = report.out / "t1_tensions.png"
    plot_t1_tensions(histories, path=path)
    return [f"Tension of the junction each T1 removes, over the {before} frames before it, by kind "
            f"(`t1_tensions.csv`; median at the last frame before the T1: "
            + ", ".join(f"{k} {v:.2f}" for k, v in last.items()) + "):", ""] + report.figure(
                path, "tension before T1s")


# ---------------------------------------------------------------------------------------------------------
# force inference
# ---------------------------------------------------------------------------------------------------------
def tension_layer(movie) -> tuple | None:
    """Vectors layer of the junctions with an inferred tension (``--mechanics``), coloured by it.

    Each junction is a line from ``vertex_a`` to ``vertex_b`` (minimum image
    in a periodic box); colour: the ``tension`` feature on viridis, between
    its 2nd and 98th percentiles.  ``features``: frame, edge, tension,
    tension_sd.  None when the results have no tensions.
    """
    edges = movie.tables.get("edges")
    if edges is None or "tension" not in edges.columns:
        return None
    edges = edges[np.isfinite(edges["tension"].to_numpy(float))].reset_index(drop=True)
    v = movie.vertices.set_index(["frame", "vertex"])[["x", "y"]]
    a = v.reindex(list(zip(edges["frame"], edges["vertex_a"]))).to_numpy(float)
    b = v.reindex(list(zip(edges["frame"], edges["vertex_b"]))).to_numpy(float)
    d = b - a if movie.box is None else movie.box.min_image(b - a)
    start = coords(movie, edges["frame"], a[:, 0], a[:, 1])
    step = coords(movie, np.zeros(len(edges)), d[:, 0], d[:, 1])
    tension = edges["tension"].to_numpy(float)
    low, high = np.percentile(tension, [2, 98]) if len(tension) else (0.0, 1.0)
    features = edges[["frame", "edge", "tension"] + (["tension_sd"] if "tension_sd" in edges else [])]
    kwargs = {"name": "tension", "edge_width": 1.5, "edge_color": "tension", "edge_colormap": "viridis",
              "edge_contrast_limits": (float(low), float(high) if high > low else float(low) + 1.0),
              "vector_style": "line", "length": 1.0, "features": features, "visible": False, **common(movie)}
    return np.stack([start, step], axis=1), kwargs, "vectors"


VIEW = StageView(report=(Section(90, _forces),),
                 layers=(LayerMaker(90, single(tension_layer)),),
                 widget=(WidgetField("enabled", name="mechanics", label="force inference"),))
