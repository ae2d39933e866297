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
(labelled icosphere s = 8, 1.3 M faces; exact s = 2, 0.96 M faces), best of 3, and of its coarse-grained field alone.

The coarse-grained field Gamma_p: defects of the cells' gamma_p and of Gamma_p against the disk radius (in R_cell)
on exact tissues of 400 cells on a sphere of radius 100 px (5 seeds, jitter 0.3 and 0.1) and on a torus (R = 100,
r = 40 px, 250 cells, 3 seeds), with the cells per disk and the charge sums; and the disk's distance: the chord and
the arc of the normals' circle (:func:`hexatissue.surface.transport.arc_lengths`, what the disks use) against the great
circle between the centroids' directions on the sphere (100, 400 and 2000 cells, 3 seeds): median relative error
of the pairs within 1.3 R and the cells per disk whose membership differs.

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
from hexatissue.surface.mesh_field import coarse_field
from hexatissue.surface.transport import arc_lengths
from hexatissue.synthetic_surface import sphere_tissue, torus_tissue

SEEDS = range(5)
RADIUS = 100.0
N_CELLS = 100
LEVELS = {"labelled": (4, 5, 6, 7), "exact": (1, 2, 3, 4, 5)}
REPEATS = 3
FACTORS = (1.5, 2.0, 2.5, 3.0, 4.0)


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
        c, frames = tables["mesh_cells"], tables["mesh_frames"].iloc[0]
        normal = c[["normal_x", "normal_y", "normal_z"]].to_numpy()
        e1 = c[["e1_x", "e1_y", "e1_z"]].to_numpy()
        gammas = [(c[f"gamma{q}_re"] + 1j * c[f"gamma{q}_im"]).to_numpy() for q in (6, 2)]
        field = np.inf
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            coarse_field(c[["x", "y", "z"]].to_numpy(), normal, e1, np.cross(normal, e1), gammas, (6, 2),
                          ~c.is_border.to_numpy(), frames.radius)
            field = min(field, time.perf_counter() - t0)
        out["exact" if exact else "labelled"] = (len(t.faces), best, field, frames)
    return out


def defect_counts(tissue):
    """``{factor: (cells-level counts p=6, p=2, coarse counts p=6, p=2, mean cells per disk, coarse sums)}``."""
    r_cell = mesh_tissue(tissue.vertices, tissue.faces, tissue.labels, p=(6,))["mesh_frames"].r_cell[0]
    out = {}
    for f in FACTORS:
        tables = mesh_tissue(tissue.vertices, tissue.faces, tissue.labels, p=(6, 2), radius=f * r_cell)
        n = tables["mesh_defects"].groupby(["field", "p"]).size()
        frames = tables["mesh_frames"].iloc[0]
        out[f] = (n.get(("cells", 6), 0), n.get(("cells", 2), 0), n.get(("coarse", 6), 0), n.get(("coarse", 2), 0),
                  tables["mesh_cells"].n_disk.mean(), (frames.coarse_charge6, frames.coarse_charge2))
    return out


def coarse_rows(name, tissues):
    rows = [f"### {name}", "", "| R / R_cell | cells per disk | defects of gamma_p: p = 6, p = 2 | defects of "
            "Gamma_p: p = 6, p = 2 | Gamma_p charge sums |", "|---|---|---|---|---|"]
    counts = [defect_counts(t) for t in tissues]
    for f in FACTORS:
        c = np.array([x[f][:5] for x in counts], float).mean(axis=0)
        sums = sorted({f"{a:g}, {b:g}" for a, b in (x[f][5] for x in counts)})
        rows.append(f"| {f:g} | {c[4]:.2f} | {c[0]:.1f}, {c[1]:.1f} | {c[2]:.1f}, {c[3]:.1f} | "
                    f"{' / '.join(sums)} in all {len(tissues)} |")
    return rows + [""]


def distances():
    rows = ["| cells | R / radius of the sphere | cells per disk | chord: median error, cells per disk differing | "
            "arc: median error, cells per disk differing |", "|---|---|---|---|---|"]
    for n in (100, 400, 2000):
        stats = {"chord": [], "arc": []}
        for seed in range(3):
            t = sphere_tissue(n, RADIUS, seed, 3, exact=True)
            tables = mesh_tissue(t.vertices, t.faces, t.labels, p=(6,))
            c, radius = tables["mesh_cells"], tables["mesh_frames"].radius[0]
            x = c[["x", "y", "z"]].to_numpy()
            normal = c[["normal_x", "normal_y", "normal_z"]].to_numpy()
            i, j = (k.ravel() for k in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
            i, j = i[i != j], j[i != j]
            u = x / np.linalg.norm(x, axis=1)[:, None]
            true = RADIUS * 2 * np.arctan2(np.linalg.norm(u[i] - u[j], axis=1), np.linalg.norm(u[i] + u[j], axis=1))
            near = true <= 1.3 * radius
            for name, d in (("chord", np.linalg.norm(x[i] - x[j], axis=1)),
                            ("arc", arc_lengths(x[i], x[j], normal[i], normal[j]))):
                stats[name].append((np.median(d[near] / true[near] - 1), ((d <= radius) != (true <= radius)).sum() / n,
                                    1 + (true <= radius).sum() / n, radius / RADIUS))
        m = {k: np.mean(v, axis=0) for k, v in stats.items()}
        rows.append(f"| {n} | {m['arc'][3]:.3f} | {m['arc'][2]:.2f} | {m['chord'][0]:+.2%}, {m['chord'][1]:.3f} | "
                    f"{m['arc'][0]:+.2%}, {m['arc'][1]:.3f} |")
    return rows + [""]


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
              "the arcs by about (side / radius)^2 / 24 whatever the mesh.", ""]
    lines += ["## The coarse-grained field Gamma_p", "",
              "Exact cells, default R = 2.5 R_cell; means over the tissues; the cells' defects do not depend on R.", ""]
    for jitter in (0.3, 0.1):
        lines += coarse_rows(f"{4 * N_CELLS} cells on a sphere of radius {RADIUS:g} px, jitter {jitter:g}",
                             [sphere_tissue(4 * N_CELLS, RADIUS, seed, 2, jitter=jitter, exact=True) for seed in SEEDS])
    lines += coarse_rows("250 cells on a torus (R = 100, r = 40 px)",
                         [torus_tissue(250, 100.0, 40.0, seed) for seed in range(3)])
    lines += ["### The disk's distance on a sphere of radius 100 px", ""] + distances()
    lines += ["## Cost", ""]
    for kind, (faces, best, field, frames) in cost().items():
        lines.append(f"- {kind}: 10,000 cells on {faces:,} faces: {best:.2f} s for every table, of which the "
                     f"coarse-grained field (p = 6 and 2) {field:.3f} s (best of {REPEATS}; charge sums "
                     f"{frames.charge6:g} and {frames.charge2:g}, of Gamma_p {frames.coarse_charge6:g} and "
                     f"{frames.coarse_charge2:g}).")
    lines += ["", f"1-minute load {os.getloadavg()[0]:.1f} after the run.", ""]
    text = "\n".join(lines)
    print(text)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
