"""Synthetic label movies with a known deformation, for the TissueMiner side-by-side check.

Every movie is a finite patch of Voronoi cells (background 0 around it) in a
*reference* configuration, deformed by a uniform affine map ``F_t`` about the
image centre: the label of pixel ``p`` at frame ``t`` is the reference
Voronoi label at ``c + F_t^{-1} (p - c)``.  Cell polygons are therefore exact
affine images of the reference polygons (up to rasterisation), so every
cell centre moves affinely and the tissue's shear rate is known exactly.

``F_t = R(phi) diag(exp(eps t), exp(-eps t)) R(-phi)``: pure shear, no
rotation, no area change.  Per frame pair (t -> t+1) the displacement
gradient is ``F_{t+1} F_t^{-1} - 1 = R(phi) diag(e^eps - 1, e^-eps - 1) R(-phi)``;
its traceless symmetric part (TissueMiner's ``nu``) is
``sinh(eps) (cos 2phi, sin 2phi)`` and the logarithmic (true) shear rate is
``eps (cos 2phi, sin 2phi)``; rotation, area growth, T1, division and
extrusion contributions are all exactly 0.

Kinds (``--kind``):

* ``shear``    : the above, no topology change.
* ``t1``       : the same shear, plus at frame ``event_frame`` two cells ``c``, ``d``
                 on either side of an interior junction a-b are pulled together in the
                 reference configuration so that a-b lose contact and c-d gain it (one T1).
* ``division`` : the same shear, plus at frame ``event_frame`` one interior cell is
                 replaced by two daughters (its seed split in two, 0.3 spacing apart);
                 the daughters get new label ids, the mother's id ends.

Labels are int32, ``[row, col]``; x = column, y = row (hexatissue's convention).

Usage::

    PYTHONPATH=/work/wt-tm python benchmarks/tissueminer/movies.py --kind shear --out /tmp/tmbench/shear
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree, Voronoi

from hexatissue.synthetic import hexagonal_seeds

SHAPE = (260, 260)
SPACING = 20.0
RADIUS = 95.0          # reference seeds within this distance of the centre are the tissue
EPS = 0.01             # log strain per frame
PHI = np.pi / 8        # shear axis: both xx and xy components nonzero
N_FRAMES = 7


def shear_map(t, eps=EPS, phi=PHI):
    """F_t (2x2) in (x, y)."""
    c, s = np.cos(phi), np.sin(phi)
    r = np.array([[c, -s], [s, c]])
    return r @ np.diag([np.exp(eps * t), np.exp(-eps * t)]) @ r.T


def exact_rates(eps=EPS, phi=PHI):
    """Per-frame exact shear rates: TissueMiner's linearised nu and the logarithmic rate."""
    return {
        "nu_xx": float(np.sinh(eps) * np.cos(2 * phi)), "nu_xy": float(np.sinh(eps) * np.sin(2 * phi)),
        "log_xx": float(eps * np.cos(2 * phi)), "log_xy": float(eps * np.sin(2 * phi)),
    }


def render(seeds, labels_of_seeds, keep, F, shape=SHAPE):
    """Label image of the reference Voronoi of ``seeds`` deformed by F about the image centre."""
    rows, cols = shape
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])
    gx, gy = np.meshgrid(np.arange(cols, dtype=float), np.arange(rows, dtype=float))
    pix = np.c_[gx.ravel(), gy.ravel()]
    ref = (pix - centre) @ np.linalg.inv(F).T + centre
    idx = cKDTree(seeds).query(ref)[1]
    lab = np.where(keep[idx], labels_of_seeds[idx], 0)
    return lab.reshape(rows, cols).astype(np.int32)


