"""The surface stage against exact curved tissues (issue 46): areas and |gamma6| on tilted planes and a bump.

Tissues (:mod:`hexatissue.synthetic_surface`), 5 seeds each:

- a flat Voronoi tissue (240 x 320 px in its own plane, cells 24 px apart) on a plane tilted by 0, 30, 50 and 70
  degrees about x, projected (labels + height map): each interior cell's ``surface_area`` and
  ``|surface_gamma6|`` against the flat tissue's exact polygon, and against the same tissue imaged flat and
  analysed (the issue's reference), beside what the flat analysis of the projection gives (``polygon_area``,
  ``|gamma6|``);
- Voronoi cells of the (x, y) plane (256 x 256 px, 24 px apart) lifted onto Gaussian bumps z = h exp(-r^2/2s^2),
  h = 80, s = 60 px (steepest slope 39 degrees, curvature radius 45 px at the top) and h = 60, s = 80 px: the
  interior cells' ``surface_area`` against the quadrature, through the analysed network and with the exact
  Voronoi vertices lifted (the surface geometry alone); the analysed network's own error on the same cells
  (``polygon_area`` against the exact projected polygon) is the pixel floor.

- the same tilted planes (30, 50 and 70 degrees), the coarse-grained field: the surface Gamma_6 (each cell's
  surface gamma_6 transported into the node's tangent plane, :func:`hexatissue.surface.surface_coarse_grain`)
  against the truth, the flat tissue's own cells (``flat_labels``, analysed) coarse-grained on the same grid
  and disks with their centroids squeezed into the image, beside the flat analysis of the projection on the
  same grid (R = 1.5 R_cell of the projected cells); and the defects (p = 6 and 2) the truth's field has that
  each finds at the same plaquette with the same charge.

Errors are pooled over the seeds' interior cells (medians, and the max where said); the cost of the stage is
the ``surface_arrays`` time against the mesh's, and a whole ``analyze`` with and without the stage, on a 2048 x 2048
tissue (best of 7 alternating runs).

    NUMBA_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_surface.py [--out benchmarks/results_surface.md]
"""
import argparse
import datetime
import os
import platform
import time
from pathlib import Path

import numpy as np

from hexatissue import OrderOptions, analyze, coarse_grain, find_defects, mesh_from_labels
from hexatissue._dispatch import references
from hexatissue.geometry import pack_polygons
from hexatissue.order import polygon_rows
from hexatissue.geometry import segment_sum
from hexatissue.surface import lift, surface_arrays, tangent_polygons
from hexatissue.surface._reference import _fan_area
from hexatissue.synthetic import jittered_seeds, voronoi_labels, voronoi_polygons
from hexatissue.synthetic_surface import gaussian_bump_tissue, tilted_plane_tissue

SEEDS = range(5)
TILTS = (0, 30, 50, 70)
BUMPS = ((80.0, 60.0), (60.0, 80.0))
REPEATS = 7


def _interior(cells):
    return cells[~cells["is_border"].to_numpy(bool) & (cells["n_sides"].to_numpy() > 0)]


def _abs6(cells, prefix=""):
    return np.hypot(cells[f"{prefix}gamma6_re"], cells[f"{prefix}gamma6_im"]).to_numpy()


def tilted(tilt):
    rows = {k: [] for k in ("area", "flat_area", "g6", "flat_g6", "area_vs_imaged", "g6_vs_imaged")}
    for seed in SEEDS:
        t = tilted_plane_tissue(tilt, shape=(240, 320), spacing=24, seed=seed)
        c = _interior(analyze(t.labels, surface=t.height, workers=1, progress=False).cells)
        c = c.merge(t.truth, on="cell", suffixes=("", "_true"))
        g6 = np.hypot(c["gamma6_re_true"], c["gamma6_im_true"]).to_numpy()
        rows["area"].append(np.abs(c["surface_area"] / c["area_true"] - 1))
        rows["flat_area"].append(np.abs(c["polygon_area"] / c["area_true"] - 1))
        rows["g6"].append(np.abs(_abs6(c, "surface_") - g6))
        rows["flat_g6"].append(np.abs(_abs6(c) - g6))
        imaged = _interior(analyze(t.flat_labels, workers=1, progress=False).cells)
        both = c.merge(imaged[["cell", "polygon_area", "gamma6_re", "gamma6_im"]], on="cell",
                       suffixes=("", "_imaged"))
        rows["area_vs_imaged"].append(np.abs(both["surface_area"] / both["polygon_area_imaged"] - 1))
        rows["g6_vs_imaged"].append(np.abs(_abs6(both, "surface_") - np.hypot(both["gamma6_re_imaged"],
                                                                             both["gamma6_im_imaged"])))
    return {k: np.concatenate(v) for k, v in rows.items()}


FIELD_TILTS = (30, 50, 70)


def _field_defects(defects, p):
    d = defects[defects["p"] == p]
    return set(map(tuple, np.round(d[["x", "y", "charge"]].to_numpy(), 6)))


