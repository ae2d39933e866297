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
* ``t1``       : the same shear, plus two cells ``c``, ``d`` at the ends of an interior junction
                 a-b steadily pulled together in the reference configuration (their seeds end at
                 1 - T1_PULL of their distance from their midpoint): a-b shrinks and is replaced by
                 c-d (T1s; the frames where the exact neighbours change are in truth.json).
* ``division`` : the same shear, plus at frame ``event_frame`` one interior cell is
                 replaced by two daughters (its seed split in two, 0.3 spacing apart);
                 the daughters get new label ids, the mother's id ends.

* ``extrusion`` : the same shear; the central cell shrinks steadily (a power diagram: its weight
                 falls linearly to EXTRUDE_LAST x the weight at which it vanishes, at frame
                 ``event_frame``) and is gone from frame ``event_frame + 1`` on (an interior
                 disappearance: hexatissue's ``extrusion``, TissueMiner's ``Apoptosis``).

Labels are int32, ``[row, col]``; x = column, y = row (hexatissue's convention).

Usage::

    PYTHONPATH=$PWD python benchmarks/tissueminer/movies.py --kind shear --out /tmp/tmbench/shear
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
EXTRUDE_LAST = 0.6  # extrusion movie: weight at the last frame the cell is present, x the vanishing weight
T1_PULL = 0.6       # t1 movie: c and d end at 0.4 of their initial distance from their midpoint


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


def exact_centres(seeds, labels_of_seeds, keep, F, shape=SHAPE):
    """Exact area centroids and areas of the kept cells (continuous Voronoi polygons mapped by F)."""
    rows, cols = shape
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])
    vor = Voronoi(seeds)
    out = []
    for k in np.flatnonzero(keep):
        region = vor.regions[vor.point_region[k]]
        if not region or -1 in region:
            raise ValueError(f"kept cell {labels_of_seeds[k]} is unbounded")
        xy = (vor.vertices[region] - centre) @ F.T + centre
        x, y = xy[:, 0], xy[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        a = cross.sum() / 2
        cx, cy = ((x + xn) * cross).sum() / (6 * a), ((y + yn) * cross).sum() / (6 * a)
        out.append((int(labels_of_seeds[k]), cx, cy, abs(a)))
    return out


def power_cells(seeds, weights, keep, F, shape=SHAPE):
    """Exact cells of the power diagram |q - s_i|^2 - w_i (kept ones), mapped by F about the centre.

    Returns ``{index: (polygon (m, 2) after F, set of neighbour indices)}``; empty cells are left out.
    """
    rows, cols = shape
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])
    tree = cKDTree(seeds)
    out = {}
    for i in np.flatnonzero(keep):
        si = seeds[i]
        poly = [si + SPACING * 3 * np.array(c) for c in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        src = [-1] * 4  # which neighbour made each edge (edge k: poly[k] -> poly[k+1])
        for j in tree.query_ball_point(si, 4 * SPACING):
            if j == i or not poly:
                continue
            n = 2 * (seeds[j] - si)
            c = seeds[j] @ seeds[j] - si @ si - weights[j] + weights[i]
            new, new_src = [], []
            m = len(poly)
            for k in range(m):
                a, b = poly[k], poly[(k + 1) % m]
                ina, inb = a @ n <= c, b @ n <= c
                if ina:
                    new.append(a)
                    new_src.append(src[k])
                if ina != inb:
                    x = a + (c - a @ n) / ((b - a) @ n) * (b - a)
                    new.append(x)
                    new_src.append(src[k] if ina else j)
            # the edge that starts at an entering point lies on the clipping line
            poly, src = new, new_src
            for k in range(len(poly)):
                a, b = poly[k], poly[(k + 1) % len(poly)]
                if abs(a @ n - c) < 1e-9 and abs(b @ n - c) < 1e-9:
                    src[k] = j
        if len(poly) < 3:
            continue
        xy = (np.array(poly) - centre) @ F.T + centre
        x, y = xy[:, 0], xy[:, 1]
        if abs((x * np.roll(y, -1) - np.roll(x, -1) * y).sum()) < 1e-9:
            continue
        out[int(i)] = (xy, {k for k in src if k >= 0})
    return out


def render_power(seeds, weights, labels_of_seeds, keep, F, shape=SHAPE):
    """Label image of the power diagram (lifted to 3-D: the nearest lifted seed is the power cell)."""
    rows, cols = shape
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])
    gx, gy = np.meshgrid(np.arange(cols, dtype=float), np.arange(rows, dtype=float))
    pix = np.c_[gx.ravel(), gy.ravel()]
    ref = (pix - centre) @ np.linalg.inv(F).T + centre
    lift = np.sqrt(weights.max() - weights)
    idx = cKDTree(np.c_[seeds, lift]).query(np.c_[ref, np.zeros(len(ref))])[1]
    lab = np.where(keep[idx], labels_of_seeds[idx], 0)
    return lab.reshape(rows, cols).astype(np.int32)


