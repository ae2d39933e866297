"""Benchmark: force inference from label images of a vertex-model tissue with known tensions and pressures.

Truth: :func:`hexatissue.synthetic.vertex_model_tissue`, a periodic sheet of
``--cells`` cells (16 x 16 by default) with line tensions uniform in
[0.8, 1.2] and preferred areas uniform in [0.9, 1.1] x the mean, relaxed to
force balance (largest vertex force < 1e-10): its tensions are the line
tensions, its pressures ``-K (A - A0)``.  The sheet is drawn as a periodic
label image (:func:`hexatissue.synthetic.network_labels`) at 10, 20 and 40 px
per cell diameter (lattice pitch), clean and with boundary noise (the labels read
through a smooth random displacement field of s.d. ``--noise`` px per axis,
0.5, correlation length 2 px), meshed by :func:`hexatissue.mesh_from_labels` (periodic box) and its
forces inferred by :func:`hexatissue.mechanics.frame_forces` with each
junction model (``auto``, the default; ``straight``; ``curved``) and two
variants measured and not taken: ``per-junction`` (arcs only on the
junctions whose pixels show a curvature) and ``fitted lines`` (every junction
straight along the line fitted to its pixels instead of its chord).  The
same images are also given as 1-px skeletons (every pixel whose right or
lower neighbour is another cell; meshed with ``kind="skeleton"``, each
region matched to the cell under most of its pixels), with the models of
``--skeleton-models`` (auto and curved).  Junctions are matched to the truth by their two cells.

Scores per image and model: Pearson r of the tensions and of the pressures
against the truth, median relative tension error and median pressure error
over the s.d. of the true pressures (truth in the estimate's gauge: mean
tension 1 over the same junctions, mean pressure 0 over the same cells), and
the share of the truth inside the 90 % posterior intervals (estimate +- 1.645
s.d.).  Also the exact vertices (no image).  Writes
``benchmarks/results_forces.md`` (machine, date, load).  Usage::

    python benchmarks/bench_forces.py [--seeds 0 1 2] [--noise 0.5] [--skeleton-models auto curved]
        [--out benchmarks/results_forces.md]
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import hexatissue as ht  # noqa: E402
from hexatissue.mechanics import frame_forces, infer_forces  # noqa: E402
from hexatissue.mechanics.curvature import junction_shapes  # noqa: E402
from hexatissue.mesh.labels import mesh_labels, validate_labels  # noqa: E402
from hexatissue.synthetic import network_labels, vertex_model_tissue  # noqa: E402

PITCH = 20.0  # the generator's lattice pitch, px; images are drawn at d / PITCH px per unit
ROWS = 16
ROW_SPACING = 278.0 / ROWS  # 17.375 (regular: 17.32), so the box is a whole number of px at 10, 20 and 40 px
RESOLUTIONS = (10, 20, 40)
MODELS = ("auto", "straight", "curved", "per-junction", "fitted lines")
Z90 = 1.6448536269514722


def tissue(seed):
    return vertex_model_tissue(16, ROWS, spacing=PITCH, row_spacing=ROW_SPACING, tension_spread=0.2,
                               area_spread=0.1, seed=seed)


def boundary_noise(labels, amplitude, seed, correlation=2.0):
    """Labels read through a smooth random displacement field (s.d. ``amplitude`` px per axis, Gaussian
    correlation length ``correlation`` px, periodic): boundaries wander, cells stay whole."""
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(seed)
    H, W = labels.shape
    shift = []
    for _ in range(2):
        field = gaussian_filter(rng.standard_normal((H, W)), correlation, mode="wrap")
        shift.append(field * amplitude / field.std())
    rows, cols = np.mgrid[0:H, 0:W]
    return labels[np.rint(rows + shift[0]).astype(int) % H, np.rint(cols + shift[1]).astype(int) % W]


def compare(est_t, sd_t, true_t, est_p, sd_p, true_p):
    out = {}
    ok = np.isfinite(est_t) & np.isfinite(true_t)
    t = true_t[ok] / true_t[ok].mean()
    e = est_t[ok]
    out["n_t"] = int(ok.sum())
    out["r_t"] = float(np.corrcoef(e, t)[0, 1])
    out["err_t"] = float(np.median(np.abs(e - t) / t))
    out["cover_t"] = float(np.mean(np.abs(e - t) <= Z90 * sd_t[ok])) if np.isfinite(sd_t[ok]).all() else np.nan
    unit = true_t[ok].mean()
    okp = np.isfinite(est_p) & np.isfinite(true_p)
    p = (true_p[okp] - true_p[okp].mean()) / unit
    ep = est_p[okp]
    out["n_p"] = int(okp.sum())
    out["r_p"] = float(np.corrcoef(ep, p)[0, 1]) if okp.sum() > 2 else np.nan
    out["err_p"] = float(np.median(np.abs(ep - p)) / p.std()) if okp.sum() > 2 else np.nan
    out["cover_p"] = (float(np.mean(np.abs(ep - p) <= Z90 * sd_p[okp])) if np.isfinite(sd_p[okp]).all()
                      else np.nan)
    return out


def skeleton_of(labels):
    """A 1-px skeleton of a periodic label image: every pixel whose right or lower neighbour is another cell
    (no two 4-adjacent unmarked pixels then belong to different cells)."""
    return ((labels != np.roll(labels, -1, axis=1)) | (labels != np.roll(labels, -1, axis=0))).astype(np.uint8)


def mesh(labels, box, skeleton):
    """The labels the mesh uses, its tables, and per cell id of the tables the truth's cell id."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if not skeleton:
            frame = ht.mesh_from_labels(labels, box=box)
            return labels, {k: pd.DataFrame(v) for k, v in frame.tables.items()}, None
        regions, _ = mesh_labels(validate_labels(skeleton_of(labels)), box, ht.MeshOptions(kind="skeleton"))
        frame = ht.mesh_from_labels(regions, box=box)
    # each region's truth cell: the most frequent label under it
    pairs = pd.DataFrame({"region": regions.ravel(), "label": labels.ravel()})
    pairs = pairs[pairs["region"] > 0].value_counts().reset_index()
    first = pairs.drop_duplicates("region")
    id_map = np.zeros(int(regions.max()) + 1, np.int64)
    id_map[first["region"].to_numpy()] = first["label"].to_numpy()
    return regions, {k: pd.DataFrame(v) for k, v in frame.tables.items()}, id_map


