"""Speed of coarse-graining and defects: hexatissue against a port of the published scripts, in the same run.

    python benchmarks/bench_order.py [--repeats 5] [--port-repeats 2] [--before REV] [--skip-big] [--misc]

1. **MDCK, published conventions.**  The 63 MDCK images (6-68) of Armengol-Collado et al. 2023
   (``exp_#.dat``: x, y, gamma_2..6), p = 2..6, R = 1..9 x 21.5 px, the published 23 x 23 grid
   (x, y = k 500/23), empty disks kept as Gamma = 0.  hexatissue (``coarse_grain`` with every p and
   radius in one call, ``find_defects`` for every p, the image means) against
   ``benchmarks/published_port.py`` (a plain-Python port of the published algorithm, used only
   for comparison), interleaved; then every Gamma_p, every cell count, every defect and every
   image mean is compared.
2. **MDCK, hexatissue's own conventions** (R_cell per image, spacing R_cell, whole disk on the
   tissue): every p and radius per image, and ``order_vs_radius``; with ``--before REV`` also the
   implementation of git revision REV (one call per p and radius, as its API required), in the
   same run, and the results compared.
3. **2048 x 2048 open image, 152k cells**: ``mesh_from_labels``, ``shape_order``,
   ``coarse_grain(p=6)`` and ``find_defects``, interleaved.
4. ``--misc``: random periodic/open cells, defect tracking (the older rows of results_order.md).

Prints medians (and minima) of the repeats with the machine, date and ``uptime`` load; the
numbers go to benchmarks/results_order.md by hand.  Timings are never asserted.
"""
from __future__ import annotations

import argparse
import datetime
import importlib
import os
import platform
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import published_port as port  # noqa: E402  (benchmarks/published_port.py)
from _timing import REAL_DATA, median_time  # noqa: E402  (benchmarks/_timing.py)
from hexatissue import Box, mesh_from_labels, shape_order  # noqa: E402
from hexatissue.defects import defect_events, find_defects, track_defects  # noqa: E402
from hexatissue.order import cell_radius, coarse_grain, order_vs_radius  # noqa: E402

MDCK = REAL_DATA / "hexanematic_mdck"
IMAGES = range(6, 69)
ORDERS = port.ORDERS
FACTORS = tuple(range(1, 10))


def load():
    return os.getloadavg()[0]


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def mdck_cells():
    """One cells table of the 63 images from the published dat files (every cell interior)."""
    parts = []
    for image in IMAGES:
        data = np.loadtxt(MDCK / "dat" / f"exp_{image}.dat")
        table = {"frame": np.full(len(data), image, np.int64), "x": data[:, 0], "y": data[:, 1]}
        for k, p in enumerate(ORDERS):
            table[f"gamma{p}_re"], table[f"gamma{p}_im"] = data[:, 2 + 2 * k], data[:, 3 + 2 * k]
        parts.append(pd.DataFrame(table))
    return pd.concat(parts, ignore_index=True)


# ---------------------------------------------------------------------------- 1. published conventions

def hexatissue_published(cells):
    """Gamma_p, defects and image means with the published conventions."""
    radii = [f * port.R_CELL for f in FACTORS]
    grid = coarse_grain(cells, p=ORDERS, radius=radii, spacing=port.GRID_SIZE / port.GRID_NODES, origin=(0.0, 0.0),
                        shape=(port.GRID_NODES, port.GRID_NODES), r_cell=port.R_CELL, validity="all")
    defects = find_defects(grid, p=ORDERS)
    occupied = (grid["n_cells"].to_numpy() > 0).reshape(len(IMAGES), len(FACTORS), -1)
    n_occupied = np.maximum(occupied.sum(axis=2), 1)
    means = {}
    for p in ORDERS:
        size = np.hypot(grid[f"Gamma{p}_re"].to_numpy(), grid[f"Gamma{p}_im"].to_numpy()).reshape(occupied.shape)
        means[p] = np.where(occupied, size, 0.0).sum(axis=2) / n_occupied
    return grid, defects, means