def _polygon_centroid(xy):
    x, y = xy[:, 0], xy[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    a = cross.sum() / 2
    return ((x + xn) * cross).sum() / (6 * a), ((y + yn) * cross).sum() / (6 * a), abs(a)


def _contacts(seeds, labels_of_seeds, keep):
    """Exact neighbour pairs (label, label) among the kept cells."""
    vor = Voronoi(seeds)
    return {tuple(sorted((int(labels_of_seeds[p]), int(labels_of_seeds[q])))) for p, q in vor.ridge_points
            if keep[p] and keep[q]}


def _min_ridge(seeds, *cells):
    """Shortest Voronoi junction of the given seed indices."""
    vor = Voronoi(seeds)
    out = np.inf
    for (p, q), ridge in zip(vor.ridge_points, vor.ridge_vertices):
        if (p in cells or q in cells) and -1 not in ridge:
            out = min(out, np.hypot(*(vor.vertices[ridge[0]] - vor.vertices[ridge[1]])))
    return out


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
    if kind == "t1":
        a, b, c, d = _interior_pair(seeds, keep, centre)
        mid = 0.5 * (seeds[c] + seeds[d])

        def at(t):  # c and d approach each other steadily: a-b shrinks, vanishes, c-d grows
            moved = seeds.copy()
            f = 1.0 - T1_PULL * t / max(n_frames - 1, 1)
            moved[c] = mid + f * (seeds[c] - mid)
            moved[d] = mid + f * (seeds[d] - mid)
            return moved, ids, keep
        info.update(t1_lost=[int(ids[a]), int(ids[b])], t1_gained=[int(ids[c]), int(ids[d])])
    elif kind == "division":
        k = int(np.argmin(np.hypot(*(seeds - centre).T)))
        n = len(seeds)

        def split_at(angle):
            half = 0.15 * SPACING * np.array([np.cos(angle), np.sin(angle)])
            return (np.vstack([np.delete(seeds, k, 0), seeds[k] - half, seeds[k] + half]),
                    np.r_[np.delete(ids, k), n + 1, n + 2], np.r_[np.delete(keep, k), True, True])
        # the division axis whose daughters' junctions are all long (no near-four-fold vertex,
        # which rasterisation would turn into a four-fold one)
        angles = np.linspace(0, np.pi, 24, endpoint=False)
        angle = max(angles, key=lambda a: _min_ridge(split_at(a)[0], n - 1, n))
        split = split_at(angle)
        info["division_angle"] = float(angle)

        def at(t):  # the mother's seed splits in two at event_frame
            return split if t >= event_frame else (seeds, ids, keep)
        info.update(event_frame=event_frame, mother=int(ids[k]), daughters=[n + 1, n + 2])
    elif kind == "extrusion":
        k = int(np.argmin(np.hypot(*(seeds - centre).T)))
        # the weight at which the central cell's power cell vanishes (bisection on its area)
        lo, hi = -4.0 * SPACING ** 2, 0.0
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            w = np.zeros(len(seeds))
            w[k] = mid
            if k in power_cells(seeds, w, keep, np.eye(2)):
                hi = mid
            else:
                lo = mid
        w_gone = lo
        last = event_frame  # the last frame the cell is present

        def weights(t):  # shrinks steadily to 0.6 of the vanishing weight at `last`, gone after
            w = np.zeros(len(seeds))
            w[k] = w_gone * (EXTRUDE_LAST * t / last if t <= last else 1.3)
            return w
        info.update(event_frame=last + 1, extruded=int(ids[k]), w_gone=float(w_gone))
    elif kind == "shear":
        def at(t):
            return seeds, ids, keep
    else:
        raise SystemExit(f"unknown kind {kind!r}")
    centres, contacts = [], []
    if kind == "extrusion":
        for t in range(n_frames):
            F = shear_map(t, eps, phi)
            cellsp = power_cells(seeds, weights(t), keep, F)
            present = np.zeros(len(seeds), bool)
            present[list(cellsp)] = True
            frames.append(render_power(seeds, weights(t), ids, present, F))
            centres += [(t, int(ids[i])) + _polygon_centroid(xy) for i, (xy, _) in sorted(cellsp.items())]
            contacts.append({tuple(sorted((int(ids[i]), int(ids[j])))) for i, (_, nb) in cellsp.items() for j in nb
                             if j in cellsp})
        same = [np.array_equal(weights(t), weights(t + 1)) for t in range(n_frames - 1)]
    else:
        for t in range(n_frames):
            s, i, k = at(t)
            frames.append(render(s, i, k, shear_map(t, eps, phi)))
            centres += [(t,) + row for row in exact_centres(s, i, k, shear_map(t, eps, phi))]
            contacts.append(_contacts(s, i, k))
        same = [len(at(t)[0]) == len(at(t + 1)[0]) and np.array_equal(at(t)[0], at(t + 1)[0]) for t in range(n_frames - 1)]
    # frame pairs t -> t+1 over which every cell moves with the uniform affine map (reference
    # seeds unchanged): there the rotation and growth terms vanish exactly
    info["affine_pairs"] = [t for t in range(n_frames - 1) if same[t]]
    # frame pairs t -> t+1 whose exact neighbour relations change (T1s, divisions)
    info["topology_changes"] = [
        {"frame": t, "lost": sorted(map(list, contacts[t] - contacts[t + 1])),
         "gained": sorted(map(list, contacts[t + 1] - contacts[t]))}
        for t in range(n_frames - 1) if contacts[t] != contacts[t + 1]]
    info["exact_centres"] = centres
    return np.stack(frames), info


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kind", default="shear", choices=["shear", "t1", "division", "extrusion"])
    ap.add_argument("--frames", type=int, default=N_FRAMES)
    ap.add_argument("--eps", type=float, default=EPS)
    ap.add_argument("--phi", type=float, default=PHI)
    ap.add_argument("--out", required=True, help="folder: labels.npy, truth.json, exact_centres.csv (the exact "
                    "area centroids of the continuous cells), then hexatissue's tables in tables/")
    ap.add_argument("--no-analyze", action="store_true")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stack, info = make(args.kind, args.frames, args.eps, args.phi)
    np.save(out / "labels.npy", stack)
    import pandas as pd
    pd.DataFrame(info.pop("exact_centres"), columns=["frame", "cell", "x", "y", "area"]).to_csv(
        out / "exact_centres.csv", index=False)
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
