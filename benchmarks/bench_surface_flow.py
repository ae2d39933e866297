"""The tissue flow on a height map's surface against exact moving tissues: speeds on tilted planes, the areal rate
on a growing bump, and the cost of the surface fits.

Tissues (:mod:`hexatissue.synthetic_surface`), 5 seeds each, analysed with ``analyze(labels, surface=height)``:

- a flat Voronoi tissue (240 x 320 px in its own plane, cells 24 px apart) translating at 1 px/frame up a plane
  tilted by 30, 50 and 70 degrees about x (``tilted_plane_movie``, 5 frames): each interior cell's speed on the
  surface ``|(surface_vx, surface_vy)|`` against 1, beside the projected speed ``|(vx, vy)|`` (cos of the tilt), and
  the grid's fitted speed and areal rate (zero for a translation);
- Voronoi cells of the (x, y) plane fixed on a Gaussian bump z = h (1 + 0.05 t) exp(-r^2/2s^2), h = 60 px,
  s = 45 px, 160 x 160 px, cells 12 px apart (``bump_movie``, 5 frames): nothing moves in the image, the cells'
  surface areas grow; the analytic rate of the area element d log sqrt(1 + |grad z|^2)/dt at each valid node
  against ``flow.areal_rate``, against the sum ``surface_divergence - 2 mean_curvature vn`` of the three fits, and
  against the rate of the summed ``surface_area`` of the cells in the node's disk; the cells' own ``surface_area``
  rate (centred differences) against the analytic rate at their centroids; at ``radius_factor`` 1.5 and 2 (the
  default), and with cells 16 px apart on a 192 x 192 px image.

Errors are pooled over the seeds (medians); rates relative to the median analytic rate.  The cost: the surface
velocities and fits (``surface_velocities``, ``surface_flow_fields``) against the flat ones (``cell_velocities``,
``flow_fields``) on a 512 x 512 px bump movie of 10 frames (best of 7 alternating runs, one core).

    NUMBA_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_surface_flow.py [--out benchmarks/results_surface_flow.md]
"""
import argparse
import datetime
import os
import platform
import time
import warnings
from pathlib import Path

import numpy as np

from hexatissue import FlowOptions, analyze
from hexatissue.flow import area_rates, cell_velocities, flow_fields, surface_flow_fields, surface_velocities
from hexatissue.synthetic_surface import bump_movie, tilted_plane_movie

SEEDS = range(5)
TILTS = (30, 50, 70)
BUMPS = ((12.0, 160, 1.5), (12.0, 160, 2.0), (16.0, 192, 1.5))
H0, GROWTH, WIDTH = 60.0, 0.05, 45.0
REPEATS = 7


