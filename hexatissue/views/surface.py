"""The surface stage's presentation: the curved tissue in the report (tilt, surface over projected area, the modulus
of gamma_p on the surface and in projection, per frame)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from . import Section, StageView, columns, has_column
from .text import md_table

__all__ = ["VIEW", "surface_summary"]


def surface_summary(movie, p=6) -> pd.DataFrame:
    """Per frame, over the interior cells with a surface area: how curved the tissue is and what projection hides.

    Columns: ``frame``; ``cells``; ``median_tilt_deg`` (the tangent planes'
    angle to the image plane, ``arccos(normal_z)``); ``area_ratio`` (the
    cells' summed ``surface_area`` over their summed ``polygon_area``: 1 for
    a flat tissue); ``median_abs_gamma{p}_surface`` and
    ``median_abs_gamma{p}_projected``.  Empty when the stage did not run.
    """
    if not has_column(movie, "cells", "surface_area"):
        return pd.DataFrame()
    cells = columns(movie, "cells", ["frame", "is_border", "surface_area", "polygon_area", "normal_z",
                                     f"surface_gamma{p}_re", f"surface_gamma{p}_im", f"gamma{p}_re", f"gamma{p}_im"])
    cells = cells[~cells["is_border"].to_numpy(bool) & np.isfinite(cells["surface_area"].to_numpy(float))]
    rows = []
    for t, c in cells.groupby("frame", sort=True):
        row = {"frame": int(t), "cells": int(len(c)),
               "median_tilt_deg": float(np.degrees(np.arccos(np.clip(c["normal_z"].median(), -1, 1)))),
               "area_ratio": float(c["surface_area"].sum() / c["polygon_area"].sum())}
        if f"surface_gamma{p}_re" in c.columns:
            row[f"median_abs_gamma{p}_surface"] = float(np.hypot(c[f"surface_gamma{p}_re"],
                                                                 c[f"surface_gamma{p}_im"]).median())
            row[f"median_abs_gamma{p}_projected"] = float(np.hypot(c[f"gamma{p}_re"], c[f"gamma{p}_im"]).median())
        rows.append(row)
    return pd.DataFrame(rows)


def _surface(movie, report):
    """The curved tissue per frame (``surface.csv``), when the surface stage ran."""
    table = surface_summary(movie, report.p)
    if not len(table):
        return []
    report.table(table, "surface.csv")
    report.numbers["surface"] = {"median_tilt_deg": float(table["median_tilt_deg"].median()),
                                 "area_ratio": float(table["area_ratio"].median())}
    lines = ["## Curved tissue", "",
             "Every cell measured on the surface of the height map (docs/surface.md), over the interior cells: the "
             "median tilt of their tangent planes, their surface area over their projected area (1 for a flat "
             f"tissue), and the median |gamma_{report.p}| in their tangent planes and in projection:", "",
             md_table(table.head(20)), ""]
    if len(table) > 20:
        lines += [f"(first 20 of {len(table)} frames; all in surface.csv)", ""]
    return lines


VIEW = StageView(report=(Section(14, _surface),))
