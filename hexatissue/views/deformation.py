"""The deformation budget's presentation: its table, curves and map in the report, its shear-rate bars in napari,
its switch in the napari widget."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..plot import BUDGET_GROUPS, plot_deformation_budget, plot_deformation_map
from . import LayerMaker, Section, StageView, WidgetField, columns
from .layerdata import common, coords, spacing
from .text import md_table

__all__ = ["VIEW", "deformation_layers"]


def _budget(movie, report):
    """The deformation budget: cumulative contributions over the movie, the curves and the map."""
    if movie.deformation is None or len(movie.deformation) == 0:
        return []
    budget = columns(movie, "deformation", movie.deformation.columns)  # every column: the table is the CSV's
    cal = movie.calibration
    everything = budget[budget["region"] == "tissue"]
    # the headline leaves out the intervals whose events rest on doubtful tracking (their totals stay in the CSV)
    doubtful = (everything["tracking_doubtful"].to_numpy(bool) if "tracking_doubtful" in everything
                else np.zeros(len(everything), bool))
    every_one = bool(len(everything)) and doubtful.all()  # nothing to leave them out for: shown, and said so
    tissue = everything if every_one else everything[~doubtful]

    def cumulative(part):
        rows = []
        for label, terms, _ in (("total", ("total",), None),) + BUDGET_GROUPS:
            rows.append({"contribution": label, **{f"cumulative {c}": sum(part[f"{t}_{c}"].sum() for t in terms
                                                                          if f"{t}_{c}" in part)
                                                   for c in ("xx", "xy", "iso")}})
        return pd.DataFrame(rows)

    table = cumulative(tissue)
    closure = float(everything[["closure_xx", "closure_xy", "closure_iso"]].abs().to_numpy().max(initial=0.0))
    report.numbers["deformation"] = {"cumulative": table.to_dict("records"), "max_closure": closure,
                              "n_pairs": int(len(tissue)), "n_pairs_doubtful": int(doubtful.sum())}
    if doubtful.any() and not every_one:
        report.numbers["deformation"]["cumulative_all"] = cumulative(everything).to_dict("records")
    report.table(budget, "deformation.csv")
    path = report.out / "deformation.png"
    plot_deformation_budget(budget, calibration=cal, path=path)
    duration = cal.time(float(len(tissue)))
    span = (f"{len(tissue)} frame intervals, **every one of them with doubtful tracking** (see Tracking quality: "
            f"the events' terms are likely tracking errors)" if every_one else
            f"the {len(tissue)} frame intervals of {len(everything)} whose tracking is not doubtful" if doubtful.any()
            else f"{len(tissue)} frame intervals")
    lines = ["## Deformation budget", "",
             f"The tissue's shear and growth over {span} ({duration:.3g} {cal.time_label}), "
             f"split into the contributions of cell shape change and of each kind of cellular event (the triangle "
             f"method; cumulative, dimensionless; 'cell shape change' includes its corotational terms):", "",
             md_table(table), ""]
    if doubtful.any() and not every_one:
        left = everything.loc[doubtful, "frame"].astype(int).tolist()
        shown = ", ".join(f"{t}-{t + 1}" for t in left[:10]) + (", ..." if len(left) > 10 else "")
        total = cumulative(everything).iloc[0]
        lines += [f"- left out of the table: {len(left)} interval(s) ({shown}) whose tracking is doubtful (interior "
                  f"extrusions above 1 % of the cells, frames far apart, a suspect division or an unconfirmed "
                  f"extrusion: see Tracking "
                  f"quality; `deformation.tracking_doubtful`); with them the cumulative total would be "
                  f"xx {total['cumulative xx']:.3g}, xy {total['cumulative xy']:.3g}, iso "
                  f"{total['cumulative iso']:.3g}", ""]
    lines += [f"- closure (total minus the sum of the parts): at most {closure:.2g} per interval",
              f"- triangles that would flip over within an interval (retriangulated instead): "
              f"{int(tissue['n_flipped'].sum())}", ""]
    lines += report.figure(path, "deformation budget")
    if (budget["region"] == "grid").any() and movie.grid is not None:
        path = report.out / "deformation_map.png"
        plot_deformation_map(budget, columns(movie, "grid", ["frame", "node", "x", "y"]), calibration=cal, path=path,
                             box=movie.box)
        lines += report.figure(path, "deformation map")
    return lines


def deformation_layers(movie) -> list:
    """Vectors layers of the deformation budget's shear rate on the grid regions, per frame interval.

    One bar per grid node and interval, centred on the node along the
    stretching axis: the total shear rate (white) and the T1s' part (cycles,
    intercalations and unresolved together; red), lengths in proportion to
    the rate (the largest total: 0.9 x the cell spacing).  Empty when the
    results have no grid budget.  ``features``: frame, node and the rate's
    xx, xy components (1/frame).
    """
    budget, grid = movie.deformation, movie.grid
    if budget is None or grid is None:
        return []
    rows = budget[budget["region"] == "grid"].reset_index(drop=True)
    if not len(rows):
        return []
    nodes = grid.drop_duplicates(["frame", "node"]).set_index(["frame", "node"])
    xy = nodes.loc[list(zip(rows["frame"], rows["region_id"])), ["x", "y"]].to_numpy(float)
    t1 = [sum(rows[f"{k}_{c}"].to_numpy() for k in ("t1_cycle", "t1_intercalation", "t1_unresolved"))
          for c in ("xx", "xy")]
    total = [rows[f"total_{c}"].to_numpy() for c in ("xx", "xy")]
    largest = max(float(np.nanmax(np.hypot(*total), initial=0.0)), 1e-300)
    out = []
    for name, (xx, xy_), colour in (("shear rate (total)", total, "white"), ("shear rate (T1s)", t1, "#d62728")):
        half = 0.45 * spacing(movie) * np.hypot(xx, xy_) / largest
        angle = 0.5 * np.arctan2(xy_, xx)  # the stretching axis
        d = np.c_[np.cos(angle), np.sin(angle)] * half[:, None]
        start = coords(movie, rows["frame"], xy[:, 0] - d[:, 0], xy[:, 1] - d[:, 1])
        step = coords(movie, np.zeros(len(rows)), 2 * d[:, 0], 2 * d[:, 1])
        features = pd.DataFrame({"frame": rows["frame"], "node": rows["region_id"], "rate_xx": xx, "rate_xy": xy_})
        kwargs = {"name": name, "edge_width": 1.5, "edge_color": colour, "vector_style": "line", "length": 1.0,
                  "features": features, "visible": name.endswith("(total)"),
                  **common(movie, bar_per_unit_rate_px=0.9 * spacing(movie) / largest)}
        out.append((np.stack([start, step], axis=1), kwargs, "vectors"))
    return out


VIEW = StageView(report=(Section(50, _budget, tracked=True),),
                 layers=(LayerMaker(80, lambda movie, p: deformation_layers(movie)),),
                 widget=(WidgetField("enabled", name="deformation", label="deformation budget"),))
