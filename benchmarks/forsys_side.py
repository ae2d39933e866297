"""ForSys's side of benchmarks/bench_forsys.py: run under the Python that has ``forsys`` installed (never a
dependency of hexatissue).

Usage (called by bench_forsys.py)::

    /path/to/forsys-venv/bin/python benchmarks/forsys_side.py {dump,tif} INPUT OUT.json [MINIMUM_DISTANCE]

``dump``: a Surface Evolver dump, read by ForSys's own reader (its ground truth kept); ``tif``: a skeleton image
(``MINIMUM_DISTANCE``: ForSys's ``Skeleton(minimum_distance=...)``, default 0), run as ForSys's own test of
it (``tests/test_real_tissue.py``: 6 virtual vertices per junction, Savitzky-Golay filter, DLITE circle fits,
non-negative least squares).  Writes, per interior junction of ForSys's network, its vertices' positions, its
inferred stress and ForSys's ground truth; per cell its vertices' mean position and pressure; and the seconds the
inference took (reading included).
"""
import json
import sys
import time
import warnings

import numpy as np
import forsys as fs


def main():
    mode, path, out = sys.argv[1:4]
    minimum_distance = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
    warnings.simplefilter("ignore")
    start = time.perf_counter()
    if mode == "dump":
        se = fs.surface_evolver.SurfaceEvolver(path)
        frame = fs.frames.Frame(0, se.vertices, se.edges, se.cells, time=0, gt=True)
        run = fs.ForSys({0: frame}, cm=False)
        run.build_force_matrix(when=0)
        run.solve_stress(when=0)
    else:
        skeleton = fs.skeleton.Skeleton(path, mirror_y=False, minimum_distance=minimum_distance)
        vertices, edges, cells = skeleton.create_lattice()
        vertices, edges, cells, _ = fs.virtual_edges.generate_mesh(vertices, edges, cells, ne=6)
        frame = fs.frames.Frame(0, vertices, edges, cells, time=0)
        frame.filter_edges(method="SG")
        run = fs.ForSys({0: frame}, cm=False, initial_guess={})
        run.build_force_matrix(when=0, metadata={"ignore_four": False}, angle_limit=np.inf,
                               circle_fit_method="dlite")
        run.solve_stress(when=0, b_matrix="static", velocity_normalization=0, adimensional_velocity=False,
                         method="lsq", use_std=False, allow_negatives=False)
    pressure_error = None
    try:
        run.build_pressure_matrix(when=0)
        run.solve_pressure(when=0, method="lagrange_pressure")
    except Exception as error:  # ForSys's own refusal, reported beside its tensions
        pressure_error = f"{type(error).__name__}: {error}"
    seconds = time.perf_counter() - start
    frame = run.frames[0]
    tensions = frame.get_tensions()
    junctions = []
    for beid, stress, gt in zip(tensions["id"], tensions["stress"], tensions["gt"]):
        edge = frame.big_edges[beid]
        junctions.append({"id": int(beid), "x": [float(v) for v in edge.xs], "y": [float(v) for v in edge.ys],
                          "stress": float(stress), "gt": float(gt)})
    cells = []
    if pressure_error is None:
        pressures = frame.get_pressures()
        for cid, p, gt in zip(pressures["id"], pressures["pressure"], pressures["gt_pressure"]):
            cell = frame.cells[cid]
            cells.append({"id": int(cid), "x": float(np.mean([v.x for v in cell.vertices])),
                          "y": float(np.mean([v.y for v in cell.vertices])), "pressure": float(p),
                          "gt": float(gt) if gt is not None else None})
    with open(out, "w") as fh:
        json.dump({"seconds": seconds, "junctions": junctions, "cells": cells, "pressure_error": pressure_error}, fh)


if __name__ == "__main__":
    main()