def tilted_field(tilt):
    """|Gamma_6| errors (surface, projected) at the valid nodes and the truth's defects found, pooled over seeds."""
    cos = np.cos(np.radians(tilt))
    out = {"surface": [], "projected": [], "surface_complex": [], "truth": [],
           **{f"{kind}{p}": 0 for kind in ("truth", "surface", "projected") for p in (6, 2)}}
    for seed in SEEDS:
        t = tilted_plane_tissue(tilt, shape=(240, 320), spacing=24, seed=seed)
        movie = analyze(t.labels, surface=t.height, workers=1, progress=False)
        grid = movie.grid
        step, radius = float(grid["spacing"].iloc[0]), float(grid["radius"].iloc[0])
        layout = dict(radius=radius, spacing=step, r_cell=step,
                      origin=(float(grid["x"].min()), float(grid["y"].min())),
                      shape=(int(grid["row"].max()) + 1, int(grid["col"].max()) + 1))
        flat = analyze(t.flat_labels, workers=1, progress=False).cells.copy()
        flat["y"] *= cos
        truth = coarse_grain(flat, p=(6, 2), **layout)
        projected = analyze(t.labels, workers=1, progress=False, order=OrderOptions(**layout)).grid
        valid = grid["valid"].to_numpy() & truth["valid"].to_numpy()
        ref = (truth["Gamma6_re"] + 1j * truth["Gamma6_im"]).to_numpy()[valid]
        surf = (grid["Gamma6_re"] + 1j * grid["Gamma6_im"]).to_numpy()[valid]
        proj = (projected["Gamma6_re"] + 1j * projected["Gamma6_im"]).to_numpy()[valid]
        out["surface"].append(np.abs(np.abs(surf) - np.abs(ref)))
        out["projected"].append(np.abs(np.abs(proj) - np.abs(ref)))
        out["surface_complex"].append(np.abs(surf - ref))
        out["truth"].append(np.abs(ref))
        found = {"truth": find_defects(truth, p=(6, 2)), "surface": movie.defects,
                 "projected": find_defects(projected, p=(6, 2))}
        for p in (6, 2):
            expected = _field_defects(found["truth"], p)
            out[f"truth{p}"] += len(expected)
            for kind in ("surface", "projected"):
                out[f"{kind}{p}"] += len(_field_defects(found[kind], p) & expected)
    return {k: (np.concatenate(v) if isinstance(v, list) else v) for k, v in out.items()}


def bump(amplitude, width):
    errors, exact, chords, floor, flat = [], [], [], [], []
    for seed in SEEDS:
        b = gaussian_bump_tissue(shape=(256, 256), amplitude=amplitude, width=width, spacing=24, seed=seed)
        polygons = voronoi_polygons(b.seeds, b.labels.shape)
        xy, starts = pack_polygons([polygons[k] for k in b.truth["cell"]])
        lifted = surface_arrays(xy, starts, np.arange(len(starts)), b.height)["surface_area"]
        exact.append(lifted / b.truth["area"].to_numpy() - 1)
        # the same fan over the sides' chords alone (no lifted midpoints)
        xyz = lift(b.height, xy)
        apex = lift(b.height, segment_sum(xy, starts, len(starts)) / np.diff(np.r_[starts, len(xy)])[:, None])
        fan = _fan_area(xyz, starts, apex, tangent_polygons(xyz, starts)["normal"])
        chords.append(fan / b.truth["area"].to_numpy() - 1)
        c = _interior(analyze(b.labels, surface=b.height, workers=1, progress=False).cells)
        c = c.merge(b.truth, on="cell", suffixes=("", "_true"))
        errors.append((c["surface_area"] / c["area_true"] - 1).to_numpy())
        projected = np.array([0.5 * abs(float(np.dot(q[:, 0], np.roll(q[:, 1], -1))
                                              - np.dot(np.roll(q[:, 0], -1), q[:, 1])))
                              for q in (polygons[k] for k in c["cell"])])
        floor.append(c["polygon_area"].to_numpy() / projected - 1)
        flat.append((c["polygon_area"] / c["area_true"] - 1).to_numpy())
    return {k: np.concatenate(v) for k, v in (("analysed", errors), ("exact", exact), ("chords", chords),
                                               ("floor", floor), ("flat", flat))}


def cost():
    labels = voronoi_labels(jittered_seeds((2048, 2048), 20, seed=0), (2048, 2048))
    height = np.random.default_rng(0).random(labels.shape) * 20
    f = mesh_from_labels(labels)
    polygons = f.mesh_polygons()
    take = polygon_rows(f.cells["n_sides"].to_numpy() > 0)
    surface_arrays(*polygons, take, height)  # compiled (or read from numba's cache) first
    runs = {"with": {"surface": height}, "without": {}}
    times = {name: [] for name in ("mesh", "surface", "reference", *runs)}
    for _ in range(REPEATS):  # the codes alternate, so a change of the machine's load reaches both
        times["mesh"].append(_seconds(lambda: mesh_from_labels(labels)))
        times["surface"].append(_seconds(lambda: surface_arrays(*polygons, take, height)))
        with references("reference"):  # the kernel's plain-numpy reference in its place
            times["reference"].append(_seconds(lambda: surface_arrays(*polygons, take, height)))
        for name, given in runs.items():
            times[name].append(_seconds(lambda: analyze(labels, workers=1, progress=False, **given)))
    return len(f.cells), {name: min(values) for name, values in times.items()}


