"""Speed of the Fig. 3e-g analyses at the paper's scale (440 cells, 2001 frames), on synthetic tables.

Random-walk cells in the paper's 384 x 403 periodic box, 12 defects and 10 T1 events per frame.
Prints the median of ``--repeats`` wall times per analysis.  Run: ``python benchmarks/bench_analysis.py``.
"""
import argparse

import numpy as np
import pandas as pd

from _timing import median_time  # benchmarks/_timing.py (the script's own folder is on sys.path)
from hexatissue.analysis import cell_timing, migration_populations, migration_table, t1_defect_proximity
from hexatissue.box import Box


def tables(n_cells=440, n_frames=2001, n_defects=12, n_events=10, seed=0):
    rng = np.random.default_rng(seed)
    box = Box(384.0, 403.0)
    xy = rng.uniform(0, 1, (1, n_cells, 2)) * box.lengths + np.cumsum(rng.normal(0, 0.3, (n_frames, n_cells, 2)), 0)
    xy = box.wrap(xy)
    cells = pd.DataFrame({"frame": np.repeat(np.arange(n_frames), n_cells), "cell": np.tile(np.arange(1, n_cells + 1),
                                                                                           n_frames)})
    cells["track"], cells["x"], cells["y"] = cells["cell"], xy[..., 0].ravel(), xy[..., 1].ravel()
    d = rng.uniform(0, 1, (n_frames * n_defects, 2)) * box.lengths
    defects = pd.DataFrame({"frame": np.repeat(np.arange(n_frames), n_defects),
                            "defect": np.tile(np.arange(n_defects), n_frames), "x": d[:, 0], "y": d[:, 1],
                            "charge": np.tile([1 / 6, -1 / 6], n_frames * n_defects // 2), "p": 6})
    n = n_frames * n_events
    quartets = rng.integers(1, n_cells + 1, (n, 4))
    events = pd.DataFrame({"event": np.arange(n), "kind": rng.choice(["cycle", "intercalation"], n),
                           "frame_start": np.repeat(np.arange(n_frames), n_events), "cell_a": quartets[:, 0],
                           "cell_b": quartets[:, 1], "cell_c": quartets[:, 2], "cell_d": quartets[:, 3],
                           "x": rng.uniform(0, 384, n), "y": rng.uniform(0, 403, n)})
    events["duration"] = np.where(events["kind"] == "cycle", rng.integers(1, 20, n), np.nan).astype(float)
    return cells, defects, events, box




def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cells, defects, events, box = tables()
    print(f"{len(cells)} cell rows, {len(defects)} defects, {len(events)} events")
    table = migration_table(cells, defects, dl=35, dt=50, box=box, events=events)
    runs = {
        "t1_defect_proximity (n_control=5)": lambda: t1_defect_proximity(events, cells, defects, box=box),
        "migration_table (dl=35, dt=50)": lambda: migration_table(cells, defects, dl=35, dt=50, box=box,
                                                                  events=events),
        "migration_populations": lambda: migration_populations(table),
        "cell_timing": lambda: cell_timing(events, cells),
    }
    for name, fn in runs.items():
        print(f"{name}: {median_time(fn, args.repeats):.2f} s (median of {args.repeats})")


if __name__ == "__main__":
    main()
