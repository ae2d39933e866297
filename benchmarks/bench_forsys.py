"""Benchmark: hexatissue's force inference beside ForSys (Borges et al., bioRxiv 2024) on the same frames.

Inputs (the ForSys repository's test data, BSD 3-Clause: ``--data`` is a folder holding
``surface_evolver_12_12_step_24.dmp``, ``exp_1.tif.gz`` or ``exp_1.tif``, and ``exp_1_forsys_stress.csv``):

1. **Surface Evolver tissue, read directly** (exact tensions ``density``, pressures ``lagrange_multiplier``):
   hexatissue on its triple-junction network, straight and curved junctions (arcs fitted to each chain), least
   squares and Bayesian (ABIC); ForSys with its own dump reader and its default solve.
2. **The same tissue as an image**: drawn as a label image at ``--px-per-unit`` (bodies filled, outside 0), and as
   the skeleton of that image (its label boundaries thinned to one 8-connected pixel, as ForSys's skeletons are).
   hexatissue on the label image and on the skeleton; ForSys on the skeleton (``Skeleton(minimum_distance=2)``:
   with the default 0 ForSys's lattice builder fails on these skeletons).  Junctions are matched to the truth by
   their two end vertices (within ``--match`` px), cells by the body under their centroid.
3. **exp_1.tif** (a real skeleton, 15 cells): hexatissue's tensions against ForSys's own published output
   ``exp_1_forsys_stress.csv`` (the ForSys run here reproduces it to its 2 decimals: checked).

Errors: inferred and true tensions each scaled to mean 1 over the same matched junctions, median |error| / truth;
pressures each shifted to mean 0 and divided by their own mean tension, median |error| / s.d. of the truth
(``p err``), and the same after scaling each to unit s.d. (``p z``: blind to the pressure unit, which ForSys sets
differently); Pearson correlations.  Times: wall-clock from the file to the forces (hexatissue: reading, meshing, curvature,
Bayesian with ABIC, no s.d., median of ``--repeats``; ForSys: one run of its pipeline in its own interpreter,
numba/JIT warm-up excluded for hexatissue).  ForSys runs in a separate environment (``--forsys-python``, a Python
with ``pip install forsys``; never a dependency of hexatissue) through ``benchmarks/forsys_side.py``; without it
only hexatissue's side is printed.  Usage::

    python benchmarks/bench_forsys.py --data DIR [--forsys-python PY] [--px-per-unit 4] [--repeats 3]
"""
from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import gzip  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import hexatissue as ht  # noqa: E402
from hexatissue.mechanics import infer_forces, junction_curvature  # noqa: E402
from hexatissue.mechanics.evolver import evolver_labels, evolver_network  # noqa: E402
from hexatissue.mesh import label_skeleton  # noqa: E402
from hexatissue.mesh.labels import mesh_labels, validate_labels  # noqa: E402

DUMP = "surface_evolver_12_12_step_24.dmp"
HERE = Path(__file__).resolve().parent


def timed(repeats, func):
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = func()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), out


