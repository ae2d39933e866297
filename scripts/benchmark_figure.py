"""docs/figures/benchmark_render.png: rendered benchmark frames beside their truth labels.

    PYTHONPATH=$PWD python scripts/benchmark_figure.py [--out docs/figures/benchmark_render.png]

Top row: frame 0 of the bundled MPF run (hexatissue/sample_data/mpf_small, 60 cells, periodic 140 x 151 px):
the truth labels with the truth polygons, rendered at SNR 20 with 2-px membranes (Gaussian PSF,
sigma 1 px), and at SNR 4 with 1-px membranes, an Airy PSF and slightly bent junctions.
Bottom row: an open field of view (160 x 200 px) cropped from a periodic Voronoi tissue: the truth
labels (grey crosses: border cells, cut by the crop), the membrane channel (SNR 10), and the
nuclear channel.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hexatissue.benchmark import Renderer, RenderOptions, truth_from_run, truth_from_voronoi  # noqa: E402
from hexatissue.plot import plot_labels, save_figure  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "figures" / "benchmark_render.png"))
    args = ap.parse_args(argv)
    from matplotlib.figure import Figure

    run = truth_from_run(ROOT / "hexatissue" / "sample_data" / "mpf_small" / "run.zarr", frames=[0], progress=False)
    crop = truth_from_voronoi(300, (320, 360), 1, seed=3, crop=(60, 80, 160, 200), progress=False)
    panels = [
        (run, None, "MPF run: truth labels"),
        (run, RenderOptions(snr=20, membrane_width=2), "SNR 20, 2 px membranes"),
        (run, RenderOptions(snr=4, membrane_width=1, psf="airy", curvature=0.05), "SNR 4, 1 px, Airy, bent"),
        (crop, None, "open crop: truth (x: border cells)"),
        (crop, RenderOptions(snr=10, nuclei=True), "membrane channel, SNR 10"),
        (crop, RenderOptions(snr=10, nuclei=True), "nuclear channel"),
    ]
    fig = Figure(figsize=(12, 7.2), dpi=100, layout="constrained")
    axes = fig.subplots(2, 3)
    for k, (ax, (truth, options, title)) in enumerate(zip(axes.ravel(), panels)):
        movie = truth.movie
        if options is None:
            plot_labels(labels=truth.labels[0], polygons=movie.polygons(0), cells=movie.table_at("cells", 0),
                        box=truth.box, ax=ax)
        else:
            image = Renderer(truth, options, seed=1).frame(0)[1 if title == "nuclear channel" else 0]
            plot_labels(image=image, ax=ax)
        ax.set_title(title, fontsize=10)
    save_figure(fig, args.out)
    print(args.out)


if __name__ == "__main__":
    main()
