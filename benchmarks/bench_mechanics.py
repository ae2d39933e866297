"""Benchmark: force inference and stress on one large frame.

A periodic Voronoi tissue of a jittered hexagonal lattice (``--cells``,
10,000 by default, 20 px apart; its vertices are not at force balance, which
does not change the work) is built as exact network tables
(:func:`hexatissue.synthetic.periodic_voronoi_network`); then, on one core
(``OMP_NUM_THREADS=1`` etc. set before numpy loads), each of these is timed
``--repeats`` times (median): the force-balance matrix, least squares (with
the probes for free unknowns), the Bayesian estimate at a fixed prior weight,
the Bayesian estimate with ABIC, and the cell stress.  The same on an open
crop of the tissue (the central cells, border cells marked).  The posterior
s.d. (one solve per unknown) is timed on ``--sd-cells`` cells.  Printed with
the machine's load.  Usage::

    python benchmarks/bench_mechanics.py [--cells 10000] [--repeats 3] [--sd-cells 1000]
"""
from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import hexatissue as ht  # noqa: E402
from hexatissue.mechanics import cell_stress, force_system, infer_forces  # noqa: E402
from hexatissue.synthetic import periodic_voronoi_network  # noqa: E402


def tissue(n_cells, seed=0, spacing=20.0):
    side = int(round(np.sqrt(n_cells)))
    ny = side + side % 2
    row = spacing * np.sqrt(3) / 2
    box = ht.Box(side * spacing, ny * row)
    X, Y = np.meshgrid(np.arange(side) * spacing, np.arange(ny) * row)
    X = X + (np.arange(ny)[:, None] % 2) * spacing / 2
    rng = np.random.default_rng(seed)
    seeds = np.stack([X.ravel(), Y.ravel()], axis=1) + rng.uniform(-0.2, 0.2, (side * ny, 2)) * spacing
    return periodic_voronoi_network(seeds, box), box


def crop(tables, box):
    """The cells whose centroid lies in the central 80 % of the box, as an open image (outside = 0)."""
    cells = tables["cells"].copy()
    keep = ((np.abs(cells["x"] - box.Lx / 2) < 0.4 * box.Lx) & (np.abs(cells["y"] - box.Ly / 2) < 0.4 * box.Ly))
    ids = set(cells.loc[keep, "cell"])
    edges = tables["edges"].copy()
    a_in, b_in = edges["cell_a"].isin(ids), edges["cell_b"].isin(ids)
    edges = edges[a_in | b_in].copy()
    lone_a = ~edges["cell_a"].isin(ids)
    edges.loc[lone_a, "cell_a"] = 0
    edges.loc[~edges["cell_b"].isin(ids), "cell_b"] = 0
    swap = edges["cell_a"] > edges["cell_b"]
    edges.loc[swap, ["cell_a", "cell_b"]] = edges.loc[swap, ["cell_b", "cell_a"]].to_numpy()
    cv = tables["cell_vertices"][tables["cell_vertices"]["cell"].isin(ids)]
    vertices = tables["vertices"][tables["vertices"]["vertex"].isin(cv["vertex"])].copy()
    touching = set(edges.loc[edges["cell_a"] == 0, "vertex_a"]) | set(edges.loc[edges["cell_a"] == 0, "vertex_b"])
    vertices["is_border"] = vertices["vertex"].isin(touching)
    cells = cells[keep].copy()
    cells["is_border"] = cells["cell"].isin(set(edges.loc[edges["cell_a"] == 0, "cell_b"]))
    # the open image's coordinates: no wrapping needed, the crop lies inside the box
    return {"cells": cells, "vertices": vertices, "edges": edges, "cell_vertices": cv}


def timed(repeats, func):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = func()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), out


def run(tables, box, repeats, label):
    args = (tables["cells"], tables["vertices"], tables["edges"], tables["cell_vertices"], box)
    t_sys, system = timed(repeats, lambda: force_system(*args))
    t_lsq, lsq = timed(repeats, lambda: infer_forces(*args, method="lsq"))
    t_fix, fixed = timed(repeats, lambda: infer_forces(*args, method="bayes", mu=0.01, sd=False))
    t_abic, abic = timed(1, lambda: infer_forces(*args, method="bayes", sd=False))
    t_stress, _ = timed(repeats, lambda: cell_stress(tables["cells"], tables["vertices"], tables["edges"],
                                                      fixed.edges["tension"].to_numpy(),
                                                      fixed.cells["pressure"].to_numpy(), box))
    print(f"{label}: {len(tables['cells'])} cells, {system.matrix.shape[0]} equations x {system.matrix.shape[1]} "
          f"unknowns")
    print(f"  force-balance matrix {t_sys:.3f} s; least squares + free-unknown probes {t_lsq:.3f} s "
          f"({int(np.isfinite(lsq.edges['tension']).sum())} tensions determined); Bayesian at mu = 0.01 "
          f"{t_fix:.3f} s; Bayesian with ABIC {t_abic:.2f} s (mu = {abic.mu:.2g}); cell stress {t_stress:.3f} s")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=10000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sd-cells", type=int, default=1000)
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    tables, box = tissue(args.cells)
    infer_forces(*(tissue(100)[0][k] for k in ("cells", "vertices", "edges", "cell_vertices")), tissue(100)[1])
    run(tables, box, args.repeats, "periodic")
    run(crop(tables, box), None, args.repeats, "open crop")
    small, small_box = tissue(args.sd_cells)
    t_sd, _ = timed(1, lambda: infer_forces(small["cells"], small["vertices"], small["edges"],
                                            small["cell_vertices"], small_box, method="bayes", mu=0.01))
    print(f"posterior s.d., {len(small['cells'])} cells (periodic, mu = 0.01, estimate included): {t_sd:.2f} s")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