def infer(tables, curvature, method="bayes"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return infer_forces(tables["cells"], tables["vertices"], tables["edges"], tables["cell_vertices"],
                            method=method, sd=False, curvature=curvature)


def scores(t, t_true, p=None, p_true=None):
    """Median relative tension error, tension r, median pressure error / s.d., pressure r (module docstring)."""
    t, t_true = np.asarray(t, float), np.asarray(t_true, float)
    ok = np.isfinite(t) & np.isfinite(t_true)
    out = {"junctions": int(ok.sum())}
    if ok.sum() < 3:
        return out | {"t_err": np.nan, "t_r": np.nan, "cells": 0, "p_err": np.nan, "p_z": np.nan, "p_r": np.nan}
    unit, unit_true = t[ok].mean(), t_true[ok].mean()
    a, b = t[ok] / unit, t_true[ok] / unit_true
    out |= {"t_err": float(np.median(np.abs(a - b) / b)), "t_r": float(np.corrcoef(a, b)[0, 1])}
    if p is None or not len(p):
        return out | {"cells": 0, "p_err": np.nan, "p_z": np.nan, "p_r": np.nan}
    p, p_true = np.asarray(p, float), np.asarray(p_true, float)
    pk = np.isfinite(p) & np.isfinite(p_true)
    a = (p[pk] - p[pk].mean()) / unit
    b = (p_true[pk] - p_true[pk].mean()) / unit_true
    return out | {"cells": int(pk.sum()), "p_err": float(np.median(np.abs(a - b)) / b.std()),
                  "p_z": float(np.median(np.abs(a / a.std() - b / b.std()))), "p_r": float(np.corrcoef(a, b)[0, 1])}


def match_ends(ends, ref_ends, tol):
    """For each junction (end points ``ends[k] = [[xa, ya], [xb, yb]]``): the row of ``ref_ends`` with the same two
    ends (either order) within ``tol`` px summed, or -1."""
    ends, ref = np.asarray(ends, float), np.asarray(ref_ends, float)
    if not len(ends) or not len(ref):
        return np.full(len(ends), -1)
    same = (np.hypot(*(ends[:, None, 0] - ref[None, :, 0]).transpose(2, 0, 1))
            + np.hypot(*(ends[:, None, 1] - ref[None, :, 1]).transpose(2, 0, 1)))
    swap = (np.hypot(*(ends[:, None, 0] - ref[None, :, 1]).transpose(2, 0, 1))
            + np.hypot(*(ends[:, None, 1] - ref[None, :, 0]).transpose(2, 0, 1)))
    d = np.minimum(same, swap)
    best = d.argmin(axis=1)
    return np.where(d[np.arange(len(ends)), best] <= tol, best, -1)


def edge_ends(tables):
    v = tables["vertices"].set_index("vertex")[["x", "y"]]
    e = tables["edges"]
    return np.stack([v.loc[e["vertex_a"]].to_numpy(), v.loc[e["vertex_b"]].to_numpy()], axis=1)


def run_forsys(python, mode, path, minimum_distance=0.0):
    if python is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.json"
        cmd = [python, str(HERE / "forsys_side.py"), mode, str(path), str(out), str(minimum_distance)]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode:
            tail = (done.stderr.strip().splitlines() or ["?"])[-1]
            print(f"  ForSys failed on {Path(path).name}: {tail}")
            return None
        return json.loads(out.read_text())


def skeleton_tables(skeleton):
    """hexatissue on a ForSys-style skeleton (lines 255, cells and the tissue's outside 0, a 1-px frame ForSys
    crops): the region at the image corner is the outside."""
    regions = label_skeleton(skeleton)
    outside = int(regions[0, 0])
    labels, _ = mesh_labels(validate_labels(regions), None, ht.MeshOptions(kind="membrane", background=(outside,)))
    tables = {k: pd.DataFrame(v) for k, v in ht.mesh_from_labels(labels).tables.items()}
    return tables, labels


def label_tables(labels):
    return {k: pd.DataFrame(v) for k, v in ht.mesh_from_labels(labels).tables.items()}


def row(name, s, seconds):
    def f(x):
        return "-" if not np.isfinite(x) else f"{x:.3f}"
    print(f"  {name:<58} {s['junctions']:>4} {f(s['t_err']):>7} {f(s['t_r']):>6} {s['cells']:>4} "
          f"{f(s['p_err']):>7} {f(s['p_z']):>7} {f(s['p_r']):>6} {seconds:>8.2f}")


def header():
    print(f"  {'method':<58} {'junc':>4} {'t err':>7} {'t r':>6} {'cell':>4} {'p err':>7} {'p z':>7} {'p r':>6} {'s':>8}")


def dump_direct(path, args):
    print(f"1. {DUMP}, read directly")
    header()
    tables, tension, pressure = evolver_network(path)
    for curved in (False, True):
        for method in ("lsq", "bayes"):
            def go():
                t, _, _ = evolver_network(path)
                return infer(t, t["edges"]["curvature"].to_numpy() if curved else None, method)
            seconds, forces = timed(args.repeats, go)
            row(f"hexatissue {'curved' if curved else 'straight'}, {method}",
                scores(forces.edges["tension"], tension, forces.cells["pressure"], pressure), seconds)
    fs = run_forsys(args.forsys_python, "dump", path)
    if fs is not None:
        j, c = pd.DataFrame(fs["junctions"]), pd.DataFrame(fs["cells"])
        row("ForSys (its dump reader, default solve)", scores(j["stress"], j["gt"], c["pressure"], c["gt"]),
            fs["seconds"])


def dump_image(path, args, tmp):
    s = args.px_per_unit
    print(f"2. {DUMP} drawn at {s:g} px per unit")
    coarse, tension, pressure = evolver_network(path)
    labels, origin = evolver_labels(path, px_per_unit=s)
    truth_ends = (edge_ends(coarse) - origin) * s
    body_pressure = pd.Series(pressure / s, index=coarse["cells"]["cell"])

    boundary = np.zeros(labels.shape, bool)
    boundary[:, :-1] |= labels[:, :-1] != labels[:, 1:]
    boundary[:-1] |= labels[:-1] != labels[1:]
    from skimage.morphology import thin
    skeleton = np.pad(np.where(thin(boundary), 255, 0).astype(np.uint8), 1)
    sk_path = Path(tmp) / "evolver_skeleton.tif"
    import tifffile
    tifffile.imwrite(sk_path, np.repeat(skeleton[..., None], 3, axis=2))
    print(f"  image {labels.shape[1]} x {labels.shape[0]} px; skeleton written for ForSys")
    header()

    def truth_for(tables, labels_here, offset=0.0):
        k = match_ends(edge_ends(tables) + offset, truth_ends, args.match)
        t_true = np.where(k >= 0, tension[np.maximum(k, 0)], np.nan)
        cxy = np.round(tables["cells"][["x", "y"]].to_numpy() + offset).astype(int)
        body = labels[np.clip(cxy[:, 1], 0, labels.shape[0] - 1), np.clip(cxy[:, 0], 0, labels.shape[1] - 1)]
        return t_true, body_pressure.reindex(body).to_numpy()

    for source in ("label image", "skeleton"):
        for curved in (False, True):
            def go():
                if source == "label image":
                    lab = evolver_labels(path, px_per_unit=s)[0]
                    t = label_tables(lab)
                else:
                    t, lab = skeleton_tables(tifffile.imread(sk_path)[..., 0][1:-1, 1:-1])
                kappa = junction_curvature(lab, t["vertices"], t["edges"]) if curved else None
                return t, infer(t, kappa)
            seconds, (t, forces) = timed(args.repeats, go)
            t_true, p_true = truth_for(t, labels)
            row(f"hexatissue on the {source}, {'curved' if curved else 'straight'}",
                scores(forces.edges["tension"], t_true, forces.cells["pressure"], p_true), seconds)
    fs = run_forsys(args.forsys_python, "tif", sk_path, minimum_distance=2)
    if fs is not None:
        j = pd.DataFrame(fs["junctions"])
        ends = np.array([[[x[0], y[0]], [x[-1], y[-1]]] for x, y in zip(j["x"], j["y"])])
        k = match_ends(ends, truth_ends, args.match)  # ForSys's coordinates: the skeleton without its frame
        t_true = np.where(k >= 0, tension[np.maximum(k, 0)], np.nan)
        p, p_true = [], []
        for cell in fs["cells"]:
            x, y = int(round(cell["x"])), int(round(cell["y"]))
            p.append(cell["pressure"])
            p_true.append(body_pressure.get(labels[y, x], np.nan))
        row("ForSys on the skeleton", scores(j["stress"], t_true, p, p_true), fs["seconds"])
        if fs.get("pressure_error"):
            print(f"  ForSys gave no pressures: {fs['pressure_error']}")


def experiment(data, args, tmp):
    print("3. exp_1.tif against ForSys's own exp_1_forsys_stress.csv")
    tif = data / "exp_1.tif"
    if not tif.is_file():
        tif = Path(tmp) / "exp_1.tif"
        tif.write_bytes(gzip.decompress((data / "exp_1.tif.gz").read_bytes()))
    import tifffile
    published = pd.read_csv(data / "exp_1_forsys_stress.csv")["stress"].to_numpy()

    def go():
        t, lab = skeleton_tables(tifffile.imread(tif)[..., 0][1:-1, 1:-1])
        return t, infer(t, junction_curvature(lab, t["vertices"], t["edges"]))
    seconds, (t, forces) = timed(args.repeats, go)
    print(f"  hexatissue: {int(np.isfinite(forces.edges['tension']).sum())} tensions, {seconds:.2f} s")
    fs = run_forsys(args.forsys_python, "tif", tif)
    if fs is None:
        return
    j = pd.DataFrame(fs["junctions"])
    same = np.abs(j["stress"].round(2).to_numpy() - np.round(published, 2)).max()
    print(f"  ForSys here: {len(j)} tensions, {fs['seconds']:.2f} s; largest difference from the published csv "
          f"(2 decimals): {same:.2g}")
    ends = np.array([[[x[0], y[0]], [x[-1], y[-1]]] for x, y in zip(j["x"], j["y"])])
    k = match_ends(ends, edge_ends(t), args.match)
    ours = np.where(k >= 0, forces.edges["tension"].to_numpy()[np.maximum(k, 0)], np.nan)
    s = scores(ours, published)
    print(f"  matched {s['junctions']} of {len(published)}: hexatissue vs published ForSys, median relative "
          f"difference {s['t_err']:.3f}, r = {s['t_r']:.3f}; speed ratio ForSys / hexatissue "
          f"{fs['seconds'] / seconds:.0f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True)
    parser.add_argument("--forsys-python", default=None)
    parser.add_argument("--px-per-unit", type=float, default=4.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--match", type=float, default=8.0, help="px: end-vertex tolerance (sum of both ends)")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    path = args.data / DUMP
    infer(evolver_network(path)[0], None)  # warm-up
    with tempfile.TemporaryDirectory() as tmp:
        dump_direct(path, args)
        dump_image(path, args, tmp)
        experiment(args.data, args, tmp)
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
