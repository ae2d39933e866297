"""Divisions found and judged plausible on the real stacks of the real-data folder, and the T1s of a random Voronoi
movie with the joint loss/gain pairing.

Run from the repository root: ``python benchmarks/divisions_real.py [--data FOLDER]`` (default: the folder named by
``HEXATISSUE_REAL_DATA``, as for the tests).  Prints one
line per stack: frames, cells per frame, divisions, plausible, suspect, the reasons' counts, the contacts held as
four-fold vertices; then the T1 events of the random movie of ``tests/test_events.py`` (60 cells, 40 frames,
exact contacts).  Numbers only: nothing is timed.
"""
from __future__ import annotations

import argparse
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

import hexatissue as ht
from _timing import REAL_DATA  # benchmarks/_timing.py
from hexatissue.events import detect_t1
from hexatissue.synthetic import movie_contacts, voronoi_movie
from hexatissue.track import division_rows

ROOT = Path(__file__).resolve().parents[1]


def stacks(data):
    yield "EpiCure 013 (curated)", ROOT / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"
    yield "EpiTools wing disc", np.load(data / "epitools_wingdisc" / "SegResults_CLabels_RegIm_TYX.npz")["CLabels"]
    yield "mouse epidermis", data / "mouse_epidermis_laptrack" / "labels.npy"
    yield "Skeletor pupal abdomen", data / "skeletor_pupal_abdomen" / "Final_Skeleton"
    yield "EpiCure area3 (EpySeg)", data / "epicure_notum" / "area3_Composite_epyseg.tif"


def random_movie_t1s():
    mov = voronoi_movie(60, (110, 150), 40, periodic=True, amplitude=0.4, seed=2)
    seeds = np.stack([mov.seeds(t) for t in range(len(mov))])
    edges = movie_contacts(seeds, mov.shape[1:], True)
    cells = pd.DataFrame({"frame": np.repeat(np.arange(len(mov)), len(mov.base)),
                          "cell": np.tile(np.arange(1, len(mov.base) + 1), len(mov)),
                          "x": seeds[..., 0].ravel(), "y": seeds[..., 1].ravel()})
    return {ml: detect_t1(edges, cells, censor=3, box=mov.box, min_length=ml) for ml in (0.0, 2.0)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REAL_DATA)
    args = parser.parse_args()
    warnings.simplefilter("ignore", ht.HexatissueWarning)
    for name, source in stacks(args.data):
        movie = ht.analyze(source, workers=1, progress=False)
        t, e = movie.summary["tracking"], movie.summary["events"]
        per_frame = movie.cells.groupby("frame").size().tolist()
        reasons = Counter(r for text in division_rows(movie.lineage)["reason"] for r in text.split(";") if r)
        print(f"{name}: {len(per_frame)} frames, cells {per_frame[0]} -> {per_frame[-1]} (min {min(per_frame)}, "
              f"max {max(per_frame)}), tracking {t['resolved']}; divisions {t['n_divisions']}: "
              f"{t['n_divisions_plausible']} plausible, {t['n_divisions_suspect']} suspect {dict(reasons)}; "
              f"held four-fold: {e['n_held_contacts']} contacts at {e['n_held_vertices']} vertex-frames; "
              f"T1 events {len(movie.events)}", flush=True)
    for ml, ev in random_movie_t1s().items():
        print(f"random Voronoi movie, min_length {ml}: {len(ev)} T1 events {ev['kind'].value_counts().to_dict()}")


if __name__ == "__main__":
    main()