def _analyze(labels, height, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return analyze(labels, surface=height, workers=1, progress=False, **options)


def tilted(tilt):
    out = {k: [] for k in ("speed", "projected", "node_speed", "areal", "vn")}
    for seed in SEEDS:
        movie = tilted_plane_movie(tilt, n_frames=5, velocity=(0.0, 1.0), shape=(240, 320), seed=seed)
        result = _analyze(movie.labels, movie.height)
        cells = result.cells[~result.cells["is_border"] & np.isfinite(result.cells["surface_vx"])]
        out["speed"].append(np.hypot(cells["surface_vx"], cells["surface_vy"]).to_numpy())
        out["projected"].append(np.hypot(cells["vx"], cells["vy"]).to_numpy())
        out["vn"].append(np.abs(cells["vn"]).to_numpy())
        flow = result.flow[result.flow["valid"] & np.isfinite(result.flow["areal_rate"])]
        out["node_speed"].append(np.hypot(flow["surface_vx"], flow["surface_vy"]).to_numpy())
        out["areal"].append(np.abs(flow["areal_rate"]).to_numpy())
    return {k: np.concatenate(v) for k, v in out.items()}


def area_element_rate(x, y, t, centre):
    """d log sqrt(1 + |grad z|^2) / dt of z = H0 (1 + GROWTH t) g, g = exp(-r^2 / 2 WIDTH^2)."""
    r2 = (x - centre) ** 2 + (y - centre) ** 2
    q = np.exp(-r2 / WIDTH ** 2) * r2 / WIDTH ** 4  # |grad g|^2
    h = H0 * (1 + GROWTH * t)
    return h * H0 * GROWTH * q / (1 + h * h * q)


def bump(spacing, size, radius_factor):
    out = {k: [] for k in ("areal", "sum", "regional", "cells", "truth", "cell_truth", "flat", "radius")}
    centre = (size - 1) / 2
    for seed in SEEDS:
        movie = bump_movie(5, amplitude=H0, growth=GROWTH, width=WIDTH, shape=(size, size), spacing=spacing,
                           seed=seed, subdivisions=2)
        result = _analyze(movie.labels, movie.height, flow=FlowOptions(radius_factor=radius_factor))
        cells = result.cells.sort_values(["track", "frame"]).reset_index(drop=True)
        rate = area_rates(cells)
        area, frame = cells["surface_area"].to_numpy(), cells["frame"].to_numpy()
        inner = ~cells["is_border"].to_numpy() & np.isfinite(rate)
        out["cells"].append(rate[inner])
        out["cell_truth"].append(area_element_rate(cells["x"], cells["y"], cells["frame"], centre).to_numpy()[inner])
        flow = result.flow[result.flow["valid"] & np.isfinite(result.flow["areal_rate"])]
        out["truth"].append(area_element_rate(flow["x"], flow["y"], flow["frame"], centre).to_numpy())
        out["areal"].append(flow["areal_rate"].to_numpy())
        out["sum"].append((flow["surface_divergence"] - 2 * flow["mean_curvature"] * flow["vn"]).to_numpy())
        out["flat"].append(np.abs(flow["divergence"]).to_numpy())
        out["radius"].append(flow["radius"].to_numpy())
        for t, nodes in flow.groupby("frame"):
            here = inner & (frame == t)
            xy, a, r = cells.loc[here, ["x", "y"]].to_numpy(), area[here], rate[here]
            for x, y, radius, areal in nodes[["x", "y", "radius", "areal_rate"]].itertuples(index=False):
                near = np.hypot(xy[:, 0] - x, xy[:, 1] - y) <= radius
                out["regional"].append([areal - (a[near] * r[near]).sum() / a[near].sum() if near.sum() >= 3
                                        else np.nan])
    return {k: np.concatenate(v) for k, v in out.items()}


def cost():
    movie = bump_movie(10, amplitude=150.0, growth=0.02, width=120.0, drift=(0.5, 0.2), shape=(512, 512),
                       spacing=12.0, subdivisions=1)
    result = _analyze(movie.labels, movie.height)
    cells, grid = result.cells, result.grid

    def flat():
        vx, vy = cell_velocities(cells)
        flow_fields(cells.assign(vx=vx, vy=vy), grid)

    def surface():
        velocities = surface_velocities(cells)
        surface_flow_fields(cells.assign(vx=velocities["vx"], vy=velocities["vy"], vz=velocities["vz"]), grid)

    flat(), surface()  # compiled (or read from numba's cache) first
    times = {"flat": [], "surface": []}
    for _ in range(REPEATS):  # alternating, so a change of the machine's load reaches both
        for name, call in (("flat", flat), ("surface", surface)):
            t0 = time.perf_counter()
            call()
            times[name].append(time.perf_counter() - t0)
    return len(cells), len(grid), {name: min(values) for name, values in times.items()}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "results_surface_flow.md"))
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0]
    lines = ["# The tissue flow on a height map's surface against exact moving tissues (`bench_surface_flow.py`)", "",
             f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.machine()} with "
             f"{os.cpu_count()} cores (shared), Python {platform.python_version()}, numpy {np.__version__}; 1-minute "
             f"load {load_before:.1f} before the run. Command: `NUMBA_NUM_THREADS=1 PYTHONPATH=$PWD python "
             "benchmarks/bench_surface_flow.py`. Tissues and method: the script's docstring; 5 seeds per tissue, "
             "pooled.", "",
             "## A tissue translating on a tilted plane (1 px/frame up the slope, 5 frames)", "",
             "| tilt | cells | speed on the surface: median \\|s - 1\\|, mean s | projected speed: median (cos of the "
             "tilt) | nodes | grid speed: median \\|s - 1\\| | areal rate: median \\|.\\| (1/frame) | \\|vn\\|: median, "
             "max (px/frame) |",
             "|---|---|---|---|---|---|---|---|"]
    for tilt in TILTS:
        r = tilted(tilt)
        lines.append(f"| {tilt}° | {len(r['speed'])} | {np.median(np.abs(r['speed'] - 1)):.1%}, "
                     f"{r['speed'].mean():.3f} | {np.median(r['projected']):.3f} ({np.cos(np.radians(tilt)):.3f}) | "
                     f"{len(r['node_speed'])} | {np.median(np.abs(r['node_speed'] - 1)):.1%} | "
                     f"{np.median(r['areal']):.1e} | {np.median(r['vn']):.0e}, {r['vn'].max():.0e} |")
    lines += ["", "## Cells fixed on a growing bump (h = 60 px growing 5 % a frame, s = 45 px, 5 frames)", "",
              "| cells apart (px), image (px), radius_factor | fit radius (px) | cells: their surface_area rate "
              "against the analytic rate | nodes | median analytic rate (1/frame) | areal_rate: median, 90th "
              "percentile | surface_divergence - 2 H vn | against the cells' summed surface area in the disk | flat "
              "divergence: max \\|.\\| |",
              "|---|---|---|---|---|---|---|---|---|"]
    for spacing, size, factor in BUMPS:
        r = bump(spacing, size, factor)
        scale = np.median(r["truth"])
        error = np.abs(r["areal"] - r["truth"]) / scale
        lines.append(f"| {spacing:g}, {size}, {factor:g} | {np.median(r['radius']):.1f} | "
                     f"{np.median(np.abs(r['cells'] - r['cell_truth'])) / np.median(r['cell_truth']):.1%} | "
                     f"{len(r['areal'])} | {scale:.2e} | {np.median(error):.1%}, {np.percentile(error, 90):.1%} | "
                     f"{np.median(np.abs(r['sum'] - r['truth'])) / scale:.1%} | "
                     f"{np.nanmedian(np.abs(r['regional'])) / scale:.1%} | {r['flat'].max():.0e} |")
    n_cells, n_nodes, best = cost()
    lines += ["", "Rates relative to the median analytic rate; the error of the grid's fits falls with the fit's "
              "radius against the bump's width.", "", "## Cost", "",
              f"A 512 x 512 px bump movie of 10 frames ({n_cells} cells, {n_nodes} nodes), one core, best of "
              f"{REPEATS} alternating runs: the flat velocities and fits (`cell_velocities`, `flow_fields`) "
              f"{best['flat']:.3f} s, the surface ones (`surface_velocities`, `surface_flow_fields`: five affine "
              f"fits of two columns each against one) {best['surface']:.3f} s.", "",
              f"1-minute load {os.getloadavg()[0]:.1f} after the run.", ""]
    text = "\n".join(lines)
    print(text)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
