"""Write TissueMiner's input (its SQLite movie database + the RData files its shear code loads)
from hexatissue's results tables.

TissueMiner (https://github.com/mpicbg-scicomp/tissue_miner) reads, for its shear
decomposition (``shear/CalculateShearContributions.R`` -> ``CreateIntermediates.R``
-> ``ShearByCellEvents2.R``):

* ``<movie>/<movie>.sqlite`` with the tables

  - ``cells(frame, cell_id, center_x, center_y, area, elong_xx, elong_xy)``;
    cell_id 10000 is TissueMiner's background ("void") cell, real ids start at 10001;
  - ``directed_bonds(frame, dbond_id, conj_dbond_id, bond_id, cell_id, vertex_id, left_dbond_id)``:
    each cell's junctions as directed bonds, clockwise in (x, y) (counter-clockwise on screen,
    y down: the orientation for which CreateTriangles.R's triangles have positive area),
    ``left_dbond_id`` = the next bond of the same cell (TissueMiner's parser: ``leftBondSeenFromCellMap[bonds[j]] = bonds[j+1]``),
    ``conj_dbond_id`` = the same junction seen from the neighbour (background: cell 10000);
  - ``bonds(frame, bond_id, bond_length)``, ``vertices(frame, vertex_id, x_pos, y_pos)``;
  - ``cell_histories(cell_id, tissue_analyzer_group_id, first_occ, last_occ,
    left_daughter_cell_id, right_daughter_cell_id, appears_by, disappears_by,
    lineage_group, generation)`` with TissueMiner's codes (disappears_by: Division,
    Apoptosis, MovesOutOfMask, Unclassified; appears_by: Division, MovedIntoMask,
    SegErrAppearance, Unclassified);
  - ``frames(frame, time_sec)``;

* ``<movie>/roi_bt/lgRoiSmoothed.RData``: a data.frame (cell_id, roi).  The shear code adds the
  ROI "raw" (every cell) itself; we add "interior" (the tracks that are never border cells);
* ``<movie>/shear_contrib/triList.RData`` (frame, tri_id, cell_id, tri_order) and
  ``neighbors.RData`` (frame, cell_id.x, dbond_id, left_dbond_id, cell_id.y).  By default
  these are made by TissueMiner's own ``triangles/CreateTriangles.R`` from ``directed_bonds``
  (run_tissueminer.sh does it); ``--triangles hexatissue`` writes them here instead, from
  hexatissue's vertices: one triangle per three-fold vertex not touching the background (its
  three cells, counter-clockwise in (x, y), i.e. positive signed area as TissueMiner's formulas
  need) and a fan of n - 2 triangles per n-fold one; ``--triangles stage`` writes exactly the
  triangles of hexatissue's deformation stage (``hexatissue.deformation.frame_triangles``).  (CreateTriangles.R makes n overlapping
  triangles at an n-fold vertex: each cell with its two neighbours there.)

Mapping of hexatissue's tables: TissueMiner cell_id = 10001 + track (a dividing mother's
track ends, its daughters are new tracks, as TissueMiner's ids); center = the pixel centroid
(x = column, y = row, both codes in the same frame); polygons from ``cell_vertices``
(counter-clockwise in (x, y)), the neighbour across each polygon side from ``edges``.
``elong_xx/elong_xy`` are written as 0 (not used by the shear code).

Usage::

    PYTHONPATH=$PWD python benchmarks/tissueminer/write_db.py RESULTS_DIR OUT_DIR/MOVIE [--triangles tm|hexatissue]
"""
from __future__ import annotations

import argparse
import sqlite3
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd

VOID = 10000
OFFSET = 10001
FRAME_SECONDS = 300.0

APPEARS = {"movie_start": "Unclassified", "division": "Division", "border": "MovedIntoMask",
           "appearance": "SegErrAppearance"}
DISAPPEARS = {"movie_end": "Unclassified", "division": "Division", "border": "MovesOutOfMask",
              "extrusion": "Apoptosis"}


def cell_ids(cells):
    """(frame, cell) -> TissueMiner cell_id."""
    return dict(zip(zip(cells["frame"], cells["cell"]), cells["track"].astype(np.int64) + OFFSET))


