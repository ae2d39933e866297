"""Defect densities of the MDCK images against the paper's published ones, R = 1..5 R_cell, and why R = 1 differs.

Armengol-Collado et al. 2023 publish the mean defect densities of the 63 MDCK images against the
coarse-graining radius (source data of Fig. 3d, ``source_data_fig3.xlsx`` in GitHub
``hexanematic/orientation_tracker``; the numbers are copied below).  hexatissue computes Gamma_p and
the defects with the published scripts' conventions (R_cell 21.5 px, the 23 x 23 grid of step
500/23 px from (0, 0), an empty disk Gamma = 0; ``validity="all"``: the conventions
``benchmarks/bench_order.py`` checks node for node against a port of the scripts), counts the
defects of each charge per image and divides by the 22 x 22 plaquettes.  Beside it, per radius:
the share of empty disks (Gamma = 0 by the published rule, hence theta = 0), the mean number of
cells per disk, and the share of the defects on a plaquette with an empty corner.

Writes ``benchmarks/results_defect_density.md``.  Usage::

    PYTHONPATH=$PWD python benchmarks/defect_density_published.py
"""
from __future__ import annotations

import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import published_port as port  # noqa: E402
from bench_order import IMAGES, MDCK, mdck_cells  # noqa: E402
from hexatissue.defects import find_defects  # noqa: E402
from hexatissue.order import coarse_grain  # noqa: E402

FACTORS = (1, 2, 3, 4, 5)
N_PLAQUETTES = (port.GRID_NODES - 1) ** 2
# Fig. 3d source data: mean density (s.e.m.) per R / R_cell = 1..5.  The column labelled "+ 1/2" rises
# with R (0.0114, 0.0336, 0.0581, 0.0795, 0.0883) while "- 1/2" falls (0.0441 ... 0.0053): it is not a
# density of +1/2 defects and is left out.
PUBLISHED = {
    ("-1/2", 2, -1): ([0.044111, 0.020807, 0.011486, 0.00717, 0.005302],
                      [0.002150, 0.000690, 0.000589, 0.000509, 0.000502]),
    ("+1/6", 6, 1): ([0.058244, 0.029902, 0.019628, 0.01294, 0.009904],
                     [0.002333, 0.000947, 0.00088, 0.000634, 0.000556]),
    ("-1/6", 6, -1): ([0.050703, 0.029673, 0.019929, 0.013039, 0.009704],
                      [0.002629, 0.000911, 0.000826, 0.000588, 0.00063]),
}


def main():
    t0 = time.time()
    cells = mdck_cells()
    radii = [f * port.R_CELL for f in FACTORS]
    common = dict(spacing=port.GRID_SIZE / port.GRID_NODES, origin=(0.0, 0.0),
                  shape=(port.GRID_NODES, port.GRID_NODES), r_cell=port.R_CELL)
    grid = coarse_grain(cells, p=[2, 6], radius=radii, validity="all", **common)
    defects = find_defects(grid, p=[2, 6])
    # the same fields with empty disks invalid: defects only on plaquettes whose four corners hold cells
    occupied = find_defects(coarse_grain(cells, p=[2, 6], radius=radii, validity="occupied", **common), p=[2, 6])
    rows = []
    for (name, p, sign), (values, sems) in PUBLISHED.items():
        for k, f in enumerate(FACTORS):
            at = np.isclose(defects["radius"], f * port.R_CELL) & (defects["p"] == p)
            mine = defects[at & (np.sign(defects["charge"]) == sign)].groupby("frame").size()
            per_image = mine.reindex(IMAGES, fill_value=0) / N_PLAQUETTES
            at_occ = np.isclose(occupied["radius"], f * port.R_CELL) & (occupied["p"] == p)
            n_occ = int((at_occ & (np.sign(occupied["charge"]) == sign)).sum())
            g = grid[np.isclose(grid["radius"], f * port.R_CELL)]
            rows.append({"defect": name, "R/R_cell": f, "published": values[k], "published s.e.m.": sems[k],
                         "hexatissue": per_image.mean(), "s.e.m.": per_image.std(ddof=1) / np.sqrt(len(per_image)),
                         "difference %": 100 * (per_image.mean() / values[k] - 1),
                         "empty disks %": 100 * float((g["n_cells"] == 0).mean()),
                         "cells per disk": float(g["n_cells"].mean()),
                         "defects at an empty corner %": 100 * (1 - n_occ / max(int(mine.sum()), 1))})
    table = pd.DataFrame(rows)
    lines = ["# Defect densities against the published ones (`benchmarks/defect_density_published.py`)", "",
             f"Generated {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on {platform.node() or 'this machine'} "
             f"({os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}), {time.time() - t0:.0f} s. Data: {MDCK.name}, "
             f"images 6-68 (63). Density = defects per image / {N_PLAQUETTES} plaquettes, mean over images; "
             "published: Fig. 3d source data (the '+ 1/2' column rises with R and is not a +1/2 density: left out).",
             "", "| " + " | ".join(table.columns) + " |", "|" + "---|" * len(table.columns)]
    for r in table.itertuples(index=False):
        lines.append("| " + " | ".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in r) + " |")
    out = HERE / "results_defect_density.md"
    out.write_text("\n".join(lines) + "\n")
    print(out.read_text())


if __name__ == "__main__":
    main()