def run_image(labels, box, truth_edges, truth_t, truth_p, model, method="bayes", skeleton=False):
    labels, tables, id_map = mesh(labels, box, skeleton)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        args = (tables["cells"], tables["vertices"], tables["edges"], tables["cell_vertices"], box)
        start = time.perf_counter()
        if model in ("auto", "straight", "curved"):
            forces, curvature, _, _ = frame_forces(labels, *args, junctions=model, method=method)
        else:
            # the variants not taken as defaults: arcs only on the junctions whose pixels show a curvature (the
            # others straight), or every junction straight along the line fitted to its pixels
            shapes = junction_shapes(labels, tables["vertices"], tables["edges"], box)
            arcs = shapes["curved"].to_numpy(bool)
            curvature = np.where(arcs, shapes["kappa"].to_numpy(float), 0.0)
            kw = (dict(curvature=curvature, arcs=arcs) if model == "per-junction" else
                  dict(directions=shapes[["direction_x", "direction_y"]].to_numpy(float)))
            if model == "fitted lines":
                curvature = np.zeros(len(tables["edges"]))
            forces = infer_forces(*args, method=method, **kw)
        seconds = time.perf_counter() - start
    # junctions by their two cells (the label ids are the truth's cell ids); pairs with two junctions left out
    truth = pd.Series(truth_t, index=pd.MultiIndex.from_arrays([truth_edges["cell_a"], truth_edges["cell_b"]]))
    truth = truth[~truth.index.duplicated(keep=False)]
    e = tables["edges"]
    ca, cb, cid = e["cell_a"].to_numpy(), e["cell_b"].to_numpy(), tables["cells"]["cell"].to_numpy()
    if id_map is not None:
        ca, cb, cid = id_map[ca], id_map[cb], id_map[cid]
        ca, cb = np.minimum(ca, cb), np.maximum(ca, cb)
    pair = pd.MultiIndex.from_arrays([ca, cb])
    dup = pair.duplicated(keep=False)
    true_t = truth.reindex(pair).to_numpy(float).copy()
    true_t[dup] = np.nan
    true_p = pd.Series(truth_p[1], index=truth_p[0]).reindex(cid).to_numpy(float)
    out = compare(forces.edges["tension"].to_numpy(), forces.edges["tension_sd"].to_numpy(), true_t,
                  forces.cells["pressure"].to_numpy(), forces.cells["pressure_sd"].to_numpy(), true_p)
    out["seconds"] = seconds
    out["curved"] = float(np.mean(curvature[np.isfinite(forces.edges["tension"])] != 0))
    return out


