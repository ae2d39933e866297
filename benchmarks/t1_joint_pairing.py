"""T1s of the joint loss/gain pairing against an older checkout's, on exact Voronoi contacts (issue 29).

Run from the repository root: ``python benchmarks/t1_joint_pairing.py --old ../main-at-c24d2a1``.  Both trees
detect the T1s of the same movies (60 cells x 40 frames as in ``tests/test_events.py``; 440 cells x 300 frames,
384 x 403 px, periodic) with ``min_length`` 0 and 2 px, each in its own process; the script prints the counts,
the old rows absent from the new output, and how many of those are the undo half of a cycle whose first half
only the new pairing finds.  Counts only, nothing timed.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
KEY = ["frame_start", "frame_gain", "cell_a", "cell_b", "cell_c", "cell_d"]
MOVIES = {"60 cells x 40 frames": (60, (110, 150), 40, 0.4, 2), "440 cells x 300 frames": (440, (384, 403), 300, 0.3, 0)}

DETECT = """
import sys, numpy as np, pandas as pd
from hexatissue.events import detect_t1
from hexatissue.synthetic import movie_contacts, voronoi_movie
n, shape, frames, amplitude, seed, ml, out = eval(sys.argv[1])
mov = voronoi_movie(n, shape, frames, periodic=True, amplitude=amplitude, seed=seed)
seeds = np.stack([mov.seeds(t) for t in range(len(mov))])
edges = movie_contacts(seeds, mov.shape[1:], True)
cells = pd.DataFrame({"frame": np.repeat(np.arange(len(mov)), len(mov.base)),
                      "cell": np.tile(np.arange(1, len(mov.base) + 1), len(mov)),
                      "x": seeds[..., 0].ravel(), "y": seeds[..., 1].ravel()})
detect_t1(edges, cells, box=mov.box, min_length=ml).to_csv(out, index=False)
"""


def detect(tree, movie, ml, out):
    env = {**os.environ, "PYTHONPATH": str(tree)}
    subprocess.run([sys.executable, "-c", DETECT, repr((*movie, ml, str(out)))], check=True, env=env, cwd=tree)
    return pd.read_csv(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, required=True, help="a checkout of the older code")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for name, movie in MOVIES.items():
            for ml in (0.0, 2.0):
                old = detect(args.old.resolve(), movie, ml, Path(tmp) / "old.csv")
                new = detect(ROOT, movie, ml, Path(tmp) / "new.csv")
                m = old.merge(new[KEY], on=KEY, how="left", indicator=True)
                gone = m[m["_merge"] == "left_only"]
                quartet = new[["cell_a", "cell_b", "cell_c", "cell_d"]].apply(frozenset, axis=1)
                undo = sum(bool(((s["kind"] == "cycle") & (s["frame_start"] < r.frame_start)
                                 & (s["frame_end"] >= r.frame_start)).any())
                           for r in gone.itertuples()
                           for s in [new[(quartet == frozenset((r.cell_a, r.cell_b, r.cell_c, r.cell_d))).to_numpy()]])
                print(f"{name}, min_length {ml}: old {len(old)} T1s, new {len(new)}; old rows absent from the new: "
                      f"{len(gone)}, of which {undo} now the undo of a cycle whose first half is found", flush=True)


if __name__ == "__main__":
    main()
