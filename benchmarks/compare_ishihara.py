"""Ishihara & Sugimura's Bayesian force-inference sample: hexatissue's network and tensions beside GetVertex's.

``--data`` holds ``sample.tif`` (a 1-px skeleton, 402 x 212) and ``VDat_sample.txt`` (the vertex table GetVertex
made from it; IshiharaLab/BayesianForceInference, MIT).  The skeleton is meshed by hexatissue
(``kind="skeleton"``); the table is read by :func:`hexatissue.mechanics.vdat.read_vdat` and meshed from its cell
polygons.  Matching: each table vertex to the nearest network vertex within ``--tol`` px (1.5); each table cell to
the network cell whose label holds its polygon's centroid; each table junction to the network junction joining
its two matched vertices.  Then the Bayesian estimate (ABIC) on both networks (straight junctions, as the table's
polygons are; and curved, from the skeleton's pixels, and the default junction model, on the image network) and the Pearson correlation of the
tensions over the matched interior junctions.  Usage::

    python benchmarks/compare_ishihara.py --data DIR [--tol 1.5]
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
import tifffile
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import hexatissue as ht  # noqa: E402
from hexatissue.mechanics import frame_forces, infer_forces, junction_curvature  # noqa: E402
from hexatissue.mechanics.vdat import read_vdat  # noqa: E402
from hexatissue.mesh.labels import mesh_labels, validate_labels  # noqa: E402



def compare(data, tol=1.5):
    """Counts of matched/unmatched vertices, cells and junctions, and the tension correlations (a dict)."""
    from scipy.spatial import cKDTree

    table = read_vdat(Path(data) / "VDat_sample.txt")
    skeleton = tifffile.imread(Path(data) / "sample.tif")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        labels, _ = mesh_labels(validate_labels(skeleton), None, ht.MeshOptions(kind="skeleton"))
        image = {k: pd.DataFrame(v) for k, v in ht.mesh_from_labels(labels).tables.items()}
        poly = {k: pd.DataFrame(v) for k, v in ht.mesh_from_polygons(table["polygons"], tolerance=0.5).tables.items()}
    out = {}
    # vertices
    vxy = image["vertices"][["x", "y"]].to_numpy()
    dist, near = cKDTree(vxy).query(table["vertices"])
    vmatch = np.where(dist <= tol, image["vertices"]["vertex"].to_numpy()[near], -1)
    out["vertices"] = (int((vmatch >= 0).sum()), int((vmatch < 0).sum()), len(image["vertices"]))
    # cells: the label under each table polygon's centroid
    cells = {}
    for cid, p in table["polygons"].items():
        x, y = poly["cells"].set_index("cell").loc[cid, ["x", "y"]]
        cells[cid] = int(labels[int(round(y)), int(round(x))])
    hit = [c for c in cells.values() if c > 0]
    out["cells"] = (len(set(hit)), len(cells) - len(set(hit)), len(image["cells"]))
    # junctions: the image junction joining the two matched vertices
    e = image["edges"]
    key = {frozenset(k): i for i, k in enumerate(zip(e["vertex_a"], e["vertex_b"]))}
    jmatch = np.array([key.get(frozenset((vmatch[a], vmatch[b])), -1) if vmatch[a] >= 0 and vmatch[b] >= 0 else -1
                       for a, b in table["edges"]])
    out["junctions"] = (int((jmatch >= 0).sum()), int((jmatch < 0).sum()), len(e))
    # the table's junctions in the polygon network: by their end positions
    pv = poly["vertices"].set_index("vertex")[["x", "y"]]
    pkey = {}
    for i, (a, b) in enumerate(zip(poly["edges"]["vertex_a"], poly["edges"]["vertex_b"])):
        pkey[frozenset((tuple(np.round(pv.loc[a], 3)), tuple(np.round(pv.loc[b], 3))))] = i
    tv = np.round(table["vertices"], 3)
    prow = np.array([pkey.get(frozenset((tuple(tv[a]), tuple(tv[b]))), -1) for a, b in table["edges"]])

    def forces(t, curvature=None):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return infer_forces(t["cells"], t["vertices"], t["edges"], t["cell_vertices"], sd=False,
                                curvature=curvature).edges["tension"].to_numpy()

    t_table = forces(poly)
    t_image = forces(image)
    t_curved = forces(image, junction_curvature(labels, image["vertices"], image["edges"]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        auto, _, model, share = frame_forces(labels, image["cells"], image["vertices"], image["edges"],
                                             image["cell_vertices"], sd=False)
    out["auto_model"] = (model, share)
    t_auto = auto.edges["tension"].to_numpy()
    both = (jmatch >= 0) & (prow >= 0)
    a = t_table[prow[both]]
    for name, t in (("straight", t_image), ("curved", t_curved), ("auto", t_auto)):
        b = t[jmatch[both]]
        ok = np.isfinite(a) & np.isfinite(b)
        out[f"r_{name}"] = (float(np.corrcoef(a[ok], b[ok])[0, 1]), int(ok.sum()))
        out[f"median_rel_{name}"] = float(np.median(np.abs(b[ok] / b[ok].mean() - a[ok] / a[ok].mean())
                                                    / (a[ok] / a[ok].mean())))
    out["table"] = (len(table["vertices"]), len(table["edges"]), len(table["polygons"]))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True)
    parser.add_argument("--tol", type=float, default=1.5)
    args = parser.parse_args()
    out = compare(args.data, args.tol)
    nv, ne, nc = out["table"]
    print(f"GetVertex table: {nv} vertices, {ne} junctions, {nc} cells")
    for what in ("vertices", "cells", "junctions"):
        hit, miss, total = out[what]
        print(f"  {what}: {hit} matched, {miss} of the table's unmatched (hexatissue's network: {total})")
    print(f"  default (junctions auto): {out['auto_model'][0]} ({out['auto_model'][1]:.2f} of the tested junctions "
          f"curved)")
    for name in ("straight", "curved", "auto"):
        r, n = out[f"r_{name}"]
        print(f"  tensions, table network vs image network ({name}): r = {r:.3f} over {n} junctions, median "
              f"relative difference {out[f'median_rel_{name}']:.3f}")


if __name__ == "__main__":
    main()