def port_published():
    return [port.analyse_image(MDCK / "dat" / f"exp_{image}.dat", FACTORS) for image in IMAGES]


def compare_published(ours, theirs):
    grid, defects, means = ours
    n_nodes = port.GRID_NODES ** 2
    col, row = grid["col"].to_numpy()[:n_nodes], grid["row"].to_numpy()[:n_nodes]
    worst_gamma, worst_mean, count_diff, n_def, def_diff = 0.0, 0.0, 0, 0, 0
    by_group = {key: g for key, g in defects.groupby(["frame", "p", "radius"])}
    for a, (image, (fields, counts, found, pmeans)) in enumerate(zip(IMAGES, theirs)):
        for k, factor in enumerate(FACTORS):
            block = slice((a * len(FACTORS) + k) * n_nodes, (a * len(FACTORS) + k + 1) * n_nodes)
            count_diff += int((grid["n_cells"].to_numpy()[block] != np.array(counts[k])[col, row]).sum())
            for p in ORDERS:
                mine = grid[f"Gamma{p}_re"].to_numpy()[block] + 1j * grid[f"Gamma{p}_im"].to_numpy()[block]
                worst_gamma = max(worst_gamma, float(np.abs(mine - np.array(fields[p][k])[col, row]).max()))
                worst_mean = max(worst_mean, abs(means[p][a, k] - pmeans[(p, k)]))
                theirs_d = sorted(found[(p, k)])
                g = by_group.get((image, p, factor * port.R_CELL))
                mine_d = [] if g is None else sorted(zip(g["x"], g["y"], g["charge"]))
                n_def += len(theirs_d)
                same = len(mine_d) == len(theirs_d) and all(
                    np.allclose(u, v, rtol=0, atol=1e-9) for u, v in zip(mine_d, theirs_d))
                def_diff += 0 if same else 1
    return worst_gamma, worst_mean, count_diff, n_def, def_diff