def directed_bonds(movie):
    """directed_bonds, bonds and vertices tables (global ids) from cells/edges/cell_vertices."""
    cells, edges, cv, verts = movie.cells, movie.edges, movie.cell_vertices, movie.vertices
    ids = cell_ids(cells)
    vid = lambda f, v: int(f) * 1_000_000 + int(v)  # noqa: E731  global vertex ids
    rows, bond_rows = [], []
    next_id = 1
    for f, cvf in cv.sort_values(["frame", "cell", "rank"]).groupby("frame", sort=True):
        ef = edges[edges["frame"] == f]
        other = {}
        for a, b, u, v, length, e in zip(ef["cell_a"], ef["cell_b"], ef["vertex_a"], ef["vertex_b"], ef["length"], ef["edge"]):
            other[(a, u, v)] = other[(a, v, u)] = (b, e, length)
            other[(b, u, v)] = other[(b, v, u)] = (a, e, length)
        key_to_id, frame_rows = {}, []
        for c, g in cvf.groupby("cell", sort=True):
            # TissueMiner's CreateTriangles.R makes the triangle (A, C, B) from bond j of A (neighbour B)
            # and its left bond j+1 (neighbour C); its formulas need positive signed area in
            # (x, y), so a cell's bonds must run clockwise in (x, y): reverse hexatissue's CCW polygon
            vs = g["vertex"].to_numpy()[::-1]
            n = len(vs)
            if n < 3:
                continue
            first = next_id
            for j in range(n):
                u, v = vs[j], vs[(j + 1) % n]
                nb, e, length = other[(c, u, v)]
                key_to_id[(c, u, v)] = next_id
                frame_rows.append(dict(frame=f, dbond_id=next_id, cell=c, nb=nb, u=u, v=v, edge=e,
                                       left_dbond_id=first + (j + 1) % n, length=length))
                next_id += 1
        # the background's bonds (cell 10000): reversed sides facing cell 0
        for r in list(frame_rows):
            if r["nb"] == 0:
                key_to_id[(0, r["v"], r["u"])] = next_id
                frame_rows.append(dict(frame=f, dbond_id=next_id, cell=0, nb=r["cell"], u=r["v"], v=r["u"],
                                       edge=r["edge"], left_dbond_id=next_id, length=r["length"]))
                next_id += 1
        for r in frame_rows:
            conj = key_to_id.get((r["nb"], r["v"], r["u"]))
            if conj is None:  # neighbour without a polygon (n_sides 0): treat as void
                conj = -1
            rows.append((int(f), r["dbond_id"], conj, int(f) * 1_000_000 + int(r["edge"]),
                         VOID if r["cell"] == 0 else ids[(f, r["cell"])], vid(f, r["u"]), r["left_dbond_id"]))
        for e, length in zip(ef["edge"], ef["length"]):
            bond_rows.append((int(f), int(f) * 1_000_000 + int(e), float(length)))
    db = pd.DataFrame(rows, columns=["frame", "dbond_id", "conj_dbond_id", "bond_id", "cell_id", "vertex_id", "left_dbond_id"])
    bonds = pd.DataFrame(bond_rows, columns=["frame", "bond_id", "bond_length"])
    vt = pd.DataFrame({"frame": verts["frame"].astype(int),
                       "vertex_id": [vid(f, v) for f, v in zip(verts["frame"], verts["vertex"])],
                       "x_pos": verts["x"], "y_pos": verts["y"]})
    return db, bonds, vt


def neighbors_table(dbonds):
    """TissueMiner's neighbors.RData content, as CreateTriangles.R builds it."""
    real = dbonds[dbonds["cell_id"] != VOID]
    m = real[["frame", "cell_id", "dbond_id", "left_dbond_id"]].merge(
        real[["conj_dbond_id", "cell_id"]].rename(columns={"conj_dbond_id": "dbond_id"}), on="dbond_id",
        suffixes=(".x", ".y"))
    return m[["dbond_id", "frame", "cell_id.x", "left_dbond_id", "cell_id.y"]]


