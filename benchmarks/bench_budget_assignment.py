"""How much of the deformation budget's retriangulation no event explains: pure warp and T1-carried shear.

Two movies of a random Voronoi patch (300 seeds in 360 x 360 px, on background) analysed with the
deformation stage (default options):

- **pure warp**: the label image of frame 0 pulled through the affine maps exp(t L), L = [[0.01,
  0.004], [0.004, -0.01]] per frame, 8 frames: no cell changes neighbours, so every retriangulation
  is a resampling artefact and the ideal ``rearrangement`` is 0;
- **T1-carried**: the seeds moved by exp(t L), L = diag(0.03, -0.03), and re-tessellated, 12 frames:
  the cells exchange neighbours and the T1 terms should carry the shear the cells' shapes do not.

Each at the default ``merge_distance`` (2 px) and at the others asked (``--merge``).  Reported:
per-interval means of |term| / |total shear| (tissue region) for ``rearrangement`` (a contact
changes, no T1 explains it) and ``resampling`` (no contact changes), their sums over the movie
over the summed total, the T1 share T1 / (T1 + rearrangement) of the summed xx shear, and the
number of T1 events.  Writes ``benchmarks/results_budget_assignment.md``.  Usage::

    PYTHONPATH=$PWD python benchmarks/bench_budget_assignment.py [--seed 0] [--merge 0.5]
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.linalg import expm

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import hexatissue as ht  # noqa: E402
from hexatissue.errors import HexatissueWarning  # noqa: E402
from hexatissue.synthetic import voronoi_labels  # noqa: E402

warnings.simplefilter("ignore", HexatissueWarning)
SHAPE = (360, 360)
T1_TERMS = ("t1_cycle", "t1_intercalation", "t1_unresolved")


def patch(seeds, labels, reference):
    """Background outside the central patch of the reference seeds (no cell enters or leaves the image)."""
    outside = np.flatnonzero(np.abs(reference - np.array(SHAPE[::-1]) / 2.0).max(axis=1) > 0.3 * min(SHAPE)) + 1
    labels[np.isin(labels, outside)] = 0
    return labels


def warp_movie(seeds, n_frames=8):
    L = np.array([[0.01, 0.004], [0.004, -0.01]])
    base = patch(seeds, voronoi_labels(seeds, SHAPE), seeds)
    centre = (np.array(SHAPE) - 1) / 2.0
    frames = []
    for t in range(n_frames):
        inv = np.linalg.inv(expm(t * L)[::-1, ::-1])  # (row, col)
        frames.append(ndimage.affine_transform(base, inv, offset=centre - inv @ centre, order=0, mode="constant"))
    return np.stack(frames)


def t1_movie(seeds, n_frames=12):
    L = np.diag([0.03, -0.03])
    centre = np.array(SHAPE[::-1]) / 2.0 - 0.5
    return np.stack([patch(seeds, voronoi_labels((seeds - centre) @ expm(t * L).T + centre, SHAPE), seeds)
                     for t in range(n_frames)])


def measure(labels, merge_distance):
    mv = ht.analyze(labels, workers=1, progress=False, mesh=ht.MeshOptions(merge_distance=merge_distance),
                    deformation=ht.DeformationOptions(enabled=True))
    d = mv.deformation[mv.deformation["region"] == "tissue"]
    total = np.hypot(d["total_xx"], d["total_xy"])

    def per_interval(terms):
        xx = sum(d[f"{t}_xx"] for t in terms)
        xy = sum(d[f"{t}_xy"] for t in terms)
        return float(np.hypot(xx, xy).mean() / total.mean()), float(xx.sum()), float(xy.sum())

    rearr, t1, resampling = per_interval(["rearrangement"]), per_interval(T1_TERMS), per_interval(["resampling"])
    shear_xx = float(d["total_xx"].sum())
    return {"intervals": len(d), "total_xx": shear_xx, "total_xy": float(d["total_xy"].sum()),
            "rearrangement / shear (per interval)": rearr[0], "rearrangement_xx": rearr[1], "rearrangement_xy": rearr[2],
            "rearrangement_xx / total_xx": rearr[1] / shear_xx,
            "resampling / shear (per interval)": resampling[0], "resampling_xx": resampling[1],
            "resampling_xx / total_xx": resampling[1] / shear_xx,
            "T1_xx": t1[1], "T1_xy": t1[2], "T1 share (xx)": t1[1] / (t1[1] + rearr[1]) if t1[1] + rearr[1] else np.nan,
            "T1 events": len(mv.events), "max |closure|": float(d[["closure_xx", "closure_xy"]].abs().to_numpy().max())}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--merge", type=float, nargs="*", default=[0.5], help="merge distances (px) beside the default")
    args = p.parse_args()
    t0 = time.time()
    seeds = np.random.default_rng(args.seed).uniform(30, 330, (300, 2))
    default = ht.MeshOptions().merge_distance
    rows = {}
    for merge in [default] + [m for m in args.merge if m != default]:
        tag = f"merge {merge:g} px" + (" (default)" if merge == default else "")
        rows[f"pure warp, {tag}"] = measure(warp_movie(seeds), merge)
        rows[f"T1-carried, {tag}"] = measure(t1_movie(seeds), merge)
    keys = list(next(iter(rows.values())))
    lines = ["# Retriangulations no event explains (`benchmarks/bench_budget_assignment.py`)", "",
             f"Generated {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on {platform.node() or 'this machine'} "
             f"({os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}), {time.time() - t0:.0f} s, seed {args.seed}, `--merge {' '.join(f'{m:g}' for m in args.merge)}`. "
             "Goals: rearrangement <= 0.5 % of the shear on the pure warp; T1 share >= 0.9 where T1s carry it.", "",
             "| movie | " + " | ".join(keys) + " |", "|" + "---|" * (len(keys) + 1)]
    for name, r in rows.items():
        lines.append(f"| {name} | " + " | ".join(f"{r[k]:.4g}" if isinstance(r[k], float) else str(r[k])
                                                   for k in keys) + " |")
    out = HERE / "results_budget_assignment.md"
    out.write_text("\n".join(lines) + "\n")
    print(out.read_text())


if __name__ == "__main__":
    main()