def section_published(repeats, port_repeats):
    cells = mdck_cells()
    hexatissue_published(cells)  # warm-up: numba caches, imports
    t_hex, t_port, load_at = [], [], [load()]
    ours = theirs = None
    for _ in range(port_repeats):
        for _ in range(max(1, (repeats - 1) // port_repeats)):
            t, ours = timed(lambda: hexatissue_published(cells))
            t_hex.append(t)
        t, theirs = timed(port_published)
        t_port.append(t)
        load_at.append(load())
    t, ours = timed(lambda: hexatissue_published(cells))
    t_hex.append(t)
    worst_gamma, worst_mean, count_diff, n_def, def_diff = compare_published(ours, theirs)
    t_curve, curve = timed(lambda: order_vs_radius(cells, p=ORDERS, factors=FACTORS, r_cell=port.R_CELL,
                                                   spacing=port.GRID_SIZE / port.GRID_NODES, origin=(0.0, 0.0),
                                                   shape=(port.GRID_NODES, port.GRID_NODES), validity="occupied"))
    pmeans = np.array([[[theirs[a][3][(p, k)] for k in range(len(FACTORS))] for p in ORDERS]
                       for a in range(len(IMAGES))])
    worst_curve = float(np.abs(curve["abs_Gamma"].to_numpy() - pmeans.ravel()).max())
    print(f"[1] MDCK published conventions: {len(cells)} cells in {len(IMAGES)} images, p = {ORDERS}, "
          f"R = {FACTORS[0]}..{FACTORS[-1]} x {port.R_CELL} px, {port.GRID_NODES}^2 nodes; load {load_at}")
    print(f"    hexatissue (coarse_grain + find_defects + means): median {np.median(t_hex):.3f} s "
          f"(min {min(t_hex):.3f}, n = {len(t_hex)}: {', '.join(f'{t:.3f}' for t in t_hex)})")
    print(f"    published port: median {np.median(t_port):.1f} s ({', '.join(f'{t:.1f}' for t in t_port)})")
    print(f"    ratio of medians: {np.median(t_port) / np.median(t_hex):.0f}x")
    print(f"    max |Gamma_hexatissue - Gamma_port| = {worst_gamma:.2e}; cell counts differing: {count_diff}; "
          f"defect lists differing: {def_diff} of {len(IMAGES) * len(FACTORS) * len(ORDERS)} "
          f"({n_def} defects); max image-mean difference {worst_mean:.2e}")
    print(f"    order_vs_radius(validity='occupied') {t_curve:.3f} s; max |abs_Gamma - port mean| = {worst_curve:.2e}")


# ---------------------------------------------------------------------------- 2. hexatissue's conventions

def polygon_cells():
    """The 63 images from the published polygons (area and gamma_p from the polygons, as the tests use)."""
    import scipy.io

    from hexatissue.order import cells_from_polygons

    parts = []
    for image in IMAGES:
        polygon = scipy.io.loadmat(MDCK / "mat" / f"Image{image}_Polygon.mat", simplify_cells=True)["Polygon"]
        cells = cells_from_polygons(polygon["Vertex"], p=ORDERS, centers=polygon["CenterOfMass"])
        parts.append(cells.assign(frame=image))
    return pd.concat(parts, ignore_index=True)


def own_conventions(module_order, module_defects, cells, one_call):
    """Gamma_p (every p, R = 1..9 R_cell of each image) and defects on every image, default conventions."""
    grids, defects = [], []
    for image, group in cells.groupby("frame"):
        radii = [f * module_order.cell_radius(group) for f in FACTORS]
        if one_call:
            grid = module_order.coarse_grain(group, p=ORDERS, radius=radii)
            grids.append(grid)
            defects.append(module_defects.find_defects(grid, p=ORDERS))
            continue
        for p in ORDERS:
            for r in radii:
                grid = module_order.coarse_grain(group, p=p, radius=r)
                grids.append(grid)
                defects.append(module_defects.find_defects(grid, p=p))
    return grids, defects


def load_revision(rev):
    """The hexatissue package of git revision ``rev``, imported under another name from a temporary folder."""
    folder = Path(tempfile.mkdtemp(prefix="hexatissue_before_"))
    archive = subprocess.run(["git", "-C", str(HERE.parent), "archive", rev, "hexatissue"], check=True,
                             capture_output=True).stdout
    with tarfile.open(fileobj=__import__("io").BytesIO(archive)) as tar:
        tar.extractall(folder, filter="data")
    (folder / "hexatissue").rename(folder / "hexatissue_before")
    (folder / "hexatissue_before" / "box.py").write_text("from hexatissue.box import Box, as_box  # noqa: F401\n")
    sys.path.insert(0, str(folder))
    return (importlib.import_module("hexatissue_before.order"), importlib.import_module("hexatissue_before.defects"))


def section_own(repeats, before):
    import hexatissue.defects as new_defects
    import hexatissue.order as new_order

    cells = polygon_cells()
    own_conventions(new_order, new_defects, cells.query("frame == 6"), True)
    old = load_revision(before) if before else None
    t_new, t_old, t_curve, t_curve_old, load_at = [], [], [], [], [load()]
    for _ in range(repeats if old is None else max(1, repeats // 2)):
        t, new = timed(lambda: own_conventions(new_order, new_defects, cells, True))
        t_new.append(t)
        t, _ = timed(lambda: order_vs_radius(cells, p=ORDERS, factors=FACTORS))
        t_curve.append(t)
        if old is not None:
            t, previous = timed(lambda: own_conventions(*old, cells, False))
            t_old.append(t)
            t, curve_old = timed(lambda: pd.concat([old[0].order_vs_radius(cells, p=p, factors=FACTORS)
                                                    for p in ORDERS]))
            t_curve_old.append(t)
        load_at.append(load())
    print(f"[2] MDCK hexatissue conventions (R_cell per image, tissue validity), from the polygons; load {load_at}")
    print(f"    every p and R = 1..9 R_cell, one call per image: median {np.median(t_new):.3f} s "
          f"({', '.join(f'{t:.3f}' for t in t_new)}); order_vs_radius all p: median {np.median(t_curve):.3f} s")
    if old is None:
        return
    print(f"    revision {before}: one call per p and R: median {np.median(t_old):.1f} s "
          f"({', '.join(f'{t:.1f}' for t in t_old)}); order_vs_radius per p: {np.median(t_curve_old):.1f} s")
    print(f"    ratio {np.median(t_old) / np.median(t_new):.0f}x (fields + defects), "
          f"{np.median(t_curve_old) / np.median(t_curve):.0f}x (order_vs_radius)")
    grids, defects = new
    worst, flags = 0.0, 0
    # the old grids are one per (image, p, R), in the loop order of own_conventions
    for a, grid in enumerate(grids):
        n = len(grid) // len(FACTORS)
        for b, p in enumerate(ORDERS):
            for c in range(len(FACTORS)):
                og = previous[0][(a * len(ORDERS) + b) * len(FACTORS) + c]
                ng = grid.iloc[c * n:(c + 1) * n]
                for col in (f"Gamma{p}_re", f"Gamma{p}_im", "coverage"):
                    d = np.abs(ng[col].to_numpy() - og[col].to_numpy())
                    worst = max(worst, float(np.nanmax(d)) if np.isfinite(d).any() else 0.0)
                flags += int((ng["valid"].to_numpy() != og["valid"].to_numpy()).sum())
                flags += int((ng["n_cells"].to_numpy() != og["n_cells"].to_numpy()).sum())
    d_new = pd.concat(defects, ignore_index=True)
    d_old = pd.concat(previous[1], ignore_index=True)
    same_defects = len(d_new) == len(d_old) and np.allclose(
        np.sort(d_new[["x", "y", "charge"]].to_numpy(), axis=0), np.sort(d_old[["x", "y", "charge"]].to_numpy(), axis=0))
    keys = ["frame", "p", "factor"]
    curve_new = order_vs_radius(cells, p=ORDERS, factors=FACTORS).sort_values(keys, kind="stable")
    curve_old = curve_old.sort_values(keys, kind="stable")
    worst_curve = float(np.nanmax(np.abs(curve_new["abs_Gamma"].to_numpy() - curve_old["abs_Gamma"].to_numpy())))
    print(f"    same results: max |difference| of Gamma_p and coverage {worst:.1e}; valid / n_cells flags differing "
          f"{flags}; defects identical: {same_defects} ({len(d_new)}); order_vs_radius max difference {worst_curve:.1e}")


# ---------------------------------------------------------------------------- 3. large open image

def section_big(repeats):
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    labels = voronoi_labels(jittered_seeds((2048, 2048), 5.25, seed=0), (2048, 2048), periodic=False)
    shape_order(mesh_from_labels(labels[:256, :256]), p=6)
    frame = shape_order(mesh_from_labels(labels), p=6)
    grid = coarse_grain(frame.cells.iloc[:2000], p=6)
    find_defects(grid, p=6)
    times = {"mesh_from_labels": [], "shape_order": [], "coarse_grain": [], "find_defects": []}
    load_at = [load()]
    for _ in range(repeats):
        t, network = timed(lambda: mesh_from_labels(labels))
        times["mesh_from_labels"].append(t)
        t, frame = timed(lambda: shape_order(network, p=6))
        times["shape_order"].append(t)
        t, grid = timed(lambda: coarse_grain(frame.cells, p=6))
        times["coarse_grain"].append(t)
        t, defects = timed(lambda: find_defects(grid, p=6))
        times["find_defects"].append(t)
        load_at.append(load())
    cells = frame.cells
    print(f"[3] 2048 x 2048 open Voronoi image: {len(cells)} cells ({(~cells['is_border']).sum()} interior), "
          f"R_cell {cell_radius(cells):.2f} px, {len(grid)} nodes ({grid['valid'].sum()} valid), "
          f"{len(defects)} defects; load {[round(v, 2) for v in load_at]}")
    for name, values in times.items():
        print(f"    {name}: median {np.median(values):.3f} s (min {min(values):.3f}; "
              f"{', '.join(f'{t:.3f}' for t in values)})")
    fields = np.array(times["coarse_grain"]) + np.array(times["find_defects"])
    print(f"    coarse_grain + find_defects / mesh_from_labels, per repeat: "
          f"{', '.join(f'{r:.2f}' for r in fields / np.array(times['mesh_from_labels']))}")


# ---------------------------------------------------------------------------- 4. misc (older rows)

def random_cells(n_side, a=10.0, seed=0):
    rng = np.random.default_rng(seed)
    g = (np.arange(n_side) + 0.5) * a
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2) + rng.uniform(-0.3 * a, 0.3 * a, (n_side**2, 2))
    phase = rng.uniform(-np.pi, np.pi, len(xy))
    return pd.DataFrame({"x": xy[:, 0], "y": xy[:, 1], "area": a * a, "is_border": False,
                         "gamma6_re": 0.5 * np.cos(phase), "gamma6_im": 0.5 * np.sin(phase)}), Box(n_side * a, n_side * a)


def random_walk_defects(n_pairs=100, n_frames=100, size=500.0, step=1.0, seed=1):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, size, (2 * n_pairs, 2))
    charge = np.repeat([1 / 6, -1 / 6], n_pairs)
    rows = []
    for f in range(n_frames):
        xy = np.mod(xy + rng.normal(scale=step, size=xy.shape), size)
        rows.append(pd.DataFrame({"frame": f, "x": xy[:, 0], "y": xy[:, 1], "charge": charge}))
    return pd.concat(rows, ignore_index=True), Box(size, size)


def section_misc():
    print("[4] random cells and defect tracking")
    for n_side in (50, 100, 200):
        cells, box = random_cells(n_side)
        coarse_grain(cells, box=box)
        t_per = median_time(lambda: coarse_grain(cells, box=box))
        t_open = median_time(lambda: coarse_grain(cells))
        grid = coarse_grain(cells, box=box)
        t_def = median_time(lambda: find_defects(grid, box=box))
        print(f"    coarse_grain {n_side**2:6d} cells ({len(grid)} nodes): periodic {t_per * 1e3:7.1f} ms, "
              f"open {t_open * 1e3:7.1f} ms; find_defects {t_def * 1e3:6.1f} ms")
    defects, box = random_walk_defects()
    t_track = median_time(lambda: track_defects(defects, max_distance=4.0, box=box), repeats=3)
    tracked = track_defects(defects, max_distance=4.0, box=box)
    t_events = median_time(lambda: defect_events(tracked, pair_distance=8.0, box=box), repeats=3)
    print(f"    track_defects {len(defects)} defects ({defects['frame'].nunique()} frames x 200): "
          f"{t_track * 1e3:.0f} ms; defect_events {t_events * 1e3:.0f} ms; {tracked['track'].nunique()} tracks")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="hexatissue repeats (default 5)")
    parser.add_argument("--port-repeats", type=int, default=2, help="runs of the published port (default 2)")
    parser.add_argument("--before", default=None, help="git revision to compare against in section 2")
    parser.add_argument("--skip-big", action="store_true", help="skip the 2048^2 image")
    parser.add_argument("--misc", action="store_true", help="also the random-cell and tracking rows")
    parser.add_argument("--images", type=int, default=63, help="use the first N MDCK images only (quick check)")
    args = parser.parse_args()
    global IMAGES
    IMAGES = IMAGES[:args.images]
    print(f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC; python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} cpus; uptime: {subprocess.getoutput('uptime').strip()}")
    if MDCK.is_dir():
        section_published(args.repeats, args.port_repeats)
        section_own(args.repeats, args.before)
    else:
        print(f"MDCK data not found at {MDCK}: sections 1 and 2 skipped")
    if not args.skip_big:
        section_big(max(3, args.repeats // 2))
    if args.misc:
        section_misc()
    print(f"uptime at the end: {subprocess.getoutput('uptime').strip()}")


if __name__ == "__main__":
    main()