def _interior_pair(seeds, keep, centre):
    """An interior Voronoi ridge a-b near the centre and the two cells c, d at its ends."""
    vor = Voronoi(seeds)
    best = None
    for (a, b), ridge in zip(vor.ridge_points, vor.ridge_vertices):
        if -1 in ridge or not (keep[a] and keep[b]):
            continue
        mid = 0.5 * (seeds[a] + seeds[b])
        d = np.hypot(*(mid - centre))
        if best is None or d < best[0]:
            best = (d, a, b, ridge)
    _, a, b, ridge = best
    # the cells sharing the ridge's end vertices besides a and b
    ends = []
    for v in ridge:
        owners = [k for k, reg in enumerate(vor.point_region) if v in vor.regions[reg]]
        others = [k for k in owners if k not in (a, b)]
        ends.append(others[0])
    return a, b, ends[0], ends[1]


def make(kind="shear", n_frames=N_FRAMES, eps=EPS, phi=PHI, event_frame=3, seed=3):
    rows, cols = SHAPE
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])
    # a jittered hexagonal lattice: robustly three-fold vertices (a jittered square lattice has
    # near-four-fold ones that rasterisation turns into four-fold vertices)
    seeds, _ = hexagonal_seeds(int(cols // SPACING) + 2, 2 * int(rows // (SPACING * 0.866) / 2) + 2,
                               spacing=SPACING, row_spacing=SPACING * np.sqrt(3) / 2, offset=(-SPACING, -SPACING))
    seeds = seeds + np.random.default_rng(seed).uniform(-0.2, 0.2, seeds.shape) * SPACING
    keep = np.hypot(*(seeds - centre).T) < RADIUS
    ids = np.arange(1, len(seeds) + 1)
    info = {"kind": kind, "n_frames": n_frames, "eps": eps, "phi": phi, "shape": SHAPE,
            "n_cells": int(keep.sum()), "exact_per_frame": exact_rates(eps, phi)}
    frames = []
    seeds_after, ids_after, keep_after = seeds, ids, keep
    if kind == "t1":
        a, b, c, d = _interior_pair(seeds, keep, centre)
        moved = seeds.copy()
        mid = 0.5 * (seeds[c] + seeds[d])
        moved[c] = mid + 0.3 * (seeds[c] - mid)   # c and d approach: they become neighbours,
        moved[d] = mid + 0.3 * (seeds[d] - mid)   # a and b lose their contact
        seeds_after = moved
        info.update(event_frame=event_frame, t1_lost=[int(ids[a]), int(ids[b])], t1_gained=[int(ids[c]), int(ids[d])])
    elif kind == "division":
        k = int(np.argmin(np.hypot(*(seeds - centre).T)))
        half = 0.15 * SPACING * np.array([np.cos(0.4), np.sin(0.4)])
        seeds_after = np.vstack([np.delete(seeds, k, 0), seeds[k] - half, seeds[k] + half])
        n = len(seeds)
        ids_after = np.r_[np.delete(ids, k), n + 1, n + 2]
        keep_after = np.r_[np.delete(keep, k), True, True]
        info.update(event_frame=event_frame, mother=int(ids[k]), daughters=[n + 1, n + 2])
    elif kind != "shear":
        raise SystemExit(f"unknown kind {kind!r}")
    for t in range(n_frames):
        after = kind != "shear" and t >= event_frame
        s, i, k = (seeds_after, ids_after, keep_after) if after else (seeds, ids, keep)
        frames.append(render(s, i, k, shear_map(t, eps, phi)))
    return np.stack(frames), info


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kind", default="shear", choices=["shear", "t1", "division"])
    ap.add_argument("--frames", type=int, default=N_FRAMES)
    ap.add_argument("--eps", type=float, default=EPS)
    ap.add_argument("--phi", type=float, default=PHI)
    ap.add_argument("--out", required=True, help="folder: labels.npy + truth.json, then hexatissue's tables in tables/")
    ap.add_argument("--no-analyze", action="store_true")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stack, info = make(args.kind, args.frames, args.eps, args.phi)
    np.save(out / "labels.npy", stack)
    (out / "truth.json").write_text(json.dumps(info, indent=1))
    print(json.dumps(info))
    if not args.no_analyze:
        import warnings
        import hexatissue as ht
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            movie = ht.analyze(stack, workers=1, progress=False)
        movie.write(out / "tables")
        print("tables:", sorted(movie.tables))


if __name__ == "__main__":
    main()