def triangles_from_vertices(movie):
    """Triangles dual to the interior vertices: (frame, tri_id, cell_id, tri_order), CCW in (x, y).

    A three-fold vertex gives its three cells; an n-fold vertex (n >= 4) a fan of n - 2 triangles
    from its smallest cell id over the cells in angular order (a tiling, unlike the n overlapping
    triangles TissueMiner's CreateTriangles.R makes from the directed bonds).  Vertices touching
    the background are left out (TissueMiner leaves out the triangles with its void cell).
    """
    cells, cv, verts = movie.cells, movie.cell_vertices, movie.vertices
    ids = cell_ids(cells)
    pos = dict(zip(zip(cells["frame"], cells["cell"]), zip(cells["x"], cells["y"])))
    inner = verts[(verts["degree"] >= 3) & ~verts["is_border"].astype(bool)]
    vpos = dict(zip(zip(inner["frame"], inner["vertex"]), zip(inner["x"], inner["y"])))
    around = cv[[k in vpos for k in zip(cv["frame"], cv["vertex"])]]
    out, tri = [], 0
    for (f, v), g in around.groupby(["frame", "vertex"], sort=True):
        cs = sorted({c for c in g["cell"] if c != 0})
        if len(cs) < 3:
            continue
        xy = np.array([pos[(f, c)] for c in cs]) - np.array(vpos[(f, v)])
        ring = [cs[i] for i in np.argsort(np.arctan2(xy[:, 1], xy[:, 0]), kind="stable")]
        s0 = ring.index(min(ring))
        ring = ring[s0:] + ring[:s0]
        for k in range(1, len(ring) - 1):
            tri += 1
            for order, c in enumerate((ring[0], ring[k], ring[k + 1]), 1):
                out.append((int(f), tri, ids[(f, c)], order))
    return pd.DataFrame(out, columns=["frame", "tri_id", "cell_id", "tri_order"])


def triangles_of_stage(movie, centres=None):
    """The triangles hexatissue's deformation stage uses (hexatissue.deformation.frame_triangles, frame
    by frame with the previous frame's diagonals): interior cells only, two triangles per four-fold
    vertex.  Returns (frame, tri_id, cell_id, tri_order), counter-clockwise in (x, y)."""
    from hexatissue.deformation import frame_triangles, triangle_edges
    cells = movie.cells.sort_values(["frame", "track"])
    if centres is not None:
        ex = pd.read_csv(centres)
        cells = cells.drop(columns=["x", "y"]).merge(ex[["frame", "cell", "x", "y"]], on=["frame", "cell"], how="left")
    out, tri, previous = [], 0, set()
    for f, c in cells.groupby("frame", sort=True):
        ids, _ = frame_triangles(c["track"].to_numpy(np.int64), c[["x", "y"]].to_numpy(float), c["cell"].to_numpy(np.int64),
                                 movie.vertices[movie.vertices["frame"] == f], movie.cell_vertices[movie.cell_vertices["frame"] == f],
                                 None, previous, ~c["is_border"].to_numpy(bool))
        previous = triangle_edges(ids)
        for row in ids:
            tri += 1
            for order, t in enumerate(row, 1):
                out.append((int(f), tri, int(t) + OFFSET, order))
    return pd.DataFrame(out, columns=["frame", "tri_id", "cell_id", "tri_order"])


def cell_histories(movie):
    lin = movie.lineage.copy()
    lin["cell_id"] = lin["track"].astype(np.int64) + OFFSET
    daughters = {}
    for t, p in zip(lin["track"], lin["parent"]):
        if p > 0:
            daughters.setdefault(int(p), []).append(int(t) + OFFSET)
    left = [sorted(daughters[t])[0] if t in daughters and len(daughters[t]) == 2 else None for t in lin["track"]]
    right = [sorted(daughters[t])[1] if t in daughters and len(daughters[t]) == 2 else None for t in lin["track"]]
    # lineage group: the root of each track's ancestry; generation: divisions since the root
    parent = dict(zip(lin["track"], lin["parent"]))

    def root_gen(t):
        g = 0
        while parent.get(t, 0) > 0:
            t, g = parent[t], g + 1
        return t, g

    rg = [root_gen(t) for t in lin["track"]]
    return pd.DataFrame({
        "cell_id": lin["cell_id"], "tissue_analyzer_group_id": lin["track"],
        "first_occ": lin["frame_start"].astype(int), "last_occ": lin["frame_end"].astype(int),
        "left_daughter_cell_id": pd.array(left, dtype="Int64"), "right_daughter_cell_id": pd.array(right, dtype="Int64"),
        "appears_by": lin["begin"].map(APPEARS).fillna("Unclassified"),
        "disappears_by": lin["end"].map(DISAPPEARS).fillna("Unclassified"),
        "lineage_group": [r + OFFSET for r, _ in rg], "generation": [g for _, g in rg],
    })


def r_save(csv_to_name, rdata, obj):
    """Rscript: read CSV files into data.frames and save them to ``rdata`` (first object = obj)."""
    reads = "; ".join(f"{name} <- read.csv('{csv}', check.names=FALSE)" for name, csv in csv_to_name)
    names = ", ".join(f"'{n}'" for n, _ in csv_to_name)
    subprocess.run(["Rscript", "-e", f"{reads}; save(list=c({names}), file='{rdata}')"], check=True)


