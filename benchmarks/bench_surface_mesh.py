"""Surface meshes against exact spherical Voronoi tissues: area and perimeter error vs mesh resolution, charge sums,
time per 10^4 cells.

Tissues (:func:`hexatissue.synthetic_surface.sphere_tissue`), 100 cells on a sphere of radius 100 px (cells about
35 px across), 5 seeds each, all cells pooled (a closed surface has no border):

- labelled: an icosphere cut s times (edges about 110 / 2^s px), every face the cell of the seed nearest its
  centroid (jagged boundaries, as a segmented mesh has them);
- exact: each exact cell fanned from its seed and cut s times on the sphere (boundaries on the great circles);

each cell's ``area``, ``perimeter`` (along the mesh edges) and ``polygon_perimeter`` (straight sides between its
junction vertices) against the exact cell (scipy's SphericalVoronoi areas and arc lengths), and the sum of the
hexatic and nematic defect charges in every tissue.  Cost: :func:`hexatissue.surface.mesh_tissue` on 10,000 cells
(labelled icosphere s = 8, 1.3 M faces; exact s = 2, 0.96 M faces), best of 3.

    PYTHONPATH=$PWD python benchmarks/bench_surface_mesh.py [--out benchmarks/results_surface_mesh.md]
"""
import argparse
import datetime
import os
import platform
import time
from pathlib import Path

import numpy as np

from hexatissue.surface import mesh_tissue
from hexatissue.synthetic_surface import sphere_tissue

SEEDS = range(5)
RADIUS = 100.0
N_CELLS = 100
LEVELS = {"labelled": (4, 5, 6, 7), "exact": (1, 2, 3, 4, 5)}
REPEATS = 3


def errors(exact, subdivisions):
    area, perimeter, polygon, charges, faces, edge = [], [], [], [], 0, 0.0
    for seed in SEEDS:
        t = sphere_tissue(N_CELLS, RADIUS, seed, subdivisions, exact=exact)
        tables = mesh_tissue(t.vertices, t.faces, t.labels, p=(6, 2))
        c = tables["mesh_cells"].merge(t.truth, on="cell", suffixes=("", "_true"))
        area.append(c.area / c.area_true - 1)
        perimeter.append(c.perimeter / c.perimeter_true - 1)
        polygon.append(c.polygon_perimeter / c.perimeter_true - 1)
        frames = tables["mesh_frames"].iloc[0]
        charges.append((frames.charge6, frames.charge2))
        faces = len(t.faces)
        e = t.vertices[t.faces[:, 1]] - t.vertices[t.faces[:, 0]]
        edge = float(np.median(np.linalg.norm(e, axis=1)))
    return {k: np.concatenate(v) for k, v in (("area", area), ("perimeter", perimeter), ("polygon", polygon))} | {
        "charges": charges, "faces": faces, "edge": edge}


def cost():
    out = {}
    for exact, s in ((False, 8), (True, 2)):
        t = sphere_tissue(10_000, 500.0, 0, s, exact=exact)
        mesh_tissue(t.vertices, t.faces, t.labels)  # warm (numba's gamma_p kernel)
        best = np.inf
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            tables = mesh_tissue(t.vertices, t.faces, t.labels)
            best = min(best, time.perf_counter() - t0)
        out["exact" if exact else "labelled"] = (len(t.faces), best, tables["mesh_frames"].iloc[0])
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "results_surface_mesh.md"))
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0]
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = ["# Surface meshes against exact spherical Voronoi tissues (`bench_surface_mesh.py`)", "",
             f"{stamp}, {platform.machine()} with {os.cpu_count()} cores (shared), Python "
             f"{platform.python_version()}, numpy {np.__version__}; 1-minute load {load_before:.1f} before the run. "
             "Command: `PYTHONPATH=$PWD python benchmarks/bench_surface_mesh.py`. Tissues and method: the script's "
             f"docstring; {N_CELLS} cells on a sphere of radius {RADIUS:g} px, {len(SEEDS)} seeds, all cells pooled.",
             ""]
    for kind in ("labelled", "exact"):
        lines += [f"## {kind.capitalize()} cells", "",
                  "| s | faces | median edge (px) | area: median \\|e\\|, max \\|e\\| | perimeter (mesh edges): "
                  "median e | polygon perimeter: median \\|e\\|, max \\|e\\| | charge sums p = 6, p = 2 |",
                  "|---|---|---|---|---|---|---|"]
        for s in LEVELS[kind]:
            r = errors(kind == "exact", s)
            sums = sorted({f"{a:g}, {b:g}" for a, b in r["charges"]})
            lines.append(f"| {s} | {r['faces']} | {r['edge']:.2f} | {np.median(np.abs(r['area'])):.3%}, "
                         f"{np.abs(r['area']).max():.3%} | {np.median(r['perimeter']):+.2%} | "
                         f"{np.median(np.abs(r['polygon'])):.2%}, {np.abs(r['polygon']).max():.2%} | "
                         f"{' / '.join(sums)} in all {len(SEEDS)} |")
        lines.append("")
    lines += ["The exact cells' polygon perimeter is the chords between the exact Voronoi vertices, shorter than "
              "the arcs by about (side / radius)^2 / 24 whatever the mesh.", "", "## Cost", ""]
    for kind, (faces, best, frames) in cost().items():
        lines.append(f"- {kind}: 10,000 cells on {faces:,} faces: {best:.2f} s for every table (best of {REPEATS}; "
                     f"charge sums {frames.charge6:g} and {frames.charge2:g}).")
    lines += ["", f"1-minute load {os.getloadavg()[0]:.1f} after the run.", ""]
    text = "\n".join(lines)
    print(text)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
