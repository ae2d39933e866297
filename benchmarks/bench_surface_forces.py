"""Force inference on a height map against a vertex model at force balance laid on tilted planes.

The truth (:func:`hexatissue.synthetic_surface.tilted_network`): a periodic vertex-model sheet at force balance
(:func:`hexatissue.synthetic.vertex_model_tissue`, 14 x 14 cells 30 px apart, tensions 1 +- 0.2), cut open along
its box's edges and laid rigidly on a plane tilted by ``tilt`` about an axis at ``azimuth`` in the image plane, then
projected: the labels (the projected polygons drawn at 1 px per px) and the plane's height map.  A rigid motion keeps
the balance, so the true tensions are the flat sheet's.  Each is analysed with the default force inference
(Bayesian, ABIC, junction model ``auto``) twice: without the height map (flat inference on the projection) and with
it (each vertex balanced in its tangent plane); the interior junctions' tensions are matched to the truth by their
cell pair, both scaled to mean 1, and the median relative error and the correlation are pooled over the seeds.

The same with the exact vertices (the network's own tables, no pixels): the largest |A x| of the truth in the
projected and the surface equations, and the median relative error of the ABIC estimate.

    NUMBA_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_surface_forces.py [--out FILE]
"""
import argparse
import datetime
import os
import platform
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from hexatissue import MechanicsOptions, analyze
from hexatissue.errors import HexatissueWarning
from hexatissue.mechanics import force_system, infer_forces
from hexatissue.synthetic import vertex_model_tissue
from hexatissue.synthetic_surface import tilted_network

SEEDS = (3, 4, 5)
TILTS = ((0, 0), (30, 0), (30, 60), (50, 0), (50, 60), (70, 0))


def _pair_truth(truth_edges, values, edges):
    truth = pd.Series(values, index=pd.MultiIndex.from_arrays([truth_edges["cell_a"], truth_edges["cell_b"]]))
    truth = truth[~truth.index.duplicated(keep=False)]
    return truth.reindex(pd.MultiIndex.from_arrays([edges["cell_a"], edges["cell_b"]])).to_numpy(float)


def _errors(tension, want):
    ok = np.isfinite(tension) & np.isfinite(want)
    t, w = tension[ok] / tension[ok].mean(), want[ok] / want[ok].mean()
    return np.abs(t - w) / w, t, w


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "results_surface_forces.md"))
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0]
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    sheets = {seed: vertex_model_tissue(14, 14, spacing=30.0, tension_spread=0.2, seed=seed) for seed in SEEDS}
    rows = []
    for tilt, azimuth in TILTS:
        pooled = {k: [] for k in ("flat", "surface", "flat_t", "flat_w", "surface_t", "surface_w", "exact_flat",
                                  "exact_surface")}
        residual = {"flat": [], "surface": []}
        miss = {"flat": 0.0, "surface": 0.0}
        for seed in SEEDS:
            net = tilted_network(*sheets[seed], tilt, azimuth)
            t = net.tables
            tables = (t["cells"], t["vertices"], t["edges"], t["cell_vertices"])
            for name, normals in (("flat", None), ("surface", net.normals)):
                system = force_system(*tables, normals=normals)
                truth = np.r_[net.tension[system.edge_rows], net.pressure[system.cell_rows]]
                miss[name] = max(miss[name], float(np.abs(system.matrix @ truth).max()))
                forces = infer_forces(*tables, normals=normals, sd=False)
                inner = ((t["edges"]["cell_a"] != 0) & (t["edges"]["cell_b"] != 0)).to_numpy()
                e, _, _ = _errors(np.where(inner, forces.edges["tension"].to_numpy(), np.nan), net.tension)
                pooled[f"exact_{name}"].append(e)
            for name, surface in (("flat", None), ("surface", net.height)):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", HexatissueWarning)
                    movie = analyze(net.labels, surface=surface, mechanics=MechanicsOptions(enabled=True),
                                    workers=1, progress=False)
                edges = movie.edges
                inner = ((edges["cell_a"] != 0) & (edges["cell_b"] != 0)).to_numpy()
                e, tt, w = _errors(np.where(inner, edges["tension"].to_numpy(float), np.nan),
                                   _pair_truth(t["edges"], net.tension, edges))
                pooled[name].append(e)
                pooled[f"{name}_t"].append(tt)
                pooled[f"{name}_w"].append(w)
                residual[name].append(float(movie.tables["force_fit"]["residual"].iloc[0]))
        p = {k: np.concatenate(v) for k, v in pooled.items()}
        r = {name: np.corrcoef(p[f"{name}_t"], p[f"{name}_w"])[0, 1] for name in ("flat", "surface")}
        rows.append(f"| {tilt}°, {azimuth}° | {len(p['flat'])} | {np.median(p['flat']):.1%} | "
                    f"{np.median(p['surface']):.1%} | {r['flat']:.2f}, {r['surface']:.2f} | "
                    f"{np.median(residual['flat']):.4f}, {np.median(residual['surface']):.4f} | "
                    f"{miss['flat']:.2g}, {miss['surface']:.2g} | {np.median(p['exact_flat']):.1%}, "
                    f"{np.median(p['exact_surface']):.1%} |")
        print(rows[-1], flush=True)
    lines = ["# Force inference on a height map against tilted vertex-model sheets (`bench_surface_forces.py`)", "",
             f"{stamp}, {platform.machine()} with {os.cpu_count()} cores (shared), Python "
             f"{platform.python_version()}, numpy {np.__version__}; 1-minute load {load_before:.1f} before the run. "
             "Command: `NUMBA_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_surface_forces.py`. Tissues and "
             f"method: the script's docstring; seeds {', '.join(map(str, SEEDS))}, interior junctions pooled.", "",
             "| tilt, azimuth | junctions | median relative tension error, flat inference on the projection | "
             "the same, on the height map | r (flat, surface) | force_fit.residual, median (flat, surface) | "
             "exact vertices: largest \\|A x\\| of the truth (projected, surface equations) | exact vertices: "
             "median relative tension error (flat, surface) |",
             "|---|---|---|---|---|---|---|---|", *rows, "",
             "Goal: on the height map the error of the untilted sheet at every tilt; the flat inference's grows with "
             "the tilt.", "", f"1-minute load {os.getloadavg()[0]:.1f} after the run.", ""]
    text = "\n".join(lines)
    print(text)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