def write(movie, out: Path, triangles="tm", centres=None):
    out = Path(out)
    name = out.name
    (out / "roi_bt").mkdir(parents=True, exist_ok=True)
    (out / "shear_contrib").mkdir(parents=True, exist_ok=True)
    (out / "csv").mkdir(parents=True, exist_ok=True)
    cells = movie.cells
    ids = cell_ids(cells)
    cells_db = pd.DataFrame({
        "frame": cells["frame"].astype(int), "cell_id": [ids[k] for k in zip(cells["frame"], cells["cell"])],
        "center_x": cells["x"].astype(float), "center_y": cells["y"].astype(float),
        "area": cells["area"].astype(float), "elong_xx": 0.0, "elong_xy": 0.0})
    if centres is not None:  # exact centres (synthetic truth) instead of the pixel centroids
        ex = pd.read_csv(centres)
        exd = dict(zip(zip(ex["frame"], ex["cell"]), zip(ex["x"], ex["y"], ex["area"])))
        got = [exd[k] for k in zip(cells["frame"], cells["cell"])]
        cells_db["center_x"], cells_db["center_y"], cells_db["area"] = np.array(got).T
    dbonds, bonds, verts = directed_bonds(movie)
    hist = cell_histories(movie)
    frames = np.sort(cells["frame"].unique())
    frames_db = pd.DataFrame({"frame": frames.astype(int), "time_sec": frames * FRAME_SECONDS})
    dbfile = out / f"{name}.sqlite"
    dbfile.unlink(missing_ok=True)
    with sqlite3.connect(dbfile) as con:
        for tname, df in [("cells", cells_db), ("directed_bonds", dbonds), ("bonds", bonds), ("vertices", verts),
                          ("cell_histories", hist), ("frames", frames_db)]:
            df.to_sql(tname, con, index=False)
    # ROI: "interior" = tracks never flagged is_border (the shear code adds "raw" = all cells)
    border_tracks = set(cells.loc[cells["is_border"].astype(bool), "track"])
    roi = pd.DataFrame({"cell_id": sorted(t + OFFSET for t in set(cells["track"]) - border_tracks), "roi": "interior"})
    roi.to_csv(out / "csv" / "lgRoiSmoothed.csv", index=False)
    r_save([("lgRoiSmoothed", out / "csv" / "lgRoiSmoothed.csv")], out / "roi_bt" / "lgRoiSmoothed.RData", "lgRoiSmoothed")
    tri_hx = triangles_from_vertices(movie)
    tri_hx.to_csv(out / "csv" / "triList_hexatissue.csv", index=False)
    nb = neighbors_table(dbonds)
    nb.to_csv(out / "csv" / "neighbors.csv", index=False)
    if triangles == "stage":
        triangles_of_stage(movie, centres).to_csv(out / "csv" / "triList_stage.csv", index=False)
        r_save([("triList", out / "csv" / "triList_stage.csv")], out / "shear_contrib" / "triList.RData", "triList")
        r_save([("neighbors", out / "csv" / "neighbors.csv")], out / "shear_contrib" / "neighbors.RData", "neighbors")
    if triangles == "hexatissue":
        r_save([("triList", out / "csv" / "triList_hexatissue.csv")], out / "shear_contrib" / "triList.RData", "triList")
        r_save([("neighbors", out / "csv" / "neighbors.csv")], out / "shear_contrib" / "neighbors.RData", "neighbors")
    return {"db": str(dbfile), "n_cells_rows": len(cells_db), "n_dbonds": len(dbonds), "n_triangles_hexatissue": len(tri_hx) // 3,
            "n_interior_roi_cells": len(roi)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("results", help="hexatissue results folder (Movie.write / hexatissue analyze --out)")
    ap.add_argument("out", help="TissueMiner movie folder to create (its name is the movie / database name)")
    ap.add_argument("--triangles", choices=["tm", "hexatissue", "stage"], default="tm",
                    help="tm: leave triList/neighbors to TissueMiner's CreateTriangles.R (default); "
                         "hexatissue: write them here from hexatissue's vertices (fans at n-fold vertices); "
                         "stage: the triangles of hexatissue's deformation stage (frame_triangles: interior "
                         "cells only, a four-fold vertex keeps the previous frame's diagonal)")
    ap.add_argument("--centres", help="CSV (frame, cell, x, y, area) of exact cell centres to write instead of "
                    "hexatissue's pixel centroids (movies.py's exact_centres.csv)")
    args = ap.parse_args(argv)
    import hexatissue as ht
    movie = ht.read_results(args.results)
    print(write(movie, Path(args.out), args.triangles, args.centres))


if __name__ == "__main__":
    main()
