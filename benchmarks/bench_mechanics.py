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
the machine's load.

``--baseline REF`` compares the Bayesian estimate (mu = 0.01, no s.d., and
with ABIC) and least squares of this tree with ``hexatissue/mechanics/`` as it was at
the git revision ``REF``, loaded beside it in the same process: runs
alternated, best of ``--repeats``, the ratio new / old, and the largest
differences of every output; written to ``benchmarks/results_mechanics.md``.
Usage::

    python benchmarks/bench_mechanics.py [--cells 10000] [--repeats 3] [--sd-cells 1000] [--baseline REF]
"""
from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import datetime  # noqa: E402
import importlib.util  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
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


def baseline_module(ref):
    """``hexatissue.mechanics`` as it was at git revision ``ref``, as a package beside the installed one."""
    root = Path(__file__).resolve().parents[1]
    names = subprocess.run(["git", "-C", str(root), "ls-tree", "--name-only", ref, "hexatissue/mechanics/"],
                           check=True, capture_output=True, text=True).stdout.split()
    folder = Path(tempfile.mkdtemp())
    for name in names:
        if name.endswith(".py"):
            text = subprocess.run(["git", "-C", str(root), "show", f"{ref}:{name}"],
                                  check=True, capture_output=True, text=True).stdout
            (folder / Path(name).name).write_text(text)
    # a sibling of hexatissue.mechanics: its ``..`` imports resolve in the installed package, its ``.`` imports
    # (the modules of a package split by concept) in the revision's own files
    spec = importlib.util.spec_from_file_location("hexatissue._mechanics_baseline", folder / "__init__.py",
                                                  submodule_search_locations=[str(folder)])
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def largest_difference(a, b):
    """Largest absolute difference of every column of the two Forces' tables and of mu and ABIC."""
    out = 0.0
    for x, y in ((a.edges, b.edges), (a.cells, b.cells)):
        for column in x.columns:
            u, v = x[column].to_numpy(float), y[column].to_numpy(float)
            if not np.array_equal(np.isnan(u), np.isnan(v)):
                return np.inf
            out = max(out, float(np.nanmax(np.abs(u - v), initial=0.0)))
    if not a.undetermined.equals(b.undetermined):
        return np.inf
    return max(out, abs(a.mu - b.mu), abs(a.abic - b.abic) / max(abs(b.abic), 1.0))


def compare(tables, box, repeats, ref):
    """New / old of each estimate, alternated in this run; the lines of the results file."""
    old = baseline_module(ref)
    args = (tables["cells"], tables["vertices"], tables["edges"], tables["cell_vertices"], box)
    lines = []
    for label, kw, n_rep in (("Bayes, mu = 0.01, no s.d.", {"method": "bayes", "mu": 0.01, "sd": False}, repeats),
                             ("least squares", {"method": "lsq"}, repeats),
                             ("Bayes, ABIC, no s.d.", {"method": "bayes", "sd": False}, 1)):
        best = {"new": np.inf, "old": np.inf}
        out = {}
        for _ in range(n_rep):
            for name, func in (("old", old.infer_forces), ("new", infer_forces)):
                start = time.perf_counter()
                out[name] = func(*args, **kw)
                best[name] = min(best[name], time.perf_counter() - start)
        diff = largest_difference(out["new"], out["old"])
        lines.append(f"| {label} | {best['old']:.3f} s | {best['new']:.3f} s | "
                     f"**{best['new'] / best['old']:.3f}** | {diff:.1e} |")
        print(lines[-1], flush=True)
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=10000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sd-cells", type=int, default=1000)
    parser.add_argument("--baseline", help="git revision whose force inference the Bayesian estimate is "
                                           "compared with (alternated runs, best of --repeats)")
    args = parser.parse_args()
    load_before = os.getloadavg()
    print(f"load average before: {load_before}")
    tables, box = tissue(args.cells)
    infer_forces(*(tissue(100)[0][k] for k in ("cells", "vertices", "edges", "cell_vertices")), tissue(100)[1])
    if args.baseline:
        start = datetime.datetime.now(datetime.timezone.utc)
        rows = compare(tables, box, args.repeats, args.baseline)
        head = [f"# Force inference: this tree against `{args.baseline}` (`bench_mechanics.py --baseline`)", "",
                f"{start:%Y-%m-%d %H:%M} UTC, {platform.machine()} ({os.cpu_count()} cores), Python "
                f"{platform.python_version()}, one core (`OMP_NUM_THREADS=1`); 1-minute load before "
                f"{load_before[0]:.1f}.  Periodic Voronoi tissue of {len(tables['cells'])} cells (exact network "
                f"tables).  Runs alternated old / new; best of {args.repeats} (ABIC: one run each).  The last "
                "column is the largest absolute difference of every output column (tension, tension_sd, pressure, "
                "pressure_sd), of mu and of ABIC (relative); inf if the NaNs or the undetermined unknowns differ.",
                "", "| estimate | old | new | new / old | largest difference |", "|---|---|---|---|---|"]
        with open(Path(__file__).resolve().parent / "results_mechanics.md", "w") as fh:
            fh.write("\n".join(head + rows + ["", f"1-minute load after: {os.getloadavg()[0]:.1f}", ""]))
        return
    run(tables, box, args.repeats, "periodic")
    run(crop(tables, box), None, args.repeats, "open crop")
    small, small_box = tissue(args.sd_cells)
    t_sd, _ = timed(1, lambda: infer_forces(small["cells"], small["vertices"], small["edges"],
                                            small["cell_vertices"], small_box, method="bayes", mu=0.01))
    print(f"posterior s.d., {len(small['cells'])} cells (periodic, mu = 0.01, estimate included): {t_sd:.2f} s")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
