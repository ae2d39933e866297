"""Regenerate the figures and the |Gamma_p|(R) table of docs/order.md.

    python docs/figures/order_figures.py [--real DIR]   (DIR: a folder holding hexanematic_mdck/)

Uses the published MDCK polygons (Armengol-Collado et al. 2023, not copied into
the repository) when the real-data folder is there, and synthetic tissues
otherwise.  Writes docs/figures/order_*.png and order_vs_radius.csv.  The stress figures
order_stress{2,6}.png come from a small multiphase-field run with --mpf (several minutes);
without it, order_stress{2,6}_voronoi.png use smoothed Voronoi indicators as phase fields.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import ndimage
from scipy.spatial import Voronoi

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

from hexatissue import Box, plot  # noqa: E402
from hexatissue.defects import find_defects  # noqa: E402
from hexatissue.io import write_table  # noqa: E402
from hexatissue.order import cells_from_polygons, coarse_grain, order_vs_radius  # noqa: E402
from hexatissue.simulate.stress import cell_stress  # noqa: E402
from hexatissue.synthetic import jittered_seeds, voronoi_labels  # noqa: E402


def mdck(folder, image):
    """Polygons {cell: (n, 2)} and cells table of one published MDCK image."""
    from scipy.io import loadmat

    polygon = loadmat(folder / "mat" / f"Image{image}_Polygon.mat", simplify_cells=True)["Polygon"]
    cells = cells_from_polygons(polygon["Vertex"], centers=polygon["CenterOfMass"])
    polys = {c: np.asarray(v, float)[:-1] for c, v in zip(cells["cell"], polygon["Vertex"])}
    return polys, cells


def mdck_figures(folder):
    import tifffile

    polys, cells = mdck(folder, 13)
    membranes = tifffile.imread(folder / "raw" / "Image13.tif")[:, 1].max(axis=0)  # C1 = cell outlines
    plot.plot_labels(image=membranes, polygons=polys, path=HERE / "order_mdck_polygons.png")
    plot.plot_stars(cells, p=6, polygons=polys, image=membranes, path=HERE / "order_mdck_stars6.png")
    for p in (6, 2):
        grid = coarse_grain(cells, p=p)
        defects = find_defects(grid, p=p)
        plot.plot_order_field(grid, defects, p=p, polygons=polys, path=HERE / f"order_mdck_field{p}.png")
        print(f"MDCK image 13, p={p}: {(defects['charge'] > 0).sum()} positive, "
              f"{(defects['charge'] < 0).sum()} negative defects")
    # |Gamma_p| against R / R_cell over images 6-68
    all_cells = pd.concat([mdck(folder, k)[1].assign(frame=k) for k in range(6, 69)], ignore_index=True)
    factors = (0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0)
    curve = pd.concat([order_vs_radius(all_cells, p=p, factors=factors) for p in (2, 6)], ignore_index=True)
    summary = curve.groupby(["p", "factor"]).agg(mean=("abs_Gamma", "mean"), sd=("abs_Gamma", "std"),
                                                 nodes=("n_nodes", "mean")).reset_index()
    write_table(summary, HERE / "order_vs_radius.csv")
    fig = plot.plot_order_vs_radius(curve, path=HERE / "order_vs_radius.png")
    fig.axes[0].set_title("MDCK, images 6-68")
    plot.save_figure(fig, HERE / "order_vs_radius.png")
    print(summary.to_string(index=False))


def quadrupole_figure():
    """Cells on a jittered hexagonal lattice whose gamma6 phase is the quadrupole 6 theta = Arg W."""
    rng = np.random.default_rng(0)
    a, nx = 10.0, 24
    row = a * np.sqrt(3) / 2
    ny = 2 * int(round(nx * a / row / 2))
    j, i = np.meshgrid(np.arange(nx), np.arange(ny))
    box = Box(nx * a, ny * row)
    xy = box.wrap(np.c_[((j + 0.5 * (i % 2)) * a).ravel(), (i * row).ravel()] + rng.uniform(-2, 2, (i.size, 2)))
    z = (xy[:, 0] - box.Lx / 2) + 1j * (xy[:, 1] - box.Ly / 2)
    w = (z**2 + 30.0**2) / (z**2 - 30.0**2)
    gamma = np.exp(0.3j * rng.normal(size=len(xy))) * w / np.abs(w)  # noisy phases, |gamma6| = 1
    cells = pd.DataFrame({"x": xy[:, 0], "y": xy[:, 1], "area": np.sqrt(3) / 2 * a * a, "is_border": False,
                          "gamma6_re": gamma.real, "gamma6_im": gamma.imag})
    grid = coarse_grain(cells, box=box)
    defects = find_defects(grid, box=box)
    fig = plot.plot_order_field(grid, defects, p=6, box=box, path=HERE / "order_quadrupole.png")
    ax = fig.axes[0]
    ax.set_title(f"quadrupole $6\\theta = \\mathrm{{Arg}}\\,W$, $\\ell = 30$ px: {len(defects)} defects (centre)")
    ax.set_xlim(box.Lx / 2 - 65, box.Lx / 2 + 65)
    ax.set_ylim(box.Ly / 2 + 65, box.Ly / 2 - 65)
    plot.save_figure(fig, HERE / "order_quadrupole.png")


def synthetic_phase_fields(shape=(200, 240), spacing=24.0, patch=41, width=1.5, seed=3):
    """MPF-like patches: each Voronoi cell's indicator smoothed by a Gaussian of ``width`` px.

    Returns the interior cells' polygons and cells table, and their (n, patch, patch) fields.
    """
    seeds = jittered_seeds(shape, spacing, jitter=0.3, seed=seed)
    labels = voronoi_labels(seeds, shape)
    vor = Voronoi(seeds)
    lo, hi = np.array([0, 0]), np.array([shape[1] - 1, shape[0] - 1])
    polys = {}
    for k, region in enumerate(vor.point_region):
        verts = vor.regions[region]
        if verts and -1 not in verts and np.all((vor.vertices[verts] > lo) & (vor.vertices[verts] < hi)):
            polys[k + 1] = vor.vertices[verts]
    ids = np.array(list(polys))
    cells = cells_from_polygons(polys, centers=seeds[ids - 1])
    half = patch // 2
    padded = np.pad(labels, half)
    phi = np.empty((len(ids), patch, patch))
    for n, (c, (x, y)) in enumerate(zip(ids, seeds[ids - 1])):
        r, q = int(round(y)) + half, int(round(x)) + half
        window = padded[r - half: r + half + 1, q - half: q + half + 1] == c
        phi[n] = ndimage.gaussian_filter(window.astype(float), width, mode="constant")
    return polys, cells, phi


def stress_figures():
    polys, cells, phi = synthetic_phase_fields()
    for p in (2, 6):
        theta = np.angle(cells[f"gamma{p}_re"] + 1j * cells[f"gamma{p}_im"]) / p
        cells[f"sigma{p}"] = cell_stress(phi, theta, k_phi=1.0, p=p)
        fig = plot.plot_stress(cells, f"sigma{p}", polys)
        ax = fig.axes[0]
        plot.plot_stars(cells, p=p, ax=ax, color="k")
        ax.set_title(f"$\\sigma_\\parallel^{{({p})}}$ ($k_\\phi = 1$) and Arg$(\\gamma_{p})/{p}$; "
                     "smoothed-Voronoi phase fields")
        plot.save_figure(fig, HERE / f"order_stress{p}_voronoi.png")


def mpf_stress_figures(steps=3000, seed=1):
    """sigma_par of a small passively relaxed MPF tissue (64 cells, periodic 150 x 152 px)."""
    from hexatissue import mesh_from_labels, shape_order
    from hexatissue.simulate.model import initial_state
    from hexatissue.simulate.params import Params

    params = Params(n_cells=64, Lx=150, Ly=152, dtype="float64")
    sim = initial_state(params, seed=seed)
    sim.advance(steps, active=False)
    vmax, imax = sim.max_field()
    labels = np.where(vmax > params.phi0 / 2, imax + 1, 0)
    # argmax segmentation: the small gaps at triple junctions (max phi < phi0/2) go to the nearest cell
    nearest = ndimage.distance_transform_edt(labels == 0, return_distances=False, return_indices=True)
    labels = labels[tuple(nearest)]
    box = Box(params.Lx, params.Ly)
    frame = shape_order(mesh_from_labels(labels, box=box))
    cells = frame.cells
    polys = frame.polygons()
    patches = sim.phi[cells["cell"].to_numpy() - 1]  # label c is patch c - 1
    for p in (2, 6):
        theta = np.angle(cells[f"gamma{p}_re"] + 1j * cells[f"gamma{p}_im"]) / p
        cells[f"sigma{p}"] = cell_stress(patches, theta, k_phi=params.k_phi, p=p)
        fig = plot.plot_stress(cells, f"sigma{p}", polys, box=box)
        plot.plot_stars(cells, p=p, ax=fig.axes[0], color="k", box=box)
        fig.axes[0].set_title(f"MPF, 64 cells, {steps} passive steps: $\\sigma_\\parallel^{{({p})}}$ "
                              f"and Arg$(\\gamma_{p})/{p}$")
        plot.save_figure(fig, HERE / f"order_stress{p}.png")
        print(f"MPF sigma_par p={p}: mean {cells[f'sigma{p}'].mean():.4f}, s.d. {cells[f'sigma{p}'].std():.4f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--real", type=Path, default=HERE.parents[2] / "shared" / "data" / "real")
    parser.add_argument("--mpf", action="store_true",
                        help="stress figures from a small MPF run (minutes); else from smoothed Voronoi fields")
    args = parser.parse_args(argv)
    folder = args.real / "hexanematic_mdck"
    if folder.is_dir():
        mdck_figures(folder)
    else:
        print(f"{folder} not found: skipping the MDCK figures")
    quadrupole_figure()
    if args.mpf:
        mpf_stress_figures()
    else:
        stress_figures()


if __name__ == "__main__":
    main()