def _seconds(call):
    t0 = time.perf_counter()
    call()
    return time.perf_counter() - t0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "results_surface.md"))
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0]
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = ["# Cells on a height map against exact curved tissues (`bench_surface.py`)", "",
             f"{stamp}, {platform.machine()} with {os.cpu_count()} cores (shared), Python "
             f"{platform.python_version()}, numpy {np.__version__}; 1-minute load {load_before:.1f} before the run. "
             "Command: `NUMBA_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_surface.py`. Tissues and "
             f"method: the script's docstring; {len(SEEDS)} seeds per tissue, interior cells pooled.", "",
             "## Tilted plane (240 x 320 px flat tissue, cells 24 px apart)", "",
             "| tilt | cells | area error, surface | area error, flat analysis | \\|\\|γ6\\| error\\|, surface | "
             "\\|\\|γ6\\| error\\|, flat analysis | surface against the tissue imaged flat: area, \\|γ6\\| |",
             "|---|---|---|---|---|---|---|"]
    for tilt in TILTS:
        r = tilted(tilt)
        lines.append(f"| {tilt}° | {len(r['area'])} | {np.median(r['area']):.2%} (max {r['area'].max():.1%}) | "
                     f"{np.median(r['flat_area']):.2%} | {np.median(r['g6']):.3f} | {np.median(r['flat_g6']):.3f} | "
                     f"{np.median(r['area_vs_imaged']):.2%}, {np.median(r['g6_vs_imaged']):.3f} |")
    lines += ["", "Errors against the flat tissue's exact polygons (medians); goal at 50°: area <= 2 %, "
              "\\|γ6\\| <= 0.05.", "",
              "## The field Γ_6 on the tilted plane", "",
              "| tilt | nodes | median \\|Γ6\\| of the truth | median \\|\\|Γ6\\| error\\|, surface | "
              "median \\|Γ6 error\\| (complex), surface | median \\|\\|Γ6\\| error\\|, flat analysis of the "
              "projection | defects of the truth found, p = 6: surface, projection | p = 2: surface, projection |",
              "|---|---|---|---|---|---|---|---|"]
    for tilt in FIELD_TILTS:
        r = tilted_field(tilt)
        lines.append(f"| {tilt}° | {len(r['surface'])} | {np.median(r['truth']):.3f} | "
                     f"{np.median(r['surface']):.3f} | {np.median(r['surface_complex']):.3f} | "
                     f"{np.median(r['projected']):.3f} | {r['surface6']} / {r['truth6']}, {r['projected6']} / "
                     f"{r['truth6']} | {r['surface2']} / {r['truth2']}, {r['projected2']} / {r['truth2']} |")
    lines += ["", "The truth: the tissue imaged flat, its cells coarse-grained on the surface grid's nodes and disks "
              "(centroids squeezed by cos(tilt) into the image); valid nodes of both, 5 seeds pooled. A defect is "
              "found when the same plaquette has the same charge.", "",
              "## Gaussian bump (256 x 256 px, cells 24 px apart)", "",
              "| h, s (px) | cells | area error, analysed: median \\|e\\|, median e, max \\|e\\| | "
              "exact vertices lifted: median \\|e\\|, max \\|e\\| | the same, the sides' chords alone (no "
              "lifted midpoints): median \\|e\\|, max \\|e\\| | pixel floor: the network's polygon_area on "
              "the projected cells, median \\|e\\| | flat analysis: median \\|e\\| |",
              "|---|---|---|---|---|---|---|"]
    for h, s in BUMPS:
        r = bump(h, s)
        a, e = r["analysed"], r["exact"]
        lines.append(f"| {h:g}, {s:g} | {len(a)} | {np.median(np.abs(a)):.2%}, {np.median(a):+.2%}, "
                     f"{np.abs(a).max():.1%} | {np.median(np.abs(e)):.2%}, {np.abs(e).max():.2%} | "
                     f"{np.median(np.abs(r['chords'])):.2%}, {np.abs(r['chords']).max():.2%} | "
                     f"{np.median(np.abs(r['floor'])):.2%} | {np.median(np.abs(r['flat'])):.1%} |")
    n_cells, best = cost()
    lines += ["", "Goal: areas within 1 %.", "", "## Cost", "",
              f"2048 x 2048 px, {n_cells} cells, one core, best of {REPEATS} alternating runs: the junction network "
              f"(`mesh_from_labels`) {best['mesh']:.3f} s, the surface columns (`surface_arrays`: its numba pass and "
              f"gamma_p) {best['surface']:.3f} s ({best['reference']:.3f} s with the kernel's numpy reference); a whole `analyze` of the frame {best['without']:.2f} s without "
              f"the surface stage, {best['with']:.2f} s with it (and with Γ_p and its defects on the surface, "
              "on this random height map).", "",
              f"1-minute load {os.getloadavg()[0]:.1f} after the run.", ""]
    text = "\n".join(lines)
    print(text)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
