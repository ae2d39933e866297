"""hexatissue's deformation budget of a results folder, written beside the TissueMiner run.

Calls :func:`hexatissue.deformation.deformation_budget` on the folder's cells, vertices,
cell_vertices, lineage and events tables (the same tables write_db.py gives TissueMiner) and
writes the ``deformation`` table (``--out``, Parquet).  ``--centres`` replaces the cells' pixel
centroids by exact centres (movies.py's exact_centres.csv), as write_db.py --centres does for
TissueMiner, so both codes see the same positions.

Usage::

    PYTHONPATH=$PWD python benchmarks/tissueminer/hexatissue_budget.py RESULTS_DIR --out DEFORMATION.parquet [--centres CSV]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd


def budget(results, centres=None):
    import hexatissue as ht
    from hexatissue.deformation import deformation_budget
    movie = ht.read_results(results)
    cells = movie.cells.copy()
    if centres is not None:
        ex = pd.read_csv(centres)
        m = cells[["frame", "cell"]].merge(ex, on=["frame", "cell"], how="left")
        if m["x"].isna().any():
            raise SystemExit("exact centres missing for some cells")
        cells["x"], cells["y"] = m["x"].to_numpy(), m["y"].to_numpy()
    events = movie.tables.get("events")
    table, _ = deformation_budget(cells, movie.vertices, movie.cell_vertices, movie.lineage, events)
    return table


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("results")
    ap.add_argument("--out", required=True)
    ap.add_argument("--centres")
    args = ap.parse_args(argv)
    table = budget(args.results, args.centres)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    table.to_parquet(args.out)
    tissue = table[table["region"] == "tissue"]
    cols = ["frame"] + [c for c in tissue if c.endswith(("_xx", "_xy")) and abs(tissue[c]).max() > 0]
    with pd.option_context("display.width", 250, "display.float_format", "{:.3e}".format):
        print(tissue[cols].set_index("frame").T.to_string())


if __name__ == "__main__":
    main()
