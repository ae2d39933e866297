"""Benchmark: junction network + gamma6 of a 2048 x 2048 periodic Voronoi label image (~10,000 cells).

Compares, in the same run and on one core, hexatissue.mesh_from_labels with the per-cell
scikit-image route people use today (regionprops, then find_contours and approximate_polygon per
cell, then gamma6 of that polygon).  Peak memory is the peak resident set size of a fresh process
running each route once (the kernel's high-water mark, reset before the run), minus its size just
before (numba allocations are invisible to tracemalloc); the label image itself (16 MB as int32) is
not included.  CPU times (process time)
are printed beside wall times: on a shared machine they are the steadier figure.

With ``--against TREE`` (another checkout, e.g. a worktree of main) the route of that tree's
package runs in the same process, calls alternating with this tree's, and the medians and the
per-pair CPU ratio are added: on a shared machine whose speed drifts from minute to minute this is
the steadiest comparison.

Run:  python benchmarks/bench_mesh.py [--size 2048] [--spacing 20.5] [--repeats 5] [--against TREE]
"""
import argparse
import importlib
import json
import os
import platform
import shutil
import subprocess
import tempfile
import sys
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))


def make_labels(size, spacing):
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    seeds = jittered_seeds((size, size), spacing, seed=0)
    return voronoi_labels(seeds, (size, size), periodic=True)


def hexatissue_route(labels, package=None):
    """gamma6 of every cell by ``shape_order(mesh_from_labels(labels, box), p=6)`` of ``package`` (default this tree's)."""
    ht = package or importlib.import_module("hexatissue")
    frame = ht.shape_order(ht.mesh_from_labels(labels, box=ht.Box.from_shape(labels.shape)), p=6)
    return frame.cells["gamma6_re"].to_numpy() + 1j * frame.cells["gamma6_im"].to_numpy()


def import_other_tree(tree):
    """The ``hexatissue`` package of another checkout, imported beside this one as ``hexatissue_base``.

    A copy under that name (its modules import each other relatively; the few absolute
    ``hexatissue`` imports, outside the mesh route, get this tree's modules).
    """
    where = tempfile.mkdtemp()
    shutil.copytree(os.path.join(tree, "hexatissue"), os.path.join(where, "hexatissue_base"),
                    ignore=shutil.ignore_patterns("__pycache__"))
    sys.path.insert(0, where)
    return importlib.import_module("hexatissue_base")


def alternate(labels, other, repeats):
    """CPU seconds of this tree's route and of ``other``'s, calls alternating; medians and per-pair ratio."""
    hexatissue_route(labels, other)  # compile the other tree's kernels
    mine, theirs = [], []
    for _ in range(repeats):
        for package, out in ((other, theirs), (None, mine)):
            c = time.process_time()
            hexatissue_route(labels, package)
            out.append(time.process_time() - c)
    mine, theirs = np.array(mine), np.array(theirs)
    return {"against_cpu_s_median": float(np.median(theirs)), "this_cpu_s_median": float(np.median(mine)),
            "cpu_ratio_this_over_against": float(np.median(mine / theirs))}


def skimage_route(labels):
    from skimage.measure import approximate_polygon, find_contours, regionprops

    from hexatissue import shape_function

    polygons = []
    for region in regionprops(labels):
        contour = find_contours(np.pad(region.image, 1).astype(float), 0.5)[0]
        polygons.append(approximate_polygon(contour, tolerance=1.0)[:-1, ::-1])  # (row, col) -> (x, y)
    return shape_function(polygons, p=6)


def peak_rss_mb(route, labels_path):
    """Run one route in a fresh process: its peak RSS during the run minus the RSS before the run (MB).

    The peak is the kernel's high-water mark (VmHWM), reset just before the run: ``ru_maxrss``
    cannot be used, as a process started from a large parent inherits the parent's resident size
    as its ``ru_maxrss`` across exec (it printed 131 MB here after the other routes had run in the
    parent, against 60 MB run from a small parent).
    """
    code = (
        "import sys, numpy as np, psutil; sys.path.insert(0, %r);"
        "import bench_mesh as b; labels = np.load(%r);"
        "b.%s(np.ascontiguousarray(labels[:256, :256]));"
        "base = psutil.Process().memory_info().rss; b.reset_peak_rss(); b.%s(labels);"
        "print((b.peak_rss() - base) / 2**20)"
    ) % (os.path.dirname(os.path.abspath(__file__)), str(labels_path), route, route)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def reset_peak_rss():
    """Reset this process's peak resident size to its current size (Linux >= 4.0)."""
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def peak_rss():
    """Peak resident size of this process since the last :func:`reset_peak_rss` (bytes)."""
    with open("/proc/self/status") as f:
        line = next(line for line in f if line.startswith("VmHWM:"))
    return int(line.split()[1]) * 1024


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=2048)
    parser.add_argument("--spacing", type=float, default=20.5, help="seed lattice pitch, px (20.5 -> ~10,000 cells)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--against", help="another checkout whose route runs alternately in this process")
    args = parser.parse_args()

    labels = make_labels(args.size, args.spacing)
    labels_path = os.path.join(tempfile.mkdtemp(), "labels.npy")
    np.save(labels_path, labels)
    hexatissue_route(make_labels(256, args.spacing))  # compile / load the numba cache
    times, cpu = [], []
    for _ in range(args.repeats):
        t, c = time.perf_counter(), time.process_time()
        g6 = hexatissue_route(labels)
        times.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    t, c = time.perf_counter(), time.process_time()
    g6_sk = skimage_route(labels)
    t_sk, cpu_sk = time.perf_counter() - t, time.process_time() - c
    rss = peak_rss_mb("hexatissue_route", labels_path)
    result = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.python_version()}",
        "load_1min": os.getloadavg()[0],
        "image": f"{args.size}x{args.size} periodic Voronoi, {labels.max()} cells",
        "hexatissue_s_median": float(np.median(times)),
        "hexatissue_s_min": float(np.min(times)),
        "skimage_per_cell_s": t_sk,
        "speedup_vs_median": t_sk / float(np.median(times)),
        # CPU time of this process: less disturbed than wall time when other jobs share the cores
        "hexatissue_cpu_s_median": float(np.median(cpu)),
        "skimage_per_cell_cpu_s": cpu_sk,
        "speedup_cpu": cpu_sk / float(np.median(cpu)),
        "hexatissue_peak_rss_mb": rss,
        "hexatissue_peak_bytes_per_px": rss * 2**20 / labels.size,
        "skimage_peak_rss_mb": peak_rss_mb("skimage_route", labels_path),
        "mean_abs_gamma6": [float(np.nanmean(np.abs(g6))), float(np.nanmean(np.abs(g6_sk)))],
    }
    if args.against:
        result.update(against=args.against, **alternate(labels, import_other_tree(args.against), 3 * args.repeats))
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