def exact(tables, tension, pressure, box):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        forces = infer_forces(tables["cells"], tables["vertices"], tables["edges"], tables["cell_vertices"], box)
    t = forces.edges["tension"].to_numpy()
    return float(np.abs(t - tension / tension.mean()).max()), forces.mu


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--noise", type=float, default=0.5)
    parser.add_argument("--models", nargs="+", default=list(MODELS))
    parser.add_argument("--skeleton-models", nargs="*", default=["auto", "curved"],
                        help="junction models also run on the images' 1-px skeletons")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results_forces.md")
    args = parser.parse_args()
    load = os.getloadavg()
    rows, exact_rows = [], []
    for seed in args.seeds:
        tables, tension, pressure, box = tissue(seed)
        exact_rows.append((seed, *exact(tables, tension, pressure, box)))
        truth_p = (tables["cells"]["cell"].to_numpy(), pressure)
        for d in RESOLUTIONS:
            scale = d / PITCH
            clean, image_box = network_labels(tables, box, scale)
            for noise in (0.0, args.noise):
                labels = boundary_noise(clean, noise, seed) if noise else clean
                runs = [(m, False) for m in args.models] + [(m, True) for m in args.skeleton_models]
                for model, skeleton in runs:
                    out = run_image(labels, image_box, tables["edges"], tension, (truth_p[0], pressure / scale),
                                    model, skeleton=skeleton)
                    out.update(seed=seed, px=d, noise=noise, model=model, form="skeleton" if skeleton else "labels")
                    rows.append(out)
                    print({k: (round(v, 3) if isinstance(v, float) else v) for k, v in out.items()}, flush=True)
    table = pd.DataFrame(rows)
    mean = table.groupby(["form", "px", "noise", "model"], sort=True).mean(numeric_only=True).reset_index()
    lines = ["# Force inference on rendered vertex-model tissues (`benchmarks/bench_forces.py`)", "",
             f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.node()}, "
             f"{os.cpu_count()} cores, load {load[0]:.2f} at the start; seeds {args.seeds}, boundary noise "
             f"{args.noise}; Bayesian estimate, ABIC, default options but the junction model.", "",
             "Means over the seeds. r: Pearson correlation with the truth; tension error: median |error| / truth "
             "(mean tension 1); pressure error: median |error| / s.d. of the true pressures; cover: share of the "
             "truth inside the 90 % posterior interval; curved: share of junctions drawn as arcs.", "",
             "| input | px per cell | noise | junctions | tensions | tension r | tension error | tension cover | pressure r | "
             "pressure error | pressure cover | curved | seconds |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in mean.iterrows():
        lines.append(f"| {r.form} | {r.px:.0f} | {r.noise:g} | {r.model} | {r.n_t:.0f} | {r.r_t:.3f} | {r.err_t:.3f} | "
                     f"{r.cover_t:.2f} | {r.r_p:.3f} | {r.err_p:.2f} | {r.cover_p:.2f} | {r.curved:.2f} | "
                     f"{r.seconds:.2f} |")
    lines += ["", "Exact vertices (no image), Bayesian estimate with ABIC: largest tension error (mean tension 1) "
              "and the prior weight ABIC chose:", ""]
    lines += [f"- seed {s}: {err:.1e} (mu = {mu:.2g})" for s, err, mu in exact_rows]
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
