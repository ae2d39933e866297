"""Speed of coarse-graining, defect finding, defect tracking and MPF cell stresses.

    python benchmarks/bench_order.py

Prints the median of repeated runs; results with machine, date and load go to
benchmarks/results_order.md.
"""
from __future__ import annotations

import os
import platform
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _timing import median_time  # noqa: E402  (benchmarks/_timing.py)
from hexatissue import Box  # noqa: E402
from hexatissue.defects import defect_events, find_defects, track_defects  # noqa: E402
from hexatissue.order import coarse_grain  # noqa: E402
from hexatissue.simulate.stress import cell_stress  # noqa: E402




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


def main():
    print(f"python {platform.python_version()}, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cpus, load {os.getloadavg()}")
    for n_side in (50, 100, 200):
        cells, box = random_cells(n_side)
        t_per = median_time(lambda: coarse_grain(cells, box=box))
        t_open = median_time(lambda: coarse_grain(cells))
        grid = coarse_grain(cells, box=box)
        t_def = median_time(lambda: find_defects(grid, box=box))
        print(f"coarse_grain {n_side**2:6d} cells ({len(grid)} nodes): periodic {t_per * 1e3:7.1f} ms, "
              f"open {t_open * 1e3:7.1f} ms; find_defects {t_def * 1e3:6.1f} ms")
    defects, box = random_walk_defects()
    t_track = median_time(lambda: track_defects(defects, max_distance=4.0, box=box), repeats=3)
    tracked = track_defects(defects, max_distance=4.0, box=box)
    t_events = median_time(lambda: defect_events(tracked, pair_distance=8.0, box=box), repeats=3)
    print(f"track_defects {len(defects)} defects ({defects['frame'].nunique()} frames x 200): "
          f"{t_track * 1e3:.0f} ms; defect_events {t_events * 1e3:.0f} ms; {tracked['track'].nunique()} tracks")
    rng = np.random.default_rng(2)
    phi = rng.random((440, 41, 41)).astype(np.float64)
    theta = rng.uniform(0, np.pi, 440)
    for p in (2, 6):
        t = median_time(lambda: cell_stress(phi, theta, 1.0, p))
        print(f"cell_stress 440 cells x 41 x 41, p={p}: {t * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
